//! Helpers shared by the integration tests: render a scene given as TOML text on the shared test context
//! (Khronos validation on) and check that the validation layer stayed silent.
#![allow(dead_code)]

pub mod bsdf;
pub mod cli;
pub mod envmap;
pub mod fuzz;
pub mod stats;
pub mod vec;

use vkpath::gpu::testing;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::{Film, Scene};

pub fn scene(toml: &str) -> Scene {
    Scene::from_toml_str(toml, None).unwrap_or_else(|e| panic!("test scene is invalid: {e}"))
}

/// Renders `scene` with `passes` passes of `spp_per_pass` samples.
pub fn render_passes(
    scene: &Scene,
    options: &RenderOptions,
    passes: u32,
    spp_per_pass: u32,
) -> Film {
    let ctx = testing::context();
    let mut r = Renderer::new(&ctx, scene, options).expect("renderer");
    for _ in 0..passes {
        r.run_pass(spp_per_pass).expect("pass");
    }
    let film = r.film().expect("film");
    assert_no_validation_errors();
    film
}

/// Renders with the scene's own sample count in one pass.
pub fn render(scene: &Scene) -> Film {
    render_passes(scene, &RenderOptions::default(), 1, scene.render.samples)
}

/// The image mean of the green channel and its standard error: the pixels' variances of their means,
/// summed, over n^2 (the pixels are independent).
pub fn mean_and_se(film: &Film) -> (f64, f64) {
    let n = film.mean.len() as f64;
    let mean = film.mean.iter().map(|p| p[1] as f64).sum::<f64>() / n;
    let var = film.variance.iter().map(|v| v[1] as f64).sum::<f64>() / (n * n);
    (mean, var.sqrt())
}

pub fn assert_no_validation_errors() {
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "Vulkan validation errors: {errors:#?}");
}

/// Renders `base` with each light-sampling strategy and asserts that the green channel's image means
/// agree pairwise within 4 standard errors of their difference. The variance of an image mean is the
/// sum of the pixels' variances of their means over n^2; the renders share their random numbers, so the
/// sum of two renders' variances over-states their difference's (conservative). Returns each
/// strategy's image mean and standard error.
pub fn assert_strategies_agree(
    base: &Scene,
    strategies: &[vkpath::scene::LightSampling],
) -> Vec<(f64, f64)> {
    let mut stats = Vec::new();
    for &strategy in strategies {
        let mut s = base.clone();
        s.render.light_sampling = strategy;
        let (mean, se) = mean_and_se(&render(&s));
        println!("{strategy:?}: image mean {mean:.5}, standard error {se:.2e}");
        stats.push((mean, se));
    }
    for i in 0..stats.len() {
        for j in i + 1..stats.len() {
            let d = stats[i].0 - stats[j].0;
            let se = (stats[i].1.powi(2) + stats[j].1.powi(2)).sqrt();
            assert!(
                d.abs() <= 4.0 * se,
                "{:?} {} vs {:?} {}: {d} > 4 x {se}",
                strategies[i],
                stats[i].0,
                strategies[j],
                stats[j].0
            );
        }
    }
    stats
}

/// The camera at the centre of a closed diffuse sphere of albedo `albedo` that emits `emission` from its
/// outside, or from both sides with `two_sided` (seen from inside: a white furnace that emits). Each wall
/// point then has L = Le + a L over an unbounded path (L = Le / (1 - a)), or the sum up to a^N over N
/// bounces. `max_bounces` as the scene file writes it (-1: no limit).
pub fn inside_emissive_sphere(
    albedo: f64,
    emission: f64,
    two_sided: bool,
    max_bounces: &str,
    size: u32,
    samples: u32,
) -> String {
    format!(
        r#"
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 90.0
[image]
width = {size}
height = {size}
[render]
samples = {samples}
max_bounces = {max_bounces}
[materials]
wall = {{ type = "diffuse", albedo = [{albedo}, {albedo}, {albedo}], emission = [{emission}, {emission}, {emission}], two_sided_emission = {two_sided} }}
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 2.0
material = "wall"
"#
    )
}

/// How far apart two renders of the same scene are: the sum of |a - b| over every channel, relative to
/// the sum of b, and the fraction of pixels where some channel differs by more than 1 % of b's mean.
pub fn render_distance(a: &vkpath::Film, b: &vkpath::Film) -> (f64, f64) {
    let (mut diff, mut total) = (0.0f64, 0.0f64);
    for (p, q) in a.mean.iter().zip(&b.mean) {
        for c in 0..3 {
            diff += (p[c] as f64 - q[c] as f64).abs();
            total += q[c] as f64;
        }
    }
    let mean = total / (3 * b.mean.len()) as f64;
    let far = a
        .mean
        .iter()
        .zip(&b.mean)
        .filter(|(p, q)| (0..3).any(|c| (p[c] as f64 - q[c] as f64).abs() > 0.01 * mean))
        .count();
    (diff / total, far as f64 / b.mean.len() as f64)
}
