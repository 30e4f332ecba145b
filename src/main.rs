//! The `vkpath` command line (contract: docs/cli.md). Parses flags, calls the library, maps errors to
//! exit codes: 0 success, 2 bad input (scene, flags), 1 anything else.

use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;
use vkpath::checkpoint::Checkpoint;
use vkpath::gpu::{ContextOptions, GpuContext};
use vkpath::render::{
    Budget, Fault, RenderOptions, Renderer, SaveEvery, StopReason, render_progressive,
};
use vkpath::{Error, Scene};

#[derive(Parser)]
#[command(
    name = "vkpath",
    version,
    about = "A physically based path tracer on Vulkan compute"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the embedded course scene when none is given) to PNG/EXR.
    Render(Box<RenderArgs>),
    /// Open a window and watch the render converge (cargo feature `preview`). Keys: S saves the image
    /// (PNG + EXR), R restarts, Esc/Q quits; drag with the left button to orbit the camera.
    Preview(Box<PreviewArgs>),
    /// Combine partial renders (checkpoints of disjoint --sample-range's) into the image of their union.
    Merge(MergeArgs),
    /// Benchmarks that report measured ratios.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// List the Vulkan devices, the one chosen and why, and its limits.
    Info {
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Error against a reference vs time for each knob setting, at doubling spp: a CSV, a log-log PNG
    /// and a Markdown table of the time to reach 5%, 2% and 1% relative error.
    Convergence(ConvergenceArgs),
    /// Samples/s of each scene in ./scenes at fixed settings (median, min, max of several passes).
    Throughput {
        /// Scene files (default: every .toml in ./scenes).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 128)]
        width: u32,
        #[arg(long, default_value_t = 128)]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Timed passes per scene.
        #[arg(long, default_value_t = 5)]
        runs: u32,
        /// Print the rows as JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Samples/s and BVH build time for generated meshes of growing size in the course's box, and
    /// BVH vs brute force on the smaller ones, as a Markdown table.
    Mesh {
        /// Triangle counts (default 1000 10000 100000 1000000).
        sizes: Vec<usize>,
        #[arg(long, default_value_t = 128)]
        width: u32,
        #[arg(long, default_value_t = 128)]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 8)]
        spp: u32,
        /// Timed passes per mesh (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: u32,
        /// Also time brute force (no BVH) for meshes up to this many triangles.
        #[arg(long = "brute-force-up-to", default_value_t = 10_000)]
        brute_force_up_to: usize,
    },
    /// Samples/s of each scene with its specialised kernel, the generic kernel and (for diffuse/point-light
    /// scenes) a hand-trimmed kernel, as a Markdown table.
    Specialisation {
        /// Scene files (default: every .toml in ./scenes).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 128)]
        width: u32,
        #[arg(long, default_value_t = 128)]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Timed passes per kernel (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: u32,
        /// Print the rows as JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Instead, measure what each absent feature's absence gains (one kernel per feature put back).
        #[arg(long)]
        ablation: bool,
    },
}

/// `--sampler` (render.sampler in the scene file).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum SamplerArg {
    Independent,
    Sobol,
}

/// `--light-sampling` (render.light_sampling in the scene file).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum LightSamplingArg {
    Cone,
    Area,
    None,
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// Output file; repeatable; the format follows the extension (.png, .exr). Default: <scene-stem>.png.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Samples per pixel (overrides the scene); with --time, the upper bound.
    #[arg(long)]
    spp: Option<u32>,
    /// Stop after the first pass that ends past this many seconds.
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f64>,
    /// Stop when the estimated relative error of the image falls below E (checked after each pass from
    /// 16 spp on; the scene's samples, or --spp, stays the upper bound).
    #[arg(long = "target-error", allow_negative_numbers = true)]
    target_error: Option<f64>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    seed: Option<u32>,
    /// Image width in pixels (overrides the scene).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long)]
    height: Option<u32>,
    /// Scattering events per path (overrides the scene).
    #[arg(long = "max-bounces")]
    max_bounces: Option<u32>,
    /// Where random numbers come from (overrides the scene's render.sampler).
    #[arg(long, value_enum)]
    sampler: Option<SamplerArg>,
    /// How sphere lights are sampled (overrides the scene's render.light_sampling).
    #[arg(long = "light-sampling", value_enum)]
    light_sampling: Option<LightSamplingArg>,
    /// Rewrite the outputs after every N samples per pixel.
    #[arg(long = "progress-every")]
    progress_every: Option<u32>,
    /// Print one JSON object on stdout when the render ends.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Samples per pixel in each pass (default: adapted to about a quarter second per pass).
    #[arg(long = "samples-per-pass")]
    samples_per_pass: Option<u32>,
    /// Start Russian roulette after this many bounces ("off" disables it). Default 3.
    #[arg(long = "roulette-depth")]
    roulette_depth: Option<String>,
    /// Run the one all-features kernel instead of the kernel specialised for this scene.
    #[arg(long)]
    generic: bool,
    /// Save the accumulation state to this file (atomically) every --checkpoint-every, and when the
    /// render ends or is interrupted (Ctrl-C, SIGTERM).
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// How often to save the checkpoint: N samples per pixel, or a duration such as 30s, 10m, 1h.
    /// Default: 60s.
    #[arg(long = "checkpoint-every")]
    checkpoint_every: Option<String>,
    /// Go on from a checkpoint of this render (same scene, flags and vkpath version), to the same bits
    /// as a render that never stopped. New checkpoints go to this file unless --checkpoint names another.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Render only the sample indices A..B (A included, B excluded) of every pixel: a partial render,
    /// to be combined with `vkpath merge` (save it with --checkpoint).
    #[arg(long = "sample-range")]
    sample_range: Option<String>,
    /// Cut the image into tiles of at most WxH pixels (one dispatch each) and strips of at most H rows
    /// (one accumulator buffer each), instead of the adaptive cut. The image is the same.
    #[arg(long)]
    tile: Option<String>,
    /// Target duration of one dispatch in milliseconds (default 100): tiles adapt so that a dispatch
    /// stays well under a desktop GPU's watchdog. The image is the same.
    #[arg(long = "dispatch-ms", allow_negative_numbers = true)]
    dispatch_ms: Option<f64>,
}

#[derive(Args)]
struct ConvergenceArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// A converged linear EXR of the same size to compare with (e.g. the one an earlier run wrote).
    #[arg(long, conflicts_with = "reference_spp")]
    reference: Option<PathBuf>,
    /// Samples per pixel of the reference rendered when --reference is not given.
    #[arg(long = "reference-spp", default_value_t = 4096)]
    reference_spp: u32,
    /// Largest samples per pixel measured (the curve has 1, 2, 4, ... up to it).
    #[arg(long = "max-spp", default_value_t = 256)]
    max_spp: u32,
    #[arg(long, default_value_t = 128)]
    width: u32,
    #[arg(long, default_value_t = 128)]
    height: u32,
    /// Settings to measure, comma-separated: default, or knob=value joined by + (knobs: max_bounces,
    /// roulette, samples_per_pass, sampler, light_sampling).
    #[arg(long, default_value = vkpath::bench::convergence::DEFAULT_KNOBS)]
    knobs: String,
    /// Directory of the CSV, the PNG and the rendered reference.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
}

#[derive(Args)]
// Without the `preview` feature the flags are still parsed and checked, but not all of them are read.
#[cfg_attr(not(feature = "preview"), allow(dead_code))]
struct PreviewArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// Stop accumulating at N samples per pixel (the window stays open). Default: never stop.
    #[arg(long)]
    spp: Option<u32>,
    /// Image width in pixels (overrides the scene); the window shows the image scaled to fit.
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long)]
    height: Option<u32>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    seed: Option<u32>,
    /// Scattering events per path (overrides the scene).
    #[arg(long = "max-bounces")]
    max_bounces: Option<u32>,
    /// Exit after N presents of a rendered image (scripted use; see --json for the spp shown).
    #[arg(long)]
    frames: Option<u64>,
    /// With --frames: save the image shown by the last present as PNG (the same bytes as shown).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Directory where S saves <scene-stem>-<spp>spp.png and .exr. Default: the current directory.
    #[arg(long = "save-dir", default_value = ".")]
    save_dir: PathBuf,
    /// Presents per second the window aims at (the latest image is shown again while passes run).
    #[arg(long, default_value_t = 30.0)]
    fps: f64,
    /// Print one JSON object on stdout when the window closes (spp shown, presents/s, ...).
    #[arg(long)]
    json: bool,
    /// Scripted input for tests: "N:ACTION; ...", ACTION one of `resize WxH`, `restart`,
    /// `orbit AZ EL`, `save`, run after present N.
    #[arg(long, hide = true)]
    script: Option<String>,
}

#[derive(Args)]
struct MergeArgs {
    /// Partial renders: checkpoint files written by `vkpath render --sample-range A..B --checkpoint FILE`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output image; repeatable; .png or .exr.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Also write the merged state as a checkpoint (to merge further, or resume with more samples).
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// Print one JSON object on stdout when done.
    #[arg(long)]
    json: bool,
}

fn usage(msg: impl Into<String>) -> Error {
    Error::Usage(msg.into())
}

/// Applies the command-line overrides to the scene and checks them as the scene file's rules would.
fn apply_overrides(scene: &mut Scene, a: &RenderArgs) -> Result<(), Error> {
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(usage("--spp must be at least 1."));
        }
        scene.render.samples = spp;
    }
    if let Some(w) = a.width {
        scene.image.width = w;
    }
    if let Some(h) = a.height {
        scene.image.height = h;
    }
    let (w, h) = (scene.image.width as u64, scene.image.height as u64);
    if w == 0 || h == 0 || w > 65536 || h > 65536 || w * h > (1 << 28) {
        return Err(usage(format!(
            "an image of {w}x{h} pixels is not allowed: width and height must be 1..=65536 and their product at most 2^28 (268435456)."
        )));
    }
    if let Some(b) = a.max_bounces {
        scene.render.max_bounces = b;
    }
    if let Some(s) = a.sampler {
        scene.render.sampler = match s {
            SamplerArg::Independent => vkpath::scene::Sampler::Independent,
            SamplerArg::Sobol => vkpath::scene::Sampler::Sobol,
        };
    }
    if let Some(l) = a.light_sampling {
        scene.render.light_sampling = match l {
            LightSamplingArg::Cone => vkpath::scene::LightSampling::Cone,
            LightSamplingArg::Area => vkpath::scene::LightSampling::Area,
            LightSamplingArg::None => vkpath::scene::LightSampling::None,
        };
    }
    if let Some(s) = a.seed {
        scene.render.seed = s;
    }
    Ok(())
}

fn render_options(a: &RenderArgs) -> Result<RenderOptions, Error> {
    let mut o = RenderOptions {
        generic: a.generic,
        ..Default::default()
    };
    if let Some(k) = a.samples_per_pass {
        if k == 0 {
            return Err(usage("--samples-per-pass must be at least 1."));
        }
        o.samples_per_pass = Some(k);
    }
    if let Some(r) = &a.roulette_depth {
        o.roulette_depth = match r.as_str() {
            "off" => u32::MAX,
            s => s.parse().map_err(|_| {
                usage(format!(
                    "--roulette-depth takes a number of bounces or \"off\", not \"{s}\"."
                ))
            })?,
        };
    }
    if let Some(t) = &a.tile {
        let bad = || {
            usage(format!(
                "--tile takes WxH, a tile's width and height in pixels (each at least 1), e.g. 256x256, not \"{t}\"."
            ))
        };
        let (w, h) = t.split_once(['x', 'X']).ok_or_else(bad)?;
        let w: u32 = w.trim().parse().map_err(|_| bad())?;
        let h: u32 = h.trim().parse().map_err(|_| bad())?;
        if w == 0 || h == 0 {
            return Err(bad());
        }
        o.max_tile = Some([w, h]);
    }
    if let Some(ms) = a.dispatch_ms {
        if !(ms.is_finite() && ms > 0.0) {
            return Err(usage(format!(
                "--dispatch-ms must be a positive number of milliseconds, not {ms}."
            )));
        }
        o.target_dispatch_seconds = ms / 1000.0;
    }
    // A test hook: simulate a device fault (docs/reliability.md).
    if let Some(f) = std::env::var("VKPATH_FAULT").ok().filter(|v| !v.is_empty()) {
        o.fault = Some(Fault::parse(&f).ok_or_else(|| {
            usage(format!(
                "VKPATH_FAULT={f} is not a fault to simulate: use device-lost@N, out-of-memory or shader, or unset it."
            ))
        })?);
    }
    Ok(o)
}

/// What is on disk when a render fails part-way, for the error message: the last checkpoint and the
/// last image written, with their sample counts.
#[derive(Default)]
struct Saved {
    checkpoint: Option<(PathBuf, u32)>,
    image: Option<(PathBuf, u32)>,
}

impl Saved {
    /// One sentence per file still on disk, to append to the error's paragraph.
    fn hint(&self) -> String {
        let mut s = String::new();
        if let Some((p, n)) = &self.checkpoint {
            s.push_str(&format!(
                " The last checkpoint, {} ({n} samples per pixel), is intact: go on with --resume {}.",
                p.display(),
                p.display()
            ));
        }
        if let Some((p, n)) = &self.image {
            s.push_str(&format!(
                " The last progress image, {} ({n} samples per pixel), is intact.",
                p.display()
            ));
        }
        s
    }
}

/// `--checkpoint-every`: `N` samples per pixel, or a duration `Ns`, `Nm`, `Nh`.
fn parse_save_every(text: &str) -> Result<SaveEvery, Error> {
    let bad = || {
        usage(format!(
            "--checkpoint-every takes a number of samples per pixel (e.g. 64) or a duration (e.g. 30s, 10m, 1h), not \"{text}\"."
        ))
    };
    let t = text.trim();
    let (number, unit) = match t.char_indices().last() {
        Some((i, 's')) => (&t[..i], 1.0),
        Some((i, 'm')) => (&t[..i], 60.0),
        Some((i, 'h')) => (&t[..i], 3600.0),
        _ => {
            let n: u32 = t.parse().map_err(|_| bad())?;
            if n == 0 {
                return Err(bad());
            }
            return Ok(SaveEvery::Samples(n));
        }
    };
    let v: f64 = number.trim().parse().map_err(|_| bad())?;
    let seconds = v * unit;
    if !(seconds.is_finite() && seconds > 0.0 && seconds < 1e9) {
        return Err(bad());
    }
    Ok(SaveEvery::Time(Duration::from_secs_f64(seconds)))
}

/// `--sample-range A..B`: the half-open range of sample indices [A, B), A < B.
fn parse_sample_range(text: &str) -> Result<[u32; 2], Error> {
    let bad = |why: &str| {
        usage(format!(
            "--sample-range takes A..B, the sample indices from A (included) to B (excluded) with 0 <= A < B < 2^32, e.g. 0..64; \"{text}\" {why}."
        ))
    };
    let (a, b) = text.split_once("..").ok_or_else(|| bad("has no \"..\""))?;
    let a: u32 = a
        .trim()
        .parse()
        .map_err(|_| bad("does not start with a number"))?;
    let b: u32 = b
        .trim()
        .parse()
        .map_err(|_| bad("does not end with a number"))?;
    if a >= b {
        return Err(bad("is empty"));
    }
    Ok([a, b])
}

/// Ctrl-C, SIGTERM and SIGHUP end the render after the pass in flight (the outputs and the checkpoint are
/// then written); a second one exits at once (every file on disk is still whole: they are written
/// atomically).
fn install_stop_handler() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // If a handler cannot be installed (e.g. one already exists in an embedding), a signal just kills us.
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            eprintln!("vkpath: interrupted twice; exiting now without writing.");
            std::process::exit(130);
        }
    });
    stop
}

fn run_render(a: RenderArgs) -> Result<i32, Error> {
    if let Some(e) = a.target_error
        && !(e.is_finite() && e > 0.0)
    {
        return Err(usage(format!(
            "--target-error must be a positive relative error (e.g. 0.02 for 2%), not {e}."
        )));
    }
    let budget_time = match a.time {
        Some(t) if !(t.is_finite() && t > 0.0) => {
            return Err(usage(format!(
                "--time must be a positive number of seconds, not {t}."
            )));
        }
        Some(t) => Some(Duration::from_secs_f64(t)),
        None => None,
    };
    if a.progress_every == Some(0) {
        return Err(usage("--progress-every must be at least 1."));
    }
    let range = a
        .sample_range
        .as_deref()
        .map(parse_sample_range)
        .transpose()?;
    if range.is_some() && a.spp.is_some() {
        return Err(usage(
            "--spp and --sample-range both set the samples to render; give one of them.",
        ));
    }
    // Checkpoints go to --checkpoint, or back into the file resumed from.
    let checkpoint_path = a.checkpoint.clone().or_else(|| a.resume.clone());
    let save_every = match (&a.checkpoint_every, &checkpoint_path) {
        (Some(_), None) => {
            return Err(usage(
                "--checkpoint-every needs --checkpoint FILE (or --resume FILE) to say where to save.",
            ));
        }
        (Some(text), Some(_)) => Some(parse_save_every(text)?),
        (None, Some(_)) => Some(SaveEvery::Time(Duration::from_secs(60))),
        (None, None) => None,
    };
    let mut scene = match &a.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    apply_overrides(&mut scene, &a)?;
    let options = render_options(&a)?;
    let outputs = if a.outputs.is_empty() {
        vec![PathBuf::from(format!("{}.png", scene.stem()))]
    } else {
        a.outputs.clone()
    };
    for o in &outputs {
        if vkpath::film::OutputFormat::from_path(o).is_none() {
            return Err(usage(format!(
                "cannot tell the image format of output {}: use a .png or .exr extension.",
                o.display()
            )));
        }
    }
    // A damaged or foreign file is refused before any device work.
    let resumed = a
        .resume
        .as_deref()
        .map(|p| Checkpoint::read(p).map(|c| (p.to_path_buf(), c)))
        .transpose()?;

    let stop = install_stop_handler();
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let mut renderer = Renderer::new(&ctx, &scene, &options)?;
    // The samples this run must end with: B - A of a range, else the scene's (or --spp's) count.
    let target_spp = match range {
        Some([a0, b0]) => b0 - a0,
        None => scene.render.samples,
    };
    match (&resumed, range) {
        (Some((path, c)), range) => {
            c.check_identity(path, &renderer.identity())?;
            // A partial render goes on only within its own range (else other samples would be rendered).
            let held = vkpath::checkpoint::show_ranges(&c.header.ranges);
            let first = c.header.ranges.first().map_or(0, |r| r[0]);
            let refusal = match range {
                Some([a0, b0])
                    if c.header.ranges.len() != 1 || first != a0 || c.next_sample() > b0 =>
                {
                    Some(format!(
                        "this checkpoint holds the samples {held}, which is not the start of --sample-range {a0}..{b0}. Resume it with the --sample-range it was made with."
                    ))
                }
                None if first != 0 => Some(format!(
                    "this is a partial render of the samples {held}: resume it with its --sample-range {first}..B, or combine it with the other parts with `vkpath merge`."
                )),
                _ => None,
            };
            if let Some(message) = refusal {
                return Err(Error::Checkpoint {
                    path: path.clone(),
                    message,
                });
            }
            renderer.restore(&c.header.ranges, &c.accum)?;
            if !a.quiet {
                let device = &ctx.device_info().name;
                if &c.header.device != device {
                    eprintln!(
                        "vkpath: warning: the checkpoint was computed on {}, this render runs on {device}; the image is a valid estimate, but bit-for-bit equality with an uninterrupted render is promised only on the same device.",
                        c.header.device
                    );
                }
            }
        }
        (None, Some([a0, _])) => renderer.start_at(a0)?,
        (None, None) => {}
    }
    let resumed_samples = renderer.samples_done();
    drop(resumed);

    let budget = Budget {
        spp: target_spp,
        time: budget_time,
        progress_every: a.progress_every,
        save_every,
        target_error: a.target_error,
    };
    let bar = if !a.quiet && std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(target_spp as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {pos}/{len} spp ({per_sec}, eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_position(resumed_samples as u64);
        Some(bar)
    } else {
        None
    };
    // What is on disk, for the message if the render fails part-way (a lost device).
    let saved = std::cell::RefCell::new(Saved::default());
    if let (Some(p), true, None) = (&checkpoint_path, resumed_samples > 0, &a.checkpoint) {
        saved.borrow_mut().checkpoint = Some((p.clone(), resumed_samples));
    }
    let save_checkpoint = |r: &mut Renderer| -> Result<(), Error> {
        if let Some(path) = &checkpoint_path {
            Checkpoint::of(r, &scene)?.write(path)?;
            saved.borrow_mut().checkpoint = Some((path.clone(), r.samples_done()));
        }
        Ok(())
    };
    let fail = |e: Error| -> Result<i32, Error> {
        if let Some(bar) = &bar {
            bar.abandon();
        }
        eprintln!("vkpath: error: {e}{}", saved.borrow().hint());
        Ok(e.exit_code())
    };
    let rendered = render_progressive(&mut renderer, &options, &budget, &stop, |r, report| {
        if let Some(bar) = &bar {
            bar.set_position(report.samples_done as u64);
        }
        let ending = report.samples_done >= budget.spp;
        if report.progress && !ending {
            let film = r.film()?;
            for o in &outputs {
                film.write(o, &scene.image)?;
                saved.borrow_mut().image = Some((o.clone(), film.spp));
            }
        }
        if report.save_state && !ending {
            save_checkpoint(r)?;
        }
        Ok(())
    });
    let (reason, elapsed) = match rendered {
        Ok(v) => v,
        Err(e) => return fail(e),
    };
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let film = match renderer.film() {
        Ok(f) => f,
        Err(e) => return fail(e.into()),
    };
    if film.spp == 0 {
        eprintln!("vkpath: interrupted before the first pass ended; no image was written.");
        return Ok(1);
    }
    for o in &outputs {
        film.write(o, &scene.image)?;
    }
    save_checkpoint(&mut renderer)?;
    if reason == StopReason::Interrupted && !a.quiet {
        eprintln!(
            "vkpath: interrupted; wrote the image with {} samples per pixel{}.",
            film.spp,
            match &checkpoint_path {
                Some(p) => format!(
                    " and the checkpoint {} (go on with --resume {})",
                    p.display(),
                    p.display()
                ),
                None => String::new(),
            }
        );
    }
    let validation_errors = ctx.validation_errors();
    let seconds = elapsed.as_secs_f64();
    let traced = film.spp - resumed_samples;
    let samples = scene.image.width as f64 * scene.image.height as f64 * traced as f64;
    if a.json {
        let rel = film.estimated_rel_error();
        let json = serde_json::json!({
            "scene": scene.display_name(),
            "width": scene.image.width,
            "height": scene.image.height,
            "spp": film.spp,
            "seconds": seconds,
            "samples_per_second": samples / seconds.max(1e-12),
            "estimated_rel_error": if rel.is_finite() { serde_json::json!(rel) } else { serde_json::Value::Null },
            "device": ctx.device_info().name,
            "max_bounces": scene.render.max_bounces,
            "seed": scene.render.seed,
            "stop_reason": reason,
            "outputs": outputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "validation_errors": validation_errors.len(),
            "triangles": renderer.scene_stats().triangles,
            "bvh_nodes": renderer.scene_stats().bvh_nodes,
            "bvh_build_ms": renderer.scene_stats().bvh_build_ms,
            "kernel": vkpath::checkpoint::kernel_name(renderer.features()),
            "features_absent": renderer.features().absent(),
            "sample_ranges": renderer.ranges(),
            "strips": renderer.tile_layout().strips.len(),
            "tiles_per_sample": renderer.tiles_per_sample(),
            "resumed_spp": resumed_samples,
            "checkpoint": checkpoint_path.as_ref().map(|p| p.display().to_string()),
        });
        println!("{json}");
    }
    if !validation_errors.is_empty() {
        for e in &validation_errors {
            eprintln!("vkpath: Vulkan validation error: {e}");
        }
        eprintln!(
            "vkpath: the Vulkan validation layer reported {} error(s) (VKPATH_VALIDATION is set); this is a bug in vkpath.",
            validation_errors.len()
        );
        return Ok(1);
    }
    Ok(0)
}

/// `vkpath preview`: flags and scene are checked the same way with or without the `preview` feature.
fn run_preview(a: PreviewArgs) -> Result<i32, Error> {
    if a.screenshot.is_some() && a.frames.is_none() {
        return Err(usage(
            "--screenshot needs --frames N: the screenshot is the image shown by the N-th present.",
        ));
    }
    if let Some(p) = &a.screenshot
        && vkpath::film::OutputFormat::from_path(p) != Some(vkpath::film::OutputFormat::Png)
    {
        return Err(usage(format!(
            "--screenshot writes a PNG: give it a .png path, not {}.",
            p.display()
        )));
    }
    if a.frames == Some(0) || a.spp == Some(0) {
        return Err(usage("--frames and --spp must be at least 1."));
    }
    if !(a.fps.is_finite() && a.fps > 0.0 && a.fps <= 1000.0) {
        return Err(usage(format!(
            "--fps must be a number of presents per second in (0, 1000], not {}.",
            a.fps
        )));
    }
    let mut scene = match &a.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    // The same overrides and size rule as `vkpath render` (apply_overrides).
    scene.image.width = a.width.unwrap_or(scene.image.width);
    scene.image.height = a.height.unwrap_or(scene.image.height);
    let (w, h) = (scene.image.width as u64, scene.image.height as u64);
    if w == 0 || h == 0 || w > 65536 || h > 65536 || w * h > (1 << 28) {
        return Err(usage(format!(
            "an image of {w}x{h} pixels is not allowed: width and height must be 1..=65536 and their product at most 2^28 (268435456)."
        )));
    }
    scene.render.seed = a.seed.unwrap_or(scene.render.seed);
    scene.render.max_bounces = a.max_bounces.unwrap_or(scene.render.max_bounces);
    preview_window(a, scene)
}

#[cfg(not(feature = "preview"))]
fn preview_window(_a: PreviewArgs, _scene: Scene) -> Result<i32, Error> {
    Err(usage(
        "this vkpath was built without the `preview` feature, so it cannot open a window; rebuild it \
         with `cargo build --release --features preview` (on by default), or use `vkpath render \
         --progress-every N` and watch the output file.",
    ))
}

#[cfg(feature = "preview")]
fn preview_window(a: PreviewArgs, scene: Scene) -> Result<i32, Error> {
    let script = match &a.script {
        Some(text) => vkpath::preview::control::parse_script(text).map_err(usage)?,
        None => Vec::new(),
    };
    let settings = vkpath::preview::PreviewSettings {
        scene,
        options: RenderOptions::default(),
        max_spp: a.spp,
        frames: a.frames,
        screenshot: a.screenshot.clone(),
        script,
        save_dir: a.save_dir.clone(),
        max_presents_per_second: a.fps,
    };
    let report = vkpath::preview::run(settings)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string(&report).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
        );
    }
    for p in &report.saved {
        eprintln!("vkpath: saved {}", p.display());
    }
    let mut code = 0;
    for e in &report.save_errors {
        eprintln!("vkpath: error: S could not save the image: {e}");
        code = 1;
    }
    if !report.validation_errors.is_empty() {
        for e in &report.validation_errors {
            eprintln!("vkpath: Vulkan validation error: {e}");
        }
        eprintln!(
            "vkpath: the Vulkan validation layer reported {} error(s) (VKPATH_VALIDATION is set); this is a bug in vkpath.",
            report.validation_errors.len()
        );
        code = 1;
    }
    Ok(code)
}

fn run_merge(m: MergeArgs) -> Result<i32, Error> {
    if m.outputs.is_empty() && m.checkpoint.is_none() {
        return Err(usage(
            "vkpath merge needs somewhere to write: -o OUT.png / -o OUT.exr and/or --checkpoint FILE.",
        ));
    }
    for o in &m.outputs {
        if vkpath::film::OutputFormat::from_path(o).is_none() {
            return Err(usage(format!(
                "cannot tell the image format of output {}: use a .png or .exr extension.",
                o.display()
            )));
        }
    }
    let mut parts = Vec::with_capacity(m.parts.len());
    for p in &m.parts {
        parts.push((p.clone(), Checkpoint::read(p)?));
    }
    let merged = vkpath::checkpoint::merge::merge(&parts)?;
    drop(parts);
    let film = merged.film();
    let settings = merged.image_settings();
    for o in &m.outputs {
        film.write(o, &settings)?;
    }
    if let Some(path) = &m.checkpoint {
        merged.write(path)?;
    }
    if m.json {
        let rel = film.estimated_rel_error();
        let json = serde_json::json!({
            "scene": merged.header.scene,
            "width": film.width,
            "height": film.height,
            "spp": film.spp,
            "parts": m.parts.len(),
            "sample_ranges": merged.header.ranges,
            "estimated_rel_error": if rel.is_finite() { serde_json::json!(rel) } else { serde_json::Value::Null },
            "device": merged.header.device,
            "outputs": m.outputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "checkpoint": m.checkpoint.as_ref().map(|p| p.display().to_string()),
        });
        println!("{json}");
    }
    Ok(0)
}

fn run_convergence(a: ConvergenceArgs) -> Result<i32, Error> {
    if a.width == 0 || a.height == 0 || a.max_spp == 0 || a.reference_spp == 0 {
        return Err(usage(
            "--width, --height, --max-spp and --reference-spp must be at least 1.",
        ));
    }
    let mut scene = match &a.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    scene.image.width = a.width;
    scene.image.height = a.height;
    let settings = vkpath::bench::convergence::parse_settings(&a.knobs, &scene)?;
    let config = vkpath::bench::convergence::Config {
        scene,
        settings,
        reference: a.reference,
        reference_spp: a.reference_spp,
        max_spp: a.max_spp,
        out_dir: a.out,
    };
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let report =
        vkpath::bench::convergence::run(&ctx, &config, |line| eprintln!("vkpath: {line}"))?;
    eprintln!(
        "vkpath: wrote {} and {}",
        report.csv.display(),
        report.plot.display()
    );
    print!("{}", report.table);
    Ok(0)
}

/// The size and repetitions shared by the timing benchmarks, each at least 1.
fn bench_settings(
    width: u32,
    height: u32,
    spp: u32,
    runs: u32,
) -> Result<vkpath::bench::BenchSettings, Error> {
    if width == 0 || height == 0 || spp == 0 || runs == 0 {
        return Err(usage(
            "--width, --height, --spp and --runs must be at least 1.",
        ));
    }
    Ok(vkpath::bench::BenchSettings {
        width,
        height,
        spp,
        runs,
    })
}

/// The scenes a benchmark times: those given, or every scene in ./scenes.
fn bench_scenes(scenes: Vec<PathBuf>) -> Result<Vec<PathBuf>, Error> {
    let scenes = if scenes.is_empty() {
        vkpath::bench::scene_files(std::path::Path::new("scenes"))?
    } else {
        scenes
    };
    if scenes.is_empty() {
        return Err(usage("no scene files given and none found in ./scenes."));
    }
    Ok(scenes)
}

fn run_bench(b: BenchCommand) -> Result<i32, Error> {
    match b {
        BenchCommand::Convergence(a) => run_convergence(a),
        BenchCommand::Throughput {
            scenes,
            width,
            height,
            spp,
            runs,
            json,
        } => {
            let settings = bench_settings(width, height, spp, runs)?;
            let scenes = bench_scenes(scenes)?;
            let ctx = GpuContext::new(&ContextOptions::default())?;
            let device = &ctx.device_info().name;
            let rows = vkpath::bench::throughput::throughput(&ctx, &scenes, settings)?;
            if json {
                println!("{}", serde_json::json!({ "device": device, "rows": rows }));
            } else {
                print!(
                    "{}",
                    vkpath::bench::throughput::throughput_table(&rows, settings, device)
                );
            }
            Ok(0)
        }
        BenchCommand::Mesh {
            sizes,
            width,
            height,
            spp,
            runs,
            brute_force_up_to,
        } => {
            let settings = bench_settings(width, height, spp, runs)?;
            let sizes = if sizes.is_empty() {
                vkpath::bench::mesh::DEFAULT_SIZES.to_vec()
            } else {
                sizes
            };
            let ctx = GpuContext::new(&ContextOptions::default())?;
            let rows =
                vkpath::bench::mesh::mesh_scaling(&ctx, &sizes, settings, brute_force_up_to)?;
            print!(
                "{}",
                vkpath::bench::mesh::mesh_scaling_table(&rows, settings, &ctx.device_info().name)
            );
            Ok(0)
        }
        BenchCommand::Specialisation {
            scenes,
            width,
            height,
            spp,
            runs,
            json,
            ablation,
        } => {
            let settings = bench_settings(width, height, spp, runs)?;
            let scenes = bench_scenes(scenes)?;
            let ctx = GpuContext::new(&ContextOptions::default())?;
            let device = &ctx.device_info().name;
            if ablation {
                let rows = vkpath::bench::specialisation::ablation(&ctx, &scenes, settings)?;
                if json {
                    println!("{}", serde_json::json!({ "device": device, "rows": rows }));
                } else {
                    print!(
                        "{}",
                        vkpath::bench::specialisation::ablation_table(&rows, settings, device)
                    );
                }
                return Ok(0);
            }
            let rows = vkpath::bench::specialisation::specialisation(&ctx, &scenes, settings)?;
            if json {
                println!(
                    "{}",
                    serde_json::json!({ "device": ctx.device_info().name, "rows": rows })
                );
            } else {
                print!(
                    "{}",
                    vkpath::bench::specialisation::specialisation_table(
                        &rows,
                        settings,
                        &ctx.device_info().name
                    )
                );
            }
            Ok(0)
        }
    }
}

fn run_info(json: bool) -> Result<i32, Error> {
    let devices = vkpath::gpu::context::list_devices()?;
    let substring = std::env::var("VKPATH_DEVICE")
        .ok()
        .filter(|s| !s.is_empty());
    let (chosen, reason) = vkpath::gpu::context::choose_device(&devices, substring.as_deref())?;
    if json {
        let v = serde_json::json!({ "devices": devices, "chosen": chosen, "reason": reason });
        println!("{v}");
        return Ok(0);
    }
    for d in &devices {
        let mark = if d.index == chosen { "*" } else { " " };
        println!(
            "{mark} [{}] {} ({}, Vulkan {})",
            d.index, d.name, d.device_type, d.api_version
        );
    }
    let d = &devices[chosen];
    println!("chosen: [{}] {}, because {}", d.index, d.name, reason);
    println!("limits:");
    println!(
        "  max compute workgroup count:       {:?}",
        d.max_compute_workgroup_count
    );
    println!(
        "  max compute workgroup invocations: {}",
        d.max_compute_workgroup_invocations
    );
    println!(
        "  max storage buffer range:          {} bytes",
        d.max_storage_buffer_range
    );
    println!(
        "  max memory allocation size:        {} bytes",
        d.max_memory_allocation_size
    );
    println!(
        "  device-local memory:               {} bytes",
        d.device_local_memory_bytes
    );
    Ok(0)
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version: print and exit 0
        Err(e) => {
            // Clap's usage errors span several paragraphs; the contract asks for one.
            let text = e.to_string();
            let msg: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("vkpath: {}", msg.join(" "));
            std::process::exit(2);
        }
    };
    let result = match cli.command {
        Command::Render(a) => run_render(*a),
        Command::Preview(p) => run_preview(*p),
        Command::Info { json } => run_info(json),
        Command::Merge(m) => run_merge(m),
        Command::Bench(b) => run_bench(b),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("vkpath: error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}
