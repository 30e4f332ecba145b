//! Whether two images hold the same pixels, and how far apart they are if not: `vkpath compare A B` and
//! the Python module's `vkpath.compare`.
//!
//! Files of the same render are not byte-identical when their metadata differ (a merged farm render and
//! a single render record different seconds and devices), so "the same image" is decided on the pixels:
//! the linear values of an EXR's R, G and B (as f32 bits), or the bytes of a PNG.

use crate::Error;
use serde::Serialize;
use std::path::Path;

/// How two images' values compare (`vkpath compare --json`'s object).
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub identical: bool,
    pub width: u32,
    pub height: u32,
    /// Channel values (3 per pixel) whose bits differ.
    pub differing_values: usize,
    pub max_abs_difference: f64,
    /// sqrt(mean squared difference) / mean(B), over every channel value.
    pub rel_rmse: f64,
}

/// An image file's RGB values as f32 (EXR: linear; PNG: the 8-bit values as 0..255), with its width
/// and height.
pub fn read_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>), Error> {
    let image = image::open(path).map_err(|e| {
        Error::Usage(format!(
            "cannot read the image {}: {e}. vkpath compare reads .png and .exr files.",
            path.display()
        ))
    })?;
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let (w, h) = (image.width(), image.height());
    let values = if is_exr {
        image.to_rgb32f().into_raw()
    } else {
        image
            .to_rgb8()
            .into_raw()
            .into_iter()
            .map(f32::from)
            .collect()
    };
    Ok((w, h, values))
}

/// Compares the values `a` with the reference `b` (the same length) of a `width` x `height` image.
pub fn compare(width: u32, height: u32, a: &[f32], b: &[f32]) -> Comparison {
    let differing = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    let (mut max, mut sq, mut sum_b) = (0f64, 0f64, 0f64);
    for (&x, &y) in a.iter().zip(b) {
        let d = (f64::from(x) - f64::from(y)).abs();
        max = max.max(d);
        sq += d * d;
        sum_b += f64::from(y);
    }
    let n = a.len().max(1) as f64;
    Comparison {
        identical: differing == 0,
        width,
        height,
        differing_values: differing,
        max_abs_difference: max,
        rel_rmse: (sq / n).sqrt() / (sum_b / n),
    }
}
