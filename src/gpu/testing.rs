//! Shader unit tests via readback: run a small WGSL test kernel that calls the shader library over an
//! input buffer, and get its output buffer back as Pod values.
//!
//! Lavapipe ends an invocation's loops after 65535 iterations in total (see trace.wgsl): a test that needs
//! more work per element carries its state across several runs of a [`TestKernel`].
//!
//! A test kernel is WGSL assembled with the library files it declares in its `// requires:` line (the same
//! files the renderer uses, see [`crate::kernel::library`]). It declares its input at binding 0 and its
//! output at binding 1 (any names), and an entry point `main` with one invocation per output element:
//!
//! ```wgsl
//! // requires: bsdf.wgsl
//! @group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
//! @group(0) @binding(1) var<storage, read_write> output: array<f32>;
//! @compute @workgroup_size(64)
//! fn main(@builtin(global_invocation_id) id: vec3<u32>) {
//!     if id.x >= arrayLength(&output) { return; }
//!     output[id.x] = fresnel_dielectric(input[id.x].x, input[id.x].y);
//! }
//! ```
//!
//! ```no_run
//! # use vkpath::gpu::testing;
//! let input = vec![[1.0f32, 1.5, 0.0, 0.0]];
//! let out: Vec<f32> = testing::run_kernel(&testing::context(), "/* the WGSL above */", &input, 1)?;
//! # Ok::<(), vkpath::gpu::GpuError>(())
//! ```

use super::{Buffer, Command, ContextOptions, GpuContext, GpuError, Kernel};
use crate::kernel::{library, specialise};
use std::sync::{Arc, Mutex, OnceLock};

/// A process-wide context for tests, with the Khronos validation layer on when it is installed
/// (`VKPATH_VALIDATION=0` turns it off). Panics with the setup message if no device exists: tests need one.
pub fn context() -> Arc<GpuContext> {
    static CTX: OnceLock<Arc<GpuContext>> = OnceLock::new();
    CTX.get_or_init(|| {
        let want = std::env::var("VKPATH_VALIDATION")
            .map(|v| v != "0")
            .unwrap_or(true);
        let options = ContextOptions {
            validation: want,
            ..Default::default()
        };
        GpuContext::new(&options)
            .unwrap_or_else(|e| panic!("vkpath tests need a Vulkan device: {e}"))
    })
    .clone()
}

/// A test kernel compiled once and run as often as needed (e.g. to carry state across dispatches).
pub struct TestKernel {
    ctx: Arc<GpuContext>,
    kernel: Kernel,
    /// The names of bindings 0 (input) and 1 (output).
    input: String,
    output: String,
}

impl TestKernel {
    /// Compiles `kernel_source` with the library files it requires.
    pub fn new(ctx: &Arc<GpuContext>, kernel_source: &str) -> Result<TestKernel, GpuError> {
        let source = library::assemble_text("test kernel", kernel_source)
            .map_err(|e| GpuError::Shader(e.to_string()))?;
        let compiled = specialise::compile(&source)?;
        let name_of = |binding: u32| {
            compiled
                .bindings
                .iter()
                .find(|b| b.binding == binding)
                .map(|b| b.name.clone())
                .ok_or_else(|| GpuError::Usage(format!("the test kernel has no binding {binding}")))
        };
        Ok(TestKernel {
            ctx: ctx.clone(),
            input: name_of(0)?,
            output: name_of(1)?,
            kernel: Kernel::new(ctx, &compiled)?,
        })
    }

    /// Runs one invocation per output element over `input` and returns the `output_len` outputs.
    pub fn run<I: bytemuck::Pod, O: bytemuck::Pod>(
        &mut self,
        input: &[I],
        output_len: usize,
    ) -> Result<Vec<O>, GpuError> {
        self.run_with(input, output_len, &[])
    }

    /// As [`TestKernel::run`], with more read-only storage buffers bound by their WGSL names: the
    /// library's own buffers that the code under test reads (`light_triangles`, `env_cdf`, ...).
    pub fn run_with<I: bytemuck::Pod, O: bytemuck::Pod>(
        &mut self,
        input: &[I],
        output_len: usize,
        extra: &[(&str, &[u8])],
    ) -> Result<Vec<O>, GpuError> {
        let ctx = &self.ctx;
        let input_buffer = Buffer::storage_from(ctx, "test input", input)?;
        let out_bytes = (output_len * std::mem::size_of::<O>()) as u64;
        let output = Buffer::readable_storage(ctx, "test output", out_bytes)?;
        let extra_buffers = extra
            .iter()
            .map(|(name, bytes)| Ok((*name, Buffer::storage_from(ctx, name, bytes)?)))
            .collect::<Result<Vec<_>, GpuError>>()?;
        // The library's buffers the kernel reads but the test gives no data for (the emissive
        // triangles of a light dispatcher that a test of point lights never reaches) are bound empty.
        let empty = Buffer::storage_from::<u32>(ctx, "unused", &[0; 4])?;
        let mut bindings: Vec<(&str, &Buffer)> =
            vec![(&self.input, &input_buffer), (&self.output, &output)];
        bindings.extend(extra_buffers.iter().map(|(n, b)| (*n, b)));
        let given: Vec<String> = bindings.iter().map(|(n, _)| n.to_string()).collect();
        let unbound: Vec<String> = self
            .kernel
            .bindings()
            .iter()
            .map(|b| b.name.clone())
            .filter(|n| !given.contains(n))
            .collect();
        bindings.extend(unbound.iter().map(|n| (n.as_str(), &empty)));
        self.kernel.bind(&bindings)?;
        self.kernel.submit(&[Command::Dispatch {
            invocations: [output_len as u32, 1, 1],
        }])?;
        let bytes = &output.read_bytes()?[..out_bytes as usize];
        Ok(bytemuck::pod_collect_to_vec(bytes))
    }
}

/// Compiles `kernel_source` after the shader library, runs one invocation per output element over
/// `input`, and returns the `output_len` elements of the output buffer.
///
/// Compiled kernels are kept for the process and reused (keyed by the context and the source): naga and
/// the driver's compiler take about as long as a dispatch of 2^18 BSDF samples on lavapipe, and the
/// statistical tests call this hundreds of times with the same kernel. A kernel serves one call at a
/// time; tests that run at once on other threads compile their own copy, which then joins the pool.
pub fn run_kernel<I: bytemuck::Pod, O: bytemuck::Pod>(
    ctx: &Arc<GpuContext>,
    kernel_source: &str,
    input: &[I],
    output_len: usize,
) -> Result<Vec<O>, GpuError> {
    type Pool = Vec<((usize, String), TestKernel)>;
    static POOL: Mutex<Pool> = Mutex::new(Vec::new());
    let key = (Arc::as_ptr(ctx) as usize, kernel_source.to_string());
    let idle = {
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let at = pool.iter().position(|(k, _)| *k == key);
        at.map(|i| pool.swap_remove(i).1)
    };
    let mut kernel = match idle {
        Some(k) => k,
        None => TestKernel::new(ctx, kernel_source)?,
    };
    let out = kernel.run(input, output_len);
    POOL.lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((key, kernel));
    out
}
