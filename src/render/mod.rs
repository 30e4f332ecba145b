//! The progressive renderer: uploads a scene, dispatches passes of samples, reads back the film.
//!
//! Each pass traces samples `[start, start + k)` of every pixel, one dispatch per sample (one path per
//! invocation, see trace.wgsl), and adds them in index order to per-pixel Kahan sums on the GPU. Because a sample's random numbers depend only on (pixel,
//! sample index, dimension, seed), the image after N passes of k samples is bit-identical to one pass of
//! N k samples: pass sizes are free to adapt to time budgets and progress reports.

use crate::film::Film;
use crate::gpu::features::FeatureSet;
use crate::gpu::scene::{GpuScene, params_for};
use crate::gpu::shader::CompiledShader;
use crate::gpu::types::{GpuAccum, GpuParams, GpuPassConstants};
use crate::gpu::{Buffer, Command, GpuContext, GpuError, Kernel, shader};
use crate::scene::Scene;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The most samples (dispatches) recorded into one command buffer; a pass of more is several submits.
const MAX_DISPATCHES_PER_SUBMIT: u32 = 256;

/// Lavapipe (Mesa's llvmpipe) ends all loops of an invocation once it has run 65535 loop iterations in
/// total. A path's loops are bounded (bounces x (primitives + lights x primitives)), so the renderer
/// refuses, up front and with the limit named, a scene whose longest possible path would exceed this
/// on such a device, instead of rendering it silently wrong. (The BVH will make the per-ray count
/// logarithmic; real GPUs have no such limit.)
pub const LAVAPIPE_LOOP_BUDGET: u64 = 65_535;

/// An upper bound on the loop iterations one path can run in trace.wgsl: for each of max_bounces + 1
/// ray casts, the primitive loop of the closest hit, and for each light, one shadow query over the
/// primitives, plus the loop bookkeeping.
pub fn worst_case_loop_iterations(gpu: &GpuScene, max_bounces: u32) -> u64 {
    let prims = gpu.spheres.len() as u64 + gpu.triangles.len() as u64;
    let lights = gpu.lights.len() as u64;
    let per_cast = prims + lights * (prims + 1) + 1;
    (max_bounces as u64 + 1) * per_cast + 1
}

/// Renderer settings that are not part of the scene file.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Russian roulette starts after this many scattering events (`u32::MAX` disables it). Unbiased:
    /// a path survives with probability q = clamp(max(beta), 0.05, 0.95) and its weight is divided by q.
    pub roulette_depth: u32,
    /// Samples per pixel in each pass; `None` adapts the pass to about `target_pass_seconds`.
    pub samples_per_pass: Option<u32>,
    /// Target duration of one pass when adapting (keeps Ctrl-C, `--time` and progress responsive).
    pub target_pass_seconds: f64,
    /// Run the one all-features kernel instead of the one specialised for the scene (for comparison).
    pub generic: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            roulette_depth: 3,
            samples_per_pass: None,
            target_pass_seconds: 0.25,
            generic: false,
        }
    }
}

/// A scene uploaded to the device with its kernel and accumulator.
pub struct Renderer {
    ctx: Arc<GpuContext>,
    kernel: Kernel,
    params: GpuParams,
    accum: Buffer,
    readback: Buffer,
    pass_constants: Buffer,
    // Parameter and scene buffers: bound to the kernel, kept alive with it.
    _bound_buffers: Vec<Buffer>,
    samples_done: u32,
    features: FeatureSet,
}

/// The compiled kernel for a feature set, compiled once per process (naga's work; the driver's pipeline
/// compile happens per renderer).
pub fn kernel_for(features: &FeatureSet) -> Result<Arc<CompiledShader>, GpuError> {
    static CACHE: OnceLock<Mutex<HashMap<FeatureSet, Arc<CompiledShader>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    if let Some(hit) = cache
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .get(features)
    {
        return Ok(hit.clone());
    }
    let compiled = Arc::new(shader::compile_with(
        &shader::trace_source(),
        &features.pipeline_constants(),
    )?);
    cache
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(*features, compiled.clone());
    Ok(compiled)
}

impl Renderer {
    /// Compiles the kernel and uploads `scene`. The scene must have been validated (Scene::load does).
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &Scene,
        options: &RenderOptions,
    ) -> Result<Renderer, GpuError> {
        Renderer::build(ctx, scene, options, None)
    }

    /// A renderer running a kernel of the caller's (for benchmarks: e.g. a hand-trimmed kernel). It must
    /// use the bindings of `shaders/scene_data.wgsl`.
    pub fn with_kernel(
        ctx: &Arc<GpuContext>,
        scene: &Scene,
        options: &RenderOptions,
        kernel: Arc<CompiledShader>,
    ) -> Result<Renderer, GpuError> {
        Renderer::build(ctx, scene, options, Some(kernel))
    }

    fn build(
        ctx: &Arc<GpuContext>,
        scene: &Scene,
        options: &RenderOptions,
        custom_kernel: Option<Arc<CompiledShader>>,
    ) -> Result<Renderer, GpuError> {
        let gpu = GpuScene::build(scene);
        let device = &ctx.device_info().name;
        let iterations = worst_case_loop_iterations(&gpu, scene.render.max_bounces);
        if device.contains("llvmpipe") && iterations > LAVAPIPE_LOOP_BUDGET {
            let per_bounce = worst_case_loop_iterations(&gpu, 0);
            let max_ok = (LAVAPIPE_LOOP_BUDGET / per_bounce).saturating_sub(1);
            return Err(GpuError::Limit(format!(
                "this scene is too heavy for {device}: a path of up to {} bounces over {} primitives and {} \
                 lights could run {iterations} shader loop iterations, and lavapipe stops every loop of an \
                 invocation after {LAVAPIPE_LOOP_BUDGET}, which would cut paths short silently. Lower \
                 max_bounces to {max_ok} or less (Russian roulette keeps the result unbiased), use fewer \
                 primitives, or render on a GPU (VKPATH_DEVICE).",
                scene.render.max_bounces,
                gpu.spheres.len() + gpu.triangles.len(),
                gpu.lights.len()
            )));
        }
        let mut params = params_for(scene, options.roulette_depth);
        params.num_spheres = gpu.spheres.len() as u32;
        params.num_triangles = gpu.triangles.len() as u32;
        params.num_lights = gpu.lights.len() as u32;
        let features = if options.generic {
            FeatureSet::generic()
        } else {
            FeatureSet::of(&gpu, &params)
        };
        let compiled = match custom_kernel {
            Some(k) => k,
            None => kernel_for(&features)?,
        };
        let mut kernel = Kernel::new(ctx, &compiled)?;
        let params_buffer = Buffer::uniform_from(ctx, "params", &params)?;
        // Upload only the arrays the (specialised) kernel still reads: a scene without triangles has no
        // triangle buffer at all.
        let mut bound = vec![(0, params_buffer)];
        if kernel.uses_binding(1) {
            bound.push((1, Buffer::storage_from(ctx, "spheres", &gpu.spheres)?));
        }
        if kernel.uses_binding(2) {
            bound.push((2, Buffer::storage_from(ctx, "triangles", &gpu.triangles)?));
        }
        if kernel.uses_binding(3) {
            bound.push((3, Buffer::storage_from(ctx, "materials", &gpu.materials)?));
        }
        if kernel.uses_binding(4) {
            bound.push((4, Buffer::storage_from(ctx, "lights", &gpu.lights)?));
        }
        let pixels = scene.image.width as u64 * scene.image.height as u64;
        // Device-local: every sample reads and writes its pixel's sums. The host reads them through a
        // copy into a host-visible buffer when it wants the film.
        let accum_bytes = pixels * std::mem::size_of::<GpuAccum>() as u64;
        let accum = Buffer::new(
            ctx,
            "accumulator",
            accum_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let readback = Buffer::new(
            ctx,
            "film readback",
            accum_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let pass_constants = Buffer::new(
            ctx,
            "pass constants",
            std::mem::size_of::<GpuPassConstants>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let mut bindings: Vec<(u32, &Buffer)> = bound.iter().map(|(n, b)| (*n, b)).collect();
        bindings.push((5, &accum));
        bindings.push((6, &pass_constants));
        kernel.bind(&bindings)?;
        let mut r = Renderer {
            ctx: ctx.clone(),
            kernel,
            params,
            accum,
            readback,
            pass_constants,
            _bound_buffers: bound.into_iter().map(|(_, b)| b).collect(),
            samples_done: 0,
            features,
        };
        r.reset()?;
        Ok(r)
    }

    /// Clears the accumulator: the next pass starts again at sample 0.
    pub fn reset(&mut self) -> Result<(), GpuError> {
        self.kernel.submit(&[Command::Zero(&self.accum)])?;
        self.samples_done = 0;
        Ok(())
    }

    /// Traces `spp` more samples per pixel and waits for them.
    pub fn run_pass(&mut self, spp: u32) -> Result<(), GpuError> {
        if self.samples_done.checked_add(spp).is_none() {
            return Err(GpuError::Usage("more than 2^32 samples per pixel".into()));
        }
        let invocations = [self.params.width, self.params.height, 1];
        let mut left = spp;
        while left > 0 {
            let k = left.min(MAX_DISPATCHES_PER_SUBMIT);
            let constants: Vec<GpuPassConstants> = (0..k)
                .map(|i| GpuPassConstants {
                    sample_index: self.samples_done + i,
                    _pad: [0; 3],
                })
                .collect();
            let commands: Vec<Command> = constants
                .iter()
                .flat_map(|c| {
                    [
                        Command::Update(&self.pass_constants, bytemuck::bytes_of(c)),
                        Command::Dispatch {
                            invocations,
                        },
                    ]
                })
                .collect();
            self.kernel.submit(&commands)?;
            self.samples_done += k;
            left -= k;
        }
        Ok(())
    }

    /// The features the kernel was specialised for (all of them for the generic kernel).
    pub fn features(&self) -> &FeatureSet {
        &self.features
    }

    /// Samples per pixel accumulated so far.
    pub fn samples_done(&self) -> u32 {
        self.samples_done
    }

    /// The device context.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Reads the accumulator back as a film (means and variances, linear radiance).
    pub fn film(&mut self) -> Result<Film, GpuError> {
        self.kernel
            .submit(&[Command::Copy(&self.accum, &self.readback)])?;
        let bytes = self.readback.read_bytes()?;
        let accum: &[GpuAccum] = bytemuck::try_cast_slice(bytes)
            .map_err(|e| GpuError::Usage(format!("accumulator readback: {e}")))?;
        let pixels = self.params.width as usize * self.params.height as usize;
        Ok(Film::from_sums(
            self.params.width,
            self.params.height,
            self.samples_done,
            &accum[..pixels],
        ))
    }
}

/// When a progressive render stops.
#[derive(Clone, Debug)]
pub struct Budget {
    /// Upper bound on samples per pixel.
    pub spp: u32,
    /// Stop after the first pass that ends past this duration.
    pub time: Option<Duration>,
    /// Call `on_checkpoint` whenever the sample count reaches a multiple of this.
    pub checkpoint_every: Option<u32>,
}

/// Why a progressive render ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    Samples,
    Time,
    Interrupted,
}

/// What [`render_progressive`] reports after each pass.
#[derive(Clone, Copy, Debug)]
pub struct PassReport {
    pub samples_done: u32,
    pub elapsed: Duration,
    /// True when `samples_done` is a multiple of `checkpoint_every` (or the render is ending).
    pub checkpoint: bool,
}

/// Runs passes until the budget is spent or `stop` is set (Ctrl-C), adapting the pass size so that a
/// pass takes about `options.target_pass_seconds`. `on_pass` runs after every pass; an error from it
/// ends the render. Returns why it stopped and the time spent tracing.
pub fn render_progressive(
    renderer: &mut Renderer,
    options: &RenderOptions,
    budget: &Budget,
    stop: &AtomicBool,
    mut on_pass: impl FnMut(&mut Renderer, &PassReport) -> Result<(), crate::Error>,
) -> Result<(StopReason, Duration), crate::Error> {
    let start = Instant::now();
    let mut pass_spp = options.samples_per_pass.unwrap_or(1).max(1);
    let reason = loop {
        if stop.load(Ordering::SeqCst) {
            break StopReason::Interrupted;
        }
        let done = renderer.samples_done();
        if done >= budget.spp {
            break StopReason::Samples;
        }
        if let Some(t) = budget.time
            && done > 0
            && start.elapsed() >= t
        {
            break StopReason::Time;
        }
        let mut k = pass_spp.min(budget.spp - done);
        if let Some(every) = budget.checkpoint_every.filter(|&e| e > 0) {
            let next = (done / every + 1).saturating_mul(every);
            k = k.min(next - done);
        }
        let t0 = Instant::now();
        renderer.run_pass(k)?;
        let dt = t0.elapsed().as_secs_f64();
        let done = renderer.samples_done();
        let checkpoint = budget
            .checkpoint_every
            .is_some_and(|e| e > 0 && done.is_multiple_of(e));
        on_pass(
            renderer,
            &PassReport {
                samples_done: done,
                elapsed: start.elapsed(),
                checkpoint,
            },
        )?;
        if options.samples_per_pass.is_none() && k == pass_spp {
            // Grow (at most doubling) or shrink the pass towards the target duration.
            let per_sample = dt / k as f64;
            let ideal = (options.target_pass_seconds / per_sample.max(1e-9)).floor();
            pass_spp = (ideal as u32).clamp(1, pass_spp.saturating_mul(2));
        }
    };
    Ok((reason, start.elapsed()))
}
