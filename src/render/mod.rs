//! The progressive renderer: uploads a scene, dispatches passes of samples, reads back the film.
//!
//! Each pass traces samples `[start, start + k)` of every pixel, in dispatches over tiles of the image in
//! which each invocation traces consecutive samples of its pixel for at most [`casts_per_dispatch`] ray
//! casts (path regeneration and continuation, trace.wgsl), then dispatches over the queue of paths still
//! going until none is left, and adds them to per-pixel sums on the GPU: exact sums of the samples
//! (long accumulators, accumulate.wgsl) and Kahan sums of their squares, in sample index order. Because a
//! sample's random numbers depend only on (pixel, sample index, dimension, seed), the image after N passes
//! of k samples is bit-identical to one pass of N k samples: pass sizes are free to adapt to time budgets
//! and progress reports.

pub mod adaptive;
pub mod host_use;
pub mod identity;
pub mod splat;
pub mod tiles;

use crate::film::Film;
use crate::gpu::{
    Buffer, Command, DataImage, GpuContext, GpuError, Kernel, upload_device_local,
    upload_uniform_padded,
};
use crate::kernel::abi::{
    GpuAccum, GpuParams, GpuPassConstants, GpuSplatAccum, PATH_STATE_BYTES, SAMPLE_FAULT_COUNTERS,
    SPLIT_ARRAYS, UNIFORM_ARRAY_BYTES, UNIFORM_ARRAYS, split_array,
};
use crate::kernel::features::{Feature, FeatureSet};
use crate::kernel::specialise::CompiledShader;
use crate::kernel::upload::{GpuScene, SceneStats, params_for};
use crate::kernel::{library, specialise};
use crate::scene::Scene;
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Pixels per dispatch before the renderer has timed one, at the default dispatch target (0.1 s; in
/// proportion for another): small, so that the very first dispatch is bounded in time too (4096 paths of
/// at most [`MAX_CASTS_PER_DISPATCH`] casts: well under a desktop watchdog's two seconds even on
/// lavapipe). The tiles then grow, at most [`TILE_GROWTH`] times per pass, towards
/// [`RenderOptions::target_dispatch_seconds`].
const INITIAL_TILE_PIXELS: f64 = 4096.0;

/// The most the tile may grow from one pass to the next (a slow start, as TCP's): a dispatch is never
/// more than this many times the largest one timed so far.
const TILE_GROWTH: f64 = 4.0;

/// Lavapipe (Mesa's llvmpipe) ends all loops of an invocation once it has run 65535 loop iterations in
/// total. One ray cast's loops are bounded (primitives + lights x primitives, a BVH walk at most
/// `bvh::MAX_STEPS`), and an invocation makes at most [`casts_per_dispatch`] casts before its path is
/// saved for the next dispatch, so a path of any length fits; the renderer refuses, up front and with
/// the limit named, only a scene of which a single cast could exceed it (thousands of lights), instead
/// of rendering it silently wrong. Real GPUs have no such limit.
pub const LAVAPIPE_LOOP_BUDGET: u64 = 65_535;

/// The most ray casts one invocation makes per dispatch where no loop budget applies. Past a few
/// hundred the dispatches saved no longer show, and the casts bound a dispatch's duration with its tile.
pub const MAX_CASTS_PER_DISPATCH: u32 = 256;

/// The most paths in flight at once: the path state (`PATH_STATE_BYTES` each) and queue buffers hold
/// this many, 100 MiB in all, and a tile has at most this many pixels.
pub const MAX_PATHS_IN_FLIGHT: u64 = 1 << 20;

/// An upper bound on the loop iterations one path can run in trace.wgsl: for each of max_bounces + 1
/// ray casts, one scene query for the closest hit, and for each light, one shadow query, plus the loop
/// bookkeeping. A query loops over the spheres (or walks their BVH, when there are many), then walks the
/// triangle BVH (shaders/bvh.wgsl).
///
/// One BVH walk runs at most `bvh::MAX_STEPS` iterations (2048), whatever the number of triangles: that
/// cap is what lets a 10^6-triangle mesh fit lavapipe's budget, and it is far above what a ray needs in
/// a SAH tree (about 2 log2(N) nodes and a few leaves; `tests/shader_bvh.rs` measures it). A small tree needs
/// fewer: a walk visits each interior node at most once, tests each triangle at most once, skips at most
/// three stacked entries per interior node (the tree is 4 wide) and ends with one more iteration, so it
/// runs at most 4 nodes + triangles + 1 iterations. With the course's settings (5 bounces, one light) a mesh of any
/// size costs at most 12 walks, 24,576 iterations.
pub fn worst_case_loop_iterations(gpu: &GpuScene, max_bounces: u32) -> u64 {
    let triangles = gpu.triangles.len() as u64;
    let walk = if triangles == 0 {
        0
    } else if gpu.instances.is_empty() {
        walk_iterations(gpu.bvh_nodes.len(), gpu.triangles.len())
    } else {
        // Through every placement's tree, as if the placements were copies (add_instanced).
        gpu.instanced_walk
            .min(u64::from(crate::scene::bvh::MAX_STEPS))
    };
    // The spheres: every one in a loop, or a walk of their own tree, bounded the same way.
    let spheres = if gpu.sphere_nodes.is_empty() {
        gpu.spheres.len() as u64
    } else {
        walk_iterations(gpu.sphere_nodes.len(), gpu.spheres.len())
    };
    let per_query = spheres + walk;
    let lights = gpu.lights.len() as u64;
    // Per cast: the closest hit, a shadow query per light, and (with mis) a look-up of the light a hit
    // emitter belongs to.
    let per_cast = per_query + lights * (per_query + 2) + 1;
    (max_bounces as u64 + 1) * per_cast + 1
}

/// The most iterations one walk of a BVH (bvh.wgsl, bvh_walk) runs over a tree of `nodes` interior nodes
/// and `primitives` leaf primitives: each iteration visits a node, tests a primitive or pops an entry
/// (at most WIDTH - 1 pushed per node), plus the last that ends the walk; and never more than the walk's
/// own cap, `bvh::MAX_STEPS`.
fn walk_iterations(nodes: usize, primitives: usize) -> u64 {
    use crate::scene::bvh::{MAX_STEPS, WIDTH};
    (WIDTH as u64 * nodes as u64 + primitives as u64 + 1).min(u64::from(MAX_STEPS))
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
    /// Target duration of one dispatch (one sample over one tile): the tiles adapt so that a dispatch
    /// takes about this long, well under the second or two after which a desktop GPU's watchdog resets
    /// the device. The image does not depend on it.
    pub target_dispatch_seconds: f64,
    /// A fixed largest tile (width, height) in pixels instead of adaptive tiles: the image is then cut
    /// into strips of at most that many rows (one accumulator each) and tiles of that size. The image
    /// does not depend on it (`--tile`; tests use it to tile small images).
    pub max_tile: Option<[u32; 2]>,
    /// A fault to inject, for testing what the caller does when the device fails (`VKPATH_FAULT`).
    pub fault: Option<Fault>,
    /// What the samples are: radiance ([`AOV_NONE`](crate::kernel::abi::AOV_NONE)), or an `AOV_*`
    /// layer (`--aov`: albedo, normal or depth, averaged over the pixel's samples like radiance).
    pub aov: u32,
    /// The most ray casts one kernel invocation makes in a dispatch before its path is saved for the
    /// next (trace.wgsl, `main`); `None` lets the renderer choose ([`casts_per_dispatch`]). The image
    /// does not depend on it (tests/tiling.rs).
    pub casts_per_dispatch: Option<u32>,
    /// Bytes per pixel the caller will hold on the host besides the renderer's buffers (its film, the
    /// images it writes, checkpoints: [`host_use::HostUse`]); the renderer refuses, before
    /// allocating, a render whose host memory would exceed what the machine has available.
    pub host_bytes_per_pixel: u64,
    /// Adaptive sampling (`render.adaptive`, [`adaptive`]): pixels stop once their error is below the
    /// threshold; `None` samples every pixel equally.
    pub adaptive: Option<adaptive::AdaptiveSettings>,
}

/// Faults the renderer can be told to simulate, so that the handling of each (messages, exit codes,
/// files left intact) can be tested on any device. The CLI reads them from `VKPATH_FAULT`:
/// `device-lost@N`, `out-of-memory`, `shader`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The device is lost during pass `N` (1-based), after part of the pass was submitted.
    DeviceLostAtPass(u32),
    /// Allocating the accumulator fails with VK_ERROR_OUT_OF_DEVICE_MEMORY.
    OutOfMemory,
    /// The kernel fails to compile.
    Shader,
    /// The kernel takes two minutes to compile (as `--generic` may on a cold cache): for the test that
    /// a stop request during the compile ends the program at once.
    SlowCompile,
}

impl Fault {
    /// Parses `VKPATH_FAULT`'s value.
    pub fn parse(text: &str) -> Option<Fault> {
        match text.trim() {
            "out-of-memory" => Some(Fault::OutOfMemory),
            "shader" => Some(Fault::Shader),
            "slow-compile" => Some(Fault::SlowCompile),
            t => t
                .strip_prefix("device-lost@")
                .and_then(|n| n.parse().ok())
                .filter(|&n| n > 0)
                .map(Fault::DeviceLostAtPass),
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            roulette_depth: 3,
            samples_per_pass: None,
            target_pass_seconds: 0.25,
            generic: false,
            target_dispatch_seconds: 0.1,
            max_tile: None,
            fault: None,
            aov: crate::kernel::abi::AOV_NONE,
            casts_per_dispatch: None,
            host_bytes_per_pixel: host_use::FILM_BYTES_PER_PIXEL,
            adaptive: None,
        }
    }
}

/// How many ray casts one invocation makes per dispatch (trace.wgsl, `main`): on lavapipe, as many as
/// fit its loop budget, a cast running at most `worst_case_loop_iterations(gpu, 0)` iterations plus one
/// of the invocation's own loop ([`LAVAPIPE_LOOP_BUDGET`]); elsewhere [`MAX_CASTS_PER_DISPATCH`]. At
/// least 1 (a scene whose single cast exceeds the budget is refused before this is asked).
pub fn casts_per_dispatch(device_name: &str, gpu: &GpuScene) -> u32 {
    let mut m = MAX_CASTS_PER_DISPATCH;
    if device_name.contains("llvmpipe") {
        let per_cast = worst_case_loop_iterations(gpu, 0) + 1;
        m = m.min((LAVAPIPE_LOOP_BUDGET / per_cast) as u32);
    }
    m.max(1)
}

/// One strip of whole rows of the image and its accumulator (see [`tiles`]).
struct Strip {
    rows: [u32; 2],
    buffer: Buffer,
}

/// A scene uploaded to the device with its kernel and accumulator.
pub struct Renderer {
    ctx: Arc<GpuContext>,
    kernel: Kernel,
    params: GpuParams,
    /// The accumulator, one buffer per strip of rows (one strip unless the image is large).
    strips: Vec<Strip>,
    /// Which strip's accumulator is bound (`accum`).
    bound_strip: usize,
    layout: tiles::TileLayout,
    /// The current budget of pixels per dispatch (adapted to `target_dispatch_seconds`).
    tile_pixels: u64,
    /// The most ray casts one invocation makes per dispatch ([`casts_per_dispatch`]).
    casts_per_dispatch: u32,
    /// Samples of a pixel one dispatch begins: the whole pass, except for a caller's kernel (1).
    samples_per_dispatch: u32,
    /// Paths in flight at most: the capacity of `path_state` and of each half of `path_queue`.
    path_slots: u64,
    /// `path_count` (trace.wgsl): how many paths the last dispatch left for the next; host-visible.
    path_count: Buffer,
    target_dispatch_seconds: f64,
    /// Host-visible, as large as the largest strip: film readback and checkpoint restore go through it.
    staging: Buffer,
    pass_constants: Buffer,
    // Parameter and scene buffers with their WGSL names: bound to the kernel, kept alive with it.
    bound: Vec<(&'static str, Buffer)>,
    /// The data images the kernel reads (`Feature::DataImages`).
    images: Vec<(&'static str, DataImage)>,
    /// `sample_faults` (scene_data.wgsl): samples clamped and dropped by the accumulator since the
    /// last reset, counted on the device.
    sample_faults: Buffer,
    /// Set when a pass failed part-way: the accumulator then holds an unknown part of it, and reading
    /// it (a film, a checkpoint) or adding to it is refused.
    poisoned: Option<String>,
    /// Whether the kernel has been dispatched once ([`Renderer::warm_up`]).
    warmed_up: bool,
    fault: Option<Fault>,
    /// Passes run (for [`Fault::DeviceLostAtPass`]).
    passes: u32,
    /// Triangles, BVH size and build time, scene bytes (`--json`).
    scene_stats: SceneStats,
    /// The sample index the next dispatch traces.
    next_sample: u32,
    /// Samples per pixel in the accumulator.
    samples_done: u32,
    /// The sample indices in the accumulator: sorted disjoint `[start, end)` ranges (see src/checkpoint/mod.rs).
    ranges: Vec<[u32; 2]>,
    features: FeatureSet,
    /// [`identity::content_hash`] of the scene as uploaded.
    content_hash: u64,
    /// A splatted render's gather and sums (`render.splat`); `None` for per-pixel sums alone.
    splat: Option<splat::Splat>,
    /// Adaptive sampling's counts and list of pixels still sampling (`render.adaptive`).
    adaptive: Option<adaptive::Adaptive>,
}

/// The kernels compiled in this process, by feature set (see [`kernel_for`]).
static KERNELS: OnceLock<Mutex<HashMap<FeatureSet, Arc<CompiledShader>>>> = OnceLock::new();

/// How many kernels this process has compiled: one per feature set rendered (the Python module's tests
/// hold an edit that changes only values to compiling none).
pub fn kernels_compiled() -> usize {
    KERNELS
        .get()
        .map_or(0, |c| c.lock().unwrap_or_else(|p| p.into_inner()).len())
}

/// The compiled kernel for a feature set, compiled once per process (naga's work; the driver's pipeline
/// compile happens per renderer).
pub fn kernel_for(features: &FeatureSet) -> Result<Arc<CompiledShader>, GpuError> {
    let cache = KERNELS.get_or_init(Default::default);
    if let Some(hit) = cache
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .get(features)
    {
        return Ok(hit.clone());
    }
    let compiled = Arc::new(specialise::compile_with(
        &library::trace_source(),
        &features.pipeline_constants(),
    )?);
    cache
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(*features, compiled.clone());
    Ok(compiled)
}

/// Samples that did not enter the accumulator as they were (accumulate.wgsl), counted over the samples
/// traced since the renderer was reset: `clamped` had a channel at or above 2^64 (about 1.8e19) and went
/// in clamped just below it; `not_finite` were NaN or infinite and went in as black. Both are zero in
/// any sane scene; the CLI reports them on stderr and in `--json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SampleFaults {
    pub clamped: u32,
    pub not_finite: u32,
    /// Paths ended by the bounce cap (`abi::BOUNCE_CAP`) rather than by the scene's own limit or by
    /// Russian roulette: zero unless roulette is off in a scene without a bounce limit (or with more
    /// bounces than the cap).
    pub bounce_capped: u32,
}

/// Refuses, on lavapipe, a scene of which one ray cast could run more loop iterations than lavapipe
/// allows one invocation (see [`LAVAPIPE_LOOP_BUDGET`]): with next-event estimation towards every light,
/// thousands of lights over many spheres. Paths of any length are fine (trace.wgsl carries them across
/// dispatches).
///
/// On any device, refuses a scene with instances whose trees together could need more traversal-stack
/// entries than the walk has (`GpuScene::stack_need`; each tree alone always fits: `Bvh::wide`).
fn check_loop_budget(ctx: &GpuContext, gpu: &GpuScene) -> Result<(), GpuError> {
    check_instance_limits(gpu)?;
    let device = &ctx.device_info().name;
    let iterations = worst_case_loop_iterations(gpu, 0) + 1;
    if device.contains("llvmpipe") && iterations > LAVAPIPE_LOOP_BUDGET {
        return Err(GpuError::Limit(format!(
            "this scene is too heavy for {device}: one ray cast over {} primitives and {} lights could run \
             {iterations} shader loop iterations, and lavapipe stops every loop of an invocation after \
             {LAVAPIPE_LOOP_BUDGET}, which would cut paths short silently. Use fewer lights or spheres, \
             or render on a GPU (VKPATH_DEVICE).",
            gpu.spheres.len() + gpu.triangles.len(),
            gpu.lights.len(),
        )));
    }
    Ok(())
}

/// The limits of the two-level BVH (any device): placement and triangle indices below bit 28 of a
/// leaf reference, and the walk's stack for the trees together.
fn check_instance_limits(gpu: &GpuScene) -> Result<(), GpuError> {
    instance_limits(gpu.triangles.len(), gpu.instances.len(), gpu.stack_need)
}

/// [`check_instance_limits`] on the counts: `instances` placements (0: a scene without instances),
/// `triangles` triangles uploaded, a walk needing `stack_need` stack entries.
fn instance_limits(triangles: usize, instances: usize, stack_need: usize) -> Result<(), GpuError> {
    use crate::scene::bvh::STACK_SIZE;
    // (With instances, a leaf reference holds a placement's or a triangle's index shifted by
    // bvh::LEAF_COUNT_BITS below bit 30, bvh::INSTANCE: indices below 2^28. Without, bit 30 is free.)
    let limit = 1usize << (30 - crate::scene::bvh::LEAF_COUNT_BITS);
    if instances > 0 && (triangles >= limit || instances >= limit) {
        return Err(GpuError::Limit(format!(
            "this scene has {triangles} triangles and {instances} placements of instanced meshes; with \
             instances the BVH holds at most {} of each. Use fewer or smaller meshes.",
            limit - 1
        )));
    }
    if stack_need > STACK_SIZE {
        return Err(GpuError::Limit(format!(
            "this scene's instances make a BVH walk need {stack_need} stack entries, and the kernel's walk \
             has {STACK_SIZE}: the tree over the {instances} placements and the deepest instanced mesh's \
             tree are too deep together. Use fewer placements, or meshes of fewer triangles."
        )));
    }
    Ok(())
}

/// The kernel's parameters for `scene` as uploaded: the scene's settings and the array sizes.
fn render_params(scene: &Scene, gpu: &GpuScene, options: &RenderOptions) -> GpuParams {
    let mut params = params_for(scene, options.roulette_depth);
    params.num_spheres = gpu.spheres.len() as u32;
    params.num_triangles = gpu.triangles.len() as u32;
    params.num_lights = gpu.lights.len() as u32;
    params.environment_light = gpu.environment_light;
    params.triangle_light = gpu.triangle_light;
    params.aov = options.aov;
    if options.aov != crate::kernel::abi::AOV_NONE {
        // The firefly clamp is for radiance: it would scale normals and distances. A layer is each
        // pixel's own (the denoiser's guides), never splatted.
        params.sample_clamp = 0.0;
        params.splat = 0;
    }
    params
}

/// The compiled kernel for `features` (from the process-wide cache), or the injected shader fault.
fn compile_kernel(
    features: &FeatureSet,
    fault: Option<Fault>,
) -> Result<Arc<CompiledShader>, GpuError> {
    if fault == Some(Fault::Shader) {
        return Err(GpuError::Shader(
            "error: injected fault (VKPATH_FAULT=shader)".into(),
        ));
    }
    if fault == Some(Fault::SlowCompile) {
        std::thread::sleep(Duration::from_secs(120));
    }
    kernel_for(features)
}

/// Whether the kernel reads a small scene's arrays from their uniform twins on this device
/// (`kernel::abi::UniformArray` says why): on a CPU driver whose uniform buffers hold a twin, but not
/// on lavapipe from Mesa 26 on, whose llvmpipe reads a storage word at a lane-varying index with one
/// gather instruction: there the twins measured 0.98-1.02x (docs/performance.md).
pub fn uniform_arrays_help(info: &crate::gpu::DeviceInfo) -> bool {
    info.device_type == "CPU"
        && info.max_uniform_buffer_range as usize >= UNIFORM_ARRAY_BYTES
        && info.lavapipe_mesa.is_none_or(|[major, _]| major < 26)
}

/// Whether the kernel should read its large arrays ([`DATA_IMAGE_ARRAYS`]) from data images
/// (`gpu::image` says why): on Mesa's lavapipe before 26, whose llvmpipe compiles every storage read at a
/// lane-varying index into branches per lane (Mesa 26 gathers them). Other devices keep the storage
/// buffers until a measurement there says otherwise.
pub fn data_images_help(info: &crate::gpu::DeviceInfo) -> bool {
    info.lavapipe_mesa.is_some_and(|[major, _]| major < 26)
}

/// The arrays a kernel with `Feature::DataImages` reads from data images: (array name, image binding's
/// WGSL name, bytes of one element).
pub const DATA_IMAGE_ARRAYS: [(&str, &str, usize); 5] = [
    (
        "bvh_nodes",
        "bvh_nodes_image",
        std::mem::size_of::<crate::kernel::abi::GpuBvhNode>(),
    ),
    (
        "triangles",
        "triangles_image",
        std::mem::size_of::<crate::kernel::abi::GpuTriangle>(),
    ),
    (
        "mesh_faces",
        "mesh_faces_image",
        std::mem::size_of::<crate::kernel::abi::GpuMeshFace>(),
    ),
    (
        "mesh_vertices",
        "mesh_vertices_image",
        std::mem::size_of::<crate::kernel::abi::GpuMeshVertex>(),
    ),
    ("texels", "texels_image", 4),
];

/// Pixels converted per copy out of the mapped staging buffer (which need not be aligned for the
/// entries): 4096, 384 KiB of `GpuAccum`s.
const STRIP_CHUNK: usize = 4096;

/// One device-local buffer of `bytes_per_pixel` per pixel for each strip of rows of `layout`: the
/// accumulator's, and a splatted render's splatted sums.
fn strip_buffers(
    ctx: &Arc<GpuContext>,
    layout: &tiles::TileLayout,
    name: &str,
    bytes_per_pixel: u64,
) -> Result<Vec<Buffer>, GpuError> {
    (0..layout.strips.len())
        .map(|i| Buffer::device_storage(ctx, name, layout.strip_pixels(i) * bytes_per_pixel))
        .collect()
}

/// One device-local accumulator buffer per strip of rows of `layout`.
fn allocate_strips(
    ctx: &Arc<GpuContext>,
    layout: &tiles::TileLayout,
) -> Result<Vec<Strip>, GpuError> {
    let buffers = strip_buffers(ctx, layout, "accumulator", tiles::ACCUM_BYTES_PER_PIXEL)?;
    Ok(buffers
        .into_iter()
        .zip(&layout.strips)
        .map(|(buffer, rows)| Strip {
            rows: *rows,
            buffer,
        })
        .collect())
}

/// Calls `f` on the entries of `buffers` (one buffer per strip of `layout`, one `T` per pixel, row-major
/// from the top), each strip copied to `staging` and read back [`STRIP_CHUNK`] pixels at a time.
fn read_strips<'a, T: bytemuck::Pod>(
    kernel: &mut Kernel,
    staging: &Buffer,
    layout: &tiles::TileLayout,
    buffers: impl Iterator<Item = &'a Buffer>,
    mut f: impl FnMut(&[T]),
) -> Result<(), GpuError> {
    let size = std::mem::size_of::<T>();
    for (buffer, rows) in buffers.zip(&layout.strips) {
        kernel.submit(&[Command::Copy(buffer, staging)])?;
        let n = (rows[1] - rows[0]) as usize * layout.width as usize;
        let bytes = staging
            .read_bytes()?
            .get(..n * size)
            .ok_or_else(|| GpuError::Usage("accumulator staging is too small".into()))?;
        for chunk in bytes.chunks(STRIP_CHUNK * size) {
            f(&bytemuck::pod_collect_to_vec::<u8, T>(chunk));
        }
    }
    Ok(())
}

/// Puts `data` (one `T` per pixel, row-major from the top) into `buffers` (one per strip of `layout`)
/// through `staging`.
fn write_strips<'a, T: bytemuck::Pod>(
    kernel: &mut Kernel,
    staging: &mut Buffer,
    layout: &tiles::TileLayout,
    buffers: impl Iterator<Item = &'a Buffer>,
    data: &[T],
) -> Result<(), GpuError> {
    let width = layout.width as usize;
    for (buffer, rows) in buffers.zip(&layout.strips) {
        let (a, b) = (rows[0] as usize * width, rows[1] as usize * width);
        staging.write(bytemuck::cast_slice(&data[a..b]))?;
        kernel.submit(&[Command::Copy(staging, buffer)])?;
    }
    Ok(())
}

/// The scene's resources as the kernel reads them, each under its WGSL name.
pub struct UploadedScene {
    pub buffers: Vec<(&'static str, Buffer)>,
    /// The data images (`Feature::DataImages`).
    pub images: Vec<(&'static str, DataImage)>,
}

/// Uploads the arrays the (specialised) kernel still reads, each under its WGSL name: a scene without
/// triangles has no triangle buffer at all. The big mesh arrays (64 bytes per BVH node, 48 per
/// triangle) live in device-local memory, uploaded through a staging copy.
pub fn upload_scene(
    ctx: &Arc<GpuContext>,
    kernel: &mut Kernel,
    gpu: &GpuScene,
    params: &GpuParams,
) -> Result<UploadedScene, GpuError> {
    let mut bound = vec![("params", Buffer::uniform_from(ctx, "params", params)?)];
    let mut images = Vec::new();
    let small = |name: &'static str, bytes: &[u8]| -> Result<(&'static str, Buffer), GpuError> {
        Ok((name, Buffer::storage_from(ctx, name, bytes)?))
    };
    if kernel.uses("spheres") {
        bound.push(small("spheres", bytemuck::cast_slice(&gpu.spheres))?);
    }
    if kernel.uses("sphere_nodes") {
        bound.push(small(
            "sphere_nodes",
            bytemuck::cast_slice(&gpu.sphere_nodes),
        )?);
    }
    if kernel.uses("materials") {
        bound.push(small("materials", bytemuck::cast_slice(&gpu.materials))?);
    }
    if kernel.uses("lights") {
        bound.push(small("lights", bytemuck::cast_slice(&gpu.lights))?);
    }
    if kernel.uses("meshes") {
        bound.push(small("meshes", bytemuck::cast_slice(&gpu.meshes))?);
    }
    if kernel.uses("instances") {
        bound.push(small("instances", bytemuck::cast_slice(&gpu.instances))?);
    }
    if kernel.uses("textures") {
        bound.push(small("textures", bytemuck::cast_slice(&gpu.textures))?);
    }
    if kernel.uses("material_textures") {
        bound.push(small(
            "material_textures",
            bytemuck::cast_slice(&gpu.material_textures),
        )?);
    }
    // A small scene's arrays that the kernel reads from their uniform twins.
    for a in &UNIFORM_ARRAYS {
        if kernel.uses(a.uniform) {
            let data = gpu.array_bytes(a.name);
            let buffer = upload_uniform_padded(ctx, kernel, a.uniform, data, UNIFORM_ARRAY_BYTES)?;
            bound.push((a.uniform, buffer));
        }
    }
    for (name, bytes) in gpu.large_arrays() {
        let image = DATA_IMAGE_ARRAYS
            .iter()
            .find(|(array, image, _)| *array == name && kernel.uses(image));
        if let Some(&(_, image_name, element_bytes)) = image {
            images.push((
                image_name,
                DataImage::upload(ctx, kernel, image_name, bytes)?,
            ));
            if kernel.uses(name) {
                // The kernel reads only whether the array is empty (`has_bvh_nodes`, `triangle_face`):
                // a witness of one element, or none.
                let witness = &bytes[..bytes.len().min(element_bytes)];
                bound.push((name, upload_device_local(ctx, kernel, name, witness)?));
            }
            continue;
        }
        match split_array(name) {
            // Each part the kernel reads (all of them in the generic kernel, empty past the data).
            Some(split) => {
                for (k, &part) in split.parts.iter().enumerate() {
                    if kernel.uses(part) {
                        let data = split.part(bytes, k);
                        bound.push((part, upload_device_local(ctx, kernel, part, data)?));
                    }
                }
            }
            None => {
                if kernel.uses(name) {
                    bound.push((name, upload_device_local(ctx, kernel, name, bytes)?));
                }
            }
        }
    }
    Ok(UploadedScene {
        buffers: bound,
        images,
    })
}

/// Binds the scene's buffers, one accumulator strip, the pass constants and the fault counters.
#[allow(clippy::too_many_arguments)]
fn bind_all(
    kernel: &mut Kernel,
    scene: &[(&'static str, Buffer)],
    images: &[(&'static str, DataImage)],
    accum: &Buffer,
    pass_constants: &Buffer,
    [sample_faults, path_count]: [&Buffer; 2],
    splat: Option<&splat::Splat>,
    adaptive: Option<&adaptive::Adaptive>,
) -> Result<(), GpuError> {
    let mut bindings: Vec<(&str, &Buffer)> = scene.iter().map(|(n, b)| (*n, b)).collect();
    if let Some(s) = splat {
        bindings.push(("splat_samples", &s.samples));
    }
    if let Some(a) = adaptive {
        bindings.push(("active_pixels", &a.list));
    }
    bindings.push(("accum", accum));
    bindings.push(("pass_constants", pass_constants));
    bindings.push(("sample_faults", sample_faults));
    bindings.push(("path_count", path_count));
    let images: Vec<(&str, &DataImage)> = images.iter().map(|(n, i)| (*n, i)).collect();
    kernel.bind_with_images(&bindings, &images)
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
        check_loop_budget(ctx, &gpu)?;
        let mut params = render_params(scene, &gpu, options);
        if custom_kernel.is_some() {
            // A caller's kernel writes no splat records.
            params.splat = 0;
        }
        let mut features = if options.generic {
            FeatureSet::generic_for(&gpu, &params)
        } else {
            FeatureSet::of(&gpu, &params)
        };
        if !uniform_arrays_help(ctx.device_info()) {
            features.without_uniform_arrays();
        }
        // (Only where there are triangles: the arrays the images hold.)
        if data_images_help(ctx.device_info())
            && features.has(Feature::Triangles)
            && !features.has(Feature::SplitArrays)
            && DATA_IMAGE_ARRAYS.iter().all(|(name, _, _)| {
                crate::gpu::image::data_image_fits(
                    gpu.array_bytes(name).len(),
                    ctx.device_info().max_image_dimension_2d,
                )
            })
        {
            features.set(Feature::DataImages, true);
        }
        let content_hash = identity::content_hash(scene, &gpu, &params);
        // A caller's kernel (benchmarks) traces one sample per invocation and never saves a path.
        let samples_per_dispatch = if custom_kernel.is_some() { 1 } else { u32::MAX };
        let most_casts = casts_per_dispatch(&ctx.device_info().name, &gpu);
        let casts = options
            .casts_per_dispatch
            .map_or(most_casts, |m| m.clamp(1, most_casts));
        let compiled = match custom_kernel {
            Some(k) => k,
            None => compile_kernel(&features, options.fault)?,
        };
        // Refuse, before allocating anything, what the device cannot hold.
        let layout = tiles::TileLayout::new(
            params.width,
            params.height,
            [compiled.workgroup_size[0], compiled.workgroup_size[1]],
            tiles::TileLimits::of(ctx),
            options.max_tile,
        )
        .map_err(|e| GpuError::Limit(format!("{e}. Render a narrower image.")))?;
        // Paths in flight: a tile has at most this many pixels (a fixed tile, all of it).
        let largest_strip = (0..layout.strips.len())
            .map(|i| layout.strip_pixels(i))
            .max()
            .unwrap_or(0);
        let fixed_tile = options
            .max_tile
            .map_or(0, |[w, h]| u64::from(w) * u64::from(h));
        let fixed_tile = fixed_tile.min(largest_strip);
        if fixed_tile > MAX_PATHS_IN_FLIGHT {
            return Err(GpuError::Limit(format!(
                "a tile of {fixed_tile} pixels is more than the {MAX_PATHS_IN_FLIGHT} paths the renderer \
                 keeps in flight (one per pixel of a dispatch). Use a smaller --tile."
            )));
        }
        let path_slots = largest_strip
            .min(MAX_PATHS_IN_FLIGHT)
            .max(fixed_tile)
            .max(64);
        let splat_bytes = if params.splat != 0 {
            splat::device_bytes(ctx, &params)
        } else {
            0
        };
        check_device_memory(
            ctx,
            &gpu,
            &layout,
            path_slots,
            options.host_bytes_per_pixel,
            splat_bytes,
        )?;
        let mut kernel = Kernel::new(ctx, &compiled)?;
        let UploadedScene {
            buffers: bound,
            images,
        } = upload_scene(ctx, &mut kernel, &gpu, &params)?;
        // Device-local: every sample reads and writes its pixel's sums, one buffer per strip of rows. The
        // host reads them (and restores them) through a copy to (from) a host-visible staging buffer.
        if options.fault == Some(Fault::OutOfMemory) {
            return Err(GpuError::OutOfMemory(
                "vkAllocateMemory (injected: VKPATH_FAULT=out-of-memory)",
            ));
        }
        let strips = allocate_strips(ctx, &layout)?;
        let staging = Buffer::staging(ctx, "accumulator staging", layout.max_strip_bytes())?;
        let pass_constants = Buffer::device_uniform(
            ctx,
            "pass constants",
            std::mem::size_of::<GpuPassConstants>() as u64,
        )?;
        let sample_faults =
            Buffer::readable_storage(ctx, "sample faults", 4 * SAMPLE_FAULT_COUNTERS as u64)?;
        let path_count = Buffer::readable_storage(ctx, "path count", 16)?;
        let mut bound = bound;
        if kernel.uses("path_state") {
            let state = Buffer::device_storage(ctx, "path state", path_slots * PATH_STATE_BYTES)?;
            bound.push(("path_state", state));
            let queue = Buffer::device_storage(ctx, "path queue", path_slots * 2 * 4)?;
            bound.push(("path_queue", queue));
        }
        let splat = if params.splat != 0 {
            Some(splat::Splat::new(ctx, &params, &layout)?)
        } else {
            if kernel.uses("splat_samples") {
                // The generic kernel, not splatting: it never writes a record, but binds the buffer.
                bound.push((
                    "splat_samples",
                    Buffer::device_storage(ctx, "splat records", 16)?,
                ));
            }
            None
        };
        if splat.is_some()
            && options.adaptive.is_some()
            && options.aov == crate::kernel::abi::AOV_NONE
        {
            return Err(GpuError::Usage(
                "adaptive sampling of a splatted render (render.splat with render.adaptive)".into(),
            ));
        }
        let adaptive = match options.adaptive {
            // A caller's kernel (benchmarks) traces tiles only; AOV layers sample every pixel.
            Some(settings)
                if kernel.uses("active_pixels") && options.aov == crate::kernel::abi::AOV_NONE =>
            {
                Some(adaptive::Adaptive::new(
                    ctx,
                    settings,
                    params.width,
                    params.height,
                )?)
            }
            _ => {
                if kernel.uses("active_pixels") {
                    bound.push((
                        "active_pixels",
                        Buffer::device_storage(ctx, "active pixels", 16)?,
                    ));
                }
                None
            }
        };
        bind_all(
            &mut kernel,
            &bound,
            &images,
            &strips[0].buffer,
            &pass_constants,
            [&sample_faults, &path_count],
            splat.as_ref(),
            adaptive.as_ref(),
        )?;
        let mut r = Renderer {
            ctx: ctx.clone(),
            kernel,
            params,
            strips,
            bound_strip: 0,
            layout,
            tile_pixels: (INITIAL_TILE_PIXELS * options.target_dispatch_seconds / 0.1)
                .clamp(64.0, path_slots as f64) as u64,
            casts_per_dispatch: casts,
            samples_per_dispatch,
            path_slots,
            path_count,
            target_dispatch_seconds: options.target_dispatch_seconds,
            staging,
            pass_constants,
            bound,
            images,
            sample_faults,
            poisoned: None,
            warmed_up: false,
            fault: options.fault,
            passes: 0,
            scene_stats: gpu.stats,
            next_sample: 0,
            samples_done: 0,
            ranges: Vec::new(),
            features,
            content_hash,
            splat,
            adaptive,
        };
        r.reset()?;
        Ok(r)
    }

    /// Has the driver make the kernel's machine code now, with one dispatch over an empty tile (every
    /// invocation returns at once: trace.wgsl, `main`, and the benchmark kernels test the tile first
    /// too); once per renderer, and by the first [`Renderer::run_pass`] if not called before. A driver
    /// may compile a pipeline at its first dispatch rather than in vkCreateComputePipelines: lavapipe's
    /// llvmpipe makes its JIT variant at launch (Mesa's lp_state_cs.c, `llvmpipe_update_cs`), seconds for
    /// a large scene's kernel when the shader cache is cold. Without this, that compile would land in the
    /// first pass's dispatches, whose durations size the next pass's tiles (`dispatch_samples`); a caller
    /// that times its passes (the render session) calls it before starting its clock. Not done in
    /// `build`, so that a renderer built and never run (tests that look at its kernel) compiles nothing.
    pub fn warm_up(&mut self) -> Result<(), GpuError> {
        if self.warmed_up {
            return Ok(());
        }
        let empty = GpuPassConstants::default();
        self.kernel.submit(&[
            Command::Update(&self.pass_constants, bytemuck::bytes_of(&empty)),
            Command::Dispatch {
                invocations: [1, 1, 1],
            },
        ])?;
        if let Some(s) = &mut self.splat {
            s.warm_up()?;
        }
        self.warmed_up = true;
        Ok(())
    }

    /// What uploading the scene made and cost: triangles, BVH nodes, BVH build time, bytes.
    pub fn scene_stats(&self) -> &SceneStats {
        &self.scene_stats
    }

    /// Clears the accumulator: the next pass starts again at sample 0.
    pub fn reset(&mut self) -> Result<(), GpuError> {
        self.start_at(0)
    }

    /// Clears the accumulator; the next pass traces samples from index `first_sample` on (a partial
    /// render of a sample range, `--sample-range`).
    pub fn start_at(&mut self, first_sample: u32) -> Result<(), GpuError> {
        let zero: Vec<Command> = self
            .strips
            .iter()
            .map(|s| Command::Zero(&s.buffer))
            .collect();
        self.kernel.submit(&zero)?;
        if let Some(s) = &mut self.splat {
            s.zero()?;
        }
        if let Some(a) = &mut self.adaptive {
            a.clear()?;
        }
        self.sample_faults
            .write(&[0u8; 4 * SAMPLE_FAULT_COUNTERS])?;
        self.next_sample = first_sample;
        self.samples_done = 0;
        self.ranges.clear();
        self.poisoned = None;
        Ok(())
    }

    fn check_usable(&self) -> Result<(), GpuError> {
        match &self.poisoned {
            None => Ok(()),
            Some(why) => Err(GpuError::Usage(format!(
                "the accumulator holds part of a pass that failed ({why}); start again (reset, start_at \
                 or restore a checkpoint)"
            ))),
        }
    }

    /// Points `accum` at strip `i`'s accumulator.
    fn bind_strip(&mut self, i: usize) -> Result<(), GpuError> {
        if self.bound_strip == i {
            return Ok(());
        }
        bind_all(
            &mut self.kernel,
            &self.bound,
            &self.images,
            &self.strips[i].buffer,
            &self.pass_constants,
            [&self.sample_faults, &self.path_count],
            self.splat.as_ref(),
            self.adaptive.as_ref(),
        )?;
        self.bound_strip = i;
        Ok(())
    }

    /// Samples the accumulator could not take as they were since the last reset (see
    /// [`SampleFaults`]). Read after the passes that traced them have completed.
    pub fn sample_faults(&self) -> Result<SampleFaults, GpuError> {
        let counts: Vec<u32> = bytemuck::pod_collect_to_vec(
            &self.sample_faults.read_bytes()?[..4 * SAMPLE_FAULT_COUNTERS],
        );
        Ok(SampleFaults {
            clamped: counts[0],
            not_finite: counts[1],
            bounce_capped: counts[crate::kernel::abi::FAULT_BOUNCE_CAP as usize],
        })
    }

    /// Traces `spp` more samples per pixel (the next `spp` sample indices) and waits for them.
    ///
    /// Each sample is one dispatch per tile of each strip (see [`tiles`]); a pixel's samples are added in
    /// index order whatever the tiling. If a submit fails part-way (a lost device), the accumulator holds
    /// an unknown part of the pass: the renderer then refuses to read or extend it.
    pub fn run_pass(&mut self, spp: u32) -> Result<(), GpuError> {
        self.check_usable()?;
        self.warm_up()?;
        if self.next_sample.checked_add(spp).is_none() {
            return Err(GpuError::Usage(format!(
                "sample indices past 2^32 - 1: this render is at sample {} and {spp} more were asked for",
                self.next_sample
            )));
        }
        let start = self.next_sample;
        self.passes += 1;
        if let Err(e) = self.trace_pass(start, spp) {
            self.poisoned = Some(e.to_string());
            return Err(e);
        }
        self.next_sample += spp;
        self.samples_done += spp;
        if let Some(a) = &mut self.adaptive {
            a.add_samples(spp);
        }
        match self.ranges.last_mut() {
            Some(last) if last[1] == start => last[1] = self.next_sample,
            _ if spp == 0 => {}
            _ => self.ranges.push([start, self.next_sample]),
        }
        Ok(())
    }

    /// Traces samples `start..start + spp` of every pixel ([`Renderer::dispatch_samples`]); a splatted
    /// render in pieces of at most the records' capacity, each followed by its gather.
    fn trace_pass(&mut self, start: u32, spp: u32) -> Result<(), GpuError> {
        let Some(capacity) = self.splat.as_ref().map(|s| s.capacity) else {
            return self.dispatch_samples(start, spp);
        };
        let mut done = 0;
        while done < spp {
            let n = capacity.min(spp - done);
            self.dispatch_samples(start + done, n)?;
            let layout = &self.layout;
            self.splat
                .as_mut()
                .expect("a splatted render")
                .gather(layout, n)?;
            done += n;
        }
        Ok(())
    }

    /// Traces samples `start..start + spp` of every pixel (the records of a splatted render's pass start
    /// at `start`): for each strip, for each tile (and, with a
    /// caller's kernel, each sample in order), [`Renderer::trace_tile`]. The tiles then adapt so that
    /// the slowest dispatch per pixel of this pass, at the next pass's tile size, takes about
    /// `target_dispatch_seconds`.
    fn dispatch_samples(&mut self, start: u32, spp: u32) -> Result<(), GpuError> {
        let chunk = self.samples_per_dispatch.clamp(1, spp.max(1));
        let mut slowest_per_pixel = 0.0f64;
        for si in 0..self.strips.len() {
            let tiles = self.tiles_of_strip(si);
            if tiles.is_empty() {
                continue;
            }
            self.bind_strip(si)?;
            let accum_base = self.strips[si].rows[0] * self.params.width;
            let mut offset = 0;
            while offset < spp {
                let count = chunk.min(spp - offset);
                for t in &tiles {
                    let seconds = self.trace_tile(t, accum_base, [start, start + offset], count)?;
                    let pixels = match t.list {
                        Some([_, n]) => f64::from(n),
                        None => {
                            f64::from(t.end[0] - t.origin[0]) * f64::from(t.end[1] - t.origin[1])
                        }
                    };
                    slowest_per_pixel = slowest_per_pixel.max(seconds / pixels.max(1.0));
                }
                offset += count;
            }
        }
        if slowest_per_pixel > 0.0 {
            let ideal = self.target_dispatch_seconds / slowest_per_pixel;
            let most = (TILE_GROWTH * self.tile_pixels as f64).min(self.path_slots as f64);
            self.tile_pixels = ideal.clamp(64.0, most.max(64.0)) as u64;
        }
        Ok(())
    }

    /// Traces `count` samples from `sample_index` on over one tile: a dispatch that begins them, then
    /// dispatches over the queue of paths still going (trace.wgsl, `main`) until none is left, one submit
    /// each (the host reads the queue's length in between). Returns the longest dispatch's duration in
    /// seconds.
    fn trace_tile(
        &mut self,
        t: &tiles::Tile,
        accum_base: u32,
        [pass_start, sample_index]: [u32; 2],
        count: u32,
    ) -> Result<f64, GpuError> {
        let width = t.end[0] - t.origin[0];
        let height = t.end[1] - t.origin[1];
        let mut c = GpuPassConstants {
            sample_index,
            accum_base,
            tile_x0: t.origin[0],
            tile_y0: t.origin[1],
            tile_x1: t.end[0],
            tile_y1: t.end[1],
            sample_count: count,
            queued: 0,
            queue_in: 0,
            queue_out: 0,
            casts: self.casts_per_dispatch,
            pass_start,
            list_start: t.list.map_or(0, |l| l[0]),
            list_len: t.list.map_or(0, |l| l[1]),
        };
        let half = self.path_slots as u32;
        let mut longest = 0.0f64;
        loop {
            self.path_count.write(&[0u8; 4])?;
            // Continuing: one invocation per queued path, in rows as wide as the tile.
            let invocations = if c.queued == 0 {
                [width, height, 1]
            } else {
                [width, c.queued.div_ceil(width), 1]
            };
            let t0 = Instant::now();
            self.kernel.submit(&[
                Command::Update(&self.pass_constants, bytemuck::bytes_of(&c)),
                Command::Dispatch { invocations },
            ])?;
            longest = longest.max(t0.elapsed().as_secs_f64());
            if self.fault == Some(Fault::DeviceLostAtPass(self.passes)) {
                // As a real loss would: part of the pass is in the accumulator.
                return Err(GpuError::DeviceLost(
                    "vkQueueSubmit (injected: VKPATH_FAULT=device-lost@N)",
                ));
            }
            let left = u32::from_le_bytes(
                self.path_count.read_bytes()?[..4]
                    .try_into()
                    .expect("4 bytes"),
            );
            if left == 0 {
                return Ok(longest);
            }
            // The queue's two halves take turns as input and output.
            c.queued = left;
            c.queue_in = c.queue_out;
            c.queue_out = if c.queue_in == 0 { half } else { 0 };
        }
    }

    /// How the image is cut into strips (accumulator buffers) and tiles (dispatches).
    pub fn tile_layout(&self) -> &tiles::TileLayout {
        &self.layout
    }

    /// The most ray casts one invocation makes per dispatch ([`casts_per_dispatch`]).
    pub fn casts_per_dispatch(&self) -> u32 {
        self.casts_per_dispatch
    }

    /// The tiles one sample is dispatched over now (they adapt to the dispatch target; with adaptive
    /// sampling, the pieces of the list of pixels still sampling).
    pub fn tiles_per_sample(&self) -> usize {
        (0..self.strips.len())
            .map(|i| self.tiles_of_strip(i).len())
            .sum()
    }

    /// The dispatches of one sample over strip `si` at the current tile size: its tiles, or with
    /// adaptive sampling, the pieces of the list of its pixels still sampling.
    fn tiles_of_strip(&self, si: usize) -> Vec<tiles::Tile> {
        match &self.adaptive {
            Some(a) => list_tiles(
                a.active_in_rows(self.strips[si].rows),
                self.tile_pixels,
                self.params.width,
            ),
            None => self.layout.tiles(si, self.tile_pixels),
        }
    }

    /// The sample index the next pass starts at.
    pub fn next_sample(&self) -> u32 {
        self.next_sample
    }

    /// The sample indices accumulated, as sorted disjoint `[start, end)` ranges.
    pub fn ranges(&self) -> &[[u32; 2]] {
        &self.ranges
    }

    /// The hash of the scene content this renderer was built from ([`identity::content_hash`]).
    pub fn content_hash(&self) -> u64 {
        self.content_hash
    }

    /// The uniform parameters of this render (image size, seed, bounces, ...).
    pub fn params(&self) -> &GpuParams {
        &self.params
    }

    /// What must match for a checkpoint to resume this render.
    pub fn identity(&self) -> identity::Identity {
        identity::Identity::new(&self.params, self.content_hash)
    }

    /// The accumulator's raw per-pixel state (exact sums, Kahan pairs of squares), exactly as the GPU
    /// holds it.
    /// Read strip by strip through the staging buffer.
    pub fn accum_state(&mut self) -> Result<Vec<GpuAccum>, GpuError> {
        let pixels = self.params.width as usize * self.params.height as usize;
        let mut out: Vec<GpuAccum> = Vec::with_capacity(pixels);
        self.each_strip(|strip| out.extend_from_slice(strip))?;
        Ok(out)
    }

    /// Calls `f` on each strip's pixels in turn (row-major from the top), read back through the staging
    /// buffer [`STRIP_CHUNK`] pixels at a time: the host holds no more than a chunk of the accumulator
    /// beyond what `f` keeps.
    fn each_strip(&mut self, f: impl FnMut(&[GpuAccum])) -> Result<(), GpuError> {
        self.check_usable()?;
        let buffers = self.strips.iter().map(|s| &s.buffer);
        read_strips(&mut self.kernel, &self.staging, &self.layout, buffers, f)
    }

    /// Puts an accumulation state (from [`Renderer::accum_state`], a checkpoint or a merge) back on the
    /// device: `accum` holds one entry per pixel, `ranges` the sample indices it holds. The next pass
    /// goes on at the end of the last range, and adds its samples to exactly these bits.
    pub fn restore(&mut self, ranges: &[[u32; 2]], accum: &[GpuAccum]) -> Result<(), GpuError> {
        let pixels = self.params.width as usize * self.params.height as usize;
        if accum.len() != pixels {
            return Err(GpuError::Usage(format!(
                "restore of {} pixels into a {}x{} image",
                accum.len(),
                self.params.width,
                self.params.height
            )));
        }
        let samples: u64 = ranges
            .iter()
            .map(|r| u64::from(r[1].saturating_sub(r[0])))
            .sum();
        let samples = u32::try_from(samples)
            .map_err(|_| GpuError::Usage("restore of more than 2^32 - 1 samples".into()))?;
        let buffers = self.strips.iter().map(|s| &s.buffer);
        write_strips(
            &mut self.kernel,
            &mut self.staging,
            &self.layout,
            buffers,
            accum,
        )?;
        self.poisoned = None;
        self.ranges = ranges.to_vec();
        self.samples_done = samples;
        self.next_sample = ranges.last().map_or(0, |r| r[1]);
        // Adaptive sampling: every pixel holds all the samples and goes on, until
        // [`Renderer::restore_adaptive`] says otherwise.
        if let Some(a) = &mut self.adaptive {
            a.restore(&vec![[samples, 1]; pixels], samples)?;
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
    /// Read strip by strip: the host holds the film (24 bytes a pixel), never a copy of the whole
    /// accumulator (96).
    pub fn film(&mut self) -> Result<Film, GpuError> {
        let mut film = Film::for_sums(self.params.width, self.params.height, self.samples_done);
        if let Some(a) = &self.adaptive {
            film.pixel_spp = a.counts().to_vec();
        }
        self.each_strip(|strip| film.push_sums(strip))?;
        let mut at = 0;
        self.each_splat_strip(|chunk| {
            film.push_splatted(at, chunk);
            at += chunk.len();
        })?;
        Ok(film)
    }

    /// Adaptive sampling's state (`render.adaptive`): the samples of each pixel and the pixels still
    /// sampling; `None` when every pixel samples equally.
    pub fn adaptive(&self) -> Option<&adaptive::Adaptive> {
        self.adaptive.as_ref()
    }

    /// With adaptive sampling, at one of its checks ([`adaptive::Adaptive::checks_at`]): stops the
    /// pixels that have converged and returns how many still sample. `None` without adaptive sampling
    /// or between checks.
    pub fn stop_converged(&mut self) -> Result<Option<usize>, GpuError> {
        match &self.adaptive {
            Some(a) if a.checks_at(self.samples_done) => {}
            _ => return Ok(None),
        }
        let film = self.film()?;
        let a = self.adaptive.as_mut().expect("checked above");
        a.stop_converged(&film).map(Some)
    }

    /// Puts adaptive sampling's per-pixel counts back (from a checkpoint, after [`Renderer::restore`]).
    pub fn restore_adaptive(&mut self, counts: &[[u32; 2]]) -> Result<(), GpuError> {
        let done = self.samples_done;
        match &mut self.adaptive {
            Some(a) => a.restore(counts, done),
            None => Err(GpuError::Usage(
                "restore of adaptive sample counts into a render without adaptive sampling".into(),
            )),
        }
    }

    /// Whether the render splats its samples (`render.splat`).
    pub fn splats(&self) -> bool {
        self.splat.is_some()
    }

    /// A splatted render's splatted sums, exactly as the GPU holds them (empty for a render that does
    /// not splat).
    pub fn splat_state(&mut self) -> Result<Vec<GpuSplatAccum>, GpuError> {
        let mut out = Vec::new();
        self.each_splat_strip(|chunk| out.extend_from_slice(chunk))?;
        Ok(out)
    }

    /// Calls `f` on the splatted sums, as [`Renderer::each_strip`] does on the per-pixel ones; nothing
    /// for a render that does not splat.
    fn each_splat_strip(&mut self, f: impl FnMut(&[GpuSplatAccum])) -> Result<(), GpuError> {
        self.check_usable()?;
        let Some(splat) = &self.splat else {
            return Ok(());
        };
        read_strips(
            &mut self.kernel,
            &self.staging,
            &self.layout,
            splat.strips.iter(),
            f,
        )
    }

    /// Puts a splatted render's splatted sums back on the device (after [`Renderer::restore`], from the
    /// same state). Refused for a render that does not splat, or with the wrong number of pixels.
    pub fn restore_splat(&mut self, sums: &[GpuSplatAccum]) -> Result<(), GpuError> {
        let pixels = self.params.width as usize * self.params.height as usize;
        let Some(splat) = &self.splat else {
            return Err(GpuError::Usage(
                "restore of splatted sums into a render that does not splat".into(),
            ));
        };
        if sums.len() != pixels {
            return Err(GpuError::Usage(format!(
                "restore of {} splatted pixels into a {}x{} image",
                sums.len(),
                self.params.width,
                self.params.height
            )));
        }
        write_strips(
            &mut self.kernel,
            &mut self.staging,
            &self.layout,
            splat.strips.iter(),
            sums,
        )
    }
}

/// The dispatches over the pixels still sampling `range` (indices into adaptive sampling's list), at
/// most `tile_pixels` each, in rows of at most the image's `width` (the invocations a rectangle of the
/// same pixels would have).
fn list_tiles(range: std::ops::Range<usize>, tile_pixels: u64, width: u32) -> Vec<tiles::Tile> {
    let most = tile_pixels.clamp(1, u64::from(u32::MAX)) as usize;
    let mut out = Vec::new();
    let mut at = range.start;
    while at < range.end {
        let n = (range.end - at).min(most) as u32;
        let row = n.min(width.max(1));
        out.push(tiles::Tile {
            origin: [0, 0],
            end: [row, n.div_ceil(row)],
            list: Some([at as u32, n]),
        });
        at += n as usize;
    }
    out
}

/// When a progressive render stops.
#[derive(Clone, Debug)]
pub struct Budget {
    /// Upper bound on samples per pixel.
    pub spp: u32,
    /// Stop after the first pass that ends past this duration.
    pub time: Option<Duration>,
    /// Report `progress` whenever the sample count reaches a multiple of this (passes are cut to land
    /// on the multiples).
    pub progress_every: Option<u32>,
    /// How often to report `save_state` (for checkpoints).
    pub save_every: Option<SaveEvery>,
    /// Stop once the film's estimated relative error ([`Film::estimated_rel_error`]) is below this.
    /// Tested after each pass once at least [`TARGET_ERROR_MIN_SPP`] samples are in: with fewer, the
    /// per-pixel variances are too noisy to trust.
    pub target_error: Option<f64>,
}

/// The fewest samples per pixel before `--target-error` may stop a render.
pub const TARGET_ERROR_MIN_SPP: u32 = 16;

/// How often a render saves its state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SaveEvery {
    /// Whenever the sample count reaches a multiple of this (passes are cut to land on the multiples).
    Samples(u32),
    /// After the first pass that ends this long after the last save (or the start).
    Time(Duration),
}

/// Why a progressive render ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    Samples,
    Time,
    TargetError,
    /// Adaptive sampling stopped every pixel (each met `render.adaptive_threshold`).
    Converged,
    Interrupted,
}

/// What [`render_progressive`] reports after each pass.
#[derive(Clone, Copy, Debug)]
pub struct PassReport {
    pub samples_done: u32,
    pub elapsed: Duration,
    /// True when `samples_done` is a multiple of `progress_every`.
    pub progress: bool,
    /// True when the state is due to be saved (see [`SaveEvery`]).
    pub save_state: bool,
}

/// The most samples per pixel of an `--aov` layer: albedo, normal and depth vary only with the surface a
/// camera ray meets, so a few dozen samples filter their edges as the image does, and more would only
/// add time.
pub const AOV_MAX_SPP: u32 = 64;

/// Renders `spp` samples per pixel of an `--aov` layer (`AOV_ALBEDO`, `AOV_NORMAL` or `AOV_DEPTH`) of
/// `scene` with a renderer of its own (its kernel specialised for the layer, its own accumulator: the
/// render's are untouched), and returns its film: the layer's mean per pixel (see trace.wgsl's
/// `trace_aov` for what each holds).
pub fn render_aov(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    options: &RenderOptions,
    aov: u32,
    spp: u32,
) -> Result<Film, GpuError> {
    let options = RenderOptions {
        aov,
        fault: None,
        ..options.clone()
    };
    let mut r = Renderer::new(ctx, scene, &options)?;
    let mut done = 0;
    while done < spp {
        let k = (spp - done).min(16);
        r.run_pass(k)?;
        done += k;
    }
    r.film()
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
    let mut last_save = start;
    let mut pass_spp = options.samples_per_pass.unwrap_or(1).max(1);
    let save_samples = match budget.save_every {
        Some(SaveEvery::Samples(n)) if n > 0 => Some(n),
        _ => None,
    };
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
        let adaptive_every = renderer.adaptive().map(|a| a.settings.min_spp.max(1));
        for every in [budget.progress_every, save_samples, adaptive_every]
            .into_iter()
            .flatten()
        {
            if let Some(q) = done.checked_div(every) {
                let next = (q + 1).saturating_mul(every);
                k = k.min(next - done);
            }
        }
        let t0 = Instant::now();
        renderer.run_pass(k)?;
        let dt = t0.elapsed().as_secs_f64();
        let done = renderer.samples_done();
        // Adaptive sampling's check, before the report, so that the progress line shows the pixels
        // still sampling and a checkpoint holds the counts the next pass starts from.
        let converged = renderer.stop_converged()? == Some(0);
        let progress = budget
            .progress_every
            .is_some_and(|e| e > 0 && done.is_multiple_of(e));
        let save_state = match budget.save_every {
            Some(SaveEvery::Samples(e)) => e > 0 && done.is_multiple_of(e),
            Some(SaveEvery::Time(t)) => last_save.elapsed() >= t,
            None => false,
        };
        if save_state {
            last_save = Instant::now();
        }
        on_pass(
            renderer,
            &PassReport {
                samples_done: done,
                elapsed: start.elapsed(),
                progress,
                save_state,
            },
        )?;
        if converged && done < budget.spp {
            break StopReason::Converged;
        }
        if let Some(target) = budget.target_error
            && done >= TARGET_ERROR_MIN_SPP
            && done < budget.spp
            && renderer.film()?.estimated_rel_error() < target
        {
            break StopReason::TargetError;
        }
        if options.samples_per_pass.is_none() && k == pass_spp {
            // Grow (at most doubling) or shrink the pass towards the target duration.
            let per_sample = dt / k as f64;
            let ideal = (options.target_pass_seconds / per_sample.max(1e-9)).floor();
            pass_spp = (ideal as u32).clamp(1, pass_spp.saturating_mul(2));
        }
    };
    Ok((reason, start.elapsed()))
}

/// Refuses, before anything is allocated, a render whose buffers exceed the device: each scene array
/// against the storage-buffer range, and everything (scene arrays, accumulator strips, staging) against
/// the device's memory; then the host's share against the memory the machine has available: the
/// staging buffer and `host_bytes_per_pixel` for every pixel, and on a CPU device (lavapipe) all of the
/// device's buffers too, which are host memory there. The message names the sizes and the limit.
fn check_device_memory(
    ctx: &GpuContext,
    gpu: &GpuScene,
    layout: &tiles::TileLayout,
    path_slots: u64,
    host_bytes_per_pixel: u64,
    splat_bytes: u64,
) -> Result<(), GpuError> {
    let info = ctx.device_info();
    let range = u64::from(info.max_storage_buffer_range);
    // Every array the kernel may bind. Taken apart with no `..`: a new array must be counted here.
    let GpuScene {
        spheres,
        triangles,
        materials,
        lights,
        bvh_nodes,
        sphere_nodes,
        mesh_faces,
        mesh_vertices,
        meshes,
        texels,
        textures,
        material_textures,
        light_triangles,
        env_texels,
        env_cdf,
        environment_light: _,
        triangle_light: _,
        instances,
        stack_need: _,
        instanced_walk: _,
        world_triangles: _,
        stats: _,
    } = gpu;
    let arrays: [(&str, &str, u64); 16] = [
        (
            "instances",
            "instances",
            std::mem::size_of_val(instances.as_slice()) as u64,
        ),
        (
            "sphere BVH nodes",
            "sphere_nodes",
            std::mem::size_of_val(sphere_nodes.as_slice()) as u64,
        ),
        (
            "spheres",
            "spheres",
            std::mem::size_of_val(spheres.as_slice()) as u64,
        ),
        (
            "triangles",
            "triangles",
            std::mem::size_of_val(triangles.as_slice()) as u64,
        ),
        (
            "materials",
            "materials",
            std::mem::size_of_val(materials.as_slice()) as u64,
        ),
        (
            "lights",
            "lights",
            std::mem::size_of_val(lights.as_slice()) as u64,
        ),
        (
            "BVH nodes",
            "bvh_nodes",
            std::mem::size_of_val(bvh_nodes.as_slice()) as u64,
        ),
        (
            "mesh faces",
            "mesh_faces",
            std::mem::size_of_val(mesh_faces.as_slice()) as u64,
        ),
        (
            "mesh vertices",
            "mesh_vertices",
            std::mem::size_of_val(mesh_vertices.as_slice()) as u64,
        ),
        (
            "meshes",
            "meshes",
            std::mem::size_of_val(meshes.as_slice()) as u64,
        ),
        (
            "texture table",
            "textures",
            std::mem::size_of_val(textures.as_slice()) as u64,
        ),
        (
            "material textures",
            "material_textures",
            std::mem::size_of_val(material_textures.as_slice()) as u64,
        ),
        (
            "texture texels",
            "texels",
            std::mem::size_of_val(texels.as_slice()) as u64,
        ),
        (
            "emissive triangles",
            "light_triangles",
            std::mem::size_of_val(light_triangles.as_slice()) as u64,
        ),
        (
            "environment map texels",
            "env_texels",
            std::mem::size_of_val(env_texels.as_slice()) as u64,
        ),
        (
            "environment map distribution",
            "env_cdf",
            std::mem::size_of_val(env_cdf.as_slice()) as u64,
        ),
    ];
    let mib = |b: u64| b as f64 / f64::from(1 << 20);
    // The arrays split across bindings (abi::SPLIT_ARRAYS) are limited by their parts, each of which
    // fits any Vulkan device's range.
    for split in &SPLIT_ARRAYS {
        let n = gpu.array_len(split.name);
        if n > split.max_elements() {
            return Err(GpuError::Limit(format!(
                "the scene has {n} {} (each {} bytes), more than the {} the renderer can bind ({} \
                 storage buffers of {} each). Use a smaller scene, or split it into instances of \
                 smaller meshes.",
                split.name.replace('_', " "),
                split.element_bytes,
                split.max_elements(),
                split.parts.len(),
                split.part_elements(),
            )));
        }
    }
    for (name, wgsl_name, bytes) in arrays {
        if split_array(wgsl_name).is_some() {
            continue;
        }
        if bytes > range {
            return Err(GpuError::Limit(format!(
                "the scene's {name} take {bytes} bytes ({:.0} MiB), more than the {range} bytes one \
                 storage buffer may hold on {} (maxStorageBufferRange). Use a smaller scene, or a device \
                 with a larger limit (VKPATH_DEVICE).",
                mib(bytes),
                info.name
            )));
        }
    }
    let scene_bytes: u64 = arrays.iter().map(|(_, _, b)| b).sum();
    let accum = layout.total_bytes();
    // The staging buffer is host-visible; on a discrete GPU it is not device memory, but counting it
    // keeps the check simple and errs on the side of refusing.
    let paths = path_slots * (PATH_STATE_BYTES + 8);
    let total = scene_bytes + accum + layout.max_strip_bytes() + paths + splat_bytes;
    let available = info.device_local_memory_bytes;
    if available > 0 && total > available {
        return Err(GpuError::Limit(format!(
            "this render needs {:.0} MiB of device memory ({:.0} MiB of accumulator for {}x{} pixels at \
             {} bytes each, {:.0} MiB of staging, {:.0} MiB of paths in flight, {:.0} MiB of splatting \
             (render.splat), {:.0} MiB of scene), and {} has {:.0} MiB. Render a smaller image, or use a \
             device with more memory (VKPATH_DEVICE).",
            mib(total),
            mib(accum),
            layout.width,
            layout.height,
            tiles::ACCUM_BYTES_PER_PIXEL,
            mib(layout.max_strip_bytes()),
            mib(paths),
            mib(splat_bytes),
            mib(scene_bytes),
            info.name,
            mib(available)
        )));
    }
    let pixels = u64::from(layout.width) * u64::from(layout.height);
    let device_on_host = if info.device_type == "CPU" {
        total
    } else {
        layout.max_strip_bytes()
    };
    let host = device_on_host + pixels * host_bytes_per_pixel;
    if let Some(available) = crate::memory::available_bytes()
        && host > available
    {
        return Err(GpuError::Limit(format!(
            "this render needs about {:.0} MiB of host memory ({:.0} MiB of {}, {:.0} MiB of film, \
             images and checkpoints at {host_bytes_per_pixel} bytes a pixel for {}x{} pixels), and the \
             machine has {:.0} MiB available (MemAvailable). Render a smaller image, or free memory.",
            mib(host),
            mib(device_on_host),
            if info.device_type == "CPU" {
                "device buffers, host memory on a CPU device"
            } else {
                "staging buffer"
            },
            mib(pixels * host_bytes_per_pixel),
            layout.width,
            layout.height,
            mib(available)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The uniform twins: on CPU devices whose uniform buffers hold one, but not on Mesa 26's lavapipe
    /// (whose storage reads are gathers already) nor on GPUs.
    #[test]
    fn uniform_twins_are_for_cpu_drivers_before_mesa_26() {
        let lavapipe = crate::gpu::DeviceInfo::test_lavapipe;
        assert!(uniform_arrays_help(&lavapipe([25, 0])));
        assert!(uniform_arrays_help(&lavapipe([24, 2])));
        assert!(!uniform_arrays_help(&lavapipe([26, 1])));
        let mut other_cpu = lavapipe([25, 0]);
        other_cpu.lavapipe_mesa = None;
        assert!(uniform_arrays_help(&other_cpu));
        let mut small = lavapipe([25, 0]);
        small.max_uniform_buffer_range = 16384;
        assert!(!uniform_arrays_help(&small));
        let mut gpu = lavapipe([25, 0]);
        gpu.device_type = "discrete GPU".into();
        gpu.lavapipe_mesa = None;
        assert!(!uniform_arrays_help(&gpu));
    }

    /// The warm-up dispatch (`Renderer::warm_up`, before a renderer's first pass) is over an empty tile,
    /// which must trace nothing: after a pass, another warm-up leaves every pixel's sums, the fault
    /// counters and the next pass's bits as they were.
    #[test]
    fn the_warm_up_dispatch_traces_nothing() {
        let ctx = crate::gpu::testing::context();
        let mut scene = crate::Scene::default_scene();
        scene.image.width = 24;
        scene.image.height = 16;
        let mut r = Renderer::new(&ctx, &scene, &RenderOptions::default()).unwrap();
        r.run_pass(2).unwrap();
        let before = r.accum_state().unwrap();
        assert!(
            before.iter().any(|a| a.sum.iter().any(|&w| w != 0)),
            "the pass added nothing"
        );
        let faults = r.sample_faults().unwrap();
        r.warmed_up = false;
        r.warm_up().unwrap();
        assert!(
            r.accum_state().unwrap() == before,
            "the warm-up dispatch changed the sums"
        );
        assert_eq!(r.sample_faults().unwrap(), faults);
        // And the next pass adds what it adds without the extra dispatch.
        r.run_pass(1).unwrap();
        let mut fresh = Renderer::new(&ctx, &scene, &RenderOptions::default()).unwrap();
        fresh.run_pass(2).unwrap();
        fresh.run_pass(1).unwrap();
        assert!(r.accum_state().unwrap() == fresh.accum_state().unwrap());
    }

    /// A scene with one instanced quad fits the walk; the same upload with a stack need past the walk's
    /// stack (what a top-level tree over very many placements and a deep mesh tree would add up to:
    /// no scene small enough for a test reaches it) is refused, naming the need and the stack.
    #[test]
    fn instances_past_the_walks_stack_are_refused() {
        let mut scene = crate::Scene::from_toml_str(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[materials]\n\
             w = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n",
            None,
        )
        .expect("scene");
        let quad = crate::scene::mesh::Mesh {
            obj: "quad".into(),
            positions: vec![
                glam::Vec3::new(-1.0, -1.0, 0.0),
                glam::Vec3::new(1.0, -1.0, 0.0),
                glam::Vec3::new(1.0, 1.0, 0.0),
                glam::Vec3::new(-1.0, 1.0, 0.0),
            ],
            normals: Vec::new(),
            uvs: Vec::new(),
            tangents: Vec::new(),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            material: 0,
            texture: None,
            maps: Default::default(),
        };
        scene.instanced.push(crate::scene::mesh::InstancedMesh {
            parts: vec![quad],
            placements: vec![
                crate::scene::mesh::MeshPlacement::at(glam::DAffine3::IDENTITY),
                crate::scene::mesh::MeshPlacement::at(glam::DAffine3::from_scale(
                    glam::DVec3::splat(2.0),
                )),
            ],
        });
        let mut gpu = GpuScene::build(&scene);
        assert_eq!(gpu.instances.len(), 2);
        assert!(gpu.stack_need <= crate::scene::bvh::STACK_SIZE);
        assert!(check_instance_limits(&gpu).is_ok());
        gpu.stack_need = crate::scene::bvh::STACK_SIZE + 1;
        match check_instance_limits(&gpu) {
            Err(GpuError::Limit(m)) => assert!(
                m.contains(&format!(
                    "need {} stack entries",
                    crate::scene::bvh::STACK_SIZE + 1
                )) && m.contains("2 placements"),
                "{m}"
            ),
            other => panic!("expected a limit, got {other:?}"),
        }
    }

    /// With instances, a BVH leaf holds a placement's or a triangle's index in 28 bits: 2^28 - 1 of each
    /// is accepted, 2^28 refused with both counts named (no scene small enough for a test has so many:
    /// the counts are checked as the upload gives them). Without instances the bit is free and the
    /// triangles are bounded elsewhere (`mesh::MAX_TRIANGLES`).
    #[test]
    fn instances_past_the_leaf_index_bits_are_refused() {
        let most = (1usize << 28) - 1;
        assert!(instance_limits(most, most, 1).is_ok());
        assert!(instance_limits(most + 1, 0, 1).is_ok());
        for (triangles, instances) in [(most + 1, 2), (10, most + 1)] {
            match instance_limits(triangles, instances, 1) {
                Err(GpuError::Limit(m)) => assert!(
                    m.contains(&format!("{triangles} triangles and {instances} placements"))
                        && m.contains(&format!("at most {most} of each")),
                    "{m}"
                ),
                other => panic!("expected a limit, got {other:?}"),
            }
        }
    }
}
