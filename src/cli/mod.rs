//! The subcommands of the `vkpath` binary (contract: docs/cli.md), one module each, and what they share:
//! the parsed command line, usage errors, the stop handler and the checks every command makes the same
//! way. Each `run` returns the exit status to end with, or an error that `main` maps to one.

mod bench;
mod compare;
mod convert;
mod denoise;
mod info;
mod merge;
mod paths;
mod preview;
mod render;
mod report;

use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use vkpath::scene::import::Importer;
use vkpath::scene::translated::ImportOptions;
use vkpath::{Error, Scene};

#[derive(Parser)]
#[command(
    name = "vkpath",
    version,
    about = "A physically based path tracer on Vulkan compute"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene (the embedded course scene when none is given) to PNG/EXR.
    Render(Box<render::RenderArgs>),
    /// Open a window and watch the render converge (cargo feature `preview`). Keys: S saves the image
    /// (PNG + EXR), D toggles the denoised view, R restarts, Esc/Q quits; drag with the left button to
    /// orbit the camera.
    Preview(Box<preview::PreviewArgs>),
    /// Combine partial renders (--part or --sample-range checkpoints; a directory, a glob) into the image
    /// of their union.
    Merge(merge::MergeArgs),
    /// Benchmarks that report measured ratios.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Denoise an EXR that carries albedo and normal layers (Intel Open Image Denoise, loaded at run
    /// time: ci/setup.sh --denoise installs it).
    Denoise(denoise::DenoiseArgs),
    /// Write any scene vkpath can read (TOML, glTF) as vkpath TOML: what was understood, to see and edit.
    Convert(convert::ConvertArgs),
    /// Whether two images hold the same pixels (exit 0) or not (exit 1), and how far apart they are.
    Compare(compare::CompareArgs),
    /// List the Vulkan devices, the one chosen and why, and its limits.
    Info {
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// Runs a parsed command: the exit status it ends with, or the error that decides it.
pub fn run(command: Command) -> Result<i32, Error> {
    match command {
        Command::Render(a) => render::run_render(*a),
        Command::Preview(p) => preview::run_preview(*p),
        Command::Info { json } => info::run_info(json),
        Command::Merge(m) => merge::run_merge(m),
        Command::Convert(c) => convert::run_convert(c),
        Command::Denoise(d) => denoise::run_denoise(d),
        Command::Compare(c) => compare::run_compare(c),
        Command::Bench(b) => bench::run_bench(b),
    }
}

fn usage(msg: impl Into<String>) -> Error {
    Error::Usage(msg.into())
}

/// `--camera auto|N`: a glTF scene framed from its bounds, or a camera (sensor) by index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraArg {
    Auto,
    Index(u32),
}

impl CameraArg {
    /// Import options with this camera choice and nothing else set.
    fn options(arg: Option<CameraArg>) -> ImportOptions {
        ImportOptions {
            camera: match arg {
                Some(CameraArg::Index(n)) => Some(n as usize),
                _ => None,
            },
            auto_camera: arg == Some(CameraArg::Auto),
            ..ImportOptions::default()
        }
    }
}

/// Parses `--camera`: `auto` or a camera index (0, 1, ...); clap names the flag in the error.
fn parse_camera(text: &str) -> Result<CameraArg, String> {
    if text == "auto" {
        return Ok(CameraArg::Auto);
    }
    text.parse::<u32>()
        .map(CameraArg::Index)
        .map_err(|_| format!("\"{text}\" is neither auto nor a camera index (0, 1, 2, ...)"))
}

/// The scene file given (TOML or glTF; `camera` picks a glTF scene's camera), or the embedded course
/// scene when none is. What the reader noticed and worked around (Scene::warnings) is printed on stderr,
/// one line each.
fn load_scene(path: Option<&Path>, camera: Option<usize>) -> Result<Scene, Error> {
    let options = ImportOptions {
        camera,
        ..ImportOptions::default()
    };
    load_scene_with(path, &options)
}

/// [`load_scene`] with every import option: `--xml-lenient` (a Mitsuba XML scene's unknown elements are
/// skipped with a warning) and `-D` (a Mitsuba XML scene's `<default>` parameters), which only an XML
/// scene takes.
fn load_scene_with(path: Option<&Path>, options: &ImportOptions) -> Result<Scene, Error> {
    if let (Some(path), Some((name, _))) = (path, options.defines.first())
        && !Importer::for_path(path).takes_defines
    {
        return Err(usage(format!(
            "-D {name}=...: -D sets the <default> parameters of a Mitsuba XML scene, and {} is a {} file.",
            path.display(),
            Importer::for_path(path).name
        )));
    }
    let scene = match (path, options.camera.is_some() || options.auto_camera) {
        (Some(path), _) => Scene::load_with(path, options)?,
        (None, false) if options.defines.is_empty() => Scene::default_scene(),
        (None, false) => {
            return Err(usage(
                "-D sets the <default> parameters of a Mitsuba XML scene; give the scene file as well.",
            ));
        }
        (None, true) => {
            return Err(usage(
                "--camera picks a camera of a glTF or Mitsuba XML scene file; give the scene file as well.",
            ));
        }
    };
    for w in &scene.warnings {
        eprintln!("{}", vkpath::scene::warning_line(w));
    }
    Ok(scene)
}

/// The image size rule of the scene file, checked again after the command line has overridden it.
fn check_image_size(scene: &Scene) -> Result<(), Error> {
    let (w, h) = (scene.image.width as u64, scene.image.height as u64);
    if w == 0 || h == 0 || w > 65536 || h > 65536 || w * h > (1 << 28) {
        return Err(usage(format!(
            "an image of {w}x{h} pixels is not allowed: width and height must be 1..=65536 and their product at most 2^28 (268435456)."
        )));
    }
    Ok(())
}

/// Refuses, before any work, an output whose image format the extension does not name.
fn check_output_formats(outputs: &[PathBuf]) -> Result<(), Error> {
    for o in outputs {
        if vkpath::film::OutputFormat::from_path(o).is_none() {
            return Err(usage(format!(
                "cannot tell the image format of output {}: use a .png or .exr extension.",
                o.display()
            )));
        }
    }
    Ok(())
}

/// Ctrl-C, SIGTERM and SIGHUP end the render after the pass in flight (the outputs and the checkpoint are
/// then written); a second one exits at once (every file on disk is still whole: they are written
/// atomically). Before the passes start (`started` still false: the scene is uploaded and the kernel
/// compiled, which can take minutes on a cold shader cache), there is nothing to write, so the first
/// one exits at once, with status 1 (an interrupted render that wrote nothing).
fn install_stop_handler() -> (Arc<AtomicBool>, Arc<AtomicBool>) {
    let stop = Arc::new(AtomicBool::new(false));
    let started = Arc::new(AtomicBool::new(false));
    let (flag, passes) = (stop.clone(), started.clone());
    // If a handler cannot be installed (e.g. one already exists in an embedding), a signal just kills us.
    let _ = ctrlc::set_handler(move || {
        if !passes.load(Ordering::SeqCst) {
            eprintln!(
                "vkpath: interrupted before the first sample (while the scene was uploaded and the \
                 kernel compiled); nothing was written."
            );
            std::process::exit(1);
        }
        if flag.swap(true, Ordering::SeqCst) {
            eprintln!("vkpath: interrupted twice; exiting now without writing.");
            std::process::exit(130);
        }
    });
    (stop, started)
}

/// The Vulkan validation layer's errors (only collected when VKPATH_VALIDATION is set) on stderr; true
/// when there were any, which makes the command end with status 1: they are bugs in vkpath.
fn report_validation_errors(errors: &[String]) -> bool {
    if errors.is_empty() {
        return false;
    }
    for e in errors {
        eprintln!("vkpath: Vulkan validation error: {e}");
    }
    eprintln!(
        "vkpath: the Vulkan validation layer reported {} error(s) (VKPATH_VALIDATION is set); this is a bug in vkpath.",
        errors.len()
    );
    true
}

/// `-D NAME=VALUE`: a Mitsuba XML `<default>` parameter, as Mitsuba's own command line takes it.
fn parse_define(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err("expected NAME=VALUE, e.g. -D integrator=path".into()),
    }
}

/// `--max-bounces N`: a count of scattering events, or -1 for no limit
/// ([`vkpath::scene::NO_BOUNCE_LIMIT`]).
fn parse_max_bounces(text: &str) -> Result<u32, String> {
    match text.trim().parse::<i64>() {
        Ok(-1) => Ok(vkpath::scene::NO_BOUNCE_LIMIT),
        Ok(n) if (0..i64::from(u32::MAX)).contains(&n) => Ok(n as u32),
        _ => Err(format!(
            "expected a number of bounces from 0 to {}, or -1 for no limit",
            u32::MAX - 1
        )),
    }
}
