//! Denoising (`--denoise`, `render.denoise`, `vkpath denoise`) with Intel Open Image Denoise, loaded at
//! run time (src/denoise.rs). These tests need OIDN: `ci/setup.sh --test` (CI) and `ci/setup.sh
//! --denoise` install it; without it they fail with that hint, except the one that checks what happens
//! without it (it points VKPATH_OIDN_DIR at an empty folder).

mod common;

use common::cli::{run, run_ok, vkpath, write};
use std::path::Path;
use vkpath::output::ExrChannels;

/// Fails the test with the install hint when OIDN cannot be loaded here.
fn require_oidn() {
    if let Err(e) = vkpath::denoise::Denoiser::new(vkpath::denoise::DeviceChoice::Cpu) {
        panic!("these tests need Intel Open Image Denoise: run ci/setup.sh --denoise ({e})");
    }
}

fn read(path: &Path) -> ExrChannels {
    ExrChannels::read(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The pixels of `prefix`.R/G/B (the beauty image for an empty prefix).
fn rgb(exr: &ExrChannels, prefix: &str) -> Vec<[f32; 3]> {
    exr.rgb(prefix, ["R", "G", "B"])
        .unwrap_or_else(|| panic!("no {prefix} R/G/B channels"))
}

fn rmse(image: &[[f32; 3]], answer: f64) -> f64 {
    let sum: f64 = image
        .iter()
        .flat_map(|p| p.iter())
        .map(|&v| (f64::from(v) - answer).powi(2))
        .sum();
    (sum / (image.len() * 3) as f64).sqrt()
}

fn mean(image: &[[f32; 3]]) -> f64 {
    image
        .iter()
        .flat_map(|p| p.iter())
        .map(|&v| f64::from(v))
        .sum::<f64>()
        / (image.len() * 3) as f64
}

/// The emitting furnace (common::inside_emissive_sphere): every pixel's answer is Le / (1 - a) = 10;
/// Russian roulette makes the estimate noisy (at 4 samples a pixel its RMSE is about 4).
fn furnace(dir: &Path, extra_render: &str) -> std::path::PathBuf {
    let text = common::inside_emissive_sphere(0.9, 1.0, true, "-1", 64, 4);
    let text = text.replace("[render]\n", &format!("[render]\n{extra_render}"));
    write(dir, "furnace.toml", &text)
}

/// Without OIDN (VKPATH_OIDN_DIR names a folder without it, and vkpath then looks nowhere else):
/// `--denoise`, `render.denoise` and `vkpath denoise` exit 2 with a message that says how to install it,
/// and write nothing: a file already at an output keeps its bytes.
#[test]
fn without_the_denoiser_nothing_is_written_and_the_message_says_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let empty = d.join("no-oidn");
    std::fs::create_dir(&empty).unwrap();
    let scene = furnace(d, "");
    write(d, "kept.png", "the user's file");
    let check = |args: &[&str], outputs: &[&str]| {
        let out = vkpath(d)
            .env("VKPATH_OIDN_DIR", &empty)
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("Open Image Denoise")
                && err.contains("ci/setup.sh --denoise")
                && err.contains("VKPATH_OIDN_DIR")
                && err.contains("no-oidn"),
            "{err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "one paragraph: {err}");
        for o in outputs {
            assert!(!d.join(o).exists(), "{args:?} wrote {o}");
        }
        assert_eq!(
            std::fs::read(d.join("kept.png")).unwrap(),
            b"the user's file"
        );
    };
    let s = scene.to_str().unwrap();
    check(
        &["render", s, "--denoise", "-o", "a.png", "-o", "a.exr"],
        &["a.png", "a.exr"],
    );
    check(&["render", s, "--denoise", "-o", "kept.png"], &[]);
    let asked = furnace(d, "denoise = true\n");
    check(
        &["render", asked.to_str().unwrap(), "-o", "b.exr"],
        &["b.exr"],
    );
    // `vkpath denoise` on an EXR that has the layers.
    run_ok(d, &["render", s, "--aov", "albedo,normal", "-o", "in.exr"]);
    check(
        &["denoise", "in.exr", "-o", "c.exr", "-o", "c.png"],
        &["c.exr", "c.png"],
    );
}

/// `--denoise` on a noisy render of a scene whose answer is known (the emitting furnace, 10 everywhere):
/// the denoised image's RMSE against the answer is at least 5 times smaller than the raw estimate's
/// (measured: 0.22 against 3.95 at 64 x 64, 4 spp, 18 times), and the image mean is kept within 1 %
/// (the denoiser redistributes, it must not darken or brighten). The EXR's raw.R/G/B are bit for bit the
/// R/G/B of the same render without --denoise, and the files say what denoised them.
#[test]
fn a_noisy_furnace_comes_out_closer_to_its_answer() {
    require_oidn();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = furnace(d, "");
    let s = scene.to_str().unwrap();
    let out = run_ok(
        d,
        &["render", s, "--denoise", "-o", "den.exr", "-o", "den.png"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("denoised in"), "{err}");
    run_ok(d, &["render", s, "-o", "raw.exr"]);
    let den = read(&d.join("den.exr"));
    let plain = read(&d.join("raw.exr"));
    let (denoised, raw) = (rgb(&den, ""), rgb(&den, "raw"));
    assert_eq!(
        raw,
        rgb(&plain, ""),
        "raw layer != the render without --denoise"
    );
    let (e_raw, e_den) = (rmse(&raw, 10.0), rmse(&denoised, 10.0));
    assert!(
        e_raw > 1.0,
        "the raw estimate should be noisy: rmse {e_raw}"
    );
    assert!(5.0 * e_den < e_raw, "denoised rmse {e_den} vs raw {e_raw}");
    let (m_raw, m_den) = (mean(&raw), mean(&denoised));
    assert!(
        (m_den / m_raw - 1.0).abs() < 0.01,
        "mean {m_den} vs raw {m_raw}"
    );
    let what = den.attribute("vkpath:denoised").expect("vkpath:denoised");
    assert!(
        what.contains("Open Image Denoise") && what.contains("CPU"),
        "{what}"
    );
    assert!(plain.attribute("vkpath:denoised").is_none());
    // The aux layers were rendered for the denoiser, not asked for: not written.
    assert!(den.channel("albedo.R").is_none() && den.channel("normal.X").is_none());
    // The PNG is the denoised image through the display transform.
    let png = image::open(d.join("den.png")).unwrap().to_rgb8();
    let film = vkpath::Film {
        width: 64,
        height: 64,
        spp: 4,
        pixel_spp: Vec::new(),
        mean: denoised,
        variance: vec![[0.0; 3]; 64 * 64],
    };
    let settings = read(&d.join("den.exr")).display_settings();
    assert_eq!(png, film.to_rgb8(&settings));
}

/// A converged image passes through nearly unchanged: the course scene at 128 x 128 and 1024 samples a
/// pixel (estimated error 6 %) changes by less than 3 % in mean absolute difference relative to its mean
/// (measured 1.9 %; at 4096 samples 1.1 %: the change is the residual noise removed), and its mean by less
/// than 0.5 % (measured 0.1 %).
#[test]
fn a_converged_image_passes_through_nearly_unchanged() {
    require_oidn();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = ["--width", "128", "--height", "128", "--spp", "1024"];
    run_ok(
        d,
        &[&["render"][..], &args, &["--denoise", "-o", "c.exr"]].concat(),
    );
    let exr = read(&d.join("c.exr"));
    let (den, raw) = (rgb(&exr, ""), rgb(&exr, "raw"));
    let diff: f64 = den
        .iter()
        .zip(&raw)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs())))
        .sum::<f64>()
        / (raw.len() * 3) as f64;
    let change = diff / mean(&raw);
    assert!(change < 0.03, "relative change {change}");
    assert!((mean(&den) / mean(&raw) - 1.0).abs() < 0.005);
}

/// `vkpath denoise` gives the same bits twice for the same input, and the same bits as `--denoise` at
/// the end of the render (the same filter on the same images); an EXR it wrote is denoised again from
/// its raw layer, not from its denoised pixels; an EXR without the aux layers is refused with the flag
/// that renders them.
#[test]
fn vkpath_denoise_is_deterministic_and_matches_the_render_flag() {
    require_oidn();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = furnace(d, "");
    let s = scene.to_str().unwrap();
    run_ok(d, &["render", s, "--aov", "albedo,normal", "-o", "in.exr"]);
    run_ok(d, &["render", s, "--denoise", "-o", "flag.exr"]);
    run_ok(d, &["denoise", "in.exr", "-o", "a.exr", "-o", "a.png"]);
    run_ok(d, &["denoise", "in.exr", "-o", "b.exr"]);
    run_ok(d, &["denoise", "a.exr", "-o", "again.exr"]);
    let a = read(&d.join("a.exr"));
    assert_eq!(
        rgb(&a, ""),
        rgb(&read(&d.join("b.exr")), ""),
        "not deterministic"
    );
    assert_eq!(rgb(&a, ""), rgb(&read(&d.join("flag.exr")), ""));
    assert_eq!(rgb(&a, ""), rgb(&read(&d.join("again.exr")), ""));
    assert_eq!(rgb(&a, "raw"), rgb(&read(&d.join("in.exr")), ""));
    // The input's layers and metadata are carried over.
    assert!(a.channel("albedo.R").is_some() && a.channel("normal.Z").is_some());
    assert_eq!(a.attribute("vkpath:spp"), Some("4"));
    // No aux layers: refused, naming the file and the flag.
    run_ok(d, &["render", s, "-o", "bare.exr"]);
    let out = run(d, &["denoise", "bare.exr", "-o", "x.exr"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bare.exr") && err.contains("--aov albedo,normal"),
        "{err}"
    );
    assert!(!d.join("x.exr").exists());
    // Too large for the memory available (the test hook stands for MemAvailable): refused before
    // denoising, naming what it would take.
    let out = vkpath(d)
        .env(vkpath::memory::AVAILABLE_OVERRIDE, "1000000")
        .args(["denoise", "in.exr", "-o", "small.exr"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("denoising 64x64") && err.contains("MiB"),
        "{err}"
    );
    assert!(!d.join("small.exr").exists());
    // `render.denoise = true` is the flag.
    let asked = furnace(d, "denoise = true\n");
    run_ok(d, &["render", asked.to_str().unwrap(), "-o", "key.exr"]);
    assert_eq!(rgb(&read(&d.join("key.exr")), ""), rgb(&a, ""));
}

/// A farm render denoised at the merge: parts rendered with --denoise keep the aux images in their
/// checkpoints (no denoiser needed on the render nodes: VKPATH_OIDN_DIR points nowhere there), and
/// `vkpath merge --denoise` writes bit for bit the image of one render with --denoise (the same samples,
/// the same aux images: every part renders the whole render's). The merged checkpoint keeps the aux
/// images; a part without them is refused by name.
#[test]
fn a_farm_frame_is_denoised_at_the_merge_as_one_render_would_be() {
    require_oidn();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = furnace(d, "");
    let s = scene.to_str().unwrap();
    let empty = d.join("no-oidn");
    std::fs::create_dir(&empty).unwrap();
    for i in 0..3 {
        let part = format!("{i}/3");
        let ckpt = format!("p{i}.ckpt");
        let out = vkpath(d)
            .env("VKPATH_OIDN_DIR", &empty)
            .args([
                "render",
                s,
                "--spp",
                "12",
                "--part",
                &part,
                "--checkpoint",
                &ckpt,
            ])
            .arg("--denoise")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    run_ok(
        d,
        &["render", s, "--spp", "12", "--denoise", "-o", "one.exr"],
    );
    run_ok(
        d,
        &[
            "merge",
            "p0.ckpt",
            "p1.ckpt",
            "p2.ckpt",
            "--denoise",
            "-o",
            "m.exr",
            "--checkpoint",
            "m.ckpt",
        ],
    );
    let (one, merged) = (read(&d.join("one.exr")), read(&d.join("m.exr")));
    assert_eq!(rgb(&merged, ""), rgb(&one, ""));
    assert_eq!(rgb(&merged, "raw"), rgb(&one, "raw"));
    assert!(merged.attribute("vkpath:denoised").is_some());
    // The merged state denoises again.
    run_ok(d, &["merge", "m.ckpt", "--denoise", "-o", "again.exr"]);
    assert_eq!(rgb(&read(&d.join("again.exr")), ""), rgb(&one, ""));
    // A part rendered without --denoise has no aux images.
    run_ok(
        d,
        &[
            "render",
            s,
            "--spp",
            "12",
            "--part",
            "0/3",
            "--checkpoint",
            "bare.ckpt",
        ],
    );
    let out = run(
        d,
        &[
            "merge",
            "bare.ckpt",
            "p1.ckpt",
            "p2.ckpt",
            "--denoise",
            "-o",
            "x.exr",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bare.ckpt") && err.contains("--denoise"),
        "{err}"
    );
    assert!(!d.join("x.exr").exists());
}
