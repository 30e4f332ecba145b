//! Adaptive sampling (`render.adaptive`, `--adaptive`): after a minimum number of samples, each pixel
//! keeps sampling only while its estimated error is above a threshold, and the passes go to the pixels
//! still sampling, listed for the kernel (trace.wgsl, `active_pixels`) so that a pixel that has stopped
//! costs nothing on the device.
//!
//! The rule, checked every `min_spp` samples (at `min_spp`, `2 min_spp`, ...): pixel p with mean m_p
//! (the mean of its three channels) has the error
//!
//! ```text
//!     e_p = sqrt(V_p) / max(m_p, M),    V_p = mean over the 3x3 window W(p) of v_q
//! ```
//!
//! where v_q = s_q^2 / n_q is the estimated variance of pixel q's mean (the mean over channels of each
//! channel's unbiased sample variance over its n_q samples, [`crate::film::Film`]) and M the image's mean
//! (all pixels and channels). The denominator makes e_p relative to the pixel's own value where it is
//! brighter than the image and to the image's mean where it is darker, so that dark pixels do not
//! sample on for a relative precision nobody sees, and a render whose every pixel met the threshold
//! meets `--target-error`'s own measure as well ([`Film::estimated_rel_error`]: the root of the mean of
//! v_p, over M). The variance is pooled over the window because a variance estimated from 16 samples is
//! itself noisy (its relative error is about sqrt(2 / (n - 1)) for Gaussian noise and far worse for
//! heavy tails), and neighbouring pixels see much the same light. A pixel then stops when e_q <=
//! threshold for every still-sampling q in its 3x3 neighbourhood: the dilation that Cycles applies to
//! its convergence mask (intern/cycles/kernel/film/adaptive_sampling.h), which keeps a pixel sampling
//! while its neighbours do. A pixel that has stopped never starts again, so every pixel's samples are
//! the first n_p of its sequence (indices 0..n_p), as for a render without adaptive sampling, and n_p
//! is the sample count at which it stopped.
//!
//! What it cannot see: light that arrives through rare paths (a caustic seen on a diffuse wall, a
//! small light reached through a mirror) gives a pixel a large variance that its first samples may not
//! show at all; such a pixel can stop with an error well above the threshold (docs/speed-vs-accuracy.md
//! measures it). A higher `render.adaptive_min_samples` is the remedy.
//!
//! Consistent, not unbiased. A pixel's stopping time depends on its own samples, and the mean of
//! samples at such a time is biased (optional stopping: E[S_tau / tau] need not be the mean, though
//! E[S_tau] = E[tau] mu by Wald's identity; Kirk and Arvo, "Unbiased sampling techniques for image
//! synthesis", SIGGRAPH 1991): a pixel whose first samples missed a rare bright path looks calm and
//! stops a little dark, one whose samples caught it goes on and averages it down. Cycles' adaptive
//! sampling has the same bias. The image converges as the threshold goes to 0 (every pixel then samples
//! on to the render's samples). Deciding from the neighbours' samples alone removes the
//! bias to first order, and was tried: on the course's box it gave 1.1x the equal-time efficiency of
//! plain sampling where this rule gives 2.3x, because the pixel that drew a firefly is exactly the one
//! that needs more samples. Measured here: the pixels that stopped at 16 samples on Bitterli's
//! veach-mis sum to 0.1 % below the reference (z about -1.5, 256x144, 64 spp, threshold 0.05), and
//! tests/adaptive.rs holds block and image means within 4 and 3 standard errors of a reference.
//!
//! Deterministic: the checks fall at fixed sample counts (the progressive loop cuts its passes to land
//! on them), and read the exact sums and the Kahan pairs of squares, which do not depend on passes,
//! tiles or the kernel; so the pixels' counts, and the image, are the same bits for a given seed however
//! the render is cut into passes. A checkpoint carries each pixel's count and whether it still samples
//! (a pixel stopped at the check at n has n samples too), so a resume gives the same bits; a
//! `--sample-range` part cannot know what the samples before it decided, so a partial render is refused
//! with adaptive sampling on.

use crate::film::Film;
use crate::gpu::{Buffer, GpuContext, GpuError};
use std::sync::Arc;

/// What adaptive sampling aims for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// The error e_p (see the module's documentation) below which a pixel stops.
    pub threshold: f64,
    /// Samples every pixel takes before any stops; the checks then fall every `min_spp` samples.
    pub min_spp: u32,
}

impl AdaptiveSettings {
    /// The settings when the scene (with the command line's overrides) turns adaptive sampling on: its
    /// threshold, else the target error's (`--target-error`), else the default; `None` when off.
    pub fn asked(asked: &crate::scene::Adaptive, target_error: Option<f64>) -> Option<Self> {
        (asked.on == Some(true)).then(|| AdaptiveSettings {
            threshold: asked
                .threshold
                .or(target_error)
                .unwrap_or(DEFAULT_THRESHOLD),
            min_spp: asked.min_samples.unwrap_or(DEFAULT_MIN_SPP),
        })
    }
}

/// Default `render.adaptive_threshold`: Cycles' default noise threshold.
pub const DEFAULT_THRESHOLD: f64 = 0.01;

/// Default `render.adaptive_min_samples`: as few as keep the variance estimates from being too noisy to
/// trust (the same count as `--target-error`'s [`super::TARGET_ERROR_MIN_SPP`]).
pub const DEFAULT_MIN_SPP: u32 = 16;

/// A render's adaptive state: each pixel's samples, and the pixels still sampling.
pub struct Adaptive {
    pub settings: AdaptiveSettings,
    width: u32,
    /// Samples taken by each pixel (row-major).
    counts: Vec<u32>,
    /// The pixels still sampling, row-major indices, ascending.
    active: Vec<u32>,
    /// `active` on the device (trace.wgsl's `active_pixels`), host-written.
    pub(super) list: Buffer,
    /// The samples (summed over the pixels) put back from a checkpoint ([`Adaptive::restore`]).
    restored: u64,
}

impl Adaptive {
    pub fn new(
        ctx: &Arc<GpuContext>,
        settings: AdaptiveSettings,
        width: u32,
        height: u32,
    ) -> Result<Adaptive, GpuError> {
        let pixels = width as usize * height as usize;
        let mut list = Buffer::host_storage(ctx, "active pixels", 4 * pixels.max(1) as u64)?;
        let active: Vec<u32> = (0..pixels as u32).collect();
        list.write(bytemuck::cast_slice(&active))?;
        Ok(Adaptive {
            settings,
            width,
            counts: vec![0; pixels],
            active,
            list,
            restored: 0,
        })
    }

    /// Back to no samples, every pixel sampling (the list rewritten in place: the kernel keeps its
    /// binding).
    pub fn clear(&mut self) -> Result<(), GpuError> {
        self.counts.fill(0);
        self.active = (0..self.counts.len() as u32).collect();
        self.restored = 0;
        self.list.write(bytemuck::cast_slice(&self.active))
    }

    /// Samples taken by each pixel, row-major.
    pub fn counts(&self) -> &[u32] {
        &self.counts
    }

    /// The samples, summed over the pixels, that came from a checkpoint.
    pub fn restored_samples(&self) -> u64 {
        self.restored
    }

    /// The pixels still sampling (row-major indices, ascending).
    pub fn active(&self) -> &[u32] {
        &self.active
    }

    /// Whether the render checks for converged pixels once `done` samples are in (a multiple of
    /// `min_spp`).
    pub fn checks_at(&self, done: u32) -> bool {
        let m = self.settings.min_spp.max(1);
        done >= m && done.is_multiple_of(m)
    }

    /// The pixels of rows `rows[0]..rows[1]` still sampling: a range of [`Adaptive::active`].
    pub fn active_in_rows(&self, rows: [u32; 2]) -> std::ops::Range<usize> {
        let lo = rows[0] * self.width;
        let hi = rows[1] * self.width;
        let a = self.active.partition_point(|&p| p < lo);
        let b = self.active.partition_point(|&p| p < hi);
        a..b
    }

    /// Counts `spp` more samples for every pixel still sampling (after a pass traced them).
    pub fn add_samples(&mut self, spp: u32) {
        for &p in &self.active {
            self.counts[p as usize] += spp;
        }
    }

    /// Stops the pixels that have converged (see the module's documentation), given the film of the
    /// samples so far; returns how many are still sampling.
    pub fn stop_converged(&mut self, film: &Film) -> Result<usize, GpuError> {
        let still = converged_mask(film, &self.active, self.settings.threshold);
        let (w, h) = (film.width as i64, film.height as i64);
        // 3x3 dilation of "not converged" over the pixels still sampling.
        self.active.retain(|&p| {
            let (x, y) = ((p % film.width) as i64, (p / film.width) as i64);
            (y - 1..=y + 1).any(|yy| {
                (x - 1..=x + 1).any(|xx| {
                    (0..w).contains(&xx) && (0..h).contains(&yy) && still[(yy * w + xx) as usize]
                })
            })
        });
        self.list.write(bytemuck::cast_slice(&self.active))?;
        Ok(self.active.len())
    }

    /// Each pixel's `[samples, 1 if still sampling else 0]`: what a checkpoint keeps.
    pub fn state(&self) -> Vec<[u32; 2]> {
        let mut out: Vec<[u32; 2]> = self.counts.iter().map(|&n| [n, 0]).collect();
        for &p in &self.active {
            out[p as usize][1] = 1;
        }
        out
    }

    /// Puts a checkpoint's [`Adaptive::state`] back, `done` samples into the render. Refuses a state of
    /// the wrong length, or one in which a pixel still sampling has other than `done` samples or any
    /// pixel more.
    pub fn restore(&mut self, state: &[[u32; 2]], done: u32) -> Result<(), GpuError> {
        if state.len() != self.counts.len()
            || state
                .iter()
                .any(|&[n, on]| n > done || on > 1 || (on == 1 && n != done))
        {
            return Err(GpuError::Usage(format!(
                "restore of {} adaptive sample counts that do not fit a render of {} pixels at {done} \
                 samples",
                state.len(),
                self.counts.len()
            )));
        }
        self.counts = state.iter().map(|p| p[0]).collect();
        self.restored = self.counts.iter().map(|&n| u64::from(n)).sum();
        self.active = (0..state.len() as u32)
            .filter(|&p| state[p as usize][1] == 1)
            .collect();
        self.list.write(bytemuck::cast_slice(&self.active))?;
        Ok(())
    }
}

/// Per pixel: true where the pixel is still sampling and its error is above `threshold` (or not yet
/// known: NaN), so that it and its neighbours go on.
fn converged_mask(film: &Film, active: &[u32], threshold: f64) -> Vec<bool> {
    let image_mean = film.average();
    let mut going = vec![false; film.mean.len()];
    let (w, h) = (film.width as usize, film.height as usize);
    let var = |i: usize| film.variance[i].iter().map(|&v| f64::from(v)).sum::<f64>() / 3.0;
    for &p in active {
        let p = p as usize;
        let m = film.mean[p].iter().map(|&v| f64::from(v)).sum::<f64>() / 3.0;
        // The variance pooled over the 3x3 window (clipped at the edges).
        let (x, y) = (p % w, p / w);
        let (mut sum, mut k) = (0.0, 0.0);
        for yy in y.saturating_sub(1)..(y + 2).min(h) {
            for xx in x.saturating_sub(1)..(x + 2).min(w) {
                sum += var(yy * w + xx);
                k += 1.0;
            }
        }
        let v = sum / k;
        let scale = m.max(image_mean);
        let error = if v == 0.0 {
            0.0
        } else if scale > 0.0 {
            v.sqrt() / scale
        } else {
            f64::INFINITY
        };
        // NaN (fewer than 2 samples) keeps going.
        going[p] = error.is_nan() || error > threshold;
    }
    going
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(mean: Vec<[f32; 3]>, variance: Vec<[f32; 3]>, width: u32) -> Film {
        let height = mean.len() as u32 / width;
        Film {
            width,
            height,
            spp: 16,
            pixel_spp: Vec::new(),
            mean,
            variance,
        }
    }

    #[test]
    fn error_is_the_pooled_deviation_over_the_brighter_of_pixel_and_image() {
        // A 4x1 image of means 0.5, 0.5, 1.5, 1.5 (image mean M = 1) and variances a, a, b, b with
        // a = 0.02^2, b = 0.006^2. Pooled over each pixel's window (clipped at the ends) and divided by
        // max(m, M): pixel 0: sqrt(a) / 1 = 0.02; pixel 1: sqrt((2a + b) / 3) / 1 = 0.0167; pixel 2:
        // sqrt((a + 2b) / 3) / 1.5 = 0.0084; pixel 3: sqrt(b) / 1.5 = 0.004. Threshold 0.01.
        let (a, b) = (0.02f32 * 0.02, 0.006f32 * 0.006);
        let f = film(
            vec![[0.5; 3], [0.5; 3], [1.5; 3], [1.5; 3]],
            vec![[a; 3], [a; 3], [b; 3], [b; 3]],
            4,
        );
        assert_eq!(
            converged_mask(&f, &[0, 1, 2, 3], 0.01),
            vec![true, true, false, false]
        );
        // A stopped pixel is never "going", whatever its error.
        assert_eq!(
            converged_mask(&f, &[2, 3], 0.01),
            vec![false, false, false, false]
        );
    }

    #[test]
    fn nan_variance_keeps_a_pixel_going() {
        let f = film(vec![[1.0; 3]], vec![[f32::NAN; 3]], 1);
        assert_eq!(converged_mask(&f, &[0], 0.5), vec![true]);
    }
}
