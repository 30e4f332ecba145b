//! Renders lit by emitting surfaces and by the environment, against expectations computed here in f64:
//!
//! * a diffuse floor under an emissive quad: Lambert's closed-form irradiance of a polygon, per pixel;
//! * the camera inside an emissive diffuse sphere: L = Le (1 + a + ... + a^N);
//! * white furnaces: a diffuse sphere under a uniform environment reflects a L (albedo 1: it vanishes),
//!   and under an environment map every point of an albedo-1 sphere shows the map's cosine-weighted
//!   mean over its normal's hemisphere (a quadrature here);
//! * every light-sampling strategy renders the same image mean (the MIS weights sum to one) in the
//!   Cornell box (scenes/cornell-box.toml) and under an environment map.

mod common;

use common::envmap::{cosine_convolution, test_map, write_exr};
use common::vec::{V3, cross, dot, normalize, sub};
use common::*;
use std::f64::consts::PI;
use vkpath::scene::LightSampling;

const ALL: [LightSampling; 4] = [
    LightSampling::Mis,
    LightSampling::Cone,
    LightSampling::Area,
    LightSampling::None,
];

fn strategy_name(s: LightSampling) -> &'static str {
    LightSampling::ALL
        .iter()
        .find(|(x, _)| *x == s)
        .map(|(_, n)| *n)
        .expect("named")
}

/// Irradiance at p (normal n) from a polygon of uniform radiance le, by Lambert's formula: the polygon's
/// projected solid angle is (1/2) |sum_i theta_i (n . g_i)|, with theta_i the angle its edge i subtends
/// at p and g_i the unit normal of the plane through p and that edge; E = le times it.
fn polygon_irradiance(p: V3, n: V3, polygon: &[V3], le: f64) -> f64 {
    let mut sum = 0.0;
    for i in 0..polygon.len() {
        let a = normalize(sub(polygon[i], p));
        let b = normalize(sub(polygon[(i + 1) % polygon.len()], p));
        let theta = dot(a, b).clamp(-1.0, 1.0).acos();
        sum += theta * dot(n, normalize(cross(a, b)));
    }
    0.5 * sum.abs() * le
}

/// A grey floor (y = 0) under a 2 x 1.5 emitter quad facing down at height 1, offset from the view's
/// centre, seen straight down by an orthographic camera through pixel centres: every floor pixel the
/// quad does not hide reflects a E(p) / pi, with E Lambert's irradiance of the quad. Direct light only
/// (max_bounces 1: nothing else is lit). Checked per pixel within 5 standard errors (from the pixel's
/// own variance) plus 1e-4 relative, for every strategy but "none" (BSDF sampling alone finds the quad
/// too rarely at this sample count for a per-pixel test; its image mean is checked instead).
#[test]
fn a_floor_under_an_emissive_quad_gets_lamberts_irradiance() {
    let (a, le) = (0.6f64, 3.0f64);
    let quad: [V3; 4] = [
        [-0.5, 1.0, -1.0],
        [1.5, 1.0, -1.0],
        [1.5, 1.0, 0.5],
        [-0.5, 1.0, 0.5],
    ];
    let q = |i: usize| format!("[{}, {}, {}]", quad[i][0], quad[i][1], quad[i][2]);
    // Both triangles wound so that (v1 - v0) x (v2 - v0) points down (-y): the front faces the floor.
    let text = format!(
        r#"
[camera]
type = "orthographic"
position = [0.0, 10.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
extent = 8.0
[image]
width = 32
height = 32
[render]
samples = 256
max_bounces = 1
filter = "none"
[materials]
grey = {{ type = "diffuse", albedo = [{a}, {a}, {a}] }}
lamp = {{ type = "emitter", radiance = [{le}, {le}, {le}] }}
[[triangle]]
vertices = [[-50.0, 0.0, -50.0], [50.0, 0.0, 50.0], [50.0, 0.0, -50.0]]
material = "grey"
[[triangle]]
vertices = [[-50.0, 0.0, -50.0], [-50.0, 0.0, 50.0], [50.0, 0.0, 50.0]]
material = "grey"
[[triangle]]
vertices = [{}, {}, {}]
material = "lamp"
[[triangle]]
vertices = [{}, {}, {}]
material = "lamp"
"#,
        q(0),
        q(1),
        q(2),
        q(0),
        q(2),
        q(3)
    );
    let base = scene(&text);
    for strategy in [LightSampling::Mis, LightSampling::Cone, LightSampling::Area] {
        let mut s = base.clone();
        s.render.light_sampling = strategy;
        let film = render(&s);
        let (mut checked, mut worst) = (0, 0.0f64);
        for py in 0..32u32 {
            for px in 0..32u32 {
                // Pixel centre -> floor point: right = +x, up = -z, 8 units across 32 pixels.
                let x = (2.0 * (px as f64 + 0.5) / 32.0 - 1.0) * 4.0;
                let z = -(1.0 - 2.0 * (py as f64 + 0.5) / 32.0) * 4.0;
                let hidden = (-0.5..=1.5).contains(&x) && (-1.0..=0.5).contains(&z);
                if hidden {
                    assert_eq!(film.pixel(px, py)[1], 0.0, "the back of the lamp is black");
                    continue;
                }
                let expected = a / PI * polygon_irradiance([x, 0.0, z], [0.0, 1.0, 0.0], &quad, le);
                let got = film.pixel(px, py)[1] as f64;
                let se = (film.variance[(py * 32 + px) as usize][1] as f64).sqrt();
                let err = (got - expected).abs();
                assert!(
                    err <= 5.0 * se + 1e-4 * expected,
                    "{}: pixel ({px},{py}) at ({x}, {z}): {got} vs {expected} (se {se})",
                    strategy_name(strategy)
                );
                worst = worst.max(err / expected);
                checked += 1;
            }
        }
        println!(
            "{}: {checked} floor pixels, worst relative error {worst:.2e}",
            strategy_name(strategy)
        );
        assert!(checked > 800);
    }
    // All four strategies, "none" included, render the same image mean.
    let mut s = base.clone();
    s.render.samples = 1024;
    s.image.width = 16;
    s.image.height = 16;
    assert_strategies_agree(&s, &ALL);
}

fn inside_sphere(albedo: f64, two_sided: bool, max_bounces: u32) -> vkpath::Scene {
    scene(&inside_emissive_sphere(
        albedo,
        1.5,
        two_sided,
        &max_bounces.to_string(),
        16,
        256,
    ))
}

/// The camera inside a closed diffuse sphere of albedo a that emits Le from its inside (two-sided):
/// every path sees Le at each of its N + 1 hits, weighted a^k, so L = Le (1 - a^(N+1)) / (1 - a), the
/// same in every pixel and for every strategy (the sphere is a light, which its own interior cannot
/// sample: every hit counts in full). Russian roulette keeps it unbiased: the image mean is checked
/// within 5 standard errors. One-sided, its emission faces outwards and the inside is black.
#[test]
fn inside_an_emissive_sphere() {
    let (a, le, n) = (0.6f64, 1.5f64, 12u32);
    let expected = le * (1.0 - a.powi(n as i32 + 1)) / (1.0 - a);
    for strategy in ALL {
        let mut s = inside_sphere(a, true, n);
        s.render.light_sampling = strategy;
        let film = render(&s);
        let npix = film.mean.len() as f64;
        let mean = film.mean.iter().map(|p| p[0] as f64).sum::<f64>() / npix;
        let se = (film.variance.iter().map(|v| v[0] as f64).sum::<f64>() / (npix * npix)).sqrt();
        println!(
            "{}: {mean:.5} vs {expected:.5} (se {se:.1e})",
            strategy_name(strategy)
        );
        assert!(
            (mean - expected).abs() <= 5.0 * se + 1e-5,
            "{}: {mean} vs {expected} (se {se})",
            strategy_name(strategy)
        );
    }
    let film = render(&inside_sphere(a, false, n));
    assert!(
        film.mean.iter().all(|p| p[0] == 0.0),
        "one-sided: dark inside"
    );
}

fn furnace(albedo: f64, environment: &str) -> vkpath::Scene {
    scene(&format!(
        r#"
[camera]
type = "orthographic"
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
extent = 2.5
[image]
width = 24
height = 24
[render]
samples = 128
max_bounces = 4
filter = "none"
[materials]
white = {{ type = "diffuse", albedo = [{albedo}, {albedo}, {albedo}] }}
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "white"
{environment}
"#
    ))
}

/// A diffuse sphere of albedo a under a uniform environment of radiance L: it is convex, so every ray
/// leaving it escapes, and it reflects a L (the background around it shows L). Albedo 1: the sphere
/// vanishes. Per pixel within 5 standard errors + 1e-5, every strategy; with BSDF sampling alone
/// ("none") cosine sampling makes every path carry exactly a L.
#[test]
fn white_furnace_under_a_uniform_environment() {
    let l = 0.7f64;
    for albedo in [1.0f64, 0.5] {
        for strategy in ALL {
            let mut s = furnace(
                albedo,
                &format!("[environment]\nradiance = [{l}, {l}, {l}]"),
            );
            s.render.light_sampling = strategy;
            let film = render(&s);
            for (i, (p, v)) in film.mean.iter().zip(&film.variance).enumerate() {
                let (x, y) = ((i % 24) as f64 - 11.5, 11.5 - (i / 24) as f64);
                let r = (x * x + y * y).sqrt() * 2.5 / 24.0;
                let expected = if r < 1.0 { albedo * l } else { l };
                if (r - 1.0).abs() < 0.06 {
                    continue; // the silhouette
                }
                let (got, se) = (p[1] as f64, (v[1] as f64).sqrt());
                assert!(
                    (got - expected).abs() <= 5.0 * se + 1e-5,
                    "albedo {albedo}, {}: pixel {i}: {got} vs {expected} (se {se})",
                    strategy_name(strategy)
                );
            }
        }
    }
}

/// An albedo-1 diffuse sphere under a non-uniform environment map (rotated 30 degrees, tinted): each
/// point shows the map's cosine-weighted mean over its normal's hemisphere, computed here by quadrature
/// from the map's texels (Mitsuba's layout, written independently of the renderer); checked for the
/// pixels of the sphere's central part within 5 standard errors + 0.5%. And a map of one constant value
/// is a uniform environment: the albedo-1 sphere vanishes into it.
#[test]
fn white_furnace_under_an_environment_map() {
    let dir = tempfile::tempdir().unwrap();
    // A spot 4 times brighter than the sky (not 40 times, as the sampler's own test has): BSDF sampling
    // alone ("none") finds a small bright spot too rarely for per-pixel variance estimates at 512 spp
    // to be trusted.
    let map = test_map(4.0);
    let path = dir.path().join("sky.exr");
    write_exr(&map, &path);
    let tint = [0.5, 1.0, 2.0];
    let env = format!(
        "[environment]\nmap = \"{}\"\nradiance = [{}, {}, {}]\nrotate = 30.0",
        path.display(),
        tint[0],
        tint[1],
        tint[2]
    );
    // The central pixels and what each shows.
    let expected: Vec<(usize, V3)> = (0..24 * 24)
        .filter_map(|i| {
            let (x, y) = (
                ((i % 24) as f64 - 11.5) * 2.5 / 24.0,
                (11.5 - (i / 24) as f64) * 2.5 / 24.0,
            );
            let n = [x, y, (1.0 - x * x - y * y).max(0.0).sqrt()];
            (x * x + y * y <= 0.8 * 0.8).then(|| (i, cosine_convolution(&map, 30.0, tint, n, 200)))
        })
        .collect();
    assert!(expected.len() > 150, "{}", expected.len());
    for strategy in [LightSampling::Mis, LightSampling::Cone, LightSampling::None] {
        let mut s = furnace(1.0, &env);
        s.render.light_sampling = strategy;
        s.render.samples = 512;
        let film = render(&s);
        for &(i, expected) in &expected {
            let (p, v) = (film.mean[i], film.variance[i]);
            for ch in 0..3 {
                let (got, se) = (p[ch] as f64, (v[ch] as f64).sqrt());
                assert!(
                    (got - expected[ch]).abs() <= 5.0 * se + 5e-3 * expected[ch],
                    "{}: pixel {i}, channel {ch}: {got} vs {} (se {se})",
                    strategy_name(strategy),
                    expected[ch]
                );
            }
        }
    }
    // A constant map: the sphere vanishes.
    let mut constant = map.clone();
    constant
        .texels
        .iter_mut()
        .for_each(|t| *t = [0.8, 0.8, 0.8]);
    let path = dir.path().join("grey.exr");
    write_exr(&constant, &path);
    let film = render(&furnace(
        1.0,
        &format!("[environment]\nmap = \"{}\"", path.display()),
    ));
    for (i, (p, v)) in film.mean.iter().zip(&film.variance).enumerate() {
        let se = (v[1] as f64).sqrt();
        assert!(
            (p[1] as f64 - 0.8).abs() <= 5.0 * se + 1e-5,
            "pixel {i}: {} (se {se})",
            p[1]
        );
    }
}

/// MIS weights sum to one: every strategy renders the same image mean, in the Cornell box (lit by its
/// quad) and in scenes/envmap.toml (lit by a map; mirror and glass make its caustics noisy, so few
/// bounces).
#[test]
fn every_strategy_renders_the_same_image_mean() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut cbox = vkpath::Scene::load(&root.join("cornell-box.toml")).unwrap();
    cbox.image.width = 24;
    cbox.image.height = 24;
    cbox.render.samples = 128;
    cbox.render.max_bounces = 3;
    assert_strategies_agree(&cbox, &ALL);
    let mut env = vkpath::Scene::load(&root.join("envmap.toml")).unwrap();
    env.image.width = 24;
    env.image.height = 16;
    env.render.samples = 128;
    env.render.max_bounces = 2;
    assert_strategies_agree(
        &env,
        &[LightSampling::Mis, LightSampling::Cone, LightSampling::None],
    );
}

#[test]
fn polygon_irradiance_formula_checks_out() {
    // A disc-like check: directly under a small square of side s at height h, E ~ le s^2 / h^2.
    let (s, h) = (0.01f64, 1.0f64);
    let sq = [
        [-s / 2.0, h, -s / 2.0],
        [s / 2.0, h, -s / 2.0],
        [s / 2.0, h, s / 2.0],
        [-s / 2.0, h, s / 2.0],
    ];
    let e = polygon_irradiance([0.0; 3], [0.0, 1.0, 0.0], &sq, 1.0);
    assert!((e / (s * s / (h * h)) - 1.0).abs() < 1e-4, "{e}");
    // An infinite plane (a huge square) gives E = pi le.
    let big = 1e6;
    let sq = [
        [-big, h, -big],
        [big, h, -big],
        [big, h, big],
        [-big, h, big],
    ];
    let e = polygon_irradiance([0.0; 3], [0.0, 1.0, 0.0], &sq, 1.0);
    assert!((e / PI - 1.0).abs() < 1e-5, "{e}");
}

/// A spot light (Mitsuba's falloff: full intensity to the beam angle, linear in the angle to zero at the
/// cutoff) above a diffuse floor, seen straight down by an orthographic camera through pixel centres:
/// each floor pixel reflects a/pi E with E = I f(theta) cos(theta) / r^2, I = power / Omega and Omega
/// the falloff's solid angle, integrated here by quadrature (independently of the closed form the
/// renderer uses). A delta light and max_bounces 1: one sample per pixel is exact up to rounding.
/// Given by its on-axis `intensity` instead, the same image.
#[test]
fn a_spot_light_lights_the_floor_by_its_falloff_and_power() {
    spot_floor(false);
}

/// The same with glTF's smooth falloff (`falloff = "smooth"`, KHR_lights_punctual's recommended form):
/// f = t^2, t = clamp((cos theta - cos c) / (cos b - cos c), 0, 1).
#[test]
fn a_smooth_spot_light_lights_the_floor_by_the_gltf_falloff() {
    spot_floor(true);
}

fn spot_floor(smooth: bool) {
    let (a, h, power, cutoff, beam) = (0.5f64, 2.0f64, 30.0f64, 40.0f64, 25.0f64);
    let falloff = |t: f64| {
        let (c, b) = (cutoff.to_radians(), beam.to_radians());
        if smooth {
            let x = ((t.cos() - c.cos()) / (b.cos() - c.cos())).clamp(0.0, 1.0);
            x * x
        } else if t >= c {
            0.0
        } else if t <= b {
            1.0
        } else {
            (c - t) / (c - b)
        }
    };
    // Omega = 2 pi integral_0^pi f(t) sin t dt, midpoint rule.
    let n = 200_000;
    let dt = PI / n as f64;
    let omega: f64 = (0..n)
        .map(|k| {
            let t = (k as f64 + 0.5) * dt;
            falloff(t) * t.sin() * dt
        })
        .sum::<f64>()
        * 2.0
        * PI;
    let intensity = power / omega;
    let size = 48u32;
    let head = format!(
        r#"
[camera]
type = "orthographic"
position = [0.0, 10.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
extent = 4.0
[image]
width = {size}
height = {size}
[render]
samples = 1
max_bounces = 1
filter = "none"
[materials]
grey = {{ type = "diffuse", albedo = [{a}, {a}, {a}] }}
[[triangle]]
vertices = [[-50.0, 0.0, -50.0], [50.0, 0.0, 50.0], [50.0, 0.0, -50.0]]
material = "grey"
[[triangle]]
vertices = [[-50.0, 0.0, -50.0], [-50.0, 0.0, 50.0], [50.0, 0.0, 50.0]]
material = "grey"
[[light]]
type = "spot"
position = [0.0, {h}, 0.0]
look_at = [0.0, 0.0, 0.0]
cutoff_angle = {cutoff}
beam_width = {beam}
falloff = "{}"
"#,
        if smooth { "smooth" } else { "linear" }
    );
    let by_power = render(&scene(&format!("{head}power = {power}\n")));
    let by_intensity = render(&scene(&format!("{head}intensity = {intensity}\n")));
    let (mut lit, mut dark, mut worst) = (0, 0, 0.0f64);
    for py in 0..size {
        for px in 0..size {
            let x = (2.0 * (px as f64 + 0.5) / size as f64 - 1.0) * 2.0;
            let z = -(1.0 - 2.0 * (py as f64 + 0.5) / size as f64) * 2.0;
            let r = (x * x + z * z + h * h).sqrt();
            let theta = (h / r).acos();
            let expected = a / PI * intensity * falloff(theta) * (h / r) / (r * r);
            for film in [&by_power, &by_intensity] {
                let got = film.pixel(px, py)[0] as f64;
                if expected == 0.0 {
                    assert_eq!(got, 0.0, "pixel ({px},{py}) outside the cone");
                    dark += 1;
                } else {
                    // The shading point is where the ray hit, within the floor's rounding bound (its
                    // vertices at +-50: ~1e-5), which moves theta by ~1e-6 rad and f by ~1e-5 where
                    // f falls: 1e-4 of the unattenuated value allows for it.
                    let full = a / PI * intensity * (h / r) / (r * r);
                    let err = (got - expected).abs() / expected;
                    assert!(
                        (got - expected).abs() <= 1e-3 * expected + 1e-4 * full,
                        "pixel ({px},{py}) at ({x}, {z}): {got} vs {expected}"
                    );
                    worst = worst.max(err);
                    lit += 1;
                }
            }
        }
    }
    println!(
        "spot (smooth: {smooth}): {lit} lit and {dark} dark pixel checks, worst relative error {worst:.2e}"
    );
    assert!(lit > 800 && dark > 800, "{lit} lit, {dark} dark");
}
