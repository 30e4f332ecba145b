//! glTF 2.0 meshes (`[[mesh]] obj = "*.gltf"`): a small glTF written here (JSON, an external buffer and
//! a PNG), with a node hierarchy (a translated parent, a rotated and scaled child), a textured
//! metallic-roughness material and an emissive one with KHR_materials_emissive_strength.
//!
//! * Positions, normals and uvs after loading, against the node transforms worked out by hand.
//! * Materials: metallic_roughness with the factors, the emission times its strength, the base colour
//!   texture (oriented as glTF's: v = 0 is the image's top row).
//! * The image against the same scene written by hand as OBJ files and TOML materials: image means agree
//!   within noise.

mod common;

use glam::Vec3;
use std::path::Path;
use vkpath::scene::{Bsdf, Emission, Scene};

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn u32s(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The quad (primitive 0) and the triangle (primitive 1), in the mesh's local coordinates.
const QUAD: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
/// glTF uvs: v = 0 is the top of the image.
const QUAD_UV: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
const TRI: [[f32; 3]; 3] = [[3.0, 0.0, 0.0], [4.0, 0.0, 0.0], [3.0, 1.0, 0.0]];

/// Writes scene.gltf, mesh.bin and tex.png into `dir`.
fn write_gltf(dir: &Path) {
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>| {
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend(bytes);
    };
    push(f32s(QUAD.as_flattened())); // 0: quad positions
    push(f32s(&[0.0, 0.0, 1.0].repeat(4))); // 1: quad normals
    push(f32s(QUAD_UV.as_flattened())); // 2: quad uvs
    push(u32s(&[0, 1, 2, 0, 2, 3])); // 3: quad indices
    push(f32s(TRI.as_flattened())); // 4: triangle positions
    push(f32s(&[1.0, 0.0, 0.0].repeat(3))); // 5: triangle normals (along local x)
    push(u32s(&[0, 1, 2])); // 6: triangle indices
    std::fs::write(dir.join("mesh.bin"), &bin).unwrap();
    // 2 x 2: red, green on the top row; blue, white below.
    image::RgbImage::from_fn(2, 2, |x, y| match (x, y) {
        (0, 0) => image::Rgb([255, 0, 0]),
        (1, 0) => image::Rgb([0, 255, 0]),
        (0, 1) => image::Rgb([0, 0, 255]),
        _ => image::Rgb([255, 255, 255]),
    })
    .save(dir.join("tex.png"))
    .unwrap();
    let s45 = std::f32::consts::FRAC_1_SQRT_2;
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
    {{"type": "point", "color": [1, 0.5, 0.25], "intensity": 10}},
    {{"type": "directional", "intensity": 2}},
    {{"type": "spot", "spot": {{}}}}
  ]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 2, 3, 4, 5, 6]}}],
  "nodes": [
    {{"name": "parent", "translation": [1, 0, 0], "children": [1]}},
    {{"name": "child", "rotation": [0, 0, {s45}, {s45}], "scale": [2, 1, 1], "mesh": 0}},
    {{"name": "camera", "translation": [0.5, 1, 6], "camera": 0}},
    {{"name": "lamp", "translation": [0.5, 1, 3], "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}},
    {{"name": "sun", "rotation": [{s45}, 0, 0, {s45}], "extensions": {{"KHR_lights_punctual": {{"light": 1}}}}}},
    {{"name": "spot", "extensions": {{"KHR_lights_punctual": {{"light": 2}}}}}},
    {{"name": "side camera", "translation": [10, 0, 0], "rotation": [0, {s45}, 0, {s45}], "camera": 1}}
  ],
  "cameras": [
    {{"type": "perspective", "perspective": {{"yfov": 0.5, "aspectRatio": 2.0, "znear": 0.01}}}},
    {{"type": "orthographic", "orthographic": {{"xmag": 3, "ymag": 1.5, "znear": 0.01, "zfar": 100}}}}
  ],
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}},
    {{"attributes": {{"POSITION": 4, "NORMAL": 5, "TEXCOORD_0": 7}}, "indices": 6, "material": 1}}
  ]}}],
  "materials": [
    {{"name": "painted", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}},
      "metallicFactor": 0.0, "roughnessFactor": 0.8}}}},
    {{"name": "lamp", "pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1]}},
      "emissiveFactor": [1.0, 0.5, 0.25],
      "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4.0}}}}}}
  ],
  "textures": [{{"source": 0}}],
  "images": [{{"uri": "tex.png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 4, "componentType": 5126, "count": 3, "type": "VEC3", "min": [3, 0, 0], "max": [4, 1, 0]}},
    {{"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC3"}},
    {{"bufferView": 6, "componentType": 5125, "count": 3, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}}
  ],
  "bufferViews": [{}],
  "buffers": [{{"uri": "mesh.bin", "byteLength": {}}}]
}}"#,
        views.join(", "),
        bin.len()
    );
    std::fs::write(dir.join("scene.gltf"), json).unwrap();
}

/// World = T(1, 0, 0) R_z(90) S(2, 1, 1): (x, y, z) -> (1 - y, 2x, z). Normals by the inverse transpose,
/// R S^-1: local x -> (0, 1, 0).
fn world(p: [f32; 3]) -> Vec3 {
    Vec3::new(1.0 - p[1], 2.0 * p[0], p[2])
}

const HEAD: &str = "[camera]\nposition = [0.5, 1.0, 6.0]\nlook_at = [0.5, 1.0, 0.0]\nfov = 30\n\
    [image]\nwidth = 40\nheight = 40\n[render]\nsamples = 64\nmax_bounces = 1\nfilter = \"box\"\n\
    [environment]\nradiance = [1.0, 1.0, 1.0]\n";

fn load(dir: &Path, toml: &str) -> Scene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("scene should load: {e}"))
}

#[test]
fn a_gltf_mesh_loads_with_its_transforms_and_materials() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let scene = load(
        dir.path(),
        &format!("{HEAD}[[mesh]]\nobj = \"scene.gltf\"\n"),
    );
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.material_names, ["mesh[0]/painted", "mesh[0]/lamp"]);
    assert_eq!(
        scene.materials[0].bsdf,
        Bsdf::MetallicRoughness {
            base_color: Vec3::ONE,
            metallic: 0.0,
            roughness: 0.8
        }
    );
    assert_eq!(scene.materials[0].emission, None);
    assert_eq!(
        scene.materials[1].emission,
        Some(Emission {
            radiance: Vec3::new(4.0, 2.0, 1.0),
            two_sided: false
        })
    );
    let [quad, tri] = &scene.meshes[..] else {
        panic!("two meshes, one per primitive: {}", scene.meshes.len())
    };
    for (got, want) in quad.positions.iter().zip(QUAD.map(world)) {
        assert!((*got - want).length() < 1e-6, "{got} vs {want}");
    }
    for (got, want) in tri.positions.iter().zip(TRI.map(world)) {
        assert!((*got - want).length() < 1e-5, "{got} vs {want}");
    }
    for n in &tri.normals {
        assert!((*n - Vec3::Y).length() < 1e-6, "normal {n}");
    }
    // uvs flipped to v up: the first corner had glTF (0, 1), the image's bottom-left.
    assert_eq!(quad.uvs[0], [0.0, 0.0]);
    let t = quad.texture.as_ref().expect("the painted quad is textured");
    assert_eq!(t.texels[0].to_le_bytes()[..3], [255, 0, 0]);
    assert!(tri.texture.is_none());

    // The texture as glTF orients it, read at texel centres (the 2 x 2 texture repeats, so bilinear
    // filtering mixes all four texels near the quad's corners): uv (0.25, 0.25), the top-left texel
    // (red), is local (0.25, 0.75), world (0.25, 0.5); uv (0.75, 0.25) (green) is world (0.25, 1.5);
    // uv (0.25, 0.75) (blue) is world (0.75, 0.5). The camera looks down -z with +y up.
    let film = common::render(&scene);
    let at = |x: f32, y: f32| {
        // The camera sees [0.5 -+ w, 1 -+ w] with w = 6 tan(15 deg).
        let w = 6.0 * 15f32.to_radians().tan();
        let px = ((x - (0.5 - w)) / (2.0 * w) * 40.0) as usize;
        let py = (((1.0 + w) - y) / (2.0 * w) * 40.0) as usize;
        film.mean[py * 40 + px]
    };
    let dominant = |p: [f32; 3], c: usize| (0..3).all(|k| k == c || p[c] > 2.0 * p[k]);
    let (red, green, blue) = (at(0.25, 0.5), at(0.25, 1.5), at(0.75, 0.5));
    assert!(dominant(red, 0), "red expected: {red:?}");
    assert!(dominant(green, 1), "green expected: {green:?}");
    assert!(dominant(blue, 2), "blue expected: {blue:?}");
}

/// The same scene written by hand (world positions, v-up uvs, TOML materials) renders the same image, in
/// expectation: image means within 4 standard errors.
#[test]
fn a_gltf_mesh_renders_like_its_hand_written_equivalent() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let obj = |corners: &[Vec3], uvs: Option<&[[f32; 2]]>, n: Vec3, faces: &str| {
        let mut s = String::new();
        for p in corners {
            s += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        for uv in uvs.into_iter().flatten() {
            s += &format!("vt {} {}\n", uv[0], 1.0 - uv[1]);
        }
        s += &format!("vn {} {} {}\n", n.x, n.y, n.z);
        s + faces
    };
    std::fs::write(
        dir.path().join("quad.obj"),
        obj(
            &QUAD.map(world),
            Some(&QUAD_UV),
            Vec3::Z,
            "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n",
        ),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("tri.obj"),
        obj(&TRI.map(world), None, Vec3::Y, "f 1//1 2//1 3//1\n"),
    )
    .unwrap();
    let by_hand = load(
        dir.path(),
        &format!(
            "{HEAD}[materials]\n\
             painted = {{ type = \"metallic_roughness\", base_color = [1, 1, 1], metallic = 0.0, roughness = 0.8 }}\n\
             lamp = {{ type = \"metallic_roughness\", base_color = [0, 0, 0], metallic = 1.0, roughness = 1.0, emission = [4, 2, 1] }}\n\
             [[mesh]]\nobj = \"quad.obj\"\nmaterial = \"painted\"\ntexture = \"tex.png\"\n\
             [[mesh]]\nobj = \"tri.obj\"\nmaterial = \"lamp\"\n"
        ),
    );
    let from_gltf = load(
        dir.path(),
        &format!("{HEAD}[[mesh]]\nobj = \"scene.gltf\"\n"),
    );
    let stats = |s: &Scene| common::mean_and_se(&common::render(s));
    let (a, sa) = stats(&by_hand);
    let (b, sb) = stats(&from_gltf);
    println!("by hand {a:.5} +- {sa:.1e}, glTF {b:.5} +- {sb:.1e}");
    assert!(
        (a - b).abs() <= 4.0 * (sa * sa + sb * sb).sqrt(),
        "{a} vs {b}"
    );
}

/// What glTF brings that vkpath does not use is a warning; a broken file is an error at the mesh's `obj`.
#[test]
fn gltf_notes_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let json = std::fs::read_to_string(dir.path().join("scene.gltf")).unwrap();
    let with_normal_map = json.replace(
        r#""metallicFactor": 0.0, "roughnessFactor": 0.8}}"#,
        r#""metallicFactor": 0.0, "roughnessFactor": 0.8}, "normalTexture": {"index": 0}}"#,
    );
    assert_ne!(json, with_normal_map);
    std::fs::write(dir.path().join("scene.gltf"), with_normal_map).unwrap();
    let scene = load(
        dir.path(),
        &format!("{HEAD}[[mesh]]\nobj = \"scene.gltf\"\n"),
    );
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("normalTexture"),
        "{:?}",
        scene.warnings
    );

    std::fs::write(dir.path().join("scene.gltf"), "{\"asset\": {}}").unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(
        &path,
        format!("{HEAD}[[mesh]]\nobj = \"scene.gltf\"  # line 15\n"),
    )
    .unwrap();
    let err = Scene::load(&path).expect_err("not a glTF");
    let message = err.to_string();
    assert_eq!(err.line(), Some(15), "{message}");
    assert_eq!(err.key(), Some("mesh[0].obj"), "{message}");
    assert!(message.contains("scene.gltf"), "{message}");
}

/// `vkpath render scene.gltf`: the file as a scene of its own, its first camera (or `--camera N`), its
/// point and directional lights (a candela as a W/sr, a lux as a W/m^2), spot lights a warning.
#[test]
fn a_gltf_file_is_a_scene_with_its_camera_and_lights() {
    use vkpath::scene::{Light, Projection};
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let path = dir.path().join("scene.gltf");
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        scene.warnings.iter().any(|w| w.contains("spot light 2")),
        "{:?}",
        scene.warnings
    );
    let c = scene.camera;
    assert!((c.position - Vec3::new(0.5, 1.0, 6.0)).length() < 1e-6);
    assert!((c.look_at - Vec3::new(0.5, 1.0, 5.0)).length() < 1e-6);
    assert!((c.up - Vec3::Y).length() < 1e-6);
    // fov_x = 2 atan(aspect tan(yfov / 2)) = 2 atan(2 tan 0.25) in degrees; 640 x 320.
    let want = (2.0 * (2.0 * 0.25f32.tan()).atan()).to_degrees();
    assert!((c.fov_deg - want).abs() < 1e-4, "{} vs {want}", c.fov_deg);
    assert_eq!((scene.image.width, scene.image.height), (640, 320));
    assert_eq!(scene.meshes.len(), 2);
    let [
        Light::Point {
            position,
            power,
            color,
        },
        Light::Directional {
            direction,
            irradiance,
            ..
        },
    ] = &scene.lights[..]
    else {
        panic!("a point and a directional light: {:?}", scene.lights)
    };
    assert!((*position - Vec3::new(0.5, 1.0, 3.0)).length() < 1e-6);
    assert!((power - 40.0 * std::f32::consts::PI).abs() < 1e-3);
    assert_eq!(*color, Vec3::new(1.0, 0.5, 0.25));
    // The sun node is turned 90 degrees about x: its -z, the way the light goes, turns into +y.
    assert!(
        (*direction - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-6,
        "{direction}"
    );
    assert_eq!(*irradiance, 2.0);

    let side = Scene::load_with_camera(&path, Some(1)).unwrap();
    assert_eq!(side.camera.projection, Projection::Orthographic);
    assert!((side.camera.extent - 6.0).abs() < 1e-6);
    assert!((side.camera.position - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-5);
    // Turned 90 degrees about y: it looks along -x.
    assert!((side.camera.look_at - Vec3::new(9.0, 0.0, 0.0)).length() < 1e-5);
    assert_eq!((side.image.width, side.image.height), (640, 320));
    let err = Scene::load_with_camera(&path, Some(2)).expect_err("two cameras");
    assert_eq!(err.key(), Some("--camera"), "{err}");
    assert!(err.to_string().contains("0 to 1"), "{err}");
}

/// The command line: `render` renders a glTF scene (its warnings on stderr), `--camera` out of range
/// exits with status 2 and names the flag, `convert` writes TOML that reads back as the same scene, the
/// mesh path made relative to where the TOML goes.
#[test]
fn render_and_convert_a_gltf_scene_from_the_command_line() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_vkpath"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    let out = run(&["render", "scene.gltf", "--spp", "1", "-o", "out.png"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("warning: glTF spot light 2"), "{stderr}");
    let png = image::open(dir.path().join("out.png")).unwrap();
    assert_eq!((png.width(), png.height()), (640, 320));

    let out = run(&["render", "scene.gltf", "--camera", "5", "-o", "bad.png"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--camera"));
    assert!(!dir.path().join("bad.png").exists());

    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let out = run(&["convert", "scene.gltf", "-o", "sub/converted.toml"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.path().join("sub/converted.toml")).unwrap();
    assert!(text.contains("obj = \"../scene.gltf\""), "{text}");
    let converted = Scene::load(&dir.path().join("sub/converted.toml")).unwrap();
    let direct = Scene::load(&dir.path().join("scene.gltf")).unwrap();
    assert_eq!(converted.camera, direct.camera);
    assert_eq!(converted.lights, direct.lights);
    assert_eq!(converted.materials, direct.materials);
    assert_eq!(converted.meshes.len(), direct.meshes.len());

    let out = run(&["convert", "scene.gltf", "-o", "scene.gltf"]);
    assert_eq!(out.status.code(), Some(2));
}

/// The gallery's glTF scene (scenes/gltf/materials.gltf, written by make_gltf.py) reads as a scene: its
/// camera, a sun and a point light, the floor, five balls and the emissive one; and its specialised kernel
/// renders the same bits as the generic one (metallic_roughness is a feature like the others).
#[test]
fn the_gallery_gltf_scene_loads_and_specialises() {
    use vkpath::render::RenderOptions;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gltf/materials.gltf");
    let mut scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.lights.len(), 2);
    assert_eq!(scene.meshes.len(), 7);
    assert_eq!(scene.material_names.len(), 7);
    assert!(
        scene
            .materials
            .iter()
            .all(|m| matches!(m.bsdf, Bsdf::MetallicRoughness { .. }))
    );
    scene.image.width = 24;
    scene.image.height = 14;
    let specialised = common::render_passes(&scene, &RenderOptions::default(), 1, 4);
    let generic = common::render_passes(
        &scene,
        &RenderOptions {
            generic: true,
            ..Default::default()
        },
        1,
        4,
    );
    assert!(specialised.average() > 0.0);
    assert_eq!(specialised.mean, generic.mean);
}
