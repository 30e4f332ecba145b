//! Adaptive sampling (`render.adaptive`, src/render/adaptive.rs): pixels stop once their estimated
//! error is below a threshold; the passes go to the pixels still sampling.
//!
//! - Every pixel's samples are the first n_p of its sequence: each pixel of an adaptive render is
//!   bit-identical to the same pixel of a plain render of n_p samples (so the list dispatch traces
//!   exactly the pixels it counts, and the image's expectation is the plain render's).
//! - The same bits however the render is cut: passes, tiles, the generic kernel.
//! - A scene of constant radiance converges at the minimum (every pixel stops at 16 samples).
//! - The image's expectation is unchanged: block means within 4 standard errors of a long reference,
//!   the whole image's within 3.
//! - No pixel stops whose true error (its per-sample variance from a long reference, over its sample
//!   count, with the independent sampler, for which that is the variance of its mean) is above twice the
//!   threshold, on the Cornell box.
//! - The command line: the spp layer, the report, and the refusals (exit 2).

mod common;

use common::cli::{run, run_ok, write};
use common::{assert_no_validation_errors, scene};
use std::sync::atomic::AtomicBool;
use vkpath::gpu::testing;
use vkpath::render::adaptive::AdaptiveSettings;
use vkpath::render::{Budget, RenderOptions, Renderer, StopReason, render_progressive};
use vkpath::{Film, Scene};

/// The Cornell box of scenes/ at `size` x `size` with `samples` and `seed` (`sampler` as given).
fn cornell(size: u32, samples: u32, seed: u32, sampler: &str) -> Scene {
    let text = include_str!("../scenes/cornell-box.toml")
        .replace("width  = 256", &format!("width  = {size}"))
        .replace("height = 256", &format!("height = {size}"))
        .replace(
            "samples        = 512",
            &format!("samples = {samples}\nseed = {seed}\nsampler = \"{sampler}\""),
        );
    let s = scene(&text);
    assert_eq!(s.image.width, size, "the scene text changed");
    assert_eq!(s.render.samples, samples, "the scene text changed");
    s
}

fn adaptive(threshold: f64) -> RenderOptions {
    RenderOptions {
        adaptive: Some(AdaptiveSettings {
            threshold,
            min_spp: 16,
        }),
        ..RenderOptions::default()
    }
}

/// Renders `scene` to its samples through the progressive loop (which makes adaptive sampling's
/// checks); the film and why it stopped.
fn render_adaptive(scene: &Scene, options: &RenderOptions) -> (Film, StopReason) {
    let ctx = testing::context();
    let mut r = Renderer::new(&ctx, scene, options).expect("renderer");
    let budget = Budget {
        spp: scene.render.samples,
        time: None,
        progress_every: None,
        save_every: None,
        target_error: None,
    };
    let (reason, _) =
        render_progressive(&mut r, options, &budget, &AtomicBool::new(false), |_, _| {
            Ok(())
        })
        .expect("render");
    let film = r.film().expect("film");
    assert_no_validation_errors();
    (film, reason)
}

fn render_plain(scene: &Scene, spp: u32) -> Film {
    let ctx = testing::context();
    let mut r = Renderer::new(&ctx, scene, &RenderOptions::default()).expect("renderer");
    r.run_pass(spp).expect("pass");
    r.film().expect("film")
}

#[test]
fn each_pixel_holds_the_first_samples_of_its_sequence() {
    let s = cornell(32, 64, 5, "sobol");
    let (film, reason) = render_adaptive(&s, &adaptive(0.04));
    assert_eq!(reason, StopReason::Samples);
    assert_eq!(film.pixel_spp.len(), 32 * 32);
    let mut counts = film.pixel_spp.clone();
    counts.sort();
    counts.dedup();
    // The threshold is chosen so that some pixels stop and some go on to the end: otherwise this test
    // could not tell a list dispatch from a plain one.
    assert!(
        counts.len() >= 2 && counts[0] < 64 && *counts.last().unwrap() == 64,
        "counts {counts:?}"
    );
    for &n in &counts {
        assert!(n % 16 == 0, "a pixel stopped between checks: {n}");
        let plain = render_plain(&s, n);
        for (i, &c) in film.pixel_spp.iter().enumerate() {
            if c == n {
                assert_eq!(
                    film.mean[i], plain.mean[i],
                    "pixel {i} ({n} samples) differs from a plain render of {n} samples"
                );
                assert_eq!(film.variance[i], plain.variance[i], "pixel {i}'s variance");
            }
        }
    }
}

#[test]
fn adaptive_renders_are_the_same_bits_however_they_are_cut() {
    let s = cornell(24, 48, 2, "sobol");
    let (one, _) = render_adaptive(&s, &adaptive(0.05));
    assert!(one.pixel_spp.iter().any(|&n| n < 48), "nothing stopped");
    for (what, options) in [
        (
            "passes of 5 samples over 8x8 tiles",
            RenderOptions {
                samples_per_pass: Some(5),
                max_tile: Some([8, 8]),
                ..adaptive(0.05)
            },
        ),
        (
            "the generic kernel",
            RenderOptions {
                generic: true,
                ..adaptive(0.05)
            },
        ),
    ] {
        let (cut, _) = render_adaptive(&s, &options);
        assert_eq!(one, cut, "{what}");
    }
}

#[test]
fn a_constant_image_converges_at_the_minimum() {
    // The furnace without Russian roulette: every sample of every pixel is 1 (up to float rounding).
    let s = scene(include_str!("../scenes/furnace.toml"));
    let options = RenderOptions {
        roulette_depth: u32::MAX,
        ..adaptive(1e-3)
    };
    let (film, reason) = render_adaptive(&s, &options);
    assert_eq!(reason, StopReason::Converged);
    assert!(
        film.pixel_spp.iter().all(|&n| n == 16),
        "{:?}",
        &film.pixel_spp[..8]
    );
    for p in &film.mean {
        for &v in p {
            assert!((v - 1.0).abs() < 1e-4, "furnace pixel {v}");
        }
    }
}

#[test]
fn adaptive_sampling_keeps_the_image_expectation() {
    let size = 32;
    let (film, _) = render_adaptive(&cornell(size, 256, 11, "sobol"), &adaptive(0.08));
    let mean_spp = film.pixel_spp.iter().map(|&n| f64::from(n)).sum::<f64>() / (size * size) as f64;
    assert!(
        mean_spp < 200.0,
        "adaptive sampling saved little: {mean_spp} spp"
    );
    let reference = render_plain(&cornell(size, 4096, 99, "sobol"), 4096);
    // Blocks of 8x8: mean difference against the standard error of the two estimates' block means.
    let block = 8usize;
    let w = size as usize;
    let mut worst: f64 = 0.0;
    let mut whole = [(0.0f64, 0.0f64); 3];
    for by in 0..w / block {
        for bx in 0..w / block {
            for (c, total) in whole.iter_mut().enumerate() {
                let (mut d, mut var) = (0.0, 0.0);
                for y in by * block..(by + 1) * block {
                    for x in bx * block..(bx + 1) * block {
                        let i = y * w + x;
                        d += f64::from(film.mean[i][c]) - f64::from(reference.mean[i][c]);
                        var += f64::from(film.variance[i][c]) + f64::from(reference.variance[i][c]);
                    }
                }
                total.0 += d;
                total.1 += var;
                let z = d / var.sqrt();
                worst = worst.max(z.abs());
            }
        }
    }
    assert!(worst < 4.0, "a block mean is {worst} standard errors off");
    for (c, (d, var)) in whole.iter().enumerate() {
        let z = d / var.sqrt();
        assert!(
            z.abs() < 3.0,
            "channel {c}: the image mean is {z} standard errors off"
        );
    }
}

#[test]
fn no_pixel_stops_with_more_than_twice_the_threshold_of_true_error() {
    // The independent sampler: a pixel's mean over n samples then has the variance sigma^2 / n exactly,
    // with sigma^2 the per-sample variance, known from a long reference (4096 samples: its own relative
    // uncertainty about 2 %).
    let (size, t) = (40u32, 0.05);
    let (film, _) = render_adaptive(&cornell(size, 512, 4, "independent"), &adaptive(t));
    let stopped = film.pixel_spp.iter().filter(|&&n| n < 512).count();
    assert!(
        stopped > (size * size / 2) as usize,
        "too few pixels stopped ({stopped}) for the test to say anything"
    );
    let reference = render_plain(&cornell(size, 4096, 8, "independent"), 4096);
    let image_mean = reference.average();
    let mut worst: f64 = 0.0;
    for (i, &n) in film.pixel_spp.iter().enumerate() {
        if n == 512 {
            continue;
        }
        let m = reference.mean[i].iter().map(|&v| f64::from(v)).sum::<f64>() / 3.0;
        // The reference's variance of its mean times its samples: sigma^2 (mean over channels).
        let sigma2 = reference.variance[i]
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            / 3.0
            * 4096.0;
        let true_error = (sigma2 / f64::from(n)).sqrt() / m.max(image_mean);
        worst = worst.max(true_error);
    }
    assert!(
        worst <= 2.0 * t,
        "a pixel stopped with a true error of {worst} (threshold {t})"
    );
}

#[test]
fn the_command_line_writes_the_spp_layer_and_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let adaptive = [
        "render",
        "--width",
        "24",
        "--height",
        "24",
        "--adaptive-threshold",
        "0.05",
        "--quiet",
    ];
    fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [base, extra].concat()
    }
    let out = run_ok(
        d,
        &with(
            &adaptive,
            &["--spp", "48", "--aov", "spp", "--json", "-o", "a.exr"],
        ),
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let mean_spp = report["mean_spp"].as_f64().expect("mean_spp");
    assert!((16.0..=48.0).contains(&mean_spp), "{report}");
    assert_eq!(report["adaptive"]["threshold"].as_f64(), Some(0.05));
    let exr = exr::prelude::read_all_flat_layers_from_file(d.join("a.exr")).expect("exr");
    let layer = &exr.layer_data[0];
    let spp = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == "spp.Y")
        .expect("spp.Y");
    let values: Vec<f32> = match &spp.sample_data {
        exr::prelude::FlatSamples::F32(v) => v.clone(),
        other => panic!("spp.Y is not f32: {other:?}"),
    };
    let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
    assert!((mean - mean_spp).abs() < 1e-9, "{mean} vs {mean_spp}");

    for (args, says) in [
        (
            vec!["--adaptive", "on", "--splat", "on"],
            "--splat on and adaptive sampling",
        ),
        (
            vec![
                "--adaptive",
                "on",
                "--part",
                "0/2",
                "--checkpoint",
                "p.ckpt",
            ],
            "part",
        ),
        (vec!["--adaptive-threshold", "0"], "--adaptive-threshold"),
    ] {
        let mut all = vec![
            "render", "--spp", "4", "--width", "8", "--height", "8", "-o", "x.png",
        ];
        all.extend(args.iter().copied());
        let out = run(d, &all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!d.join("x.png").exists(), "{args:?} wrote an image");
    }

    // A checkpoint carries the counts: 32 samples, then resumed to 48, are the bits of 48 at once
    // (the check at 32 is in the checkpoint); the other setting, and a merge, are refused.

    run_ok(d, &with(&adaptive, &["--spp", "48", "-o", "whole.exr"]));
    run_ok(
        d,
        &with(
            &adaptive,
            &["--spp", "32", "--checkpoint", "c.ckpt", "-o", "half.exr"],
        ),
    );
    run_ok(
        d,
        &with(
            &adaptive,
            &["--spp", "48", "--resume", "c.ckpt", "-o", "resumed.exr"],
        ),
    );
    let same = run(d, &["compare", "whole.exr", "resumed.exr"]);
    assert_eq!(
        same.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&same.stdout)
    );
    let differs = run(d, &["compare", "whole.exr", "half.exr"]);
    assert_eq!(differs.status.code(), Some(1), "the test cannot fail");
    for (args, says) in [
        (
            vec![
                "render", "--width", "24", "--height", "24", "--spp", "64", "--resume", "c.ckpt",
                "-o", "y.png",
            ],
            "is of an adaptive render",
        ),
        (vec!["merge", "c.ckpt", "-o", "y.png"], "adaptive render"),
    ] {
        let out = run(d, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!d.join("y.png").exists(), "{args:?} wrote an image");
    }

    // The scene file's keys: a bad threshold names its key and line; splat with adaptive is refused.
    let base = include_str!("../scenes/cornell-box.toml");
    for (extra, key) in [
        ("adaptive_threshold = -1.0", "render.adaptive_threshold"),
        ("adaptive_min_samples = 1", "render.adaptive_min_samples"),
        (
            "adaptive = true\nsplat = true\nfilter = \"tent\"\nsample_border = false",
            "render.splat",
        ),
    ] {
        let text = base
            .replace("filter         = \"box\"", "")
            .replace("samples        = 512", &format!("samples = 4\n{extra}"));
        let path = write(d, "bad.toml", &text);
        let out = run(d, &["render", path.to_str().unwrap(), "-o", "x.png"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra}: {err}");
        assert!(
            err.contains(key) && err.contains("bad.toml, line "),
            "{extra}: {err}"
        );
        assert!(!d.join("x.png").exists());
    }
}
