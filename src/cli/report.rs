//! The `--json` reports: one object on stdout when a command ends (contract: docs/cli.md). Their keys
//! and values are the contract; `vkpath render`'s report is the library's `session::RenderReport` (the
//! Python module returns the same), `vkpath preview`'s the library's own `PreviewReport`.

use serde::Serialize;
use std::path::PathBuf;
use vkpath::gpu::context::DeviceInfo;

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
