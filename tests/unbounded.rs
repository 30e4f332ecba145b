//! Paths without a bounce limit (`max_bounces = -1`, Mitsuba's `max_depth = -1`): the kernel carries a
//! path across dispatches (trace.wgsl, `main`), so a path of any length fits lavapipe's loop budget, and
//! the renderer ends paths by Russian roulette only, or at the documented cap (`abi::BOUNCE_CAP`), which
//! it counts and reports.

mod common;

use common::cli::{run, run_ok, write};
use common::{render_passes, scene};
use vkpath::kernel::abi::BOUNCE_CAP;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::scene::NO_BOUNCE_LIMIT;

/// A white furnace that emits (common::inside_emissive_sphere): the camera inside a closed sphere whose
/// diffuse wall has albedo a = 0.9 and emits radiance Le = 1 on both sides. Every wall point then has
/// L = Le + a L (the wall sees only wall, of the same radiance, and a Lambertian wall reflects a times its
/// irradiance pi L as radiance a L), so L = Le / (1 - a) = 10: the geometric series 1 + a + a^2 + ...,
/// which only a path without a bounce limit sums. With cosine-weighted bounces each path of n bounces
/// carries exactly 1 + a + ... + a^n.
fn emitting_furnace(size: u32, samples: u32, max_bounces: &str) -> String {
    common::inside_emissive_sphere(0.9, 1.0, true, max_bounces, size, samples)
}

/// With Russian roulette (the default, from bounce 3), the unbounded furnace's image mean converges to
/// 1 / (1 - 0.9) = 10 within 5 standard errors (the pixels are independent: the image mean's variance is
/// the sum of the pixels' variances of their means over n^2). At 5 bounces it would be 1 + ... + 0.9^5 =
/// 4.69, at 64 bounces 9.99: the test also checks that the mean is not one of the short sums.
#[test]
fn an_unbounded_furnace_sums_the_whole_geometric_series() {
    let s = scene(&emitting_furnace(24, 64, "-1"));
    assert_eq!(s.render.max_bounces, NO_BOUNCE_LIMIT);
    let ctx = vkpath::gpu::testing::context();
    let mut r = Renderer::new(&ctx, &s, &RenderOptions::default()).expect("renderer");
    r.run_pass(64).expect("pass");
    let film = r.film().expect("film");
    common::assert_no_validation_errors();
    let n = film.mean.len() as f64;
    let mean = film.mean.iter().map(|p| f64::from(p[1])).sum::<f64>() / n;
    let var = film.variance.iter().map(|v| f64::from(v[1])).sum::<f64>() / (n * n);
    let se = var.sqrt();
    assert!(se > 0.0 && se < 0.2, "roulette adds some noise: se = {se}");
    assert!(
        (mean - 10.0).abs() < 5.0 * se,
        "mean {mean} vs 10 (se {se})"
    );
    // Roulette ended every path long before the cap.
    assert_eq!(r.sample_faults().expect("faults").bounce_capped, 0);
}

/// Without roulette, nothing ends a path in a closed scene: every path runs to the cap of BOUNCE_CAP
/// bounces, carries exactly 1 + a + ... + a^BOUNCE_CAP = 10 (1 - a^(BOUNCE_CAP + 1)) (a^1025 ~ 1e-47:
/// 10 to f32 rounding), and is counted, one per sample.
#[test]
fn a_path_that_roulette_cannot_end_is_capped_and_counted() {
    let s = scene(&emitting_furnace(8, 4, "-1"));
    let options = RenderOptions {
        roulette_depth: u32::MAX,
        ..RenderOptions::default()
    };
    let ctx = vkpath::gpu::testing::context();
    let mut r = Renderer::new(&ctx, &s, &options).expect("renderer");
    r.run_pass(4).expect("pass");
    let film = r.film().expect("film");
    common::assert_no_validation_errors();
    let expected = 10.0 * (1.0 - 0.9f64.powi(BOUNCE_CAP as i32 + 1));
    for (i, px) in film.mean.iter().enumerate() {
        for &c in px {
            // 1025 f32 multiply-adds of a sum near 10: a few hundred ulps of 10 at most.
            assert!(
                (f64::from(c) - expected).abs() < 2e-4,
                "pixel {i}: {c} vs {expected}"
            );
        }
    }
    let faults = r.sample_faults().expect("faults");
    assert_eq!(faults.bounce_capped, 8 * 8 * 4, "{faults:?}");
    // A scene's own limit is no cap: the same furnace at 10 bounces counts nothing and gives the short
    // sum 1 + ... + 0.9^10.
    let s = scene(&emitting_furnace(8, 4, "10"));
    let film = render_passes(&s, &options, 1, 4);
    let short: f64 = (0..=10).map(|k| 0.9f64.powi(k)).sum();
    assert!(
        (f64::from(film.mean[0][0]) - short).abs() < 1e-5,
        "{} vs {short}",
        film.mean[0][0]
    );
}

/// The command line: `--max-bounces -1` and `max_bounces = -1` are no limit, reported as -1 in
/// `--json`; a capped path is reported on stderr; -2 is refused, naming the key or the flag.
#[test]
fn the_command_line_takes_no_limit_and_reports_the_cap() {
    let dir = tempfile::tempdir().expect("tempdir");
    write(dir.path(), "furnace.toml", &emitting_furnace(8, 2, "3"));
    let out = run_ok(
        dir.path(),
        &[
            "render",
            "furnace.toml",
            "--max-bounces",
            "-1",
            "--roulette-depth",
            "off",
            "--json",
            "-o",
            "out.exr",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!("128 paths reached {BOUNCE_CAP} bounces")),
        "{stderr}"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(json["max_bounces"], -1, "{json}");
    assert_eq!(json["sample_faults"]["bounce_capped"], 128, "{json}");

    let out = run(
        dir.path(),
        &["render", "furnace.toml", "--max-bounces", "-2"],
    );
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--max-bounces") && stderr.contains("-1 for no limit"),
        "{stderr}"
    );
    write(dir.path(), "bad.toml", &emitting_furnace(8, 2, "-2"));
    let out = run(dir.path(), &["render", "bad.toml"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("render.max_bounces") && stderr.contains("-1 sets no limit"),
        "{stderr}"
    );
    assert!(!dir.path().join("out.png").exists());
}
