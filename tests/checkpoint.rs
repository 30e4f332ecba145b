//! Checkpoint, resume, sample ranges and merge, through the library (the command line is exercised in
//! tests/reliability.rs).
//!
//! - A render stopped, saved to a file, read back into a fresh renderer and continued holds the same
//!   bits (every Kahan pair of every pixel) as a render that never stopped.
//! - A checkpoint of another render (seed, size, scene content, version) is refused, naming what differs.
//! - Partial renders of four sample ranges merge into the image of one render of their union, within the
//!   rounding bound derived below.

mod common;

use common::*;
use std::path::PathBuf;
use vkpath::checkpoint::{self, Checkpoint};
use vkpath::gpu::testing;
use vkpath::kernel::abi::GpuAccum;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::{Error, Scene};

/// Diffuse, mirror and glass spheres on a floor, lit by a sphere light: every material kind, next-event
/// estimation, Fresnel choices and Russian roulette (from bounce 3 of 6) draw random numbers.
const SCENE: &str = r#"[camera]
position = [0.0, 2.0, 30.0]
look_at  = [0.0, 0.0, 0.0]
fov      = 50.0

[image]
width  = 40
height = 30

[render]
samples     = 16
max_bounces = 6
seed        = 11

[materials]
white  = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
red    = { type = "diffuse", albedo = [0.8, 0.2, 0.1] }
mirror = { type = "mirror" }
glass  = { type = "dielectric", ior = 1.5 }

[[sphere]]
center   = [-6.0, 0.0, 0.0]
radius   = 4.0
material = "red"

[[sphere]]
center   = [0.0, 0.0, 2.0]
radius   = 3.0
material = "glass"

[[sphere]]
center   = [6.0, 0.0, 0.0]
radius   = 4.0
material = "mirror"

[[sphere]]
center   = [0.0, -1004.0, 0.0]
radius   = 1000.0
material = "white"

[[light]]
type   = "sphere"
center = [5.0, 20.0, 20.0]
radius = 3.0
power  = 40000.0
"#;

fn renderer(scene: &Scene) -> Renderer {
    Renderer::new(&testing::context(), scene, &RenderOptions::default()).expect("renderer")
}

fn bits(accum: &[GpuAccum]) -> &[u8] {
    bytemuck::cast_slice(accum)
}

/// Stopping after 5 samples, writing the state to a file, reading it into a new renderer and going on
/// to 13 samples gives the bits of 13 samples rendered in one go: sums, compensations, squares.
#[test]
fn resume_from_a_file_reproduces_the_uninterrupted_bits() {
    let scene = scene(SCENE);
    let mut straight = renderer(&scene);
    straight.run_pass(13).unwrap();
    let expected = straight.accum_state().unwrap();

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("state.ckpt");
    {
        let mut first = renderer(&scene);
        first.run_pass(2).unwrap();
        first.run_pass(3).unwrap();
        Checkpoint::of(&mut first, &scene)
            .unwrap()
            .write(&path)
            .unwrap();
    }
    let saved = Checkpoint::read(&path).unwrap();
    assert_eq!(saved.samples(), 5);
    assert_eq!(saved.header.ranges, vec![[0, 5]]);
    let mut resumed = renderer(&scene);
    saved
        .check_identity(&path, &resumed.identity())
        .expect("same render");
    resumed.restore(&saved.header.ranges, &saved.accum).unwrap();
    assert_eq!(resumed.next_sample(), 5);
    // Going on in passes of another size changes nothing either.
    resumed.run_pass(4).unwrap();
    resumed.run_pass(4).unwrap();
    let got = resumed.accum_state().unwrap();
    assert!(
        bits(&got) == bits(&expected),
        "the resumed accumulator differs from the uninterrupted one"
    );
    assert_eq!(resumed.ranges(), &[[0, 13]]);
    assert_eq!(resumed.film().unwrap(), straight.film().unwrap());
    assert_no_validation_errors();
}

fn refusal(scene_text: &str, options: &RenderOptions, saved: &Checkpoint) -> String {
    let scene = scene(scene_text);
    let r = Renderer::new(&testing::context(), &scene, options).unwrap();
    match saved.check_identity(&PathBuf::from("saved.ckpt"), &r.identity()) {
        Err(e @ Error::Checkpoint { .. }) => {
            assert_eq!(e.exit_code(), 2);
            e.to_string()
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
}

/// A checkpoint resumes only the render it came from; the refusal names what differs. What does not
/// change the sums (the target sample count, exposure, gamma) does not block a resume.
#[test]
fn a_checkpoint_of_another_render_is_refused() {
    let base = scene(SCENE);
    let mut r = renderer(&base);
    r.run_pass(1).unwrap();
    let saved = Checkpoint::of(&mut r, &base).unwrap();
    let opts = RenderOptions::default();

    let e = refusal(
        &SCENE.replace("seed        = 11", "seed = 12"),
        &opts,
        &saved,
    );
    assert!(e.contains("seed is 11, this one 12"), "{e}");
    let e = refusal(&SCENE.replace("width  = 40", "width = 41"), &opts, &saved);
    assert!(e.contains("40x30") && e.contains("41x30"), "{e}");
    let e = refusal(&SCENE.replace("ior = 1.5", "ior = 1.33"), &opts, &saved);
    assert!(e.contains("scene's content differs"), "{e}");
    let e = refusal(
        SCENE,
        &RenderOptions {
            roulette_depth: u32::MAX,
            ..Default::default()
        },
        &saved,
    );
    assert!(e.contains("roulette depth is 3, this one off"), "{e}");
    let mut other_version = saved.clone();
    other_version.header.identity.vkpath_version = "0.0.1".into();
    let e = other_version
        .check_identity(&PathBuf::from("x"), &r.identity())
        .unwrap_err()
        .to_string();
    assert!(e.contains("written by vkpath 0.0.1"), "{e}");

    // Same render: more samples, another exposure and gamma, the generic kernel: accepted.
    let same = scene(&SCENE.replace("samples     = 16", "samples = 99").replace(
        "height = 30",
        "height = 30\nexposure = 2.0\ngamma = \"srgb\"",
    ));
    let generic = RenderOptions {
        generic: true,
        ..Default::default()
    };
    let r2 = Renderer::new(&testing::context(), &same, &generic).unwrap();
    saved
        .check_identity(&PathBuf::from("x"), &r2.identity())
        .expect("display settings and the target count do not matter");
}

/// Four partial renders (sample ranges 0..8, 8..16, 16..24, 24..32, rendered by separate renderers, out
/// of order, one of them in two passes) merge into exactly the image of one render of 0..32.
///
/// The sums of samples are exact integers (long accumulators), so the merged sums must have the same
/// bits as the single render's, and so must the means and the written EXR. The sums of squares are Kahan
/// pairs: the single render's is one chain in f32, the parts' are four chains added in f64. Kahan
/// summation of non-negative terms is within 2u (u = 2^-24, plus O(n u^2)) of the exact sum SQ, relative,
/// so the two differ by at most 4u SQ; with the mean identical, the variances of the mean then differ by
/// at most 4u SQ / (n (n - 1)) plus one ulp of rounding.
#[test]
fn merge_of_four_ranges_equals_one_render_exactly() {
    let scene = scene(SCENE);
    let mut single = renderer(&scene);
    single.run_pass(32).unwrap();
    let one = single.film().unwrap();
    let one_state = single.accum_state().unwrap();

    let dir = tempfile::tempdir().unwrap();
    let mut parts = Vec::new();
    // Rendered out of order, and the last one in two passes.
    for (start, passes) in [(16u32, &[8u32][..]), (0, &[8]), (24, &[3, 5]), (8, &[8])] {
        let mut r = renderer(&scene);
        r.start_at(start).unwrap();
        for &k in passes {
            r.run_pass(k).unwrap();
        }
        let path = dir.path().join(format!("part{start}.ckpt"));
        Checkpoint::of(&mut r, &scene)
            .unwrap()
            .write(&path)
            .unwrap();
        parts.push((path.clone(), Checkpoint::read(&path).unwrap()));
    }
    let merged = checkpoint::merge::merge(&parts).unwrap();
    assert_eq!(
        merged.header.ranges,
        vec![[0, 8], [8, 16], [16, 24], [24, 32]]
    );
    let film = merged.film();
    assert_eq!(film.spp, 32);

    // The image: every sum, every mean, and the EXR file, bit for bit.
    for (p, (a, b)) in one_state.iter().zip(&merged.accum).enumerate() {
        assert_eq!(a.sum, b.sum, "pixel {p}: exact sums differ");
    }
    assert!(
        one.mean
            .iter()
            .zip(&film.mean)
            .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits))
    );
    let settings = scene.image;
    let (exr1, exr2) = (dir.path().join("one.exr"), dir.path().join("merged.exr"));
    one.write(&exr1, &settings).unwrap();
    film.write(&exr2, &settings).unwrap();
    assert!(std::fs::read(&exr1).unwrap() == std::fs::read(&exr2).unwrap());
    // Not a vacuous comparison: the image has light in it.
    assert!(one.average() > 0.0);

    // The variance estimate: within the Kahan bound above.
    let u = 2f64.powi(-24);
    let n = 32.0;
    let mut worst_var_ratio = 0f64;
    for (p, a) in one_state.iter().enumerate() {
        for c in 0..3 {
            let sq = a.sum_sq[c] as f64 - a.sum_sq_c[c] as f64;
            let (v1, v2) = (one.variance[p][c] as f64, film.variance[p][c] as f64);
            let ulp = |v: f64| f64::from(f32::from_bits((v as f32).to_bits() + 1)) - v;
            let bound = 4.0 * u * sq / (n * (n - 1.0)) * 1.01 + ulp(v1.max(v2));
            assert!(
                (v1 - v2).abs() <= bound,
                "pixel {p} channel {c}: variances {v1} and {v2} differ by more than {bound}"
            );
            if bound > 0.0 {
                worst_var_ratio = worst_var_ratio.max((v1 - v2).abs() / bound);
            }
        }
    }
    eprintln!(
        "merge vs single render: image bit-identical; worst variance difference {worst_var_ratio:.2} \
         of its bound"
    );
    // The merged state, resumed, is a valid state: a render can go on from it.
    let mut more = renderer(&scene);
    more.restore(&merged.header.ranges, &merged.accum).unwrap();
    assert_eq!(more.next_sample(), 32);
    more.run_pass(1).unwrap();
    assert_eq!(more.samples_done(), 33);
    assert_no_validation_errors();
}

/// A partial render of the samples 0..A is exactly the first A samples of a full render, and the part
/// A..B resumed from its checkpoint (a chain) equals the full render's bits.
#[test]
fn a_sample_range_is_a_slice_of_the_full_render() {
    let scene = scene(SCENE);
    let mut full = renderer(&scene);
    full.run_pass(6).unwrap();
    let mut part = renderer(&scene);
    part.start_at(0).unwrap();
    part.run_pass(6).unwrap();
    assert!(bits(&part.accum_state().unwrap()) == bits(&full.accum_state().unwrap()));
    // A range starting elsewhere traces other samples: its image differs.
    let mut later = renderer(&scene);
    later.start_at(6).unwrap();
    later.run_pass(6).unwrap();
    assert_eq!(later.ranges(), &[[6, 12]]);
    assert_ne!(later.film().unwrap().mean, full.film().unwrap().mean);
}

/// After a pass fails part-way (a lost device, simulated), the accumulator holds an unknown part of the
/// pass: the renderer refuses to read it (so no film or checkpoint can be made of it) or extend it,
/// until it is started again or a checkpoint is restored.
#[test]
fn a_failed_pass_poisons_the_accumulator_until_restored() {
    use vkpath::render::Fault;
    let scene = scene(SCENE);
    let options = RenderOptions {
        fault: Some(Fault::DeviceLostAtPass(2)),
        max_tile: Some([20, 30]), // two dispatches per sample: the fault lands between them
        ..Default::default()
    };
    let mut r = Renderer::new(&testing::context(), &scene, &options).unwrap();
    r.run_pass(3).unwrap();
    let saved = Checkpoint::of(&mut r, &scene).unwrap();
    let e = r.run_pass(3).unwrap_err().to_string();
    assert!(e.contains("device was lost"), "{e}");
    for e in [
        r.accum_state().unwrap_err().to_string(),
        r.film().unwrap_err().to_string(),
        Checkpoint::of(&mut r, &scene).unwrap_err().to_string(),
        r.run_pass(1).unwrap_err().to_string(),
    ] {
        assert!(e.contains("part of a pass that failed"), "{e}");
    }
    r.restore(&saved.header.ranges, &saved.accum).unwrap();
    assert_eq!(r.accum_state().unwrap(), saved.accum);
    r.start_at(0).unwrap();
    assert_eq!(r.samples_done(), 0);
}

/// Vulkan's device-lost and out-of-memory results become the errors that say so (exit status 1).
#[test]
fn vulkan_failures_map_to_clear_errors() {
    use vkpath::gpu::GpuError;
    for (e, words) in [
        (
            GpuError::DeviceLost("vkQueueSubmit"),
            "device was lost during vkQueueSubmit",
        ),
        (
            GpuError::OutOfMemory("vkAllocateMemory"),
            "ran out of memory",
        ),
        (GpuError::Shader("x".into()), "failed to compile"),
    ] {
        let e = Error::from(e);
        assert_eq!(e.exit_code(), 1);
        assert!(e.to_string().contains(words), "{e}");
    }
}
