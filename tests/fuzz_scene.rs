//! Fuzzing the scene parser and the OBJ loader (proptest, a bounded number of cases so that it runs in
//! CI in a few seconds): arbitrary bytes, and mutations of valid scene files and OBJ files. For every
//! input: no panic, no hang (each case runs under a watchdog), and either a valid result (the invariants
//! the renderer relies on hold) or an error value whose message is one paragraph.
//!
//! The case counts below are the defaults; `PROPTEST_CASES=N` runs N cases per target instead, and
//! `PROPTEST_RNG_SEED=S` another seed (the default seed is fixed, so CI runs are reproducible).

mod common;

use common::fuzz::{EXTREMES, JSON_STRUCTURE, apply, config, mutation, within_watchdog};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Duration;
use vkpath::Scene;
use vkpath::scene::mesh::ObjMesh;
use vkpath::scene::obj::parse_obj;
use vkpath::scene::ply::parse_ply;

// ---------------------------------------------------------------------------------------------------
// Seeds: valid inputs to mutate
// ---------------------------------------------------------------------------------------------------

/// Every key of the format, a mesh among them.
const EVERY_KEY: &str = r#"[camera]
position       = [0.0, 0.0, 55.0]
look_at        = [0.0, 0.0, 0.0]
up             = [0.0, 1.0, 0.0]
fov            = 60.0
aperture       = 0.5
focus_distance = 55.0

[image]
width    = 64
height   = 48
exposure = 1.5
gamma    = "srgb"

[render]
samples      = 4
max_bounces  = 5
seed         = 3
filter       = "box"
filter_sigma = 0.5
background   = [0.1, 0.2, 0.3]

[materials]
white  = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
mirror = { type = "mirror", tint = [1.0, 0.9, 0.8] }
glass  = { type = "dielectric", ior = 1.5 }
lamp   = { type = "emitter", radiance = [4.0, 3.0, 2.0], two_sided = true }
panel  = { type = "diffuse", albedo = [0.5, 0.5, 0.5], emission = [1.0, 1.0, 1.0], two_sided_emission = false }

[[sphere]]
center   = [20.0, 20.0, 0.0]
radius   = 1.0
material = "lamp"

[[triangle]]
vertices = [[-5.0, 15.0, -20.0], [5.0, 15.0, -20.0], [0.0, 20.0, -20.0]]
material = "panel"

[[sphere]]
center   = [0.0, 0.0, 0.0]
radius   = 10.0
material = "white"

[[triangle]]
vertices = [[-5.0, -5.0, -20.0], [5.0, -5.0, -20.0], [0.0, 5.0, -20.0]]
material = "mirror"

[[mesh]]
obj       = "cube.obj"
material  = "glass"
scale     = 2.0
rotate    = [0.0, 45.0, 0.0]
translate = [0.0, 3.0, 0.0]
smooth    = false

[[light]]
type     = "point"
position = [-10.0, 20.0, 40.0]
power    = 37699.1
color    = [1.0, 1.0, 1.0]

[[light]]
type   = "sphere"
center = [10.0, 20.0, 40.0]
radius = 5.0
power  = 37699.1
"#;

/// A unit cube with uvs and normals, quads and a negative (relative) index.
const CUBE_OBJ: &str = "# cube
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
f 1/1/1 4/4/1 3/3/1 2/2/1
f 5/1/2 6/2/2 7/3/2 8/4/2
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f -8 -4 -1 -5
";

fn scene_seeds() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut seeds = vec![EVERY_KEY.to_string()];
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("scenes/")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    for f in files {
        seeds.push(std::fs::read_to_string(f).expect("scene"));
    }
    seeds
}

// ---------------------------------------------------------------------------------------------------
// Mutations
// ---------------------------------------------------------------------------------------------------

/// Fragments that stress a TOML scene parser: structure, quoting, extreme and non-finite numbers, huge
/// integers, every table and key name, and the unusual characters TOML allows.
const TOKENS: &[&str] = &[
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    ",",
    "\"",
    "'",
    "'''",
    "\"\"\"",
    "#",
    "\n",
    "\r\n",
    "\t",
    ".",
    "\\",
    "\\u0000",
    "\u{0}",
    "\u{feff}",
    "é",
    "🦀",
    "nan",
    "-nan",
    "inf",
    "+inf",
    "-inf",
    "1e39",
    "-1e39",
    "1e-46",
    "-0.0",
    "0",
    "-1",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "99999999999999999999999",
    "0x10",
    "1_000",
    "1979-05-27T07:32:00Z",
    "true",
    "[camera]",
    "[image]",
    "[render]",
    "[materials]",
    "[[sphere]]",
    "[[triangle]]",
    "[[mesh]]",
    "[[light]]",
    "width = 65536",
    "height = 65537",
    "width = 0",
    "samples = 0",
    "fov = 180",
    "radius = 0",
    "type = \"sphere\"",
    "type = \"point\"",
    "type = \"unknown\"",
    "material = \"nope\"",
    "obj = \"cube.obj\"",
    "obj = \"missing.obj\"",
    "obj = \"/\"",
    "obj = \"\"",
    "texture = \"cube.obj\"",
    "gamma = \"srgb\"",
    "gamma = -1",
    "ior = 0",
    "albedo = [2, 0, 0]",
    "[0.0, 0.0]",
    "[0.0, 0.0, 0.0, 0.0]",
    "[[1,2,3]]",
    "center = [0, 0, 0]",
    "vertices = [[0,0,0],[0,0,0],[0,0,0]]",
    "a.b.c = 1",
    "x = { y = { z = 1 } }",
];

// ---------------------------------------------------------------------------------------------------
// What every answer must satisfy
// ---------------------------------------------------------------------------------------------------

fn finite(v: glam::Vec3) -> bool {
    v.is_finite()
}

/// A scene the parser accepted holds the invariants the renderer relies on; a refusal is one paragraph
/// that names the file.
fn check_scene_answer(result: Result<Scene, vkpath::scene::SceneError>, file: &str) {
    match result {
        Ok(s) => {
            let (w, h) = (u64::from(s.image.width), u64::from(s.image.height));
            assert!((1..=65536).contains(&w) && (1..=65536).contains(&h) && w * h <= 1 << 28);
            assert!(s.render.samples >= 1);
            let c = &s.camera;
            assert!(finite(c.position) && finite(c.look_at) && finite(c.up));
            assert!(c.position != c.look_at);
            assert!(c.fov_deg > 0.0 && c.fov_deg < 180.0);
            assert!(c.aperture >= 0.0 && c.focus_distance > 0.0 && c.focus_distance.is_finite());
            let m = s.materials.len() as u32;
            for sp in &s.spheres {
                assert!(finite(sp.center) && sp.radius > 0.0 && sp.radius.is_finite());
                assert!(sp.material < m);
            }
            for t in &s.triangles {
                assert!(t.vertices.iter().all(|v| finite(*v)) && t.material < m);
            }
            for mesh in &s.meshes {
                assert!(mesh.material < m);
                let nv = mesh.positions.len() as u32;
                assert!(mesh.triangles.iter().flatten().all(|&i| i < nv));
                assert!(mesh.positions.iter().all(|p| finite(*p)));
            }
            for l in &s.lights {
                match *l {
                    vkpath::scene::Light::Point {
                        position,
                        power,
                        color,
                    } => {
                        assert!(
                            finite(position) && power > 0.0 && power.is_finite() && finite(color)
                        );
                    }
                    vkpath::scene::Light::Sphere {
                        center,
                        radius,
                        power,
                        color,
                    } => {
                        assert!(finite(center) && radius > 0.0 && power > 0.0 && finite(color));
                    }
                    vkpath::scene::Light::Spot {
                        position,
                        axis,
                        intensity,
                        color,
                        cutoff_deg,
                        beam_deg,
                        falloff,
                    } => {
                        assert!(finite(position) && finite(axis) && finite(color));
                        assert!((axis.length() - 1.0).abs() < 1e-5);
                        assert!(intensity > 0.0 && intensity.is_finite());
                        let smooth = falloff == vkpath::scene::SpotFalloff::Smooth;
                        assert!(
                            (0.0 < beam_deg || (smooth && beam_deg == 0.0))
                                && beam_deg <= cutoff_deg
                                && cutoff_deg <= 90.0
                        );
                    }
                    vkpath::scene::Light::Directional {
                        direction,
                        irradiance,
                        color,
                        angle_deg,
                    } => {
                        assert!((direction.length() - 1.0).abs() < 1e-5, "{direction}");
                        assert!(irradiance > 0.0 && irradiance.is_finite() && finite(color));
                        assert!((0.0..180.0).contains(&angle_deg));
                    }
                }
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(
                !msg.contains('\n'),
                "a refusal must be one paragraph: {msg:?}"
            );
            assert!(msg.starts_with(file), "a refusal names the file: {msg:?}");
        }
    }
}

/// An OBJ the loader accepted is consistent: indices in range, per-vertex arrays of the right length,
/// finite coordinates. A refusal is one paragraph.
fn check_obj_answer(result: Result<ObjMesh, vkpath::scene::mesh::ObjError>) {
    match result {
        Ok(m) => {
            let nv = m.positions.len();
            assert!(!m.triangles.is_empty());
            assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < nv));
            assert!(m.positions.iter().all(|p| finite(*p)));
            if let Some(n) = &m.normals {
                assert_eq!(n.len(), nv);
            }
            if let Some(uv) = &m.uvs {
                assert_eq!(uv.len(), nv);
            }
        }
        Err(e) => assert!(!e.message.contains('\n'), "one paragraph: {:?}", e.message),
    }
}

/// Parses `bytes` as a scene file on disk (so that `[[mesh]]` tables find `cube.obj` beside it, and
/// invalid UTF-8 reaches the reader), under the watchdog.
fn parse_scene_file(dir: &Path, bytes: Vec<u8>) {
    let path = dir.join("scene.toml");
    std::fs::write(&path, &bytes).unwrap();
    let file = path.display().to_string();
    let result = within_watchdog("Scene::load", move || Scene::load(&path));
    check_scene_answer(result, &file);
}

/// A directory for mutated scenes: `cube.obj` for EVERY_KEY, and `models/` and `maps/` pointing at
/// scenes/models and scenes/maps so that the shipped scenes find their OBJ files and environment maps as
/// they do beside their own file.
fn scene_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    for sub in ["models", "maps"] {
        let target = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(sub);
        #[cfg(unix)]
        if target.is_dir() {
            std::os::unix::fs::symlink(&target, dir.path().join(sub)).unwrap();
        }
    }
    dir
}

#[test]
fn the_seeds_are_valid() {
    let dir = scene_dir();
    for (i, s) in scene_seeds().iter().enumerate() {
        let path = dir.path().join("seed.toml");
        std::fs::write(&path, s).unwrap();
        Scene::load(&path).unwrap_or_else(|e| panic!("seed scene {i} is invalid: {e}"));
    }
    parse_obj(CUBE_OBJ.as_bytes()).expect("the cube is valid");
    let square = parse_ply(SQUARE_PLY.as_bytes()).expect("the PLY square is valid");
    assert_eq!(square.triangles.len(), 3);
}

proptest! {
    #![proptest_config(config(1500))]

    /// Arbitrary bytes as a scene file: refused with an error value, never a panic or a hang.
    #[test]
    fn scene_parser_survives_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let result = within_watchdog("Scene::from_toml_str", move || Scene::from_toml_str(&text, None));
        check_scene_answer(result, "<default scene>");
    }

    /// Arbitrary TOML-ish token soup: reaches deeper into the parser than raw bytes.
    #[test]
    fn scene_parser_survives_token_soup(picks in proptest::collection::vec(0..TOKENS.len(), 0..60)) {
        let text: String = picks.iter().map(|&i| TOKENS[i]).collect::<Vec<_>>().join(" ");
        let result = within_watchdog("Scene::from_toml_str", move || Scene::from_toml_str(&text, None));
        check_scene_answer(result, "<default scene>");
    }
}

proptest! {
    #![proptest_config(config(2500))]

    /// Valid scenes (every file in scenes/ and one with every key and a mesh), mutated 1 to 6 times:
    /// accepted with the invariants intact, or refused with a one-paragraph error.
    #[test]
    fn scene_parser_survives_mutated_scenes(
        seed in any::<prop::sample::Index>(),
        mutations in proptest::collection::vec(mutation(), 1..7),
    ) {
        let seeds = scene_seeds();
        let mut bytes = seeds[seed.index(seeds.len())].clone().into_bytes();
        for m in &mutations {
            apply(&mut bytes, m, TOKENS, EXTREMES);
        }
        let dir = scene_dir();
        parse_scene_file(dir.path(), bytes);
    }
}

/// OBJ fragments: statements, index forms, extreme numbers.
const OBJ_TOKENS: &[&str] = &[
    "v",
    "vt",
    "vn",
    "f",
    "l",
    "p",
    "o",
    "g",
    "s",
    "usemtl",
    "mtllib",
    " ",
    "\n",
    "\r\n",
    "#",
    "/",
    "//",
    "1",
    "-1",
    "0",
    "3",
    "-9",
    "99999999999",
    "4294967296",
    "1e39",
    "nan",
    "inf",
    "-inf",
    "1.5",
    "1/1",
    "1//1",
    "1/1/1",
    "-1/-1/-1",
    "0/0/0",
    "\\\n",
    "\u{0}",
    "é",
];

proptest! {
    #![proptest_config(config(1500))]

    /// Arbitrary bytes as an OBJ file.
    #[test]
    fn obj_loader_survives_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let result = within_watchdog("parse_obj", move || parse_obj(&bytes));
        check_obj_answer(result);
    }

    /// A valid OBJ (quads, uvs, normals, a negative index), mutated 1 to 6 times.
    #[test]
    fn obj_loader_survives_mutated_objs(mutations in proptest::collection::vec(mutation(), 1..7)) {
        let mut bytes = CUBE_OBJ.as_bytes().to_vec();
        for m in &mutations {
            apply(&mut bytes, m, OBJ_TOKENS, EXTREMES);
        }
        let result = within_watchdog("parse_obj", move || parse_obj(&bytes));
        check_obj_answer(result);
    }
}

/// A valid ASCII PLY (a quad and a triangle, normals, uvs, a skipped property) for the PLY fuzzers.
const SQUARE_PLY: &str = "ply\nformat ascii 1.0\ncomment fuzz seed\nelement vertex 5\nproperty float x\n\
    property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
    property uchar red\nproperty float u\nproperty float v\nelement face 2\n\
    property list uchar int vertex_indices\nend_header\n0 0 0 0 0 1 9 0 0\n1 0 0 0 0 1 9 1 0\n\
    1 1 0 0 0 1 9 1 1\n0 1 0 0 0 1 9 0 1\n2 2 0 0 0 1 9 1 1\n4 0 1 2 3\n3 1 4 2\n";

const PLY_TOKENS: &[&str] = &[
    "ply",
    "format",
    "ascii",
    "binary_little_endian",
    "binary_big_endian",
    "1.0",
    "element",
    "vertex",
    "face",
    "property",
    "list",
    "uchar",
    "int",
    "float",
    "double",
    "x",
    "y",
    "z",
    "nx",
    "u",
    "v",
    "vertex_indices",
    "end_header",
    "\n",
    " ",
    "0",
    "1",
    "-1",
    "3",
    "4",
    "255",
    "65536",
    "4294967295",
];

proptest! {
    #![proptest_config(config(1500))]

    /// Arbitrary bytes after a PLY magic line (binary bodies see every byte pattern).
    #[test]
    fn ply_loader_survives_arbitrary_bytes(
        binary in any::<bool>(),
        bytes in proptest::collection::vec(any::<u8>(), 0..600),
    ) {
        let head = if binary {
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        } else {
            "ply\n"
        };
        let input = [head.as_bytes(), &bytes].concat();
        let result = within_watchdog("parse_ply", move || parse_ply(&input));
        check_obj_answer(result);
    }

    /// The valid PLY, mutated 1 to 6 times.
    #[test]
    fn ply_loader_survives_mutated_plys(mutations in proptest::collection::vec(mutation(), 1..7)) {
        let mut bytes = SQUARE_PLY.as_bytes().to_vec();
        for m in &mutations {
            apply(&mut bytes, m, PLY_TOKENS, EXTREMES);
        }
        let result = within_watchdog("parse_ply", move || parse_ply(&bytes));
        check_obj_answer(result);
    }
}

/// Huge counts are refused before anything is allocated for them, with the limit named: a scene file
/// larger than the limit is not even read (10^8 spheres would be a file of several GB), a 10^9-pixel
/// image is refused by the parser.
#[test]
fn huge_inputs_are_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let e = Scene::from_toml_str(
        "[camera]\nposition=[0,0,1]\nlook_at=[0,0,0]\nfov=60\n[image]\nwidth=40000\nheight=25000\n",
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("2^28"), "{e}");
    // A sparse file: as large as 10^8 spheres would take, without writing them.
    let path = dir.path().join("huge.toml");
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(100_000_000 * 60).unwrap();
    drop(f);
    let start = std::time::Instant::now();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        start.elapsed() < Duration::from_secs(2),
        "the file was read"
    );
    assert!(e.contains("MiB") && e.contains("limit"), "{e}");
}

/// A valid checkpoint file's bytes (3x2 pixels, two sample ranges, with the denoiser's aux images),
/// built without a GPU.
fn checkpoint_bytes() -> Vec<u8> {
    use vkpath::checkpoint::{Aux, Checkpoint, Display, Header, Identity};
    let c = Checkpoint {
        header: Header {
            identity: Identity {
                vkpath_version: vkpath::VKPATH_VERSION.into(),
                scene_hash: "0123456789abcdef".into(),
                width: 3,
                height: 2,
                seed: 1,
                max_bounces: 5,
                roulette_depth: 3,
                sampler: "independent".into(),
                light_sampling: "mis".into(),
            },
            scene: "fuzz".into(),
            device: "none".into(),
            ranges: vec![[0, 4], [8, 12]],
            display: Display {
                exposure: 1.0,
                gamma: None,
                tonemap: vkpath::scene::Tonemap::Aces,
                denoise: true,
            },
            part: None,
            aux_samples: Some(4),
            splat: true,
            adaptive: true,
        },
        accum: vec![vkpath::kernel::abi::GpuAccum::default(); 6],
        aux: Some(Aux {
            albedo: vec![[0.5, 0.25, 1.0]; 6],
            normal: vec![[0.0, 0.0, 1.0]; 6],
        }),
        splat: Some(vec![
            vkpath::kernel::abi::GpuSplatAccum {
                sum: [7; 18],
                weight: [3, 1],
            };
            6
        ]),
        adaptive: Some(vec![[8, 1], [8, 0], [4, 0], [8, 1], [0, 0], [8, 1]]),
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.ckpt");
    c.write(&path).unwrap();
    std::fs::read(path).unwrap()
}

/// Fragments of a checkpoint header: JSON structure and the values its checks are about.
/// (With [`common::fuzz::JSON_STRUCTURE`].)
const CHECKPOINT_TOKENS: &[&str] = &[
    "true",
    "-1",
    "0",
    "4294967295",
    "4294967296",
    "1e999",
    "\"ranges\":[[5,1]]",
    "\"ranges\":[]",
    "\"width\":0",
    "\"aux_samples\":4",
    "\"height\":99999999",
    "\u{0}",
    "VKPATHCP",
];

proptest! {
    #![proptest_config(config(1000))]

    /// Checkpoint files (the `--resume` and `vkpath merge` inputs): arbitrary bytes and a valid file
    /// mutated 1 to 6 times are decoded into a consistent state or refused with an error value.
    #[test]
    fn checkpoint_decoder_survives_mutated_files(
        arbitrary in proptest::collection::vec(any::<u8>(), 0..300),
        mutations in proptest::collection::vec(mutation(), 1..7),
    ) {
        let mut bytes = checkpoint_bytes();
        for m in &mutations {
            apply(&mut bytes, m, &[JSON_STRUCTURE, CHECKPOINT_TOKENS].concat(), EXTREMES);
        }
        for input in [arbitrary, bytes] {
            let result = within_watchdog("Checkpoint::from_bytes", move || {
                vkpath::checkpoint::Checkpoint::from_bytes(&input)
            });
            if let Ok(c) = result {
                let id = &c.header.identity;
                prop_assert_eq!(c.accum.len(), id.width as usize * id.height as usize);
                prop_assert!(c.samples() >= 1);
            }
        }
    }
}
