//! `vkpath preview` in a real window: an X server in memory (Xvfb, through `xvfb-run -a`, which
//! `ci/setup.sh --test` installs), the window's swapchain on lavapipe, the Khronos validation layer on.
//!
//! What the window showed (`--screenshot`: the last present's pixels, read back from the swapchain
//! image) is compared with a headless
//! `vkpath render` of the same scene at the spp the preview reports: the same pixels, within 8-bit
//! rounding. A second run resizes the window, restarts, saves and orbits the camera (scripted with the
//! hidden `--script` flag, which drives the same code as the keys and the mouse), and must end without
//! a validation error, on the image of the orbited camera.
//!
//! These tests do not skip: without Xvfb they fail and say how to install it.

#![cfg(feature = "preview")]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;
use tempfile::TempDir;
use vkpath::preview::control::orbit;

const BIN: &str = env!("CARGO_BIN_EXE_vkpath");

/// Small enough for lavapipe with validation on, large enough to see the scene.
const SIZE: [&str; 4] = ["--width", "96", "--height", "64"];

fn course_scene() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/course.toml");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The course scene (a glass and a mirror ball, an area light) written into `dir`, its camera moved to
/// `position` when given.
fn write_scene(dir: &Path, name: &str, position: Option<[f32; 3]>) -> PathBuf {
    let mut text = course_scene();
    if let Some([x, y, z]) = position {
        let old = "position = [0.0, 0.0, 55.0]";
        assert!(text.contains(old), "scenes/course.toml's camera moved");
        // `{:?}` prints the shortest decimal that reads back as the same f32.
        text = text.replace(old, &format!("position = [{x:?}, {y:?}, {z:?}]"));
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn run(cmd: &mut Command) -> Output {
    cmd.output()
        .unwrap_or_else(|e| panic!("could not run {cmd:?}: {e}"))
}

/// One X server at a time: `xvfb-run -a` picks the first display number without a lock file, and two
/// started at once can pick the same one.
static XVFB: Mutex<()> = Mutex::new(());

/// `vkpath preview ARGS` under `xvfb-run -a` (a free display number each time), validation on.
fn preview(dir: &Path, args: &[&str]) -> Value {
    preview_with(dir, args, &[])
}

/// [`preview`] with environment variables set.
fn preview_with(dir: &Path, args: &[&str], env: &[(&str, &Path)]) -> Value {
    let _one_at_a_time = XVFB.lock().unwrap_or_else(|p| p.into_inner());
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24", BIN, "preview"])
        .args(args)
        .arg("--json")
        .current_dir(dir)
        .env("VKPATH_VALIDATION", "1")
        .envs(env.iter().copied())
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
            "xvfb-run is not installed, and the preview tests need an X server: run `ci/setup.sh --test` \
             (or `sudo apt-get install -y xvfb xauth`)"
        ),
        Err(e) => panic!("could not run xvfb-run: {e}"),
    };
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "vkpath preview {args:?} failed ({}):\nstdout: {stdout}\nstderr: {stderr}",
        out.status
    );
    let line = stdout
        .lines()
        .last()
        .unwrap_or_else(|| panic!("no JSON on stdout; stderr: {stderr}"));
    let report: Value =
        serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}\nstderr: {stderr}"));
    assert_eq!(
        report["validation"], true,
        "validation was not on: {report}"
    );
    assert_eq!(
        report["validation_errors"].as_array().map(Vec::len),
        Some(0),
        "{report}"
    );
    report
}

/// A headless render of `scene` at `spp`, as PNG.
fn render(dir: &Path, scene: &Path, spp: u64, out: &str) -> image::RgbImage {
    let spp = spp.to_string();
    let o = run(Command::new(BIN)
        .arg("render")
        .arg(scene)
        .args(SIZE)
        .args(["--spp", &spp, "--quiet", "-o", out])
        .current_dir(dir)
        .env("VKPATH_VALIDATION", "1"));
    assert!(
        o.status.success(),
        "render failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    read_png(&dir.join(out))
}

fn read_png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// The largest difference of any channel of any pixel; the images must be the same size.
fn max_difference(a: &image::RgbImage, b: &image::RgbImage) -> u8 {
    assert_eq!(a.dimensions(), b.dimensions());
    a.as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

fn mean(img: &image::RgbImage) -> f64 {
    img.as_raw().iter().map(|&v| f64::from(v)).sum::<f64>() / img.as_raw().len() as f64
}

fn spp_of(report: &Value) -> u64 {
    report["spp"]
        .as_u64()
        .unwrap_or_else(|| panic!("no spp: {report}"))
}

#[test]
fn the_screenshot_is_the_headless_render_at_the_same_spp() {
    let dir = TempDir::new().unwrap();
    let scene = write_scene(dir.path(), "course.toml", None);
    let scene_arg = scene.to_str().unwrap();
    let report = preview(
        dir.path(),
        &[
            &[scene_arg][..],
            &SIZE,
            &["--frames", "12", "--screenshot", "shot.png"],
        ]
        .concat(),
    );
    assert_eq!(report["presents"], 12, "{report}");
    // The window is at the image's size, so the screenshot is the window's pixels at 1:1.
    assert_eq!(report["window"], serde_json::json!([96, 64]), "{report}");
    assert_eq!(report["screenshot_source"], "swapchain", "{report}");
    assert_eq!(report["width"], 96);
    assert_eq!(report["height"], 64);
    let spp = spp_of(&report);
    assert!(spp >= 1, "{report}");
    let shown = read_png(&dir.path().join("shot.png"));
    let headless = render(dir.path(), &scene, spp, "headless.png");
    let diff = max_difference(&shown, &headless);
    assert!(
        diff <= 1,
        "the window showed other pixels than the render at {spp} spp: up to {diff}/255 apart"
    );
    // Not an empty comparison: the course box is lit (its mean 8-bit value is around 100).
    assert!(
        mean(&shown) > 20.0,
        "the screenshot is nearly black: mean {}",
        mean(&shown)
    );
}

#[test]
fn resizes_restarts_saves_and_orbits_without_validation_errors() {
    let dir = TempDir::new().unwrap();
    let scene = write_scene(dir.path(), "course.toml", None);
    let scene_arg = scene.to_str().unwrap();
    // Ends back at the image's size, so that the screenshot (the window's pixels) is at 1:1.
    let script = "3:resize 300x200; 6:restart; 9:resize 80x240; 12:save; 15:orbit 40 15; \
                  17:resize 200x150; 19:restart; 20:resize 96x64";
    let report = preview(
        dir.path(),
        &[
            &[scene_arg][..],
            &SIZE,
            &[
                "--frames",
                "28",
                "--screenshot",
                "shot.png",
                "--save-dir",
                "saved",
                "--script",
                script,
            ],
        ]
        .concat(),
    );
    assert_eq!(report["presents"], 28, "{report}");
    assert_eq!(report["restarts"], 2, "{report}");
    assert!(report["resizes"].as_u64() >= Some(4), "{report}");
    assert_eq!(report["window"], serde_json::json!([96, 64]), "{report}");
    assert_eq!(report["screenshot_source"], "swapchain", "{report}");
    // S: the image shown then, as PNG and EXR, named after its spp.
    let saved: Vec<PathBuf> = report["saved"]
        .as_array()
        .unwrap_or_else(|| panic!("{report}"))
        .iter()
        .filter_map(|p| p.as_str().map(|p| dir.path().join(p)))
        .collect();
    assert_eq!(saved.len(), 2, "{report}");
    assert!(saved[0].extension().is_some_and(|e| e == "png"));
    assert!(saved[1].extension().is_some_and(|e| e == "exr"));
    assert_eq!(read_png(&saved[0]).dimensions(), (96, 64));
    let exr = image::open(&saved[1]).unwrap_or_else(|e| panic!("{}: {e}", saved[1].display()));
    assert_eq!((exr.width(), exr.height()), (96, 64));
    // The last image is the orbited camera's, from sample 0 after the restart: the headless render of
    // the scene with that camera, at the same spp.
    let loaded = vkpath::Scene::load(&scene).unwrap();
    let moved = orbit(&loaded.camera, 40.0, 15.0);
    assert!((moved.position - loaded.camera.position).length() > 10.0);
    let orbited = write_scene(dir.path(), "orbited.toml", Some(moved.position.into()));
    let spp = spp_of(&report);
    let shown = read_png(&dir.path().join("shot.png"));
    let headless = render(dir.path(), &orbited, spp, "orbited.png");
    let diff = max_difference(&shown, &headless);
    assert!(
        diff <= 1,
        "after the orbit the window showed other pixels than the render at {spp} spp: up to {diff}/255 apart"
    );
    // And it is not the unmoved camera's image.
    let unmoved = render(dir.path(), &scene, spp, "unmoved.png");
    assert!(max_difference(&shown, &unmoved) > 16);
}

/// Root-mean-square difference of two 8-bit images, in 8-bit units.
fn rms_difference(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let sum: f64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum();
    (sum / a.as_raw().len() as f64).sqrt()
}

/// D (a scripted `denoise`) shows the denoised image: the screenshot at N spp is closer to the
/// converged image (1024 spp) than the raw render at the same N is, by a stated factor (below 0.7 of
/// its RMS difference). Without the denoiser the window goes on with the raw view and says why.
#[test]
fn the_denoised_view_is_closer_to_the_converged_image() {
    let dir = TempDir::new().unwrap();
    let scene = write_scene(dir.path(), "course.toml", None);
    let scene_arg = scene.to_str().unwrap();
    let report = preview(
        dir.path(),
        &[
            &[scene_arg][..],
            &SIZE,
            &[
                "--spp",
                "4",
                "--frames",
                "30",
                "--screenshot",
                "shot.png",
                "--script",
                "1:denoise",
            ],
        ]
        .concat(),
    );
    assert!(report["denoise_error"].is_null(), "{report}");
    assert!(
        report["denoised_images_shown"].as_u64() >= Some(1),
        "{report}"
    );
    assert_eq!(spp_of(&report), 4, "{report}");
    let shown = read_png(&dir.path().join("shot.png"));
    let raw = render(dir.path(), &scene, 4, "raw.png");
    let converged = render(dir.path(), &scene, 1024, "converged.png");
    let (e_shown, e_raw) = (
        rms_difference(&shown, &converged),
        rms_difference(&raw, &converged),
    );
    assert!(
        e_shown < 0.7 * e_raw,
        "denoised view {e_shown} vs raw {e_raw} (8-bit RMS)"
    );
    // No denoiser: the raw view, and the reason in the report.
    let empty = dir.path().join("no-oidn");
    std::fs::create_dir(&empty).unwrap();
    let report = preview_with(
        dir.path(),
        &[
            &[scene_arg][..],
            &SIZE,
            &["--frames", "6", "--script", "1:denoise"],
        ]
        .concat(),
        &[("VKPATH_OIDN_DIR", &empty)],
    );
    assert_eq!(report["denoised_images_shown"], 0, "{report}");
    let why = report["denoise_error"]
        .as_str()
        .unwrap_or_else(|| panic!("{report}"));
    assert!(why.contains("ci/setup.sh --denoise"), "{why}");
}

#[test]
fn without_a_display_it_fails_in_one_paragraph() {
    let dir = TempDir::new().unwrap();
    let o = run(Command::new(BIN)
        .args(["preview", "--frames", "1"])
        .current_dir(dir.path())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("DISPLAY") && stderr.contains("xvfb-run"),
        "{stderr}"
    );
}

#[test]
fn flag_errors_exit_2_before_any_window() {
    let dir = TempDir::new().unwrap();
    for (args, words) in [
        (
            &["preview", "--screenshot", "a.png"][..],
            &["--screenshot", "--frames"][..],
        ),
        (
            &["preview", "--frames", "2", "--screenshot", "a.jpg"],
            &["PNG"],
        ),
        (&["preview", "--frames", "0"], &["--frames"]),
        (&["preview", "--fps", "0"], &["--fps"]),
        (
            &["preview", "--frames", "1", "--script", "1:jump"],
            &["--script", "jump"],
        ),
        (&["preview", "missing.toml"], &["missing.toml"]),
    ] {
        let o = run(Command::new(BIN)
            .args(args)
            .current_dir(dir.path())
            .env_remove("DISPLAY"));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        for w in words {
            assert!(stderr.contains(w), "{args:?}: {w:?} not in {stderr}");
        }
    }
}
