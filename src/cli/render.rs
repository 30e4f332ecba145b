//! `vkpath render`: a scene to PNG/EXR, progressively, with time and error budgets, progress images,
//! checkpoints, resumes and partial renders (`--sample-range`, and `--part I/N` for render farms).
//!
//! The render itself is a library session (`vkpath::session`: the plan of samples, the passes and their
//! stopping rules, the progress images and checkpoints on the way, the AOV layers, the final files).
//! This command is what surrounds it: [`run_render`] runs [`check_flags`] (what the flags decide on
//! their own, a `--part` resolved from the scheduler's variables), [`prepare`] (the scene with its
//! overrides, the options, the outputs, the checkpoint to resume, all before any device work), the
//! session with a progress bar, and [`report`] (what is printed, and the exit status).

use super::report::print_json;
use super::{
    check_image_size, check_output_formats, install_stop_handler, load_scene_with,
    report_validation_errors, usage,
};
use clap::Args;
use indicatif::ProgressBar;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Duration;
use vkpath::checkpoint::{Checkpoint, Part};
use vkpath::denoise::{Denoiser, DeviceChoice};
use vkpath::film::Film;
use vkpath::film::OutputFormat;
use vkpath::gpu::{ContextOptions, GpuContext};
use vkpath::output::Aov;
use vkpath::render::adaptive::AdaptiveSettings;
use vkpath::render::{Fault, PassReport, RenderOptions, Renderer, SaveEvery, StopReason};
use vkpath::scene::translated::ImportOptions;
use vkpath::session::{Plan, Request, Session};
use vkpath::{Error, Scene};

/// `vkpath render`: the exit status, or the error that decides it. A failure part-way through the
/// render (a lost device) is reported here, with the files still intact, and ends with its status.
pub fn run_render(a: RenderArgs) -> Result<i32, Error> {
    let flags = check_flags(&a)?;
    let job = prepare(&a, flags.part.is_some())?;
    if !flags.aovs.is_empty()
        && !job
            .outputs
            .iter()
            .any(|o| OutputFormat::from_path(o) == Some(OutputFormat::Exr))
    {
        return Err(usage(
            "--aov adds layers to the EXR output, and no -o names an .exr file: add -o OUT.exr.",
        ));
    }
    // A part's range depends on the render's samples, known once the scene is read.
    let part = flags
        .part
        .map(|(index, count)| {
            Part::new(index, count, job.scene.render.samples)
                .map_err(|m| usage(format!("--part {index}/{count}: {m}.")))
        })
        .transpose()?;
    let range = part.map(|p| p.range()).or(flags.range);

    let (stop, started) = install_stop_handler();
    let ctx = GpuContext::new(&ContextOptions::default())?;
    if let (Some(w), false) = (ctx.device_info().old_lavapipe_warning(), a.quiet) {
        eprintln!("vkpath: warning: {w}");
    }
    // The denoiser is loaded before the first sample: a missing one is refused now, not after the
    // render (a part without images has nothing to denoise: the merge denoises the frame, from the aux
    // images each part's checkpoint keeps).
    let denoise = a.denoise || job.scene.image.denoise;
    let denoiser = if denoise && !job.outputs.is_empty() {
        Some(Denoiser::new(DeviceChoice::for_vulkan(ctx.device_info()))?)
    } else {
        None
    };
    let mut session = Session::start(
        &ctx,
        Request {
            scene: &job.scene,
            options: &job.options,
            outputs: &job.outputs,
            checkpoint: flags.checkpoint.as_deref(),
            resume: job.resumed,
            range,
            part,
            aovs: &flags.aovs,
            denoiser: denoiser.as_ref(),
            keep_aux: denoise && range.is_some() && flags.checkpoint.is_some(),
            time: flags.time,
            target_error: a.target_error,
            progress_every: a.progress_every,
            save_every: flags.save_every,
        },
    )?;
    // The kernel is compiled and the passes start: from now on a stop request writes what was rendered.
    started.store(true, std::sync::atomic::Ordering::SeqCst);
    if !a.quiet {
        for w in &session.plan().warnings {
            eprintln!("vkpath: warning: {w}");
        }
    }
    let bar = progress_bar(a.quiet, session.plan());
    let mut error_shown = ErrorShown::default();
    let ended = session.run(&stop, |r, report| {
        if let Some(bar) = &bar {
            show_progress(bar, r, report, &mut error_shown)?;
        }
        Ok(())
    });
    let ended = match ended {
        Ok(v) => v,
        Err(e) => return Ok(fail(bar.as_ref(), &session, e)),
    };
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let film = match session.finish() {
        Ok(Some(film)) => film,
        Ok(None) => {
            eprintln!("vkpath: interrupted before the first pass ended; no image was written.");
            return Ok(1);
        }
        // Say what is still on disk (the checkpoint, written first).
        Err(e) => return Ok(fail(None, &session, e)),
    };
    Ok(report(&a, &session, &film, ended))
}

/// What the flags decide on their own, before any file is read.
struct Flags {
    /// `--time`.
    time: Option<Duration>,
    /// `--sample-range`.
    range: Option<[u32; 2]>,
    /// `--part`: the part's index and the number of parts (the range follows from the scene's samples).
    part: Option<(u32, u32)>,
    /// `--aov`: the EXR's extra layers.
    aovs: Vec<Aov>,
    /// Where checkpoints go: `--checkpoint`, or back into the file resumed from.
    checkpoint: Option<PathBuf>,
    /// How often to save one (every 60 s when only the file is given).
    save_every: Option<SaveEvery>,
}

/// Refuses the flags that are wrong on their own (a non-positive time or target error, a zero progress
/// interval, a malformed range or checkpoint interval) or together (`--spp` with `--sample-range`,
/// `--checkpoint-every` with nowhere to save), and decides the time budget, the sample range and where
/// and how often checkpoints are saved.
fn check_flags(a: &RenderArgs) -> Result<Flags, Error> {
    if let Some(e) = a.target_error
        && !(e.is_finite() && e > 0.0)
    {
        return Err(usage(format!(
            "--target-error must be a positive relative error (e.g. 0.02 for 2%), not {e}."
        )));
    }
    let time = match &a.time {
        Some(t) => Some(parse_duration("--time", t)?),
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
    let part = a
        .part
        .as_deref()
        .map(|p| resolve_part(p, |name| std::env::var(name).ok()))
        .transpose()?;
    if part.is_some() && range.is_some() {
        return Err(usage(
            "--part and --sample-range both choose the samples to render; give one of them.",
        ));
    }
    if part.is_some() && (a.time.is_some() || a.target_error.is_some()) {
        return Err(usage(
            "--part renders the whole of its part, so that the merge can use it: --time and \
             --target-error would stop it early. Give neither with --part (choose the samples with --spp \
             and the number of parts instead).",
        ));
    }
    if part.is_some() && a.checkpoint.is_none() && a.resume.is_none() {
        return Err(usage(
            "--part renders one part of the samples, to be merged with the others: give --checkpoint \
             FILE (the part's file for vkpath merge), or --resume FILE to finish a part that stopped.",
        ));
    }
    let checkpoint = a.checkpoint.clone().or_else(|| a.resume.clone());
    let save_every = match (&a.checkpoint_every, &checkpoint) {
        (Some(_), None) => {
            return Err(usage(
                "--checkpoint-every needs --checkpoint FILE (or --resume FILE) to say where to save.",
            ));
        }
        (Some(text), Some(_)) => Some(parse_save_every(text)?),
        (None, Some(_)) => Some(SaveEvery::Time(Duration::from_secs(60))),
        (None, None) => None,
    };
    let aovs = match &a.aov {
        Some(list) => Aov::parse_list(list).map_err(|m| {
            usage(format!(
                "--aov takes a comma-separated list of the EXR's extra layers (albedo,normal,variance,depth,spp): {m}."
            ))
        })?,
        None => Vec::new(),
    };
    Ok(Flags {
        time,
        range,
        part,
        aovs,
        checkpoint,
        save_every,
    })
}

/// What the render works from, all read and checked before any device work.
struct Job {
    /// The scene with the command line's overrides applied.
    scene: Scene,
    options: RenderOptions,
    /// The images to write: `-o`'s, or `<scene-stem>.png`.
    outputs: Vec<PathBuf>,
    /// `--resume`'s file and its state.
    resumed: Option<(PathBuf, Checkpoint)>,
}

/// Loads the scene and applies the overrides, decides the renderer's options and the outputs (refusing
/// an output of unknown format; a part writes no image unless asked: its checkpoint is what counts), and
/// reads the checkpoint to resume: a damaged or foreign file is refused here, before any device work.
fn prepare(a: &RenderArgs, is_part: bool) -> Result<Job, Error> {
    let import = ImportOptions {
        xml_lenient: a.xml_lenient,
        defines: a.defines.clone(),
        environment_given: a.environment.is_some(),
        ..super::CameraArg::options(a.camera)
    };
    let mut scene = load_scene_with(a.scene.as_deref(), &import)?;
    apply_overrides(&mut scene, a)?;
    let mut options = render_options(a)?;
    options.adaptive = AdaptiveSettings::asked(&scene.render.adaptive, a.target_error);
    let outputs = if a.outputs.is_empty() && !is_part {
        vec![PathBuf::from(format!("{}.png", scene.stem()))]
    } else {
        a.outputs.clone()
    };
    check_output_formats(&outputs)?;
    let checkpoint = a.checkpoint.as_deref().or(a.resume.as_deref());
    let inputs = super::paths::scene_inputs(&scene);
    super::paths::check_outputs(&outputs, checkpoint, inputs, a.resume.as_deref())?;
    // The header first: a state of another image size is refused before its pixels are decoded.
    let resumed = a
        .resume
        .as_deref()
        .map(|p| {
            Checkpoint::read_header(p)?.check_image_size(
                p,
                scene.image.width,
                scene.image.height,
            )?;
            Checkpoint::read(p).map(|c| (p.to_path_buf(), c))
        })
        .transpose()
        .map_err(|e| e.with_checkpoint_hint("Render without --resume to start afresh."))?;
    Ok(Job {
        scene,
        options,
        outputs,
        resumed,
    })
}

/// How often the progress bar's estimated error is brought up to date.
const BAR_ERROR_EVERY: Duration = Duration::from_secs(5);

/// A progress bar on stderr when it is a terminal and `--quiet` is not given, starting at the samples
/// resumed.
fn progress_bar(quiet: bool, plan: &Plan) -> Option<ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(plan.target_spp as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} spp ({rate}{msg}, eta {eta})",
        )
        .map(|s| {
            // indicatif's own {per_sec} prints "17.7599/s", without the unit.
            s.with_key(
                "rate",
                |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{:.1} spp/s", state.per_sec());
                },
            )
        })
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_position(plan.resumed_samples as u64);
    Some(bar)
}

/// The progress bar's estimated error: when it was last computed, and its text.
#[derive(Default)]
struct ErrorShown {
    at: Option<std::time::Instant>,
    text: String,
}

/// Brings the bar up to date after a pass: the samples done, and the estimated error, which needs the
/// film read back (96 bytes a pixel): at most every few seconds, so that the bar costs the render next
/// to nothing.
fn show_progress(
    bar: &ProgressBar,
    r: &mut Renderer,
    report: &PassReport,
    shown: &mut ErrorShown,
) -> Result<(), Error> {
    bar.set_position(report.samples_done as u64);
    // Adaptive sampling: the share of the pixels still sampling, after every pass (no readback).
    let active = r.adaptive().map_or(String::new(), |a| {
        let pixels = a.counts().len().max(1);
        format!(
            ", {:.1}% of pixels sampling",
            100.0 * a.active().len() as f64 / pixels as f64
        )
    });
    if report.samples_done >= 2 && shown.at.is_none_or(|t| t.elapsed() >= BAR_ERROR_EVERY) {
        let rel = r.film()?.estimated_rel_error();
        if rel.is_finite() {
            shown.text = format!(", error {:.2}%", 100.0 * rel);
        }
        shown.at = Some(std::time::Instant::now());
    }
    bar.set_message(format!("{}{active}", shown.text));
    Ok(())
}

/// A render that failed part-way (a lost device): the error, with the files still intact on disk to go
/// on from, and the exit status it ends with.
fn fail(bar: Option<&ProgressBar>, session: &Session, e: Error) -> i32 {
    if let Some(bar) = bar {
        bar.abandon();
    }
    eprintln!("vkpath: error: {e}{}", session.saved_hint());
    e.exit_code()
}

/// Says how an interrupted render can go on (unless `--quiet`), prints the `--json` report, and reports
/// the validation layer's errors. The exit status: 1 when there were any (a bug in vkpath), else 0.
fn report(
    a: &RenderArgs,
    session: &Session,
    film: &Film,
    (reason, elapsed): (StopReason, Duration),
) -> i32 {
    // A part that stopped early is not done: exit 1, so that the scheduler (Slurm, Kubernetes) does not
    // count the task as a success and runs it again, and the merge is not started without it.
    let renderer = session.renderer();
    let unfinished_part = match (reason, session.part()) {
        (StopReason::Interrupted, Some(p)) => Some(p),
        _ => None,
    };
    if let Some(p) = unfinished_part {
        let [start, end] = p.range();
        eprintln!(
            "vkpath: error: part {} was interrupted with {} of its {} samples per pixel ({start}..{end}); \
             its checkpoint {} holds them: finish it with --resume {} (the same scene and flags). Exit \
             status 1: the part is not done.",
            p.show(),
            film.spp,
            end - start,
            session
                .checkpoint()
                .map_or("(none)".into(), |c| c.display().to_string()),
            session
                .checkpoint()
                .map_or("FILE".into(), |c| c.display().to_string()),
        );
    } else if reason == StopReason::Interrupted && !a.quiet {
        eprintln!(
            "vkpath: interrupted; wrote the image with {} samples per pixel{}.",
            film.spp,
            match session.checkpoint() {
                Some(p) => format!(
                    " and the checkpoint {} (go on with --resume {})",
                    p.display(),
                    p.display()
                ),
                None => String::new(),
            }
        );
    }
    let validation_errors = renderer.context().validation_errors();
    // Read once the passes have completed; a failed read only loses the warning.
    let summary = session.report(film, reason, elapsed);
    warn_sample_faults(&summary.sample_faults);
    if !a.quiet {
        eprintln!(
            "{}",
            summary_line(session, film, summary.seconds, summary.samples_per_second)
        );
    }
    if a.json {
        print_json(&summary);
    }
    if report_validation_errors(&validation_errors) || unfinished_part.is_some() {
        return 1;
    }
    0
}

/// Says on stderr (whatever --quiet) how many samples did not enter the image as they were, and what
/// that means for the image.
fn warn_sample_faults(faults: &vkpath::render::SampleFaults) {
    if faults.clamped > 0 {
        eprintln!(
            "vkpath: warning: {} samples had a radiance of 2^64 (1.8e19) or more and were clamped below \
             it, so the image is darker than the scene where they fell. Such radiance usually means a \
             light far too powerful for the scale of the scene: check the lights' power (W) and the \
             distances.",
            faults.clamped
        );
    }
    if faults.not_finite > 0 {
        eprintln!(
            "vkpath: warning: {} samples were NaN or infinite and were counted as black. This is a bug \
             in vkpath; please report it with the scene.",
            faults.not_finite
        );
    }
    if faults.bounce_capped > 0 {
        eprintln!(
            "vkpath: warning: {} paths reached {} bounces, the most vkpath traces, and were ended there, \
             so the image is darker than the scene where they fell. With Russian roulette on a path \
             practically never gets there; turn it on (--roulette-depth N) or give the scene a bounce \
             limit (max_bounces).",
            faults.bounce_capped,
            vkpath::kernel::abi::BOUNCE_CAP
        );
    }
}

/// `--sampler` (render.sampler in the scene file).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum SamplerArg {
    Independent,
    Sobol,
}

/// `--splat` (render.splat in the scene file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Args)]
pub struct RenderArgs {
    /// Scene file: TOML, glTF 2.0 (.gltf, .glb) or Mitsuba 3 XML (.xml). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// A glTF scene's camera to render from: N counts its camera nodes, depth first (default: the first;
    /// none: framed from its bounds), or `auto` (framed from its bounds: from +z, y up, 45 degrees
    /// vertically); a Mitsuba XML scene's sensor N, in file order.
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_camera)]
    camera: Option<super::CameraArg>,
    /// A Mitsuba XML scene: skip the elements, plugins and parameters vkpath does not read, with a
    /// warning each, instead of refusing the file.
    #[arg(long = "xml-lenient")]
    xml_lenient: bool,
    /// Denoise the final images with Intel Open Image Denoise (also `render.denoise = true`): its RT
    /// filter on the image with the albedo and normal layers, rendered for it; the EXR keeps the raw
    /// estimate as raw.R/G/B. Progress images stay raw. OIDN is loaded at run time
    /// (ci/setup.sh --denoise installs it).
    #[arg(long)]
    denoise: bool,
    /// A Mitsuba XML scene's `<default>` parameter, as on Mitsuba's command line (`-D integrator=path`,
    /// `-D spp=64`); it wins over the file's `<default>`. Repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = super::parse_define)]
    defines: Vec<(String, String)>,
    /// Output file; repeatable; the format follows the extension (.png, .exr). Default: <scene-stem>.png.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Samples per pixel (overrides the scene); with --time, the upper bound.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Stop after the first pass that ends past this time: seconds (`90`, `2.5`) or a duration with
    /// units (`90s`, `10m`, `1h30m`).
    #[arg(long, allow_hyphen_values = true)]
    time: Option<String>,
    /// Stop when the estimated relative error of the image falls below E (checked after each pass from
    /// 16 spp on; the scene's samples, or --spp, stays the upper bound).
    #[arg(long = "target-error", allow_negative_numbers = true)]
    target_error: Option<f64>,
    /// Random seed (overrides the scene).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(0..))]
    seed: Option<u32>,
    /// Image width in pixels (overrides the scene).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    height: Option<u32>,
    /// Light the scene with this equirectangular map (.exr or .hdr, linear radiance, oriented as
    /// Mitsuba's envmap), replacing its environment (and a glTF scene's default uniform one).
    #[arg(long, value_name = "MAP")]
    environment: Option<PathBuf>,
    /// Scattering events per path, -1 for no limit (overrides the scene).
    #[arg(long = "max-bounces", allow_negative_numbers = true, value_parser = super::parse_max_bounces)]
    max_bounces: Option<u32>,
    /// Where random numbers come from (overrides the scene's render.sampler).
    #[arg(long, value_enum)]
    sampler: Option<SamplerArg>,
    /// Splat each sample into every pixel its filter covers, a pixel the weighted average of what it
    /// received (overrides the scene's render.splat). Default: on where the filter is a tent or a
    /// Gaussian and samples stay on the image (sample_border = false, Mitsuba's files), off with
    /// --denoise (the denoiser wants each pixel's own samples).
    #[arg(long, value_enum)]
    splat: Option<OnOff>,
    /// Adaptive sampling (overrides the scene's render.adaptive): after render.adaptive_min_samples
    /// (16), a pixel stops sampling once its estimated relative error is below --adaptive-threshold;
    /// --spp is then the most any pixel takes. Default off. Not with --sample-range or --part, nor with
    /// splatting (--splat off is implied unless --splat on is given, which is refused).
    #[arg(long, value_enum)]
    adaptive: Option<OnOff>,
    /// The relative error at which adaptive sampling stops a pixel (overrides the scene's
    /// render.adaptive_threshold; default: --target-error when given, else 0.01). Implies --adaptive on
    /// unless --adaptive off is given.
    #[arg(long = "adaptive-threshold", allow_negative_numbers = true)]
    adaptive_threshold: Option<f64>,
    /// How sphere lights are sampled (overrides the scene's render.light_sampling).
    #[arg(long = "light-sampling", value_parser = light_sampling_names())]
    light_sampling: Option<String>,
    /// Rewrite the outputs after every N samples per pixel.
    #[arg(long = "progress-every", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    progress_every: Option<u32>,
    /// Print one JSON object on stdout when the render ends.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Samples per pixel in each pass (default: adapted to about a quarter second per pass).
    #[arg(long = "samples-per-pass", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    samples_per_pass: Option<u32>,
    /// The most ray casts one kernel invocation makes per dispatch before its path is saved for the
    /// next (default: as many as the device's loop budget allows, at most 256). The image does not
    /// depend on it.
    #[arg(long = "casts-per-dispatch", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    casts_per_dispatch: Option<u32>,
    /// Start Russian roulette after this many bounces ("off" disables it). Default 3.
    #[arg(long = "roulette-depth", allow_hyphen_values = true)]
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
    #[arg(long = "checkpoint-every", allow_hyphen_values = true)]
    checkpoint_every: Option<String>,
    /// Go on from a checkpoint of this render (same scene, flags and vkpath version), to the same bits
    /// as a render that never stopped. New checkpoints go to this file unless --checkpoint names another.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Render only the sample indices A..B (A included, B excluded) of every pixel: a partial render,
    /// to be combined with `vkpath merge` (save it with --checkpoint).
    #[arg(long = "sample-range", allow_hyphen_values = true)]
    sample_range: Option<String>,
    /// Render part I (0-based) of N contiguous, near-equal sample ranges of the render's samples (a
    /// render farm's task; needs --checkpoint; merge the parts with `vkpath merge DIR`). `env/N` reads I
    /// from SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX (Kubernetes); `env` also reads N from
    /// SLURM_ARRAY_TASK_COUNT. No image is written unless -o is given.
    #[arg(long, allow_hyphen_values = true)]
    part: Option<String>,
    /// Extra layers in the EXR output: a comma-separated list of albedo, normal, variance, depth, spp
    /// (channels albedo.R/G/B, normal.X/Y/Z, variance.R/G/B, depth.Z, spp.Y).
    #[arg(long)]
    aov: Option<String>,
    /// Cut the image into tiles of at most WxH pixels (one dispatch each) and strips of at most H rows
    /// (one accumulator buffer each), instead of the adaptive cut. The image is the same.
    #[arg(long, allow_hyphen_values = true)]
    tile: Option<String>,
    /// Target duration of one dispatch in milliseconds (default 100): tiles adapt so that a dispatch
    /// stays well under a desktop GPU's watchdog. The image is the same.
    #[arg(long = "dispatch-ms", allow_negative_numbers = true)]
    dispatch_ms: Option<f64>,
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
    check_image_size(scene)?;
    if let Some(b) = a.max_bounces {
        scene.render.max_bounces = b;
    }
    if let Some(s) = a.sampler {
        scene.render.sampler = match s {
            SamplerArg::Independent => vkpath::scene::Sampler::Independent,
            SamplerArg::Sobol => vkpath::scene::Sampler::Sobol,
        };
    }
    if let Some(l) = &a.light_sampling {
        // clap has already checked the name against the same list.
        scene.render.light_sampling =
            vkpath::scene::LightSampling::from_name(l).unwrap_or_default();
    }
    if let Some(s) = a.seed {
        scene.render.seed = s;
    }
    if let Some(on) = a.adaptive {
        scene.render.adaptive.on = Some(matches!(on, OnOff::On));
    } else if a.adaptive_threshold.is_some() {
        scene.render.adaptive.on = Some(true);
    }
    if let Some(t) = a.adaptive_threshold {
        if !(t.is_finite() && t > 0.0) {
            return Err(usage(format!(
                "--adaptive-threshold must be a positive relative error (e.g. 0.01 for 1%), not {t}."
            )));
        }
        scene.render.adaptive.threshold = Some(t);
    }
    let adaptive = scene.render.adaptive.on == Some(true);
    if adaptive && (a.sample_range.is_some() || a.part.is_some()) {
        return Err(usage(
            "adaptive sampling (--adaptive on, or render.adaptive in the scene) cannot render a part of \
             the samples: which pixels go on depends on the samples before the part. Give --adaptive off \
             with --sample-range or --part.",
        ));
    }
    if adaptive && a.splat == Some(OnOff::On) {
        return Err(usage(
            "--splat on and adaptive sampling (--adaptive on, or render.adaptive in the scene) do not go \
             together: a splatted pixel averages its neighbours' samples, which adaptive sampling takes \
             in unequal numbers. Give one of them.",
        ));
    }
    match a.splat {
        Some(OnOff::On) if !scene.render.can_splat() => {
            return Err(usage(
                "--splat on needs a tent or Gaussian filter of radius at most 7.5 pixels and samples \
                 that stay on the image (render.filter, render.sample_border = false in the scene).",
            ));
        }
        Some(on) => scene.render.splat = Some(matches!(on, OnOff::On)),
        None => {
            if !scene.render.settle_splat(a.denoise || scene.image.denoise) {
                return Err(usage(
                    "the scene asks for splatting (render.splat = true), which does not go with adaptive \
                     sampling (--adaptive on): a splatted pixel averages its neighbours' samples, which \
                     adaptive sampling takes in unequal numbers. Give --splat off, or --adaptive off.",
                ));
            }
        }
    }
    if let Some(path) = &a.environment {
        // The same reader and checks as the scene file's [environment] map; radiance 1, no rotation.
        let map = vkpath::scene::environment::load_map(path)
            .map_err(|e| usage(format!("--environment {}: {e}.", path.display())))?;
        scene.environment = vkpath::scene::Environment {
            radiance: glam::Vec3::ONE,
            map: Some(std::sync::Arc::new(map)),
            rotate_deg: 0.0,
        };
    }
    Ok(())
}

/// The renderer's options from the flags that tune it (pass size, roulette, tiles, dispatch time) and
/// the fault-injection test hook.
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
    o.casts_per_dispatch = a.casts_per_dispatch;
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
        let most = vkpath::render::MAX_PATHS_IN_FLIGHT;
        if u64::from(w) * u64::from(h) > most {
            return Err(usage(format!(
                "--tile {w}x{h}: a tile may have at most {most} pixels (the paths the renderer keeps in \
                 flight, one per pixel of a dispatch), e.g. 1024x1024."
            )));
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

/// The line `vkpath render` ends with on stderr (unless `--quiet`): what it wrote, how many samples per
/// pixel in how long, at what rate, and the image's estimated relative error.
fn summary_line(session: &Session, film: &Film, seconds: f64, samples_per_second: f64) -> String {
    let mut wrote: Vec<String> = session
        .outputs()
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    if let Some(c) = session.checkpoint() {
        wrote.push(format!("checkpoint {}", c.display()));
    }
    let rel = film.estimated_rel_error();
    let error = if rel.is_finite() {
        format!("{:.2}%", 100.0 * rel)
    } else {
        "unknown".into()
    };
    let denoised = session.denoise_seconds().map_or(String::new(), |s| {
        format!(" (of the raw estimate); denoised in {s:.2} s")
    });
    format!(
        "vkpath: wrote {}: {} spp in {seconds:.2} s, {:.3} Msamples/s, estimated error {error}{denoised}",
        wrote.join(", "),
        film.spp,
        samples_per_second / 1e6
    )
}

/// The longest duration a flag takes (about 31 years): longer is surely a mistake, and any f64 of
/// seconds beyond u64 would not even convert to a `Duration`.
const MAX_DURATION_SECONDS: f64 = 1e9;

/// A positive duration for `flag`: a number of seconds (`90`, `2.5`) or a duration with units parsed by
/// humantime (`90s`, `10m`, `1h30m`, `1.5h` is not: write `1h30m`), at most [`MAX_DURATION_SECONDS`].
fn parse_duration(flag: &str, text: &str) -> Result<Duration, Error> {
    let bad = |why: &str| {
        usage(format!(
            "{flag} takes a positive duration: seconds (e.g. 90) or with units (e.g. 90s, 10m, 1h30m), \
             at most {MAX_DURATION_SECONDS:e} seconds; \"{text}\" {why}."
        ))
    };
    let t = text.trim();
    let seconds = match t.parse::<f64>() {
        Ok(v) => v,
        Err(_) => humantime::parse_duration(t)
            .map_err(|e| bad(&format!("is not one ({e})")))?
            .as_secs_f64(),
    };
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(bad("is not positive"));
    }
    if seconds > MAX_DURATION_SECONDS {
        return Err(bad("is longer"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

/// `--checkpoint-every`: `N` samples per pixel, or a duration (`30s`, `10m`, `1h`; see parse_duration).
fn parse_save_every(text: &str) -> Result<SaveEvery, Error> {
    let t = text.trim();
    if let Ok(n) = t.parse::<u64>() {
        if n == 0 || n > u64::from(u32::MAX) {
            return Err(usage(format!(
                "--checkpoint-every takes a number of samples per pixel from 1 to {} or a duration (e.g. 30s, 10m, 1h), not \"{text}\".",
                u32::MAX
            )));
        }
        return Ok(SaveEvery::Samples(n as u32));
    }
    Ok(SaveEvery::Time(parse_duration("--checkpoint-every", t)?))
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

/// `--part I/N`, `--part env/N` or `--part env`: the part's index and the number of parts. `var` reads
/// an environment variable (a parameter so that the tests need not set the process's environment).
///
/// `env` takes the index from a Slurm job array's SLURM_ARRAY_TASK_ID or a Kubernetes Indexed Job's
/// JOB_COMPLETION_INDEX, and the count from `/N` or else SLURM_ARRAY_TASK_COUNT. The index is used as
/// it is, not relative to the array's first index: a failed part is rerun as `sbatch --array=I` (an
/// array of one task, whose SLURM_ARRAY_TASK_COUNT is 1), so scripts should give `/N`. Without `/N`,
/// the array must be exactly 0..N-1 (SLURM_ARRAY_TASK_MIN = 0, SLURM_ARRAY_TASK_MAX = N - 1), so that
/// the count it reports is the number of parts.
fn resolve_part(text: &str, var: impl Fn(&str) -> Option<String>) -> Result<(u32, u32), Error> {
    let bad = |why: String| {
        usage(format!(
            "--part takes I/N (part I, from 0, of N), env/N or env (I, and N, from a Slurm job array or a \
             Kubernetes Indexed Job); \"{text}\" {why}."
        ))
    };
    let number = |what: &str, t: &str| -> Result<u32, Error> {
        t.trim().parse::<u32>().map_err(|_| {
            bad(format!(
                "has {what} \"{t}\", which is not a whole number from 0 to 2^32 - 1"
            ))
        })
    };
    let (index, count) = text.split_once('/').unwrap_or((text, ""));
    let (index, count) = if index.trim() == "env" {
        let count = (!count.is_empty() || text.contains('/'))
            .then(|| number("the count", count))
            .transpose()?;
        from_scheduler(count, &var)?
    } else {
        if !text.contains('/') {
            return Err(bad("has no \"/N\"".into()));
        }
        (number("the index", index)?, number("the count", count)?)
    };
    if count == 0 {
        return Err(bad("asks for 0 parts".into()));
    }
    if index >= count {
        return Err(usage(format!(
            "--part {text}: part {index} of {count} does not exist; parts are numbered from 0 to {}.{}",
            count - 1,
            if text.starts_with("env") {
                " Submit the job array as --array=0-(N-1), or give the right N in env/N."
            } else {
                ""
            }
        )));
    }
    Ok((index, count))
}

/// The part's index (and, without `count`, the number of parts) from the scheduler's environment.
fn from_scheduler(
    count: Option<u32>,
    var: &impl Fn(&str) -> Option<String>,
) -> Result<(u32, u32), Error> {
    let read = |name: &str| -> Result<Option<u32>, Error> {
        match var(name) {
            None => Ok(None),
            Some(v) => v.trim().parse::<u32>().map(Some).map_err(|_| {
                usage(format!(
                    "--part env: {name}={v} is not a whole number; it should be set by the scheduler \
                     (Slurm or Kubernetes), not by hand."
                ))
            }),
        }
    };
    let slurm = read("SLURM_ARRAY_TASK_ID")?;
    let k8s = read("JOB_COMPLETION_INDEX")?;
    let index = match (slurm, k8s) {
        (Some(s), Some(k)) if s != k => {
            return Err(usage(format!(
                "--part env: SLURM_ARRAY_TASK_ID={s} and JOB_COMPLETION_INDEX={k} disagree on the part's \
                 index; unset the one that does not belong to this job, or give --part I/N."
            )));
        }
        (Some(i), _) | (None, Some(i)) => i,
        (None, None) => {
            return Err(usage(
                "--part env reads the part's index from SLURM_ARRAY_TASK_ID (a Slurm job array: sbatch \
                 --array=0-(N-1)) or JOB_COMPLETION_INDEX (a Kubernetes Indexed Job), and neither is set: \
                 run it as a task of one, or give --part I/N.",
            ));
        }
    };
    if let Some(n) = count {
        return Ok((index, n));
    }
    if slurm.is_none() {
        return Err(usage(
            "--part env: JOB_COMPLETION_INDEX gives the part's index but not the number of parts: give \
             --part env/N, with N the Job's completions.",
        ));
    }
    let Some(n) = read("SLURM_ARRAY_TASK_COUNT")? else {
        return Err(usage(
            "--part env: SLURM_ARRAY_TASK_ID is set but not SLURM_ARRAY_TASK_COUNT (the number of parts): \
             give --part env/N.",
        ));
    };
    if n == 0 {
        return Err(usage(
            "--part env: SLURM_ARRAY_TASK_COUNT=0, a job array of no tasks, cannot be the number of parts \
             (Slurm sets it to 1 or more): give the number of parts with --part env/N.",
        ));
    }
    let (min, max) = (read("SLURM_ARRAY_TASK_MIN")?, read("SLURM_ARRAY_TASK_MAX")?);
    if min.is_some_and(|m| m != 0) || max.is_some_and(|m| Some(m) != n.checked_sub(1)) {
        return Err(usage(format!(
            "--part env: this job array runs the tasks {}..={} ({n} of them), not 0..={}: the task ids are \
             the parts' indices, so submit it as --array=0-{}, or give the number of parts with --part \
             env/N (a rerun of some parts: sbatch --array=I,J ... --part env/N).",
            min.map_or("?".into(), |m| m.to_string()),
            max.map_or("?".into(), |m| m.to_string()),
            n.saturating_sub(1),
            n.saturating_sub(1)
        )));
    }
    Ok((index, n))
}

/// `--light-sampling`'s values: the names of `LightSampling::ALL` (render.light_sampling in the scene).
fn light_sampling_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(vkpath::scene::LightSampling::ALL.map(|(_, n)| n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_with_and_without_units() {
        let secs = |t: &str| parse_duration("--time", t).map(|d| d.as_secs_f64());
        assert_eq!(secs("90").unwrap(), 90.0);
        assert_eq!(secs("2.5").unwrap(), 2.5);
        assert_eq!(secs("90s").unwrap(), 90.0);
        assert_eq!(secs("10m").unwrap(), 600.0);
        assert_eq!(secs("1h30m").unwrap(), 5400.0);
        for bad in ["0", "-1", "0s", "nan", "inf", "1e20", "soon", ""] {
            assert!(secs(bad).is_err(), "{bad:?} accepted");
        }
    }

    /// `--part` from the flag and from the schedulers' variables, and every inconsistency refused with
    /// the flag or the variable named.
    #[test]
    fn part_from_flag_and_environment() {
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                vars.iter()
                    .find(|(n, _)| *n == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        let none = env(&[]);
        assert_eq!(resolve_part("2/4", none).unwrap(), (2, 4));
        assert_eq!(resolve_part("0/1", none).unwrap(), (0, 1));
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "3"),
        ]);
        assert_eq!(resolve_part("env", slurm).unwrap(), (3, 4));
        assert_eq!(resolve_part("env/4", slurm).unwrap(), (3, 4));
        // A rerun of part 2 alone: an array of one task; the count comes from env/N.
        let rerun = env(&[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "1"),
            ("SLURM_ARRAY_TASK_MIN", "2"),
            ("SLURM_ARRAY_TASK_MAX", "2"),
        ]);
        assert_eq!(resolve_part("env/4", rerun).unwrap(), (2, 4));
        let k8s = env(&[("JOB_COMPLETION_INDEX", "1")]);
        assert_eq!(resolve_part("env/8", k8s).unwrap(), (1, 8));
        let err = |t: &str, var: &dyn Fn(&str) -> Option<String>| {
            resolve_part(t, var).unwrap_err().to_string()
        };
        for (t, words) in [
            ("4/4", &["part 4 of 4", "0 to 3"][..]),
            ("1/0", &["0 parts"]),
            ("3", &["--part", "/N"]),
            ("a/4", &["--part", "\"a\""]),
            ("1/-4", &["--part", "\"-4\""]),
            (
                "env",
                &["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX", "neither"],
            ),
            ("env/4", &["neither"]),
        ] {
            let e = err(t, &none);
            for w in words {
                assert!(e.contains(w), "--part {t}: {w:?} not in {e}");
            }
        }
        assert!(err("env", &rerun).contains("--array=0-0"));
        assert!(err("env", &k8s).contains("env/N"));
        assert!(err("env/2", &slurm).contains("part 3 of 2"));
        let clash = env(&[("SLURM_ARRAY_TASK_ID", "1"), ("JOB_COMPLETION_INDEX", "2")]);
        assert!(err("env/4", &clash).contains("disagree"));
        let junk = env(&[("JOB_COMPLETION_INDEX", "x1")]);
        assert!(err("env/4", &junk).contains("JOB_COMPLETION_INDEX=x1"));
        let no_count = env(&[("SLURM_ARRAY_TASK_ID", "1")]);
        assert!(err("env", &no_count).contains("SLURM_ARRAY_TASK_COUNT"));
        // Issue 31: a count of 0 named as the variable, with or without the array's bounds (it used to
        // say "0..=0 (0 of them), not 0..=0").
        let zero = env(&[
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "0"),
        ]);
        let zero_bounded = env(&[
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "0"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "0"),
        ]);
        for e in [err("env", &zero), err("env", &zero_bounded)] {
            assert!(
                e.contains("SLURM_ARRAY_TASK_COUNT=0") && !e.contains("0 of them"),
                "{e}"
            );
        }
    }
}
