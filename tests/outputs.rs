//! What a render writes (issue 18): the EXR's `--aov` layers against analytic values, the metadata in
//! EXR attributes and PNG text chunks, the PNG's transfer-curve chunk, and `vkpath compare`.
//!
//! The AOV scene is orthographic with the pixel filter "none", so that every sample of a pixel follows the
//! ray through the pixel's centre and each layer can be computed in f64 here: a diffuse ball of radius 2
//! at (1, 0.5, 0) in front of a diffuse wall at z = -3, seen from the plane z = 10 looking down -z.

mod common;

use common::cli::{run, run_ok};
use std::path::Path;

const SCENE: &str = r#"
[camera]
type = "orthographic"
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
extent = 8.0

[image]
width = 32
height = 24
gamma = "srgb"

[render]
samples = 4
filter = "none"
max_bounces = 3

[materials]
wall = { type = "diffuse", albedo = [0.25, 0.5, 0.75] }
ball = { type = "diffuse", albedo = [0.8, 0.1, 0.2] }

[[sphere]]
center = [1.0, 0.5, 0.0]
radius = 2.0
material = "ball"

[[triangle]]
vertices = [[-10.0, -10.0, -3.0], [10.0, -10.0, -3.0], [10.0, 10.0, -3.0]]
material = "wall"

[[triangle]]
vertices = [[-10.0, -10.0, -3.0], [10.0, 10.0, -3.0], [-10.0, 10.0, -3.0]]
material = "wall"

[[light]]
type = "point"
position = [-3.0, 4.0, 8.0]
power = 2000.0
"#;

const W: usize = 32;
const H: usize = 24;

/// Every f32 channel of the EXR's first layer, by name.
fn exr_channels(path: &Path) -> (Vec<(String, Vec<f32>)>, exr::meta::header::LayerAttributes) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path).expect("a readable EXR");
    let layer = image.layer_data.into_iter().next().expect("one layer");
    let channels = layer
        .channel_data
        .list
        .into_iter()
        .map(|c| {
            let values = match c.sample_data {
                FlatSamples::F32(v) => v,
                other => panic!("{}: not f32: {other:?}", c.name),
            };
            (c.name.to_string(), values)
        })
        .collect();
    (channels, layer.attributes)
}

fn channel<'a>(channels: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
    &channels
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no channel {name}"))
        .1
}

/// What the camera ray through pixel (i, j)'s centre meets: Some((t, normal, albedo)) for the ball or the
/// wall, in f64, and whether it is clear of the ball's silhouette (where f32 and f64 may disagree).
fn analytic(i: usize, j: usize) -> (f64, [f64; 3], [f32; 3], bool) {
    let half = 4.0; // extent / 2
    let x = (i as f64 + 0.5 - W as f64 / 2.0) / (W as f64 / 2.0) * half;
    let y = (H as f64 / 2.0 - (j as f64 + 0.5)) / (W as f64 / 2.0) * half;
    let (cx, cy, r) = (1.0, 0.5, 2.0);
    let d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
    let clear = (d2 - r * r).abs() > 0.3;
    if d2 < r * r {
        let z = (r * r - d2).sqrt();
        let t = 10.0 - z;
        (
            t,
            [(x - cx) / r, (y - cy) / r, z / r],
            [0.8, 0.1, 0.2],
            clear,
        )
    } else {
        (13.0, [0.0, 0.0, 1.0], [0.25, 0.5, 0.75], clear)
    }
}

/// `--aov albedo,normal,variance,depth`: albedo is the surface's exactly (every sample meets the same
/// surface), the normal is the sphere's (p - c) / r or the wall's +z, depth the distance along the ray,
/// and the variance layer is the render's own (its checkpoint's film), bit for bit.
#[test]
fn aov_layers_hold_the_analytic_values() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("aov.toml"), SCENE).unwrap();
    run_ok(
        d,
        &[
            "render",
            "aov.toml",
            "--quiet",
            "-o",
            "out.exr",
            "--aov",
            "depth,albedo,normal,variance",
            "--checkpoint",
            "c.ckpt",
        ],
    );
    let (channels, _) = exr_channels(&d.join("out.exr"));
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "albedo.B",
            "albedo.G",
            "albedo.R",
            "depth.Z",
            "normal.X",
            "normal.Y",
            "normal.Z",
            "variance.B",
            "variance.G",
            "variance.R"
        ]
    );
    let albedo = ["albedo.R", "albedo.G", "albedo.B"].map(|n| channel(&channels, n));
    let normal = ["normal.X", "normal.Y", "normal.Z"].map(|n| channel(&channels, n));
    let depth = channel(&channels, "depth.Z");
    let (mut ball, mut wall, mut worst_n, mut worst_t) = (0, 0, 0f64, 0f64);
    for j in 0..H {
        for i in 0..W {
            let (t, n, a, clear) = analytic(i, j);
            if !clear {
                continue;
            }
            let p = j * W + i;
            if a[0] == 0.8 {
                ball += 1;
            } else {
                wall += 1;
            }
            for c in 0..3 {
                assert_eq!(albedo[c][p], a[c], "albedo at ({i}, {j}) channel {c}");
                let e = (f64::from(normal[c][p]) - n[c]).abs();
                assert!(
                    e < 1e-4,
                    "normal at ({i}, {j}): {:?}, expected {n:?}",
                    [normal[0][p], normal[1][p], normal[2][p]]
                );
                worst_n = worst_n.max(e);
            }
            worst_t = worst_t.max((f64::from(depth[p]) - t).abs() / t);
        }
    }
    assert!(
        ball > 50 && wall > 200,
        "{ball} ball and {wall} wall pixels"
    );
    assert!(worst_n < 1e-4, "normal off by {worst_n}");
    assert!(worst_t < 1e-5, "depth off by {worst_t} (relative)");

    // The variance layer is the render's own estimate, as its checkpoint gives it.
    let film = vkpath::checkpoint::Checkpoint::read(&d.join("c.ckpt"))
        .unwrap()
        .film();
    for (c, n) in ["variance.R", "variance.G", "variance.B"]
        .iter()
        .enumerate()
    {
        let layer = channel(&channels, n);
        for (p, v) in film.variance.iter().enumerate() {
            assert_eq!(layer[p].to_bits(), v[c].to_bits(), "{n} at pixel {p}");
        }
    }
    assert!(
        film.variance.iter().any(|v| v[0] > 0.0),
        "a noiseless image would not test the variance layer"
    );
}

/// A ray that meets nothing has depth +inf and albedo and normal 0; a mirror tints the albedo of what it
/// shows.
#[test]
fn aov_layers_of_misses_and_mirrors() {
    let scene = r#"
[camera]
type = "orthographic"
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
extent = 8.0
[image]
width = 8
height = 4
[render]
samples = 2
filter = "none"
[materials]
mirror = { type = "mirror", tint = [0.5, 0.25, 1.0] }
wall = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
[[triangle]]
vertices = [[0.0, -10.0, 0.0], [0.0, 10.0, 0.0], [10.0, 10.0, 10.0]]
material = "mirror"
[[triangle]]
vertices = [[0.0, -10.0, 0.0], [10.0, 10.0, 10.0], [10.0, -10.0, 10.0]]
material = "mirror"
[[triangle]]
vertices = [[-20.0, -10.0, -5.0], [-20.0, 10.0, -5.0], [-20.0, 10.0, 5.0]]
material = "wall"
[[triangle]]
vertices = [[-20.0, -10.0, -5.0], [-20.0, 10.0, 5.0], [-20.0, -10.0, 5.0]]
material = "wall"
"#;
    // The mirror (x > 0) is the plane z = x, at 45 degrees: it sends the rays (0, 0, -1) to (-1, 0, 0),
    // onto the wall at x = -20. Rays at x < 0 miss everything.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("m.toml"), scene).unwrap();
    run_ok(
        d,
        &[
            "render",
            "m.toml",
            "--quiet",
            "-o",
            "m.exr",
            "--aov",
            "albedo,normal,depth",
        ],
    );
    let (channels, _) = exr_channels(&d.join("m.exr"));
    // The generic kernel (compiled for each layer, as the specialised one is) traces the same layers,
    // bit for bit.
    run_ok(
        d,
        &[
            "render",
            "m.toml",
            "--quiet",
            "--generic",
            "-o",
            "g.exr",
            "--aov",
            "albedo,normal,depth",
        ],
    );
    let (generic, _) = exr_channels(&d.join("g.exr"));
    for ((n, a), (m, b)) in channels.iter().zip(&generic) {
        assert_eq!(n, m);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(b), "{n}: the generic kernel's layer differs");
    }
    let albedo = ["albedo.R", "albedo.G", "albedo.B"].map(|n| channel(&channels, n));
    let normal = ["normal.X", "normal.Y", "normal.Z"].map(|n| channel(&channels, n));
    let depth = channel(&channels, "depth.Z");
    for j in 0..4 {
        for i in 0..8 {
            let p = j * 8 + i;
            if i < 4 {
                assert_eq!(depth[p], f32::INFINITY, "depth of a miss at ({i}, {j})");
                for c in 0..3 {
                    assert_eq!(
                        (albedo[c][p], normal[c][p]),
                        (0.0, 0.0),
                        "miss at ({i}, {j})"
                    );
                }
            } else {
                // The wall seen in the mirror: its albedo times the tint, its normal (the triangles'
                // (v1 - v0) x (v2 - v0) is +x), and the depth of the mirror (the first surface).
                assert_eq!(
                    [albedo[0][p], albedo[1][p], albedo[2][p]],
                    [0.25, 0.125, 0.5]
                );
                let n = [normal[0][p], normal[1][p], normal[2][p]];
                assert!(
                    (n[0] - 1.0).abs() < 1e-6 && n[1].abs() < 1e-6 && n[2].abs() < 1e-6,
                    "{n:?}"
                );
                let x = (i as f32 + 0.5 - 4.0) / 4.0 * 4.0;
                assert!(
                    (depth[p] - (10.0 - x)).abs() < 1e-4,
                    "depth {} at x {x}",
                    depth[p]
                );
            }
        }
    }
}

/// The metadata: EXR header attributes and PNG iTXt chunks with the version, scene, content hash, spp,
/// seed, device and seconds; the PNG is tagged with its transfer curve (sRGB chunk for gamma "srgb", gAMA
/// 1/2.2 for the default power).
#[test]
fn images_carry_their_metadata_and_transfer_curve() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("aov.toml"), SCENE).unwrap();
    run_ok(
        d,
        &[
            "render",
            "aov.toml",
            "--quiet",
            "--seed",
            "7",
            "--spp",
            "3",
            "-o",
            "a.exr",
            "-o",
            "a.png",
            "--checkpoint",
            "a.ckpt",
        ],
    );
    let hash = vkpath::checkpoint::Checkpoint::read(&d.join("a.ckpt"))
        .unwrap()
        .header
        .identity
        .scene_hash;
    let (_, attributes) = exr_channels(&d.join("a.exr"));
    let text = |k: &str| match attributes.other.get(&exr::prelude::Text::from(k)) {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(text("vkpath:spp"), "3");
    assert_eq!(text("vkpath:seed"), "7");
    assert_eq!(text("vkpath:scene_hash"), hash);
    assert_eq!(text("vkpath:scene"), "aov.toml");
    assert_eq!(text("vkpath:version"), vkpath::VKPATH_VERSION.to_string());
    assert!(!text("vkpath:device").is_empty());
    match attributes
        .other
        .get(&exr::prelude::Text::from("vkpath:seconds"))
    {
        Some(exr::meta::attribute::AttributeValue::F64(s)) => assert!(*s > 0.0 && *s < 600.0),
        other => panic!("vkpath:seconds: {other:?}"),
    }

    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(d.join("a.png")).unwrap(),
    ));
    let reader = decoder.read_info().unwrap();
    let info = reader.info();
    assert!(info.srgb.is_some(), "no sRGB chunk for gamma \"srgb\"");
    let chunks: std::collections::HashMap<String, String> = info
        .utf8_text
        .iter()
        .map(|c| (c.keyword.clone(), c.get_text().unwrap()))
        .collect();
    assert_eq!(chunks["vkpath:spp"], "3");
    assert_eq!(chunks["vkpath:seed"], "7");
    assert_eq!(chunks["vkpath:scene_hash"], hash);
    assert!(chunks["Software"].starts_with("vkpath "));
    assert!(chunks["vkpath:seconds"].parse::<f64>().unwrap() > 0.0);

    // The default gamma, a power of 2.2: a gAMA chunk of 1/2.2 and no sRGB chunk.
    run_ok(
        d,
        &[
            "render", "--quiet", "--spp", "1", "--width", "8", "--height", "8", "-o", "g.png",
        ],
    );
    let reader = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(d.join("g.png")).unwrap(),
    ))
    .read_info()
    .unwrap();
    let info = reader.info();
    assert!(info.srgb.is_none());
    let gamma = info.gamma().expect("a gAMA chunk").into_value();
    assert!((gamma - 1.0 / 2.2).abs() < 1e-5, "gAMA {gamma}");
}

/// `vkpath compare`: exit 0 for the same pixels (two renders with one seed, whatever their metadata), 1
/// for different ones, 2 for images of different sizes; and `--aov` mistakes are refused (exit 2).
#[test]
fn compare_and_aov_flag_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let render = |out: &str, seed: &str| {
        run_ok(
            d,
            &[
                "render", "--quiet", "--spp", "2", "--width", "16", "--height", "12", "--seed",
                seed, "-o", out,
            ],
        );
    };
    render("a.exr", "1");
    render("b.exr", "1");
    render("c.exr", "2");
    assert_ne!(
        std::fs::read(d.join("a.exr")).unwrap(),
        std::fs::read(d.join("b.exr")).unwrap(),
        "the files differ (their seconds): the comparison must look at the pixels"
    );
    let same = run(d, &["compare", "a.exr", "b.exr"]);
    assert_eq!(same.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&same.stdout).contains("the same pixels"));
    let differ = run(d, &["compare", "--json", "a.exr", "c.exr"]);
    assert_eq!(differ.status.code(), Some(1));
    let j: serde_json::Value = serde_json::from_slice(&differ.stdout).unwrap();
    assert_eq!(j["identical"], false);
    assert!(j["differing_values"].as_u64().unwrap() > 0);
    run_ok(
        d,
        &[
            "render", "--quiet", "--spp", "1", "--width", "8", "--height", "8", "-o", "s.exr",
        ],
    );
    assert_eq!(
        run(d, &["compare", "a.exr", "s.exr"]).status.code(),
        Some(2)
    );
    for (args, word) in [
        (&["--aov", "albedo,shadow", "-o", "x.exr"][..], "shadow"),
        (&["--aov", "depth,depth", "-o", "x.exr"][..], "twice"),
        (&["--aov", "albedo", "-o", "x.png"][..], "-o OUT.exr"),
    ] {
        let out = run(d, &[&["render", "--spp", "1"][..], args].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("--aov") && stderr.contains(word),
            "{stderr}"
        );
    }
    assert!(!d.join("x.exr").exists() && !d.join("x.png").exists());
}
