//! Splatting (`render.splat`, shaders/splat.wgsl): each sample weighted into every pixel its filter
//! covers, a pixel the weighted average of what it received (Mitsuba 3's film).
//!
//! - A scene of constant radiance splats to that radiance in every pixel, edges included (the weights
//!   are normalised by their own sum; only f32 rounding of one sample's neighbourhood sum remains).
//! - The splatted image has the per-pixel estimator's expectation (the same filtered image): block means
//!   agree within 4 standard errors.
//! - At equal samples it is closer to a converged reference than the per-pixel estimator on the Cornell
//!   box with Mitsuba's tent filter (the issue measured 2.2x lower MSE for Mitsuba's film; asserted:
//!   at least 1.5x).
//! - Its sums are exact, so the image has the same bits however the render is cut: passes, tiles, the
//!   generic kernel, a checkpoint written, read and resumed, sample ranges merged.

mod common;

use common::{assert_no_validation_errors, scene};
use vkpath::checkpoint::{Checkpoint, merge::merge};
use vkpath::gpu::testing;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::{Film, Scene};

/// The Cornell box of scenes/ at `size` x `size`, with Mitsuba's film: a tent filter of radius 1 and
/// samples on the image only; `splat` as given (None: not written, the default).
fn cornell(size: u32, samples: u32, splat: Option<bool>, seed: u32) -> Scene {
    let text = include_str!("../scenes/cornell-box.toml")
        .replace("width  = 256", &format!("width  = {size}"))
        .replace("height = 256", &format!("height = {size}"))
        .replace(
            "samples        = 512",
            &format!("samples = {samples}\nseed = {seed}"),
        )
        .replace(
            "filter         = \"box\"",
            &format!(
                "filter = \"tent\"\nsample_border = false\n{}",
                splat.map_or(String::new(), |s| format!("splat = {s}"))
            ),
        );
    let s = scene(&text);
    assert_eq!(
        s.render.splats(),
        splat.unwrap_or(true),
        "the scene text changed"
    );
    s
}

fn render_with(scene: &Scene, options: &RenderOptions, passes: &[u32]) -> (Film, Renderer) {
    let ctx = testing::context();
    let mut r = Renderer::new(&ctx, scene, options).expect("renderer");
    for &n in passes {
        r.run_pass(n).expect("pass");
    }
    let film = r.film().expect("film");
    assert_no_validation_errors();
    (film, r)
}

fn render(scene: &Scene) -> Film {
    render_with(scene, &RenderOptions::default(), &[scene.render.samples]).0
}

fn mse(a: &Film, b: &Film) -> f64 {
    let n = (a.mean.len() * 3) as f64;
    a.mean
        .iter()
        .zip(&b.mean)
        .flat_map(|(p, q)| (0..3).map(move |c| (f64::from(p[c]) - f64::from(q[c])).powi(2)))
        .sum::<f64>()
        / n
}

#[test]
fn a_constant_image_splats_to_its_value_in_every_pixel() {
    // Inside a closed sphere that emits 1 and reflects nothing, every sample is exactly 1.
    for filter in [
        "filter = \"tent\"",
        "filter = \"tent\"\nfilter_radius = 2.3",
        "filter = \"gaussian\"",
    ] {
        let text = common::inside_emissive_sphere(0.0, 1.0, true, "0", 13, 3).replace(
            "max_bounces = 0",
            &format!("max_bounces = 0\n{filter}\nsample_border = false"),
        );
        let s = scene(&text);
        assert!(s.render.splats(), "{filter}");
        let film = render(&s);
        for (i, p) in film.mean.iter().enumerate() {
            for &v in p {
                assert!((v - 1.0).abs() < 2e-6, "{filter}: pixel {i} is {v}");
            }
        }
    }
}

#[test]
fn splatting_keeps_the_image_and_lowers_its_error() {
    let size = 32;
    let splat = render(&cornell(size, 16, None, 1));
    let own = render(&cornell(size, 16, Some(false), 1));
    let reference = render(&cornell(size, 1024, Some(false), 7));

    // The expectation: block means of 8x8 pixels against the reference's, within 4 standard errors
    // (the per-pixel variances of the 16-spp per-pixel render estimate both estimators' noise: the
    // splatted one's is lower, so this is conservative for it).
    let block = 8;
    for by in 0..size / block {
        for bx in 0..size / block {
            let (mut a, mut b, mut r, mut var) = (0.0, 0.0, 0.0, 0.0);
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let i = (y * size + x) as usize;
                    a += f64::from(splat.mean[i][1]);
                    b += f64::from(own.mean[i][1]);
                    r += f64::from(reference.mean[i][1]);
                    var += f64::from(own.variance[i][1]) * (1.0 + 16.0 / 1024.0);
                }
            }
            let se = var.sqrt();
            for (name, v) in [("splatted", a), ("per-pixel", b)] {
                assert!(
                    (v - r).abs() <= 4.0 * se,
                    "block ({bx}, {by}): {name} sum {v} against the reference's {r}, standard error {se}"
                );
            }
        }
    }
    let (e_splat, e_own) = (mse(&splat, &reference), mse(&own, &reference));
    println!(
        "MSE at 16 spp: splatted {e_splat:.3e}, per-pixel {e_own:.3e}, ratio {:.2}",
        e_own / e_splat
    );
    assert!(
        e_own > 1.5 * e_splat,
        "splatting should lower the error: {e_splat} against {e_own}"
    );
}

#[test]
fn splatted_renders_are_the_same_bits_however_they_are_cut() {
    let s = cornell(24, 12, None, 3);
    let (one, mut r) = render_with(&s, &RenderOptions::default(), &[12]);
    let sums = r.splat_state().expect("sums");
    assert_eq!(sums.len(), 24 * 24);
    assert!(sums.iter().all(|p| p.weight != [0, 0]));

    // Passes and tiles.
    let tiled = RenderOptions {
        max_tile: Some([8, 8]),
        ..RenderOptions::default()
    };
    let (cut, _) = render_with(&s, &tiled, &[5, 1, 6]);
    assert_eq!(one, cut, "passes of 5, 1 and 6 samples over 8x8 tiles");

    // The generic kernel (the knob read from the parameters).
    let generic = RenderOptions {
        generic: true,
        ..RenderOptions::default()
    };
    let (g, _) = render_with(&s, &generic, &[12]);
    assert_eq!(one, g, "the generic kernel");

    // A checkpoint of 7 samples restored, then 5 more.
    let (_, mut part) = render_with(&s, &RenderOptions::default(), &[7]);
    let state = Checkpoint::of(&mut part, &s).expect("checkpoint");
    assert!(state.header.splat && state.splat.is_some());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.ckpt");
    state.write(&path).unwrap();
    let back = Checkpoint::read(&path).unwrap();
    assert_eq!(back, state);
    let ctx = testing::context();
    let mut resumed = Renderer::new(&ctx, &s, &RenderOptions::default()).unwrap();
    resumed
        .restore(&back.header.ranges, &back.accum)
        .expect("restore");
    resumed
        .restore_splat(back.splat.as_ref().unwrap())
        .expect("restore splat");
    resumed.run_pass(5).unwrap();
    assert_eq!(
        one,
        resumed.film().unwrap(),
        "7 samples checkpointed, then 5"
    );

    // Sample ranges 0..4 and 4..12 merged (given in either order).
    let range = |a: u32, b: u32| {
        let mut r = Renderer::new(&ctx, &s, &RenderOptions::default()).unwrap();
        r.start_at(a).unwrap();
        r.run_pass(b - a).unwrap();
        (
            dir.path().join(format!("{a}")),
            Checkpoint::of(&mut r, &s).unwrap(),
        )
    };
    let merged = merge(&[range(4, 12), range(0, 4)]).expect("merge");
    assert_eq!(merged.splat.as_deref(), Some(&sums[..]));
    // The image's bits; the variances come from the parts' Kahan-compensated squares, added in f64 by
    // the merge (a few ulps from one render's: tests/checkpoint.rs).
    assert!(one.mean == merged.film().mean, "sample ranges merged");
    assert_no_validation_errors();
}

#[test]
fn splatting_a_filter_that_cannot_be_splatted_is_refused() {
    let base = include_str!("../scenes/cornell-box.toml");
    for (render, why) in [
        ("filter = \"box\"\nsplat = true", "box"),
        ("filter = \"tent\"\nsplat = true", "sample_border"),
        (
            "filter = \"gaussian\"\nfilter_sigma = 2.0\nsample_border = false\nsplat = true",
            "radius",
        ),
    ] {
        let text = base.replace("filter         = \"box\"", render);
        let e = Scene::from_toml_str(&text, None)
            .expect_err(why)
            .to_string();
        assert!(e.contains("render.splat"), "{why}: {e}");
        assert!(e.contains("line"), "{why}: {e}");
    }
    // Not splatted unless it can be: the default leaves such scenes per-pixel.
    let text = base.replace("filter         = \"box\"", "filter = \"tent\"");
    assert!(!scene(&text).render.splats());
}
