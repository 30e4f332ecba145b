//! `vkpath compare A B`: whether two images hold the same pixels, and how far apart they are if not
//! (the library's `vkpath::compare`, which the Python module shares). Exit status as `cmp`:
//! 0 the same pixels, 1 different pixels, 2 a file that cannot be read or images of different sizes.

use super::report::print_json;
use super::usage;
use clap::Args;
use std::path::PathBuf;
use vkpath::Error;
use vkpath::compare::{compare, read_rgb};

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

pub fn run_compare(c: CompareArgs) -> Result<i32, Error> {
    let (wa, ha, a) = read_rgb(&c.a)?;
    let (wb, hb, b) = read_rgb(&c.b)?;
    if (wa, ha) != (wb, hb) {
        return Err(usage(format!(
            "{} is {wa}x{ha} and {} is {wb}x{hb}: only images of the same size can be compared.",
            c.a.display(),
            c.b.display()
        )));
    }
    let report = compare(wa, ha, &a, &b);
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
            "{} and {}: {} of {} values differ; largest difference {:e}, relative RMSE {:e}",
            c.a.display(),
            c.b.display(),
            report.differing_values,
            a.len(),
            report.max_abs_difference,
            report.rel_rmse
        );
    }
    Ok(if report.identical { 0 } else { 1 })
}
