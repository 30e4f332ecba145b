//! The `--json` reports: one object on stdout when a command ends (contract: docs/cli.md). Their keys
//! and values are the contract; `vkpath preview`'s report is the library's own `PreviewReport`.

use serde::Serialize;
use std::path::PathBuf;
use vkpath::gpu::context::DeviceInfo;
use vkpath::kernel::features::FeatureSet;
use vkpath::render::StopReason;

/// Prints a report as one line of JSON. It goes through a `serde_json::Value`, whose objects (without
/// serde_json's `preserve_order` feature) keep their keys sorted: every object, nested ones included,
/// comes out with its keys in alphabetical order, as these reports always have, whatever the order of
/// the fields below.
pub fn print_json(report: &impl Serialize) {
    let value = serde_json::to_value(report)
        .expect("a report is plain data with string keys, which always converts to JSON");
    println!("{value}");
}

/// Paths as the user gave them, for a report (`display`: lossy where a name is not UTF-8).
pub fn shown_paths(paths: &[PathBuf]) -> Vec<String> {
    paths.iter().map(|p| p.display().to_string()).collect()
}

/// Which kernel a renderer runs, for reports: specialised and generic kernels give the same bits.
pub fn kernel_name(features: &FeatureSet) -> &'static str {
    if features.is_generic() {
        "generic"
    } else {
        "specialised"
    }
}

/// `vkpath render --json`: what was rendered, how fast, how it ended, and how the work was cut.
#[derive(Serialize)]
pub struct RenderReport<'a> {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel in the image, resumed ones included (with adaptive sampling, the most any
    /// pixel took).
    pub spp: u32,
    /// The mean over the pixels of their samples (`spp` unless adaptive sampling stopped some early).
    pub mean_spp: f64,
    /// Adaptive sampling's threshold and the pixels still sampling when the render ended; `null`
    /// without adaptive sampling.
    pub adaptive: Option<AdaptiveReport>,
    pub seconds: f64,
    /// Samples traced by this run (not the resumed ones) per second.
    pub samples_per_second: f64,
    /// `null` where the film has no estimate: below 2 samples per pixel, or for a black image.
    pub estimated_rel_error: Option<f64>,
    pub device: &'a str,
    /// -1: no limit.
    pub max_bounces: i64,
    pub seed: u32,
    pub stop_reason: StopReason,
    pub outputs: Vec<String>,
    /// How many errors the validation layer reported (VKPATH_VALIDATION).
    pub validation_errors: usize,
    /// Triangles uploaded (an instanced mesh's once, however many placements it has).
    pub triangles: usize,
    /// Placements of instanced meshes (0 in a scene without).
    pub instances: usize,
    pub bvh_nodes: usize,
    pub bvh_build_ms: f64,
    /// [`kernel_name`].
    pub kernel: &'static str,
    pub features_absent: Vec<&'static str>,
    pub sample_ranges: &'a [[u32; 2]],
    pub strips: usize,
    pub tiles_per_sample: usize,
    /// Samples per pixel taken from the checkpoint resumed (0 when none).
    pub resumed_spp: u32,
    pub checkpoint: Option<String>,
    /// Samples of this run that the accumulator clamped (radiance of 2^64 or more) or dropped as not
    /// finite: both 0 in a sane scene (see accumulate.wgsl).
    pub sample_faults: vkpath::render::SampleFaults,
}

/// Adaptive sampling in `vkpath render --json`.
#[derive(Serialize)]
pub struct AdaptiveReport {
    pub threshold: f64,
    pub min_spp: u32,
    /// Pixels still sampling at the end (0 when every pixel met the threshold).
    pub pixels_active: usize,
}

/// `vkpath merge --json`: the merged render and where it was written.
#[derive(Serialize)]
pub struct MergeReport<'a> {
    pub scene: &'a str,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// How many partial renders were merged.
    pub parts: usize,
    pub sample_ranges: &'a [[u32; 2]],
    pub estimated_rel_error: Option<f64>,
    /// The devices that computed the parts, joined by " + ".
    pub device: &'a str,
    pub outputs: Vec<String>,
    pub checkpoint: Option<String>,
}

/// `vkpath bench throughput|specialisation --json`: the device and the benchmark's rows.
#[derive(Serialize)]
pub struct DeviceRows<'a, Row: Serialize> {
    pub device: &'a str,
    pub rows: &'a [Row],
}

/// `vkpath info --json`.
#[derive(Serialize)]
pub struct InfoReport<'a> {
    pub devices: &'a [DeviceInfo],
    /// The index of the device vkpath would use.
    pub chosen: usize,
    /// Why that one, in a sentence.
    pub reason: &'a str,
    /// What `--denoise` would use ("Intel Open Image Denoise 2.5.1 (PATH), CPU device"), or null.
    pub denoiser: Option<&'a str>,
    /// Why denoising is not available, when it is not.
    pub denoiser_missing: Option<&'a str>,
}
