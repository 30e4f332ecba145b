//! glTF 2.0 meshes (`[[mesh]] obj = "*.gltf"`): a small glTF written here (JSON, an external buffer and
//! a PNG), with a node hierarchy (a translated parent, a rotated and scaled child), a textured
//! metallic-roughness material and an emissive one with KHR_materials_emissive_strength.
//!
//! * Positions, normals and uvs after loading, against the node transforms worked out by hand.
//! * Materials: metallic_roughness with the factors, the emission times its strength, the base colour
//!   texture (oriented as glTF's: v = 0 is the image's top row).
//! * The image against the same scene written by hand as OBJ files and TOML materials: image means agree
//!   within noise.
//! * Textures (a one-quad glTF written per test, `write_textured_quad`): the tables after loading; base
//!   colour = factor x texel; metallic and roughness per texel against the analytic reflectances under a
//!   uniform environment; emission = factor x texel seen directly and as a light; normal maps (scale 0
//!   changes no bit, a tilted map renders like a tilted quad); the same maps as TOML keys; specialisation.

mod common;

use glam::Vec3;
use proptest::prelude::*;
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
            roughness: 0.8,
            layers: vkpath::scene::GltfLayers::NONE
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

/// An occlusionTexture is read past with a note (a scene warning marked `NOTE`, printed as `vkpath:
/// note:`); a broken file is an error at the mesh's `obj`.
#[test]
fn gltf_notes_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let json = std::fs::read_to_string(dir.path().join("scene.gltf")).unwrap();
    let with_occlusion = json.replace(
        r#""metallicFactor": 0.0, "roughnessFactor": 0.8}}"#,
        r#""metallicFactor": 0.0, "roughnessFactor": 0.8}, "occlusionTexture": {"index": 0}}"#,
    );
    assert_ne!(json, with_occlusion);
    std::fs::write(dir.path().join("scene.gltf"), with_occlusion).unwrap();
    let scene = load(
        dir.path(),
        &format!("{HEAD}[[mesh]]\nobj = \"scene.gltf\"\n"),
    );
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("occlusionTexture")
            && scene.warnings[0].starts_with(vkpath::scene::NOTE),
        "{:?}",
        scene.warnings
    );
    assert!(vkpath::scene::warning_line(&scene.warnings[0]).starts_with("vkpath: note: mesh[0]"));

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

/// bare.gltf beside write_gltf's scene.gltf: the same file whose scene holds only the mesh node, so it
/// has no camera and no lights.
fn write_bare_gltf(dir: &Path) {
    let json = std::fs::read_to_string(dir.join("scene.gltf")).unwrap();
    let bare = json.replace(
        r#""scenes": [{"nodes": [0, 2, 3, 4, 5, 6]}]"#,
        r#""scenes": [{"nodes": [0]}]"#,
    );
    assert_ne!(bare, json, "the fixture's scene list moved");
    std::fs::write(dir.join("bare.gltf"), bare).unwrap();
}

/// The framed view (`--camera auto`, and the default when the file has no camera): the scene's bounding
/// box from the POSITION bounds through the node transforms, here (x, y, z) -> (1 - y, 2x, z): the quad's
/// [0, 1]^2 goes to [0, 1] x [0, 2], the triangle's [3, 4] x [0, 1] to [0, 1] x [6, 8]: the box [0, 1] x
/// [0, 8] x {0}, centre (0.5, 4, 0), radius sqrt(65) / 2. The camera sits at d = r / sin(22.5 deg) on +z,
/// looking at the centre, 45 degrees vertically on 640 x 480: fov_x = 2 atan(4/3 tan 22.5 deg). Every
/// vertex of the scene is then inside the image. Without cameras and lights the file is also lit by a
/// uniform white environment, with a note; `--camera auto` is refused for TOML and Mitsuba scenes and
/// with an index, naming the flag.
#[test]
fn a_gltf_scene_without_a_camera_is_framed_from_its_bounds() {
    use vkpath::scene::translated::ImportOptions;
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let path = dir.path().join("scene.gltf");
    let auto = ImportOptions {
        auto_camera: true,
        ..ImportOptions::default()
    };
    let scene = Scene::load_with(&path, &auto).unwrap_or_else(|e| panic!("{e}"));
    let c = scene.camera;
    let (centre, r) = (Vec3::new(0.5, 4.0, 0.0), 65f32.sqrt() / 2.0);
    let d = r / 22.5f32.to_radians().sin();
    assert!((c.look_at - centre).length() < 1e-4, "{:?}", c.look_at);
    assert!(
        (c.position - (centre + Vec3::new(0.0, 0.0, d))).length() < 1e-3,
        "{:?}",
        c.position
    );
    assert!((c.up - Vec3::Y).length() < 1e-6);
    let fov_x = (2.0 * (4.0 / 3.0 * 22.5f32.to_radians().tan()).atan()).to_degrees();
    assert!((c.fov_deg - fov_x).abs() < 1e-3, "{} vs {fov_x}", c.fov_deg);
    assert_eq!((scene.image.width, scene.image.height), (640, 480));
    // Every vertex in view: within half the field of view across and up.
    let (tx, ty) = ((fov_x / 2.0).to_radians().tan(), 22.5f32.to_radians().tan());
    for p in QUAD.iter().chain(TRI.iter()).map(|p| world(*p)) {
        let v = p - c.position;
        assert!(
            v.x.abs() / -v.z < tx && v.y.abs() / -v.z < ty,
            "{p} out of view"
        );
    }
    // The file's lights are kept (no environment added).
    assert_eq!(scene.lights.len(), 3);
    // No camera and no lights: framed by default, and lit by a white sky.
    write_bare_gltf(dir.path());
    let bare = Scene::load(&dir.path().join("bare.gltf")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bare.camera, scene.camera);
    assert!(bare.lights.is_empty());
    assert_eq!(bare.environment.radiance, Vec3::ONE);
    for note in ["no camera: framed", "uniform white environment"] {
        assert!(
            bare.warnings.iter().any(|w| w.contains(note)),
            "{:?}",
            bare.warnings
        );
    }
    // Refusals name the flag.
    let both = ImportOptions {
        auto_camera: true,
        camera: Some(0),
        ..ImportOptions::default()
    };
    let e = Scene::load_with(&path, &both).unwrap_err().to_string();
    assert!(e.contains("--camera"), "{e}");
    let toml = dir.path().join("s.toml");
    std::fs::write(&toml, HEAD).unwrap();
    let e = Scene::load_with(&toml, &auto).unwrap_err().to_string();
    assert!(e.contains("--camera"), "{e}");
}

/// Texture coordinates are per primitive: when the untextured triangle has no TEXCOORD_0, the textured
/// quad keeps its uvs and its texture (it used to lose both: one uv-less primitive dropped the mesh's
/// uvs); the untextured triangle's part of the mesh needs none.
#[test]
fn texture_coordinates_are_per_primitive() {
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let path = dir.path().join("scene.gltf");
    let json = std::fs::read_to_string(&path).unwrap();
    let without = json.replace(r#""NORMAL": 5, "TEXCOORD_0": 7"#, r#""NORMAL": 5"#);
    assert_ne!(without, json, "the fixture's triangle moved");
    std::fs::write(&path, without).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        !scene
            .warnings
            .iter()
            .any(|w| w.contains("texture coordinates")),
        "{:?}",
        scene.warnings
    );
    let textured: Vec<_> = scene
        .meshes
        .iter()
        .filter(|m| m.texture.is_some())
        .collect();
    assert_eq!(textured.len(), 1, "the quad's material keeps its texture");
    let quad = textured[0];
    assert_eq!(quad.uvs.len(), quad.positions.len());
    // glTF's v runs down; vkpath's up: (u, v) -> (u, 1 - v).
    let want: Vec<[f32; 2]> = QUAD_UV.iter().map(|[u, v]| [*u, 1.0 - v]).collect();
    assert_eq!(quad.uvs, want);
}

/// `vkpath render scene.gltf`: the file as a scene of its own, its first camera (or `--camera N`), its
/// point, directional and spot lights (a candela as a W/sr, a lux as a W/m^2; a spot's cone angles with
/// the extension's smooth falloff, its defaults inner 0 and outer pi / 4).
#[test]
fn a_gltf_file_is_a_scene_with_its_camera_and_lights() {
    use vkpath::scene::{Light, Projection};
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    let path = dir.path().join("scene.gltf");
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
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
        Light::Spot {
            position: spot_position,
            axis,
            intensity: spot_intensity,
            cutoff_deg,
            beam_deg,
            falloff: vkpath::scene::SpotFalloff::Smooth,
            ..
        },
    ] = &scene.lights[..]
    else {
        panic!(
            "a point, a directional and a smooth spot light: {:?}",
            scene.lights
        )
    };
    assert_eq!(*spot_position, Vec3::ZERO);
    assert!((*axis - Vec3::NEG_Z).length() < 1e-6, "{axis}");
    assert_eq!((*spot_intensity, *cutoff_deg, *beam_deg), (1.0, 45.0, 0.0));
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
    assert!(!stderr.contains("warning"), "{stderr}");
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

/// `--environment MAP` lights a scene with a map, replacing its environment: on the lightless glTF
/// (whose own would be the uniform white sky, with its note) a uniform map of radiance 2.5 shows as 2.5
/// exactly in every pixel that sees the sky (an EXR out, no filter: each of those samples is the map's
/// value), and the note is gone; a map that is not .exr/.hdr, or missing, is refused naming the flag
/// (exit 2, nothing written).
#[test]
fn the_environment_flag_replaces_the_scenes_environment() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    write_gltf(dir.path());
    write_bare_gltf(dir.path());
    image::Rgb32FImage::from_pixel(8, 4, image::Rgb([2.5, 2.5, 2.5]))
        .save(dir.path().join("sky.exr"))
        .unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_vkpath"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    let out = run(&[
        "render",
        "bare.gltf",
        "--environment",
        "sky.exr",
        "--spp",
        "2",
        "--width",
        "32",
        "--height",
        "24",
        "-o",
        "lit.exr",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("uniform white environment"), "{stderr}");
    let img = image::open(dir.path().join("lit.exr")).unwrap().to_rgb32f();
    let sky = img.pixels().filter(|p| p.0 == [2.5; 3]).count();
    assert!(
        sky > 32 * 24 / 2,
        "{sky} of {} pixels show the map",
        32 * 24
    );
    for bad in ["sky.png", "missing.exr"] {
        let out = run(&["render", "bare.gltf", "--environment", bad, "-o", "bad.png"]);
        assert_eq!(out.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&out.stderr).contains("--environment"));
        assert!(!dir.path().join("bad.png").exists());
    }
}

/// The gallery's glTF scene (scenes/gltf/materials.gltf, written by make_gltf.py) reads as a scene: its
/// camera, a sun and a point light, the floor, five balls and the emissive one; and its specialised kernel
/// renders the same bits as the generic one (metallic_roughness is a feature like the others).
#[test]
fn the_gallery_gltf_scene_loads_and_specialises() {
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
    let (specialised, generic) = specialised_and_generic(&scene);
    assert!(specialised.average() > 0.0);
    assert_eq!(specialised.mean, generic.mean);
}

/// One 4-spp pass of `scene` with its specialised kernel and one with the generic kernel.
fn specialised_and_generic(scene: &vkpath::Scene) -> (vkpath::Film, vkpath::Film) {
    let generic = vkpath::render::RenderOptions {
        generic: true,
        ..Default::default()
    };
    (
        common::render_passes(scene, &Default::default(), 1, 4),
        common::render_passes(scene, &generic, 1, 4),
    )
}

// ----- Textures: base colour x factor, metallic-roughness, emissive -----

/// The sRGB decoding of an 8-bit value (IEC 61966-2-1), in f64: the reference for the shader's.
fn srgb_decode(byte: u8) -> f64 {
    let c = f64::from(byte) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Writes quad.gltf (with quad.bin) into `dir`: the square [-1, 1]^2 in the plane z = 0, facing +z, glTF
/// uv u = (x + 1) / 2, v = (1 - y) / 2 (v = 0 at the top), with the one material `material` (JSON), whose
/// texture k is image k, `images[k]` written as tex{k}.png.
fn write_textured_quad(dir: &Path, material: &str, images: &[image::RgbImage]) {
    write_quad(dir, Some(material), images, &[r#"{"mesh": 0}"#]);
}

/// `write_textured_quad`'s quad, placed by `nodes` (JSON node objects, each naming mesh 0, all roots of
/// the scene), in `material` or, with none, in no material at all (the file then has none).
fn write_quad(dir: &Path, material: Option<&str>, images: &[image::RgbImage], nodes: &[&str]) {
    let mut bin = f32s(&[
        -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ]);
    bin.extend(f32s(&[0.0, 0.0, 1.0].repeat(4)));
    bin.extend(f32s(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]));
    bin.extend(u32s(&[0, 1, 2, 0, 2, 3]));
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    let mut textures = Vec::new();
    let mut uris = Vec::new();
    for (k, img) in images.iter().enumerate() {
        img.save(dir.join(format!("tex{k}.png"))).unwrap();
        textures.push(format!(r#"{{"source": {k}}}"#));
        uris.push(format!(r#"{{"uri": "tex{k}.png"}}"#));
    }
    let roots: Vec<String> = (0..nodes.len()).map(|k| k.to_string()).collect();
    let (named, materials) = match material {
        Some(m) => (r#", "material": 0"#, format!("\n  \"materials\": [{m}],")),
        None => ("", String::new()),
    };
    let textured = if images.is_empty() {
        String::new()
    } else {
        format!(
            "\n  \"textures\": [{}],\n  \"images\": [{}],",
            textures.join(", "),
            uris.join(", ")
        )
    };
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scenes": [{{"nodes": [{}]}}],
  "nodes": [{}],
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3{named}}}
  ]}}],{materials}{textured}
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 128, "byteLength": 24}}
  ],
  "buffers": [{{"uri": "quad.bin", "byteLength": {}}}]
}}"#,
        roots.join(", "),
        nodes.join(", "),
        bin.len()
    );
    std::fs::write(dir.join("quad.gltf"), json).unwrap();
}

/// A constant image.
fn flat(w: u32, h: u32, rgb: [u8; 3]) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |_, _| image::Rgb(rgb))
}

/// The quad seen head on by an orthographic camera whose view is the quad exactly (32 x 32 pixels, each
/// 1/16 wide; +x to the right), lit by a uniform environment of radiance `env`, one bounce.
fn quad_scene(dir: &Path, env: f32, samples: u32) -> Scene {
    load(
        dir,
        &format!(
            "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\n\
             look_at = [0.0, 0.0, 0.0]\n[image]\nwidth = 32\nheight = 32\n[render]\nsamples = {samples}\n\
             max_bounces = 1\nfilter = \"box\"\n[environment]\nradiance = [{env}, {env}, {env}]\n\
             [[mesh]]\nobj = \"quad.gltf\"\n"
        ),
    )
}

/// Per channel, the mean over the pixels (px, py) in the given ranges and its standard error (the
/// pixels are independent: the variances of their means, summed, over n^2).
fn region(
    film: &vkpath::Film,
    xs: std::ops::RangeInclusive<usize>,
    ys: std::ops::RangeInclusive<usize>,
) -> [(f64, f64); 3] {
    let mut sum = [0.0f64; 3];
    let mut var = [0.0f64; 3];
    let mut n = 0.0;
    for y in ys {
        for x in xs.clone() {
            let i = y * film.width as usize + x;
            for c in 0..3 {
                sum[c] += f64::from(film.mean[i][c]);
                var[c] += f64::from(film.variance[i][c]).max(0.0);
            }
            n += 1.0;
        }
    }
    [0, 1, 2].map(|c| (sum[c] / n, var[c].sqrt() / n))
}

/// glTF's alpha coverage (§3.9.4) on the quad in front of a uniform sky of radiance 1: MASK with a 2 x 2
/// alpha checker (255 and 0) cuts two diagonal quarters out (every pixel there sees the sky: exactly 1,
/// in every sample), the other two stay solid (their dim reflection, below 0.5); BLEND with a factor
/// alpha of 0.3 lets 0.7 of the sky through: the mean over the quad is 0.7 + 0.3 x the opaque quad's, within
/// 5 standard errors. OPAQUE ignores the alpha.
#[test]
fn gltf_alpha_modes_cut_out_and_blend() {
    let dir = tempfile::tempdir().unwrap();
    let material = |mode: &str, alpha: f32| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0.0, 0.0, 0.0, {alpha}], "baseColorTexture": {{"index": 0}},
                "metallicFactor": 0.0, "roughnessFactor": 1.0}}, "alphaMode": "{mode}"}}"#
        )
    };
    let checker = image::RgbaImage::from_fn(2, 2, |x, y| {
        image::Rgba([255, 255, 255, if (x + y) % 2 == 0 { 255 } else { 0 }])
    });
    let white = image::RgbaImage::from_pixel(2, 2, image::Rgba([255; 4]));
    let render = |mode: &str, alpha: f32, img: &image::RgbaImage, spp: u32| {
        write_textured_quad(dir.path(), &material(mode, alpha), &[flat(2, 2, [0, 0, 0])]);
        img.save(dir.path().join("tex0.png")).unwrap();
        let scene = quad_scene(dir.path(), 1.0, spp);
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        common::render_passes(&scene, &Default::default(), 1, spp)
    };
    let mask = render("MASK", 1.0, &checker, 4);
    let quarter = |f: &vkpath::Film, qx: u32, qy: u32| -> Vec<f32> {
        (0..16)
            .flat_map(|y| (0..16).map(move |x| (x + 16 * qx, y + 16 * qy)))
            .map(|(x, y)| f.pixel(x, y)[1])
            .collect()
    };
    let holes: Vec<bool> = [(0, 0), (1, 0), (0, 1), (1, 1)]
        .iter()
        .map(|&(qx, qy)| {
            let q = quarter(&mask, qx, qy);
            let hole = q.iter().all(|&v| v == 1.0);
            assert!(
                hole || q.iter().all(|&v| v < 0.5),
                "quarter ({qx}, {qy}): {q:?}"
            );
            hole
        })
        .collect();
    assert_eq!(
        holes,
        [holes[0], !holes[0], !holes[0], holes[0]],
        "a checker of holes"
    );
    let opaque = render("OPAQUE", 1.0, &checker, 64);
    assert!(
        (0..32).all(|y| (0..32).all(|x| opaque.pixel(x, y)[1] < 0.5)),
        "OPAQUE ignores alpha"
    );
    let blend = render("BLEND", 0.3, &white, 64);
    let (o, so) = region(&opaque, 0..=31, 0..=31)[1];
    let (b, sb) = region(&blend, 0..=31, 0..=31)[1];
    let want = 0.7 + 0.3 * o;
    let se = (sb * sb + 0.09 * so * so).sqrt();
    assert!((b - want).abs() < 5.0 * se, "BLEND {b} vs {want} (se {se})");
}

/// A texture's sampler and KHR_texture_transform: an emissive quad whose 4 x 4 texture (every texel its
/// own colour) is read with magFilter NEAREST, wrap REPEAT and a transform of offset, rotation and scale
/// shows, at every pixel centre, the texel the extension's formula picks in glTF's uv space (uv' =
/// T R S uv, v down the image, R = [[cos, sin], [-sin, cos]]: the rotation as three.js, Babylon.js,
/// Blender and the Khronos TextureTransformTest model read it, not the transposed matrix the
/// extension's text prints, KhronosGroup/glTF issue 1563), computed here in f64: its sRGB
/// decoding, to f32 rounding; pixels within 1e-3 texel of a texel edge are skipped. The same image given as
/// a base64 data URI renders the same bits.
#[test]
fn gltf_texture_transform_and_sampler_pick_the_specifications_texel() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_fn(4, 4, |x, y| {
        image::Rgb([
            (20 + 60 * x) as u8,
            (30 + 55 * y) as u8,
            (200 - 40 * x - 7 * y) as u8,
        ])
    });
    let (tx, ty, r, sx, sy) = (0.3f64, -0.2f64, 0.5f64, 1.7f64, 2.3f64);
    write_textured_quad(
        dir.path(),
        &format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}},
               "emissiveFactor": [1.0, 1.0, 1.0],
               "emissiveTexture": {{"index": 0, "extensions": {{"KHR_texture_transform":
                   {{"offset": [{tx}, {ty}], "rotation": {r}, "scale": [{sx}, {sy}]}}}}}}}}"#
        ),
        std::slice::from_ref(&img),
    );
    let json = std::fs::read_to_string(dir.path().join("quad.gltf")).unwrap();
    let json = json.replace(
        r#""textures": [{"source": 0}]"#,
        r#""samplers": [{"magFilter": 9728, "wrapS": 10497, "wrapT": 10497}], "textures": [{"source": 0, "sampler": 0}]"#,
    );
    std::fs::write(dir.path().join("quad.gltf"), &json).unwrap();
    let n = 32u32;
    let toml = format!(
        "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
         [image]\nwidth = {n}\nheight = {n}\n[render]\nsamples = 1\nmax_bounces = 0\nfilter = \"none\"\n\
         [[mesh]]\nobj = \"quad.gltf\"\n"
    );
    let scene = load(dir.path(), &toml);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let film = common::render_passes(&scene, &Default::default(), 1, 1);
    let (c, s) = (r.cos(), r.sin());
    let mut checked = 0;
    for j in 0..n {
        for i in 0..n {
            let x = -1.0 + (f64::from(i) + 0.5) / 16.0;
            let y = 1.0 - (f64::from(j) + 0.5) / 16.0;
            let (u, v) = ((x + 1.0) / 2.0, (1.0 - y) / 2.0);
            let (su, sv) = (sx * u, sy * v);
            let uv = [c * su + s * sv + tx, -s * su + c * sv + ty];
            let t = uv.map(|a| (a - a.floor()) * 4.0);
            if t.iter().any(|a| (a - a.round()).abs() < 1e-3) {
                continue;
            }
            let texel = img.get_pixel(t[0] as u32, t[1] as u32);
            let got = film.pixel(i, j);
            for k in 0..3 {
                let want = srgb_decode(texel[k]);
                assert!(
                    (f64::from(got[k]) - want).abs() <= 1e-5 * want + 1e-7,
                    "pixel ({i}, {j}) channel {k}: {} vs texel ({}, {}) {want}",
                    got[k],
                    t[0] as u32,
                    t[1] as u32
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 800, "{checked}");
    // The image as a data URI: the same bits.
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let uri = format!(
        "data:image/png;base64,{}",
        base64::Engine::encode(&base64::engine::general_purpose::STANDARD, &png)
    );
    std::fs::write(
        dir.path().join("quad.gltf"),
        json.replace(r#""uri": "tex0.png""#, &format!(r#""uri": "{uri}""#)),
    )
    .unwrap();
    std::fs::remove_file(dir.path().join("tex0.png")).unwrap();
    let scene = load(dir.path(), &toml);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(
        common::render_passes(&scene, &Default::default(), 1, 1).mean,
        film.mean
    );
}

/// KHR_mesh_quantization: the textured quad with its POSITION as normalized i16 (32767 = 1), NORMAL as
/// normalized i8 and TEXCOORD_0 as normalized u16, or with POSITION as plain i8 (+-2) under a node scale
/// of 1/2 (the extension's way of scaling back), loads to the float quad's vertices, normals and uvs and
/// renders its bits; without the extension declared in extensionsUsed, the integer POSITION is refused
/// naming its accessor.
#[test]
fn gltf_quantized_attributes_are_the_float_ones() {
    let dir = tempfile::tempdir().unwrap();
    let material = r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}"#;
    let img = image::RgbImage::from_fn(4, 4, |x, y| {
        image::Rgb([(40 * x + 30) as u8, (50 * y + 20) as u8, 90])
    });
    write_textured_quad(dir.path(), material, std::slice::from_ref(&img));
    let toml = "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
                [image]\nwidth = 16\nheight = 16\n[render]\nsamples = 2\nmax_bounces = 1\n\
                [environment]\nradiance = [0.5, 0.5, 0.5]\n[[mesh]]\nobj = \"quad.gltf\"\n";
    let float = load(dir.path(), toml);
    let want = common::render_passes(&float, &Default::default(), 1, 2).mean;
    let json = std::fs::read_to_string(dir.path().join("quad.gltf")).unwrap();
    let i16s = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let u16s = |v: &[u16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    for (name, position_bytes, position_type, normalized, node) in [
        // 4 vertices x (3 i16 + 2 bytes of padding): 8-byte elements.
        (
            "normalized i16",
            {
                let mut b = Vec::new();
                for p in [[-1i16, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]] {
                    b.extend(i16s(&p.map(|c| c * 32767)));
                    b.extend([0, 0]);
                }
                b
            },
            5122,
            true,
            r#"{"mesh": 0}"#,
        ),
        (
            "plain i8 under a node scale",
            {
                let mut b = Vec::new();
                for p in [[-2i8, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]] {
                    b.extend(p.map(|c| c as u8));
                    b.extend([0, 0, 0, 0, 0]);
                }
                b
            },
            5120,
            false,
            r#"{"mesh": 0, "scale": [0.5, 0.5, 0.5]}"#,
        ),
    ] {
        // POSITION (32 bytes), NORMAL as normalized i8 (4 bytes each: 0, 0, 127, pad), TEXCOORD_0 as
        // normalized u16 (4 bytes each), indices as u32.
        let mut bin = position_bytes;
        bin.extend([0u8, 0, 127, 0].repeat(4));
        bin.extend(u16s(&[0, 65535, 65535, 65535, 65535, 0, 0, 0]));
        bin.extend(u32s(&[0, 1, 2, 0, 2, 3]));
        std::fs::write(dir.path().join("quant.bin"), &bin).unwrap();
        let quant = |declare: bool| {
            let start = json.find(r#""accessors""#).unwrap();
            let middle = format!(
                r#""accessors": [
    {{"bufferView": 0, "componentType": {position_type}, "normalized": {normalized}, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8}},
    {{"buffer": 0, "byteOffset": 32, "byteLength": 16, "byteStride": 4}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 16, "byteStride": 4}},
    {{"buffer": 0, "byteOffset": 64, "byteLength": 24}}
  ],
  "buffers": [{{"uri": "quant.bin", "byteLength": {}}}]
}}"#,
                bin.len()
            );
            let head = json[..start].replace(
                r#""nodes": [{"mesh": 0}]"#,
                &format!(r#""nodes": [{node}]"#),
            );
            let head = if declare {
                head.replace(
                    r#""asset": {"version": "2.0"},"#,
                    r#""asset": {"version": "2.0"}, "extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"],"#,
                )
            } else {
                head
            };
            format!("{head}{middle}")
        };
        std::fs::write(dir.path().join("quad.gltf"), quant(true)).unwrap();
        let scene = load(dir.path(), toml);
        assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
        assert_eq!(
            scene.meshes[0].positions, float.meshes[0].positions,
            "{name}"
        );
        assert_eq!(scene.meshes[0].normals, float.meshes[0].normals, "{name}");
        assert_eq!(scene.meshes[0].uvs, float.meshes[0].uvs, "{name}");
        assert_eq!(
            common::render_passes(&scene, &Default::default(), 1, 2).mean,
            want,
            "{name}"
        );
        std::fs::write(dir.path().join("quad.gltf"), quant(false)).unwrap();
        let e = Scene::load(&dir.path().join("quad.gltf"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("accessors[0]"), "{name}: {e}");
        std::fs::write(dir.path().join("quad.gltf"), &json).unwrap();
    }
}

/// What the importer makes of a material with every texture glTF's metallic-roughness model has: the
/// factors in the material, the base colour, emissive, metallic-roughness and normal textures on the mesh
/// (the first two colour, sRGB; the others linear data), the normal map's scale, and in the GPU tables: one texel block per image
/// however many textures use it, one table entry per (image, colour or data) pair.
#[test]
fn gltf_textures_load_with_their_factors() {
    use vkpath::kernel::abi::*;
    let dir = tempfile::tempdir().unwrap();
    // Image 0 is the base colour, the metallic-roughness and the normal texture (textures 0 and 2, the
    // last two sharing texture 2); image 1 the emissive one.
    write_textured_quad(
        dir.path(),
        r#"{"name": "all", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 1.0],
            "baseColorTexture": {"index": 0}, "metallicFactor": 0.75, "roughnessFactor": 0.5,
            "metallicRoughnessTexture": {"index": 2}},
          "emissiveFactor": [2.0, 1.0, 0.5], "emissiveTexture": {"index": 1},
          "normalTexture": {"index": 2, "scale": 0.5}}"#,
        &[flat(2, 2, [10, 20, 30]), flat(1, 1, [40, 50, 60])],
    );
    let json = std::fs::read_to_string(dir.path().join("quad.gltf")).unwrap();
    std::fs::write(
        dir.path().join("quad.gltf"),
        json.replace(
            r#""textures": [{"source": 0}, {"source": 1}]"#,
            r#""textures": [{"source": 0}, {"source": 1}, {"source": 0}]"#,
        ),
    )
    .unwrap();
    let scene = quad_scene(dir.path(), 1.0, 1);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(
        scene.materials[0].bsdf,
        Bsdf::MetallicRoughness {
            base_color: Vec3::new(0.5, 0.25, 1.0),
            metallic: 0.75,
            roughness: 0.5,
            layers: vkpath::scene::GltfLayers::NONE
        }
    );
    assert_eq!(
        scene.materials[0].emission.map(|e| e.radiance),
        Some(Vec3::new(2.0, 1.0, 0.5))
    );
    let m = &scene.meshes[0];
    assert!(m.maps.base_color_factor);
    let base = m.texture.as_ref().expect("a base colour texture");
    let emissive = m.maps.emissive.as_ref().expect("an emissive texture");
    let mr = m
        .maps
        .metallic_roughness
        .as_ref()
        .expect("a metallic-roughness texture");
    assert!(std::sync::Arc::ptr_eq(base, mr), "image 0 is decoded once");
    assert!(std::sync::Arc::ptr_eq(
        base,
        m.maps.normal.as_ref().unwrap()
    ));
    assert_eq!(m.maps.normal_scale, 0.5);
    assert_eq!(emissive.texels[0].to_le_bytes()[..3], [40, 50, 60]);

    let gpu = vkpath::kernel::upload::GpuScene::build(&scene);
    assert_eq!(gpu.meshes[0].flags, MESH_SMOOTH | MESH_UV);
    // The mesh's maps are bound to a copy of its material (upload::mesh_material), whose base colour
    // stays the factor the texture multiplies.
    let material = gpu.triangles[0].material as usize;
    assert_eq!(
        material,
        scene.materials.len(),
        "the mesh's own material, after the scene's"
    );
    assert_eq!(
        gpu.materials[material].albedo,
        gpu.materials[m.material as usize].albedo
    );
    let t = gpu.material_textures[material];
    assert_eq!(t.normal_scale, 0.5);
    let [b, e, r, g, n] = [
        t.albedo_texture,
        t.emission_texture,
        t.metallic_texture,
        t.roughness_texture,
        t.normal_texture,
    ]
    .map(|k| gpu.textures[k as usize]);
    // Base colour and emissive (sRGB), metallic (B), roughness (G) and the normal map (RGB, linear).
    assert_eq!(gpu.textures.len(), 5);
    let channel = |c: u32| c << TEXTURE_CHANNEL_SHIFT;
    assert_eq!(
        (b.flags, e.flags, r.flags, g.flags, n.flags),
        (
            TEXTURE_SRGB,
            TEXTURE_SRGB,
            channel(TEXTURE_CHANNEL_B),
            channel(TEXTURE_CHANNEL_G),
            0
        )
    );
    assert_eq!(b.offset, r.offset, "one image, its texels uploaded once");
    assert_eq!(b.offset, n.offset);
    assert_eq!((b.width, b.height, e.width, e.height), (2, 2, 1, 1));
    assert_eq!(gpu.texels.len(), 4 + 1);
    assert_eq!(
        gpu.texels[e.offset as usize].to_le_bytes()[..3],
        [40, 50, 60]
    );
}

/// base colour = baseColorFactor x texel (glTF 2.0 §3.9.2, both linear): a quad with a constant texture
/// c and a factor f renders as the same quad without a texture and the factor f x decode(c), computed
/// here. Same random numbers, so the images agree far within their noise.
#[test]
fn gltf_base_color_factor_multiplies_the_texture() {
    let c = [200u8, 120, 60];
    let f = [0.5f64, 0.8, 0.25];
    let product = [0, 1, 2].map(|k| f[k] * srgb_decode(c[k]));
    let material = |factor: [f64; 3], texture: bool| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [{}, {}, {}, 1.0], {}
                "metallicFactor": 0.0, "roughnessFactor": 0.5}}}}"#,
            factor[0] as f32,
            factor[1] as f32,
            factor[2] as f32,
            if texture {
                r#""baseColorTexture": {"index": 0},"#
            } else {
                ""
            }
        )
    };
    let dir = tempfile::tempdir().unwrap();
    write_textured_quad(dir.path(), &material(f, true), &[flat(1, 1, c)]);
    let textured = common::render(&quad_scene(dir.path(), 1.0, 16));
    write_textured_quad(dir.path(), &material(product, false), &[flat(1, 1, c)]);
    let plain = common::render(&quad_scene(dir.path(), 1.0, 16));
    let a = region(&textured, 0..=31, 0..=31);
    let b = region(&plain, 0..=31, 0..=31);
    for k in 0..3 {
        println!(
            "channel {k}: textured {:.6} +- {:.1e}, factor x texel {:.6}",
            a[k].0, a[k].1, b[k].0
        );
        assert!(
            (a[k].0 - b[k].0).abs() <= 1e-3 * b[k].0,
            "channel {k}: {} vs {}",
            a[k].0,
            b[k].0
        );
    }
}

/// metallic = metallicFactor x B, roughness = roughnessFactor x G (linear data, glTF 2.0 §3.9.2): a
/// texture that is metal (B = 255) on the right half and dielectric (B = 0) on the left, G = 0 (smooth)
/// throughout, under a uniform environment of radiance 1, seen head on (wo = n):
/// - metal: a mirror of Schlick reflectance F(1) = base colour, so each pixel is the base colour;
/// - dielectric: specular F_d(1) = 0.04 plus the diffuse lobe fd = (1 - F_d(wo.h)) base / pi integrated
///   against cos_i: with h halfway between n and wi, wo.h = sqrt((1 + mu) / 2) at mu = cos_i, so its
///   albedo is base x 2 int_0^1 (1 - F_d(sqrt((1 + mu) / 2))) mu dmu (Simpson's rule here).
///
/// With roughnessFactor 1 and the G channel ignored, the metal would be rough and reflect less.
#[test]
fn gltf_metallic_roughness_texture_sets_metal_and_roughness_per_texel() {
    let base = [0.9f64, 0.6, 0.3];
    let dir = tempfile::tempdir().unwrap();
    // 8 x 1: four dielectric texels, then four metal ones (R is unused: 255 there).
    let mr = image::RgbImage::from_fn(8, 1, |x, _| {
        image::Rgb([255, 0, if x < 4 { 0 } else { 255 }])
    });
    write_textured_quad(
        dir.path(),
        &format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [{}, {}, {}, 1.0],
                "metallicFactor": 1.0, "roughnessFactor": 1.0, "metallicRoughnessTexture": {{"index": 0}}}}}}"#,
            base[0] as f32, base[1] as f32, base[2] as f32
        ),
        &[mr],
    );
    let film = common::render(&quad_scene(dir.path(), 1.0, 64));
    let fd = |c: f64| 0.04 + 0.96 * (1.0 - c).powi(5);
    let n = 1000;
    let g = |mu: f64| (1.0 - fd(((1.0 + mu) / 2.0).sqrt())) * mu;
    let h = 1.0 / n as f64;
    let simpson = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * g(i as f64 * h)
        })
        .sum::<f64>()
        * h
        / 3.0;
    // Pure texels: u in [1/16, 7/16] and [9/16, 15/16] (texel centres, bilinear filtering between them),
    // pixel columns 4..=11 and 20..=27 (each 1/32 of u wide).
    let dielectric = region(&film, 4..=11, 2..=29);
    let metal = region(&film, 20..=27, 2..=29);
    for k in 0..3 {
        let want_d = fd(1.0) + base[k] * 2.0 * simpson;
        println!(
            "channel {k}: dielectric {:.5} +- {:.1e} (want {want_d:.5}), metal {:.6} (want {})",
            dielectric[k].0, dielectric[k].1, metal[k].0, base[k] as f32
        );
        assert!(
            (dielectric[k].0 - want_d).abs() <= 4.0 * dielectric[k].1 + 1e-4,
            "channel {k}: dielectric {} vs {want_d}",
            dielectric[k].0
        );
        assert!(
            (metal[k].0 - f64::from(base[k] as f32)).abs() <= 1e-4,
            "channel {k}: metal {} vs {}",
            metal[k].0,
            base[k]
        );
    }
}

/// emission = emissiveFactor x texel (sRGB decoded): a quad with a constant emissive texture c, seen
/// directly in a black environment, has exactly that radiance; its base colour texture (another colour)
/// does not tint the emission, as it does on TOML meshes.
#[test]
fn gltf_emissive_texture_multiplies_the_emissive_factor() {
    let c = [250u8, 128, 20];
    let e = [2.0f64, 1.5, 3.0];
    let dir = tempfile::tempdir().unwrap();
    write_textured_quad(
        dir.path(),
        &format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}},
                "emissiveFactor": [{}, {}, {}], "emissiveTexture": {{"index": 1}}}}"#,
            e[0], e[1], e[2]
        ),
        &[flat(1, 1, [10, 200, 30]), flat(1, 1, c)],
    );
    let film = common::render(&quad_scene(dir.path(), 0.0, 4));
    let seen = region(&film, 0..=31, 0..=31);
    for k in 0..3 {
        let want = e[k] * srgb_decode(c[k]);
        assert!(
            (seen[k].0 - want).abs() <= 1e-5 * want,
            "channel {k}: {} vs {want}",
            seen[k].0
        );
    }
}

/// The emissive texture lights other surfaces too (light sampling and the BSDF's rays that hit it): an
/// emissive quad with factor e and a constant texture c lights a diffuse floor as one of emission
/// e x decode(c) without a texture does, within noise.
#[test]
fn gltf_emissive_texture_lights_the_scene() {
    let c = [180u8, 90, 220];
    let e = [3.0f64, 2.0, 1.0];
    let dir = tempfile::tempdir().unwrap();
    let emissive = |factor: [f64; 3], texture: bool| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1]}},
                "emissiveFactor": [{}, {}, {}] {}}}"#,
            factor[0] as f32,
            factor[1] as f32,
            factor[2] as f32,
            if texture {
                r#", "emissiveTexture": {"index": 0}"#
            } else {
                ""
            }
        )
    };
    // The lamp faces down (+z turned to -y) one unit above a floor the camera looks at from above.
    let toml = "[camera]\nposition = [0.0, 6.0, 0.5]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60\n\
        [image]\nwidth = 24\nheight = 24\n[render]\nsamples = 64\nmax_bounces = 2\nfilter = \"box\"\n\
        [materials]\nfloor = { type = \"diffuse\", albedo = [0.8, 0.8, 0.8] }\n\
        [[triangle]]\nvertices = [[-4.0, 0.0, -4.0], [-4.0, 0.0, 4.0], [4.0, 0.0, 4.0]]\nmaterial = \"floor\"\n\
        [[triangle]]\nvertices = [[-4.0, 0.0, -4.0], [4.0, 0.0, 4.0], [4.0, 0.0, -4.0]]\nmaterial = \"floor\"\n\
        [[mesh]]\nobj = \"quad.gltf\"\nrotate = [90.0, 0.0, 0.0]\nscale = 0.5\ntranslate = [0.0, 1.0, 0.0]\n";
    write_textured_quad(dir.path(), &emissive(e, true), &[flat(1, 1, c)]);
    let textured = common::render(&load(dir.path(), toml));
    let product = [0, 1, 2].map(|k| e[k] * srgb_decode(c[k]));
    write_textured_quad(dir.path(), &emissive(product, false), &[flat(1, 1, c)]);
    let plain = common::render(&load(dir.path(), toml));
    let a = region(&textured, 0..=23, 0..=23);
    let b = region(&plain, 0..=23, 0..=23);
    for k in 0..3 {
        println!(
            "channel {k}: textured {:.5} +- {:.1e}, plain {:.5} +- {:.1e}",
            a[k].0, a[k].1, b[k].0, b[k].1
        );
        assert!(a[k].0 > 0.0);
        assert!(
            (a[k].0 - b[k].0).abs() <= 4.0 * (a[k].1 * a[k].1 + b[k].1 * b[k].1).sqrt(),
            "channel {k}: {} vs {}",
            a[k].0,
            b[k].0
        );
    }
}

/// A glTF mesh with every texture needs each texture feature, and its specialised kernel renders the
/// same bits as the generic one. (The metallic channel is held at 1 here: metallic_roughness materials
/// of some metallic values, e.g. 0.1423, textured or not, already render a few ulps apart in the two
/// kernels, a difference of the BSDF's code that this test is not about.)
#[test]
fn gltf_textures_are_features_and_specialise() {
    use vkpath::kernel::features::{Feature, FeatureSet};
    let dir = tempfile::tempdir().unwrap();
    let mr = image::RgbImage::from_fn(4, 4, |x, y| image::Rgb([0, 60 * x as u8 + y as u8, 255]));
    write_textured_quad(
        dir.path(),
        r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.7, 0.9, 1.0],
            "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1}},
          "emissiveFactor": [0.2, 0.3, 0.4], "emissiveTexture": {"index": 0},
          "normalTexture": {"index": 1, "scale": 0.7}}"#,
        &[flat(2, 2, [200, 150, 100]), mr],
    );
    let scene = quad_scene(dir.path(), 1.0, 4);
    let gpu = vkpath::kernel::upload::GpuScene::build(&scene);
    let features = FeatureSet::of(&gpu, &vkpath::kernel::upload::params_for(&scene, 3));
    for f in [
        Feature::Textures,
        Feature::EmissiveTextures,
        Feature::MetallicRoughnessTextures,
        Feature::NormalMaps,
    ] {
        assert!(features.has(f), "{f:?}");
    }
    let (specialised, generic) = specialised_and_generic(&scene);
    assert!(specialised.average() > 0.0);
    let differ = specialised
        .mean
        .iter()
        .zip(&generic.mean)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "pixels that differ");
}

/// The quad of [`write_textured_quad`] lit by a sun (direction (0.6, -0.3, -1), irradiance 3) in a black
/// environment, seen head on: each pixel is the BSDF at (wo = +z, wi = the sun) times the irradiance
/// times the cosine about the shading normal, with no noise but the pixel's position.
fn sunlit_quad_scene(dir: &Path) -> Scene {
    load(
        dir,
        "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\n\
         look_at = [0.0, 0.0, 0.0]\n[image]\nwidth = 32\nheight = 32\n[render]\nsamples = 4\n\
         max_bounces = 1\nfilter = \"box\"\n\
         [[light]]\ntype = \"directional\"\ndirection = [0.6, -0.3, -1.0]\nirradiance = 3.0\n\
         [[mesh]]\nobj = \"quad.gltf\"\n",
    )
}

const GLOSSY: &str = r#""pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0],
    "metallicFactor": 0.0, "roughnessFactor": 0.5}"#;

/// A normal map whose x and y are scaled to 0 (normalTexture.scale = 0) maps every texel to (0, 0, 1):
/// the shading normal stays the quad's, and the image has the same bits as without the map.
#[test]
fn gltf_flat_normal_map_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    write_textured_quad(
        dir.path(),
        &format!("{{{GLOSSY}}}"),
        &[flat(1, 1, [90, 200, 255])],
    );
    let plain = common::render(&sunlit_quad_scene(dir.path()));
    write_textured_quad(
        dir.path(),
        &format!(r#"{{{GLOSSY}, "normalTexture": {{"index": 0, "scale": 0.0}}}}"#),
        &[flat(1, 1, [90, 200, 255])],
    );
    let scene = sunlit_quad_scene(dir.path());
    assert!(scene.meshes[0].maps.normal.is_some());
    let mapped = common::render(&scene);
    assert!(plain.average() > 0.0);
    assert_eq!(plain.mean, mapped.mean);
}

/// A constant normal map tilted towards +x renders like the quad turned so that its geometric normal is
/// the mapped one: m = 2 t - 1 decoded here from the texel, the quad rotated by the quaternion that takes
/// +z to m / |m| (glTF node rotation, (z x u, 1 + z.u) normalised). The tangent frame is the uv
/// directions: +x (u) and +y (v up). Two maps: tilted towards +x (its y is 1/255, G = 128, not 0, and
/// counts as well), and towards -y.
#[test]
fn gltf_tilted_normal_map_renders_like_a_tilted_quad() {
    // Towards +x (u), and towards -y (v down: the bitangent's side).
    for texel in [[210u8, 128, 220], [128, 40, 220]] {
        let m = texel.map(|c| 2.0 * f64::from(c) / 255.0 - 1.0);
        let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        let u = m.map(|c| c / len);
        let dir = tempfile::tempdir().unwrap();
        write_textured_quad(
            dir.path(),
            &format!(r#"{{{GLOSSY}, "normalTexture": {{"index": 0}}}}"#),
            &[flat(1, 1, texel)],
        );
        let mapped = common::render(&sunlit_quad_scene(dir.path()));
        // z x u = (-u.y, u.x, 0); w = 1 + u.z.
        let q = [-u[1], u[0], 0.0, 1.0 + u[2]];
        let qn = (q.iter().map(|c| c * c).sum::<f64>()).sqrt();
        let q = q.map(|c| c / qn);
        write_textured_quad(dir.path(), &format!("{{{GLOSSY}}}"), &[flat(1, 1, texel)]);
        let json = std::fs::read_to_string(dir.path().join("quad.gltf")).unwrap();
        let turned = json.replace(
            r#""nodes": [{"mesh": 0}]"#,
            &format!(
                r#""nodes": [{{"mesh": 0, "rotation": [{}, {}, {}, {}]}}]"#,
                q[0], q[1], q[2], q[3]
            ),
        );
        assert_ne!(json, turned);
        std::fs::write(dir.path().join("quad.gltf"), turned).unwrap();
        let tilted = common::render(&sunlit_quad_scene(dir.path()));
        // The turned quad is narrower on screen: compare the middle of the image, which both cover.
        let a = region(&mapped, 10..=21, 10..=21);
        let b = region(&tilted, 10..=21, 10..=21);
        let flat_quad = {
            write_textured_quad(dir.path(), &format!("{{{GLOSSY}}}"), &[flat(1, 1, texel)]);
            region(
                &common::render(&sunlit_quad_scene(dir.path())),
                10..=21,
                10..=21,
            )
        };
        for k in 0..3 {
            println!(
                "channel {k}: normal map {:.6}, tilted quad {:.6}, flat quad {:.6}",
                a[k].0, b[k].0, flat_quad[k].0
            );
            assert!(
                (a[k].0 - b[k].0).abs() <= 1e-4 * b[k].0,
                "channel {k}: {} vs {}",
                a[k].0,
                b[k].0
            );
            // The tilt matters: the flat quad is far from both.
            assert!((flat_quad[k].0 - b[k].0).abs() > 0.05 * b[k].0);
        }
    }
}

/// The same maps on a TOML mesh (`emission_texture`, `metallic_roughness_texture`, `normal_map`,
/// `normal_scale`): an OBJ quad with them renders the bits of the glTF quad with the same textures and
/// factors (same positions, normals, uvs and materials); and each key is refused where it cannot apply.
#[test]
fn toml_mesh_maps_render_like_the_gltf_ones() {
    let dir = tempfile::tempdir().unwrap();
    let mr = image::RgbImage::from_fn(4, 4, |x, y| {
        image::Rgb([0, 60 * x as u8 + 10 * y as u8, 255])
    });
    let normals = flat(1, 1, [200, 100, 230]);
    write_textured_quad(
        dir.path(),
        r#"{"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 0.6, "metallicRoughnessTexture": {"index": 0}},
          "emissiveFactor": [0.5, 0.25, 0.125], "emissiveTexture": {"index": 1},
          "normalTexture": {"index": 2, "scale": 0.8}}"#,
        &[mr, flat(1, 1, [250, 128, 20]), normals],
    );
    let from_gltf = common::render(&sunlit_quad_scene(dir.path()));
    // The quad as an OBJ, with OBJ's v-up uvs (glTF's v flipped).
    std::fs::write(
        dir.path().join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n\
         f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n",
    )
    .unwrap();
    let mesh = "obj = \"quad.obj\"\nmaterial = \"m\"\nmetallic_roughness_texture = \"tex0.png\"\n\
        emission_texture = \"tex1.png\"\nnormal_map = \"tex2.png\"\nnormal_scale = 0.8\n";
    let toml = |mesh: &str, material: &str| {
        format!(
            "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\n\
             look_at = [0.0, 0.0, 0.0]\n[image]\nwidth = 32\nheight = 32\n[render]\nsamples = 4\n\
             max_bounces = 1\nfilter = \"box\"\n\
             [[light]]\ntype = \"directional\"\ndirection = [0.6, -0.3, -1.0]\nirradiance = 3.0\n\
             [materials]\nm = {material}\n[[mesh]]\n{mesh}"
        )
    };
    let material = "{ type = \"metallic_roughness\", base_color = [0.8, 0.5, 0.3], metallic = 1.0, \
        roughness = 0.6, emission = [0.5, 0.25, 0.125] }";
    let from_toml = common::render(&load(dir.path(), &toml(mesh, material)));
    assert!(from_toml.average() > 0.0);
    assert_eq!(from_toml.mean, from_gltf.mean);

    let refused = |mesh: &str, material: &str, key: &str| {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, toml(mesh, material)).unwrap();
        let err = Scene::load(&path).expect_err(key);
        assert_eq!(err.key(), Some(key), "{err}");
    };
    let diffuse = "{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }";
    refused(mesh, diffuse, "mesh[0].emission_texture");
    refused(
        "obj = \"quad.obj\"\nmaterial = \"m\"\nmetallic_roughness_texture = \"tex0.png\"\n",
        diffuse,
        "mesh[0].metallic_roughness_texture",
    );
    refused(
        "obj = \"quad.obj\"\nmaterial = \"m\"\nnormal_scale = 2.0\n",
        diffuse,
        "mesh[0].normal_scale",
    );
    refused(
        "obj = \"quad.obj\"\nnormal_map = \"tex2.png\"\n",
        diffuse,
        "mesh[0].normal_map",
    );
}

/// Issue 31: a node graph that is not a tree is refused, naming a node, for a glTF scene and a glTF
/// `[[mesh]]` alike, instead of walked: 64 nodes each listing the next one twice (2^64 paths: it used to
/// run for ever), a cycle, and a root listed twice. A tree of the same nodes still loads.
#[test]
fn a_gltf_node_graph_that_is_not_a_tree_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = |children: &dyn Fn(usize) -> String| {
        (0..64)
            .map(|i| format!("{{\"children\": [{}]}}", children(i)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let gltf = |roots: &str, nodes: String| {
        format!(
            "{{\"asset\": {{\"version\": \"2.0\"}}, \"scene\": 0, \"scenes\": [{{\"nodes\": [{roots}]}}], \
             \"nodes\": [{nodes}]}}"
        )
    };
    let next = |i: usize| {
        if i < 63 {
            format!("{}", i + 1)
        } else {
            String::new()
        }
    };
    let cases = [
        (
            gltf(
                "0",
                nodes(&|i| {
                    if i < 63 {
                        format!("{0}, {0}", i + 1)
                    } else {
                        String::new()
                    }
                }),
            ),
            "node 1 is a child of node 0 and of node 0",
        ),
        // A cycle through every node: each has one parent, and the walk meets node 0 again.
        (
            gltf("0", nodes(&|i| format!("{}", (i + 1) % 64))),
            "node 0 is reached twice",
        ),
        (gltf("0, 0", nodes(&next)), "node 0 is reached twice"),
        // A cycle back into the chain: 0 -> 1 -> ... -> 63 -> 1 (node 1 has two parents).
        (
            gltf(
                "0",
                nodes(&|i| {
                    if i < 63 {
                        format!("{}", i + 1)
                    } else {
                        "1".into()
                    }
                }),
            ),
            "node 1 is a child of node 0 and of node 63",
        ),
    ];
    for (json, want) in &cases {
        std::fs::write(dir.path().join("g.gltf"), json).unwrap();
        let started = std::time::Instant::now();
        let as_scene = Scene::load(&dir.path().join("g.gltf")).expect_err("not a tree");
        let as_mesh = Scene::load(&common::cli::write(
            dir.path(),
            "s.toml",
            &format!("{HEAD}[[mesh]]\nobj = \"g.gltf\"\n"),
        ))
        .expect_err("not a tree");
        for e in [as_scene.to_string(), as_mesh.to_string()] {
            assert!(e.contains(want) && e.contains("g.gltf"), "{e}");
        }
        // Refused from the node lists alone, not by walking paths (generous: it is microseconds).
        assert!(started.elapsed().as_secs() < 10);
    }
    // The chain as a tree is walked (and then refused for what it lacks: any geometry).
    std::fs::write(dir.path().join("g.gltf"), gltf("0", nodes(&next))).unwrap();
    let e =
        Scene::load(&dir.path().join("g.gltf")).map_or_else(|e| e.to_string(), |_| String::new());
    assert!(!e.contains("tree"), "{e}");
}

/// Issue 31: accessors that lie are refused, naming the primitive and the accessor, both as a glTF
/// scene and as a TOML `[[mesh]]`: 7 u16 indices in a 12-byte view (the reader stopped at the view's
/// end and a quad rendered half missing, exit 0), a view past its buffer, a byteStride shorter than an
/// element, positions of the wrong type, an index count that is not a multiple of 3.
#[test]
fn gltf_accessors_that_lie_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let positions = f32s(QUAD.as_flattened());
    let indices: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let bin = [positions.clone(), indices].concat();
    std::fs::write(dir.path().join("q.bin"), &bin).unwrap();
    let gltf = |views: &str, accessors: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0.5, 0.5, 3]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "znear": 0.1}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"metallicFactor": 0}}}}],
  "buffers": [{{"uri": "q.bin", "byteLength": {}}}],
  "bufferViews": [{views}],
  "accessors": [{accessors}]}}"#,
            bin.len()
        )
    };
    let good_views = r#"{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}"#;
    let position = r#"{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#;
    let index = |count: usize| {
        format!(r#"{{"bufferView": 1, "componentType": 5123, "count": {count}, "type": "SCALAR"}}"#)
    };
    // The honest file loads: two triangles.
    std::fs::write(
        dir.path().join("q.gltf"),
        gltf(good_views, &format!("{position}, {}", index(6))),
    )
    .unwrap();
    assert_eq!(
        Scene::load(&dir.path().join("q.gltf")).unwrap().meshes[0]
            .triangles
            .len(),
        2
    );
    let cases = [
        (
            gltf(good_views, &format!("{position}, {}", index(7))),
            "meshes[0].primitives[0].indices (accessors[1]): 7 elements of 2 bytes (stride 2) from byte 0 need 14 bytes of bufferViews[1], which holds 12",
        ),
        (
            gltf(
                r#"{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 24}"#,
                &format!("{position}, {}", index(6)),
            ),
            "bufferViews[1] (bytes 48 to 72) runs past the end of buffers[0] (60 bytes)",
        ),
        (
            gltf(
                r#"{"buffer": 0, "byteOffset": 0, "byteLength": 48, "byteStride": 4}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}"#,
                &format!("{position}, {}", index(6)),
            ),
            "byteStride 4 is less than an element (12 bytes)",
        ),
        (
            gltf(
                good_views,
                &format!("{}, {}", position.replace("5126", "5123"), index(6)),
            ),
            "attributes.POSITION (accessors[0]) is Vec3 of U16",
        ),
        (
            gltf(good_views, &format!("{position}, {}", index(5))),
            "meshes[0].primitives[0] is TRIANGLES with 5 indices",
        ),
        // Three normals for four positions: the normals used to be dropped in silence.
        (
            gltf(
                good_views,
                &format!(
                    r#"{position}, {}, {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}}"#,
                    index(6)
                ),
            )
            .replace(r#"{"POSITION": 0}"#, r#"{"POSITION": 0, "NORMAL": 2}"#),
            "attributes.NORMAL (accessors[2]) has 3 elements and meshes[0].primitives[0].attributes.POSITION (accessors[0]) 4",
        ),
    ];
    for (json, want) in &cases {
        std::fs::write(dir.path().join("q.gltf"), json).unwrap();
        let as_scene = Scene::load(&dir.path().join("q.gltf"))
            .expect_err("a lying accessor")
            .to_string();
        let as_mesh = Scene::load(&common::cli::write(
            dir.path(),
            "s.toml",
            &format!("{HEAD}[[mesh]]\nobj = \"q.gltf\"\n"),
        ))
        .expect_err("a lying accessor")
        .to_string();
        for e in [&as_scene, &as_mesh] {
            assert!(e.contains(want), "{want}: {e}");
        }
        // The glTF scene's refusal names the glTF element, not a line of the TOML made of it.
        assert!(
            as_scene.starts_with(&format!(
                "{}, key meshes:",
                dir.path().join("q.gltf").display()
            )) && !as_scene.contains("line"),
            "{as_scene}"
        );
        assert!(
            as_mesh.contains("s.toml, line 15, key mesh[0].obj"),
            "{as_mesh}"
        );
    }
    // A camera the TOML reader refuses is named as the glTF camera.
    std::fs::write(
        dir.path().join("q.gltf"),
        gltf(good_views, &format!("{position}, {}", index(6))).replace(
            "\"translation\": [0.5, 0.5, 3]",
            "\"translation\": [0.5, 0.5, 3], \"scale\": [0, 0, 0]",
        ),
    )
    .unwrap();
    let e = Scene::load(&dir.path().join("q.gltf"))
        .expect_err("a camera scaled to a point looks nowhere")
        .to_string();
    assert!(e.contains("key cameras[0]") && !e.contains("line"), "{e}");
}

/// Fragments of glTF JSON for the fuzzer to insert: references, counts, strides and offsets (the
/// values its checks are about), node graphs that are not trees, data URIs.
/// (With [`common::fuzz::JSON_STRUCTURE`].)
const GLTF_TOKENS: &[&str] = &[
    "\"children\": [0, 0]",
    "\"children\": [1]",
    "\"nodes\": [0, 0]",
    "\"bufferView\": 99",
    "\"byteStride\": 1",
    "\"byteOffset\": 4294967295",
    "\"count\": 0",
    "\"count\": 4294967295",
    "\"componentType\": 5121",
    "\"type\": \"MAT4\"",
    "\"mode\": 0",
    "\"matrix\": [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]",
    "\"scale\": [1e30, 0, -1]",
    "\"uri\": \"data:application/octet-stream;base64,AAAA\"",
    "\"uri\": \"../../../etc/passwd\"",
    "\"sparse\": {\"count\": 1, \"indices\": {\"bufferView\": 3, \"componentType\": 5125}, \"values\": {\"bufferView\": 0}}",
];

/// A GLB (binary glTF 2.0: a 12-byte header, a JSON chunk, a BIN chunk) of one textured quad.
fn glb_seed() -> Vec<u8> {
    let bin = [
        f32s(QUAD.as_flattened()),
        f32s(QUAD_UV.as_flattened()),
        u32s(&[0, 1, 2, 0, 2, 3]),
    ]
    .concat();
    let mut json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0, "scale": [2, 2, 2]}}, {{"camera": 0, "translation": [0.5, 0.5, 3]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "znear": 0.1}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"metallicFactor": 0, "baseColorFactor": [0.5, 0.5, 0.5, 1]}}}}],
  "buffers": [{{"byteLength": {}}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
                  {{"buffer": 0, "byteOffset": 80, "byteLength": 24}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
                {{"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}}]}}"#,
        bin.len()
    )
    .into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend((total as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    glb
}

/// The answer to one mutated glTF file, as a scene of its own and as a TOML `[[mesh]]`: a scene whose
/// meshes index their own vertices, all finite, or a one-paragraph refusal; never a panic or a hang.
fn check_gltf_answers(dir: &Path, name: &str) -> Result<(), TestCaseError> {
    let as_scene = dir.join(name);
    let toml = common::cli::write(
        dir,
        "m.toml",
        &format!("{HEAD}[[mesh]]\nobj = \"{name}\"\n"),
    );
    for path in [as_scene, toml] {
        let answer = common::fuzz::within_watchdog("a glTF file", move || {
            Scene::load(&path)
                .map(|s| {
                    s.meshes.iter().all(|m| {
                        let n = m.positions.len() as u32;
                        m.triangles.iter().flatten().all(|&i| i < n)
                            && m.positions.iter().all(|p| p.is_finite())
                            && m.material < s.materials.len() as u32
                    })
                })
                .map_err(|e| e.to_string())
        });
        match answer {
            Ok(consistent) => prop_assert!(consistent, "a mesh indexes past its vertices"),
            Err(text) => prop_assert!(!text.contains('\n'), "{}", text),
        }
    }
    Ok(())
}

#[test]
fn the_glb_seed_loads() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("q.glb"), glb_seed()).unwrap();
    let s = Scene::load(&dir.path().join("q.glb")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.meshes[0].triangles.len(), 2);
    assert!((s.meshes[0].positions[2] - Vec3::new(2.0, 2.0, 0.0)).length() < 1e-6);
}

proptest! {
    #![proptest_config(common::fuzz::config(3000))]

    /// glTF JSON (this file's scene, with its external buffer and texture) and GLB (one quad, its
    /// buffer in the file) mutated 1 to 6 times: every answer consistent or a refusal (issue 31).
    #[test]
    fn mutated_gltf_and_glb_files_never_panic(
        json_mutations in proptest::collection::vec(common::fuzz::mutation(), 1..7),
        glb_mutations in proptest::collection::vec(common::fuzz::mutation(), 1..7),
    ) {
        let dir = tempfile::tempdir().unwrap();
        write_gltf(dir.path());
        let tokens = [common::fuzz::JSON_STRUCTURE, GLTF_TOKENS].concat();
        let mut json = std::fs::read(dir.path().join("scene.gltf")).unwrap();
        for m in &json_mutations {
            common::fuzz::apply(&mut json, m, &tokens, common::fuzz::EXTREMES);
        }
        std::fs::write(dir.path().join("f.gltf"), &json).unwrap();
        check_gltf_answers(dir.path(), "f.gltf")?;
        let mut glb = glb_seed();
        for m in &glb_mutations {
            common::fuzz::apply(&mut glb, m, &tokens, common::fuzz::EXTREMES);
        }
        std::fs::write(dir.path().join("f.glb"), &glb).unwrap();
        check_gltf_answers(dir.path(), "f.glb")?;
    }
}

/// Regressions of the glTF fuzzer: files the `gltf` crate 1.4 panicked on (its validation indexes the
/// accessors by a POSITION index it has not checked; `Image::source` unwraps a missing mimeType or uri),
/// now refused with the element named, as a scene and as a `[[mesh]]`.
#[test]
fn gltf_files_the_gltf_crate_panicked_on_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = |meshes: &str, images: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{meshes}],
  "buffers": [{{"byteLength": 48, "uri": "data:application/octet-stream;base64,{}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 48}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}]
  {images}}}"#,
            "A".repeat(64)
        )
    };
    let mesh = r#"{"primitives": [{"attributes": {"POSITION": 0}}]}"#;
    // A GLB whose header gives a length shorter than the header (an overflow in the crate's debug
    // build).
    let mut glb = glb_seed();
    glb[8..12].copy_from_slice(&3u32.to_le_bytes());
    std::fs::write(dir.path().join("short.glb"), &glb).unwrap();
    let e = Scene::load(&dir.path().join("short.glb"))
        .expect_err("refused")
        .to_string();
    assert!(e.contains("a length of 3 bytes"), "{e}");
    for (json, want) in [
        (
            file(r#"{"primitives": [{"attributes": {"POSITION": 7}}]}"#, ""),
            "meshes[0].primitives[0].attributes.POSITION refers to accessors[7], and the file has 1",
        ),
        (
            file(mesh, r#", "images": [{"bufferView": 0}]"#),
            "images[0] has a bufferView and no mimeType",
        ),
        (
            file(mesh, r#", "images": [{}]"#),
            "images[0] has neither a uri nor a bufferView",
        ),
    ] {
        std::fs::write(dir.path().join("p.gltf"), &json).unwrap();
        let as_scene = Scene::load(&dir.path().join("p.gltf"))
            .expect_err("refused")
            .to_string();
        let as_mesh = Scene::load(&common::cli::write(
            dir.path(),
            "s.toml",
            &format!("{HEAD}[[mesh]]\nobj = \"p.gltf\"\n"),
        ))
        .expect_err("refused")
        .to_string();
        for e in [as_scene, as_mesh] {
            assert!(e.contains(want), "{want}: {e}");
        }
    }
}

/// Issue 31: a glTF buffer is read only from a regular file of bounded size, or a data URI: a uri naming
/// /dev/zero (read to its end, for ever, by the `gltf` crate's importer) or a percent-escape that is not
/// UTF-8 (a panic in it) is refused naming the buffer; a base64 data URI loads.
#[test]
fn gltf_buffers_are_files_or_data_uris() {
    let dir = tempfile::tempdir().unwrap();
    let bin = [f32s(QUAD.as_flattened()), u32s(&[0, 1, 2, 0, 2, 3])].concat();
    let file = |uri: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{}}],
  "buffers": [{{"byteLength": 72, "uri": "{uri}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 24}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5125, "count": 6, "type": "SCALAR"}}]}}"#
        )
    };
    let mesh = |uri: &str| {
        std::fs::write(dir.path().join("b.gltf"), file(uri)).unwrap();
        Scene::load(&common::cli::write(
            dir.path(),
            "s.toml",
            &format!("{HEAD}[[mesh]]\nobj = \"b.gltf\"\n"),
        ))
    };
    let data = format!(
        "data:application/octet-stream;base64,{}",
        base64::Engine::encode(&base64::engine::general_purpose::STANDARD, &bin)
    );
    assert_eq!(mesh(&data).unwrap().meshes[0].triangles.len(), 2);
    std::fs::write(dir.path().join("quad.bin"), &bin).unwrap();
    assert_eq!(mesh("quad.bin").unwrap().meshes[0].triangles.len(), 2);
    for (uri, want) in [
        (
            "/dev/zero",
            "buffers[0]: cannot read /dev/zero: it is not a regular file",
        ),
        ("%FF%FE.bin", "buffers[0]: cannot read"),
        ("missing.bin", "buffers[0]: cannot read"),
        ("http://example.com/q.bin", "is not a file or data URI"),
        ("data:application/octet-stream,AAAA", "not base64"),
    ] {
        let started = std::time::Instant::now();
        let e = mesh(uri).expect_err("refused").to_string();
        assert!(e.contains(want), "{uri}: {e}");
        assert!(started.elapsed().as_secs() < 10, "{uri}: bounded");
    }
    std::fs::write(dir.path().join("short.bin"), &bin[..40]).unwrap();
    let e = mesh("short.bin").expect_err("short").to_string();
    assert!(
        e.contains("holds 40 bytes, less than its byteLength 72"),
        "{e}"
    );
}

/// The Khronos PBR extensions (KHR_materials_ior, _specular, _transmission, _volume, _clearcoat,
/// _sheen) are read into the material's layers (bsdfs/gltf_pbr.wgsl; their shading is tested in
/// tests/bsdf_gltf.rs), the volume's absorption as -ln(attenuationColor) / attenuationDistance; a texture
/// an extension names is a warning (its factor is used alone), the volume's thicknessTexture a note (a
/// path tracer measures thickness), and an extension the file uses that vkpath does not read a warning
/// naming it.
#[test]
fn gltf_pbr_extensions_are_read_into_the_materials_layers() {
    let dir = tempfile::tempdir().unwrap();
    let material = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.25, "roughnessFactor": 0.5},
      "extensions": {
        "KHR_materials_ior": {"ior": 1.33},
        "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1, 0.5, 0.25]},
        "KHR_materials_transmission": {"transmissionFactor": 0.75},
        "KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationDistance": 2.0, "attenuationColor": [0.5, 0.25, 1.0], "thicknessTexture": {"index": 0}},
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.2, "clearcoatTexture": {"index": 0}},
        "KHR_materials_sheen": {"sheenColorFactor": [0.2, 0.3, 0.4], "sheenRoughnessFactor": 0.6}
      }}"#;
    write_textured_quad(dir.path(), material, &[flat(1, 1, [255, 255, 255])]);
    let path = dir.path().join("quad.gltf");
    let json = std::fs::read_to_string(&path).unwrap().replacen(
        r#""asset": {"version": "2.0"},"#,
        r#""asset": {"version": "2.0"}, "extensionsUsed": ["KHR_materials_ior", "KHR_materials_specular",
          "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_clearcoat",
          "KHR_materials_sheen", "KHR_materials_iridescence"],"#,
        1,
    );
    std::fs::write(&path, json).unwrap();
    let scene = quad_scene(dir.path(), 1.0, 1);
    let layers = scene
        .materials
        .iter()
        .find_map(|m| match m.bsdf {
            Bsdf::MetallicRoughness { layers, .. } => Some(layers),
            _ => None,
        })
        .expect("the quad's material");
    let want = vkpath::scene::GltfLayers {
        ior: 1.33,
        specular: 0.5,
        specular_color: Vec3::new(1.0, 0.5, 0.25),
        transmission: 0.75,
        volume: Some(Vec3::new(0.5f32.ln(), 0.25f32.ln(), 0.0) / -2.0),
        clearcoat: 1.0,
        clearcoat_roughness: 0.2,
        sheen_color: Vec3::new(0.2, 0.3, 0.4),
        sheen_roughness: 0.6,
    };
    assert_eq!(layers, want);
    let has = |text: &str, note: bool| {
        scene
            .warnings
            .iter()
            .any(|w| w.contains(text) && w.starts_with(vkpath::scene::NOTE) == note)
    };
    assert!(
        has(
            "KHR_materials_iridescence, which vkpath does not read",
            false
        ) && has(
            "KHR_materials_clearcoat's clearcoatTexture is not read",
            false
        ) && has("thicknessTexture is read past", true)
            && scene.warnings.len() == 3,
        "{:?}",
        scene.warnings
    );
}

/// Adds a TANGENT attribute, the same for the quad's four vertices, to the quad of
/// [`write_textured_quad`] (a second buffer, `tangent.bin`).
fn add_quad_tangents(dir: &Path, tangent: [f32; 4]) {
    std::fs::write(dir.join("tangent.bin"), f32s(&tangent.repeat(4))).unwrap();
    let path = dir.join("quad.gltf");
    let json = std::fs::read_to_string(&path).unwrap();
    let with = json
        .replacen(r#""TEXCOORD_0": 2}"#, r#""TEXCOORD_0": 2, "TANGENT": 4}"#, 1)
        .replacen(
            r#"{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}"#,
            r#"{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"},
    {"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC4"}"#,
            1,
        )
        .replacen(
            r#"{"buffer": 0, "byteOffset": 128, "byteLength": 24}"#,
            r#"{"buffer": 0, "byteOffset": 128, "byteLength": 24},
    {"buffer": 1, "byteOffset": 0, "byteLength": 64}"#,
            1,
        )
        .replacen(
            r#""buffers": [{"uri": "quad.bin", "byteLength": 152}]"#,
            r#""buffers": [{"uri": "quad.bin", "byteLength": 152}, {"uri": "tangent.bin", "byteLength": 64}]"#,
            1,
        );
    assert_eq!(with.matches("tangent.bin").count(), 1, "the fixture moved");
    std::fs::write(path, with).unwrap();
}

/// Normal maps with the file's tangents (glTF's TANGENT) and without (MikkTSpace's, which glTF asks
/// clients to generate: glTF 2.0 §3.7.2.1). On the quad, whose u runs along +x and v up along +y, the
/// supplied TANGENT (1, 0, 0, +1) (B = w N x T = +y) is what MikkTSpace generates: the same image, bit
/// for bit. A TANGENT of (0, 1, 0, -1) (T = +y, B = -(z x y) = +x) swaps the map's axes: the texel
/// (210, 128, 220) then renders like (128, 210, 220) with the generated frame (within f32 rounding of
/// the two frames' sums), and far from its own image with the generated frame.
#[test]
fn gltf_tangents_given_or_generated_orient_the_normal_map() {
    let dir = tempfile::tempdir().unwrap();
    let material = format!(r#"{{{GLOSSY}, "normalTexture": {{"index": 0}}}}"#);
    let render = |texel: [u8; 3], tangent: Option<[f32; 4]>| {
        write_textured_quad(dir.path(), &material, &[flat(1, 1, texel)]);
        if let Some(t) = tangent {
            add_quad_tangents(dir.path(), t);
        }
        let scene = sunlit_quad_scene(dir.path());
        assert_eq!(
            scene.meshes[0].tangents.len(),
            4,
            "tangents given ({tangent:?}) or generated"
        );
        common::render(&scene)
    };
    let generated = render([210, 128, 220], None);
    let given = render([210, 128, 220], Some([1.0, 0.0, 0.0, 1.0]));
    assert_eq!(generated.mean, given.mean);
    let swapped = render([210, 128, 220], Some([0.0, 1.0, 0.0, -1.0]));
    let reference = render([128, 210, 220], None);
    let (a, b, c) = (
        region(&swapped, 4..=27, 4..=27),
        region(&reference, 4..=27, 4..=27),
        region(&generated, 4..=27, 4..=27),
    );
    for k in 0..3 {
        assert!(
            (a[k].0 - b[k].0).abs() <= 1e-4 * b[k].0,
            "channel {k}: TANGENT (0, 1, 0, -1) {} vs the swapped texel {}",
            a[k].0,
            b[k].0
        );
        assert!((a[k].0 - c[k].0).abs() > 0.05 * c[k].0, "channel {k}");
    }
}

/// A replica of Khronos' TextureCoordinateTest (its layout, not its files): four quads facing -z, each
/// showing a 0.4 x 0.4 corner of one texture (glTF uv: "TopLeft" reads u, v in [0, 0.4], v running down
/// the image), placed where its name says for a viewer looking from -z (+y up, so screen right is -x),
/// emissive (black base, emission = the texture), nearest filtering. The texture's four corner blocks
/// have four colours: each quad must show its own corner's colour, exactly (sRGB-decoded), in the screen
/// quadrant its name gives: a v not flipped, or u and v swapped, would put another corner's colour there.
#[test]
fn gltf_texture_coordinates_follow_the_specification_corner_by_corner() {
    let dir = tempfile::tempdir().unwrap();
    // 10 x 10 texels: 4 x 4 corner blocks (top-left red, top-right green, bottom-left blue, bottom-right
    // yellow; image rows from the top), grey between.
    let colour = |x: u32, y: u32| match (x < 4, x >= 6, y < 4, y >= 6) {
        (true, _, true, _) => [200, 30, 30],
        (_, true, true, _) => [30, 200, 30],
        (true, _, _, true) => [30, 30, 200],
        (_, true, _, true) => [220, 220, 40],
        _ => [128, 128, 128],
    };
    image::RgbImage::from_fn(10, 10, |x, y| image::Rgb(colour(x, y)))
        .save(dir.path().join("uv.png"))
        .unwrap();
    // (name, uv origin (u0, v0), screen origin of the quad's top-left corner (sx, sy)); screen x = -x.
    let quads = [
        ("TopLeft", (0.0, 0.0), (-1.2, 1.2), [200u8, 30, 30]),
        ("TopRight", (0.6, 0.0), (0.2, 1.2), [30, 200, 30]),
        ("BottomLeft", (0.0, 0.6), (-1.2, -0.2), [30, 30, 200]),
        ("BottomRight", (0.6, 0.6), (0.2, -0.2), [220, 220, 40]),
    ];
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut indices = Vec::new();
    for (k, (_, (u0, v0), (sx, sy), _)) in quads.iter().enumerate() {
        // Corners in uv order (0,0), (1,0), (1,1), (0,1) of the 0.4 block; 1 unit of screen per 0.4 of uv.
        for (du, dv) in [(0.0, 0.0), (0.4, 0.0), (0.4, 0.4), (0.0, 0.4)] {
            let (screen_x, screen_y) = (sx + du * 2.5, sy - dv * 2.5);
            positions.extend([-screen_x, screen_y, 0.0f32]);
            uvs.extend([u0 + du, v0 + dv]);
        }
        let b = 4 * k as u32;
        // Counter-clockwise seen from -z (the quads' front).
        indices.extend([b, b + 2, b + 1, b, b + 3, b + 2]);
    }
    let mut bin = f32s(&positions);
    bin.extend(f32s(&[0.0, 0.0, -1.0].repeat(16)));
    bin.extend(f32s(&uvs));
    bin.extend(u32s(&indices));
    std::fs::write(dir.path().join("uv.bin"), &bin).unwrap();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}},
    "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0}}, "doubleSided": true}}],
  "samplers": [{{"magFilter": 9728, "minFilter": 9728}}],
  "textures": [{{"source": 0, "sampler": 0}}],
  "images": [{{"uri": "uv.png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 16, "type": "VEC3", "min": [-1.3, -1.2, 0], "max": [1.2, 1.2, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 16, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 16, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5125, "count": 24, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 192}},
    {{"buffer": 0, "byteOffset": 192, "byteLength": 192}},
    {{"buffer": 0, "byteOffset": 384, "byteLength": 128}},
    {{"buffer": 0, "byteOffset": 512, "byteLength": 96}}
  ],
  "buffers": [{{"uri": "uv.bin", "byteLength": {}}}]
}}"#,
        bin.len()
    );
    std::fs::write(dir.path().join("uv.gltf"), json).unwrap();
    // Looking from -z at the origin, +y up: 48 x 48 pixels over [-1.5, 1.5]^2 of screen.
    let scene = load(
        dir.path(),
        "[camera]\ntype = \"orthographic\"\nextent = 3.0\nposition = [0.0, 0.0, -5.0]\n\
         look_at = [0.0, 0.0, 0.0]\n[image]\nwidth = 48\nheight = 48\n[render]\nsamples = 1\n\
         max_bounces = 0\nfilter = \"box\"\n[[mesh]]\nobj = \"uv.gltf\"\n",
    );
    let film = common::render(&scene);
    // Pixel (px, py) from the top-left covers screen x in -1.5 + px / 16 .. +1/16, y from 1.5 down.
    for (name, _, (sx, sy), texel) in quads {
        let px0 = ((sx + 1.5) * 16.0) as usize + 2;
        let py0 = ((1.5 - sy) * 16.0) as usize + 2;
        let got = region(&film, px0..=px0 + 11, py0..=py0 + 11);
        for k in 0..3 {
            let want = srgb_decode(texel[k]);
            assert!(
                (got[k].0 - want).abs() < 1e-4,
                "{name}, channel {k}: {} where the texture's corner is {want}",
                got[k].0
            );
        }
    }
}

/// TEXCOORD_1 where the material's textures ask for it: the quad of [`write_textured_quad`] with its
/// proper uvs as TEXCOORD_1 and a scrambled TEXCOORD_0 (the normals' floats read as pairs) renders, with
/// the base colour texture on texCoord 1, the bits of the plain quad; on texCoord 0, another image. A
/// material whose textures read different sets reads them all at TEXCOORD_0, with a note.
#[test]
fn gltf_textures_read_the_texture_coordinate_set_they_name() {
    let dir = tempfile::tempdir().unwrap();
    let texture = image::RgbImage::from_fn(2, 2, |x, y| {
        image::Rgb([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]][(2 * y + x) as usize])
    });
    let material = |set: u32| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "texCoord": {set}}},
               "metallicFactor": 0.0, "roughnessFactor": 1.0}}}}"#
        )
    };
    write_textured_quad(dir.path(), &material(0), std::slice::from_ref(&texture));
    let plain = common::render(&quad_scene(dir.path(), 1.0, 4));
    let scramble = |dir: &Path| {
        let path = dir.join("quad.gltf");
        let json = std::fs::read_to_string(&path).unwrap();
        let two = json
            .replacen(
                r#""TEXCOORD_0": 2}"#,
                r#""TEXCOORD_0": 4, "TEXCOORD_1": 2}"#,
                1,
            )
            .replacen(
                r#"{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}"#,
                r#"{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"},
    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}"#,
                1,
            );
        assert_ne!(two, json);
        std::fs::write(path, two).unwrap();
    };
    write_textured_quad(dir.path(), &material(1), std::slice::from_ref(&texture));
    scramble(dir.path());
    let scene = quad_scene(dir.path(), 1.0, 4);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(common::render(&scene).mean, plain.mean);
    write_textured_quad(dir.path(), &material(0), std::slice::from_ref(&texture));
    scramble(dir.path());
    assert_ne!(
        common::render(&quad_scene(dir.path(), 1.0, 4)).mean,
        plain.mean
    );
    // Mixed sets: the emissive texture on 1, the base colour on 0.
    write_textured_quad(
        dir.path(),
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "emissiveFactor": [1, 1, 1],
            "emissiveTexture": {"index": 0, "texCoord": 1}}"#,
        std::slice::from_ref(&texture),
    );
    scramble(dir.path());
    let scene = quad_scene(dir.path(), 1.0, 4);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("emissive texture uses TEXCOORD_1, the others TEXCOORD_0")),
        "{:?}",
        scene.warnings
    );
}

// ----- Nodes sharing a mesh -----

/// Writes `name` (with `name`.bin) into `dir`: a ball (an icosphere of 320 triangles, radius 1, its
/// normals the sphere's) whose upper half is one primitive in material 0 (diffuse white) and lower half
/// another in material 1 (a glass that bounds a volume: KHR_materials_transmission and _volume, ior
/// 1.5), and a floor quad (y = -4, material 0). Five nodes under a translated parent place the ball:
/// scaled, mirrored in x, scaled non-uniformly, rotated and mirrored in y, and by a general matrix. With
/// `shared`, the five nodes name one mesh; otherwise each names its own copy of it (the same
/// primitives), which the reader flattens into the file's space.
fn write_balls_gltf(dir: &Path, name: &str, shared: bool) {
    let ball = vkpath::scene::shapes::icosphere(2);
    let (mut upper, mut lower) = (Vec::new(), Vec::new());
    for t in &ball.triangles {
        let y: f32 = t.iter().map(|&v| ball.positions[v as usize].y).sum();
        if y > 0.0 { &mut upper } else { &mut lower }.extend_from_slice(t);
    }
    let positions: Vec<f32> = ball.positions.iter().flat_map(|p| p.to_array()).collect();
    let normals: Vec<f32> = ball.normals.iter().flat_map(|n| n.to_array()).collect();
    let floor = [
        -12.0, -4.0, -6.0, -12.0, -4.0, 6.0, 12.0, -4.0, 6.0, 12.0, -4.0, -6.0,
    ];
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for bytes in [
        f32s(&positions),
        f32s(&normals),
        u32s(&upper),
        u32s(&lower),
        f32s(&floor),
        f32s(&[0.0, 1.0, 0.0].repeat(4)),
        u32s(&[0, 1, 2, 0, 2, 3]),
    ] {
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend(bytes);
    }
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let n = ball.positions.len();
    let ball_mesh = r#"{"primitives": [
      {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0},
      {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 3, "material": 1}]}"#;
    let floor_mesh = r#"{"primitives": [
      {"attributes": {"POSITION": 4, "NORMAL": 5}, "indices": 6, "material": 0}]}"#;
    let mut meshes = vec![ball_mesh; if shared { 1 } else { 5 }];
    meshes.push(floor_mesh);
    let ball_of = |k: usize| if shared { 0 } else { k };
    let (c, s) = (
        15f32.to_radians().cos(),
        15f32.to_radians().sin(), // a quaternion for 30 degrees about z
    );
    let nodes = [
        format!(
            r#"{{"translation": [-8, 0, 0], "scale": [2, 2, 2], "mesh": {}}}"#,
            ball_of(0)
        ),
        format!(
            r#"{{"translation": [-3, 0, 0], "scale": [-2, 2, 2], "mesh": {}}}"#,
            ball_of(1)
        ),
        format!(
            r#"{{"translation": [2, 0, 0], "scale": [2.5, 1.2, 2], "mesh": {}}}"#,
            ball_of(2)
        ),
        format!(
            r#"{{"translation": [7, 0, 0], "rotation": [0, 0, {s}, {c}], "scale": [2, -2, 2], "mesh": {}}}"#,
            ball_of(3)
        ),
        // Column-major, as glTF writes matrices.
        format!(
            r#"{{"matrix": [1.7, 0.5, -0.3, 0, -0.4, 1.9, 0.6, 0, 0.3, -0.2, 2.1, 0, 0, 3, 0, 1], "mesh": {}}}"#,
            ball_of(4)
        ),
        format!(r#"{{"mesh": {}}}"#, meshes.len() - 1),
    ];
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior"],
  "scenes": [{{"nodes": [0, 6]}}],
  "nodes": [{{"translation": [0, -1, 0], "children": [1, 2, 3, 4, 5]}}, {}],
  "meshes": [{}],
  "materials": [
    {{"name": "white", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1],
      "metallicFactor": 0, "roughnessFactor": 1}}}},
    {{"name": "glass", "pbrMetallicRoughness": {{"metallicFactor": 0, "roughnessFactor": 0}},
      "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}},
        "KHR_materials_volume": {{"thicknessFactor": 1}}, "KHR_materials_ior": {{"ior": 1.5}}}}}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": {n}, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]}},
    {{"bufferView": 1, "componentType": 5126, "count": {n}, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5125, "count": {}, "type": "SCALAR"}},
    {{"bufferView": 3, "componentType": 5125, "count": {}, "type": "SCALAR"}},
    {{"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-12, -4, -6], "max": [12, -4, 6]}},
    {{"bufferView": 5, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 6, "componentType": 5125, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [{}],
  "buffers": [{{"uri": "{name}.bin", "byteLength": {}}}]
}}"#,
        nodes.join(", "),
        meshes.join(", "),
        upper.len(),
        lower.len(),
        views.join(", "),
        bin.len()
    );
    std::fs::write(dir.join(format!("{name}.gltf")), json).unwrap();
}

/// glTF nodes that share a mesh place one copy of it (`Scene::instanced`, the two-level BVH), and an
/// `[[instance]]` of the file places each node once more (instance x node): the ball of
/// `write_balls_gltf` under five nodes (mirrors, a non-uniform scale, a general matrix), the file placed
/// by a `[[mesh]]` and by an `[[instance]]` that mirrors it, renders as the same file whose nodes each
/// name their own copy of the mesh, which the reader flattens (placed by two `[[mesh]]` tables).
/// Expected: the same image up to the rounding of the vertices (the kernel maps them in f32 with each
/// placement's matrix, the flattened file in f32 by each node's and the table's in f64), as for TOML
/// instances (tests/mesh.rs): measured 3e-8 relative. The glass halves refract into a volume: a
/// placement or node that mirrors must keep their fronts outside (glTF 2.0 §3.7.2.1: a negative
/// determinant turns the winding; with the reader's re-winding of mirrored nodes removed, 0.038). Shaded
/// flat: a shared mesh's smooth normals are interpolated in its own space and then mapped (as pbrt-v4's
/// TransformedPrimitive and Mitsuba's instances do), a flattened node's are mapped per vertex and then
/// interpolated, which under a non-uniform map differ (measured 8e-4 relative here, smooth). The same
/// `[[instance]]` in a plain material of its own shares the copies too (its placements carry the
/// material) and renders as the flattened file placed in that material.
#[test]
fn gltf_nodes_sharing_a_mesh_place_one_copy_and_render_as_copies() {
    let dir = tempfile::tempdir().unwrap();
    write_balls_gltf(dir.path(), "shared", true);
    write_balls_gltf(dir.path(), "flat", false);
    let head = "[camera]\nposition = [0, 0, 40]\nlook_at = [0, 0, 0]\nfov = 50\n\
        [image]\nwidth = 96\nheight = 64\n[render]\nmax_bounces = 4\n\
        [environment]\nradiance = [0.1, 0.1, 0.1]\n\
        [[light]]\ntype = \"point\"\nposition = [0, 30, 40]\npower = 300000.0\n";
    let mirror_down = "matrix = [-1, 0, 0, 0,  0, 1, 0, -6,  0, 0, 1, 0,  0, 0, 0, 1]\n";
    let a = load(
        dir.path(),
        &format!(
            "{head}[[mesh]]\nobj = \"shared.gltf\"\nname = \"balls\"\nsmooth = false\ntranslate = [0, 4, 0]\n\
             [[instance]]\nmesh = \"balls\"\n{mirror_down}"
        ),
    );
    let b = load(
        dir.path(),
        &format!(
            "{head}[[mesh]]\nobj = \"flat.gltf\"\nsmooth = false\ntranslate = [0, 4, 0]\n\
             [[mesh]]\nobj = \"flat.gltf\"\nsmooth = false\n{mirror_down}"
        ),
    );
    // The ball: one copy (its two parts, 320 triangles), ten placements (five nodes, twice).
    let ball = a
        .instanced
        .iter()
        .find(|m| m.placements.len() == 10)
        .expect("the shared ball, placed ten times");
    assert_eq!(ball.parts.len(), 2);
    assert_eq!(
        ball.parts.iter().map(|p| p.triangles.len()).sum::<usize>(),
        320
    );
    // The floor (used by one node) is the file's own geometry: a copy for the [[mesh]], and the
    // [[instance]]'s placement of the named mesh's shared copy.
    assert_eq!(a.meshes.len(), 1);
    assert_eq!(a.meshes[0].triangles.len(), 2);
    assert_eq!(a.instanced.len(), 2);
    assert!(b.instanced.is_empty());
    assert_eq!(
        b.meshes.iter().map(|m| m.triangles.len()).sum::<usize>(),
        2 * (5 * 320 + 2)
    );
    let render = |s: &Scene| common::render_passes(s, &Default::default(), 1, 4);
    let (fa, fb) = (render(&a), render(&b));
    assert!(fb.average() > 0.0);
    let (relative, far) = common::render_distance(&fa, &fb);
    assert!(
        relative < 1e-4 && far < 0.005,
        "shared vs flattened nodes: relative difference {relative}, {far} of the pixels differ by > 1 %"
    );

    // The [[instance]] in a material of its own (plain red, and the file's parts have no textures):
    // its placements of the ball and of the floor share the copies too, each in red, and render as the
    // flattened file placed by a [[mesh]] in red.
    let red = "[materials]\nred = { type = \"diffuse\", albedo = [0.8, 0.1, 0.1] }\n";
    let c = load(
        dir.path(),
        &format!(
            "{head}{red}[[mesh]]\nobj = \"shared.gltf\"\nname = \"balls\"\nsmooth = false\ntranslate = [0, 4, 0]\n\
             [[instance]]\nmesh = \"balls\"\nmaterial = \"red\"\n{mirror_down}"
        ),
    );
    let d = load(
        dir.path(),
        &format!(
            "{head}{red}[[mesh]]\nobj = \"flat.gltf\"\nsmooth = false\ntranslate = [0, 4, 0]\n\
             [[mesh]]\nobj = \"flat.gltf\"\nsmooth = false\nmaterial = \"red\"\n{mirror_down}"
        ),
    );
    let red_index = c.material_names.iter().position(|n| n == "red").unwrap() as u32;
    assert_eq!(c.meshes.len(), 1, "only the [[mesh]]'s floor is a copy");
    assert_eq!(c.instanced.len(), 2);
    // The ball's ten placements (five nodes of the [[mesh]] in the file's materials, five of the
    // [[instance]] in red) and the floor's one (the [[instance]]'s, in red): (placements, in their own
    // materials, in red).
    let mut got: Vec<(usize, usize, usize)> = c
        .instanced
        .iter()
        .map(|m| {
            let count = |material: Option<u32>| {
                m.placements
                    .iter()
                    .filter(|p| p.material == material)
                    .count()
            };
            (m.placements.len(), count(None), count(Some(red_index)))
        })
        .collect();
    got.sort();
    assert_eq!(got, [(1, 0, 1), (10, 5, 5)]);
    let (fc, fd) = (render(&c), render(&d));
    let (relative, far) = common::render_distance(&fc, &fd);
    assert!(
        relative < 1e-4 && far < 0.005,
        "shared in red vs flattened in red: relative difference {relative}, {far} of the pixels differ by > 1 %"
    );
    assert!(
        common::render_distance(&fa, &fc).0 > 0.01,
        "the red instance shows"
    );
}

/// The quad of `write_textured_quad` (quad.gltf) in one emissive material (black base, emission 1 x
/// strength 2, KHR_materials_emissive_strength; one-sided as glTF's is), placed by `nodes`.
fn write_emissive_quads(dir: &Path, nodes: &[&str]) {
    let lamp = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1],
    "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}"#;
    write_quad(dir, Some(lamp), &[], nodes);
}

/// A node that mirrors keeps its triangles' front where the file's normals face (glTF 2.0 §3.7.2.1:
/// its winding turns clockwise): the emissive quad facing +z, mirrored in x by its node, still emits
/// towards +z, every pixel of it seen head on at exactly the emission (2; before the reader re-wound
/// mirrored nodes, 0). Two nodes sharing the emitting quad (one mirrored in y) are copies, each lit
/// where it lies; the same nodes sharing a quad in a material that does not emit share one copy.
#[test]
fn gltf_mirrored_nodes_keep_their_fronts_and_emitting_shared_meshes_are_copies() {
    let dir = tempfile::tempdir().unwrap();
    let toml = |material: &str| {
        format!(
            "[camera]\ntype = \"orthographic\"\nextent = 2.0\nposition = [0.0, 0.0, 5.0]\n\
             look_at = [0.0, 0.0, 0.0]\n[image]\nwidth = 32\nheight = 32\n[render]\nsamples = 4\n\
             max_bounces = 0\nfilter = \"box\"\n[materials]\ngrey = {{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }}\n\
             [[mesh]]\nobj = \"quad.gltf\"\n{material}"
        )
    };
    let lit = |film: &vkpath::Film, inside: &dyn Fn(usize, usize) -> bool| {
        for y in 0..32 {
            for x in 0..32 {
                let expected = if inside(x, y) { 2.0 } else { 0.0 };
                let got = film.mean[y * 32 + x];
                assert!(
                    got.iter().all(|&c| (c - expected).abs() < 1e-5),
                    "pixel ({x}, {y}): {got:?}, expected {expected}"
                );
            }
        }
    };
    write_emissive_quads(dir.path(), &[r#"{"scale": [-1, 1, 1], "mesh": 0}"#]);
    let one = load(dir.path(), &toml(""));
    assert_eq!(one.meshes.len(), 1);
    lit(
        &common::render_passes(&one, &Default::default(), 1, 4),
        &|_, _| true,
    );

    // Left half: the quad halved; right half: halved and mirrored in y (rows 8 to 23 lit).
    write_emissive_quads(
        dir.path(),
        &[
            r#"{"translation": [-0.5, 0, 0], "scale": [0.5, 0.5, 1], "mesh": 0}"#,
            r#"{"translation": [0.5, 0, 0], "scale": [0.5, -0.5, 1], "mesh": 0}"#,
        ],
    );
    let two = load(dir.path(), &toml(""));
    assert!(two.instanced.is_empty(), "an emitting mesh is copied");
    assert_eq!(two.meshes.len(), 2);
    lit(
        &common::render_passes(&two, &Default::default(), 1, 4),
        &|_, y| (8..24).contains(&y),
    );
    let grey = load(dir.path(), &toml("material = \"grey\"\n"));
    assert!(grey.meshes.is_empty());
    assert_eq!(grey.instanced.len(), 1);
    assert_eq!(grey.instanced[0].placements.len(), 2);
    assert_eq!(grey.instanced[0].parts[0].triangles.len(), 2);
}

/// A glTF file without materials (its primitives name none: glTF 2.0 §3.9.6's default material) loads
/// as a `[[mesh]]` without `material` and as a scene of its own, every primitive in vkpath's default for
/// primitives without a material (diffuse, albedo 0.8); an OBJ without materials still needs one.
#[test]
fn a_gltf_without_materials_takes_the_default() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(
        dir.path(),
        None,
        &[],
        &[r#"{"mesh": 0}"#, r#"{"translation": [3, 0, 0], "mesh": 0}"#],
    );
    let path = dir.path().join("quad.gltf");
    assert!(!std::fs::read_to_string(&path).unwrap().contains("material"));
    let check = |scene: &Scene| {
        assert!(!scene.meshes.is_empty() || !scene.instanced.is_empty());
        let used: Vec<u32> = scene
            .meshes
            .iter()
            .chain(scene.instanced.iter().flat_map(|m| m.parts.iter()))
            .map(|m| m.material)
            .collect();
        for m in used {
            assert!(scene.material_names[m as usize].ends_with("/default"));
            match &scene.materials[m as usize].bsdf {
                Bsdf::Diffuse { albedo } => assert_eq!(*albedo, Vec3::splat(0.8)),
                other => panic!("{other:?}"),
            }
        }
    };
    check(&load(
        dir.path(),
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[[mesh]]\nobj = \"quad.gltf\"\n",
    ));
    check(&Scene::load(&path).unwrap_or_else(|e| panic!("{e}")));
}

/// Issue 53: extension values their specifications require to be finite (KHR_texture_transform's
/// offset, scale, rotation) or positive (KHR_materials_volume's attenuationDistance) are refused naming
/// the element, read as a glTF scene or as a `[[mesh]]` (exit 2 from the binary); before, a rotation of
/// 1e300 rendered NaN samples and a distance of 0 was clamped with a warning.
#[test]
fn gltf_extension_values_out_of_range_are_refused_naming_the_element() {
    let img = image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]));
    let cases = [
        (
            r#""emissiveTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"rotation": 1e300}}}"#,
            "materials[0].emissiveTexture.extensions.KHR_texture_transform.rotation",
        ),
        (
            r#""emissiveTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 1e39]}}}"#,
            "KHR_texture_transform.offset",
        ),
        (
            r#""emissiveTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [1.0]}}}"#,
            "KHR_texture_transform.scale",
        ),
        (
            r#""extensions": {"KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationDistance": 0}}"#,
            "materials[0].extensions.KHR_materials_volume.attenuationDistance = 0",
        ),
        (
            r#""extensions": {"KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationDistance": -1}}"#,
            "attenuationDistance = -1",
        ),
    ];
    for (extra, needle) in cases {
        let dir = tempfile::tempdir().unwrap();
        write_textured_quad(
            dir.path(),
            &format!(
                r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}},
                   "emissiveFactor": [1.0, 1.0, 1.0], {extra}}}"#
            ),
            std::slice::from_ref(&img),
        );
        let path = dir.path().join("quad.gltf");
        let as_scene = Scene::load(&path).expect_err(needle).to_string();
        assert!(as_scene.contains(needle), "{as_scene}");
        let toml = dir.path().join("s.toml");
        std::fs::write(
            &toml,
            "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 40\n[[mesh]]\nobj = \"quad.gltf\"\n",
        )
        .unwrap();
        let as_mesh = Scene::load(&toml).expect_err(needle).to_string();
        assert!(
            as_mesh.contains(needle) && as_mesh.contains("mesh[0].obj"),
            "{as_mesh}"
        );
    }
}
