//! The emissive-triangle and environment lights (shaders/lights/), read back from the GPU, against
//! expectations computed here in f64:
//!
//! * Triangles: where the samples land on the triangle fits (chi-square) the solid angle (Arvo's
//!   spherical sampling) or the area (area sampling) of 64 sub-triangles, each computed on the CPU; each
//!   sample's pdf is 1 / solid angle or d^2 / (A cos) as computed here, and `triangle_light_pdf` at its
//!   direction says the same; a triangle too small for spherical sampling falls back to area sampling.
//! * The alias table picks triangles with the probabilities of the weights it was built from.
//! * The environment map: samples fall in the map's cells with the probabilities of the cells' weights
//!   (mean corner luminance x sin theta, computed here), each with the pdf and the bilinear radiance
//!   (Mitsuba's layout, rotated) computed here; and the estimator L / pdf integrates the map over the
//!   sphere as a quadrature here does.

mod common;

use common::envmap::{bilinear, cell_of, integrate, map_uv, rotate_y, test_map, texel};
use common::stats::{assert_fits, chi2};
use common::vec::{V3, cross, dot, length, normalize, scale, sub};
use std::f64::consts::PI;
use vkpath::gpu::testing::{self, TestKernel};
use vkpath::kernel::abi::{
    GpuLightTriangle, LIGHT_SAMPLING_AREA, LIGHT_SAMPLING_CONE, LIGHT_SAMPLING_MIS,
};
use vkpath::kernel::alias;
use vkpath::scene::EnvironmentMap;

const TRIANGLE_KERNEL: &str = include_str!("../shaders/tests/triangle_light.wgsl");
const ENVIRONMENT_KERNEL: &str = include_str!("../shaders/tests/environment_light.wgsl");

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TriCase {
    v0: [f32; 4],
    v1: [f32; 4],
    v2: [f32; 4],
    p: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Out3 {
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
}

fn v3(v: [f32; 4]) -> V3 {
    [v[0] as f64, v[1] as f64, v[2] as f64]
}

fn no_validation_errors() {
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
}

/// Solid angle of the spherical triangle of unit vectors a, b, c (Van Oosterom & Strackee), f64.
fn solid_angle(a: V3, b: V3, c: V3) -> f64 {
    let triple = dot(a, cross(b, c)).abs();
    2.0 * triple.atan2(1.0 + dot(a, b) + dot(b, c) + dot(c, a))
}

fn solid_angle_from(p: V3, t: [V3; 3]) -> f64 {
    let [a, b, c] = t.map(|v| normalize(sub(v, p)));
    solid_angle(a, b, c)
}

fn mid(a: V3, b: V3) -> V3 {
    scale(common::vec::add(a, b), 0.5)
}

/// The 4^levels sub-triangles of t by midpoint subdivision, in the order `sub_triangle_of` numbers them.
fn subdivide(t: [V3; 3], levels: u32) -> Vec<[V3; 3]> {
    if levels == 0 {
        return vec![t];
    }
    let [a, b, c] = t;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    // Children: the corners at a, b, c, then the middle one (vertices opposite a, b, c).
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [bc, ca, ab]]
        .into_iter()
        .flat_map(|child| subdivide(child, levels - 1))
        .collect()
}

/// Which sub-triangle (numbered as by `subdivide`) holds the point of barycentrics (b0, b1, b2).
fn sub_triangle_of(mut b: [f64; 3], levels: u32) -> usize {
    let mut index = 0;
    for level in (0..levels).rev() {
        let span = 4usize.pow(level);
        let child = if b[0] >= 0.5 {
            b = [2.0 * b[0] - 1.0, 2.0 * b[1], 2.0 * b[2]];
            0
        } else if b[1] >= 0.5 {
            b = [2.0 * b[0], 2.0 * b[1] - 1.0, 2.0 * b[2]];
            1
        } else if b[2] >= 0.5 {
            b = [2.0 * b[0], 2.0 * b[1], 2.0 * b[2] - 1.0];
            2
        } else {
            // Middle child (bc, ca, ab): coefficients 1 - 2 b_i.
            b = [1.0 - 2.0 * b[0], 1.0 - 2.0 * b[1], 1.0 - 2.0 * b[2]];
            3
        };
        index += child * span;
    }
    index
}

/// Barycentrics of x (in the triangle's plane) with respect to t.
fn barycentrics(t: [V3; 3], x: V3) -> [f64; 3] {
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    let nn = dot(n, n);
    let b1 = dot(cross(sub(x, t[0]), sub(t[2], t[0])), n) / nn;
    let b2 = dot(cross(sub(t[1], t[0]), sub(x, t[0])), n) / nn;
    [1.0 - b1 - b2, b1, b2]
}

fn run_triangle(cases: &[TriCase]) -> Vec<Out3> {
    let out = testing::run_kernel(&testing::context(), TRIANGLE_KERNEL, cases, cases.len())
        .expect("triangle kernel");
    no_validation_errors();
    out
}

/// Samples of one triangle from p: where they land fits the expected distribution over 64
/// sub-triangles (solid angle, or area), and every pdf is the one computed here.
fn check_triangle(what: &str, t: [V3; 3], p: V3, strategy: u32, expect_spherical: bool) {
    const LEVELS: u32 = 3;
    let n = 200_000;
    let f = |v: V3, w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
    let cases: Vec<TriCase> = (0..n)
        .map(|_| TriCase {
            v0: f(t[0], strategy as f32),
            v1: f(t[1], 7.0),
            v2: f(t[2], 0.0),
            p: f(p, 0.0),
        })
        .collect();
    let out = run_triangle(&cases);
    let omega = solid_angle_from(p, t);
    let normal = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    let area = 0.5 * length(normal);
    let unit_n = normalize(normal);
    let subs = subdivide(t, LEVELS);
    let mut counts = vec![0.0; subs.len()];
    let mut worst_pdf: f64 = 0.0;
    for o in &out {
        let (wi, pdf) = (v3(o.a), o.a[3] as f64);
        assert!(pdf > 0.0, "{what}: a sample with no density: {o:?}");
        let x = v3(o.b);
        let dist = o.b[3] as f64;
        // The point is where wi meets the triangle, at the reported distance.
        let along = common::vec::add(p, scale(wi, dist));
        assert!(
            length(sub(along, x)) <= 1e-4 * dist.max(1.0),
            "{what}: {o:?}"
        );
        let b = barycentrics(t, x);
        // (Arvo's construction in f32 lands up to ~1e-3 of the triangle outside its edges.)
        assert!(
            b.iter().all(|&c| c > -1e-3),
            "{what}: point off the triangle {b:?}"
        );
        counts[sub_triangle_of(b.map(|c| c.clamp(0.0, 1.0)), LEVELS)] += 1.0;
        let expected_pdf = if expect_spherical {
            1.0 / omega
        } else {
            let d = sub(x, p);
            dot(d, d) / (area * dot(unit_n, normalize(d)).abs())
        };
        worst_pdf = worst_pdf.max((pdf / expected_pdf - 1.0).abs());
        // triangle_light_pdf at the sampled direction agrees with the sample's own.
        let again = o.c[0] as f64;
        assert!(
            (again / pdf - 1.0).abs() < 2e-3,
            "{what}: pdf {pdf} vs triangle_light_pdf {again}"
        );
    }
    println!("{what}: solid angle {omega:.3e} sr, worst relative pdf error {worst_pdf:.2e}");
    assert!(worst_pdf < 2e-3, "{what}: pdf off by {worst_pdf}");
    let expected: Vec<f64> = subs
        .iter()
        .map(|&s| {
            let share = if expect_spherical {
                solid_angle_from(p, s) / omega
            } else {
                1.0 / subs.len() as f64
            };
            share * n as f64
        })
        .collect();
    assert_fits(what, &chi2(&counts, &expected));
}

#[test]
fn triangle_samples_fit_their_solid_angle_or_area() {
    let t = [[-1.0, 2.0, -0.5], [1.5, 2.2, -0.8], [0.2, 2.1, 1.3]];
    let below = [0.3, 0.0, 0.1];
    check_triangle("spherical, 0.9 sr", t, below, LIGHT_SAMPLING_CONE, true);
    check_triangle("spherical (mis)", t, below, LIGHT_SAMPLING_MIS, true);
    check_triangle("area, 0.9 sr", t, below, LIGHT_SAMPLING_AREA, false);
    // Seen from close below its centroid, the triangle fills most of a hemisphere.
    let n = normalize(cross(sub(t[1], t[0]), sub(t[2], t[0])));
    let centroid = scale(
        common::vec::add(common::vec::add(t[0], t[1]), t[2]),
        1.0 / 3.0,
    );
    let close = common::vec::add(centroid, scale(n, 0.3));
    let omega = solid_angle_from(close, t);
    assert!((3.0..6.2).contains(&omega), "{omega} sr");
    check_triangle("spherical, close", t, close, LIGHT_SAMPLING_CONE, true);
    check_triangle("area, close", t, close, LIGHT_SAMPLING_AREA, false);
    // Far away its solid angle is below TRIANGLE_SPHERICAL_MIN_SR: sampled by area whatever the strategy.
    let far = [0.3, -300.0, 0.1];
    assert!(solid_angle_from(far, t) < 3e-4);
    check_triangle(
        "cone falls back to area, far",
        t,
        far,
        LIGHT_SAMPLING_CONE,
        false,
    );
}

/// A one-sided emitter seen from behind is no light, and gives no sample; a two-sided one is sampled
/// from both sides.
#[test]
fn a_triangle_lights_only_its_emitting_side() {
    // Normal (v1 - v0) x (v2 - v0) = -y: the front is below.
    let t = [[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [0.0, 2.0, 1.0]];
    let case = |p: V3, two_sided: bool| TriCase {
        v0: [
            t[0][0] as f32,
            t[0][1] as f32,
            t[0][2] as f32,
            LIGHT_SAMPLING_CONE as f32,
        ],
        v1: [t[1][0] as f32, t[1][1] as f32, t[1][2] as f32, 3.0],
        v2: [
            t[2][0] as f32,
            t[2][1] as f32,
            t[2][2] as f32,
            if two_sided { 1.0 } else { 0.0 },
        ],
        p: [p[0] as f32, p[1] as f32, p[2] as f32, 0.0],
    };
    let out = run_triangle(&[
        case([0.0, 0.0, 0.0], false),
        case([0.0, 4.0, 0.0], false),
        case([0.0, 4.0, 0.0], true),
    ]);
    assert_eq!(out[0].c[1], 1.0, "below: the front faces the point");
    assert_eq!(out[1].c[1], 0.0, "above: the back of a one-sided emitter");
    assert_eq!(
        out[1].c[0], 0.0,
        "no density from behind a one-sided emitter"
    );
    assert_eq!(out[2].c[1], 1.0, "a two-sided emitter faces both ways");
    assert!(out[2].c[0] > 0.0);
}

/// The shader's alias-table pick among emissive triangles: its frequencies fit the weights the table
/// was built from (weights spanning four orders of magnitude, one of them zero).
#[test]
fn the_alias_pick_follows_the_weights() {
    let weights: Vec<f64> = (0..40)
        .map(|i| {
            if i == 7 {
                0.0
            } else {
                10f64.powf((i % 5) as f64 - 2.0) * (1.0 + 0.1 * i as f64)
            }
        })
        .collect();
    let table: Vec<GpuLightTriangle> = alias::build(&weights)
        .iter()
        .map(|c| GpuLightTriangle {
            keep: c.keep,
            alias_triangle: c.alias,
            ..Default::default()
        })
        .collect();
    let n = 400_000;
    let cases = vec![
        TriCase {
            v0: [0.0, 0.0, 0.0, weights.len() as f32],
            v1: [0.0, 0.0, 0.0, 11.0],
            v2: [0.0; 4],
            p: [0.0, 0.0, 0.0, 1.0],
        };
        n
    ];
    let mut kernel = TestKernel::new(&testing::context(), TRIANGLE_KERNEL).expect("kernel");
    let out: Vec<Out3> = kernel
        .run_with(
            &cases,
            n,
            &[("light_triangles", bytemuck::cast_slice(&table))],
        )
        .expect("run");
    no_validation_errors();
    let mut counts = vec![0.0; weights.len()];
    for o in &out {
        counts[o.a[0] as usize] += 1.0;
    }
    assert_eq!(counts[7], 0.0, "a zero weight is never picked");
    let total: f64 = weights.iter().sum();
    let expected: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
    assert_fits("alias pick", &chi2(&counts, &expected));
}

// --- The environment ------------------------------------------------------------------------------

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct EnvCase {
    l0: [f32; 4],
    l1: [f32; 4],
    q: [f32; 4],
}

/// The cells' sampling weights: mean corner luminance (mean of the channels) x sin theta at the centre.
fn cell_weights(map: &EnvironmentMap) -> Vec<f64> {
    let (w, h) = (map.width as usize, map.height as usize);
    let lum = |k: usize, j: usize| {
        let t = texel(map, k, j);
        (t[0] + t[1] + t[2]) / 3.0
    };
    let mut out = Vec::new();
    for j in 0..h - 1 {
        let s = (PI * (j as f64 + 0.5) / (h - 1) as f64).sin();
        for k in 0..w {
            out.push(0.25 * (lum(k, j) + lum(k + 1, j) + lum(k, j + 1) + lum(k + 1, j + 1)) * s);
        }
    }
    out
}

#[test]
fn environment_samples_fit_the_map() {
    let map = test_map(40.0);
    let rotate = 30.0f64;
    let tint = [0.5f64, 1.0, 2.0];
    let texels: Vec<f32> = map.texels.iter().flatten().copied().collect();
    let cdf = map.distribution();
    let (s, c) = rotate.to_radians().sin_cos();
    let n = 300_000;
    // Query directions: a fixed set spread over the sphere (radiance and pdf checked at each).
    let query = |i: usize| {
        let z = 1.0 - 2.0 * ((i % 997) as f64 + 0.5) / 997.0;
        let phi = 2.4 * i as f64;
        let r = (1.0 - z * z).sqrt();
        [r * phi.cos(), z, r * phi.sin()]
    };
    let cases: Vec<EnvCase> = (0..n)
        .map(|i| {
            let q = query(i);
            EnvCase {
                l0: [c as f32, s as f32, map.width as f32, map.height as f32],
                l1: [tint[0] as f32, tint[1] as f32, tint[2] as f32, 5.0],
                q: [
                    q[0] as f32,
                    q[1] as f32,
                    q[2] as f32,
                    LIGHT_SAMPLING_MIS as f32,
                ],
            }
        })
        .collect();
    let mut kernel = TestKernel::new(&testing::context(), ENVIRONMENT_KERNEL).expect("kernel");
    let out: Vec<Out3> = kernel
        .run_with(
            &cases,
            n,
            &[
                ("env_texels", bytemuck::cast_slice(&texels)),
                ("env_cdf", bytemuck::cast_slice(&cdf)),
            ],
        )
        .expect("run");
    no_validation_errors();

    let weights = cell_weights(&map);
    let total: f64 = weights.iter().sum();
    let cells = weights.len() as f64;
    let world_to_map = |w: V3| rotate_y(-rotate, w);
    // The pdf at w as computed here, or None within 5e-3 (in cells) of a cell's edge, where rounding (of lavapipe's acos and atan2, good to a few thousand ulps)
    // may put a direction in either cell.
    let pdf_here = |w: V3| {
        let m = world_to_map(w);
        let (u, v) = map_uv(m);
        let (k, j, fx, fy) = cell_of(&map, u, v);
        let edge = |f: f64| f.min(1.0 - f) < 5e-3;
        let sin_theta = (m[0] * m[0] + m[2] * m[2]).sqrt();
        (!edge(fx) && !edge(fy)).then(|| {
            weights[j * map.width as usize + k] / total * cells / (2.0 * PI * PI * sin_theta)
        })
    };
    // What a radiance error is measured against: the value itself, or where the map is steep a
    // thousandth of the brightest corner of its cell (lavapipe's trigonometry moves a direction by up to
    // ~1e-3 of a cell).
    let scale_of = |m: V3, expect: f64| {
        let (u, v) = map_uv(m);
        let (k, j, ..) = cell_of(&map, u, v);
        let corners = [(k, j), (k + 1, j), (k, j + 1), (k + 1, j + 1)];
        let brightest = corners
            .iter()
            .map(|&(k, j)| texel(&map, k, j).iter().fold(0.0f64, |a, &b| a.max(b)))
            .fold(0.0, f64::max);
        expect.max(0.05).max(brightest)
    };
    let mut counts = vec![0.0; weights.len()];
    let (mut worst_pdf, mut worst_l): (f64, f64) = (0.0, 0.0);
    let mut estimate = [0.0f64; 3];
    for (i, o) in out.iter().enumerate() {
        let (wi, pdf) = (v3(o.a), o.a[3] as f64);
        assert!(pdf > 0.0, "sample {i}: {o:?}");
        let m = world_to_map(wi);
        let (u, v) = map_uv(m);
        let (k, j, ..) = cell_of(&map, u, v);
        counts[j * map.width as usize + k] += 1.0;
        // Away from cell edges: the pdf computed here, and environment_pdf at the sampled direction,
        // are the sample's own.
        if let Some(expected) = pdf_here(wi) {
            worst_pdf = worst_pdf.max((pdf / expected - 1.0).abs());
            worst_pdf = worst_pdf.max((o.b[3] as f64 / pdf - 1.0).abs());
        }
        let l = bilinear(&map, m);
        for ch in 0..3 {
            let expect = tint[ch] * l[ch];
            worst_l = worst_l.max((o.b[ch] as f64 - expect).abs() / scale_of(m, expect));
            estimate[ch] += o.b[ch] as f64 / pdf / n as f64;
        }
        // At the query direction: radiance and pdf as computed here.
        let q = query(i);
        let lq = bilinear(&map, world_to_map(q));
        for ch in 0..3 {
            let expect = tint[ch] * lq[ch];
            worst_l =
                worst_l.max((o.c[ch] as f64 - expect).abs() / scale_of(world_to_map(q), expect));
        }
        if let Some(pq_here) = pdf_here(q) {
            let pq = o.c[3] as f64;
            assert!(
                (pq - pq_here).abs() <= 2e-3 * pq_here.max(1e-3),
                "query {q:?}: pdf {pq} vs {pq_here}"
            );
        }
    }
    println!("environment: worst relative pdf error {worst_pdf:.2e}, radiance error {worst_l:.2e}");
    assert!(worst_pdf < 2e-3 && worst_l < 2e-3);
    let expected: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
    assert_fits("environment cells", &chi2(&counts, &expected));
    // The integral of the radiance over the sphere, by a midpoint quadrature in (u, v) fine enough that
    // its error is far below the estimate's noise (checked against half the resolution).
    let quadrature = |steps: usize| integrate(&map, rotate, tint, steps, |_| 1.0);
    let (fine, coarse) = (quadrature(1200), quadrature(600));
    for ch in 0..3 {
        assert!(
            (fine[ch] / coarse[ch] - 1.0).abs() < 1e-3,
            "quadrature not converged"
        );
        let rel = estimate[ch] / fine[ch] - 1.0;
        println!(
            "channel {ch}: integral {:.5}, estimate {:.5} ({rel:+.2e})",
            fine[ch], estimate[ch]
        );
        assert!(
            rel.abs() < 0.01,
            "channel {ch}: L / pdf averages {} vs {}",
            estimate[ch],
            fine[ch]
        );
    }
}

/// Without a map the environment is uniform: every direction with pdf 1 / (4 pi) and the radiance
/// itself; the directions' z components fit the uniform distribution on [-1, 1].
#[test]
fn a_uniform_environment_samples_the_sphere() {
    let n = 100_000;
    let cases = vec![
        EnvCase {
            l0: [1.0, 0.0, 0.0, 0.0],
            l1: [0.25, 0.5, 1.0, 9.0],
            q: [0.0, 1.0, 0.0, LIGHT_SAMPLING_CONE as f32],
        };
        n
    ];
    let out: Vec<Out3> =
        testing::run_kernel(&testing::context(), ENVIRONMENT_KERNEL, &cases, n).expect("run");
    no_validation_errors();
    let mut counts = vec![0.0; 20];
    for o in &out {
        assert!((o.a[3] as f64 * 4.0 * PI - 1.0).abs() < 1e-6);
        assert_eq!([o.b[0], o.b[1], o.b[2]], [0.25, 0.5, 1.0]);
        let bin = ((o.a[2] as f64 + 1.0) / 2.0 * 20.0)
            .floor()
            .clamp(0.0, 19.0) as usize;
        counts[bin] += 1.0;
    }
    assert_fits(
        "uniform environment",
        &chi2(&counts, &[n as f64 / 20.0; 20]),
    );
}
