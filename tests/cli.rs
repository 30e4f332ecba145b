//! The `vkpath` binary against its contract (docs/cli.md and the "Errors" and "Outputs" sections
//! of docs/scene-format.md), run as a child process with the Khronos validation layer on
//! (`VKPATH_VALIDATION=1`: the CLI then exits 1 if the layer reported anything).
//!
//! Every test works in its own temporary directory, which is also the child's working directory, so
//! that "no output was written" can be checked by listing it. Renders are tiny: lavapipe is slow.

use image::DynamicImage;
use serde_json::Value;
use std::collections::BTreeSet;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// Longer than any render here takes, even with every test running at once on two cores.
const TIMEOUT: Duration = Duration::from_secs(300);

/// A small scene whose own settings (64x48, 4 spp, seed 7, 2 bounces) differ from every override the
/// tests pass. A diffuse ball on a floor lit by a sphere light that is outside the view (level with
/// the camera, above it), so that with `max_bounces = 0` the image is black, and with the Gaussian
/// filter and the sampled sphere light every seed gives a different noise.
const TINY: &str = r#"[camera]
position = [0.0, 0.0, 30.0]
look_at  = [0.0, 0.0, 0.0]
fov      = 50.0

[image]
width  = 64
height = 48

[render]
samples     = 4
max_bounces = 2
seed        = 7

[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }

[[sphere]]
center   = [0.0, 0.0, 0.0]
radius   = 8.0
material = "white"

[[sphere]]
center   = [0.0, -1008.0, 0.0]
radius   = 1000.0
material = "white"

[[light]]
type   = "sphere"
center = [10.0, 30.0, 30.0]
radius = 3.0
power  = 40000.0
"#;

/// Lines 1-7 of the bad scenes: a valid camera and one material. Text appended starts at line 8.
const BASE: &str = r#"[camera]
position = [0, 0, 10]
look_at  = [0, 0, 0]
fov      = 60

[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
"#;

/// A valid sphere for [`BASE`], at lines 8-11.
const SPHERE: &str = "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\n";

struct Run {
    /// The exit status; `None` if the process was killed by a signal.
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// The command line, for messages.
    what: String,
}

impl Run {
    #[track_caller]
    fn assert_success(&self) {
        assert_eq!(
            self.code,
            Some(0),
            "`{}` should succeed\nstdout: {}\nstderr: {}",
            self.what,
            self.stdout,
            self.stderr
        );
    }

    /// The single JSON object on stdout.
    #[track_caller]
    fn json(&self) -> serde_json::Map<String, Value> {
        let mut values = serde_json::Deserializer::from_str(&self.stdout).into_iter::<Value>();
        let first = values
            .next()
            .unwrap_or_else(|| {
                panic!(
                    "`{}` printed no JSON on stdout: {:?}",
                    self.what, self.stdout
                )
            })
            .unwrap_or_else(|e| {
                panic!(
                    "`{}`: stdout is not JSON ({e}): {:?}",
                    self.what, self.stdout
                )
            });
        assert!(
            values.next().is_none(),
            "`{}`: stdout must hold exactly one JSON value: {:?}",
            self.what,
            self.stdout
        );
        match first {
            Value::Object(map) => map,
            other => panic!("`{}`: stdout's JSON is not an object: {other}", self.what),
        }
    }
}

/// Runs `vkpath ARGS` in `dir` with validation on, killing it after [`TIMEOUT`].
fn vkpath(dir: &Path, args: &[&str]) -> Run {
    let what = format!("vkpath {}", args.join(" "));
    let mut child = Command::new(env!("CARGO_BIN_EXE_vkpath"))
        .args(args)
        .current_dir(dir)
        .env("VKPATH_VALIDATION", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start `{what}`: {e}"));
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            r.read_to_string(&mut s).map(|_| s)
        })
    };
    let out = drain(Box::new(child.stdout.take().expect("piped stdout")));
    let err = drain(Box::new(child.stderr.take().expect("piped stderr")));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for vkpath") {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("`{what}` did not finish within {TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stdout = out.join().expect("stdout reader").expect("stdout is UTF-8");
    let stderr = err.join().expect("stderr reader").expect("stderr is UTF-8");
    Run {
        code: status.code(),
        stdout,
        stderr,
        what,
    }
}

/// A temporary directory holding `name` with `text`.
fn dir_with(name: &str, text: &str) -> TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join(name), text).expect("write scene");
    dir
}

/// The names of the entries in `dir` (hidden files included: temporary files start with a dot).
fn listing(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .expect("read temp dir")
        .map(|e| {
            e.expect("dir entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect()
}

#[track_caller]
fn assert_listing(dir: &Path, expected: &[&str], context: &str) {
    let expected: BTreeSet<String> = expected.iter().map(|s| s.to_string()).collect();
    assert_eq!(
        listing(dir),
        expected,
        "files in the working directory after {context}"
    );
}

fn field_u64(json: &serde_json::Map<String, Value>, key: &str) -> u64 {
    json.get(key)
        .and_then(Value::as_u64)
        .unwrap_or_else(|| panic!("JSON field {key:?} should be an unsigned integer: {json:?}"))
}

fn field_f64(json: &serde_json::Map<String, Value>, key: &str) -> f64 {
    json.get(key)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("JSON field {key:?} should be a number: {json:?}"))
}

fn field_str<'j>(json: &'j serde_json::Map<String, Value>, key: &str) -> &'j str {
    json.get(key)
        .and_then(Value::as_str)
        .unwrap_or_else(|| panic!("JSON field {key:?} should be a string: {json:?}"))
}

fn open_image(path: &Path) -> DynamicImage {
    image::open(path).unwrap_or_else(|e| panic!("cannot decode {}: {e}", path.display()))
}

/// The linear RGB pixels of an EXR, as written by the CLI.
fn exr_pixels(path: &Path) -> (u32, u32, Vec<f32>) {
    let img = open_image(path);
    assert!(
        matches!(
            img,
            DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_)
        ),
        "{} should decode to a float image, got {:?}",
        path.display(),
        img.color()
    );
    let rgb = img.to_rgb32f();
    (rgb.width(), rgb.height(), rgb.into_raw())
}

/// Does `message` contain "line N" with nothing more to the number (so "line 1" does not match "line 12")?
fn mentions_line(message: &str, line: usize) -> bool {
    let needle = format!("line {line}");
    message.match_indices(&needle).any(|(i, _)| {
        !message[i + needle.len()..]
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_digit())
    })
}

// ---------------------------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------------------------

#[test]
fn render_json_png_and_exr() {
    let dir = dir_with("tiny.toml", TINY);
    let args = [
        "render",
        "tiny.toml",
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "2",
        "--json",
        "-o",
        "out.png",
        "-o",
        "out.exr",
    ];
    let run = vkpath(dir.path(), &args);
    run.assert_success();
    let json = run.json();
    for key in [
        "scene",
        "width",
        "height",
        "spp",
        "seconds",
        "samples_per_second",
        "estimated_rel_error",
        "device",
    ] {
        assert!(
            json.contains_key(key),
            "--json output lacks {key:?}: {json:?}"
        );
    }
    assert!(
        field_str(&json, "scene").contains("tiny"),
        "scene should name tiny.toml: {json:?}"
    );
    assert_eq!(field_u64(&json, "width"), 32);
    assert_eq!(field_u64(&json, "height"), 32);
    assert_eq!(field_u64(&json, "spp"), 2);
    let seconds = field_f64(&json, "seconds");
    assert!(
        seconds > 0.0 && seconds < TIMEOUT.as_secs_f64(),
        "seconds = {seconds}"
    );
    let sps = field_f64(&json, "samples_per_second");
    let expected = 32.0 * 32.0 * 2.0 / seconds;
    assert!(
        ((sps - expected) / expected).abs() < 1e-6,
        "samples_per_second = {sps}, but width*height*spp/seconds = {expected}"
    );
    // 2 spp of a noisy scene: the variance estimate exists and is positive.
    let rel = field_f64(&json, "estimated_rel_error");
    assert!(rel.is_finite() && rel > 0.0, "estimated_rel_error = {rel}");
    assert!(
        !field_str(&json, "device").trim().is_empty(),
        "device should name the Vulkan device: {json:?}"
    );
    assert_listing(dir.path(), &["tiny.toml", "out.png", "out.exr"], &run.what);

    let png = open_image(&dir.path().join("out.png"));
    let DynamicImage::ImageRgb8(png) = png else {
        panic!("out.png should be 8-bit RGB, is {:?}", png.color());
    };
    assert_eq!(png.dimensions(), (32, 32), "out.png size");
    let (w, h, exr) = exr_pixels(&dir.path().join("out.exr"));
    assert_eq!((w, h), (32, 32), "out.exr size");
    assert!(
        exr.iter().all(|v| v.is_finite() && *v >= 0.0),
        "out.exr holds a negative or non-finite radiance"
    );
    assert!(
        exr.iter().any(|&v| v > 0.0),
        "out.exr is black: the lit ball should show"
    );
    // The PNG is the EXR through the default display transform: clamp(L, 0, 1)^(1/2.2), 8 bits.
    for (i, (&l, &p)) in exr.iter().zip(png.as_raw()).enumerate() {
        let expected = (l.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round();
        assert!(
            (expected - p as f32).abs() <= 1.0,
            "pixel {} channel {}: EXR radiance {l} should display as {expected}, PNG has {p}",
            i / 3,
            i % 3
        );
    }
}

#[test]
fn default_output_is_scene_stem_png_in_cwd() {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--width",
            "32",
            "--height",
            "32",
            "--spp",
            "2",
        ],
    );
    run.assert_success();
    assert!(
        run.stdout.trim().is_empty(),
        "without --json stdout should be empty: {:?}",
        run.stdout
    );
    assert_listing(dir.path(), &["tiny.toml", "tiny.png"], &run.what);
    let png = open_image(&dir.path().join("tiny.png"));
    assert_eq!((png.width(), png.height()), (32, 32), "tiny.png size");
}

#[test]
fn no_scene_renders_the_embedded_course_scene() {
    let dir = tempfile::tempdir().expect("temp dir");
    let run = vkpath(
        dir.path(),
        &[
            "render", "--width", "32", "--height", "32", "--spp", "2", "--json",
        ],
    );
    run.assert_success();
    let json = run.json();
    assert!(
        field_str(&json, "scene").contains("course"),
        "the default scene should report itself as the course scene: {json:?}"
    );
    assert_eq!(field_u64(&json, "spp"), 2);
    assert_listing(dir.path(), &["course.png"], &run.what);
    let png = open_image(&dir.path().join("course.png"));
    assert_eq!((png.width(), png.height()), (32, 32), "course.png size");
    // The course's box is lit everywhere: no black image.
    assert!(
        png.to_rgb8().as_raw().iter().any(|&v| v > 0),
        "course.png is black"
    );
}

#[test]
fn scene_settings_are_reported_without_overrides() {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &["render", "tiny.toml", "--json", "-o", "t.png"],
    );
    run.assert_success();
    let json = run.json();
    assert_eq!(field_u64(&json, "width"), 64, "{json:?}");
    assert_eq!(field_u64(&json, "height"), 48, "{json:?}");
    assert_eq!(field_u64(&json, "spp"), 4, "{json:?}");
    assert_eq!(field_u64(&json, "seed"), 7, "{json:?}");
    assert_eq!(field_u64(&json, "max_bounces"), 2, "{json:?}");
    let png = open_image(&dir.path().join("t.png"));
    assert_eq!((png.width(), png.height()), (64, 48), "t.png size");
}

#[test]
fn flags_override_the_scene() {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--seed",
            "3",
            "--max-bounces",
            "1",
            "--width",
            "24",
            "--height",
            "16",
            "--spp",
            "3",
            "--json",
            "-o",
            "t.png",
            "-o",
            "t.exr",
        ],
    );
    run.assert_success();
    let json = run.json();
    assert_eq!(field_u64(&json, "width"), 24, "{json:?}");
    assert_eq!(field_u64(&json, "height"), 16, "{json:?}");
    assert_eq!(field_u64(&json, "spp"), 3, "{json:?}");
    assert_eq!(field_u64(&json, "seed"), 3, "{json:?}");
    assert_eq!(field_u64(&json, "max_bounces"), 1, "{json:?}");
    let png = open_image(&dir.path().join("t.png"));
    assert_eq!(
        (png.width(), png.height()),
        (24, 16),
        "t.png size (width x height)"
    );
    let (w, h, _) = exr_pixels(&dir.path().join("t.exr"));
    assert_eq!((w, h), (24, 16), "t.exr size (width x height)");
}

/// `--max-bounces` reaches the renderer: with 0 bounces only lights and the background show, and the
/// light is out of view on a black background.
#[test]
fn max_bounces_override_changes_the_image() {
    let dir = dir_with("tiny.toml", TINY);
    let common = [
        "render",
        "tiny.toml",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "2",
    ];
    let zero = vkpath(
        dir.path(),
        &[&common[..], &["--max-bounces", "0", "-o", "b0.exr"]].concat(),
    );
    zero.assert_success();
    let one = vkpath(
        dir.path(),
        &[&common[..], &["--max-bounces", "1", "-o", "b1.exr"]].concat(),
    );
    one.assert_success();
    let (_, _, b0) = exr_pixels(&dir.path().join("b0.exr"));
    let (_, _, b1) = exr_pixels(&dir.path().join("b1.exr"));
    assert!(
        b0.iter().all(|&v| v == 0.0),
        "--max-bounces 0: the image should be black (light out of view, black background)"
    );
    assert!(
        b1.iter().any(|&v| v > 0.0),
        "--max-bounces 1: direct light should show"
    );
}

/// Same scene, same seed: identical EXR bytes (the EXR holds no time stamp). A different seed: different
/// noise.
#[test]
fn same_seed_gives_identical_exr_and_seed_matters() {
    let dir = dir_with("tiny.toml", TINY);
    let render = |seed: &str, out: &str| {
        let run = vkpath(
            dir.path(),
            &[
                "render",
                "tiny.toml",
                "--width",
                "32",
                "--height",
                "32",
                "--spp",
                "2",
                "--seed",
                seed,
                "-o",
                out,
            ],
        );
        run.assert_success();
        // The pixels as bits (the files' metadata differ: each records its own seconds).
        let (_, _, p) = exr_pixels(&dir.path().join(out));
        p.iter().map(|v| v.to_bits()).collect::<Vec<u32>>()
    };
    let a = render("5", "a.exr");
    let b = render("5", "b.exr");
    assert!(a == b, "two renders with seed 5 wrote different pixels");
    render("6", "c.exr");
    let (_, _, pa) = exr_pixels(&dir.path().join("a.exr"));
    let (_, _, pc) = exr_pixels(&dir.path().join("c.exr"));
    assert_ne!(
        pa, pc,
        "seeds 5 and 6 gave the same pixels: --seed is ignored"
    );
}

#[test]
fn progress_every_rewrites_outputs_and_finishes() {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "3",
            "--samples-per-pass",
            "1",
            "--progress-every",
            "1",
            "--json",
            "-o",
            "p.png",
            "-o",
            "p.exr",
        ],
    );
    run.assert_success();
    assert_eq!(field_u64(&run.json(), "spp"), 3, "final spp");
    // No temporary file survives the checkpoints.
    assert_listing(dir.path(), &["tiny.toml", "p.png", "p.exr"], &run.what);
    let (w, h, _) = exr_pixels(&dir.path().join("p.exr"));
    assert_eq!((w, h), (16, 16));
    let png = open_image(&dir.path().join("p.png"));
    assert_eq!((png.width(), png.height()), (16, 16));
}

// ---------------------------------------------------------------------------------------------------
// `vkpath info`
// ---------------------------------------------------------------------------------------------------

fn rendering_device() -> String {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--json",
        ],
    );
    run.assert_success();
    field_str(&run.json(), "device").to_string()
}

#[test]
fn info_names_the_rendering_device() {
    let device = rendering_device();
    let dir = tempfile::tempdir().expect("temp dir");
    let run = vkpath(dir.path(), &["info"]);
    run.assert_success();
    assert!(
        run.stdout.contains(&device),
        "`vkpath info` should mention the device that renders ({device:?}):\n{}",
        run.stdout
    );
    assert_listing(dir.path(), &[], "vkpath info");
}

#[test]
fn info_json_lists_devices_and_the_chosen_one() {
    let device = rendering_device();
    let dir = tempfile::tempdir().expect("temp dir");
    let run = vkpath(dir.path(), &["info", "--json"]);
    run.assert_success();
    let json = run.json();
    let devices = json
        .get("devices")
        .and_then(Value::as_array)
        .unwrap_or_else(|| panic!("`devices` should be an array: {json:?}"));
    assert!(!devices.is_empty(), "no devices listed: {json:?}");
    let chosen = field_u64(&json, "chosen") as usize;
    assert!(
        chosen < devices.len(),
        "chosen = {chosen} but {} devices",
        devices.len()
    );
    assert_eq!(
        devices[chosen].get("name").and_then(Value::as_str),
        Some(device.as_str()),
        "the chosen device should be the one `render` uses: {json:?}"
    );
}

// ---------------------------------------------------------------------------------------------------
// Bad scenes: exit 2, one paragraph naming the file, the line and the key, nothing written
// ---------------------------------------------------------------------------------------------------

/// Renders `text` saved as `bad.toml` and checks the contract's error rules.
#[track_caller]
fn expect_scene_error(text: &str, line: usize, key: &str) {
    let dir = dir_with("bad.toml", text);
    let run = vkpath(
        dir.path(),
        &[
            "render", "bad.toml", "--width", "8", "--height", "8", "--spp", "1",
        ],
    );
    assert_eq!(
        run.code,
        Some(2),
        "a bad scene should exit with status 2\nstderr: {}",
        run.stderr
    );
    let message = run.stderr.trim();
    assert!(
        !message.contains('\n'),
        "the error must be one paragraph on one line: {message:?}"
    );
    assert!(!message.contains("panicked"), "vkpath panicked: {message}");
    assert!(
        message.contains("bad.toml"),
        "the error should name the file bad.toml: {message}"
    );
    assert!(
        mentions_line(message, line),
        "the error should say \"line {line}\": {message}"
    );
    assert!(
        message.contains(key),
        "the error should name the key {key}: {message}"
    );
    assert!(run.stdout.is_empty(), "nothing on stdout: {:?}", run.stdout);
    assert_listing(dir.path(), &["bad.toml"], &run.what);
}

#[test]
fn scene_error_invalid_toml() {
    // Line 10: a value followed by garbage on the same line.
    let text =
        format!("{BASE}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1 2\nmaterial = \"white\"\n");
    expect_scene_error(&text, 10, "radius");
}

/// A missing environment map (relative to the scene file) is a scene error like any other: exit 2,
/// the key and the map's path named, nothing written.
#[test]
fn scene_error_missing_environment_map() {
    let text = format!("{BASE}{SPHERE}[environment]\nmap = \"maps/none.exr\"  # line 13\n");
    expect_scene_error(&text, 13, "environment.map");
}

#[test]
fn scene_error_unknown_key() {
    expect_scene_error(&format!("{BASE}{SPHERE}colour = 3\n"), 12, "colour");
}

#[test]
fn scene_error_undefined_material() {
    let text = format!("{BASE}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"red\"\n");
    expect_scene_error(&text, 11, "sphere[0].material");
}

#[test]
fn scene_error_radius_zero() {
    let text =
        format!("{BASE}{SPHERE}[[sphere]]\ncenter = [0, 0, 0]\nradius = 0\nmaterial = \"white\"\n");
    expect_scene_error(&text, 14, "sphere[1].radius");
}

#[test]
fn scene_error_negative_radius() {
    let text =
        format!("{BASE}[[sphere]]\ncenter = [0, 0, 0]\nradius = -2.5\nmaterial = \"white\"\n");
    expect_scene_error(&text, 10, "sphere[0].radius");
}

#[test]
fn scene_error_nan() {
    let text =
        format!("{BASE}[[sphere]]\ncenter = [0, nan, 0]\nradius = 1\nmaterial = \"white\"\n");
    expect_scene_error(&text, 9, "sphere[0].center");
}

#[test]
fn scene_error_fov_180() {
    let text = BASE.replace("fov      = 60", "fov      = 180");
    expect_scene_error(&format!("{text}{SPHERE}"), 4, "camera.fov");
}

#[test]
fn scene_error_look_at_equals_position() {
    let text = BASE.replace("look_at  = [0, 0, 0]", "look_at  = [0, 0, 10]");
    expect_scene_error(&format!("{text}{SPHERE}"), 3, "camera.look_at");
}

#[test]
fn scene_error_mesh_obj_missing() {
    let text = format!("{BASE}{SPHERE}[[mesh]]\nobj = \"bunny.obj\"\nmaterial = \"white\"\n");
    expect_scene_error(&text, 13, "mesh[0].obj");
}

// ---------------------------------------------------------------------------------------------------
// Bad flags: exit 2, a one-paragraph message that names the problem, nothing written
// ---------------------------------------------------------------------------------------------------

/// Runs `vkpath ARGS` next to a valid `tiny.toml` and expects status 2 with a one-line message on stderr
/// containing every one of `words`, and no file written.
#[track_caller]
fn expect_usage_error(args: &[&str], words: &[&str]) {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(dir.path(), args);
    assert_eq!(
        run.code,
        Some(2),
        "`{}` should exit with status 2\nstderr: {}",
        run.what,
        run.stderr
    );
    let message = run.stderr.trim();
    assert!(!message.is_empty(), "`{}`: no message on stderr", run.what);
    assert!(
        !message.contains('\n'),
        "`{}`: the message must be one paragraph on one line: {message:?}",
        run.what
    );
    for word in words {
        assert!(
            message.contains(word),
            "`{}`: the message should mention {word:?}: {message}",
            run.what
        );
    }
    assert!(
        run.stdout.is_empty(),
        "`{}`: nothing on stdout: {:?}",
        run.what,
        run.stdout
    );
    assert_listing(dir.path(), &["tiny.toml"], &run.what);
}

/// Output flags shared by the bad-flag tests, so that a wrongly accepted flag would write files.
const OUTS: [&str; 4] = ["-o", "out.png", "-o", "out.exr"];

#[test]
fn flag_error_spp_zero() {
    expect_usage_error(
        &[&["render", "tiny.toml", "--spp", "0"][..], &OUTS].concat(),
        &["--spp"],
    );
}

#[test]
fn flag_error_width_zero() {
    expect_usage_error(
        &[&["render", "tiny.toml", "--width", "0"][..], &OUTS].concat(),
        &["width"],
    );
}

#[test]
fn flag_error_unsupported_output_extension() {
    expect_usage_error(
        &["render", "tiny.toml", "-o", "out.png", "-o", "out.jpg"],
        &["out.jpg", ".png", ".exr"],
    );
}

/// `--time -1` exactly as a user types it (the contract's form `--time SECONDS`).
#[test]
fn flag_error_negative_time() {
    expect_usage_error(
        &[&["render", "tiny.toml", "--time", "-1"][..], &OUTS].concat(),
        &["--time"],
    );
}

/// The same check when clap cannot mistake the value for a flag.
#[test]
fn flag_error_negative_time_with_equals() {
    expect_usage_error(
        &[&["render", "tiny.toml", "--time=-1"][..], &OUTS].concat(),
        &["--time", "positive"],
    );
}

/// Issue 18, failure 4: `--time 1e20` panicked converting to a Duration (exit 101); now every time is
/// bounded and a usage error names the flag. Durations with units are accepted.
#[test]
fn flag_error_huge_time_and_units() {
    for t in ["1e20", "1e400", "inf", "2000000000", "0s", "soon"] {
        expect_usage_error(
            &[&["render", "tiny.toml", "--time", t][..], &OUTS].concat(),
            &["--time"],
        );
    }
    let dir = dir_with("tiny.toml", TINY);
    for t in ["1h30m", "90s", "0.5"] {
        let run = vkpath(
            dir.path(),
            &[
                "render",
                "tiny.toml",
                "--time",
                t,
                "--spp",
                "1",
                "--quiet",
                "-o",
                "t.exr",
            ],
        );
        run.assert_success();
    }
}

/// `vkpath bench mesh 99999999999999` allocated until the machine ran out of memory; now sizes are
/// bounded before anything is built.
#[test]
fn bench_mesh_sizes_are_bounded() {
    expect_usage_error(
        &["bench", "mesh", "99999999999999"],
        &["bench mesh", "99999999999999"],
    );
    expect_usage_error(&["bench", "mesh", "0"], &["bench mesh"]);
}

#[test]
fn flag_error_target_error_not_positive() {
    expect_usage_error(
        &[
            &["render", "tiny.toml", "--target-error", "-0.01"][..],
            &OUTS,
        ]
        .concat(),
        &["--target-error", "positive"],
    );
}

#[test]
fn preview_flag_errors_come_before_any_window() {
    // The window itself is tested under Xvfb in tests/preview.rs; flags are checked with or without
    // the `preview` feature.
    expect_usage_error(
        &["preview", "tiny.toml", "--screenshot", "a.png"],
        &["--screenshot", "--frames"],
    );
}

#[test]
fn missing_scene_file() {
    expect_usage_error(
        &[&["render", "missing.toml"][..], &OUTS].concat(),
        &["missing.toml"],
    );
}

/// Samples the exact accumulator cannot hold (radiance of 2^64, 1.8e19, or more) are counted and said:
/// a warning on stderr, even with --quiet, and `sample_faults` in the JSON. TINY's light made a
/// trillion trillion times stronger lights the ball and the floor far past the limit; as it is, no
/// sample is clamped and nothing is said.
#[test]
fn clamped_samples_are_reported() {
    let bright = TINY.replace("power  = 40000.0", "power  = 4.0e28");
    assert_ne!(bright, TINY);
    for (text, clamped) in [(bright.as_str(), true), (TINY, false)] {
        let dir = dir_with("tiny.toml", text);
        let run = vkpath(
            dir.path(),
            &["render", "tiny.toml", "--spp", "1", "--quiet", "--json"],
        );
        run.assert_success();
        let json = run.json();
        let faults = json["sample_faults"]
            .as_object()
            .unwrap_or_else(|| panic!("no sample_faults object: {json:?}"));
        let n = faults["clamped"].as_u64().expect("clamped is a count");
        assert_eq!(faults["not_finite"].as_u64(), Some(0));
        let warned = run.stderr.contains("were clamped");
        if clamped {
            assert!(n > 100, "the bright light clamped only {n} samples");
            assert!(warned, "no warning on stderr: {}", run.stderr);
            assert!(run.stderr.contains(&n.to_string()), "{}", run.stderr);
        } else {
            assert_eq!(n, 0);
            assert!(!warned, "a warning without clamped samples: {}", run.stderr);
        }
    }
}

/// `--light-sampling` takes every strategy the scene format names (cone, area, none, mis) and nothing
/// else: `mis` renders the default's bits, `cone` another estimate of the same image (light samples
/// alone: the BSDF-sampled hits of TINY's sphere light are not weighted in), and an unknown name exits 2
/// naming the flag and the values, with no output.
#[test]
fn light_sampling_flag_takes_every_strategy() {
    let dir = dir_with("tiny.toml", TINY);
    let render = |extra: &[&str], out: &str| {
        let mut args = vec!["render", "tiny.toml", "--spp", "2", "--quiet", "-o", out];
        args.extend_from_slice(extra);
        let run = vkpath(dir.path(), &args);
        run.assert_success();
        exr_pixels(&dir.path().join(out)).2
    };
    let default = render(&[], "d.exr");
    assert_eq!(render(&["--light-sampling", "mis"], "m.exr"), default);
    let cone = render(&["--light-sampling", "cone"], "c.exr");
    assert_ne!(
        cone, default,
        "mis weighs the BSDF's hits of the light in, cone does not"
    );
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    assert!((mean(&cone) / mean(&default) - 1.0).abs() < 0.05);
    for s in ["area", "none"] {
        render(&["--light-sampling", s], &format!("{s}.exr"));
    }
    let run = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--light-sampling",
            "bsdf",
            "-o",
            "x.png",
        ],
    );
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("--light-sampling") && run.stderr.contains("mis"),
        "{}",
        run.stderr
    );
    assert!(!dir.path().join("x.png").exists());
}

/// A render ends with one summary line on stderr (issue 18): the outputs written, spp, seconds,
/// Msamples/s and the estimated error; `--quiet` silences it.
#[test]
fn a_render_ends_with_a_summary_line() {
    let dir = dir_with("tiny.toml", TINY);
    let run = vkpath(
        dir.path(),
        &["render", "tiny.toml", "--spp", "16", "-o", "s.png"],
    );
    run.assert_success();
    let line = run.stderr.trim();
    assert_eq!(line.lines().count(), 1, "{line}");
    for w in [
        "wrote s.png",
        "16 spp",
        " s, ",
        "Msamples/s",
        "estimated error",
        "%",
    ] {
        assert!(line.contains(w), "{w:?} not in {line:?}");
    }
    let quiet = vkpath(
        dir.path(),
        &[
            "render",
            "tiny.toml",
            "--spp",
            "1",
            "--quiet",
            "-o",
            "q.png",
        ],
    );
    quiet.assert_success();
    assert!(quiet.stderr.trim().is_empty(), "{:?}", quiet.stderr);
}

/// Issue 18: a negative value (`--spp -1`) said "unexpected argument '-1' found", naming no flag, with a
/// wrong tip. Every numeric flag now takes it as its value and names itself with its range.
#[test]
fn negative_numbers_name_their_flag() {
    for flag in [
        "--spp",
        "--seed",
        "--width",
        "--height",
        "--progress-every",
        "--samples-per-pass",
        "--casts-per-dispatch",
    ] {
        expect_usage_error(
            &[&["render", "tiny.toml", flag, "-1"][..], &OUTS].concat(),
            &[flag, "-1 is not in"],
        );
    }
    // -1 is no bounce limit (tests/unbounded.rs); -2 names the flag and what it takes.
    expect_usage_error(
        &[&["render", "tiny.toml", "--max-bounces", "-2"][..], &OUTS].concat(),
        &["--max-bounces", "-1 for no limit"],
    );
    for flag in ["--width", "--height", "--spp", "--runs"] {
        expect_usage_error(
            &["bench", "throughput", flag, "-3"],
            &[flag, "-3 is not in"],
        );
    }
}
