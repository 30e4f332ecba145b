// passes_shim.c: where lavapipe's kernel compile spends its time, pass by pass.
//
// llvmpipe (Mesa 25) builds each kernel as an LLVM module, runs `LLVMRunPasses` on it twice (first
// "default<O0>", which holds the coroutine passes: a compute shader is always a coroutine there, then
// its optimisation passes "sroa,early-cse,...") and hands the result to MCJIT, which generates the machine
// code. Preloaded into vkpath, this wraps LLVMRunPasses: it prints each run's duration and pass string
// and, when SHIM_DIR is set, writes the module before (mN.bc) and after (mN.opt.bc) each run, so that
// LLVM's own tools can time every pass offline:
//
//   gcc -shared -fPIC -O2 -o /tmp/passes_shim.so benches/jit/passes_shim.c -L/usr/lib/llvm-15/lib -lLLVM-15
//   mkdir -p /tmp/dump && SHIM_DIR=/tmp/dump LD_PRELOAD=/tmp/passes_shim.so \
//       MESA_SHADER_CACHE_DIR=$(mktemp -d) target/release/vkpath render SCENE --width 32 --height 32 --spp 1
//   opt-15 -passes='default<O0>' -time-passes /tmp/dump/mK.bc -o /dev/null     # K: the largest module
//   llc-15 -O2 -mcpu=native -time-passes /tmp/dump/mK+1.opt.bc -filetype=obj -o /dev/null
//
// (apt-get install llvm-15 for opt-15, llc-15 and llvm-dis-15; the LLVM version must be the one lavapipe
// links, `vkpath info` names it.) docs/performance.md, "What the first sample waits for", has what it
// found.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef void *LLVMModuleRef;
typedef void *LLVMErrorRef;
typedef void *LLVMTargetMachineRef;
typedef void *LLVMPassBuilderOptionsRef;
extern int LLVMWriteBitcodeToFile(LLVMModuleRef module, const char *path);

static int runs = 0;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

LLVMErrorRef LLVMRunPasses(LLVMModuleRef module, const char *passes, LLVMTargetMachineRef tm,
                           LLVMPassBuilderOptionsRef options) {
    static LLVMErrorRef (*real)(LLVMModuleRef, const char *, LLVMTargetMachineRef, LLVMPassBuilderOptionsRef);
    if (!real) {
        real = dlsym(RTLD_NEXT, "LLVMRunPasses");
    }
    const char *dir = getenv("SHIM_DIR");
    char path[4096];
    if (dir) {
        snprintf(path, sizeof path, "%s/m%d.bc", dir, runs);
        LLVMWriteBitcodeToFile(module, path);
    }
    double start = now();
    LLVMErrorRef result = real(module, passes, tm, options);
    double seconds = now() - start;
    if (dir) {
        snprintf(path, sizeof path, "%s/m%d.opt.bc", dir, runs);
        LLVMWriteBitcodeToFile(module, path);
    }
    fprintf(stderr, "passes_shim: LLVMRunPasses #%d %.3f s: %s\n", runs, seconds, passes);
    runs++;
    return result;
}
