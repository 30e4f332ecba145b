//! The triangle BVH and mesh shading, read back from the GPU: test kernels (shaders/tests/bvh_query.wgsl,
//! mesh_surface.wgsl) composed after the render kernel's own scene code and bound to a real `GpuScene`'s
//! buffers, so what is tested is what renders.
//!
//! - The BVH walk returns exactly the brute-force closest hit (same t, bit for bit, and the same triangle
//!   up to exact ties), and the any-hit walk agrees on occlusion, over thousands of random rays into a
//!   triangle soup and a closed sphere mesh.
//! - No ray from inside a closed mesh escapes through the BVH (rays aimed at every vertex).
//! - The walk's iteration count stays far below its cap (`bvh::MAX_STEPS`), measured up to 10^5
//!   triangles.
//! - Interpolated shading normals are continuous across shared edges while geometric normals jump.

mod common;

use glam::Vec3;
use std::sync::Arc;
use vkpath::gpu::{Buffer, Command, GpuContext, Kernel, testing};
use vkpath::kernel::abi::GpuParams;
use vkpath::kernel::upload::{GpuScene, params_for};
use vkpath::kernel::{library, specialise};
use vkpath::scene::bvh::MAX_STEPS;
use vkpath::scene::{Mesh, Scene, shapes};

const MINIMAL: &str = r#"
[camera]
position = [0, 0, 50]
look_at  = [0, 0, 0]
fov      = 60
[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
"#;

/// A scene holding one mesh (and nothing else).
fn mesh_scene(positions: Vec<Vec3>, normals: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Scene {
    let mut s = common::scene(MINIMAL);
    s.meshes.push(Mesh {
        obj: "generated".into(),
        positions,
        normals,
        uvs: Vec::new(),
        tangents: Vec::new(),
        triangles,
        material: 0,
        texture: None,
        maps: Default::default(),
    });
    s
}

/// A test kernel over a GpuScene's buffers, uploaded by the renderer's own `upload_scene`.
struct SceneKernel {
    ctx: Arc<GpuContext>,
    kernel: Kernel,
    scene: Vec<(&'static str, Buffer)>,
}

impl SceneKernel {
    fn new(scene: &Scene, test_source: &str) -> (SceneKernel, GpuScene) {
        let ctx = testing::context();
        let gpu = GpuScene::build(scene);
        let mut params: GpuParams = params_for(scene, 3);
        params.num_spheres = gpu.spheres.len() as u32;
        params.num_triangles = gpu.triangles.len() as u32;
        params.num_lights = gpu.lights.len() as u32;
        let source = library::assemble_text("test kernel", test_source).unwrap();
        let compiled = specialise::compile(&source).expect("test kernel compiles");
        let mut kernel = Kernel::new(&ctx, &compiled).unwrap();
        // The scene's buffers as the renderer uploads them (every part of the split arrays included).
        // (A test kernel keeps the WGSL default, DATA_IMAGES off: no data images.)
        let uploaded = vkpath::render::upload_scene(&ctx, &mut kernel, &gpu, &params).unwrap();
        assert!(uploaded.images.is_empty());
        let k = SceneKernel {
            ctx,
            kernel,
            scene: uploaded.buffers,
        };
        (k, gpu)
    }

    /// Runs one invocation per ray and returns `per_ray` vec4s for each.
    fn run(&mut self, rays: &[[[f32; 4]; 2]], per_ray: usize, query: [u32; 4]) -> Vec<[f32; 4]> {
        let ctx = &self.ctx;
        let ray_buffer = Buffer::storage_from(ctx, "rays", rays).unwrap();
        let bytes = (rays.len() * per_ray * 16) as u64;
        let out = Buffer::readable_storage(ctx, "out", bytes).unwrap();
        let query = Buffer::uniform_from(ctx, "query", &query).unwrap();
        let mut bindings: Vec<(&str, &Buffer)> =
            vec![("rays", &ray_buffer), ("out", &out), ("query", &query)];
        bindings.extend(self.scene.iter().map(|(n, b)| (*n, b)));
        self.kernel.bind(&bindings).unwrap();
        self.kernel
            .submit(&[Command::Dispatch {
                invocations: [rays.len() as u32, 1, 1],
            }])
            .unwrap();
        let result = bytemuck::pod_collect_to_vec(&out.read_bytes().unwrap()[..bytes as usize]);
        common::assert_no_validation_errors();
        result
    }
}

/// SplitMix64, for reproducible test rays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        lo + (hi - lo) * Vec3::new(self.next(), self.next(), self.next())
    }

    fn direction(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let phi = 2.0 * std::f32::consts::PI * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

fn ray(o: Vec3, d: Vec3, t_max: f32) -> [[f32; 4]; 2] {
    [[o.x, o.y, o.z, t_max], [d.x, d.y, d.z, 0.0]]
}

const T_MISS: f32 = 3.0e38;
const NONE: u32 = u32::MAX;

/// BVH (closest and any-hit) against brute force over `rays`; returns the walk's iteration counts. The
/// first `aimed` rays go exactly through vertices, where several triangles tie.
fn compare_with_brute_force(
    scene: &Scene,
    rays: &[[[f32; 4]; 2]],
    aimed: usize,
    what: &str,
) -> Vec<u32> {
    let source = include_str!("../shaders/tests/bvh_query.wgsl");
    let (mut k, gpu) = SceneKernel::new(scene, source);
    let n = gpu.triangles.len() as u32;
    // Brute force in chunks of 20,000 triangles (lavapipe's loop budget); the BVH with the first chunk.
    let chunk = 20_000;
    let mut bvh = Vec::new();
    let mut brute: Vec<(f32, u32)> = vec![(0.0, NONE); rays.len()];
    for (c, start) in (0..n).step_by(chunk).enumerate() {
        let end = (start + chunk as u32).min(n);
        let out = k.run(rays, 2, [start, end, u32::from(c == 0), 0]);
        for (i, b) in brute.iter_mut().enumerate() {
            let t = out[2 * i + 1][0];
            let idx = out[2 * i + 1][1].to_bits();
            // Chunks come in index order: keep the earlier one on ties, as one loop would.
            if c == 0 || (idx != NONE && t < b.0) {
                *b = (t, idx);
            }
        }
        if c == 0 {
            bvh = (0..rays.len()).map(|i| out[2 * i]).collect();
        }
    }
    let mut hits = 0;
    let mut ties = 0;
    let mut steps = Vec::with_capacity(rays.len());
    for (i, (r, b)) in rays.iter().zip(&bvh).enumerate() {
        let (t_brute, idx_brute) = brute[i];
        let (t_bvh, idx_bvh) = (b[0], b[1].to_bits());
        assert_eq!(
            t_bvh.to_bits(),
            t_brute.to_bits(),
            "{what}: ray {i} {r:?}: BVH t = {t_bvh} (triangle {idx_bvh}), brute force t = {t_brute} (triangle {idx_brute})"
        );
        if idx_bvh != idx_brute {
            // Two triangles at exactly the same distance (a ray through a shared edge): either is right.
            assert!(idx_bvh != NONE && idx_brute != NONE, "{what}: ray {i}");
            ties += usize::from(i >= aimed);
        }
        let occluded = b[3] == 1.0;
        assert_eq!(
            occluded,
            idx_brute != NONE,
            "{what}: ray {i}: any-hit walk disagrees (brute force t = {t_brute}, t_max = {})",
            r[0][3]
        );
        hits += usize::from(idx_brute != NONE);
        steps.push(b[2] as u32);
    }
    assert!(
        ties * 100 <= rays.len(),
        "{what}: {ties} ties in {} rays",
        rays.len()
    );
    assert!(
        hits > rays.len() / 10,
        "{what}: only {hits} rays hit anything"
    );
    steps
}

fn soup(n: usize, rng: &mut Rng) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        // Triangles of very different sizes, some long and thin, scattered in a 100-unit box.
        let c = rng.in_box(Vec3::splat(-50.0), Vec3::splat(50.0));
        let size = 0.2 + 8.0 * rng.next().powi(3);
        for _ in 0..3 {
            positions.push(c + rng.direction() * size * (0.2 + rng.next()));
        }
    }
    let triangles = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    (positions, triangles)
}

#[test]
fn bvh_matches_brute_force_on_a_triangle_soup() {
    let mut rng = Rng(7);
    let (positions, triangles) = soup(10_000, &mut rng);
    let scene = mesh_scene(positions, Vec::new(), triangles);
    let mut rays = Vec::new();
    for k in 0..4096 {
        let o = rng.in_box(Vec3::splat(-75.0), Vec3::splat(75.0));
        let d = rng.direction();
        // Some rays limited to a random length, so that any-hit and the t_max cull are exercised.
        let t_max = if k % 3 == 0 {
            5.0 + 60.0 * rng.next()
        } else {
            T_MISS
        };
        rays.push(ray(o, d, t_max));
    }
    // Axis-parallel rays: 1/d is infinite on two axes.
    for k in 0..512 {
        let o = rng.in_box(Vec3::splat(-60.0), Vec3::splat(60.0));
        let mut d = Vec3::ZERO;
        d[k % 3] = if k % 2 == 0 { 1.0 } else { -1.0 };
        rays.push(ray(o, d, T_MISS));
    }
    let steps = compare_with_brute_force(&scene, &rays, 0, "soup");
    let max = *steps.iter().max().unwrap();
    assert!(max < MAX_STEPS / 2, "a walk took {max} iterations");
}

#[test]
fn bvh_matches_brute_force_on_a_closed_sphere_and_nothing_leaks() {
    // icosphere(5): 20,480 triangles of radius 10, off the origin.
    let center = Vec3::new(3.0, -2.0, 1.0);
    let shape = shapes::icosphere(5).transformed(10.0, center);
    let vertices = shape.positions.clone();
    let scene = mesh_scene(shape.positions, Vec::new(), shape.triangles);
    let mut rng = Rng(11);
    let mut rays = Vec::new();
    // From inside, aimed exactly at vertices (where up to six triangles meet) and at random directions:
    // every one must hit. From outside, random rays.
    for (k, v) in vertices.iter().enumerate().step_by(4) {
        let o = center + rng.direction() * (k % 7) as f32;
        rays.push(ray(o, (*v - o).normalize(), T_MISS));
    }
    let inside = rays.len();
    for _ in 0..1024 {
        let o = center + rng.direction() * 9.0 * rng.next();
        rays.push(ray(o, rng.direction(), T_MISS));
    }
    let inside_all = rays.len();
    for _ in 0..1024 {
        let o = center + rng.direction() * (10.5 + 20.0 * rng.next());
        let target = center + rng.direction() * 12.0 * rng.next();
        rays.push(ray(o, (target - o).normalize(), T_MISS));
    }
    let (mut k, _) = SceneKernel::new(&scene, include_str!("../shaders/tests/bvh_query.wgsl"));
    let out = k.run(&rays[..inside_all], 2, [0, 0, 1, 0]);
    let leaks = (0..inside_all)
        .filter(|&i| out[2 * i][1].to_bits() == NONE)
        .count();
    assert_eq!(
        leaks, 0,
        "{leaks} rays from inside escaped the closed mesh ({inside} aimed at vertices)"
    );
    compare_with_brute_force(&scene, &rays, inside, "icosphere(5)");
}

/// The walk's iteration count on meshes of growing size: far below the cap, growing with log N.
#[test]
fn bvh_walks_stay_far_below_the_step_cap() {
    let mut rng = Rng(3);
    let mut report = Vec::new();
    for level in [3u32, 5, 6] {
        let shape = shapes::icosphere(level).transformed(10.0, Vec3::ZERO);
        let n = shape.triangles.len();
        let scene = mesh_scene(shape.positions, Vec::new(), shape.triangles);
        let (mut k, _) = SceneKernel::new(&scene, include_str!("../shaders/tests/bvh_query.wgsl"));
        let mut rays = Vec::new();
        for j in 0..2048 {
            // Half from inside, half from outside towards the sphere (grazing ones included).
            let o = if j % 2 == 0 {
                rng.direction() * 9.9 * rng.next()
            } else {
                rng.direction() * 40.0
            };
            let d = if j % 2 == 0 {
                rng.direction()
            } else {
                (rng.direction() * 10.5 - o).normalize()
            };
            rays.push(ray(o, d, T_MISS));
        }
        let out = k.run(&rays, 2, [0, 0, 1, 0]);
        let steps: Vec<u32> = (0..rays.len()).map(|i| out[2 * i][2] as u32).collect();
        let inside_hits = (0..rays.len())
            .step_by(2)
            .filter(|&i| out[2 * i][1].to_bits() != NONE)
            .count();
        assert_eq!(inside_hits, rays.len() / 2, "rays from inside must hit");
        let max = *steps.iter().max().unwrap();
        let mean = steps.iter().map(|&s| s as f64).sum::<f64>() / steps.len() as f64;
        report.push((n, mean, max));
        assert!(
            max < MAX_STEPS / 4,
            "{n} triangles: a walk took {max} of at most {MAX_STEPS} iterations"
        );
    }
    // Logarithmic growth: 64x the triangles (1280 -> 81,920) costs far less than 64x the iterations.
    let (small, large) = (report[0], report[2]);
    assert!(
        large.1 < 4.0 * small.1,
        "mean iterations grew from {:.1} to {:.1}: {report:?}",
        small.1,
        large.1
    );
    eprintln!("BVH walk iterations (triangles, mean, max): {report:?}");
}

/// Smooth normals: on both sides of every shared edge of a coarse sphere mesh, a few thousandths of an
/// edge away, the interpolated normals agree while the faces' geometric normals differ by the edge's
/// dihedral angle.
#[test]
fn smooth_normals_are_continuous_across_shared_edges() {
    let shape = shapes::icosphere(2).transformed(10.0, Vec3::ZERO);
    let positions = shape.positions.clone();
    let tris = shape.triangles.clone();
    let scene = mesh_scene(shape.positions, shape.normals, shape.triangles);
    // Edges with their two faces.
    let mut faces_of_edge: std::collections::HashMap<(u32, u32), Vec<usize>> = Default::default();
    for (f, t) in tris.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            faces_of_edge
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(f);
        }
    }
    let centroid = |f: usize| tris[f].iter().map(|&i| positions[i as usize]).sum::<Vec3>() / 3.0;
    let mut rays = Vec::new();
    let mut edges = Vec::new();
    for (&(a, b), faces) in &faces_of_edge {
        assert_eq!(faces.len(), 2, "the icosphere is closed");
        let m = (positions[a as usize] + positions[b as usize]) * 0.5;
        for &f in faces {
            // A point just inside face f, 0.2% of the way from the edge's midpoint to f's centroid,
            // hit by a ray from outside along the radius.
            let p = m + (centroid(f) - m) * 2e-3;
            let o = p * 3.0;
            rays.push(ray(o, (p - o).normalize(), T_MISS));
        }
        edges.push((a, b));
    }
    let (mut k, _) = SceneKernel::new(&scene, include_str!("../shaders/tests/mesh_surface.wgsl"));
    let out = k.run(&rays, 3, [0; 4]);
    let v3 = |q: [f32; 4]| Vec3::new(q[0], q[1], q[2]);
    let mut worst_ratio = 0.0f32;
    for e in 0..edges.len() {
        let (a, b) = (2 * e, 2 * e + 1);
        assert!(
            out[3 * a][3].to_bits() != out[3 * b][3].to_bits(),
            "edge {e}: both rays hit the same triangle"
        );
        assert_eq!(out[3 * a + 1][3], 1.0, "interpolated normal expected");
        let (n1, n2) = (v3(out[3 * a]), v3(out[3 * b]));
        let (s1, s2) = (v3(out[3 * a + 1]), v3(out[3 * b + 1]));
        let geometric_jump = (n1 - n2).length();
        let shading_jump = (s1 - s2).length();
        assert!(
            geometric_jump > 0.1,
            "edge {e}: geometric normals should differ"
        );
        worst_ratio = worst_ratio.max(shading_jump / geometric_jump);
        // The shading normal there is the mean of the edge's two vertex normals, up to the 0.2% step.
        let expected =
            (positions[edges[e].0 as usize] + positions[edges[e].1 as usize]).normalize();
        assert!(
            (s1 - expected).length() < 0.01,
            "edge {e}: {s1} vs {expected}"
        );
    }
    assert!(
        worst_ratio < 0.02,
        "shading normals jump by {worst_ratio} of the geometric jump across an edge"
    );
}

/// A scene of `n` spheres of random sizes scattered in a box (they may overlap) under a uniform sky.
fn sphere_scene(n: usize, rng: &mut Rng) -> Scene {
    let mut s = common::scene(&format!(
        "{MINIMAL}\n[environment]\nradiance = [1.0, 1.0, 1.0]\n"
    ));
    for _ in 0..n {
        s.spheres.push(vkpath::scene::Sphere {
            center: rng.in_box(Vec3::splat(-20.0), Vec3::splat(20.0)),
            radius: 0.2 + 2.0 * rng.next(),
            material: 0,
        });
    }
    s
}

/// The spheres' BVH (scenes of at least `upload::SPHERE_BVH_MIN` spheres) against the loop over every
/// sphere, over random rays from inside and outside the cloud of 2000 spheres, grazing ones included:
/// the same closest t, bit for bit, and the same sphere (the walk tests each sphere with the loop's own
/// intersect_sphere, so only exact ties could differ); the any-hit walk agrees on occlusion; and a walk
/// visits far fewer boxes and spheres than the loop tests spheres.
#[test]
fn sphere_bvh_matches_the_sphere_loop() {
    let mut rng = Rng(11);
    let scene = sphere_scene(2000, &mut rng);
    let (mut k, gpu) = SceneKernel::new(&scene, include_str!("../shaders/tests/bvh_query.wgsl"));
    assert!(
        !gpu.sphere_nodes.is_empty(),
        "2000 spheres get a BVH (upload::SPHERE_BVH_MIN = {})",
        vkpath::kernel::upload::SPHERE_BVH_MIN
    );
    let mut rays = Vec::new();
    for j in 0..4096 {
        let o = if j % 2 == 0 {
            rng.in_box(Vec3::splat(-25.0), Vec3::splat(25.0))
        } else {
            rng.direction() * 60.0
        };
        // Every fourth ray aims at a sphere's silhouette (grazing), the others anywhere.
        let d = if j % 4 == 1 {
            let s =
                gpu.spheres[(rng.next() * gpu.spheres.len() as f32) as usize % gpu.spheres.len()];
            let c = Vec3::from(s.center);
            let to = (c - o).normalize();
            let side = to.cross(rng.direction()).normalize();
            (c + side * s.radius - o).normalize()
        } else {
            rng.direction()
        };
        rays.push(ray(o, d, T_MISS));
    }
    let out = k.run(&rays, 2, [0, gpu.spheres.len() as u32, 1, 1]);
    let mut hits = 0;
    let mut steps = 0.0;
    for i in 0..rays.len() {
        let (walk, looped) = (out[2 * i], out[2 * i + 1]);
        assert_eq!(
            walk[0].to_bits(),
            looped[0].to_bits(),
            "ray {i}: walk t {} against loop t {}",
            walk[0],
            looped[0]
        );
        assert_eq!(
            walk[1].to_bits(),
            looped[1].to_bits(),
            "ray {i}: another sphere"
        );
        let hit = looped[1].to_bits() != NONE;
        assert_eq!(walk[3] == 1.0, hit, "ray {i}: any-hit walk disagrees");
        hits += usize::from(hit);
        steps += f64::from(walk[2]);
    }
    let mean_steps = steps / rays.len() as f64;
    eprintln!(
        "{hits} of {} rays hit; {mean_steps:.1} walk iterations a ray",
        rays.len()
    );
    assert!(
        hits > rays.len() / 4 && hits < rays.len(),
        "{hits} hits: a poor test"
    );
    assert!(
        mean_steps < 200.0,
        "{mean_steps} iterations a ray: the walk is no better than the loop's 2000"
    );
}

/// Renders of a field of spheres through their BVH and through the loop over every sphere (the same
/// kernel with the sphere BVH feature off; the same uploaded spheres): the same bits, as each ray finds
/// the same closest sphere either way.
#[test]
fn spheres_through_their_bvh_render_the_loops_bits() {
    use vkpath::kernel::features::{Feature, FeatureSet};
    use vkpath::render::{RenderOptions, Renderer, kernel_for};
    let mut rng = Rng(5);
    let mut scene = sphere_scene(300, &mut rng);
    scene.image.width = 48;
    scene.image.height = 32;
    let ctx = testing::context();
    let options = RenderOptions::default();
    let gpu = GpuScene::build(&scene);
    assert!(!gpu.sphere_nodes.is_empty());
    let mut features = FeatureSet::of(&gpu, &params_for(&scene, options.roulette_depth));
    assert!(features.has(Feature::SphereBvh));
    let mut through_tree = Renderer::new(&ctx, &scene, &options).unwrap();
    through_tree.run_pass(4).unwrap();
    features.set(Feature::SphereBvh, false);
    let mut looped =
        Renderer::with_kernel(&ctx, &scene, &options, kernel_for(&features).unwrap()).unwrap();
    looped.run_pass(4).unwrap();
    let (a, b) = (through_tree.film().unwrap(), looped.film().unwrap());
    assert!(
        a.mean.iter().any(|p| p[0] > 0.0),
        "a black image tests nothing"
    );
    assert_eq!(a.mean, b.mean, "the sphere BVH changed the image");
    common::assert_no_validation_errors();
}

/// The spheres' BVH reorders the spheres (their leaf order) and renumbers what refers to them: the sphere
/// lights. Fifteen spheres, three of them lamps (sphere lights, sampled by next-event estimation), render
/// through the loop; the same fifteen plus a sixteenth far behind the camera, which turns the BVH on
/// (upload::SPHERE_BVH_MIN) and changes nothing the camera sees, render the same bits.
#[test]
fn spheres_reordered_by_their_bvh_keep_their_lights() {
    assert_eq!(vkpath::kernel::upload::SPHERE_BVH_MIN, 16);
    let base = format!(
        "{MINIMAL}lamp = {{ type = \"emitter\", radiance = [6.0, 5.0, 4.0] }}\n[image]\nwidth = 40\nheight = 30\n"
    );
    let mut rng = Rng(21);
    let mut spheres = String::new();
    for k in 0..15 {
        let c = rng.in_box(Vec3::new(-15.0, -10.0, -15.0), Vec3::new(15.0, 10.0, 5.0));
        let material = if k % 5 == 2 { "lamp" } else { "white" };
        spheres += &format!(
            "[[sphere]]\ncenter = [{}, {}, {}]\nradius = {}\nmaterial = \"{material}\"\n",
            c.x,
            c.y,
            c.z,
            1.0 + 2.0 * rng.next()
        );
    }
    let fifteen = common::scene(&format!("{base}{spheres}"));
    let sixteen = common::scene(&format!(
        "{base}{spheres}[[sphere]]\ncenter = [0.0, 0.0, 400.0]\nradius = 1.0\nmaterial = \"white\"\n"
    ));
    assert!(GpuScene::build(&fifteen).sphere_nodes.is_empty());
    assert!(!GpuScene::build(&sixteen).sphere_nodes.is_empty());
    let (a, b) = (common::render(&fifteen), common::render(&sixteen));
    assert!(
        a.mean.iter().any(|p| p[0] > 0.0),
        "a black image tests nothing"
    );
    assert_eq!(
        a.mean, b.mean,
        "the sphere BVH changed what the lamps light"
    );
}
