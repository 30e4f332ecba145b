//! `[[mesh]]` end to end: OBJ files and textures written to a temporary directory, loaded through the
//! scene parser and rendered on the device.
//!
//! - A closed mesh, seen from inside and from outside (with a light inside it), lets no ray through.
//! - A textured quad under a pinhole camera reproduces its texels (sRGB-decoded) and their bilinear mix.
//! - A finely tessellated sphere with smooth normals renders like the analytic sphere under a point light.
//! - OBJ and texture errors name the scene file, line and key, and the OBJ's own line.
//! - `scenes/mesh.toml`'s models are the ones this file generates.
//! - Instances: placements of one shared mesh (a two-level BVH) render as the same meshes written as
//!   copies, under any affine map (mirrors included) and where the placement's rounding matters.

mod common;

use common::cli::{run, write};
use glam::Vec3;
use std::path::Path;
use vkpath::kernel::features::FeatureSet;
use vkpath::kernel::upload::{GpuScene, params_for};
use vkpath::render::{
    LAVAPIPE_LOOP_BUDGET, RenderOptions, casts_per_dispatch, worst_case_loop_iterations,
};
use vkpath::scene::{Scene, SceneError, shapes};

fn load(dir: &Path, toml: &str) -> Scene {
    let path = write(dir, "scene.toml", toml);
    Scene::load(&path).unwrap_or_else(|e| panic!("scene should load: {e}"))
}

fn render(scene: &Scene, spp: u32) -> vkpath::Film {
    common::render_passes(scene, &RenderOptions::default(), 1, spp)
}

// ----- closed meshes -----

/// A camera inside a closed icosphere (black, opaque) with a white sky outside, and a camera outside it
/// with a light inside: with max_bounces = 0 a pixel is nonzero only if a camera ray went through the
/// mesh. Box-filtered jitter sends every ray through a different point, over edges and vertices alike.
#[test]
fn a_closed_mesh_leaks_no_rays_from_inside_or_outside() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "ico.obj", &shapes::icosphere(3).to_obj());
    let base = r#"
[image]
width = 48
height = 48
[render]
max_bounces = 0
filter = "box"
[materials]
black = { type = "diffuse", albedo = [0.0, 0.0, 0.0] }
[[mesh]]
obj = "ico.obj"
material = "black"
scale = 5.0
translate = [0.3, -0.2, 0.1]
"#;
    for (position, look_at) in [
        ("[0.3, -0.2, 0.1]", "[0, 0, -1]"),
        ("[0.3, -0.2, 0.1]", "[3, 2, 1]"),
        ("[2.5, 1.0, -2.0]", "[-3, 1, 4]"),
    ] {
        let toml = format!(
            "[camera]\nposition = {position}\nlook_at = {look_at}\nfov = 150\n{}",
            base.replace("max_bounces = 0", "max_bounces = 0\nbackground = [1, 1, 1]")
        );
        let film = render(&load(dir.path(), &toml), 16);
        let lit = film
            .mean
            .iter()
            .filter(|p| p.iter().any(|&c| c != 0.0))
            .count();
        assert_eq!(
            lit, 0,
            "camera at {position} inside: {lit} pixels see the sky"
        );
    }
    let outside = format!(
        "[camera]\nposition = [0, 0, 20]\nlook_at = [0.3, -0.2, 0.1]\nfov = 40\n{base}\
         [[light]]\ntype = \"sphere\"\ncenter = [0.3, -0.2, 0.1]\nradius = 2.0\npower = 1000.0\n"
    );
    let film = render(&load(dir.path(), &outside), 16);
    let lit = film
        .mean
        .iter()
        .filter(|p| p.iter().any(|&c| c != 0.0))
        .count();
    assert_eq!(lit, 0, "{lit} pixels see the light inside the closed mesh");
    // The same light with the mesh removed is visible: the test can see a leak.
    let open = outside
        .replace(
            "[[mesh]]",
            "[[sphere]]\ncenter = [0, 0, -100]\nradius = 1.0\nmaterial = \"black\"\n[[mesh]]",
        )
        .replace("scale = 5.0", "scale = 0.001");
    let film = render(&load(dir.path(), &open), 1);
    assert!(
        film.average() > 0.0,
        "without the mesh the light should show"
    );
}

// ----- textures -----

/// The sRGB decoding curve in f64 (IEC 61966-2-1).
fn srgb_to_linear(byte: u8) -> f64 {
    let c = byte as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A 4 x 4 texture on the quad [-1, 1]^2 (uv = ((x + 1)/2, (y + 1)/2)) facing a pinhole camera whose view
/// is exactly the quad. Under a uniform white sky with one bounce, a diffuse pixel's radiance is its
/// albedo exactly (beta = albedo, then the sky's 1), so each pixel must be its texel, decoded. At twice
/// the resolution the pixel centres fall a quarter texel from the texel centres: the bilinear mix, with
/// the texture repeated at the borders.
#[test]
fn a_textured_quad_reproduces_its_texels() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (4u32, 4u32);
    let texel = |x: u32, y: u32| -> [u8; 3] {
        [
            (x * 70 + y * 5) as u8,
            (255 - y * 60) as u8,
            ((x * 37 + y * 91) % 256) as u8,
        ]
    };
    let mut img = image::RgbImage::new(w, h);
    for (x, y, p) in img.enumerate_pixels_mut() {
        p.0 = texel(x, y);
    }
    img.save(dir.path().join("tex.png")).unwrap();
    let quad = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
    write(dir.path(), "quad.obj", quad);
    // tan(fov/2) = 1/2 at distance 2: the view spans x in [-1, 1].
    let fov = 2.0 * 0.5f64.atan().to_degrees();
    for size in [4u32, 8] {
        let toml = format!(
            r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
fov = {fov}
[image]
width = {size}
height = {size}
[render]
max_bounces = 1
filter = "none"
background = [1, 1, 1]
light_sampling = "none"
[materials]
paper = {{ type = "diffuse", albedo = [0.5, 0.5, 0.5] }}
[[mesh]]
obj = "quad.obj"
material = "paper"
texture = "tex.png"
"#
        );
        let scene = load(dir.path(), &toml);
        let film = render(&scene, 1);
        // The same quad as an emitter of radiance 2: the texture multiplies the emission.
        let lamp = toml.replace("background = [1, 1, 1]\n", "").replace(
            "paper = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }",
            "paper = { type = \"emitter\", radiance = [2, 2, 2] }",
        );
        let glowing = render(&load(dir.path(), &lamp), 1);
        let decoded = |x: i64, y: i64, c: usize| {
            let (x, y) = (x.rem_euclid(w as i64) as u32, y.rem_euclid(h as i64) as u32);
            srgb_to_linear(texel(x, y)[c])
        };
        for py in 0..size {
            for px in 0..size {
                // Continuous texel coordinates of the pixel centre (rows from the top, as the image).
                let tx = (px as f64 + 0.5) * w as f64 / size as f64 - 0.5;
                let ty = (py as f64 + 0.5) * h as f64 / size as f64 - 0.5;
                let (x0, y0) = (tx.floor(), ty.floor());
                let (fx, fy) = (tx - x0, ty - y0);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let got = film.pixel(px, py);
                for (c, &value) in got.iter().enumerate() {
                    let want = (1.0 - fx) * (1.0 - fy) * decoded(x0, y0, c)
                        + fx * (1.0 - fy) * decoded(x0 + 1, y0, c)
                        + (1.0 - fx) * fy * decoded(x0, y0 + 1, c)
                        + fx * fy * decoded(x0 + 1, y0 + 1, c);
                    assert!(
                        (value as f64 - want).abs() < 2e-5,
                        "{size}x{size}, pixel ({px}, {py}) channel {c}: {value} vs {want}"
                    );
                    let glow = glowing.pixel(px, py)[c] as f64;
                    assert!(
                        (glow - 2.0 * want).abs() < 4e-5,
                        "emitter {size}x{size}, pixel ({px}, {py}) channel {c}: {glow} vs {}",
                        2.0 * want
                    );
                }
            }
        }
    }
}

// ----- a tessellated sphere against the analytic one -----

/// Direct light only (max_bounces = 1) from a point light on a diffuse ball: the analytic sphere, and an
/// icosphere of 20,480 triangles with smooth normals in its place (the OBJ's own, and computed from the
/// faces of the same OBJ without them). Away from the silhouette and the terminator (where the polygonal
/// outline and its self-shadowing differ from the sphere by the tessellation's size), every pixel must
/// agree within 1%, and the smooth mesh must be closer to the sphere than the same mesh shaded flat.
#[test]
fn a_fine_sphere_mesh_matches_the_analytic_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let ball = shapes::icosphere(5);
    write(dir.path(), "ball.obj", &ball.to_obj());
    // The same positions without `vn` lines: smooth normals are then computed from the faces.
    let bare = shapes::Shape {
        normals: Vec::new(),
        ..ball
    };
    write(dir.path(), "bare.obj", &bare.to_obj());
    let head = r#"
[camera]
position = [0, 0, 40]
look_at = [0, 0, 0]
fov = 35
[image]
width = 64
height = 64
[render]
max_bounces = 1
filter = "none"
[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
[[light]]
type = "point"
position = [-20, 25, 30]
power = 50000.0
"#;
    let sphere = render(
        &load(
            dir.path(),
            &format!("{head}[[sphere]]\ncenter = [0, 0, 0]\nradius = 10\nmaterial = \"white\"\n"),
        ),
        1,
    );
    let mesh = |obj: &str, smooth: bool| {
        let toml = format!(
            "{head}[[mesh]]\nobj = \"{obj}\"\nmaterial = \"white\"\nscale = 10\nsmooth = {smooth}\n"
        );
        render(&load(dir.path(), &toml), 1)
    };
    let smooth = mesh("ball.obj", true);
    let computed = mesh("bare.obj", true);
    let flat = mesh("ball.obj", false);
    let (mut compared, mut worst_smooth, mut worst_computed, mut worst_flat) =
        (0, 0.0f64, 0.0f64, 0.0f64);
    let light = Vec3::new(-20.0, 25.0, 30.0);
    let tan = (17.5f32).to_radians().tan();
    for py in 0..64u32 {
        for px in 0..64u32 {
            // The analytic hit point of the pixel's centre ray, to select the pixels to compare.
            let sx = (px as f32 + 0.5 - 32.0) / 32.0 * tan;
            let sy = (32.0 - py as f32 - 0.5) / 32.0 * tan;
            let d = Vec3::new(sx, sy, -1.0).normalize();
            let o = Vec3::new(0.0, 0.0, 40.0);
            let b = o.dot(d);
            let disc = b * b - (o.length_squared() - 100.0);
            if disc <= 0.0 {
                continue;
            }
            let p = o + d * (-b - disc.sqrt());
            let n = p / 10.0;
            let cos_light = n.dot((light - p).normalize());
            let cos_view = n.dot(-d);
            if cos_light < 0.25 || cos_view < 0.35 {
                continue;
            }
            let want = sphere.pixel(px, py)[0] as f64;
            let rel = |f: &vkpath::Film| ((f.pixel(px, py)[0] as f64 - want) / want).abs();
            worst_smooth = worst_smooth.max(rel(&smooth));
            worst_computed = worst_computed.max(rel(&computed));
            worst_flat = worst_flat.max(rel(&flat));
            compared += 1;
        }
    }
    assert!(compared > 500, "only {compared} pixels compared");
    eprintln!(
        "worst relative difference from the sphere over {compared} pixels: smooth {worst_smooth:.2e}, \
         computed normals {worst_computed:.2e}, flat {worst_flat:.2e}"
    );
    assert!(
        worst_smooth < 0.01,
        "smooth mesh vs sphere: worst relative difference {worst_smooth}"
    );
    // Area-weighted face normals are not exactly radial on an icosphere (8.2e-3 measured).
    assert!(
        worst_computed < 0.015,
        "mesh with computed normals vs sphere: worst relative difference {worst_computed}"
    );
    assert!(
        worst_flat > 2.0 * worst_smooth,
        "flat shading ({worst_flat}) should be visibly further from the sphere than smooth ({worst_smooth})"
    );
}

// ----- the loop budget -----

/// A million-triangle mesh in the course's box (six wall spheres, a light): one ray cast fits lavapipe's
/// loop budget many times over, whatever the triangles (the BVH walk is capped), so that paths of any
/// length fit, a dispatch's invocation making several casts.
#[test]
fn a_million_triangles_fit_the_loop_budget() {
    let mut scene = vkpath::Scene::default_scene();
    scene.spheres.truncate(6);
    let mut gpu = GpuScene::build(&scene);
    gpu.triangles = vec![Default::default(); 1_000_000];
    gpu.bvh_nodes = vec![Default::default(); 400_000];
    let per_cast = worst_case_loop_iterations(&gpu, 0);
    assert!(
        per_cast <= LAVAPIPE_LOOP_BUDGET / 8,
        "{per_cast} iterations per cast for a 10^6-triangle scene"
    );
    assert!(casts_per_dispatch("llvmpipe (LLVM 15.0.6, 256 bits)", &gpu) >= 8);
    // And a small mesh is bounded by its size, not by the cap.
    gpu.triangles.truncate(10);
    gpu.bvh_nodes.truncate(4);
    let small = worst_case_loop_iterations(&gpu, 0);
    assert!(small < 100, "{small}");
}

// ----- arrays larger than one binding -----

/// A quad tessellated into more triangles than one storage binding holds (abi::SPLIT_ARRAYS: 2^21
/// triangles a part; Vulkan guarantees only 128 MiB a binding) renders as the same quad made of two
/// triangles: the triangles past the first part are read from the second binding, where they are.
/// Lit directly by a point light, both images are the same up to the rounding of the hit points; a part
/// read wrong or not at all leaves a hole the size of its share of the quad (here 13 %).
#[test]
fn a_mesh_larger_than_one_binding_renders_as_the_same_quad() {
    use vkpath::kernel::abi::{SPLIT_ARRAYS, split_array};
    let head = r#"
[camera]
position = [0, 0, 50]
look_at = [0, 0, 0]
fov = 60
[image]
width = 32
height = 32
[render]
max_bounces = 1
filter = "none"
[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
[[light]]
type = "point"
position = [-10, 15, 30]
power = 50000.0
"#;
    // A grid of g x g cells over [-20, 20]^2 at z = 0, two triangles a cell, facing the camera.
    let quad = |g: u32| {
        let mut scene = common::scene(head);
        let positions = (0..=g)
            .flat_map(|j| (0..=g).map(move |i| (i, j)))
            .map(|(i, j)| {
                Vec3::new(i as f32, j as f32, 0.0) * (40.0 / g as f32) - Vec3::new(20.0, 20.0, 0.0)
            })
            .collect();
        let triangles = (0..g)
            .flat_map(|j| (0..g).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let v = |di: u32, dj: u32| (j + dj) * (g + 1) + i + di;
                [[v(0, 0), v(1, 0), v(1, 1)], [v(0, 0), v(1, 1), v(0, 1)]]
            })
            .collect();
        scene.meshes.push(vkpath::scene::Mesh {
            obj: "generated".into(),
            positions,
            normals: Vec::new(),
            uvs: Vec::new(),
            tangents: Vec::new(),
            triangles,
            material: 0,
            texture: None,
            maps: Default::default(),
        });
        scene
    };
    let fine = quad(1100);
    let part = split_array("triangles").unwrap().part_elements();
    let gpu = GpuScene::build(&fine);
    assert!(
        gpu.triangles.len() > part,
        "{} triangles",
        gpu.triangles.len()
    );
    assert!(
        FeatureSet::of(&gpu, &params_for(&fine, 1))
            .has(vkpath::kernel::features::Feature::SplitArrays)
    );
    assert!(
        SPLIT_ARRAYS
            .iter()
            .all(|a| a.part_elements() * a.element_bytes <= 1 << 27)
    );
    drop(gpu);
    let a = render(&fine, 2);
    let b = render(&quad(1), 2);
    let (mut diff, mut total, mut lit) = (0.0f64, 0.0f64, 0);
    for (p, q) in a.mean.iter().zip(&b.mean) {
        for c in 0..3 {
            diff += (p[c] as f64 - q[c] as f64).abs();
            total += q[c] as f64;
        }
        lit += usize::from(q[0] > 0.0);
    }
    assert!(
        lit > 400,
        "the quad covers most of the image: {lit} pixels lit"
    );
    assert!(
        diff < 1e-4 * total,
        "split mesh vs two triangles: |difference| {diff} of {total}"
    );
}

// ----- transforms and instances -----

/// An `[[instance]]` is its mesh placed once more: two named meshes and four instances of them render as
/// six `[[mesh]]` tables placed there. The ball is a cut-out that is all hole (opacity 0.3 under a
/// cutoff of 0.5: invisible); one instance of it is in its own red diffuse, one in its own mirror (a
/// material kind no triangle of the scene has), both sharing the ball's triangles (placements of an
/// instanced mesh, walked through the two-level BVH, each placement's material replacing the
/// triangles'). The globe (a uv sphere, in plain white) has an instance in a checkerboard material of its
/// own, which shares the globe's copy, which then keeps its texture coordinates. A white triangle has an
/// instance in an emitting material, which makes it a copy (an emitting triangle is a light, sampled in
/// world space), placed as its table is (one triangle, so that both scenes' light tables agree: with
/// more, the order in which the world's BVH leaves the emitting triangles would pick different ones for
/// the same random numbers, an unbiased but different image). The shared meshes' vertices are mapped in f32 by the kernel where the tables' were
/// mapped in f64: the same image up to that rounding. Fails if the walk tests the opacity of the
/// triangles' own material (the red and mirror balls vanish), if the kernel is specialised without the
/// placements' materials (the mirror's code is left out), or if the globe's copy drops its texture
/// coordinates (the checkerboard is read at every triangle's default uvs).
#[test]
fn instances_render_as_the_same_meshes_placed_by_mesh_tables() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "ball.obj", &shapes::icosphere(2).to_obj());
    write(dir.path(), "globe.obj", &shapes::uv_sphere(24, 12).to_obj());
    write(
        dir.path(),
        "tri.obj",
        "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n",
    );
    let head = r#"
[camera]
position = [0, 0, 36]
look_at = [0, 0, 0]
fov = 60
[image]
width = 64
height = 48
[render]
max_bounces = 2
[materials]
ghost = { type = "diffuse", albedo = [0.8, 0.8, 0.8], opacity = 0.3, alpha_cutoff = 0.5 }
red = { type = "diffuse", albedo = [0.8, 0.1, 0.1] }
chrome = { type = "mirror" }
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
checks = { type = "diffuse", albedo = { checkerboard = [[0.1, 0.7, 0.1], [0.7, 0.7, 0.1]], scale = [4, 4] } }
lamp = { type = "emitter", radiance = [2.0, 1.5, 1.0] }
floor = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
[[triangle]]
vertices = [[-40, -14, -40], [40, -14, -40], [0, -14, 40]]
material = "floor"
[[light]]
type = "point"
position = [0, 10, 20]
power = 50000.0
"#;
    let place = |at: [i32; 2]| format!("scale = 3\ntranslate = [{}, {}, 0]\n", at[0], at[1]);
    let named = |name: &str, obj: &str, material: &str, at: [i32; 2]| {
        format!(
            "[[mesh]]\nobj = \"{obj}\"\nname = \"{name}\"\nmaterial = \"{material}\"\n{}",
            place(at)
        )
    };
    let instance = |name: &str, material: &str, at: [i32; 2]| {
        format!(
            "[[instance]]\nmesh = \"{name}\"\nmaterial = \"{material}\"\n{}",
            place(at)
        )
    };
    let table = |obj: &str, material: &str, at: [i32; 2]| {
        format!(
            "[[mesh]]\nobj = \"{obj}\"\nmaterial = \"{material}\"\n{}",
            place(at)
        )
    };
    // (The red ball by a matrix: the same placement as the others' scale and translation.)
    let instanced = format!(
        "{head}{}[[instance]]\nmesh = \"ball\"\nmaterial = \"red\"\n\
         matrix = [3, 0, 0, 8,  0, 3, 0, 0,  0, 0, 3, 0,  0, 0, 0, 1]\n{}{}{}{}{}",
        named("ball", "ball.obj", "ghost", [-8, 0]),
        instance("ball", "chrome", [0, 8]),
        named("globe", "globe.obj", "white", [0, -8]),
        instance("globe", "checks", [-8, -8]),
        named("tri", "tri.obj", "white", [8, 8]),
        instance("tri", "lamp", [8, -8]),
    );
    let tables = format!(
        "{head}{}{}{}{}{}{}{}",
        table("ball.obj", "ghost", [-8, 0]),
        table("ball.obj", "red", [8, 0]),
        table("ball.obj", "chrome", [0, 8]),
        table("globe.obj", "white", [0, -8]),
        table("globe.obj", "checks", [-8, -8]),
        table("tri.obj", "white", [8, 8]),
        table("tri.obj", "lamp", [8, -8]),
    );
    let a = load(dir.path(), &instanced);
    let b = load(dir.path(), &tables);
    let index = |name: &str| a.material_names.iter().position(|n| n == name).unwrap() as u32;
    let materials: Vec<u32> = a.meshes.iter().map(|m| m.material).collect();
    assert_eq!(
        materials,
        [
            index("ghost"),
            index("white"),
            index("white"),
            index("lamp")
        ],
        "the three named meshes and the copy in lamp"
    );
    let shared: Vec<Vec<Option<u32>>> = a
        .instanced
        .iter()
        .map(|m| m.placements.iter().map(|p| p.material).collect())
        .collect();
    assert_eq!(
        shared,
        [
            vec![Some(index("red")), Some(index("chrome"))],
            vec![Some(index("checks"))]
        ]
    );
    assert!(
        !a.instanced[1].parts[0].uvs.is_empty(),
        "the globe's shared copy keeps its texture coordinates"
    );
    let gpu = GpuScene::build(&a);
    assert!(
        FeatureSet::of(&gpu, &params_for(&a, 1))
            .has(vkpath::kernel::features::Feature::InstanceMaterials)
    );
    let chrome = gpu.materials[index("chrome") as usize].kind;
    assert!(
        gpu.triangles
            .iter()
            .all(|t| gpu.materials[t.material as usize].kind != chrome),
        "only a placement is in the mirror"
    );
    drop(gpu);
    let (fa, fb) = (render(&a, 4), render(&b, 4));
    let red = fb.mean.iter().filter(|p| p[0] > 2.0 * p[1]).count();
    assert!(red > 20, "the red ball shows: {red} pixels");
    let (relative, far) = common::render_distance(&fa, &fb);
    assert!(
        relative < 1e-4 && far < 0.005,
        "instanced vs tables: relative difference {relative}, {far} of the pixels differ by > 1 %"
    );
}

/// Placements share one copy of their mesh, whatever their transform: 64 placements of a ball (flat
/// shaded, white in front and red behind: Mitsuba's twosided with two BSDFs) by rotations, non-uniform
/// scales, shears and mirrors, uploaded as one ball's triangles and 64 placements (`GpuScene::instances`)
/// instead of 64 copies, render as the same 64 balls written as `[[mesh]]` tables (expected: the same
/// image up to the rounding of the vertices, which the kernel maps in f32 and the tables in f64:
/// measured 2e-7 relative). A mirrored placement must keep its faces' fronts outside: a flipped front
/// shows the red back and bends the glass balls' light the wrong way (measured with the kernel's flip
/// removed: 0.23 relative, 10 % of the pixels off by more than 1 %).
#[test]
fn placements_share_one_copy_and_render_as_copies_under_any_affine_map() {
    let dir = tempfile::tempdir().unwrap();
    let ball = shapes::icosphere(2);
    write(dir.path(), "ball.obj", &ball.to_obj());
    let head = r#"
[camera]
position = [0, 0, 60]
look_at = [0, 0, 0]
fov = 50
[image]
width = 96
height = 64
[render]
max_bounces = 4
[materials]
front = { type = "diffuse", albedo = [0.8, 0.8, 0.8], back = "behind" }
behind = { type = "diffuse", albedo = [0.8, 0.0, 0.0] }
glass = { type = "dielectric", ior = 1.5 }
floor = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
[[light]]
type = "point"
position = [0, 30, 40]
power = 300000.0
[[triangle]]
vertices = [[-100, -20, -100], [100, -20, 100], [100, -20, -100]]
material = "floor"
[[triangle]]
vertices = [[-100, -20, -100], [-100, -20, 100], [100, -20, 100]]
material = "floor"
"#;
    // Linear parts (row-major): uniform, mirrored in x, non-uniform, sheared, rotated about z by 30
    // degrees and mirrored in y, mirrored in all three, rotated about x and stretched, a general map.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let linear: [[f64; 9]; 8] = [
        [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0],
        [-2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0],
        [3.0, 0.0, 0.0, 0.0, 1.2, 0.0, 0.0, 0.0, 2.0],
        [2.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.5, 2.0],
        [2.0 * c, 2.0 * s, 0.0, 2.0 * s, -2.0 * c, 0.0, 0.0, 0.0, 2.0],
        [-1.8, 0.0, 0.0, 0.0, -1.8, 0.0, 0.0, 0.0, -1.8],
        [2.5, 0.0, 0.0, 0.0, 1.5 * c, -1.5 * s, 0.0, 1.5 * s, 1.5 * c],
        [1.7, -0.4, 0.3, 0.5, 1.9, -0.2, -0.3, 0.6, 2.1],
    ];
    let mut instances = String::new();
    let mut tables = String::new();
    for row in 0..8 {
        for col in 0..8 {
            let m = linear[(row + col) % 8];
            let (x, y) = (-35.0 + 10.0 * col as f64, -15.0 + 7.0 * row as f64 - 2.0);
            let matrix = format!(
                "[{}, {}, {}, {x},  {}, {}, {}, {y},  {}, {}, {}, 0,  0, 0, 0, 1]",
                m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]
            );
            let material = if col < 4 { "front" } else { "glass" };
            // (One named mesh per material: an instance in another material would be a copy.)
            instances.push_str(&format!(
                "[[instance]]\nmesh = \"{material}\"\nmatrix = {matrix}\n"
            ));
            tables.push_str(&format!(
                "[[mesh]]\nobj = \"ball.obj\"\nsmooth = false\nmaterial = \"{material}\"\nmatrix = {matrix}\n"
            ));
        }
    }
    // The named meshes themselves are drawn too: out of sight, behind the camera, in both scenes.
    let named = |name: &str, with_name: bool| {
        format!(
            "[[mesh]]\nobj = \"ball.obj\"\nsmooth = false\nmaterial = \"{name}\"\n{}translate = [0, 0, 200]\n",
            if with_name {
                format!("name = \"{name}\"\n")
            } else {
                String::new()
            }
        )
    };
    let shared = load(
        dir.path(),
        &format!(
            "{head}{}{}{instances}",
            named("front", true),
            named("glass", true)
        ),
    );
    let copies = load(
        dir.path(),
        &format!(
            "{head}{}{}{tables}",
            named("front", false),
            named("glass", false)
        ),
    );
    let faces = ball.triangles.len();
    let gpu = GpuScene::build(&shared);
    assert_eq!(
        gpu.triangles.len(),
        2 + 2 * faces + 2 * faces,
        "the floor and the named meshes, then one copy of each instanced mesh"
    );
    assert_eq!(
        gpu.instances.len(),
        64 + 1,
        "64 placements and the world's triangles"
    );
    check_two_level_tree(&gpu);
    let features = FeatureSet::of(&gpu, &params_for(&shared, 1));
    assert!(features.has(vkpath::kernel::features::Feature::Instances));
    assert!(
        !features.has(vkpath::kernel::features::Feature::InstanceMaterials),
        "no placement is in a material of its own"
    );
    assert_eq!(GpuScene::build(&copies).triangles.len(), 2 + 66 * faces);
    let (a, b) = (render(&shared, 4), render(&copies, 4));
    let (relative, far) = common::render_distance(&a, &b);
    assert!(
        relative < 1e-4 && far < 0.005,
        "placements vs copies: relative difference {relative}, {far} of the pixels differ by > 1 %"
    );
}

/// A placement rounds: the kernel maps a mesh's vertices into the world in f32, and the walk maps rays
/// back, each within a few steps of the coordinates' size in the mesh's own space. A ball modelled
/// 10^5 from its file's origin (an f32 step of 0.008 there) and placed back near the world's origin by
/// a rotation lands near the origin, where a hit point's own bound is ~10^-6: only the placement's
/// rounding in the bound (scene.wgsl, instance_error) keeps its shadow rays starting outside it. Lit by
/// a point light, with direct light only, it renders as its copy placed in f64; measured with the
/// placement's term removed from the bound: the image 52 % darker (self-shadowing); with it, 4e-5 apart.
#[test]
fn placements_of_far_modelled_meshes_spawn_rays_off_their_surface() {
    let dir = tempfile::tempdir().unwrap();
    let mut ball = shapes::icosphere(3);
    for p in &mut ball.positions {
        *p = *p * 2.0 + Vec3::new(1.0e5, 0.0, 0.0);
    }
    write(dir.path(), "ball.obj", &ball.to_obj());
    let head = r#"
[camera]
position = [0, 1, 9]
look_at = [0, 0, 0]
fov = 50
[image]
width = 64
height = 48
[render]
max_bounces = 1
[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
[[light]]
type = "point"
position = [3, 6, 8]
power = 8000.0
"#;
    // A turn of 30 degrees about y, then back towards the origin.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let matrix = format!(
        "[{c}, 0, {s}, {},  0, 1, 0, 0,  {}, 0, {c}, {},  0, 0, 0, 1]",
        -1.0e5 * c,
        -s,
        1.0e5 * s
    );
    let shared = format!(
        "{head}[[mesh]]\nobj = \"ball.obj\"\nname = \"ball\"\nsmooth = false\nmaterial = \"white\"\ntranslate = [0, 0, -1000]\n\
         [[instance]]\nmesh = \"ball\"\nmatrix = {matrix}\n"
    );
    let copy = format!(
        "{head}[[mesh]]\nobj = \"ball.obj\"\nsmooth = false\nmaterial = \"white\"\ntranslate = [0, 0, -1000]\n\
         [[mesh]]\nobj = \"ball.obj\"\nsmooth = false\nmaterial = \"white\"\nmatrix = {matrix}\n"
    );
    let (a, b) = (
        render(&load(dir.path(), &shared), 8),
        render(&load(dir.path(), &copy), 8),
    );
    let sum = |f: &vkpath::Film| f.mean.iter().map(|p| p[1] as f64).sum::<f64>();
    let lit = b.mean.iter().filter(|p| p[1] > 0.05).count();
    assert!(lit > b.mean.len() / 10, "the ball is lit: {lit} pixels");
    assert!(
        (sum(&a) / sum(&b) - 1.0).abs() < 0.01,
        "the placement renders {} of its copy's light",
        sum(&a) / sum(&b)
    );
}

/// The two-level tree as uploaded: from node 0, every top-level leaf is one placement
/// (`bvh::INSTANCE`) and every placement is a leaf once, but the scene's own triangles' (the identity),
/// which the top-level tree refers to as its tree's root node (walked in world space, no placement
/// entered); from each placement's root, its mesh's tree has triangle leaves only, all within one range
/// of `triangles` that holds every triangle of the range.
fn check_two_level_tree(gpu: &GpuScene) {
    use vkpath::scene::bvh::{INSTANCE, LEAF, LEAF_COUNT_BITS, LEAF_COUNT_MASK, NO_CHILD};
    let children = |n: u32| {
        gpu.bvh_nodes[n as usize]
            .child
            .into_iter()
            .filter(|&c| c != NO_CHILD)
    };
    let mut placed = vec![0; gpu.instances.len()];
    let mut by_root = 0;
    let first_root = gpu.instances.iter().map(|i| i.root).min().unwrap();
    let mut stack = vec![0u32];
    let mut top = 0;
    while let Some(n) = stack.pop() {
        top += 1;
        for c in children(n) {
            if c & LEAF == 0 && c >= first_root {
                let world = gpu.instances.iter().position(|i| i.root == c).unwrap();
                let identity = [
                    [1.0, 0.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.0, 0.0, 1.0, 0.0],
                ];
                let w = &gpu.instances[world];
                assert_eq!(
                    [w.to_world_x, w.to_world_y, w.to_world_z],
                    identity,
                    "only the identity placement is referred to by its root"
                );
                placed[world] += 1;
                by_root += 1;
                continue;
            }
            if c & LEAF == 0 {
                stack.push(c);
                continue;
            }
            assert!(
                c & INSTANCE != 0 && c & LEAF_COUNT_MASK == 0,
                "{c:#x}: a top-level leaf is one placement"
            );
            placed[((c & !(LEAF | INSTANCE)) >> LEAF_COUNT_BITS) as usize] += 1;
        }
    }
    assert!(
        placed.iter().all(|&k| k == 1),
        "each placement is one leaf: {placed:?}"
    );
    assert_eq!(by_root, usize::from(gpu.world_triangles > 0));
    for inst in &gpu.instances {
        assert!(
            inst.root as usize >= top,
            "a mesh's tree lies after the top-level tree"
        );
        let mut triangles = Vec::new();
        let mut stack = vec![inst.root];
        while let Some(n) = stack.pop() {
            for c in children(n) {
                if c & LEAF == 0 {
                    stack.push(c);
                } else {
                    assert!(c & INSTANCE == 0, "{c:#x}: a placement inside a placement");
                    let first = (c & !LEAF) >> LEAF_COUNT_BITS;
                    triangles.extend(first..=first + (c & LEAF_COUNT_MASK));
                }
            }
        }
        triangles.sort_unstable();
        let (lo, hi) = (triangles[0], *triangles.last().unwrap());
        assert!((hi as usize) < gpu.triangles.len());
        assert_eq!(
            triangles,
            (lo..=hi).collect::<Vec<_>>(),
            "a mesh's leaves cover its range once"
        );
    }
}

/// A matrix may scale unevenly and mirror. A quad emitting from its front (+z, towards the camera),
/// stretched 2 x 1/2 and mirrored in x by its matrix, renders as the same stretched quad written out in
/// the file (a mirror that reversed the front would leave the image black); a matrix with `translate`
/// as well, a singular or projective one, an unknown mesh name and a name used twice are errors that
/// name their key.
#[test]
fn a_matrix_stretches_and_mirrors_and_keeps_fronts_facing_out() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n",
    );
    write(
        dir.path(),
        "wide.obj",
        "v -2 -0.5 0\nv 2 -0.5 0\nv 2 0.5 0\nv -2 0.5 0\nf 1 2 3 4\n",
    );
    let head = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nwidth = 32\nheight = 24\n\
                [render]\nmax_bounces = 1\n[materials]\nlamp = { type = \"emitter\", radiance = [1, 2, 3] }\n";
    let stretched = render(
        &load(
            dir.path(),
            &format!(
                "{head}[[mesh]]\nobj = \"quad.obj\"\nmaterial = \"lamp\"\nmatrix = [-2, 0, 0, 0,  0, 0.5, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]\n"
            ),
        ),
        2,
    );
    let written = render(
        &load(
            dir.path(),
            &format!("{head}[[mesh]]\nobj = \"wide.obj\"\nmaterial = \"lamp\"\n"),
        ),
        2,
    );
    let sum = |f: &vkpath::Film| f.mean.iter().map(|p| p[2] as f64).sum::<f64>();
    assert!(
        sum(&written) > 0.1 * 32.0 * 24.0 * 3.0,
        "the quad covers a good part of the image"
    );
    assert!(
        (sum(&stretched) - sum(&written)).abs() <= 1e-6 * sum(&written),
        "mirrored and stretched {} vs written out {}",
        sum(&stretched),
        sum(&written)
    );

    let error = |extra: &str| -> String {
        let path = write(
            dir.path(),
            "bad.toml",
            &format!(
                "{head}[[mesh]]\nobj = \"quad.obj\"\nmaterial = \"lamp\"\nname = \"q\"\n{extra}"
            ),
        );
        match Scene::load(&path) {
            Ok(_) => panic!("expected an error for {extra:?}"),
            Err(e) => e.to_string(),
        }
    };
    for (extra, key) in [
        (
            "[[instance]]\nmesh = \"q\"\nmatrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]\ntranslate = [1, 0, 0]\n",
            "instance[0].matrix",
        ),
        (
            "[[instance]]\nmesh = \"q\"\nmatrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 0, 0,  0, 0, 0, 1]\n",
            "instance[0].matrix",
        ),
        (
            "[[instance]]\nmesh = \"q\"\nmatrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 1, 1]\n",
            "instance[0].matrix",
        ),
        ("[[instance]]\nmesh = \"r\"\n", "instance[0].mesh"),
        (
            "[[instance]]\nmesh = \"q\"\nmaterial = \"nope\"\n",
            "instance[0].material",
        ),
        (
            "[[mesh]]\nobj = \"quad.obj\"\nmaterial = \"lamp\"\nname = \"q\"\n",
            "mesh[1].name",
        ),
    ] {
        let message = error(extra);
        assert!(
            message.contains("bad.toml") && message.contains(key),
            "{key}: {message}"
        );
        assert!(!message.contains('\n'), "one paragraph: {message:?}");
    }
    let message = error("[[instance]]\nmesh = \"q\"\nmatrix = [1, 0, 0]\n");
    assert!(message.contains("16 numbers"), "{message}");
    // A placement past the f32 range: of a copy (the lamp's instances are copies) and of a shared mesh.
    for extra in [
        "[[instance]]\nmesh = \"q\"\nmatrix = [2e38, 0, 0, 2e38,  0, 2e38, 0, 0,  0, 0, 2e38, 0,  0, 0, 0, 1]\n",
        "[materials.grey]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n[[mesh]]\nobj = \"quad.obj\"\n\
         material = \"grey\"\nname = \"g\"\n[[instance]]\nmesh = \"g\"\nmatrix = [2e38, 0, 0, 2e38,  0, 2e38, 0, 0,  0, 0, 2e38, 0,  0, 0, 0, 1]\n",
    ] {
        let message = error(extra);
        assert!(
            message.contains("instance[0]") && message.contains("overflows 32-bit floats"),
            "{message}"
        );
    }
    // Within the range, past half of it (where the placement's box corners no longer vouch for the
    // vertices and each vertex is mapped): a shared placement loads.
    let near = write(
        dir.path(),
        "near.toml",
        &format!(
            "{head}[materials.grey]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n[[mesh]]\nobj = \"quad.obj\"\n\
             material = \"grey\"\nname = \"g\"\n[[instance]]\nmesh = \"g\"\n\
             matrix = [3e38, 0, 0, 0,  0, 3e38, 0, 0,  0, 0, 3e38, 0,  0, 0, 0, 1]\n"
        ),
    );
    let scene = Scene::load(&near).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.instanced[0].placements.len(), 1);
}

// ----- the example scene -----

const GLOBE_W: u32 = 128;
const GLOBE_H: u32 = 64;

/// The globe's texture: a 16 x 8 checkerboard over longitude and latitude, cream squares alternating
/// with a colour that changes with latitude (so that orientation and the sRGB decoding both show).
fn globe_texture() -> image::RgbImage {
    let palette = [[196, 58, 46], [222, 132, 38], [58, 140, 92], [48, 92, 170]];
    image::RgbImage::from_fn(GLOBE_W, GLOBE_H, |x, y| {
        let (i, j) = (x / 8, y / 8);
        if (i + j) % 2 == 0 {
            image::Rgb([238, 226, 196])
        } else {
            image::Rgb(palette[(j as usize / 2) % 4])
        }
    })
}

/// scenes/models/: the globe (a uv sphere with normals and uvs), its texture, and an icosphere without
/// normals (smooth ones are computed). Set VKPATH_WRITE_MODELS=1 to (re)write them.
#[test]
fn scene_models_are_generated_here() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/models");
    let globe = shapes::uv_sphere(32, 16).to_obj();
    let ico = shapes::icosphere(2).to_obj();
    let texture = globe_texture();
    if std::env::var("VKPATH_WRITE_MODELS").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("globe.obj"), &globe).unwrap();
        std::fs::write(dir.join("ico.obj"), &ico).unwrap();
        texture.save(dir.join("globe.png")).unwrap();
    }
    let read = |name: &str| {
        std::fs::read_to_string(dir.join(name))
            .unwrap()
            .replace("\r\n", "\n")
    };
    assert_eq!(read("globe.obj"), globe, "scenes/models/globe.obj is stale");
    assert_eq!(read("ico.obj"), ico, "scenes/models/ico.obj is stale");
    let png = image::open(dir.join("globe.png")).unwrap().to_rgb8();
    assert!(png == texture, "scenes/models/globe.png is stale");
}

#[test]
fn the_mesh_scene_uses_every_mesh_feature() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/mesh.toml");
    let mut scene = Scene::load(&path).unwrap();
    assert_eq!(scene.meshes.len(), 3);
    let gpu = GpuScene::build(&scene);
    let features = FeatureSet::of(&gpu, &params_for(&scene, 3));
    use vkpath::kernel::features::Feature as F;
    assert!(features.has(F::Bvh) && features.has(F::SmoothNormals) && features.has(F::Textures));
    assert_eq!(
        gpu.stats.triangles,
        scene
            .meshes
            .iter()
            .map(|m| m.triangles.len())
            .sum::<usize>()
    );
    assert!(gpu.stats.bvh_nodes > 0 && gpu.stats.bvh_nodes < gpu.stats.triangles);
    scene.image.width = 32;
    scene.image.height = 32;
    let film = render(&scene, 2);
    assert!(film.average() > 0.0);
    assert!(film.mean.iter().flatten().all(|c| c.is_finite()));
}

// ----- errors -----

/// A scene in `dir` with materials "white" and "glass" and one `[[mesh]]` whose keys are `mesh_keys`
/// (the table starts at line 8, its first key is on line 9).
fn mesh_error(dir: &Path, mesh_keys: &str) -> SceneError {
    let toml = format!(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\n\
         white = {{ type = \"diffuse\", albedo = [0.8, 0.8, 0.8] }}\n\
         glass = {{ type = \"dielectric\", ior = 1.5 }}\n[[mesh]]\n{mesh_keys}\n"
    );
    let path = write(dir, "bad.toml", &toml);
    let err = match Scene::load(&path) {
        Ok(_) => panic!("expected an error for {mesh_keys:?}"),
        Err(e) => e,
    };
    let message = err.to_string();
    assert!(message.contains("bad.toml"), "{message}");
    assert!(!message.contains('\n'), "one paragraph: {message:?}");
    err
}

#[test]
fn obj_and_texture_errors_name_the_file_the_line_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    );
    write(d, "flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    // (scene line, key, OBJ file and line or other words the message must contain)
    let cases: Vec<(&str, &str, usize, &str, Vec<&str>)> = vec![
        (
            "missing OBJ",
            "obj = \"nope.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["nope.obj", "cannot read"],
        ),
        (
            "malformed number",
            "obj = \"bad1.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad1.obj, line 2", "three numbers"],
        ),
        (
            "index out of range",
            "obj = \"bad2.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad2.obj, line 5", "vertex 7"],
        ),
        (
            "NaN vertex",
            "obj = \"bad3.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad3.obj, line 3", "non-finite"],
        ),
        (
            // Issue 31: a corner naming a normal the file does not have used to be refused without
            // the OBJ's line.
            "normal index without normals",
            "obj = \"bad5.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad5.obj, line 4", "normal 1"],
        ),
        (
            // Issue 53: a corner without its vertex index was refused without the OBJ's line.
            "corner without a vertex",
            "obj = \"bad6.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad6.obj, line 5", "`//1` has no vertex index"],
        ),
        (
            "no faces",
            "obj = \"bad4.obj\"\nmaterial = \"white\"",
            9,
            "mesh[0].obj",
            vec!["bad4.obj", "no faces"],
        ),
        (
            "missing texture",
            "obj = \"tri.obj\"\nmaterial = \"white\"\ntexture = \"nope.png\"",
            11,
            "mesh[0].texture",
            vec!["nope.png"],
        ),
        (
            "corrupt texture",
            "obj = \"tri.obj\"\nmaterial = \"white\"\ntexture = \"bad.png\"",
            11,
            "mesh[0].texture",
            vec!["bad.png", "decode"],
        ),
        (
            "texture without uvs",
            "obj = \"flat.obj\"\nmaterial = \"white\"\ntexture = \"ok.png\"",
            11,
            "mesh[0].texture",
            vec!["flat.obj", "vt"],
        ),
        (
            "texture on glass",
            "obj = \"tri.obj\"\nmaterial = \"glass\"\ntexture = \"ok.png\"",
            11,
            "mesh[0].texture",
            vec!["dielectric"],
        ),
        (
            "zero scale",
            "obj = \"tri.obj\"\nmaterial = \"white\"\nscale = 0",
            11,
            "mesh[0].scale",
            vec!["> 0"],
        ),
        (
            "NaN rotation",
            "obj = \"tri.obj\"\nmaterial = \"white\"\nrotate = [0, nan, 0]",
            11,
            "mesh[0].rotate",
            vec!["finite"],
        ),
        (
            "unknown material",
            "obj = \"tri.obj\"\nmaterial = \"wood\"",
            10,
            "mesh[0].material",
            vec!["wood"],
        ),
        (
            "unknown key",
            "obj = \"tri.obj\"\nmaterial = \"white\"\nsmoooth = true",
            11,
            "mesh[0].smoooth",
            vec!["unknown key"],
        ),
        (
            "missing obj key",
            "material = \"white\"",
            8,
            "mesh[0].obj",
            vec!["obj"],
        ),
    ];
    write(d, "bad1.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    write(
        d,
        "bad2.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
    );
    write(
        d,
        "bad3.obj",
        "v 0 0 0\r\nv 1 0 0\r\nv 0 NaN 0\r\nf 1 2 3\r\n",
    );
    write(d, "bad4.obj", "# only vertices\nv 0 0 0\nv 1 0 0\n");
    write(d, "bad5.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2 3\n");
    write(
        d,
        "bad6.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf //1 2//1 3//1\n",
    );
    std::fs::write(d.join("bad.png"), b"not a png at all").unwrap();
    image::RgbImage::new(2, 2).save(d.join("ok.png")).unwrap();
    for (what, keys, line, key, words) in cases {
        let err = mesh_error(d, keys);
        let message = err.to_string();
        assert_eq!(err.line(), Some(line), "{what}: {message}");
        assert_eq!(err.key(), Some(key), "{what}: {message}");
        for w in words {
            assert!(
                message.contains(w),
                "{what}: {message:?} should contain {w:?}"
            );
        }
    }
}

/// The command line turns a bad OBJ into exit status 2 and one paragraph on stderr.
#[test]
fn a_bad_obj_exits_with_status_2() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "bad.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
    );
    write(
        dir.path(),
        "bad.toml",
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\n\
         white = { type = \"diffuse\", albedo = [0.8, 0.8, 0.8] }\n[[mesh]]\nobj = \"bad.obj\"\nmaterial = \"white\"\n",
    );
    let out = run(dir.path(), &["render", "bad.toml", "--spp", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    for w in ["bad.toml", "line 8", "mesh[0].obj", "bad.obj, line 4"] {
        assert!(stderr.contains(w), "{stderr:?} should contain {w:?}");
    }
    assert!(!dir.path().join("bad.png").exists());
}

// ----- the scaling benchmark (not a test: run it by hand) -----

/// `cargo test --release --test mesh -- --ignored --nocapture mesh_scaling_benchmark` prints the scaling
/// table of `vkpath::bench::mesh` (sizes from VKPATH_BENCH_SIZES, comma-separated, default 10^3..10^6;
/// brute force up to VKPATH_BENCH_BRUTE triangles, default 10^4).
#[test]
#[ignore]
fn mesh_scaling_benchmark() {
    use vkpath::bench::BenchSettings;
    use vkpath::bench::mesh::{DEFAULT_SIZES, mesh_scaling, mesh_scaling_table};
    let sizes: Vec<usize> = std::env::var("VKPATH_BENCH_SIZES")
        .map(|s| s.split(',').map(|n| n.trim().parse().unwrap()).collect())
        .unwrap_or(DEFAULT_SIZES.to_vec());
    let brute = std::env::var("VKPATH_BENCH_BRUTE").map_or(10_000, |s| s.parse().unwrap());
    let settings = BenchSettings {
        width: 128,
        height: 128,
        spp: 8,
        runs: 5,
    };
    let ctx = vkpath::gpu::testing::context();
    let rows = mesh_scaling(&ctx, &sizes, settings, brute).unwrap();
    println!(
        "{}",
        mesh_scaling_table(&rows, settings, &ctx.device_info().name)
    );
}

/// A textured emitter lights the floor with its texture: light samples take the texture at the point
/// they pick on the quad, BSDF-sampled rays at the point they hit, and every strategy renders the same
/// image mean (assert_strategies_agree: a texture applied to one side only would shift the light-sampled
/// strategies' mean by the texture's mean against its value at the wrong points).
#[test]
fn a_textured_emitter_lights_with_its_texture() {
    let dir = tempfile::tempdir().unwrap();
    let mut img = image::RgbImage::new(4, 4);
    for (x, y, p) in img.enumerate_pixels_mut() {
        // Dark and bright quarters, coloured differently per channel.
        p.0 = [
            if x < 2 { 250 } else { 10 },
            if y < 2 { 250 } else { 30 },
            ((x + y) * 40) as u8,
        ];
    }
    img.save(dir.path().join("tex.png")).unwrap();
    let quad = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
    write(dir.path(), "quad.obj", quad);
    // The quad faces +z; turned 90 degrees about x it faces down, 1.2 above the floor.
    let toml = r#"
[camera]
position = [0, 3, 4]
look_at = [0, 0, 0]
fov = 60
[image]
width = 24
height = 24
[render]
samples = 256
max_bounces = 2
[materials]
floor = { type = "diffuse", albedo = [0.7, 0.7, 0.7] }
lamp = { type = "emitter", radiance = [3, 3, 3] }
[[triangle]]
vertices = [[-6, 0, -6], [-6, 0, 6], [6, 0, 6]]
material = "floor"
[[triangle]]
vertices = [[-6, 0, -6], [6, 0, 6], [6, 0, -6]]
material = "floor"
[[mesh]]
obj = "quad.obj"
material = "lamp"
texture = "tex.png"
rotate = [90, 0, 0]
translate = [0, 1.2, 0]
"#;
    let scene = load(dir.path(), toml);
    use vkpath::scene::LightSampling as L;
    common::assert_strategies_agree(&scene, &[L::Mis, L::Cone, L::Area, L::None]);
}

// ----- PLY -----

/// `shape` as a binary little-endian PLY with normals (and uvs when it has them), plus a per-vertex
/// colour that the reader must read past.
fn to_ply(shape: &shapes::Shape) -> Vec<u8> {
    let uv = !shape.uvs.is_empty();
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by tests/mesh.rs\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n{}\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        shape.positions.len(),
        if uv {
            "property float u\nproperty float v\n"
        } else {
            ""
        },
        shape.triangles.len()
    )
    .into_bytes();
    for (i, (p, n)) in shape.positions.iter().zip(&shape.normals).enumerate() {
        for c in p.to_array().into_iter().chain(n.to_array()) {
            out.extend(c.to_le_bytes());
        }
        out.push(7);
        if uv {
            out.extend(shape.uvs[i][0].to_le_bytes());
            out.extend(shape.uvs[i][1].to_le_bytes());
        }
    }
    for t in &shape.triangles {
        out.push(3);
        for i in t {
            out.extend((*i as i32).to_le_bytes());
        }
    }
    out
}

/// A mesh read from PLY is the mesh read from the equivalent OBJ: the same triangles with the same
/// corners and normals, so the same image, bit for bit (binary PLY, with a property the reader skips).
#[test]
fn a_ply_mesh_renders_the_same_bits_as_its_obj() {
    let dir = tempfile::tempdir().unwrap();
    let ball = shapes::icosphere(3);
    write(dir.path(), "ball.obj", &ball.to_obj());
    std::fs::write(dir.path().join("ball.PLY"), to_ply(&ball)).unwrap();
    let scene = |file: &str| {
        format!(
            r#"
[camera]
position = [0, 0, 6]
look_at = [0, 0, 0]
fov = 40
[image]
width = 48
height = 48
[render]
max_bounces = 2
[materials]
white = {{ type = "diffuse", albedo = [0.8, 0.8, 0.8] }}
[[light]]
type = "point"
position = [-4, 5, 6]
power = 2000.0
[[mesh]]
obj = "{file}"
material = "white"
"#
        )
    };
    let from_obj = load(dir.path(), &scene("ball.obj"));
    let from_ply = load(dir.path(), &scene("ball.PLY"));
    // (tobj numbers the OBJ's vertices its own way: compare the triangles' corners, not their indices.)
    let corners = |m: &vkpath::scene::Mesh| -> Vec<[glam::Vec3; 3]> {
        m.triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect()
    };
    assert_eq!(corners(&from_obj.meshes[0]), corners(&from_ply.meshes[0]));
    let (a, b) = (render(&from_obj, 4), render(&from_ply, 4));
    assert!(a.average() > 0.0);
    assert_eq!(a.mean, b.mean, "PLY and OBJ images differ");
}

/// A broken PLY is a scene error at the mesh's `obj` key that names the PLY file and its header line.
#[test]
fn a_bad_ply_names_the_file_and_the_header_line() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "bad.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n",
    );
    let text = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[materials]\n\
                white = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n[[mesh]]\n\
                obj = \"bad.ply\"  # line 8\nmaterial = \"white\"\n";
    let path = write(dir.path(), "scene.toml", text);
    let err = Scene::load(&path).expect_err("z is missing");
    let message = err.to_string();
    assert_eq!(err.line(), Some(8), "{message}");
    assert_eq!(err.key(), Some("mesh[0].obj"), "{message}");
    assert!(
        message.contains("bad.ply, line 3") && message.contains("x, y and z"),
        "{message}"
    );
}

// ----- OBJ materials (MTL) -----

/// Two quads side by side in one OBJ, each with its own `usemtl`, and a triangle with none.
const TWO_MATERIALS_OBJ: &str = "mtllib quads.mtl\n\
    v -2 -1 0\nv 0 -1 0\nv 0 1 0\nv -2 1 0\nv 0 -1 0\nv 2 -1 0\nv 2 1 0\nv 0 1 0\n\
    v 0 -3 0\nv 1 -3 0\nv 0 -2 0\n\
    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
    f 11/1 9/2 10/3\n\
    usemtl red\nf 1/1 2/2 3/3 4/4\n\
    usemtl lamp\nf 5/1 6/2 7/3 8/4\n";

const QUADS_MTL: &str = "# two materials\nnewmtl red\nKd 0.8 0.1 0.05\nillum 2\n\
    newmtl lamp\nKd 0 0 0\nKe 4 3 2\n\
    newmtl glass\nillum 7\nNi 1.33\n\
    newmtl pbr\nKd 0.2 0.4 0.6\nPm 0.7\nPr 0.25\n";

fn mtl_scene(dir: &Path, obj: &str, mtl: Option<&str>, mesh_keys: &str) -> Scene {
    write(dir, "quads.obj", obj);
    if let Some(mtl) = mtl {
        write(dir, "quads.mtl", mtl);
    }
    let text = format!(
        "[camera]\nposition = [0, 0, 6]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nwidth = 32\nheight = 32\n\
         [render]\nmax_bounces = 1\n[environment]\nradiance = [1.0, 1.0, 1.0]\n\
         [[mesh]]\nobj = \"quads.obj\"\n{mesh_keys}\n"
    );
    load(dir, &text)
}

/// Without a `material`, each `usemtl` group becomes a mesh of its own material (Kd diffuse, Ke
/// emission), faces without one are MTL's default grey, and they render as such: the red quad reflects
/// the white environment's light as red, the lamp shows its Ke.
#[test]
fn mtl_materials_are_used_when_the_mesh_has_none() {
    use vkpath::scene::{Bsdf, Emission};
    let dir = tempfile::tempdir().unwrap();
    let scene = mtl_scene(dir.path(), TWO_MATERIALS_OBJ, Some(QUADS_MTL), "");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(
        scene.material_names,
        ["mesh[0]/default", "mesh[0]/red", "mesh[0]/lamp"]
    );
    assert_eq!(scene.meshes.len(), 3);
    assert_eq!(
        scene.materials[0].bsdf,
        Bsdf::Diffuse {
            albedo: glam::Vec3::splat(0.8)
        }
    );
    assert_eq!(
        scene.materials[1].bsdf,
        Bsdf::Diffuse {
            albedo: glam::Vec3::new(0.8, 0.1, 0.05)
        }
    );
    assert_eq!(scene.materials[1].emission, None);
    assert_eq!(
        scene.materials[2].emission,
        Some(Emission {
            radiance: glam::Vec3::new(4.0, 3.0, 2.0),
            two_sided: false
        })
    );
    for (m, tris) in scene.meshes.iter().zip([1, 2, 2]) {
        assert_eq!(m.triangles.len(), tris);
    }
    // Pixel columns at x = -1 (the red quad) and x = +1 (the lamp), on the middle row.
    let film = render(&scene, 16);
    let px = |x: u32| film.mean[(16 * 32 + x) as usize];
    let red = px(11);
    let lamp = px(21);
    assert!(red[0] > 3.0 * red[1] && red[0] > 0.3, "red quad: {red:?}");
    for (got, want) in lamp.iter().zip([4.0, 3.0, 2.0]) {
        assert!((got - want).abs() < 1e-4, "lamp: {lamp:?}");
    }
}

/// The other illumination models: illum 7 is glass (Ni its index), Pm/Pr the metallic-roughness material;
/// a `material` on the mesh overrides the MTL for every face.
#[test]
fn mtl_illumination_models_and_overrides() {
    use vkpath::scene::{Bsdf, Roughness};
    let dir = tempfile::tempdir().unwrap();
    let obj = TWO_MATERIALS_OBJ
        .replace("usemtl red", "usemtl glass")
        .replace("usemtl lamp", "usemtl pbr");
    let scene = mtl_scene(dir.path(), &obj, Some(QUADS_MTL), "");
    assert_eq!(
        scene.materials[1].bsdf,
        Bsdf::Dielectric {
            ior: 1.33,
            roughness: Roughness::SMOOTH
        }
    );
    assert_eq!(
        scene.materials[2].bsdf,
        Bsdf::MetallicRoughness {
            base_color: glam::Vec3::new(0.2, 0.4, 0.6),
            metallic: 0.7,
            roughness: 0.25,
            layers: vkpath::scene::GltfLayers::NONE
        }
    );
    let text = "[materials]\nwhite = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n";
    let overridden = {
        write(dir.path(), "quads.obj", TWO_MATERIALS_OBJ);
        load(
            dir.path(),
            &format!(
                "[camera]\nposition = [0, 0, 6]\nlook_at = [0, 0, 0]\nfov = 60\n{text}\
                 [[mesh]]\nobj = \"quads.obj\"\nmaterial = \"white\"\n"
            ),
        )
    };
    assert_eq!(overridden.material_names, ["white"]);
    assert_eq!(overridden.meshes.len(), 1);
    assert_eq!(overridden.meshes[0].triangles.len(), 5);
}

/// A missing MTL file is a warning, not an error: the faces are MTL's default grey, and the warning says
/// which file could not be read. Without any MTL and without a `material`, the mesh is an error.
#[test]
fn a_missing_mtl_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let scene = mtl_scene(dir.path(), TWO_MATERIALS_OBJ, None, "");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("quads.mtl") && scene.warnings[0].contains("0.8"),
        "{:?}",
        scene.warnings
    );
    assert_eq!(scene.material_names, ["mesh[0]/default"]);
    assert_eq!(scene.meshes[0].triangles.len(), 5);

    write(
        dir.path(),
        "plain.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let path = write(
        dir.path(),
        "scene.toml",
        "[camera]\nposition = [0, 0, 6]\nlook_at = [0, 0, 0]\nfov = 60\n[[mesh]]  # line 5\nobj = \"plain.obj\"\n",
    );
    let err = Scene::load(&path).expect_err("no material at all");
    assert_eq!(err.line(), Some(5), "{err}");
    assert!(err.to_string().contains("needs a material"), "{err}");
}

/// map_Kd gives the group its texture (relative to the OBJ): the quad shows the texel's colour.
#[test]
fn mtl_map_kd_textures_the_group() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_fn(2, 2, |_, _| image::Rgb([20, 200, 60]))
        .save(dir.path().join("green.png"))
        .unwrap();
    let mtl = QUADS_MTL.replace("illum 2\n", "illum 2\nmap_Kd green.png\n");
    let scene = mtl_scene(dir.path(), TWO_MATERIALS_OBJ, Some(&mtl), "");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let red = &scene.meshes[1];
    let texture = red.texture.as_ref().expect("the red group is textured");
    assert_eq!(texture.texels[0].to_le_bytes()[..3], [20, 200, 60]);
    assert!(scene.meshes[0].texture.is_none() && scene.meshes[2].texture.is_none());
    let film = render(&scene, 16);
    let p = film.mean[(16 * 32 + 11) as usize];
    assert!(
        p[1] > 2.0 * p[0] && p[1] > 2.0 * p[2],
        "textured quad: {p:?}"
    );
}

// ----- a million triangles on the device -----

/// A 1,310,720-triangle icosphere (subdivided 8 times, flat faces) renders on whatever storage-buffer
/// range the device has (lavapipe on Mesa 24 and later offers 128 MiB per buffer; the triangles take
/// 63 MB, the BVH nodes and faces less), and renders right: a convex diffuse body of albedo 0.5 under a
/// uniform sky of radiance 1 reflects exactly 0.5 (every direction it scatters to sees the sky, one
/// bounce, no interreflection), the sky around it is 1, and the body covers the disc its silhouette
/// subtends: angular radius asin(r / d) about the camera axis.
#[test]
fn a_million_triangle_mesh_renders_within_the_device_buffer_limits() {
    let dir = tempfile::tempdir().unwrap();
    let mut ico = shapes::icosphere(8);
    ico.normals.clear();
    assert!(ico.triangles.len() >= 1_000_000);
    write(dir.path(), "ico.obj", &ico.to_obj());
    let scene = load(
        dir.path(),
        r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[image]
width = 64
height = 64
[render]
max_bounces = 1
filter = "box"
background = [1.0, 1.0, 1.0]
[materials]
grey = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
[[mesh]]
obj = "ico.obj"
material = "grey"
"#,
    );
    let ctx = vkpath::gpu::testing::context();
    let mut r = vkpath::render::Renderer::new(&ctx, &scene, &RenderOptions::default())
        .unwrap_or_else(|e| panic!("a 10^6-triangle mesh should render: {e}"));
    assert_eq!(r.scene_stats().triangles as usize, ico.triangles.len());
    r.run_pass(16).unwrap();
    let film = r.film().unwrap();
    common::assert_no_validation_errors();
    eprintln!(
        "device storage-buffer range {} bytes; {} triangles, {} BVH nodes",
        ctx.device_info().max_storage_buffer_range,
        r.scene_stats().triangles,
        r.scene_stats().bvh_nodes
    );

    // The silhouette: radius tan(asin(1/4)) / tan(20 deg) x 32 pixels about the image centre.
    let r_px = (0.25f64.asin().tan() / 20f64.to_radians().tan()) * 32.0;
    let (mut inside, mut outside) = ((0.0, 0), (0.0, 0));
    let mut covered = 0.0;
    for y in 0..64 {
        for x in 0..64 {
            let v = film.mean[y * 64 + x][1] as f64;
            let d = ((x as f64 + 0.5 - 32.0).powi(2) + (y as f64 + 0.5 - 32.0).powi(2)).sqrt();
            if d < r_px - 1.5 {
                inside = (inside.0 + v, inside.1 + 1);
            } else if d > r_px + 1.5 {
                outside = (outside.0 + v, outside.1 + 1);
            }
            // Sky 1, body 0.5: 2 (1 - v) is the covered fraction of the pixel, in expectation.
            covered += 2.0 * (1.0 - v);
        }
    }
    let inside_mean = inside.0 / inside.1 as f64;
    let outside_mean = outside.0 / outside.1 as f64;
    assert!(
        (inside_mean - 0.5).abs() < 0.01,
        "the body's mean {inside_mean} over {} pixels should be 0.5",
        inside.1
    );
    assert_eq!(outside_mean, 1.0, "the sky around the body is exactly 1");
    let disc = std::f64::consts::PI * r_px * r_px;
    eprintln!(
        "body {inside_mean} over {} pixels, covered {covered:.1} pixels of a {disc:.1}-pixel disc",
        inside.1
    );
    assert!(
        (covered / disc - 1.0).abs() < 0.02,
        "covered {covered:.1} pixels, the silhouette's disc {disc:.1}"
    );
}
