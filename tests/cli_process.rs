//! The command line as a process: interruption (SIGINT) and a machine without a Vulkan driver.

mod common;

use common::cli::vkpath;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Ctrl-C ends the render after the pass in flight and writes the outputs with the samples done so far:
/// exit 0, a valid image, `spp` between 1 and the requested count, stop_reason "interrupted".
#[test]
fn sigint_writes_the_samples_done_so_far() {
    let dir = tempfile::tempdir().unwrap();
    let child = vkpath(dir.path())
        .args([
            "render", "--width", "64", "--height", "64", "--spp", "1000000", "--json", "-o",
            "out.png", "-o", "out.exr",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the render is under way (first progress: any sample done takes well under this).
    std::thread::sleep(Duration::from_millis(2500));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let start = Instant::now();
    let out = child.wait_with_output().unwrap();
    assert!(
        start.elapsed() < Duration::from_secs(60),
        "the render did not stop promptly after SIGINT"
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "stderr: {stderr}");
    let json: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("one JSON object on stdout");
    assert_eq!(json["stop_reason"], "interrupted");
    let spp = json["spp"].as_u64().unwrap();
    assert!((1..1_000_000).contains(&spp), "spp = {spp}");
    let png = image::open(dir.path().join("out.png"))
        .expect("a valid PNG")
        .to_rgb8();
    assert_eq!(png.dimensions(), (64, 64));
    let exr = image::open(dir.path().join("out.exr"))
        .expect("a valid EXR")
        .to_rgb32f();
    assert!(
        exr.pixels().any(|p| p.0.iter().any(|&v| v > 0.0)),
        "the EXR is black"
    );
    // No temporary files left behind.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

/// With no Vulkan driver, the program says so in one paragraph with the install command, exits 1 and
/// writes nothing. (The loader is pointed at a driver manifest that does not exist.)
#[test]
fn no_vulkan_device_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    for args in [vec!["render", "--spp", "1", "-o", "x.png"], vec!["info"]] {
        let out = vkpath(dir.path())
            .env_remove("VKPATH_VALIDATION")
            .env("VK_ICD_FILENAMES", "/nonexistent/vkpath-test-icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/vkpath-test-icd.json")
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "one paragraph: {stderr}");
        assert!(
            stderr.contains("apt-get install") && stderr.contains("mesa-vulkan-drivers"),
            "{stderr}"
        );
    }
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing may be written"
    );
}

/// Ctrl-C while the kernel compiles (made to take two minutes by the `slow-compile` fault) ends the
/// program at once, exit 1, nothing written; it used to wait for the compile to finish.
#[test]
fn sigint_during_the_compile_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let child = vkpath(dir.path())
        .env("VKPATH_FAULT", "slow-compile")
        .args([
            "render", "--width", "16", "--height", "16", "--spp", "4", "-o", "out.png",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let start = Instant::now();
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let waited = start.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The compile would have gone on for two minutes.
    assert!(
        waited < Duration::from_secs(10),
        "took {waited:?}: {stderr}"
    );
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("before the first sample"), "{stderr}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "wrote a file"
    );
}
