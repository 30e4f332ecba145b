//! The film: per-pixel means and variances read back from the GPU, and the display transform. Image
//! files are written by `crate::output` (`Film::write` included).

use crate::kernel::abi::{GpuAccum, GpuSplatAccum, SPLAT_WEIGHT_BITS};
use crate::scene::{Gamma, ImageSettings};
use std::path::Path;

/// Linear radiance per pixel, row-major from the top-left, with the variance of each pixel's estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel behind each mean (with adaptive sampling, the most any pixel took).
    pub spp: u32,
    /// With adaptive sampling (`render.adaptive`), the samples behind each pixel's mean, row-major;
    /// empty when every pixel has `spp`.
    pub pixel_spp: Vec<u32>,
    /// Mean radiance (the estimate), RGB.
    pub mean: Vec<[f32; 3]>,
    /// Estimated variance of each mean: s^2 / n with s^2 the unbiased sample variance; NaN when n < 2.
    pub variance: Vec<[f32; 3]>,
}

/// The sRGB transfer curve (IEC 61966-2-1) of a linear value in [0, 1]: 12.92 v up to 0.0031308, then
/// 1.055 v^(1/2.4) - 0.055.
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// An output format, from the file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Exr,
}

impl OutputFormat {
    pub fn from_path(path: &Path) -> Option<OutputFormat> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "png" => Some(OutputFormat::Png),
            "exr" => Some(OutputFormat::Exr),
            _ => None,
        }
    }
}

impl Film {
    /// From the GPU's sums: each channel's exact sum (a long accumulator, `crate::accum`) rounded once
    /// to f64, and the Kahan pair of its squares read as s - c in f64.
    pub fn from_sums(width: u32, height: u32, spp: u32, accum: &[GpuAccum]) -> Film {
        let mut film = Film::for_sums(width, height, spp);
        film.push_sums(accum);
        film
    }

    /// A film with no pixels yet, room for `width x height` of them, and `spp` samples behind each: the
    /// renderer fills it strip by strip with [`Film::push_sums`], so that the accumulator (96 bytes a
    /// pixel) is never copied to the host whole.
    pub fn for_sums(width: u32, height: u32, spp: u32) -> Film {
        let pixels = width as usize * height as usize;
        Film {
            width,
            height,
            spp,
            pixel_spp: Vec::new(),
            mean: Vec::with_capacity(pixels),
            variance: Vec::with_capacity(pixels),
        }
    }

    /// Appends the means and variances of `accum`'s pixels (the next ones in row-major order; see
    /// [`Film::from_sums`]).
    pub fn push_sums(&mut self, accum: &[GpuAccum]) {
        for a in accum {
            let spp = self
                .pixel_spp
                .get(self.mean.len())
                .copied()
                .unwrap_or(self.spp);
            let n = spp as f64;
            let mut m = [0f32; 3];
            let mut v = [0f32; 3];
            for c in 0..3 {
                let s = crate::accum::to_f64(&crate::accum::channel(a, c));
                let sq = a.sum_sq[c] as f64 - a.sum_sq_c[c] as f64;
                if spp == 0 {
                    continue;
                }
                let mu = s / n;
                m[c] = mu as f32;
                v[c] = if spp < 2 {
                    f32::NAN
                } else {
                    // Unbiased sample variance, clamped at 0 against rounding, divided by n for the mean.
                    (((sq - n * mu * mu) / (n - 1.0)).max(0.0) / n) as f32
                };
            }
            self.mean.push(m);
            self.variance.push(v);
        }
    }

    /// Replaces the means of the pixels from index `at` on by a splatted render's (`render.splat`): per
    /// channel the exact sum of w L over the exact sum of the weights w, each rounded once to f64 (the
    /// filter-weighted average of the samples around the pixel, Mitsuba 3's film). A pixel that no sample
    /// weighed (possible only under a filter narrower than its pixel) keeps its own samples' mean. The
    /// variances stay those of the pixel's own samples: the error estimate is that of the per-pixel
    /// estimator, an upper bound for the splatted one (docs/speed-vs-accuracy.md, "Splatting").
    pub fn push_splatted(&mut self, at: usize, splat: &[GpuSplatAccum]) {
        for (m, s) in self.mean[at..].iter_mut().zip(splat) {
            let w = (u64::from(s.weight[1]) << 32 | u64::from(s.weight[0])) as f64
                / f64::from(1u32 << SPLAT_WEIGHT_BITS);
            if w <= 0.0 {
                continue;
            }
            for (c, v) in m.iter_mut().enumerate() {
                let sum = crate::accum::to_f64(&crate::accum::sums_channel(&s.sum, c));
                *v = (sum / w) as f32;
            }
        }
    }

    /// The samples behind pixel `i`'s (row-major) mean.
    pub fn samples_of(&self, i: usize) -> u32 {
        self.pixel_spp.get(i).copied().unwrap_or(self.spp)
    }

    /// The mean radiance of pixel (x, y), (0, 0) the top-left.
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        self.mean[(y * self.width + x) as usize]
    }

    /// Mean over all pixels and channels.
    pub fn average(&self) -> f64 {
        let total: f64 = self
            .mean
            .iter()
            .flat_map(|p| p.iter())
            .map(|&v| v as f64)
            .sum();
        total / (self.mean.len() * 3).max(1) as f64
    }

    /// Estimated relative error of the image against the converged one:
    /// sqrt(mean over pixels and channels of Var[pixel estimate]) / mean(image). NaN below 2 spp or for a
    /// black image.
    pub fn estimated_rel_error(&self) -> f64 {
        let var: f64 = self
            .variance
            .iter()
            .flat_map(|p| p.iter())
            .map(|&v| v as f64)
            .sum();
        let var = var / (self.variance.len() * 3).max(1) as f64;
        let mean = self.average();
        if !var.is_finite() || mean <= 0.0 {
            f64::NAN
        } else {
            var.sqrt() / mean
        }
    }

    /// The 8-bit display image: v = tonemap(exposure L) (the course's: clamp to [0, 1]), then v^(1/gamma)
    /// or the sRGB curve.
    pub fn to_rgb8(&self, settings: &ImageSettings) -> image::RgbImage {
        let transfer = |v: f32| -> u8 {
            let v = settings.tonemap.apply(v * settings.exposure);
            let v = if v.is_nan() { 0.0 } else { v };
            let encoded = match settings.gamma {
                Gamma::Power(g) => v.powf(1.0 / g),
                Gamma::Srgb => srgb_encode(v),
            };
            (encoded * 255.0).round().clamp(0.0, 255.0) as u8
        };
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let p = self.pixel(x, y);
            image::Rgb([transfer(p[0]), transfer(p[1]), transfer(p[2])])
        })
    }

    /// The linear float image (no exposure, no gamma): what the estimator computed.
    pub fn to_rgb32f(&self) -> image::Rgb32FImage {
        image::Rgb32FImage::from_fn(self.width, self.height, |x, y| image::Rgb(self.pixel(x, y)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Tonemap;

    /// Narkowicz's ACES fit at known points: f(0) = 0, f(1) = 2.54 / 3.16, f(0.18) (middle grey), the value
    /// where it reaches 1 (the root of 0.08 x^2 - 0.56 x - 0.14), monotonic in between, clamped beyond;
    /// "none" is the course's clamp.
    #[test]
    fn aces_tonemap_known_values() {
        let f = |x: f32| Tonemap::Aces.apply(x) as f64;
        assert_eq!(f(0.0), 0.0);
        assert!((f(1.0) - 2.54 / 3.16).abs() < 1e-6, "{}", f(1.0));
        let g = 0.18f64;
        let want = g * (2.51 * g + 0.03) / (g * (2.43 * g + 0.59) + 0.14);
        assert!((f(0.18) - want).abs() < 1e-6, "{} vs {want}", f(0.18));
        let one = (0.56 + (0.56f64 * 0.56 + 4.0 * 0.08 * 0.14).sqrt()) / 0.16;
        assert!(
            (f(one as f32) - 1.0).abs() < 1e-5,
            "f({one}) = {}",
            f(one as f32)
        );
        assert_eq!(f(100.0), 1.0);
        assert_eq!(f(-1.0), 0.0);
        let mut last = 0.0;
        for k in 1..=1000 {
            let v = f(k as f32 * 0.01);
            assert!(v >= last, "not monotonic at {}", k as f32 * 0.01);
            last = v;
        }
        assert_eq!(Tonemap::None.apply(0.5), 0.5);
        assert_eq!(Tonemap::None.apply(3.0), 1.0);
    }

    /// The PNG byte of radiance 1 with ACES and the sRGB curve is srgb(f(1)), not white as with the clamp.
    #[test]
    fn the_png_goes_through_the_tonemap() {
        let film = Film {
            pixel_spp: Vec::new(),
            width: 1,
            height: 1,
            spp: 1,
            mean: vec![[1.0, 4.0, 0.0]],
            variance: vec![[0.0; 3]],
        };
        let mut settings = ImageSettings {
            width: 1,
            height: 1,
            exposure: 1.0,
            gamma: crate::scene::Gamma::Srgb,
            tonemap: Tonemap::Aces,
            denoise: false,
        };
        let byte = |v: f32| (srgb_encode(v) * 255.0).round() as u8;
        let p = film.to_rgb8(&settings).get_pixel(0, 0).0;
        assert_eq!(
            p,
            [
                byte(Tonemap::Aces.apply(1.0)),
                byte(Tonemap::Aces.apply(4.0)),
                0
            ]
        );
        settings.tonemap = Tonemap::None;
        assert_eq!(film.to_rgb8(&settings).get_pixel(0, 0).0, [255, 255, 0]);
    }
}
