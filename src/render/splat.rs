//! Splatting (`render.splat`): the film-side gather that follows each pass of a splatted render.
//!
//! The render kernel draws each radiance sample uniformly over its pixel, adds it to the pixel's own
//! exact sums as always (their variance feeds the error estimate), and writes a record of it (radiance
//! and position in the pixel) to `splat_samples`. Once every tile of the pass has been traced, the gather
//! kernel (shaders/splat.wgsl) adds to each pixel the records of its neighbours that its filter covers,
//! weighted by the filter, into exact sums of w L and of w ([`GpuSplatAccum`]); the film is their ratio
//! (Mitsuba 3's film). Because every record is gathered where the neighbours' records of the same pass
//! are all known, no two invocations ever write one pixel, and no atomics are needed; the price is the
//! records' buffer, [`SPLAT_RECORD_BYTES`] per pixel per sample of the pass, which bounds the samples a
//! pass may trace ([`Splat::capacity`]: a longer pass is cut into several).
//!
//! Every term is a pure function of one sample and the sums are exact, so a splatted render is
//! bit-identical however it is cut into passes, tiles, checkpoints or farm parts, like the per-pixel one.

use super::LAVAPIPE_LOOP_BUDGET;
use super::tiles::TileLayout;
use crate::gpu::{Buffer, Command, GpuContext, GpuError, Kernel};
use crate::kernel::abi::{
    FILTER_GAUSSIAN, GpuParams, GpuSplatAccum, GpuSplatConstants, SPLAT_RECORD_BYTES,
};
use crate::kernel::library;
use crate::kernel::specialise::{self, CompiledShader};
use std::sync::{Arc, OnceLock};

/// The most bytes the records of one pass may take: 128 MiB, 32 samples per pixel at 512x512, 4 at
/// 1920x1080, 1 at 4096x2160. Fewer records per pass only means more, shorter passes.
pub const MAX_RECORD_BYTES: u64 = 128 << 20;

/// Bytes of one pixel's splatted sums on the device.
pub const SPLAT_ACCUM_BYTES_PER_PIXEL: u64 = std::mem::size_of::<GpuSplatAccum>() as u64;

/// The filter's radius in pixels: the tent's own, the Gaussian's 4 sigma (Mitsuba 3's).
pub fn filter_radius(params: &GpuParams) -> f32 {
    if params.filter_kind == FILTER_GAUSSIAN {
        4.0 * params.filter_width
    } else {
        params.filter_width
    }
}

/// K: how many pixels away, on each axis, a sample can still lie within the filter's radius R of a
/// pixel's centre. A sample of pixel q + d is at least |d| - 1/2 from q's centre on that axis, so
/// K = ceil(R - 1/2).
pub fn reach(params: &GpuParams) -> u32 {
    (filter_radius(params) - 0.5).ceil().max(0.0) as u32
}

/// The most samples one gather dispatch may take: each sample is (2K + 1)^2 iterations of the inner
/// loop, 2K + 1 of the middle one and one of the outer, all counted against lavapipe's budget of loop
/// iterations per invocation (with a margin for the budget's own rounding).
pub fn gather_chunk(reach: u32) -> u32 {
    let side = 2 * u64::from(reach) + 1;
    let per_sample = 1 + side * (1 + side);
    ((LAVAPIPE_LOOP_BUDGET - 64) / per_sample).max(1) as u32
}

/// The most records' bytes one pass may take on this device.
fn record_budget(ctx: &GpuContext) -> u64 {
    MAX_RECORD_BYTES.min(u64::from(ctx.limits.max_storage_buffer_range))
}

/// Device bytes of a splatted render of `params`' image: the records of the longest pass and the
/// splatted sums.
pub fn device_bytes(ctx: &GpuContext, params: &GpuParams) -> u64 {
    let pixels = u64::from(params.width) * u64::from(params.height);
    let per_sample = pixels * SPLAT_RECORD_BYTES;
    let records = (record_budget(ctx) / per_sample.max(1)).max(1) * per_sample;
    records + pixels * SPLAT_ACCUM_BYTES_PER_PIXEL
}

/// The gather kernel, compiled once per process (it does not depend on the scene).
fn gather_shader() -> Result<Arc<CompiledShader>, GpuError> {
    static SHADER: OnceLock<Result<Arc<CompiledShader>, String>> = OnceLock::new();
    SHADER
        .get_or_init(|| {
            specialise::compile(&library::splat_source())
                .map(Arc::new)
                .map_err(|e| e.to_string())
        })
        .clone()
        .map_err(GpuError::Shader)
}

/// A splatted render's gather: its kernel, the pass's records and the splatted sums, one buffer per
/// strip of the accumulator.
pub struct Splat {
    kernel: Kernel,
    /// The pass's records (`splat_samples`): `capacity` samples of every pixel.
    pub samples: Buffer,
    /// One buffer of [`GpuSplatAccum`]s per strip of rows (as the accumulator's strips).
    pub strips: Vec<Buffer>,
    constants: Buffer,
    /// Records per pixel the buffer holds: the most samples one pass traces.
    pub capacity: u32,
    reach: u32,
    params: GpuParams,
}

impl Splat {
    /// The buffers and the kernel for `params`' image, cut as `layout`.
    pub fn new(
        ctx: &Arc<GpuContext>,
        params: &GpuParams,
        layout: &TileLayout,
    ) -> Result<Splat, GpuError> {
        let pixels = u64::from(params.width) * u64::from(params.height);
        let per_sample = pixels * SPLAT_RECORD_BYTES;
        let most = record_budget(ctx);
        if per_sample > most {
            return Err(GpuError::Limit(format!(
                "a splatted render of {}x{} needs {per_sample} bytes for one sample of every pixel, more \
                 than the {most} a buffer of this device may hold. Render a smaller image, or set \
                 render.splat = false.",
                params.width, params.height
            )));
        }
        let capacity = (most / per_sample).min(u64::from(u32::MAX)) as u32;
        let samples =
            Buffer::device_storage(ctx, "splat records", per_sample * u64::from(capacity))?;
        let strips =
            super::strip_buffers(ctx, layout, "splatted sums", SPLAT_ACCUM_BYTES_PER_PIXEL)?;
        let constants = Buffer::device_uniform(
            ctx,
            "splat constants",
            std::mem::size_of::<GpuSplatConstants>() as u64,
        )?;
        let mut kernel = Kernel::new(ctx, gather_shader()?.as_ref())?;
        // Bound from the start (the warm-up dispatches before any gather), to the first strip.
        kernel.bind(&[
            ("splat_constants", &constants),
            ("splat_samples", &samples),
            ("splat_accum", &strips[0]),
        ])?;
        Ok(Splat {
            kernel,
            samples,
            strips,
            constants,
            capacity,
            reach: reach(params),
            params: *params,
        })
    }

    /// Has the driver make the gather's machine code now (see `Renderer::warm_up`): one dispatch with
    /// zero constants, whose one invocation returns at once (its pixel is outside an empty image).
    pub fn warm_up(&mut self) -> Result<(), GpuError> {
        let empty = GpuSplatConstants::default();
        self.kernel.submit(&[
            Command::Update(&self.constants, bytemuck::bytes_of(&empty)),
            Command::Dispatch {
                invocations: [1, 1, 1],
            },
        ])
    }

    /// Clears the splatted sums.
    pub fn zero(&mut self) -> Result<(), GpuError> {
        let zero: Vec<Command> = self.strips.iter().map(Command::Zero).collect();
        self.kernel.submit(&zero)
    }

    /// Adds the records of the pass just traced (`count` samples of every pixel) to every strip's sums.
    pub fn gather(&mut self, layout: &TileLayout, count: u32) -> Result<(), GpuError> {
        let p = self.params;
        let chunk = gather_chunk(self.reach);
        for (i, rows) in layout.strips.iter().enumerate() {
            self.kernel.bind(&[
                ("splat_constants", &self.constants),
                ("splat_samples", &self.samples),
                ("splat_accum", &self.strips[i]),
            ])?;
            let mut first = 0;
            while first < count {
                let n = chunk.min(count - first);
                let c = GpuSplatConstants {
                    width: p.width,
                    height: p.height,
                    accum_base: rows[0] * p.width,
                    row0: rows[0],
                    row1: rows[1],
                    first,
                    count: n,
                    filter_kind: p.filter_kind,
                    filter_width: p.filter_width,
                    reach: self.reach,
                    _pad: [0; 2],
                };
                self.kernel.submit(&[
                    Command::Update(&self.constants, bytemuck::bytes_of(&c)),
                    Command::Dispatch {
                        invocations: [p.width, rows[1] - rows[0], 1],
                    },
                ])?;
                first += n;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::abi::FILTER_TENT;

    fn params(kind: u32, width: f32) -> GpuParams {
        GpuParams {
            filter_kind: kind,
            filter_width: width,
            ..GpuParams::default()
        }
    }

    #[test]
    fn the_reach_covers_every_pixel_the_filter_can_touch() {
        // Mitsuba's tent (radius 1) reaches the 8 neighbours; its Gaussian (sigma 0.5, radius 2) two
        // pixels each way; a tent narrower than half a pixel only the pixel's own samples.
        assert_eq!(reach(&params(FILTER_TENT, 1.0)), 1);
        assert_eq!(reach(&params(FILTER_GAUSSIAN, 0.5)), 2);
        assert_eq!(reach(&params(FILTER_TENT, 0.4)), 0);
        assert_eq!(reach(&params(FILTER_TENT, 1.5)), 1);
        assert_eq!(reach(&params(FILTER_TENT, 1.51)), 2);
        // Brute force: the farthest sample of pixel q + d from q's centre is |d| - 1/2 away at the
        // nearest, so d is reached exactly when |d| - 1/2 < R.
        for r in [0.3f32, 0.5, 0.9, 1.0, 1.2, 2.0, 2.6] {
            let k = reach(&params(FILTER_TENT, r)) as i32;
            for d in 0..6i32 {
                let touches = (d as f32) - 0.5 < r;
                assert_eq!(d <= k, touches, "r {r} d {d}");
            }
        }
    }

    #[test]
    fn a_gather_dispatch_fits_lavapipes_loop_budget() {
        for k in 0..8 {
            let side = 2 * u64::from(k) + 1;
            let n = u64::from(gather_chunk(k));
            assert!(n >= 1);
            assert!(
                n * (1 + side * (1 + side)) < LAVAPIPE_LOOP_BUDGET,
                "reach {k}"
            );
        }
    }
}
