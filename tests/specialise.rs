//! Per-scene specialisation: the kernel compiled for a scene's feature set renders exactly what the
//! generic kernel renders, and the code of absent features is gone before the driver sees the SPIR-V.

mod common;

use common::*;
use vkpath::kernel::abi::{
    LIGHT_ENVIRONMENT, LIGHT_POINT, LIGHT_SPHERE, MAT_DIELECTRIC, MAT_DIFFUSE, MAT_EMITTER,
    MAT_MIRROR,
};
use vkpath::kernel::features::{Feature as F, FeatureSet};
use vkpath::render::{RenderOptions, kernel_for};

fn scene_files() -> Vec<std::path::PathBuf> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 14,
        "expected the course scenes, found {files:?}"
    );
    files
}

/// Every scene in scenes/ and its subfolders (TOML, glTF, Mitsuba XML).
fn every_scene_file() -> Vec<std::path::PathBuf> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files = scene_files();
    for (dir, ext) in [("gltf", "gltf"), ("mitsuba", "xml")] {
        let mut more: Vec<_> = std::fs::read_dir(root.join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .collect();
        more.sort();
        assert!(!more.is_empty(), "no .{ext} scene in scenes/{dir}");
        files.extend(more);
    }
    files
}

/// Every scene in scenes/ and its subfolders rendered in one pass of 6 samples, and split: passes of 1,
/// 2 and 3 samples, in 8 x 8 tiles, with one ray cast per dispatch (every path saved and continued by
/// the next dispatch, the queue in whatever order the invocations append to it): the same bits. The
/// sums are exact and each sample a function of (pixel, sample index, seed) only, so nothing may
/// differ.
#[test]
fn any_split_equals_one_render_for_every_scene() {
    for path in every_scene_file() {
        let mut s = vkpath::Scene::load(&path).unwrap();
        s.image.width = 20;
        s.image.height = 12;
        let one = render_passes(&s, &RenderOptions::default(), 1, 6);
        let options = RenderOptions {
            max_tile: Some([8, 8]),
            casts_per_dispatch: Some(1),
            ..Default::default()
        };
        let ctx = vkpath::gpu::testing::context();
        let mut r = vkpath::Renderer::new(&ctx, &s, &options).unwrap();
        for spp in [1, 2, 3] {
            r.run_pass(spp).unwrap();
        }
        let split = r.film().unwrap();
        assert_no_validation_errors();
        assert_eq!(
            one.mean,
            split.mean,
            "{}: a split render differs from one render",
            path.display()
        );
        assert!(one.average() > 0.0, "{}: black image", path.display());
    }
}

/// Every scene in scenes/ and its subfolders, specialised and generic, same seed: the same bits. A present feature runs the
/// generic code unchanged and absent ones draw no random numbers, so nothing may differ (not even by
/// float reassociation: both kernels evaluate the same expressions in the same order).
#[test]
fn specialised_equals_generic_for_every_scene() {
    use vkpath::scene::{LightSampling, Sampler};
    // Every scene with the default knobs; the soft-shadows scene (a sphere light) also with each
    // sampler and light-sampling strategy, which are specialisation constants too.
    let soft = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/10-soft-shadows.toml");
    let mut cases: Vec<_> = every_scene_file().into_iter().map(|p| (p, None)).collect();
    for knobs in [
        (Sampler::Sobol, LightSampling::Cone),
        (Sampler::Independent, LightSampling::Area),
        (Sampler::Sobol, LightSampling::None),
        (Sampler::Independent, LightSampling::Mis),
    ] {
        cases.push((soft.clone(), Some(knobs)));
    }
    for (path, knobs) in cases {
        let mut s = vkpath::Scene::load(&path).unwrap();
        s.image.width = 24;
        s.image.height = 24;
        if let Some((sampler, light_sampling)) = knobs {
            s.render.sampler = sampler;
            s.render.light_sampling = light_sampling;
        }
        let specialised = render_passes(&s, &RenderOptions::default(), 1, 4);
        let generic = render_passes(
            &s,
            &RenderOptions {
                generic: true,
                ..Default::default()
            },
            1,
            4,
        );
        assert_eq!(
            specialised.mean,
            generic.mean,
            "{} {knobs:?}: specialised and generic images differ",
            path.display()
        );
        assert!(
            specialised.average() > 0.0,
            "{}: black image",
            path.display()
        );
    }
}

fn function_names(features: &FeatureSet) -> Vec<String> {
    let compiled = kernel_for(features).unwrap();
    compiled
        .module
        .functions
        .iter()
        .filter_map(|(_, f)| f.name.clone())
        .collect()
}

/// The course's first steps use only diffuse spheres and a point light: their kernel has no triangle
/// test, no Fresnel, no refraction, no cone sampling, no lens, and no triangle buffer; the generic kernel
/// has all of them. The SPIR-V shrinks accordingly.
#[test]
fn absent_features_leave_no_code() {
    let mut s = vkpath::Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/03-shadows.toml"),
    )
    .unwrap();
    // With the independent sampler the kernel has no Sobol' code either (the default is Sobol').
    s.render.sampler = vkpath::scene::Sampler::Independent;
    let gpu = vkpath::kernel::upload::GpuScene::build(&s);
    let params = vkpath::kernel::upload::params_for(&s, RenderOptions::default().roulette_depth);
    let features = FeatureSet::of(&gpu, &params);
    assert!(
        features.has(F::Spheres)
            && features.has(F::Material(MAT_DIFFUSE))
            && features.has(F::Light(LIGHT_POINT))
    );
    assert!(
        !features.has(F::Triangles)
            && !features.has(F::Material(MAT_MIRROR))
            && !features.has(F::Material(MAT_DIELECTRIC))
            && !features.has(F::Light(LIGHT_SPHERE))
            && !features.has(F::Lens)
    );

    let trimmed = function_names(&features);
    let generic = function_names(&FeatureSet::generic());
    for f in [
        "intersect_triangle_ray",
        "fresnel_dielectric",
        "refract_dir",
        "sample_cone_local",
        "sample_uniform_disk",
        "triangle_surface",
        "sobol_owen2",
        "sphere_light_sample_area",
        "sphere_light_sample_cone",
        "dielectric_sample",
        "mirror_sample",
        "ggx_sample_visible",
        "fresnel_conductor",
        "conductor_sample",
        "rough_dielectric_sample",
        "coated_sample",
        "surface_tangent",
    ] {
        assert!(
            generic.iter().any(|n| n == f),
            "the generic kernel should contain {f}"
        );
        assert!(
            !trimmed.iter().any(|n| n == f),
            "the diffuse/point-light kernel still contains {f}"
        );
    }
    // The --aov layers' path loop: only in a layer's kernel, generic or not, never in a render's.
    let mut layer_params = params;
    layer_params.aov = vkpath::kernel::abi::AOV_ALBEDO;
    let generic_layer = function_names(&FeatureSet::generic_for(&gpu, &layer_params));
    let layer = function_names(&FeatureSet::of(&gpu, &layer_params));
    for f in ["aov_step", "bsdf_albedo"] {
        assert!(
            generic_layer.iter().any(|n| n == f) && layer.iter().any(|n| n == f),
            "a layer's kernels should contain {f}"
        );
        assert!(
            !generic.iter().any(|n| n == f) && !trimmed.iter().any(|n| n == f),
            "a render's kernels should not contain {f}"
        );
    }
    let spirv_trimmed = kernel_for(&features).unwrap().spirv.len();
    let spirv_generic = kernel_for(&FeatureSet::generic()).unwrap().spirv.len();
    assert!(
        (spirv_trimmed as f64) < 0.8 * spirv_generic as f64,
        "SPIR-V words: specialised {spirv_trimmed}, generic {spirv_generic}"
    );
    let bindings: Vec<String> = kernel_for(&features)
        .unwrap()
        .bindings
        .iter()
        .map(|b| b.name.clone())
        .collect();
    assert!(
        !bindings.iter().any(|b| b == "triangles"),
        "no triangle buffer binding without triangles: {bindings:?}"
    );
}

/// The feature set follows the scene: materials count only when an object uses them, the lens only with
/// an aperture, roulette only when it can trigger, the background only when it is not black.
#[test]
fn feature_set_follows_the_scene() {
    let base = r#"
[camera]
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
fov = 60.0
[render]
max_bounces = 2
[materials]
white = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
glass = { type = "dielectric", ior = 1.5 }
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "white"
"#;
    let features = |text: &str, roulette_depth: u32| {
        let s = scene(text);
        let gpu = vkpath::kernel::upload::GpuScene::build(&s);
        FeatureSet::of(
            &gpu,
            &vkpath::kernel::upload::params_for(&s, roulette_depth),
        )
    };
    let f = features(base, 3);
    assert!(
        !f.has(F::Material(MAT_DIELECTRIC)),
        "glass is defined but unused"
    );
    assert!(
        !f.has(F::Roulette),
        "roulette from depth 3 never triggers with max_bounces = 2"
    );
    assert!(
        !f.has(F::Lens)
            && !f.has(F::Light(LIGHT_ENVIRONMENT))
            && !f.has(F::Light(LIGHT_POINT))
            && !f.has(F::Light(LIGHT_SPHERE))
            && !f.has(F::Material(MAT_EMITTER))
    );
    assert_eq!(f.knob("filter"), Some(2), "gaussian by default");
    assert!(features(base, 2).has(F::Roulette));
    let with = base
        .replace("fov = 60.0", "fov = 60.0\naperture = 0.5")
        .replace("[render]", "[render]\nbackground = [0.0, 0.1, 0.0]")
        + "[[light]]\ntype = \"sphere\"\ncenter = [0.0, 5.0, 0.0]\nradius = 1.0\npower = 10.0\n";
    let f = features(&with, 3);
    assert!(
        f.has(F::Lens)
            && f.has(F::Light(LIGHT_ENVIRONMENT))
            && f.has(F::Light(LIGHT_SPHERE))
            && f.has(F::Material(MAT_EMITTER))
            && !f.has(F::Light(LIGHT_POINT))
    );
}

/// The hand-trimmed kernel (shaders/bench/) that bounds the specialised one in the benchmark follows
/// trace.wgsl step for step: on a scene of diffuse spheres and point lights it renders the same bits.
#[test]
fn trimmed_kernel_renders_the_same_image() {
    let mut s = vkpath::Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/07-indirect.toml"),
    )
    .unwrap();
    s.image.width = 24;
    s.image.height = 24;
    // The trimmed kernel draws independent numbers.
    s.render.sampler = vkpath::scene::Sampler::Independent;
    let specialised = render_passes(&s, &RenderOptions::default(), 1, 4);
    let trimmed_kernel = std::sync::Arc::new(
        vkpath::kernel::specialise::compile(&vkpath::kernel::library::trimmed_source()).unwrap(),
    );
    let ctx = vkpath::gpu::testing::context();
    let mut r =
        vkpath::Renderer::with_kernel(&ctx, &s, &RenderOptions::default(), trimmed_kernel).unwrap();
    r.run_pass(4).unwrap();
    let trimmed = r.film().unwrap();
    assert_eq!(specialised.mean, trimmed.mean);
    assert_no_validation_errors();
}

/// Mesh textures are features like the others: a quad with a base colour texture needs `textures` only;
/// on an emitting material the texture also multiplies the emission (`emissive_textures`); the code of
/// an absent texture feature or surface modifier is pruned (the kernel with it switched on is larger).
#[test]
fn texture_features_follow_the_scene_and_prune() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
        .save(dir.path().join("tex.png"))
        .unwrap();
    let text = |material: &str| {
        format!(
            "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 40\n[materials]\nm = {material}\n\
             [[mesh]]\nobj = {:?}\nmaterial = \"m\"\ntexture = {:?}\n",
            dir.path().join("quad.obj"),
            dir.path().join("tex.png")
        )
    };
    let features = |text: &str| {
        let s = scene(text);
        let gpu = vkpath::kernel::upload::GpuScene::build(&s);
        FeatureSet::of(
            &gpu,
            &vkpath::kernel::upload::params_for(&s, RenderOptions::default().roulette_depth),
        )
    };
    let plain = features(&text("{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }"));
    assert!(plain.has(F::Textures));
    assert!(
        !plain.has(F::EmissiveTextures)
            && !plain.has(F::MetallicRoughnessTextures)
            && !plain.has(F::NormalMaps)
    );
    let lamp = features(&text(
        "{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5], emission = [1.0, 1.0, 1.0] }",
    ));
    assert!(lamp.has(F::Textures) && lamp.has(F::EmissiveTextures));
    assert!(!lamp.has(F::MetallicRoughnessTextures));

    let words = |f: &FeatureSet| kernel_for(f).unwrap().spirv.len();
    // An emissive texture's code sits where emission is seen (HAS_EMISSION), so it is measured on the
    // emitting scene.
    let mut lamp_untextured = lamp;
    lamp_untextured.set(F::EmissiveTextures, false);
    assert!(words(&lamp_untextured) < words(&lamp));
    for name in [
        "metallic_roughness_textures",
        "normal_maps",
        "bump_maps",
        "opacity",
    ] {
        let mut with = plain;
        with.enable(name);
        assert!(
            words(&plain) < words(&with),
            "{name}: {} words without, {} with",
            words(&plain),
            words(&with)
        );
    }
}

/// A small scene's arrays are read from their uniform twins (abi::UNIFORM_ARRAYS), array by array: 20
/// spheres under a sphere light put the spheres, their tree and the lights in twins; 2100 spheres are
/// more than the spheres' twin holds (2048), so the kernel reads them from storage while their tree
/// and the lights stay in twins. The generic kernel has none. On a CPU device (lavapipe) the renderer
/// uses them; the bits against the generic kernel's storage reads are
/// `specialised_equals_generic_for_every_scene`'s to check (scenes/spheres.toml has 39 spheres).
#[test]
fn small_arrays_are_read_from_uniform_twins() {
    use vkpath::kernel::abi::UNIFORM_ARRAYS;
    use vkpath::kernel::specialise::BufferKind;
    let scene_of = |n: usize| {
        let mut text = String::from(
            "[camera]\nposition = [0, 0, 60]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nwidth = 16\n\
             height = 16\n[materials]\nw = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
             [[light]]\ntype = \"sphere\"\ncenter = [0, 30, 30]\nradius = 2\npower = 1000\n",
        );
        for i in 0..n {
            let (x, y) = ((i % 50) as f64 - 25.0, (i / 50) as f64 - 20.0);
            text +=
                &format!("[[sphere]]\ncenter = [{x}, {y}, 0]\nradius = 0.4\nmaterial = \"w\"\n");
        }
        vkpath::Scene::from_toml_str(&text, None).unwrap()
    };
    let twins = |s: &vkpath::Scene| -> Vec<(&str, bool, bool)> {
        let gpu = vkpath::kernel::upload::GpuScene::build(s);
        let features = FeatureSet::of(&gpu, &vkpath::kernel::upload::params_for(s, 3));
        let kernel = kernel_for(&features).unwrap();
        let bound = |name: &str, kind: BufferKind| {
            kernel
                .bindings
                .iter()
                .any(|b| b.name == name && b.kind == kind)
        };
        UNIFORM_ARRAYS
            .iter()
            .filter(|a| ["spheres", "sphere_nodes", "lights"].contains(&a.name))
            .map(|a| {
                (
                    a.name,
                    bound(a.uniform, BufferKind::Uniform),
                    bound(a.name, BufferKind::Storage),
                )
            })
            .collect()
    };
    let small = scene_of(20);
    assert_eq!(
        twins(&small),
        [
            ("spheres", true, false),
            ("sphere_nodes", true, false),
            ("lights", true, false)
        ]
    );
    assert_eq!(
        twins(&scene_of(2100)),
        [
            ("spheres", false, true),
            ("sphere_nodes", true, false),
            ("lights", true, false)
        ]
    );
    let generic = kernel_for(&FeatureSet::generic()).unwrap();
    assert!(
        generic
            .bindings
            .iter()
            .all(|b| b.kind != BufferKind::Uniform || !b.name.ends_with("_uniform"))
    );
    let renderer = vkpath::Renderer::new(
        &vkpath::gpu::testing::context(),
        &small,
        &RenderOptions::default(),
    )
    .unwrap();
    let helps = vkpath::render::uniform_arrays_help(vkpath::gpu::testing::context().device_info());
    assert_eq!(renderer.features().has_uniform_arrays(), helps);
}

/// The data images (gpu::image) hold the bytes of the storage buffers they replace: with every array
/// out of its uniform twin, a kernel that reads the BVH nodes, triangles, mesh faces and vertices and the
/// texels from images renders the same bits as one that reads them from storage, on meshes, instances (whose tree references and per-placement
/// nodes are node words too) and a textured glTF scene. And on lavapipe before Mesa 26 the renderer uses
/// them (render::data_images_help), with the image bindings in place of the storage ones.
#[test]
fn data_images_render_the_bits_of_storage_reads() {
    use vkpath::kernel::specialise::BufferKind;
    let ctx = vkpath::gpu::testing::context();
    for name in ["mesh.toml", "spot-instances.toml", "gltf-extensions.toml"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name);
        let mut s = vkpath::Scene::load(&path).unwrap();
        s.image.width = 24;
        s.image.height = 16;
        let gpu = vkpath::kernel::upload::GpuScene::build(&s);
        let mut features = FeatureSet::of(&gpu, &vkpath::kernel::upload::params_for(&s, 3));
        features.without_uniform_arrays();
        let mut with_images = features;
        with_images.set(F::DataImages, true);
        let render = |set: &FeatureSet| {
            let kernel = kernel_for(set).unwrap();
            let mut r =
                vkpath::Renderer::with_kernel(&ctx, &s, &RenderOptions::default(), kernel.clone())
                    .unwrap();
            r.run_pass(4).unwrap();
            (kernel, r.film().unwrap())
        };
        let (image_kernel, from_images) = render(&with_images);
        let (_, from_storage) = render(&features);
        let kind = |n: &str| {
            image_kernel
                .bindings
                .iter()
                .find(|b| b.name == n)
                .map(|b| b.kind)
        };
        let tree = features.has(F::Bvh).then_some(BufferKind::SampledImage);
        assert_eq!(kind("bvh_nodes_image"), tree, "{name}");
        assert_eq!(
            kind("triangles_image"),
            Some(BufferKind::SampledImage),
            "{name}"
        );
        assert_eq!(
            kind("triangles"),
            None,
            "{name}: triangles still read from storage"
        );
        assert!(from_images.average() > 0.0, "{name}: black image");
        assert_eq!(
            from_images.mean, from_storage.mean,
            "{name}: images and storage differ"
        );
        assert_no_validation_errors();
    }
    let mesh = vkpath::Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/mesh.toml"),
    )
    .unwrap();
    let renderer = vkpath::Renderer::new(&ctx, &mesh, &RenderOptions::default()).unwrap();
    assert_eq!(
        renderer.features().has(F::DataImages),
        vkpath::render::data_images_help(ctx.device_info())
    );
}
