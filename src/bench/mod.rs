//! Benchmarks that report measured ratios (`vkpath bench ...`). Nothing here asserts a time: the numbers
//! are printed for the README and for people comparing machines.
//!
//! This module holds what the timing benchmarks share (their settings, the timed passes, the median, the
//! scene files of a directory); each benchmark is one submodule.

pub mod convergence;
pub mod mesh;
pub mod specialisation;
pub mod throughput;

use crate::Error;
use crate::render::Renderer;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Image size, samples per pixel of each timed pass, and how many timed passes per variant.
#[derive(Clone, Copy, Debug)]
pub struct BenchSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub runs: u32,
}

/// The median of `v` (NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One timed pass: its wall-clock seconds, and the CPU seconds the whole process spent meanwhile (user
/// and system, all threads; `None` where getrusage is not available). On a CPU driver such as lavapipe
/// the CPU time is the work the pass took: unlike the wall clock it does not grow when other programs
/// share the cores, so it compares two builds on a busy machine.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassTime {
    pub wall: f64,
    pub cpu: Option<f64>,
}

/// The CPU seconds (user + system, every thread) this process has used so far.
pub fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        // SAFETY: getrusage writes a plain struct we own; RUSAGE_SELF is always a valid target.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
            return None;
        }
        let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Each of `settings.runs` timed passes of `settings.spp` samples per pixel, per renderer, after one
/// untimed warm-up pass each, interleaved across the renderers.
pub fn pass_times(
    renderers: &mut [Renderer],
    settings: BenchSettings,
) -> Result<Vec<Vec<PassTime>>, Error> {
    let mut times = vec![Vec::new(); renderers.len()];
    // One untimed pass each: the driver may finish compiling on first use.
    for r in renderers.iter_mut() {
        r.run_pass(1)?;
    }
    for run in 0..settings.runs {
        for k in 0..renderers.len() {
            // Rotate the order each run so that a slow moment of the machine hits every variant alike.
            let i = (k + run as usize) % renderers.len();
            let r = &mut renderers[i];
            r.reset()?;
            let cpu0 = process_cpu_seconds();
            let t0 = Instant::now();
            r.run_pass(settings.spp)?;
            let wall = t0.elapsed().as_secs_f64();
            let cpu = process_cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
            times[i].push(PassTime { wall, cpu });
        }
    }
    Ok(times)
}

/// The scene files of a directory, sorted by name.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    // Reading, not writing: the scene directory is the user's input (a usage error, exit 2).
    let entries = std::fs::read_dir(dir).map_err(|e| {
        Error::Usage(format!(
            "cannot read the scene directory {}: {e}. Run from the directory that holds scenes/, or \
             name the scene files on the command line.",
            dir.display()
        ))
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    Ok(files)
}
