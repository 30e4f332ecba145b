#!/usr/bin/env python3
"""Where the CPU time goes inside the machine code lavapipe compiled for vkpath's kernel.

`perf` sees lavapipe's JIT code only as anonymous memory, so this script profiles a running render and
disassembles that memory itself:

1. starts `vkpath render SCENE ...` (long enough to outlast the profile), waits for the kernel to be
   compiled, and samples the process with `perf record -p` for a few seconds;
2. copies the process's executable anonymous mappings (the JIT code) with `gdb -batch ... dump memory`
   and disassembles them with `objdump -b binary`;
3. puts every sample on its instruction and sums them by kind of instruction.

The kinds are recognised from the shapes of code llvmpipe (Mesa 25) writes, so they are heuristics:
- "buffer load, per lane": a storage-buffer read whose index differs between lanes. Mesa's
  emit_load_mem (gallivm/lp_bld_nir_soa.c) reads such a word lane by lane: a branch on the lane's
  execution-mask bit, the buffer's size and base from its descriptor, a bounds compare and branch, a
  scalar load and an insert into the vector. Recognised by those instructions.
- "private array, per lane": the walk's stack (`var<private>` arrays) indexed per lane: scalar loads,
  and masked stores as a load, a cmov and a store, addressed off %rsp with an index register.
- "spill and reload": vector and mask registers moved to and from fixed %rsp offsets.
- "branch": jumps and mask tests that decide them.
- "vector arithmetic and the rest": everything else (the box and triangle tests, the shading). Mesa 26's
  llvmpipe reads such words with one gather instruction (vpgatherdd), which lands here.

Needs perf, gdb and objdump (`apt-get install linux-perf gdb binutils`) and permission to attach
(root, or kernel.yama.ptrace_scope = 0 and kernel.perf_event_paranoid <= 1).

    benches/jit_profile.py --binary target/release/vkpath --scene scenes/course.toml \
        [--wait 15] [--seconds 8] [--spp 4096] [--wrapper CMD] [--show KIND] [-- render arguments]
"""

import argparse
import bisect
import collections
import os
import re
import subprocess
import sys
import tempfile
import time

KINDS = [
    ("private array, per lane", [r"\(%rsp,%r\w+,\d\)"]),
    (
        "buffer load, per lane",
        [
            r"^(sar|movslq|cltq|kshiftrb)\b",
            r"^test\s+\$0x1,",
            r"^j(ae|b)\b",
            r"\(%r15\)",
            r"^mov\s+0x[0-9a-f]+\(%r\w+\),%[er]\w+$",
            r"^(vmovd|vpinsrd|vpbroadcastd|vmovq|vpinsrq)\s.*\(%r(?!sp)\w+(,%r\w+,4)?\)",
            r"^cmp\s+%e",
            r"^or\s+\$0x[0-9a-f],%e",
        ],
    ),
    ("spill and reload", [r"^(vmovaps|vmovups|vmovdqa|vmovdqa32|vmovdqa64|vmovdqu|kmovw|kmovb|kmovd)\s.*\(%rsp\)"]),
    ("branch", [r"^j\w+\b", r"^(kortestb|kortestw|ktestb)\b"]),
]


def kind_of(text):
    for name, patterns in KINDS:
        if any(re.search(p, text) for p in patterns):
            return name
    return "vector arithmetic and the rest"


def executable_anonymous_regions(pid):
    regions = []
    with open(f"/proc/{pid}/maps") as maps:
        for line in maps:
            fields = line.split()
            if len(fields) == 5 and "x" in fields[1]:  # no path: anonymous
                lo, hi = (int(x, 16) for x in fields[0].split("-"))
                regions.append((lo, hi))
    return regions


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default="target/release/vkpath")
    ap.add_argument("--scene", required=True)
    ap.add_argument("--wait", type=float, default=15.0, help="seconds to let the kernel compile")
    ap.add_argument("--seconds", type=float, default=8.0, help="seconds to sample")
    ap.add_argument("--spp", type=int, default=4096, help="samples per pixel of the 512x512 render "
                    "(enough to outlast --wait and --seconds)")
    ap.add_argument("--top", type=int, default=12, help="hottest 512-byte blocks to print")
    ap.add_argument("--wrapper", default="", help="a command the render runs under (e.g. a script that "
                    "points the Vulkan loader at another driver); it must exec the binary in its process")
    ap.add_argument("--show", metavar="KIND", help="print the hottest instructions of this kind")
    ap.add_argument("extra", nargs="*", help="more `vkpath render` arguments")
    args = ap.parse_args()

    work = tempfile.mkdtemp(prefix="jit-profile-")
    render = subprocess.Popen(
        [*args.wrapper.split(), args.binary, "render", args.scene, "--width", "512", "--height", "512",
         "--spp", str(args.spp), "--output", os.path.join(work, "out.exr"), *args.extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(args.wait)
        if render.poll() is not None:
            sys.exit("the render ended before the profile: raise --spp")
        data = os.path.join(work, "perf.data")
        subprocess.run(["perf", "record", "-q", "-p", str(render.pid), "-o", data, "--", "sleep",
                        str(args.seconds)], check=True, stderr=subprocess.DEVNULL)
        regions = executable_anonymous_regions(render.pid)
        dumps = []
        for i, (lo, hi) in enumerate(regions):
            path = os.path.join(work, f"code{i}.bin")
            subprocess.run(["gdb", "-p", str(render.pid), "-batch", "-ex",
                            f"dump binary memory {path} {lo:#x} {hi:#x}"],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            dumps.append((lo, path))
    finally:
        render.kill()
        render.wait()

    ips = []
    script = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], check=True,
                            capture_output=True, text=True).stdout
    for line in script.split():
        ips.append(int(line, 16))

    addresses, text = [], {}
    for lo, path in dumps:
        listing = subprocess.run(["objdump", "-D", "-b", "binary", "-m", "i386:x86-64",
                                  f"--adjust-vma={lo:#x}", path], check=True, capture_output=True,
                                 text=True).stdout
        with open(path + ".s", "w") as out:
            out.write(listing)
        for line in listing.splitlines():
            m = re.match(r"\s*([0-9a-f]+):\t[0-9a-f ]+\t(.*)", line)
            if m:
                a = int(m.group(1), 16)
                addresses.append(a)
                text[a] = m.group(2).strip()
    addresses.sort()
    in_jit = [ip for ip in ips if any(lo <= ip < hi for lo, hi in regions)]
    per_instruction = collections.Counter()
    for ip in in_jit:
        per_instruction[addresses[bisect.bisect_right(addresses, ip) - 1]] += 1

    total = len(ips)
    jit = sum(per_instruction.values())
    print(f"{args.scene}: {total} samples, {jit} ({100 * jit / max(total, 1):.1f} %) in the JIT code")
    kinds = collections.Counter()
    for a, n in per_instruction.items():
        kinds[kind_of(text[a])] += n
    print("\n| kind of instruction | share of the JIT code's samples |\n| --- | ---: |")
    for name, n in kinds.most_common():
        print(f"| {name} | {100 * n / max(jit, 1):.1f} % |")
    if args.show:
        hottest = sorted(((n, a) for a, n in per_instruction.items() if kind_of(text[a]) == args.show),
                         reverse=True)
        print(f"\nhottest instructions of kind {args.show!r}:")
        for n, a in hottest[:args.top]:
            print(f"  {a:#x}  {100 * n / max(jit, 1):5.2f} %  {text[a]}")
    blocks = collections.Counter()
    for a, n in per_instruction.items():
        blocks[a & ~511] += n
    print(f"\nhottest 512-byte blocks (of {len(blocks)}; the disassembly is in {work}):")
    for a, n in blocks.most_common(args.top):
        print(f"  {a:#x}  {100 * n / max(jit, 1):5.1f} %")


if __name__ == "__main__":
    main()
