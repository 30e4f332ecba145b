//! Glossy materials through the whole renderer (tests/shader_glossy.rs tests them one bounce at a time).
//!
//! * A rough dielectric of ior 1 in front of a scene leaves its image unchanged (within noise).
//! * A convex white-furnace ball: a conductor whose Fresnel is 1 under a uniform environment of radiance
//!   1 shows, in every pixel it covers, the GGX albedo at that pixel's viewing angle, never more than 1;
//!   a smooth white plastic ball vanishes (it reflects all the light at every angle).

mod common;

use common::{mean_and_se, scene};

const FURNACE: &str = r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at  = [0.0, 0.0, 0.0]
fov      = 40.0
[image]
width  = 48
height = 48
[render]
samples     = 256
max_bounces = 8
filter      = "box"
[environment]
radiance = [1.0, 1.0, 1.0]
"#;

/// A diffuse ball of albedo 0.5 seen through a rough ball of ior 1 (in front of it, half its size)
/// renders like the diffuse ball alone.
#[test]
fn rough_dielectric_of_ior_one_is_invisible() {
    let base = format!(
        "{FURNACE}[materials]\nclay = {{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }}\n\
         ghost = {{ type = \"dielectric\", ior = 1.0, roughness = 0.6 }}\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"clay\"\n"
    );
    let with_ghost =
        format!("{base}[[sphere]]\ncenter = [0.3, 0.2, 1.8]\nradius = 0.5\nmaterial = \"ghost\"\n");
    let (a, sa) = mean_and_se(&common::render(&scene(&base)));
    let (b, sb) = mean_and_se(&common::render(&scene(&with_ghost)));
    let se = (sa * sa + sb * sb).sqrt();
    println!("without {a:.5} +- {sa:.1e}, with the ior-1 ball {b:.5} +- {sb:.1e}");
    assert!(
        (a - b).abs() <= 4.0 * se,
        "{a} vs {b}: {} > 4 x {se}",
        (a - b).abs()
    );
}

/// Under a uniform environment of radiance 1, a smooth white plastic ball reflects all the light: every
/// pixel is 1 within noise (the image mean within 4 standard errors of 1, no pixel beyond 6 of its own).
/// A white conductor (Schlick, base colour 1) of roughness 1 loses what single-scattering GGX loses:
/// darker than 1 where it covers the image, never brighter.
#[test]
fn white_furnace_balls() {
    let plastic = format!(
        "{FURNACE}[materials]\nwhite = {{ type = \"plastic\", albedo = [1.0, 1.0, 1.0], ior = 1.5 }}\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"white\"\n"
    );
    let film = common::render(&scene(&plastic));
    let (m, se) = mean_and_se(&film);
    println!("smooth white plastic: image mean {m:.5} +- {se:.1e}");
    assert!(
        (m - 1.0).abs() <= 4.0 * se,
        "plastic furnace mean {m} +- {se}"
    );
    for (p, v) in film.mean.iter().zip(&film.variance) {
        let sd = (v[1] as f64).sqrt();
        assert!(
            (p[1] as f64 - 1.0).abs() <= 6.0 * sd + 1e-4,
            "pixel {p:?} +- {sd}"
        );
    }
    let metal = format!(
        "{FURNACE}[materials]\nwhite = {{ type = \"conductor\", base_color = [1.0, 1.0, 1.0], roughness = 1.0 }}\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"white\"\n"
    );
    let film = common::render(&scene(&metal));
    let (m, se) = mean_and_se(&film);
    println!("white conductor, roughness 1: image mean {m:.5} +- {se:.1e}");
    assert!(
        m < 1.0 - 10.0 * se,
        "a rough conductor loses energy: mean {m} +- {se}"
    );
    for (p, v) in film.mean.iter().zip(&film.variance) {
        let sd = (v[1] as f64).sqrt();
        assert!(
            p[1] as f64 <= 1.0 + 6.0 * sd + 1e-4,
            "brighter than the furnace: {p:?} +- {sd}"
        );
    }
}
