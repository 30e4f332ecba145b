//! `vkpath preview`: a window that shows the render converging. Without the `preview` cargo feature the
//! flags and the scene are still checked, and the command then says how to get a window.

use super::{check_image_size, load_scene, usage};
use clap::Args;
use std::path::PathBuf;
use vkpath::{Error, Scene};

#[derive(Args)]
// Without the `preview` feature the flags are still parsed and checked, but not all of them are read.
#[cfg_attr(not(feature = "preview"), allow(dead_code))]
pub struct PreviewArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// Stop accumulating at N samples per pixel (the window stays open). Default: never stop.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Image width in pixels (overrides the scene); the window shows the image scaled to fit.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    height: Option<u32>,
    /// Random seed (overrides the scene).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(0..))]
    seed: Option<u32>,
    /// Scattering events per path, -1 for no limit (overrides the scene).
    #[arg(long = "max-bounces", allow_negative_numbers = true, value_parser = super::parse_max_bounces)]
    max_bounces: Option<u32>,
    /// Exit after N presents of a rendered image (scripted use; see --json for the spp shown).
    #[arg(long, allow_negative_numbers = true)]
    frames: Option<u64>,
    /// With --frames: save the image shown by the last present as PNG (the same bytes as shown).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Directory where S saves <scene-stem>-<spp>spp.png and .exr. Default: the current directory.
    #[arg(long = "save-dir", default_value = ".")]
    save_dir: PathBuf,
    /// Presents per second the window aims at (the latest image is shown again while passes run).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    fps: f64,
    /// Print one JSON object on stdout when the window closes (spp shown, presents/s, ...).
    #[arg(long)]
    json: bool,
    /// Scripted input for tests: "N:ACTION; ...", ACTION one of `resize WxH`, `restart`,
    /// `orbit AZ EL`, `save`, run after present N.
    #[arg(long, hide = true)]
    script: Option<String>,
}

/// `vkpath preview`: flags and scene are checked the same way with or without the `preview` feature.
pub fn run_preview(a: PreviewArgs) -> Result<i32, Error> {
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
    let mut scene = load_scene(a.scene.as_deref(), None)?;
    // The same overrides and size rule as `vkpath render` (apply_overrides).
    scene.image.width = a.width.unwrap_or(scene.image.width);
    scene.image.height = a.height.unwrap_or(scene.image.height);
    check_image_size(&scene)?;
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
        options: vkpath::render::RenderOptions::default(),
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
    if super::report_validation_errors(&report.validation_errors) {
        code = 1;
    }
    Ok(code)
}
