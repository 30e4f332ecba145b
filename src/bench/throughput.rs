//! `vkpath bench throughput`: samples per second of each scene at fixed settings (image size, samples per
//! pixel per timed pass), the median, min and max over several timed passes, and the process's CPU
//! seconds per million samples of its least disturbed pass: on a CPU driver (lavapipe) the work a
//! sample takes, which compares two builds even on a machine whose other tenants make the wall clock
//! vary by tens of percent from one minute to the next.

use super::{BenchSettings, median, pass_times};
use crate::gpu::GpuContext;
use crate::render::{RenderOptions, Renderer};
use crate::{Error, Scene};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;

/// One scene's line: samples/s of each timed pass summarised.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ThroughputRow {
    pub scene: String,
    pub spp: u32,
    pub median_samples_per_second: f64,
    pub min_samples_per_second: f64,
    pub max_samples_per_second: f64,
    /// The fewest CPU seconds (user + system, all threads of the process) per million samples of any
    /// timed pass; `None` where the platform does not report CPU time.
    pub min_cpu_seconds_per_msample: Option<f64>,
}

/// Times `settings.runs` passes of `settings.spp` samples per pixel of each scene (at
/// `settings.width`×`settings.height`, the scene's own specialised kernel and default options), each
/// from a reset accumulator after one untimed warm-up pass.
pub fn throughput(
    ctx: &Arc<GpuContext>,
    scenes: &[PathBuf],
    settings: BenchSettings,
) -> Result<Vec<ThroughputRow>, Error> {
    let samples = f64::from(settings.width) * f64::from(settings.height) * f64::from(settings.spp);
    let mut rows = Vec::new();
    for path in scenes {
        let mut scene = Scene::load(path)?;
        scene.image.width = settings.width;
        scene.image.height = settings.height;
        let renderer = Renderer::new(ctx, &scene, &RenderOptions::default())?;
        let times = pass_times(&mut [renderer], settings)?
            .pop()
            .unwrap_or_default();
        // The fastest pass is the highest rate: min and max swap going from seconds to samples/s.
        let rates: Vec<f64> = times.iter().map(|t| samples / t.wall.max(1e-12)).collect();
        let cpu: Option<Vec<f64>> = times.iter().map(|t| t.cpu).collect();
        let min_cpu = cpu
            .filter(|c| !c.is_empty())
            .map(|c| c.into_iter().fold(f64::INFINITY, f64::min) / (samples / 1e6));
        rows.push(ThroughputRow {
            scene: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            spp: settings.spp,
            median_samples_per_second: median(rates.clone()),
            min_samples_per_second: rates.iter().copied().fold(f64::INFINITY, f64::min),
            max_samples_per_second: rates.iter().copied().fold(0.0, f64::max),
            min_cpu_seconds_per_msample: min_cpu,
        });
    }
    Ok(rows)
}

/// The rows as a Markdown table.
pub fn throughput_table(rows: &[ThroughputRow], settings: BenchSettings, device: &str) -> String {
    let mut out = format!(
        "Throughput, {}x{}, {} spp per timed pass, {} runs, on {device}.\n\n\
         | scene | spp | Msamples/s median | min | max | CPU s/Msample (min) |\n\
         | --- | ---: | ---: | ---: | ---: | ---: |\n",
        settings.width, settings.height, settings.spp, settings.runs
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {} |",
            r.scene,
            r.spp,
            r.median_samples_per_second / 1e6,
            r.min_samples_per_second / 1e6,
            r.max_samples_per_second / 1e6,
            r.min_cpu_seconds_per_msample
                .map_or("-".into(), |c| format!("{c:.4}"))
        );
    }
    out
}
