//! What a render holds on the host per pixel, besides the renderer's own buffers: the film, the images
//! being written, the checkpoint, the AOV layers, the denoiser. The renderer adds it to its device buffers
//! and refuses, before allocating anything, a render the machine's available memory
//! (`crate::memory::available_bytes`) cannot hold.
//!
//! The per-pixel figures are the structures' sizes where they are exact, and measured peaks (maximum
//! resident set, `/usr/bin/time -f %M`, the course scene at 1024² and 2048², the difference divided by
//! the pixels added) where they are not: docs/reliability.md, "Memory", gives the measurements.

use super::tiles::ACCUM_BYTES_PER_PIXEL;

/// The film: mean and variance, three f32 each ([`crate::Film`]).
pub const FILM_BYTES_PER_PIXEL: u64 = 24;

/// Writing the images: the 8-bit or f32 planes being encoded and the encoded bytes (measured: a PNG
/// 16 bytes a pixel, an EXR with its variance layer 58).
pub const IMAGE_BYTES_PER_PIXEL: u64 = 64;

/// Writing or reading a checkpoint: the state (96 bytes a pixel) and its compressed bytes (measured 20
/// to 30 % of it on rendered images; at most as large again on noise no image has).
pub const CHECKPOINT_BYTES_PER_PIXEL: u64 = ACCUM_BYTES_PER_PIXEL + ACCUM_BYTES_PER_PIXEL / 3;

/// An `--aov` layer (albedo, normal, depth) kept for the EXR: its film.
pub const AOV_LAYER_BYTES_PER_PIXEL: u64 = FILM_BYTES_PER_PIXEL;

/// Denoising (`--denoise`): OIDN's four images (color, albedo, normal, output; 12 bytes each), the
/// decoded normals, the denoised film and the raw layers for the EXR, and above all OIDN's own scratch for
/// its network's activations. Measured (course scene, 1 spp, peak resident set with and without
/// `--denoise`): +240 MB at 512², +664 MB at 1024², +2722 MB at 2048², 654 bytes a pixel between the last
/// two (docs/denoising.md); rounded up.
pub const DENOISE_BYTES_PER_PIXEL: u64 = 700;

/// What a render keeps on the host besides the renderer's own buffers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostUse {
    /// Image files are written (at the end, and at every `--progress-every`).
    pub images: bool,
    /// A checkpoint is written or resumed.
    pub checkpoint: bool,
    /// `--aov` layers rendered after the image (albedo, normal, depth; not variance, which is the
    /// render's own): each is a film kept until the EXR is written, rendered by a renderer of its own
    /// (another accumulator while it runs).
    pub aov_layers: u32,
    /// The final image is denoised.
    pub denoise: bool,
}

impl HostUse {
    /// Bytes per pixel the host holds for this use, outside the renderer (whose device buffers are
    /// counted by the renderer, as host memory on a device that has no other: a CPU).
    pub fn bytes_per_pixel(&self) -> u64 {
        let mut b = FILM_BYTES_PER_PIXEL;
        if self.images {
            b += IMAGE_BYTES_PER_PIXEL;
        }
        if self.checkpoint {
            b += CHECKPOINT_BYTES_PER_PIXEL;
        }
        if self.aov_layers > 0 {
            // The layer renderer's accumulator and film while it runs, and each layer's film after.
            b += ACCUM_BYTES_PER_PIXEL
                + FILM_BYTES_PER_PIXEL
                + u64::from(self.aov_layers) * AOV_LAYER_BYTES_PER_PIXEL;
        }
        if self.denoise {
            b += DENOISE_BYTES_PER_PIXEL;
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_use_adds_its_bytes() {
        let film = HostUse::default().bytes_per_pixel();
        assert_eq!(film, 24);
        let all = HostUse {
            images: true,
            checkpoint: true,
            aov_layers: 3,
            denoise: true,
        };
        assert_eq!(
            all.bytes_per_pixel(),
            24 + 64 + 128 + 96 + 24 + 72 + DENOISE_BYTES_PER_PIXEL
        );
    }
}
