//! `vkpath compare A B`: whether two images hold the same pixels, and how far apart they are if not.
//!
//! Files of the same render are not byte-identical when their metadata differ (a merged farm render and
//! a single render record different seconds and devices), so "the same image" is decided on the pixels:
//! the linear values of an EXR's R, G and B (as f32 bits), or the bytes of a PNG. Exit status as `cmp`:
//! 0 the same pixels, 1 different pixels, 2 a file that cannot be read or images of different sizes.

use super::report::print_json;
use super::usage;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};
use vkpath::Error;

#[derive(Args)]
pub struct CompareArgs {
    /// The image compared (.png or .exr).
    a: PathBuf,
    /// The image it is compared with, the reference for the relative error.
    b: PathBuf,
    /// Print one JSON object instead of a line.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct CompareReport {
    identical: bool,
    width: u32,
    height: u32,
    /// Channel values (3 per pixel) whose bits differ.
    differing_values: usize,
    max_abs_difference: f64,
    /// sqrt(mean squared difference) / mean(B), over every channel value.
    rel_rmse: f64,
}

/// An image's RGB values as f32 (EXR: linear; PNG: the 8-bit values as 0..255).
fn read(path: &Path) -> Result<(u32, u32, Vec<f32>), Error> {
    let image = image::open(path).map_err(|e| {
        usage(format!(
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

pub fn run_compare(c: CompareArgs) -> Result<i32, Error> {
    let (wa, ha, a) = read(&c.a)?;
    let (wb, hb, b) = read(&c.b)?;
    if (wa, ha) != (wb, hb) {
        return Err(usage(format!(
            "{} is {wa}x{ha} and {} is {wb}x{hb}: only images of the same size can be compared.",
            c.a.display(),
            c.b.display()
        )));
    }
    let differing = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    let (mut max, mut sq, mut sum_b) = (0f64, 0f64, 0f64);
    for (&x, &y) in a.iter().zip(&b) {
        let d = (f64::from(x) - f64::from(y)).abs();
        max = max.max(d);
        sq += d * d;
        sum_b += f64::from(y);
    }
    let n = a.len().max(1) as f64;
    let report = CompareReport {
        identical: differing == 0,
        width: wa,
        height: ha,
        differing_values: differing,
        max_abs_difference: max,
        rel_rmse: (sq / n).sqrt() / (sum_b / n),
    };
    if c.json {
        print_json(&report);
    } else if report.identical {
        println!(
            "{} and {}: the same pixels ({wa}x{ha})",
            c.a.display(),
            c.b.display()
        );
    } else {
        println!(
            "{} and {}: {differing} of {} values differ; largest difference {max:e}, relative RMSE {:e}",
            c.a.display(),
            c.b.display(),
            a.len(),
            report.rel_rmse
        );
    }
    Ok(if report.identical { 0 } else { 1 })
}
