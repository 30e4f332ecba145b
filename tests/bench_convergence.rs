//! `vkpath bench convergence`: its pure parts against hand values (the log-log interpolation of the time
//! to an error, the error measures, the CSV, the knob settings), and the command itself on a tiny render,
//! checking that the measured error falls as 1/√N and agrees with the film's own variance estimate.

mod common;

use common::cli::run;
use std::path::Path;
use vkpath::bench::convergence::{
    CSV_HEADER, Point, REL_MSE_EPSILON, checkpoints, image_errors, parse_settings, time_to_error,
    to_csv,
};
use vkpath::{Error, Scene};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

#[test]
fn time_to_error_interpolates_in_log_log() {
    // e = 0.1 / sqrt(s): a power law, which log-log interpolation reproduces exactly.
    let curve = [(1.0, 0.1), (4.0, 0.05), (16.0, 0.025)];
    // On a point.
    assert!(close(time_to_error(&curve, 0.05).unwrap(), 4.0, 1e-12));
    // Between points: s = (0.1 / 0.04)^2 = 6.25.
    assert!(close(time_to_error(&curve, 0.04).unwrap(), 6.25, 1e-12));
    // s = (0.1 / 0.03)^2 = 11.111...
    assert!(close(
        time_to_error(&curve, 0.03).unwrap(),
        100.0 / 9.0,
        1e-12
    ));
    // Already reached at the first point: its time.
    assert_eq!(time_to_error(&curve, 0.2), Some(1.0));
    // Never reached.
    assert_eq!(time_to_error(&curve, 0.01), None);
    assert_eq!(time_to_error(&[], 0.01), None);
}

#[test]
fn time_to_error_takes_the_first_crossing_of_a_noisy_curve() {
    // The curve dips below 5% between s = 1 and 2, rises above it, and falls below again by s = 8:
    // the first crossing counts. Through (1, 0.1) and (2, 0.03) the power law is e = 0.1 s^k with
    // k = ln 0.3 / ln 2, so e = 0.05 at s = 0.5^(1/k).
    let curve = [(1.0, 0.1), (2.0, 0.03), (4.0, 0.06), (8.0, 0.02)];
    let k = 0.3f64.ln() / 2f64.ln();
    let expected = 0.5f64.powf(1.0 / k);
    assert!(close(time_to_error(&curve, 0.05).unwrap(), expected, 1e-12));
    assert!((expected - 1.4904).abs() < 1e-3, "{expected}");
}

#[test]
fn image_errors_match_a_hand_computation() {
    let image = [[1.0f32, 2.0, 3.0], [0.0, 0.0, 0.0]];
    let reference = [[1.0f32, 1.0, 1.0], [1.0, 1.0, 1.0]];
    let e = image_errors(&image, &reference);
    // Differences 0, 1, 2, -1, -1, -1: squares sum to 8 over 6 values; mean(reference) = 1.
    let mse = 8.0 / 6.0;
    assert!(close(e.rmse, f64::sqrt(mse), 1e-15));
    assert!(close(e.rel_error, f64::sqrt(mse), 1e-15));
    assert!(close(e.rel_mse, 8.0 / (1.0 + REL_MSE_EPSILON) / 6.0, 1e-15));

    // Against a reference of mean 0.5 with a dark pixel: rel_mse weighs each pixel by 1/(R^2 + eps).
    let image = [[0.5f32, 0.5, 0.5], [0.1, 0.1, 0.1]];
    let reference = [[0.9f32, 0.9, 0.9], [0.1, 0.1, 0.1]];
    let e = image_errors(&image, &reference);
    // Only the first pixel differs, by 0.4 (in f32: the f64 values of the f32 inputs).
    let d = f64::from(0.5f32) - f64::from(0.9f32);
    let r = f64::from(0.9f32);
    let mean_ref = (3.0 * r + 3.0 * f64::from(0.1f32)) / 6.0;
    assert!(close(e.rmse, (3.0 * d * d / 6.0).sqrt(), 1e-14));
    assert!(close(
        e.rel_error,
        (3.0 * d * d / 6.0).sqrt() / mean_ref,
        1e-14
    ));
    assert!(close(
        e.rel_mse,
        3.0 * d * d / (r * r + REL_MSE_EPSILON) / 6.0,
        1e-14
    ));
    // Identical images: no error.
    let same = image_errors(&reference, &reference);
    assert_eq!((same.rmse, same.rel_mse, same.rel_error), (0.0, 0.0, 0.0));
}

/// SSIM against its closed form: two flat images of values a and b have zero variance and covariance, so
/// SSIM = (2ab + C1) / (a^2 + b^2 + C1) with C1 = 0.01^2 (the structure term is C2 / C2 = 1); with a
/// linear display (gamma 1, exposure 1, no tone curve) the displayed luminance of grey v is v. An image
/// is 1 against itself; noise added lowers it.
#[test]
fn ssim_matches_its_closed_form_on_flat_images() {
    use vkpath::bench::convergence::ssim;
    let settings = vkpath::scene::ImageSettings {
        width: 16,
        height: 12,
        exposure: 1.0,
        gamma: vkpath::scene::Gamma::Power(1.0),
        tonemap: vkpath::scene::Tonemap::None,
        denoise: false,
    };
    let flat = |v: f32| vec![[v; 3]; 16 * 12];
    let (a, b) = (0.25f64, 0.5f64);
    let c1 = 1e-4;
    let expected = (2.0 * a * b + c1) / (a * a + b * b + c1);
    let got = ssim(&flat(a as f32), &flat(b as f32), &settings);
    assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
    let mut rng = 12345u32;
    let noisy: Vec<[f32; 3]> = flat(0.5)
        .iter()
        .map(|p| {
            rng = rng.wrapping_mul(1664525).wrapping_add(1013904223);
            let n = (rng >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            p.map(|v| v + 0.2 * n)
        })
        .collect();
    assert!((ssim(&noisy, &noisy, &settings) - 1.0).abs() < 1e-12);
    let s = ssim(&noisy, &flat(0.5), &settings);
    assert!(s < 0.9, "noise should lower SSIM: {s}");
}

#[test]
fn csv_has_the_columns_and_one_line_per_point() {
    let point = |setting: &str, spp, est| Point {
        setting: setting.into(),
        spp,
        seconds: 0.5 * spp as f64,
        samples_per_second: 2048.0,
        rmse: 0.25,
        rel_mse: 0.125,
        rel_error: 0.5,
        estimated_rel_error: est,
        ssim: 0.75,
    };
    let csv = to_csv(&[
        point("default", 1, f64::NAN),
        point("max_bounces=1", 2, 0.4),
    ]);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[0], CSV_HEADER);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(
        header,
        [
            "setting",
            "spp",
            "seconds",
            "samples_per_second",
            "rmse",
            "rel_mse",
            "rel_error",
            "estimated_rel_error",
            "ssim"
        ]
    );
    let row: Vec<&str> = lines[1].split(',').collect();
    assert_eq!(row.len(), header.len());
    assert_eq!(row[0], "default");
    assert_eq!(row[1], "1");
    assert_eq!(row[2].parse::<f64>().unwrap(), 0.5);
    assert_eq!(row[3].parse::<f64>().unwrap(), 2048.0);
    assert_eq!(row[6].parse::<f64>().unwrap(), 0.5);
    // A NaN (no variance estimate at 1 spp) is an empty field.
    assert_eq!(row[7], "");
    let row: Vec<&str> = lines[2].split(',').collect();
    assert_eq!(row[0], "max_bounces=1");
    assert_eq!(row[7].parse::<f64>().unwrap(), 0.4);
}

#[test]
fn checkpoints_double_up_to_the_maximum() {
    assert_eq!(checkpoints(1), [1]);
    assert_eq!(checkpoints(8), [1, 2, 4, 8]);
    assert_eq!(checkpoints(6), [1, 2, 4, 6]);
    assert_eq!(checkpoints(u32::MAX).len(), 33);
}

#[test]
fn knob_settings_parse_apply_and_refuse() {
    let scene = Scene::default_scene();
    let settings = parse_settings(vkpath::bench::convergence::DEFAULT_KNOBS, &scene).unwrap();
    assert_eq!(settings.len(), 8);
    assert_eq!(settings[0].label, "default");
    let (s, o) = settings[0].apply(&scene).unwrap();
    assert_eq!(s, scene);
    assert_eq!(
        o.roulette_depth,
        vkpath::RenderOptions::default().roulette_depth
    );

    let settings = parse_settings(
        "max_bounces=10+roulette=off, samples_per_pass=8,samples_per_pass=adaptive",
        &scene,
    )
    .unwrap();
    let (s, o) = settings[0].apply(&scene).unwrap();
    assert_eq!((s.render.max_bounces, o.roulette_depth), (10, u32::MAX));
    let (_, o) = settings[1].apply(&scene).unwrap();
    assert_eq!(o.samples_per_pass, Some(8));
    let (_, o) = settings[2].apply(&scene).unwrap();
    assert_eq!(o.samples_per_pass, None);

    let settings = parse_settings(
        "sampler=sobol,light_sampling=area,light_sampling=none+sampler=independent",
        &scene,
    )
    .unwrap();
    let (s, _) = settings[0].apply(&scene).unwrap();
    assert_eq!(s.render.sampler, vkpath::scene::Sampler::Sobol);
    let (s, _) = settings[1].apply(&scene).unwrap();
    assert_eq!(s.render.light_sampling, vkpath::scene::LightSampling::Area);
    let (s, _) = settings[2].apply(&scene).unwrap();
    assert_eq!(
        (s.render.light_sampling, s.render.sampler),
        (
            vkpath::scene::LightSampling::None,
            vkpath::scene::Sampler::Independent
        )
    );

    for (bad, says) in [
        ("colour=red", "no knob \"colour\""),
        ("max_bounces", "not knob=value"),
        ("max_bounces=-1", "max_bounces=-1"),
        ("samples_per_pass=0", "at least 1"),
        ("roulette=sometimes", "or off"),
        ("sampler=halton", "independent or sobol"),
        ("light_sampling=bsdf", "cone, area, none or mis"),
        ("default,default", "twice"),
        (" , ", "no setting"),
    ] {
        match parse_settings(bad, &scene) {
            Err(e @ Error::Usage(_)) => {
                let text = e.to_string();
                assert!(text.starts_with("--knobs"), "{text}");
                assert!(text.contains(says), "{bad}: {text}");
                assert_eq!(e.exit_code(), 2);
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}

/// A diffuse ball on a floor under a sphere light, Gaussian filter: noise from the light's and the
/// bounces' sampling, no caustics (the course scene's glass ball makes rare bright samples, whose
/// squared errors are too heavy-tailed for a tolerance at 16x16 and 8 spp).
const SCENE: &str = r#"[camera]
position = [0.0, 0.0, 30.0]
look_at  = [0.0, 0.0, 0.0]
fov      = 50.0

[image]
width  = 64
height = 48

[render]
samples     = 4
max_bounces = 3
seed        = 7
sampler     = "independent"   # the 1/sqrt(N) law and the film's error estimate assume independent samples

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

fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn cli_writes_the_curves_and_the_error_falls_as_one_over_sqrt_n() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tiny.toml"), SCENE).unwrap();
    let out = run(
        dir.path(),
        &[
            "bench",
            "convergence",
            "tiny.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--max-spp",
            "8",
            "--reference-spp",
            "64",
            "--knobs",
            "default,max_bounces=0",
            "--out",
            "out",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("| setting | Msamples/s |"), "{stdout}");
    assert!(stdout.contains("| max_bounces=0 |"), "{stdout}");
    let out_dir = dir.path().join("out");
    let reference = out_dir.join("tiny-reference-16x16-64spp.exr");
    assert!(reference.is_file(), "{stderr}");
    let png = image::open(out_dir.join("tiny-convergence.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1000, 700));

    let rows = csv_rows(&out_dir.join("tiny-convergence.csv"));
    let labels: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r[0].as_str(), r[1].as_str()))
        .collect();
    assert_eq!(
        labels,
        [
            ("default", "1"),
            ("default", "2"),
            ("default", "4"),
            ("default", "8"),
            ("max_bounces=0", "1"),
            ("max_bounces=0", "2"),
            ("max_bounces=0", "4"),
            ("max_bounces=0", "8"),
        ]
    );
    let num = |r: &[String], i: usize| r[i].parse::<f64>().unwrap();
    let default: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == "default").collect();
    // Seconds accumulate; samples/s is w h spp / seconds.
    for w in default.windows(2) {
        assert!(num(w[1], 2) > num(w[0], 2));
    }
    for r in &default {
        assert!(close(num(r, 3), 256.0 * num(r, 1) / num(r, 2), 1e-4));
    }
    // The reference is an independent 64 spp estimate of the same image, so the expected squared error
    // at N spp is sigma^2 (1/N + 1/64): from 1 to 8 spp the error falls by
    // sqrt((1 + 1/64) / (1/8 + 1/64)) = 2.69 (1/sqrt(N) alone would give 2.83). 768 values per image
    // leave the measured ratio some noise: accepted within a factor 1.5 either way.
    let (e1, e8) = (num(default[0], 6), num(default[3], 6));
    let expected = ((1.0f64 + 1.0 / 64.0) / (1.0 / 8.0 + 1.0 / 64.0)).sqrt();
    let ratio = e1 / e8;
    assert!(
        ratio > expected / 1.5 && ratio < expected * 1.5,
        "error at 1 spp {e1}, at 8 spp {e8}: ratio {ratio}, expected {expected}"
    );
    // The film's own estimate at 8 spp predicts the measured error: sigma^2/8 + sigma^2/64 means
    // estimated^2 * (1 + 8/64). Within a factor 1.5.
    let est8 = num(default[3], 7);
    let predicted = est8 * (1.0f64 + 8.0 / 64.0).sqrt();
    assert!(
        e8 > predicted / 1.5 && e8 < predicted * 1.5,
        "measured {e8}, predicted from the film's variance {predicted}"
    );
    // max_bounces = 0 lights only what sees the light directly (here nothing: the light is outside the
    // view), so its image is black: RMSE = sqrt(mean R^2) and relative error sqrt(mean R^2) / mean R
    // at every count, computed here from the reference EXR.
    let r = image::open(&reference).unwrap().to_rgb32f();
    let values: Vec<f64> = r.pixels().flat_map(|p| p.0).map(f64::from).collect();
    let n = values.len() as f64;
    let rms = (values.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    let mean = values.iter().sum::<f64>() / n;
    assert!(mean > 0.0);
    for r in rows.iter().filter(|r| r[0] == "max_bounces=0") {
        assert!(close(num(r, 4), rms, 1e-5), "{r:?}: rms {rms}");
        assert!(close(num(r, 6), rms / mean, 1e-5), "{r:?}: {}", rms / mean);
    }

    // Reusing the reference: no new reference is rendered.
    let out = run(
        dir.path(),
        &[
            "bench",
            "convergence",
            "tiny.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--max-spp",
            "2",
            "--knobs",
            "default",
            "--reference",
            "out/tiny-reference-16x16-64spp.exr",
            "--out",
            "again",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let again: Vec<String> = std::fs::read_dir(dir.path().join("again"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    assert_eq!(again.len(), 2, "{again:?}");
    let rows2 = csv_rows(&dir.path().join("again/tiny-convergence.csv"));
    // The same seed and reference: the first two points are the first run's, bit for bit in the errors.
    assert_eq!(rows2[0][6], rows[0][6]);
    assert_eq!(rows2[1][6], rows[1][6]);

    // A reference of another size is refused with exit 2, naming the file and the sizes.
    let out = run(
        dir.path(),
        &[
            "bench",
            "convergence",
            "tiny.toml",
            "--width",
            "8",
            "--height",
            "8",
            "--reference",
            "out/tiny-reference-16x16-64spp.exr",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("tiny-reference-16x16-64spp.exr is 16x16 pixels"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}
