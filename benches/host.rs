//! Host-side costs, with criterion: what the CPU spends around the GPU's work.
//!
//! - scene parse + build: the course scene's TOML to a validated `Scene`, then to the GPU's Pod arrays;
//! - BVH build (binned SAH) over icospheres of 20 480 and 81 920 triangles (~10^4 and ~10^5);
//! - film readback (`Renderer::film`) of a 512x512 render: the copy to the staging buffer, the map, and
//!   the conversion of the sums to means and variances (needs a Vulkan device: lavapipe will do; skipped
//!   with a message when there is none);
//! - the display transform `Film::to_rgb8`, and EXR encoding of the linear image.
//!
//! `cargo bench --bench host`; a quick look: `cargo bench --bench host -- --quick`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use vkpath::gpu::{ContextOptions, GpuContext};
use vkpath::kernel::upload::GpuScene;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::scene::{DEFAULT_SCENE_TOML, Scene, bvh, shapes};

fn scene_build(c: &mut Criterion) {
    c.bench_function("scene parse+build (course)", |b| {
        b.iter(|| {
            let scene = Scene::from_toml_str(black_box(DEFAULT_SCENE_TOML), None)
                .expect("the course scene parses");
            black_box(GpuScene::build(&scene))
        })
    });
}

fn bvh_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("bvh build (icosphere)");
    group.sample_size(10);
    // 20 * 4^s triangles: 20 480 and 81 920.
    for s in [5u32, 6] {
        let shape = shapes::icosphere(s);
        let triangles: Vec<[glam::Vec3; 3]> = shape
            .triangles
            .iter()
            .map(|t| t.map(|i| shape.positions[i as usize]))
            .collect();
        group.bench_with_input(
            BenchmarkId::from_parameter(triangles.len()),
            &triangles,
            |b, t| b.iter(|| black_box(bvh::build(t))),
        );
    }
    group.finish();
}

fn film(c: &mut Criterion) {
    let mut scene = Scene::default_scene();
    scene.image.width = 512;
    scene.image.height = 512;
    let ctx = match GpuContext::new(&ContextOptions::default()) {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("film benches skipped: no Vulkan device ({e})");
            return;
        }
    };
    let mut renderer =
        Renderer::new(&ctx, &scene, &RenderOptions::default()).expect("the renderer starts");
    renderer.run_pass(1).expect("one pass renders");
    let mut group = c.benchmark_group("film 512x512");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(5));
    group.bench_function("readback (Renderer::film)", |b| {
        b.iter(|| black_box(renderer.film().expect("readback")))
    });
    let film = renderer.film().expect("readback");
    group.bench_function("to_rgb8", |b| {
        b.iter(|| black_box(film.to_rgb8(&scene.image)))
    });
    group.bench_function("EXR encode", |b| {
        b.iter(|| {
            let mut bytes = std::io::Cursor::new(Vec::new());
            film.to_rgb32f()
                .write_to(&mut bytes, image::ImageFormat::OpenExr)
                .expect("EXR encodes");
            black_box(bytes)
        })
    });
    group.finish();
}

criterion_group!(benches, scene_build, bvh_build, film);
criterion_main!(benches);
