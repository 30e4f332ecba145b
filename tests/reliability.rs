//! Nothing lost: the `vkpath` binary as a child process, interrupted (SIGINT, SIGTERM) and killed
//! (SIGKILL) mid-render, resumed and merged; bad checkpoints and flags refused. docs/reliability.md lists
//! the promise each test backs.
//!
//! Renders are tiny (32x24, the embedded course scene) so that every test stays within a few seconds on
//! lavapipe; the Khronos validation layer is on (`VKPATH_VALIDATION=1`).

mod common;

use common::cli::{run, run_ok, vkpath};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};
use vkpath::checkpoint::Checkpoint;

const SIZE: [&str; 4] = ["--width", "32", "--height", "24"];

/// The command fails with `code`, one paragraph on stderr that contains every word of `words`.
#[track_caller]
fn run_fails(dir: &Path, args: &[&str], code: i32, words: &[&str]) -> String {
    let out = run(dir, args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(code), "vkpath {args:?}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one paragraph: {stderr}");
    for w in words {
        assert!(
            stderr.contains(w),
            "vkpath {args:?}: {w:?} not in: {stderr}"
        );
    }
    stderr
}

fn spawn(dir: &Path, args: &[&str]) -> Child {
    vkpath(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn vkpath")
}

fn signal(child: &Child, sig: &str) {
    let status = Command::new("kill")
        .args([&format!("-{sig}"), &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(status.success(), "kill -{sig}");
}

/// Waits until `path` exists and has been rewritten `writes` times (its modification time changed).
fn wait_for_writes(path: &Path, writes: u32, child: &mut Child) {
    let start = Instant::now();
    let mut seen = 0;
    let mut last = None;
    while seen < writes {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "{} was not written in time",
            path.display()
        );
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the render ended early: {status}");
        }
        let stamp = std::fs::metadata(path).and_then(|m| m.modified()).ok();
        if stamp.is_some() && stamp != last {
            seen += 1;
            last = stamp;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The linear pixels of an EXR, as bits.
fn exr_bits(path: &Path) -> Vec<u32> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{} is not a valid image: {e}", path.display()))
        .to_rgb32f()
        .into_raw()
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

/// Renders the course scene at 32x24 with `spp` samples, uninterrupted, to `name` (EXR).
fn straight(dir: &Path, spp: u32, name: &str) -> Vec<u32> {
    run_ok(
        dir,
        &[
            &["render", "--quiet", "-o", name, "--spp", &spp.to_string()][..],
            &SIZE,
        ]
        .concat(),
    );
    exr_bits(&dir.join(name))
}

fn resume(dir: &Path, ckpt: &Path, spp: u32, name: &str) -> Vec<u32> {
    let ckpt = ckpt.to_string_lossy().into_owned();
    let out = run_ok(
        dir,
        &[
            &[
                "render",
                "--quiet",
                "--json",
                "-o",
                name,
                "--spp",
                &spp.to_string(),
                "--resume",
                &ckpt,
                "--samples-per-pass",
                "2",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    let j = json(&out);
    assert_eq!(j["spp"], spp);
    exr_bits(&dir.join(name))
}

/// SIGINT and SIGTERM end the render after the pass in flight: exit 0, the image and the checkpoint
/// written with the samples done, and the checkpoint resumed to N samples gives the bits of an
/// uninterrupted N-sample render.
#[test]
fn sigint_and_sigterm_save_a_checkpoint_that_resumes_to_the_same_bits() {
    for sig in ["INT", "TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut child = spawn(
            d,
            &[
                &[
                    "render",
                    "--quiet",
                    "--json",
                    "-o",
                    "out.exr",
                    "--spp",
                    "1000000",
                    "--samples-per-pass",
                    "1",
                    "--checkpoint",
                    "c.ckpt",
                    "--checkpoint-every",
                    "3",
                ][..],
                &SIZE,
            ]
            .concat(),
        );
        wait_for_writes(&d.join("c.ckpt"), 2, &mut child);
        signal(&child, sig);
        let out = child.wait_with_output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "SIG{sig}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j = json(&out);
        assert_eq!(j["stop_reason"], "interrupted");
        let k = j["spp"].as_u64().unwrap() as u32;
        let saved = Checkpoint::read(&d.join("c.ckpt")).expect("a valid checkpoint");
        assert_eq!(
            saved.samples(),
            k,
            "the final checkpoint holds every sample done"
        );
        assert_eq!(saved.header.ranges, vec![[0, k]]);
        assert_eq!(exr_bits(&d.join("out.exr")).len(), 32 * 24 * 3);
        let target = k + 3;
        assert!(
            resume(d, &d.join("c.ckpt"), target, "resumed.exr")
                == straight(d, target, "straight.exr"),
            "SIG{sig}: resumed image differs from the uninterrupted one"
        );
    }
}

/// SIGKILL (nothing can be caught) at two moments mid-render: the checkpoint and the progress images
/// on disk are whole, valid files (they are written atomically), and the checkpoint resumes to the bits
/// of an uninterrupted render.
#[test]
fn sigkill_leaves_valid_files_and_the_last_checkpoint_resumes_exactly() {
    for writes in [2, 5] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut child = spawn(
            d,
            &[
                &[
                    "render",
                    "--quiet",
                    "-o",
                    "out.png",
                    "-o",
                    "out.exr",
                    "--spp",
                    "1000000",
                    "--samples-per-pass",
                    "1",
                    "--checkpoint",
                    "c.ckpt",
                    "--checkpoint-every",
                    "2",
                    "--progress-every",
                    "2",
                ][..],
                &SIZE,
            ]
            .concat(),
        );
        wait_for_writes(&d.join("c.ckpt"), writes, &mut child);
        child.kill().unwrap(); // SIGKILL
        let status = child.wait().unwrap();
        assert_eq!(status.code(), None, "killed by a signal");
        let saved = Checkpoint::read(&d.join("c.ckpt")).expect("the checkpoint is whole");
        let k = saved.samples();
        assert!(k >= 2 && k.is_multiple_of(2), "{k}");
        let png = image::open(d.join("out.png")).expect("the PNG is whole");
        assert_eq!((png.width(), png.height()), (32, 24));
        assert_eq!(exr_bits(&d.join("out.exr")).len(), 32 * 24 * 3);
        let target = k + 2;
        assert!(
            resume(d, &d.join("c.ckpt"), target, "resumed.exr")
                == straight(d, target, "straight.exr"),
            "resumed image differs from the uninterrupted one"
        );
    }
}

/// Four partial renders (`--sample-range`) merge (`vkpath merge`) into the image of one render of the
/// union exactly (the sums are exact integers: see tests/checkpoint.rs), whatever the order of the parts
/// on the command line; a merged checkpoint is written too.
#[test]
fn merge_of_four_ranges_equals_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut parts = Vec::new();
    for r in ["8..12", "0..4", "12..16", "4..8"] {
        let ckpt = format!("part{r}.ckpt");
        let exr = format!("part{r}.exr");
        run_ok(
            d,
            &[
                &[
                    "render",
                    "--quiet",
                    "--sample-range",
                    r,
                    "--checkpoint",
                    &ckpt,
                    "-o",
                    &exr,
                ][..],
                &SIZE,
            ]
            .concat(),
        );
        parts.push(ckpt);
    }
    let mut args: Vec<&str> = vec![
        "merge",
        "--json",
        "-o",
        "merged.exr",
        "--checkpoint",
        "m.ckpt",
    ];
    args.extend(parts.iter().map(String::as_str));
    let j = json(&run_ok(d, &args));
    assert_eq!(j["spp"], 16);
    assert_eq!(j["parts"], 4);
    let merged = exr_bits(&d.join("merged.exr"));
    let single = straight(d, 16, "single.exr");
    assert_eq!(merged.len(), single.len());
    let differing = merged.iter().zip(&single).filter(|(m, s)| m != s).count();
    assert_eq!(
        differing, 0,
        "{differing} values of the merged image differ"
    );
    assert!(
        merged.iter().any(|&b| b != 0),
        "a black image proves nothing"
    );
    let m = Checkpoint::read(&d.join("m.ckpt")).unwrap();
    assert_eq!(m.header.ranges, vec![[0, 4], [4, 8], [8, 12], [12, 16]]);

    // Overlapping parts would count samples twice; parts of another render do not belong.
    run_fails(
        d,
        &["merge", "-o", "x.exr", &parts[0], &parts[0]],
        2,
        &["overlap"],
    );
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--sample-range",
                "16..20",
                "--seed",
                "9",
                "--checkpoint",
                "s9.ckpt",
                "-o",
                "s9.exr",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    run_fails(
        d,
        &["merge", "-o", "x.exr", &parts[0], "s9.ckpt"],
        2,
        &["seed"],
    );
    run_fails(d, &["merge", &parts[0]], 2, &["-o"]);
    assert!(!d.join("x.exr").exists());
}

/// Renders `--part I/4` of the course scene at 32x24, 16 spp, into `parts/part-I.ckpt`.
fn render_part(dir: &Path, i: u32) {
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    let ckpt = format!("parts/part-{i}.ckpt");
    let part = format!("{i}/4");
    run_ok(
        dir,
        &[
            &[
                "render",
                "--quiet",
                "--spp",
                "16",
                "--part",
                &part,
                "--checkpoint",
                &ckpt,
            ][..],
            &SIZE,
        ]
        .concat(),
    );
}

/// Render farms (issue 17): four `--part I/4` renders, run in any order and writing no image, merge from
/// their directory (or a quoted glob) into the bits of one render. A missing or duplicated part is refused
/// by name with nothing written; a part from another device merges with a warning.
#[test]
fn parts_merge_from_a_directory_into_the_single_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for i in [2, 0, 3, 1] {
        render_part(d, i);
    }
    assert_eq!(
        std::fs::read_dir(d).unwrap().count(),
        1,
        "a part writes its checkpoint only"
    );
    let single = straight(d, 16, "single.exr");
    let j = json(&run_ok(d, &["merge", "--json", "parts", "-o", "dir.exr"]));
    assert_eq!(
        (j["spp"].as_u64(), j["parts"].as_u64()),
        (Some(16), Some(4))
    );
    assert!(
        exr_bits(&d.join("dir.exr")) == single,
        "merged from the directory"
    );
    run_ok(d, &["merge", "parts/*.ckpt", "-o", "glob.exr"]);
    // The variance layer of a merge is the union's; the other layers need the scene.
    run_ok(d, &["merge", "parts", "--aov", "variance", "-o", "var.exr"]);
    run_fails(
        d,
        &["merge", "parts", "--aov", "albedo", "-o", "x.exr"],
        2,
        &["--aov albedo"],
    );
    run_fails(
        d,
        &["merge", "parts", "--aov", "variance", "-o", "x.png"],
        2,
        &["-o OUT.exr"],
    );
    assert!(
        exr_bits(&d.join("glob.exr")) == single,
        "merged from the glob"
    );
    assert!(
        single.iter().any(|&b| b != 0),
        "a black image proves nothing"
    );

    // Another device's part: merged, with a warning naming the devices and the file.
    let p3 = d.join("parts/part-3.ckpt");
    let mut other = Checkpoint::read(&p3).unwrap();
    let original = other.header.device.clone();
    other.header.device = "Another GPU".into();
    other.write(&p3).unwrap();
    let out = run_ok(d, &["merge", "parts", "-o", "mixed.exr"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("different devices")
            && stderr.contains("Another GPU (parts/part-3.ckpt)")
            && stderr.contains(&original)
            && stderr.contains("not bit-identical"),
        "{stderr}"
    );
    let quiet = run_ok(d, &["merge", "--quiet", "parts", "-o", "quiet.exr"]);
    assert!(quiet.stderr.is_empty());

    // A copy of a part under another name, then a missing part: refused, nothing written.
    std::fs::copy(d.join("parts/part-0.ckpt"), d.join("parts/copy.ckpt")).unwrap();
    run_fails(
        d,
        &["merge", "parts", "-o", "x.exr"],
        2,
        &["part 0/4 again", "copy.ckpt", "part-0.ckpt"],
    );
    std::fs::remove_file(d.join("parts/copy.ckpt")).unwrap();
    std::fs::remove_file(d.join("parts/part-1.ckpt")).unwrap();
    run_fails(
        d,
        &["merge", "parts", "-o", "x.exr"],
        2,
        &["1 of the 4 parts", "1/4 (samples 4..8)", "missing"],
    );
    run_fails(
        d,
        &["merge", "nowhere/*.ckpt", "-o", "x.exr"],
        2,
        &["matches no part"],
    );
    assert!(!d.join("x.exr").exists());
}

/// A part stopped by SIGTERM (a cancelled farm task) saves what it did but exits 1, so that the
/// scheduler does not count it as done; merging it is refused by name; resumed, it finishes to the very
/// bytes of a part that was never interrupted.
#[test]
fn an_interrupted_part_exits_1_and_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let part = ["--part", "1/2", "--spp", "4000"];
    let mut child = spawn(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--samples-per-pass",
                "1",
                "--checkpoint",
                "p.ckpt",
                "--checkpoint-every",
                "3",
            ][..],
            &part,
            &SIZE,
        ]
        .concat(),
    );
    wait_for_writes(&d.join("p.ckpt"), 2, &mut child);
    signal(&child, "TERM");
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("part 1/2 was interrupted") && stderr.contains("--resume p.ckpt"),
        "{stderr}"
    );
    let saved = Checkpoint::read(&d.join("p.ckpt")).unwrap();
    let [start, end] = saved.header.ranges[0];
    assert!(start == 2000 && end > 2000 && end < 4000, "{start}..{end}");
    run_fails(
        d,
        &["merge", "p.ckpt", "-o", "x.exr"],
        2,
        &["p.ckpt", "stopped before the end", "--resume p.ckpt"],
    );
    run_ok(
        d,
        &[
            &["render", "--quiet", "--resume", "p.ckpt"][..],
            &part,
            &SIZE,
        ]
        .concat(),
    );
    run_ok(
        d,
        &[
            &["render", "--quiet", "--checkpoint", "fresh.ckpt"][..],
            &part,
            &SIZE,
        ]
        .concat(),
    );
    assert!(
        std::fs::read(d.join("p.ckpt")).unwrap() == std::fs::read(d.join("fresh.ckpt")).unwrap(),
        "the resumed part's file differs from the uninterrupted part's"
    );
}

/// A checkpoint of another render, a damaged one, or not a checkpoint at all: exit 2, one paragraph
/// saying what is wrong, and nothing written (the checkpoint itself untouched).
#[test]
fn resume_refuses_foreign_and_damaged_checkpoints() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--spp",
                "2",
                "--checkpoint",
                "c.ckpt",
                "-o",
                "a.exr",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    let before = std::fs::read(d.join("c.ckpt")).unwrap();
    let refuse = |extra: &[&str], words: &[&str]| {
        let args = [
            &["render", "--quiet", "-o", "b.exr", "--resume", "c.ckpt"][..],
            extra,
        ]
        .concat();
        run_fails(d, &args, 2, words);
        assert!(!d.join("b.exr").exists());
        assert_eq!(
            std::fs::read(d.join("c.ckpt")).unwrap(),
            before,
            "the checkpoint was changed"
        );
    };
    refuse(
        &[&SIZE[..], &["--seed", "5"]].concat(),
        &["another render", "seed is 0, this one 5"],
    );
    refuse(&["--width", "33", "--height", "24"], &["32x24", "33x24"]);
    refuse(
        &[&SIZE[..], &["--max-bounces", "2"]].concat(),
        &["max_bounces is 5, this one 2"],
    );
    refuse(
        &[&SIZE[..], &["--sample-range", "4..8"]].concat(),
        &["--sample-range"],
    );
    // A partial render resumed without its range would silently render other samples.
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--sample-range",
                "4..8",
                "--checkpoint",
                "p.ckpt",
                "-o",
                "p.exr",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    run_fails(
        d,
        &[
            &["render", "--quiet", "-o", "b.exr", "--resume", "p.ckpt"][..],
            &SIZE,
        ]
        .concat(),
        2,
        &["partial render of the samples 4..8", "--sample-range 4..B"],
    );
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--sample-range",
                "4..10",
                "--resume",
                "p.ckpt",
                "-o",
                "p.exr",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    assert_eq!(
        Checkpoint::read(&d.join("p.ckpt")).unwrap().header.ranges,
        vec![[4, 10]]
    );

    let damaged = |name: &str, bytes: &[u8], words: &[&str]| {
        std::fs::write(d.join(name), bytes).unwrap();
        let args = [
            &["render", "--quiet", "-o", "b.exr", "--resume", name][..],
            &SIZE,
        ]
        .concat();
        run_fails(d, &args, 2, words);
        assert!(!d.join("b.exr").exists());
    };
    damaged(
        "truncated.ckpt",
        &before[..before.len() - 100],
        &["truncated"],
    );
    let mut flipped = before.clone();
    let last = flipped.len() - 7;
    flipped[last] ^= 0x10;
    damaged("flipped.ckpt", &flipped, &["checksum"]);
    // Issue 18, failure 1: the sample range in the header edited (still valid JSON, one digit more) was
    // resumed as if it held more samples, an image too dark. The checksum covers the header now.
    let mut edited = before.clone();
    let ranges = edited
        .windows(11)
        .position(|w| w == b"\"ranges\":[[")
        .expect("the ranges in the header");
    let end = ranges + edited[ranges..].iter().position(|&b| b == b']').unwrap() - 1;
    assert!(edited[end].is_ascii_digit());
    edited[end] = if edited[end] == b'9' {
        b'8'
    } else {
        edited[end] + 1
    };
    damaged("edited.ckpt", &edited, &["checksum", "edited.ckpt"]);
    damaged(
        "image.ckpt",
        &std::fs::read(d.join("a.exr")).unwrap(),
        &["signature"],
    );
    run_fails(
        d,
        &[
            &[
                "render",
                "--quiet",
                "-o",
                "b.exr",
                "--resume",
                "missing.ckpt",
            ][..],
            &SIZE,
        ]
        .concat(),
        2,
        &["cannot read"],
    );
}

/// The new flags' mistakes are usage errors (exit 2) that name the flag.
#[test]
fn checkpoint_and_range_flag_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, word) in [
        (vec!["--sample-range", "5..5"], "--sample-range"),
        (vec!["--sample-range", "7"], "--sample-range"),
        (vec!["--sample-range", "0..4", "--spp", "4"], "--spp"),
        (vec!["--checkpoint-every", "4"], "--checkpoint FILE"),
        (
            vec!["--checkpoint", "c.ckpt", "--checkpoint-every", "0"],
            "--checkpoint-every",
        ),
        (
            vec!["--checkpoint", "c.ckpt", "--checkpoint-every", "soon"],
            "--checkpoint-every",
        ),
        (
            vec!["--part", "1/4", "--sample-range", "0..4"],
            "--sample-range",
        ),
        (vec!["--part", "1/4"], "--checkpoint FILE"),
        (
            vec!["--part", "1/4", "--checkpoint", "c.ckpt", "--time", "10"],
            "--time",
        ),
        (vec!["--part", "4/4", "--checkpoint", "c.ckpt"], "0 to 3"),
        (vec!["--part", "-1/4", "--checkpoint", "c.ckpt"], "--part"),
        (
            vec!["--part", "env/4", "--checkpoint", "c.ckpt"],
            "SLURM_ARRAY_TASK_ID",
        ),
        (
            vec!["--part", "3/4", "--checkpoint", "c.ckpt", "--spp", "2"],
            "cannot be cut into 4 parts",
        ),
    ] {
        let all = [&["render", "-o", "x.png"][..], &args, &SIZE].concat();
        run_fails(d, &all, 2, &[word]);
    }
    // A 10^9-pixel image is refused before anything is allocated, with the limit named.
    run_fails(
        d,
        &[
            "render", "-o", "x.png", "--width", "40000", "--height", "25000",
        ],
        2,
        &["2^28"],
    );
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 0, "nothing written");
}

/// `--checkpoint-every 30s` style durations are accepted; the final checkpoint is always written.
#[test]
fn time_based_checkpoints_and_the_final_save() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--spp",
                "3",
                "--checkpoint",
                "c.ckpt",
                "--checkpoint-every",
                "0.5m",
                "-o",
                "x.exr",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    assert_eq!(Checkpoint::read(&d.join("c.ckpt")).unwrap().samples(), 3);
    // Resuming a finished render with a larger --spp goes on from it; the file is updated in place.
    let bits = resume(d, &d.join("c.ckpt"), 5, "more.exr");
    assert_eq!(Checkpoint::read(&d.join("c.ckpt")).unwrap().samples(), 5);
    assert!(bits == straight(d, 5, "five.exr"));
}

/// A lost device mid-render (simulated: `VKPATH_FAULT=device-lost@7` fails the 7th pass after part of
/// it was submitted): exit 1, one paragraph that says what happened and which files are intact; the
/// checkpoint and progress images of the last completed save (6 samples) are whole, and the checkpoint
/// resumes to the bits of an uninterrupted render.
#[test]
fn a_lost_device_keeps_the_last_checkpoint_and_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = vkpath(d)
        .env("VKPATH_FAULT", "device-lost@7")
        .args(
            [
                &[
                    "render",
                    "--quiet",
                    "-o",
                    "out.png",
                    "-o",
                    "out.exr",
                    "--spp",
                    "100",
                    "--samples-per-pass",
                    "1",
                    "--checkpoint",
                    "c.ckpt",
                    "--checkpoint-every",
                    "2",
                    "--progress-every",
                    "2",
                ][..],
                &SIZE,
            ]
            .concat(),
        )
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one paragraph: {stderr}");
    for w in [
        "device was lost",
        "c.ckpt (6 samples per pixel), is intact",
        "--resume c.ckpt",
        "out.exr (6 samples",
    ] {
        assert!(stderr.contains(w), "{w:?} not in {stderr}");
    }
    let saved = Checkpoint::read(&d.join("c.ckpt")).expect("the checkpoint is whole");
    assert_eq!(
        saved.samples(),
        6,
        "the failed pass must not reach the checkpoint"
    );
    image::open(d.join("out.png")).expect("the PNG is whole");
    assert_eq!(exr_bits(&d.join("out.exr")).len(), 32 * 24 * 3);
    assert!(resume(d, &d.join("c.ckpt"), 9, "resumed.exr") == straight(d, 9, "straight.exr"));
}

/// Running out of device memory and a kernel that fails to compile (both simulated), and an image too
/// large for the device (real: 16 GiB of accumulator): exit 1 with a one-paragraph message, and the
/// files already on disk (a checkpoint being resumed, an earlier image) untouched.
#[test]
fn out_of_memory_shader_failure_and_device_limits_leave_files_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_ok(
        d,
        &[
            &[
                "render",
                "--quiet",
                "--spp",
                "2",
                "--checkpoint",
                "c.ckpt",
                "-o",
                "out.png",
            ][..],
            &SIZE,
        ]
        .concat(),
    );
    let ckpt = std::fs::read(d.join("c.ckpt")).unwrap();
    let png = std::fs::read(d.join("out.png")).unwrap();
    for (fault, words) in [
        ("out-of-memory", &["ran out of memory", "smaller image"][..]),
        ("shader", &["failed to compile"][..]),
    ] {
        let out = vkpath(d)
            .env("VKPATH_FAULT", fault)
            .args(
                [
                    &[
                        "render", "--quiet", "--spp", "4", "--resume", "c.ckpt", "-o", "out.png",
                    ][..],
                    &SIZE,
                ]
                .concat(),
            )
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{fault}: {stderr}");
        assert_eq!(
            stderr.trim().lines().count(),
            1,
            "{fault}: one paragraph: {stderr}"
        );
        for w in words {
            assert!(stderr.contains(w), "{fault}: {w:?} not in {stderr}");
        }
        assert_eq!(
            std::fs::read(d.join("c.ckpt")).unwrap(),
            ckpt,
            "{fault} touched the checkpoint"
        );
        assert_eq!(
            std::fs::read(d.join("out.png")).unwrap(),
            png,
            "{fault} touched the image"
        );
    }
    let huge = 16384u64 * 16384 * 64;
    let out = run(
        d,
        &[
            "render", "--quiet", "--width", "16384", "--height", "16384", "--spp", "1", "-o",
            "huge.png",
        ],
    );
    if out.status.code() == Some(1) {
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("MiB of device memory") && stderr.contains("16384x16384"),
            "{stderr}"
        );
        assert!(!d.join("huge.png").exists());
    } else {
        eprintln!("this device holds {huge} bytes of accumulator: the limit was not reached");
    }
    // An unknown fault name is a usage error.
    let out = vkpath(d)
        .env("VKPATH_FAULT", "meteor")
        .args(["render", "-o", "y.png"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// Issue 18, failures 2 and 3: every output and the checkpoint are checked before the render starts.
/// `-o x.png --checkpoint x.png` left a checkpoint in x.png, `--checkpoint scene.toml` overwrote the
/// user's scene, and `-o missing-dir/x.png --checkpoint side.ckpt` rendered everything, failed on the
/// PNG and never wrote the checkpoint. Each is now refused up front (exit 2, the paths named), with
/// nothing written and the scene untouched; resuming into the checkpoint resumed from stays allowed.
#[test]
fn outputs_are_checked_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = vkpath::scene::DEFAULT_SCENE_TOML;
    std::fs::write(d.join("scene.toml"), scene).unwrap();
    let listing = || {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    fn with<'a>(args: &[&'a str]) -> Vec<&'a str> {
        [
            &["render", "scene.toml", "--quiet", "--spp", "1"][..],
            args,
            &SIZE,
        ]
        .concat()
    }
    run_fails(
        d,
        &with(&["-o", "x.png", "--checkpoint", "x.png"]),
        2,
        &["x.png", "same file"],
    );
    run_fails(
        d,
        &with(&["-o", "x.png", "-o", "./x.png"]),
        2,
        &["x.png", "same file"],
    );
    run_fails(
        d,
        &with(&["-o", "x.png", "--checkpoint", "scene.toml"]),
        2,
        &["scene.toml", "the scene file"],
    );
    run_fails(
        d,
        &with(&["-o", "missing-dir/x.png", "--checkpoint", "side.ckpt"]),
        2,
        &["missing-dir", "does not exist"],
    );
    assert_eq!(listing(), vec!["scene.toml".to_string()], "nothing written");
    assert_eq!(
        std::fs::read_to_string(d.join("scene.toml")).unwrap(),
        scene
    );
    // Resuming into the file resumed from, or naming it as --checkpoint too, is fine.
    run_ok(d, &with(&["-o", "a.exr", "--checkpoint", "c.ckpt"]));
    let more = [
        &[
            "render",
            "scene.toml",
            "--quiet",
            "--spp",
            "2",
            "-o",
            "b.exr",
        ][..],
        &SIZE,
    ]
    .concat();
    run_ok(d, &[&more[..], &["--resume", "c.ckpt"]].concat());
    run_ok(
        d,
        &[&more[..], &["--resume", "c.ckpt", "--checkpoint", "c.ckpt"]].concat(),
    );
    // Issue 18: merge with a missing part suggested "render without --resume"; resuming another light
    // sampling said only "the scene's content differs".
    let e = run_fails(
        d,
        &["merge", "gone.ckpt", "-o", "m.exr"],
        2,
        &["gone.ckpt", "Render that part again"],
    );
    assert!(!e.contains("--resume"), "{e}");
    run_fails(
        d,
        &[
            &more[..],
            &["--resume", "c.ckpt", "--light-sampling", "cone"],
        ]
        .concat(),
        2,
        &["light sampling is mis, this one cone (--light-sampling)"],
    );
    // vkpath merge never writes over a part it merges.
    run_fails(
        d,
        &["merge", "c.ckpt", "-o", "m.exr", "--checkpoint", "c.ckpt"],
        2,
        &["c.ckpt", "a part merged"],
    );
    assert!(!d.join("m.exr").exists());
    // An output and the checkpoint may not be the same file, with --resume as without.
    run_fails(
        d,
        &[
            &[
                "render",
                "scene.toml",
                "--quiet",
                "--spp",
                "3",
                "-o",
                "c.ckpt.exr",
            ][..],
            &SIZE,
            &["--resume", "c.ckpt", "--checkpoint", "c.ckpt.exr"],
        ]
        .concat(),
        2,
        &["same file"],
    );
}

/// `vkpath args` in `dir` on a machine said to have `available` bytes of memory
/// (`VKPATH_HOST_MEMORY_AVAILABLE`): its exit status and stderr.
fn run_with_memory(dir: &Path, available: u64, args: &[&str]) -> (Option<i32>, String) {
    let out = vkpath(dir)
        .env("VKPATH_HOST_MEMORY_AVAILABLE", available.to_string())
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `bytes` (a checkpoint file written by vkpath) with its header's image size replaced by `w` x `h`, the
/// header length and the CRC-32 made right again: a file whose checksum is correct but whose header
/// lies about what its payload holds.
fn with_claimed_size(bytes: &[u8], w: u32, h: u32) -> Vec<u8> {
    let header_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[16..16 + header_len]).unwrap();
    let mut json = json;
    json["identity"]["width"] = w.into();
    json["identity"]["height"] = h.into();
    let json = serde_json::to_vec(&json).unwrap();
    let rest = &bytes[16 + header_len..bytes.len() - 4];
    let mut out = bytes[..12].to_vec();
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(&json);
    out.extend(rest);
    let crc = crc32fast::hash(&out);
    out.extend(crc.to_le_bytes());
    out
}

/// Issue 31: a 2.8 kB checkpoint with a correct checksum that claims 16384 x 16384 pixels (24 GiB decoded)
/// made --resume and merge abort on the allocation. Now: --resume of another image size is refused from
/// the header before any pixel is decoded; the decoder refuses a size the machine's memory cannot hold
/// (VKPATH_HOST_MEMORY_AVAILABLE stands for the machine's memory here) and never reserves more than the
/// payload decodes to; merge checks the headers, then memory, then reads the parts one at a time. And a
/// render larger than the host memory available is refused up front (exit 1), not killed part-way.
#[test]
fn sizes_are_checked_against_memory_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_ok(
        d,
        &[
            &["render", "--quiet", "--spp", "2", "--checkpoint", "c.ckpt"][..],
            &SIZE,
        ]
        .concat(),
    );
    let big = with_claimed_size(&std::fs::read(d.join("c.ckpt")).unwrap(), 16384, 16384);
    assert!(big.len() < 1 << 16, "a small file: {} bytes", big.len());
    std::fs::write(d.join("big.ckpt"), &big).unwrap();
    // The decoder: an error value, whatever the machine's memory (a payload of 768 pixels cannot fill
    // 2^28 of them, and nothing that size is reserved).
    let e = Checkpoint::from_bytes(&big).unwrap_err();
    assert!(e.contains("16384x16384"), "{e}");
    // --resume into a 32x24 render: refused from the header.
    run_fails(
        d,
        &[
            &["render", "--quiet", "--resume", "big.ckpt", "-o", "out.png"][..],
            &SIZE,
        ]
        .concat(),
        2,
        &["big.ckpt", "its image is 16384x16384, this one 32x24"],
    );
    // merge, on a machine of 1 GiB: refused before decoding (exit 2, the file named); on this machine,
    // refused as well (memory or the payload), never an abort.
    let (code, stderr) = run_with_memory(d, 1 << 30, &["merge", "big.ckpt", "-o", "m.png"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("big.ckpt") && stderr.contains("host memory"),
        "{stderr}"
    );
    run_fails(d, &["merge", "big.ckpt", "-o", "m.png"], 2, &["big.ckpt"]);
    // A render of 4096 x 4096 on a machine of 1 GiB: refused up front with the sizes, nothing written.
    let (code, stderr) = run_with_memory(
        d,
        1 << 30,
        &[
            "render", "--quiet", "--width", "4096", "--height", "4096", "-o", "huge.png",
        ],
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("host memory")
            && stderr.contains("4096x4096")
            && stderr.contains("1024 MiB"),
        "{stderr}"
    );
    assert!(
        !d.join("m.png").exists() && !d.join("huge.png").exists() && !d.join("out.png").exists()
    );
    // A texture whose PNG header declares 8192 x 8192 texels (1.5 GiB to decode) on a machine of 1 GiB:
    // refused from the header (exit 2, naming the file), before a texel is decoded.
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let ihdr = [
        &b"IHDR"[..],
        &8192u32.to_be_bytes(),
        &8192u32.to_be_bytes(),
        &[8, 2, 0, 0, 0],
    ]
    .concat();
    png.extend((ihdr.len() as u32 - 4).to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32fast::hash(&ihdr).to_be_bytes());
    // An empty IDAT and the IEND (the decoder reads the header up to the first IDAT).
    for chunk in [&b"IDAT"[..], &b"IEND"[..]] {
        png.extend(0u32.to_be_bytes());
        png.extend(chunk);
        png.extend(crc32fast::hash(chunk).to_be_bytes());
    }
    std::fs::write(d.join("big.png"), &png).unwrap();
    common::cli::write(
        d,
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n",
    );
    common::cli::write(
        d,
        "t.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[image]\nwidth = 8\nheight = 8\n\
         [materials]\nw = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
         [[mesh]]\nobj = \"quad.obj\"\nmaterial = \"w\"\ntexture = \"big.png\"\n",
    );
    let (code, stderr) = run_with_memory(d, 1 << 30, &["render", "t.toml", "-o", "t.png"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("big.png")
            && stderr.contains("8192 x 8192")
            && stderr.contains("host memory"),
        "{stderr}"
    );
    assert!(!d.join("t.png").exists());
    // A mesh file the machine cannot hold on the way to the device (16 bytes a byte of file: the quad's
    // 62 bytes, 992, against 900 available), and a mesh "file" that is a device, never read to its end.
    common::cli::write(
        d,
        "m.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[image]\nwidth = 8\nheight = 8\n\
         [materials]\nw = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
         [[mesh]]\nobj = \"quad.obj\"\nmaterial = \"w\"\n\
         [[mesh]]\nobj = \"/dev/zero\"\nmaterial = \"w\"\n",
    );
    let (code, stderr) = run_with_memory(d, 900, &["render", "m.toml", "-o", "m.png"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("mesh[0].obj") && stderr.contains("mesh file of 62 bytes"),
        "{stderr}"
    );
    let started = Instant::now();
    run_fails(
        d,
        &["render", "m.toml", "-o", "m.png"],
        2,
        &["mesh[1].obj", "/dev/zero: it is not a regular file"],
    );
    assert!(started.elapsed() < Duration::from_secs(30));
    assert!(!d.join("m.png").exists());
}
