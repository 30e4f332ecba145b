//! The mesh scaling benchmark: generated meshes of growing size in the course's box, rendered with the
//! BVH; build time, BVH size and samples per second per size, and the BVH against the brute-force loop
//! over every triangle on the small sizes. Nothing here asserts a time: the numbers are for the README.
//!
//! With a BVH the cost of a ray grows with log N, not N: the table reports each size's cost per sample
//! relative to the smallest and log2(N) relative to the smallest's, which should roughly agree.

use super::BenchSettings;
use crate::Error;
use crate::gpu::GpuContext;
use crate::kernel::features::FeatureSet;
use crate::kernel::upload::{GpuScene, params_for};
use crate::render::{
    LAVAPIPE_LOOP_BUDGET, RenderOptions, Renderer, kernel_for, worst_case_loop_iterations,
};
use crate::scene::{Mesh, Scene, shapes};
use std::sync::Arc;
use std::time::Instant;

/// One size of the scaling benchmark.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MeshScalingRow {
    pub triangles: usize,
    pub bvh_build_ms: f64,
    pub bvh_nodes: usize,
    pub bvh_depth: usize,
    /// Bytes of scene data on the device (triangles, BVH, spheres, ...).
    pub scene_bytes: u64,
    /// With the course's settings (5 bounces, the sphere light, Russian roulette from 3).
    pub samples_per_second: f64,
    /// Direct lighting only (max_bounces = 1), where the brute-force loop stays within lavapipe's loop
    /// budget: the BVH kernel and, on the sizes given, the brute-force one.
    pub direct_samples_per_second: f64,
    pub direct_brute_force_samples_per_second: Option<f64>,
}

/// The largest mesh `vkpath bench mesh` builds: ten times its largest default size.
pub const MAX_BENCH_TRIANGLES: usize = 10_000_000;

/// A closed, wavy blob of about `target` triangles and radius about 10: a latitude–longitude grid whose
/// radius is modulated, r = 10 (1 + 0.12 sin(5 theta) sin(4 phi)), so that rays meet it at every angle.
pub fn blob(target: usize) -> shapes::Shape {
    // A grid of s segments by r rings has 2 s (r - 1) triangles; s = 2 r.
    let rings = ((target as f64 / 4.0).sqrt().round() as u32).max(3);
    let mut s = shapes::uv_sphere(2 * rings, rings);
    for p in &mut s.positions {
        let d = p.as_dvec3();
        let theta = d.y.clamp(-1.0, 1.0).acos();
        let phi = d.z.atan2(d.x);
        let r = 10.0 * (1.0 + 0.12 * (5.0 * theta).sin() * (4.0 * phi).sin());
        *p = (d * r).as_vec3();
    }
    // Normals are recomputed from the faces by the renderer's own rule.
    s.normals = crate::scene::mesh::vertex_normals(&s.positions, &s.triangles);
    s.uvs.clear();
    s
}

/// The course's box (walls, sphere light) with the blob instead of the three balls.
pub fn scaling_scene(triangles: usize, settings: &BenchSettings) -> Scene {
    let mut scene = Scene::default_scene();
    scene.spheres.truncate(6);
    scene.image.width = settings.width;
    scene.image.height = settings.height;
    let shape = blob(triangles);
    scene.meshes.push(Mesh {
        obj: format!("<generated blob of {} triangles>", shape.triangles.len()).into(),
        positions: shape.positions,
        normals: shape.normals,
        uvs: Vec::new(),
        tangents: Vec::new(),
        triangles: shape.triangles,
        material: 4, // the course's white
        texture: None,
        maps: Default::default(),
    });
    scene
}

/// The middle of `v`, the upper of the two middle values for an even count (not their mean, as
/// [`super::median`] takes): kept as the mesh table has always computed it, so that its numbers do not
/// change with the move; `runs` is odd by default.
fn upper_median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Samples per second of `renderer`: one untimed pass (of one sample per pixel), then the median of
/// `runs` passes of `spp`.
fn throughput(renderer: &mut Renderer, settings: &BenchSettings) -> Result<f64, Error> {
    renderer.run_pass(1)?;
    let samples = f64::from(settings.width) * f64::from(settings.height) * f64::from(settings.spp);
    let mut rates = Vec::new();
    for _ in 0..settings.runs.max(1) {
        let t = Instant::now();
        renderer.run_pass(settings.spp)?;
        rates.push(samples / t.elapsed().as_secs_f64());
    }
    Ok(upper_median(rates))
}

/// Renders each size (e.g. 10^3 .. 10^6 triangles) and measures it; `brute_force_up_to` adds the
/// brute-force kernel for the sizes up to that many triangles.
pub fn mesh_scaling(
    ctx: &Arc<GpuContext>,
    sizes: &[usize],
    settings: BenchSettings,
    brute_force_up_to: usize,
) -> Result<Vec<MeshScalingRow>, Error> {
    let options = RenderOptions {
        samples_per_pass: Some(settings.spp),
        ..Default::default()
    };
    let mut rows = Vec::new();
    for &size in sizes {
        let mut scene = scaling_scene(size, &settings);
        let mut renderer = Renderer::new(ctx, &scene, &options)?;
        let stats = *renderer.scene_stats();
        let samples_per_second = throughput(&mut renderer, &settings)?;
        drop(renderer);

        scene.render.max_bounces = 1;
        let mut direct = Renderer::new(ctx, &scene, &options)?;
        let direct_samples_per_second = throughput(&mut direct, &settings)?;
        drop(direct);

        let direct_brute_force_samples_per_second = if stats.triangles <= brute_force_up_to {
            // The brute-force loop runs every triangle per query: check lavapipe's loop budget
            // ourselves, since the renderer's bound assumes the BVH.
            let gpu = GpuScene::build(&scene);
            let per_query = (gpu.spheres.len() + gpu.triangles.len()) as u64;
            let lights = gpu.lights.len() as u64;
            let bound = 2 * (per_query + lights * (per_query + 1) + 1) + 1;
            let device = &ctx.device_info().name;
            if device.contains("llvmpipe") && bound > LAVAPIPE_LOOP_BUDGET {
                return Err(Error::Usage(format!(
                    "the brute-force kernel over {} triangles could run {bound} loop iterations, more \
                     than lavapipe's {LAVAPIPE_LOOP_BUDGET}: compare at fewer triangles",
                    stats.triangles
                )));
            }
            debug_assert!(worst_case_loop_iterations(&gpu, 1) <= bound);
            let mut features = FeatureSet::of(&gpu, &params_for(&scene, options.roulette_depth));
            features.set(crate::kernel::features::Feature::Bvh, false);
            features.set(crate::kernel::features::Feature::TriangleLoop, true);
            if !crate::render::uniform_arrays_help(ctx.device_info()) {
                features.without_uniform_arrays();
            }
            let kernel = kernel_for(&features)?;
            let mut brute = Renderer::with_kernel(ctx, &scene, &options, kernel)?;
            // Hundreds of times slower: one timed pass is plenty.
            let once = BenchSettings {
                runs: 1,
                ..settings
            };
            Some(throughput(&mut brute, &once)?)
        } else {
            None
        };
        rows.push(MeshScalingRow {
            triangles: stats.triangles,
            bvh_build_ms: stats.bvh_build_ms,
            bvh_nodes: stats.bvh_nodes,
            bvh_depth: stats.bvh_depth,
            scene_bytes: stats.scene_bytes,
            samples_per_second,
            direct_samples_per_second,
            direct_brute_force_samples_per_second,
        });
    }
    Ok(rows)
}

/// The rows as a Markdown table, with the cost ratios against the first row.
pub fn mesh_scaling_table(
    rows: &[MeshScalingRow],
    settings: BenchSettings,
    device: &str,
) -> String {
    let mut out = format!(
        "Mesh scaling in the course's box, {}x{}, {} spp per timed pass, median of {} passes, on {device}.\n\n\
         | triangles | BVH build (ms) | BVH nodes | depth | scene MB | Msamples/s (5 bounces) | cost / first | log2 N / first | Msamples/s direct, BVH | Msamples/s direct, brute force | BVH / brute force |\n\
         | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        settings.width,
        settings.height,
        settings.spp,
        settings.runs.max(1)
    );
    let Some(first) = rows.first() else {
        return out;
    };
    for r in rows {
        let cost = first.samples_per_second / r.samples_per_second;
        let logs = (r.triangles as f64).log2() / (first.triangles as f64).log2();
        let (brute, ratio) = match r.direct_brute_force_samples_per_second {
            Some(b) => (
                format!("{:.3}", b / 1e6),
                format!("{:.1}", r.direct_samples_per_second / b),
            ),
            None => (String::new(), String::new()),
        };
        out.push_str(&format!(
            "| {} | {:.1} | {} | {} | {:.1} | {:.3} | {:.2} | {:.2} | {:.3} | {brute} | {ratio} |\n",
            r.triangles,
            r.bvh_build_ms,
            r.bvh_nodes,
            r.bvh_depth,
            r.scene_bytes as f64 / 1e6,
            r.samples_per_second / 1e6,
            cost,
            logs,
            r.direct_samples_per_second / 1e6,
        ));
    }
    out
}

/// The sizes of the table: 10^3, 10^4, 10^5, 10^6.
pub const DEFAULT_SIZES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blobs_have_about_the_asked_size_and_are_closed_and_outward() {
        for target in [1_000usize, 10_000] {
            let s = blob(target);
            let n = s.triangles.len();
            assert!(
                (n as f64 - target as f64).abs() < 0.1 * target as f64,
                "{n} for {target}"
            );
            // Signed volume by the divergence theorem: positive when faces wind outward.
            let volume: f64 = s
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| s.positions[i as usize].as_dvec3());
                    a.dot(b.cross(c)) / 6.0
                })
                .sum();
            let sphere = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
            assert!((volume / sphere - 1.0).abs() < 0.1, "volume {volume}");
        }
    }
}
