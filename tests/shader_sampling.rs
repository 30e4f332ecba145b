//! The sampling routines (shaders/sampling.wgsl), read back from the GPU and checked on the CPU in f64.
//!
//! * Distributions: Pearson's chi-square goodness of fit of 2^20 GPU samples, binned in (1 - cos theta,
//!   phi) for directions (axis-relative, computed without cancellation so that tiny cones bin exactly),
//!   and in (radial CDF, phi) for the Gaussian and the disk. Expected counts come from the shader's own
//!   pdf functions (`cosine_hemisphere_pdf`, `cone_pdf`, `gaussian2_pdf`, `uniform_disk_pdf`), evaluated
//!   on the GPU at every node of a Gauss–Legendre quadrature over each bin (times the Jacobian of the
//!   bin coordinates in the pdf's measure): the warp is tested against its own density, so a pdf that
//!   disagrees with its warp fails. The sum over all bins is asserted to be 1 (the shader's pdf is
//!   normalised). Significance level ALPHA = 1e-4 with fixed seeds; each test has a negative twin that
//!   asserts a huge statistic for a slightly wrong pdf, written on the CPU (uniform instead of cosine
//!   hemisphere, a 2% wider cone, a 5% wider Gaussian, ...), so the test could fail.
//! * Monte Carlo: estimates of integrals with known values (f / pdf averaged) within 5 standard errors.
//! * The sphere-light cone as the light shrinks to a point: `sphere_cone_one_minus_cos` against the f64
//!   value, the solid-angle estimate against the point-light irradiance, and directions inside the cone.
//!   A naive f32 `1 - sqrt(1 - r^2/d^2)` (on the CPU) is asserted to fail the same checks: the evidence
//!   that the cancellation-free form is what makes them pass.

mod common;

use common::stats::{Chi2, assert_fits, assert_rejects, chi2};
use common::vec::{V3, cross, dot, length, normalize, widen};
use std::cell::{Cell, RefCell};
use std::f64::consts::PI;
use std::sync::OnceLock;
use vkpath::gpu::testing;

const WARPS: &str = include_str!("../shaders/tests/sampling_warps.wgsl");
const SPHERE_CONE: &str = include_str!("../shaders/tests/sampling_sphere_cone.wgsl");
const PDFS: &str = include_str!("../shaders/tests/sampling_pdfs.wgsl");

/// Samples per chi-square test: 1024 cells expecting ~1000 each.
const N: usize = 1 << 20;
/// Unit roundoff of f32.
const U32: f64 = f32::EPSILON as f64 / 2.0;

// ---------------------------------------------------------------------------------------------------
// Statistics: the chi-square helpers and ALPHA are in tests/common/stats.rs; binning and quadrature here.

/// Gauss–Legendre nodes and weights on [-1, 1], by Newton's iteration on P_n (Numerical Recipes §4.5,
/// `gauleg`); exact for polynomials of degree 2n - 1.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// The integral of f(a, phi) over [a0, a1] x [p0, p1], 16 x 16 Gauss–Legendre points.
fn quad2(f: &dyn Fn(f64, f64) -> f64, a0: f64, a1: f64, p0: f64, p1: f64) -> f64 {
    static GL: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    let gl = GL.get_or_init(|| gauss_legendre(16));
    let (ha, hp) = (0.5 * (a1 - a0), 0.5 * (p1 - p0));
    let mut s = 0.0;
    for &(xa, wa) in gl {
        for &(xp, wp) in gl {
            s += wa * wp * f(a0 + ha * (xa + 1.0), p0 + hp * (xp + 1.0));
        }
    }
    s * ha * hp
}

/// A 2-D histogram on (a, phi): bins [a_k, a_k+1) x equal phi bins over [0, 2 pi), and one more cell for
/// samples outside [a_0, a_K] (expected: whatever probability the bins leave, normally none).
struct Grid {
    a_edges: Vec<f64>,
    n_phi: usize,
}

impl Grid {
    fn new(a_edges: Vec<f64>, n_phi: usize) -> Grid {
        Grid { a_edges, n_phi }
    }

    /// Equal-probability edges from an inverse CDF: a_k = inv(k / k_bins).
    fn from_inverse_cdf(k_bins: usize, n_phi: usize, inv: impl Fn(f64) -> f64) -> Grid {
        Grid::new(
            (0..=k_bins)
                .map(|k| inv(k as f64 / k_bins as f64))
                .collect(),
            n_phi,
        )
    }

    fn cells(&self) -> usize {
        (self.a_edges.len() - 1) * self.n_phi + 1
    }

    fn cell(&self, a: f64, phi: f64) -> usize {
        let k = self.a_edges.len() - 1;
        if !(a >= self.a_edges[0] && a <= self.a_edges[k] && phi.is_finite()) {
            return k * self.n_phi; // outside (NaN lands here too)
        }
        let i = (self.a_edges.partition_point(|&e| e <= a) - 1).min(k - 1);
        let step = 2.0 * PI / self.n_phi as f64;
        let j = ((phi.rem_euclid(2.0 * PI) / step) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// The probability of each cell (the last: outside) under `prob(a0, a1, phi0, phi1)`, and their sum
    /// over the grid proper (1 when the pdf integrates to 1 over the grid).
    fn probabilities(&self, prob: &dyn Fn(f64, f64, f64, f64) -> f64) -> (Vec<f64>, f64) {
        let step = 2.0 * PI / self.n_phi as f64;
        let mut p = Vec::with_capacity(self.cells());
        for w in self.a_edges.windows(2) {
            for j in 0..self.n_phi {
                p.push(prob(w[0], w[1], j as f64 * step, (j + 1) as f64 * step));
            }
        }
        let total: f64 = p.iter().sum();
        p.push((1.0 - total).max(0.0));
        (p, total)
    }

    /// Pearson's chi-square of `samples` (a, phi) against `prob`.
    fn chi2(&self, samples: &[(f64, f64)], prob: &dyn Fn(f64, f64, f64, f64) -> f64) -> Chi2 {
        self.chi2_of(samples, &self.probabilities(prob).0)
    }

    /// Pearson's chi-square of `samples` (a, phi) against cell probabilities `p` from `probabilities`.
    fn chi2_of(&self, samples: &[(f64, f64)], p: &[f64]) -> Chi2 {
        assert_eq!(p.len(), self.cells());
        let mut obs = vec![0.0; self.cells()];
        for &(a, phi) in samples {
            obs[self.cell(a, phi)] += 1.0;
        }
        let n = samples.len() as f64;
        let exp: Vec<f64> = p.iter().map(|p| p * n).collect();
        chi2(&obs, &exp)
    }
}

/// The probability of a cell by quadrature of a density over (a, phi).
fn by_quadrature(pdf: impl Fn(f64, f64) -> f64) -> impl Fn(f64, f64, f64, f64) -> f64 {
    move |a0, a1, p0, p1| quad2(&pdf, a0, a1, p0, p1)
}

/// One call of a pdf in shaders/tests/sampling_pdfs.wgsl: (mode, x, y, param), its arguments as given.
type PdfQuery = [f32; 4];

/// The shader's density at each query, one dispatch for all; every value finite and non-negative (an
/// unknown mode gives -1).
fn shader_pdfs(queries: &[PdfQuery]) -> Vec<f32> {
    let out: Vec<f32> =
        testing::run_kernel(&testing::context(), PDFS, queries, queries.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    for (q, v) in queries.iter().zip(&out) {
        assert!(v.is_finite() && *v >= 0.0, "pdf query {q:?}: {v}");
    }
    out
}

/// `probs(pdf)` where `pdf` answers a query with the shader's density, evaluated on the GPU.
///
/// A quadrature asks for its nodes one at a time, and a kernel compiled and dispatched per node (up to
/// ~10^6 of them) would be far too slow, so `probs` runs twice: first with a pdf that only records the queries (answering 0), then, after one dispatch for
/// all of them, with a pdf that answers from the GPU's values in the recorded order. The quadrature
/// depends on the answers only through its sums, never in where it asks next, so the second run asks
/// the same queries in the same order; each is compared bit for bit with the recorded one all the same,
/// so a mismatch fails loudly instead of pairing a node with another node's density.
fn with_shader_pdf<T>(probs: impl Fn(&dyn Fn(PdfQuery) -> f64) -> T) -> T {
    let recorded = RefCell::new(Vec::new());
    probs(&|q| {
        recorded.borrow_mut().push(q);
        0.0
    });
    let queries = recorded.into_inner();
    eprintln!("{} pdf queries, one dispatch", queries.len());
    let values = shader_pdfs(&queries);
    let next = Cell::new(0);
    let out = probs(&|q| {
        let i = next.get();
        next.set(i + 1);
        assert!(
            i < queries.len() && queries[i].map(f32::to_bits) == q.map(f32::to_bits),
            "pdf query {i} changed between the runs: {q:?} vs {:?}",
            queries.get(i)
        );
        values[i] as f64
    });
    assert_eq!(
        next.get(),
        queries.len(),
        "the second run asked fewer queries"
    );
    out
}

/// How far the f32 shader pdf's probabilities may sum from 1. Each value carries a few ulps (2^-24) of
/// rounding from its f32 arguments and operations; the Gaussian's exp(x) is bounded by Vulkan only to
/// (3 + 2|x|) ulps, but weighted by the mass E|x| = 1, so at those bounds the sum is within ~1e-6 of the
/// exact integral (on lavapipe it is within 1e-7). A pdf off by a factor fails by far more.
const PDF_SUM_TOL: f64 = 1e-5;

/// Asserts that the shader's pdf integrates to 1 over the grid, within PDF_SUM_TOL.
fn assert_normalised(what: &str, total: f64) {
    eprintln!(
        "{what}: shader pdf sums to 1 {:+.2e} over the grid",
        total - 1.0
    );
    assert!(
        (total - 1.0).abs() < PDF_SUM_TOL,
        "{what}: the shader's pdf integrates to {total}, not 1"
    );
}

// ---------------------------------------------------------------------------------------------------
// Vectors in f64 and the directions' coordinates.

/// A CPU orthonormal basis (t, b) around unit `axis`, independent of the shader's frame: the tests only
/// rely on the distributions being symmetric about the axis.
fn cpu_basis(axis: V3) -> (V3, V3) {
    let helper = if axis[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t = normalize(cross(helper, axis));
    (t, cross(axis, t))
}

/// (1 - cos theta, phi) of direction `w` about `axis`. 1 - cos = sin^2 / (1 + cos) with
/// sin^2 = |w x axis|^2 / |w|^2: no cancellation, so a cone of half-angle 1e-5 still bins exactly
/// (for axes along a coordinate axis, whose frame is exact). Below the horizon: 1 - cos > 1.
fn cone_coords(w: V3, axis: V3, basis: (V3, V3)) -> (f64, f64) {
    let l = length(w);
    let cos = dot(w, axis) / l;
    let sin2 = dot(cross(w, axis), cross(w, axis)) / (l * l);
    let a = if cos > 0.0 {
        sin2 / (1.0 + cos)
    } else {
        1.0 - cos
    };
    let phi = dot(w, basis.1).atan2(dot(w, basis.0)).rem_euclid(2.0 * PI);
    (a, phi)
}

// ---------------------------------------------------------------------------------------------------
// Running the warps on the GPU (shaders/tests/sampling_warps.wgsl).

#[derive(Clone, Copy, Debug)]
enum Warp {
    Cosine {
        n: [f32; 3],
    },
    Cone {
        axis: [f32; 3],
        omc: f32,
    },
    SphereCone {
        axis: [f32; 3],
        r: f32,
        d2: f32,
    },
    Gaussian {
        sigma: f32,
    },
    Disk,
    Tent {
        radius: f32,
    },
    /// Mode 6: a tent of `radius` (x) and a Gaussian of `sigma` (y), each cut off to [lo, hi].
    CutOff {
        radius: f32,
        sigma: f32,
        lo: f32,
        hi: f32,
    },
}

fn header(w: Warp, seed: u32) -> [[f32; 4]; 2] {
    let s = seed as f32;
    assert_eq!(s as u32, seed, "the seed travels as an f32");
    match w {
        Warp::Cosine { n } => [[0.0, s, 0.0, 0.0], [n[0], n[1], n[2], 0.0]],
        Warp::Cone { axis, omc } => [[1.0, s, 0.0, 0.0], [axis[0], axis[1], axis[2], omc]],
        Warp::SphereCone { axis, r, d2 } => [[2.0, s, r, d2], [axis[0], axis[1], axis[2], 0.0]],
        Warp::Gaussian { sigma } => [[3.0, s, 0.0, 0.0], [0.0, 0.0, 0.0, sigma]],
        Warp::Disk => [[4.0, s, 0.0, 0.0], [0.0; 4]],
        Warp::Tent { radius } => [[5.0, s, 0.0, 0.0], [0.0, 0.0, 0.0, radius]],
        Warp::CutOff {
            radius,
            sigma,
            lo,
            hi,
        } => [[6.0, s, lo, hi], [sigma, 0.0, 0.0, radius]],
    }
}

fn run(input: &[[f32; 4]], count: usize) -> Vec<[f32; 4]> {
    let out = testing::run_kernel(&testing::context(), WARPS, input, count).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// `count` samples of `w` from the renderer's random numbers (rng_new(i, 0, seed), rng_next2).
fn warp(w: Warp, seed: u32, count: usize) -> Vec<[f32; 4]> {
    run(&header(w, seed), count)
}

/// One sample of `w` per given uniform pair.
fn warp_given(w: Warp, us: &[[f32; 2]]) -> Vec<[f32; 4]> {
    let mut input = header(w, 0).to_vec();
    input.extend(us.iter().map(|u| [u[0], u[1], 0.0, 0.0]));
    run(&input, us.len())
}

fn xyz(o: &[f32; 4]) -> V3 {
    [o[0] as f64, o[1] as f64, o[2] as f64]
}

/// The largest uniform the RNG returns, 1 - 2^-24, and a grid of extreme uniform pairs.
const U_MAX: f32 = 1.0 - f32::EPSILON / 2.0;

fn extreme_us() -> Vec<[f32; 2]> {
    let edge = [0.0, f32::EPSILON / 2.0, 1e-3, 0.25, 0.5, 0.999, U_MAX];
    edge.iter()
        .flat_map(|&x| edge.iter().map(move |&y| [x, y]))
        .collect()
}

/// The f64 cone of a sphere of radius r at squared distance d2, without cancellation.
fn one_minus_cos_f64(r: f64, d2: f64) -> f64 {
    let s2 = (r * r / d2).min(1.0);
    s2 / (1.0 + (1.0 - s2).sqrt())
}

/// The naive f32 formula, on the CPU: what the shader would compute without the rewrite.
fn one_minus_cos_naive_f32(r: f32, d2: f32) -> f32 {
    1.0 - (1.0 - (r * r / d2).min(1.0)).sqrt()
}

// ---------------------------------------------------------------------------------------------------
// Cosine-weighted hemisphere: pdf cos(theta) / pi.

const COS_NORMALS: [[f32; 3]; 2] = [[0.0, 0.0, 1.0], [0.267_261_24, 0.534_522_5, -0.801_783_7]];

fn cosine_samples(k: usize) -> &'static [[f32; 4]] {
    static S: [OnceLock<Vec<[f32; 4]>>; 2] = [OnceLock::new(), OnceLock::new()];
    S[k].get_or_init(|| warp(Warp::Cosine { n: COS_NORMALS[k] }, 1000 + k as u32, N))
}

fn cosine_coords(k: usize) -> Vec<(f64, f64)> {
    let n = normalize(widen(COS_NORMALS[k]));
    let basis = cpu_basis(n);
    cosine_samples(k)
        .iter()
        .map(|o| cone_coords(xyz(o), n, basis))
        .collect()
}

/// 32 x 32 cells with equal expected counts: in a = 1 - cos, P(a < x) = 1 - (1 - x)^2.
fn cosine_grid() -> Grid {
    Grid::from_inverse_cdf(32, 32, |p| 1.0 - (1.0 - p).sqrt())
}

/// Chi-square for the +z normal and for a normal with negative z (the other branch of the shader's
/// frame) against the shader's `cosine_hemisphere_pdf`, which integrates to 1 over the hemisphere. A unit
/// of (a, phi) is a steradian (d omega = d(cos) dphi = da dphi): the pdf needs no Jacobian.
#[test]
fn cosine_hemisphere_chi_square() {
    let grid = cosine_grid();
    let (p, total) = with_shader_pdf(|pdf| {
        grid.probabilities(&by_quadrature(|a, _| {
            pdf([0.0, (1.0 - a) as f32, 0.0, 0.0])
        }))
    });
    assert_normalised("cosine hemisphere", total);
    for (k, n) in COS_NORMALS.iter().enumerate() {
        let t = grid.chi2_of(&cosine_coords(k), &p);
        assert_fits(&format!("cosine hemisphere, n = {n:?}"), &t);
    }
}

/// The test rejects the uniform hemisphere (pdf 1/(2 pi); statistic ~300 times the critical value) and
/// a slightly wrong lobe cos^1.1 (normalised: 2.1 cos^1.1 / (2 pi); ~3 times) for the same GPU samples.
#[test]
fn cosine_hemisphere_chi_square_rejects_wrong_pdfs() {
    let grid = cosine_grid();
    let s = cosine_coords(1);
    let uniform = |_a: f64, _p: f64| 1.0 / (2.0 * PI);
    let (_, total) = grid.probabilities(&by_quadrature(uniform));
    assert!((total - 1.0).abs() < 1e-12);
    assert_rejects(
        "uniform hemisphere",
        &grid.chi2(&s, &by_quadrature(uniform)),
        50.0,
    );
    let lobe = |a: f64, _p: f64| 2.1 * (1.0 - a).powf(1.1) / (2.0 * PI);
    let (_, total) = grid.probabilities(&by_quadrature(lobe));
    assert!((total - 1.0).abs() < 1e-6, "cos^1.1 integrates to {total}");
    assert_rejects("cos^1.1 lobe", &grid.chi2(&s, &by_quadrature(lobe)), 2.0);
}

/// Monte Carlo: the integral of cos^2 over the hemisphere is 2 pi / 3; the estimator f / pdf = pi cos
/// has variance pi^2 (1/2 - 4/9) = pi^2 / 18. Within 5 standard errors. Every sample is a unit vector
/// in the upper hemisphere.
#[test]
fn cosine_hemisphere_monte_carlo_and_domain() {
    for (k, &normal) in COS_NORMALS.iter().enumerate() {
        let n = normalize(widen(normal));
        let s = cosine_samples(k);
        let mut sum = 0.0;
        for o in s {
            let w = xyz(o);
            assert!((length(w) - 1.0).abs() < 8.0 * U32, "not unit: {w:?}");
            let c = dot(w, n);
            assert!(c > 0.0, "below the horizon: {w:?}");
            sum += PI * c;
        }
        let est = sum / s.len() as f64;
        let se = (PI * PI / 18.0 / s.len() as f64).sqrt();
        eprintln!("int cos^2: {est} vs {} (se {se:.1e})", 2.0 * PI / 3.0);
        assert!((est - 2.0 * PI / 3.0).abs() < 5.0 * se, "estimate {est}");
    }
}

/// Extreme uniforms (0, 2^-24, 1 - 2^-24, ...) and awkward normals (the poles, where the shader's frame
/// switches branch, and a coordinate axis): unit, finite, cos(theta) = sqrt(1 - u1) as documented.
#[test]
fn cosine_hemisphere_extremes() {
    let us = extreme_us();
    let normals: [[f32; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [1e-20, 0.0, -1.0],
        [0.6, 0.0, -0.8],
    ];
    for n in normals {
        let out = warp_given(Warp::Cosine { n }, &us);
        let n64 = widen(n);
        for (u, o) in us.iter().zip(&out) {
            let w = xyz(o);
            assert!(w.iter().all(|x| x.is_finite()), "n {n:?} u {u:?}: {w:?}");
            // Unit: the frame is orthonormal to a few ulps.
            assert!(
                (length(w) - 1.0).abs() < 8.0 * U32,
                "n {n:?} u {u:?}: |w| = {}",
                length(w)
            );
            let want = (1.0 - u[0] as f64).sqrt();
            assert!(
                (dot(w, n64) - want).abs() < 8.0 * U32,
                "n {n:?} u {u:?}: cos {} vs {want}",
                dot(w, n64)
            );
            assert!(dot(w, n64) > 0.0);
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Uniform cone, as the sphere light samples it.

/// Axis (1, 2, 3)/sqrt(14): no symmetry of the frame helps.
const AXIS: [f32; 3] = [0.267_261_24, 0.534_522_5, 0.801_783_7];

struct ConeCase {
    axis: [f32; 3],
    r: f32,
    d2: f32,
}

/// A big cone (r/d = 0.9, half-angle 64 degrees) about a generic axis, and a tiny one (r/d = 1e-5:
/// 1 - cos = 5e-11, so cos(theta) rounds to 1 in f32) about -z, whose frame is exact so that its
/// directions can be binned.
const CONES: [ConeCase; 2] = [
    ConeCase {
        axis: AXIS,
        r: 0.9,
        d2: 1.0,
    },
    ConeCase {
        axis: [0.0, 0.0, -1.0],
        r: 1e-5,
        d2: 1.0,
    },
];

fn cone_samples(k: usize) -> &'static [[f32; 4]] {
    static S: [OnceLock<Vec<[f32; 4]>>; 2] = [OnceLock::new(), OnceLock::new()];
    let c = &CONES[k];
    S[k].get_or_init(|| {
        warp(
            Warp::SphereCone {
                axis: c.axis,
                r: c.r,
                d2: c.d2,
            },
            2000 + k as u32,
            N,
        )
    })
}

/// The samples in (1 - cos, phi) and the exact f64 1 - cos(theta_max) of the cone.
fn cone_coords_of(k: usize) -> (Vec<(f64, f64)>, f64) {
    let c = &CONES[k];
    let axis = normalize(widen(c.axis));
    let basis = cpu_basis(axis);
    let s = cone_samples(k)
        .iter()
        .map(|o| cone_coords(xyz(o), axis, basis))
        .collect();
    (s, one_minus_cos_f64(c.r as f64, c.d2 as f64))
}

/// Uniform in the cone: pdf 1 / (2 pi (1 - cos theta_max)) per steradian; 32 equal bins of a = 1 - cos.
fn uniform_cone(omc: f64) -> impl Fn(f64, f64) -> f64 {
    move |a, _| {
        if a <= omc {
            1.0 / (2.0 * PI * omc)
        } else {
            0.0
        }
    }
}

/// The f32 1 - cos(theta_max) the GPU warp sampled the cone with (sampling_warps.wgsl returns it in .w).
fn cone_gpu_omc(k: usize) -> f32 {
    let s = cone_samples(k);
    let omc = s[0][3];
    assert!(s.iter().all(|o| o[3] == omc), "one cone per run");
    omc
}

/// Uniform in the cone, for the big and the tiny cone, with the cone from `sphere_cone_one_minus_cos` as
/// the renderer samples sphere lights, against the shader's `cone_pdf` for the same f32 cone (the one
/// the warp used, so that the test compares the warp and its pdf rather than two cones); the pdf
/// integrates to 1 over the cone. A unit of (a = 1 - cos, phi) is a steradian: no Jacobian.
#[test]
fn cone_chi_square_big_and_tiny() {
    for (k, cone) in CONES.iter().enumerate() {
        let (s, _) = cone_coords_of(k);
        let omc32 = cone_gpu_omc(k);
        let omc = omc32 as f64;
        let grid = Grid::from_inverse_cdf(32, 32, |p| p * omc);
        let (p, total) = with_shader_pdf(|pdf| {
            grid.probabilities(&by_quadrature(|a, _| pdf([1.0, a as f32, omc32, 0.0])))
        });
        let what = format!("cone r/d = {}", cone.r);
        assert_normalised(&what, total);
        assert_fits(&what, &grid.chi2_of(&s, &p));
    }
}

/// The cone test rejects a cone 2% wider in 1 - cos (1% in angle) and, for the big cone, directions
/// uniform in theta instead of in solid angle (a classic mistake: P(theta in [t0, t1]) = (t1 - t0) /
/// theta_max).
#[test]
fn cone_chi_square_rejects_wrong_pdfs() {
    for (k, cone) in CONES.iter().enumerate() {
        let (s, omc) = cone_coords_of(k);
        let wide = 1.02 * omc;
        let grid = Grid::from_inverse_cdf(32, 32, |p| p * wide);
        assert_rejects(
            &format!("cone r/d = {} 2% wider", cone.r),
            &grid.chi2(&s, &by_quadrature(uniform_cone(wide))),
            10.0,
        );
    }
    let (s, omc) = cone_coords_of(0);
    let theta = |a: f64| 2.0 * (a / 2.0).sqrt().asin();
    let theta_max = theta(omc);
    let grid = Grid::from_inverse_cdf(32, 32, |p| p * omc);
    let uniform_theta = |a0: f64, a1: f64, p0: f64, p1: f64| {
        (theta(a1) - theta(a0)) / theta_max * (p1 - p0) / (2.0 * PI)
    };
    assert_rejects(
        "cone uniform in theta",
        &grid.chi2(&s, &uniform_theta),
        10.0,
    );
}

// ---------------------------------------------------------------------------------------------------
// The sphere light as it shrinks to a point.

const RATIOS: [f64; 8] = [0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7];

/// `sphere_cone_one_minus_cos(r, d2)` against the f64 value of the same f32 inputs, for r/d from 0.5 down
/// to 1e-7 and distances from 1e-3 to 1e4. The f32 evaluation is r*r, /d2, 1 - s2, sqrt, 1 + cos, and one
/// division: six operations, each within 3 ulps on Vulkan (the spec's bounds for division and sqrt are
/// 2.5 and 3 ulps; the others are correctly rounded), and only the last two touch the small quantity, whose
/// errors do not cancel: 16 ulps (2^-19 ~ 1.9e-6) bounds the relative error.
///
/// The naive `1 - sqrt(1 - s2)` in f32 (on the CPU, correctly rounded) loses everything to cancellation:
/// asserted to be off by more than 1% at r/d = 1e-3 (it is 7%) and by 100% (zero) below r/d = 1.7e-4,
/// where s2 <= 2^-25 and 1 - s2 rounds to 1.
#[test]
fn sphere_cone_matches_f64_as_light_shrinks() {
    let mut input = Vec::new();
    for &ratio in &RATIOS {
        for d in [1e-3f64, 1.0, 37.5, 1e4] {
            input.push([(ratio * d) as f32, (d * d) as f32, 0.0, 0.0]);
        }
    }
    // A sphere touching or containing the point: the cone is the hemisphere (1 - cos = 1), not NaN.
    input.push([1.0, 1.0, 0.0, 0.0]);
    input.push([2.0, 1.0, 0.0, 0.0]);
    let out: Vec<f32> =
        testing::run_kernel(&testing::context(), SPHERE_CONE, &input, input.len()).expect("kernel");
    let tol = 16.0 * 2.0 * U32;
    for (q, &got) in input.iter().zip(&out) {
        let (r, d2) = (q[0], q[1]);
        let want = one_minus_cos_f64(r as f64, d2 as f64);
        let rel = (got as f64 - want).abs() / want;
        let naive = one_minus_cos_naive_f32(r, d2);
        let naive_rel = (naive as f64 - want).abs() / want;
        eprintln!(
            "r/d = {:.1e}: gpu rel err {rel:.1e}, naive f32 rel err {naive_rel:.1e}",
            r as f64 / (d2 as f64).sqrt()
        );
        assert!(got.is_finite() && got > 0.0, "r {r} d2 {d2}: {got}");
        assert!(
            rel <= tol,
            "r {r} d2 {d2}: {got} vs {want} (rel {rel:.2e} > {tol:.2e})"
        );
        // The pdf of the cone, 1 / (2 pi omc), is finite (the renderer multiplies by 2 pi omc instead).
        assert!((1.0 / (2.0 * std::f32::consts::PI * got)).is_finite());
        let ratio = (r as f64) / (d2 as f64).sqrt();
        if ratio < 2e-3 {
            assert!(
                naive_rel > 1e-2,
                "naive f32 at r/d {ratio:.1e} unexpectedly good: {naive_rel:.1e}"
            );
        }
        if ratio < 2e-4 {
            assert_eq!(naive, 0.0, "naive f32 at r/d {ratio:.1e}");
        }
    }
}

/// The irradiance from a sphere light of radiance Le at distance d, on a surface facing it, estimated as
/// the renderer does (sample the cone, average Le cos(theta) * 2 pi (1 - cos theta_max)): it equals
/// Le pi sin^2(theta_max) = Le pi r^2 / d^2 exactly for any r < d, which is the irradiance I / d^2 of the
/// point light of intensity I = Le pi r^2 it tends to. 2^16 samples per radius, within 5 standard errors
/// plus 16 ulps of rounding. The naive cone formula would give an irradiance 100% wrong (zero) at
/// r/d <= 1e-4: asserted on the CPU.
#[test]
fn sphere_light_irradiance_converges_to_point_light() {
    let le = 3.0f64;
    for &ratio in &RATIOS {
        for d in [1.0f64, 100.0] {
            let (r, d2) = ((ratio * d) as f32, (d * d) as f32);
            let out = warp(Warp::SphereCone { axis: AXIS, r, d2 }, 77, 1 << 16);
            let axis = normalize(widen(AXIS));
            let vals: Vec<f64> = out
                .iter()
                .map(|o| le * dot(xyz(o), axis) * 2.0 * PI * o[3] as f64)
                .collect();
            let n = vals.len() as f64;
            let mean = vals.iter().sum::<f64>() / n;
            let var = vals.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
            let point = le * PI * (r as f64) * (r as f64) / d2 as f64;
            let rel = (mean - point).abs() / point;
            let bound = 5.0 * (var / n).sqrt() / point + 32.0 * U32;
            // The naive cone, with the exact mean cosine over it (1 - omc/2).
            let omc_naive = one_minus_cos_naive_f32(r, d2) as f64;
            let naive = le * 2.0 * PI * omc_naive * (1.0 - omc_naive / 2.0);
            let naive_rel = (naive - point).abs() / point;
            eprintln!(
                "r/d = {ratio:.0e}, d = {d}: E rel err {rel:.1e} (bound {bound:.1e}); naive {naive_rel:.1e}"
            );
            assert!(
                rel <= bound,
                "r/d {ratio} d {d}: E {mean} vs point light {point}"
            );
            if ratio <= 1e-4 {
                assert!(
                    naive_rel >= 0.99,
                    "naive irradiance at r/d {ratio}: rel err {naive_rel}"
                );
            }
        }
    }
}

/// Directions sampled in sphere-light cones from r/d = 0.5 down to 1e-7, about a generic axis and
/// including extreme uniforms: finite, unit, and inside the cone. The angle from the axis is computed in
/// f64 from the f32 direction, whose components carry absolute errors of a few ulps of 1, so the allowed
/// slack is 8 * 2^-24 rad beyond theta_max (which is asin(r/d)).
#[test]
fn sphere_cone_directions_inside_cone() {
    let us = extreme_us();
    for &ratio in &RATIOS {
        let (r, d2) = (ratio as f32, 1.0f32);
        let axis = normalize(widen(AXIS));
        let theta_max = ratio.asin();
        let mut out = warp(Warp::SphereCone { axis: AXIS, r, d2 }, 5, 1 << 14);
        out.extend(warp_given(Warp::SphereCone { axis: AXIS, r, d2 }, &us));
        let mut widest: f64 = 0.0;
        for o in &out {
            let w = xyz(o);
            assert!(w.iter().all(|x| x.is_finite()), "r/d {ratio}: {w:?}");
            assert!(
                (length(w) - 1.0).abs() < 8.0 * U32,
                "r/d {ratio}: |w| = {}",
                length(w)
            );
            let angle = length(cross(w, axis)).atan2(dot(w, axis));
            widest = widest.max(angle);
            assert!(
                angle <= theta_max + 8.0 * U32,
                "r/d {ratio}: angle {angle} > {theta_max}"
            );
        }
        // And the samples fill the cone: the widest is near the edge.
        assert!(
            widest > 0.9 * theta_max,
            "r/d {ratio}: widest {widest} of {theta_max}"
        );
    }
}

/// sample_cone at its limits: an empty cone (1 - cos = 0) returns the axis; the full sphere (1 - cos = 2)
/// and the hemisphere stay unit and finite for extreme uniforms.
#[test]
fn cone_limits() {
    let us = extreme_us();
    let axis = normalize(widen(AXIS));
    for omc in [0.0f32, 1e-30, 1.0, 2.0] {
        let out = warp_given(Warp::Cone { axis: AXIS, omc }, &us);
        for (u, o) in us.iter().zip(&out) {
            let w = xyz(o);
            assert!(w.iter().all(|x| x.is_finite()), "omc {omc} u {u:?}: {w:?}");
            assert!(
                (length(w) - 1.0).abs() < 8.0 * U32,
                "omc {omc} u {u:?}: |w| = {}",
                length(w)
            );
            let want = 1.0 - u[0] as f64 * omc as f64;
            assert!(
                (dot(w, axis) - want).abs() < 8.0 * U32,
                "omc {omc} u {u:?}: cos {} vs {want}",
                dot(w, axis)
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// The tent filter.

/// The CDF of the tent of radius r, f(x) = max(0, 1 - |x| / r) / r, written independently of the shader:
/// the area of the triangle left of x.
fn tent_cdf(x: f64, r: f64) -> f64 {
    let t = (x / r).clamp(-1.0, 1.0);
    if t <= 0.0 {
        0.5 * (1.0 + t) * (1.0 + t)
    } else {
        1.0 - 0.5 * (1.0 - t) * (1.0 - t)
    }
}

/// sample_tent2: through the tent's CDF in x and in y, the samples must be uniform on the unit square
/// (chi-square on a 32 x 32 grid, the second CDF scaled to the grid's [0, 2 pi)); every sample within the
/// radius. A tent 10 % wider, and a box of the same radius, are rejected.
#[test]
fn tent_chi_square() {
    let r = 1.5f64;
    let s = warp(Warp::Tent { radius: r as f32 }, 7, N);
    assert!(
        s.iter()
            .all(|o| o[0].abs() <= r as f32 && o[1].abs() <= r as f32)
    );
    let coords = |width: f64, cdf: &dyn Fn(f64, f64) -> f64| -> Vec<(f64, f64)> {
        s.iter()
            .map(|o| {
                let (x, y) = (f64::from(o[0]), f64::from(o[1]));
                (cdf(x, width), 2.0 * PI * cdf(y, width))
            })
            .collect()
    };
    let grid = Grid::from_inverse_cdf(32, 32, |p| p);
    let uniform = |a0: f64, a1: f64, p0: f64, p1: f64| (a1 - a0) * (p1 - p0) / (2.0 * PI);
    assert_fits(
        "tent (F(x), F(y))",
        &grid.chi2(&coords(r, &tent_cdf), &uniform),
    );
    assert_rejects(
        "tent of radius 1.1 r",
        &grid.chi2(&coords(1.1 * r, &tent_cdf), &uniform),
        5.0,
    );
    let box_cdf = |x: f64, w: f64| ((x / w + 1.0) / 2.0).clamp(0.0, 1.0);
    assert_rejects("box", &grid.chi2(&coords(r, &box_cdf), &uniform), 5.0);
}

/// The standard normal CDF, Phi(z) = (1 + erf(z / sqrt 2)) / 2, with erf by its Taylor series
/// 2 / sqrt(pi) sum (-1)^n x^(2n+1) / (n! (2n+1)) (independent of the shader's erf; for |z| <= 6, the range
/// used here, 100 terms leave an error below 1e-9 after the series' cancellation).
fn normal_cdf(z: f64) -> f64 {
    let x = (z / 2f64.sqrt()).clamp(-4.3, 4.3);
    let (mut term, mut sum) = (x, x);
    for n in 1..100 {
        term *= -x * x / n as f64;
        sum += term / (2 * n + 1) as f64;
    }
    0.5 * (1.0 + (2.0 / PI.sqrt() * sum).clamp(-1.0, 1.0))
}

/// The filters cut off at the image's edge (render.sample_border = false, trace.wgsl's film_position):
/// sample_tent_within and sample_gaussian_within on [lo, hi] follow the renormalised CDFs of the cut-off
/// filters, (F(x) - F(lo)) / (F(hi) - F(lo)), each through its own coordinate (chi-square on a 32 x 32
/// grid of the two), on a cut that takes one side off (an edge pixel's) and on the uncut range, where
/// the tent is sample_tent's bit for bit; every sample lies in [lo, hi]. The uncut filters' CDFs are
/// rejected on the cut range.
#[test]
fn filters_cut_off_at_the_image_edge_follow_their_renormalised_cdfs() {
    let (r, sigma) = (1.0f64, 0.5f64);
    for (lo, hi) in [(-1.0f64, 0.5f64), (-0.3, 0.8), (-1.0, 1.0)] {
        let w = Warp::CutOff {
            radius: r as f32,
            sigma: sigma as f32,
            lo: lo as f32,
            hi: hi as f32,
        };
        let s = warp(w, 11, N);
        assert!(
            s.iter()
                .all(|o| (lo..=hi).contains(&f64::from(o[0]))
                    && (lo..=hi).contains(&f64::from(o[1])))
        );
        let cut = |cdf: &dyn Fn(f64) -> f64, x: f64| (cdf(x) - cdf(lo)) / (cdf(hi) - cdf(lo));
        let tent = |x: f64| tent_cdf(x, r);
        let gauss = |x: f64| normal_cdf(x / sigma);
        let coords = |t: &dyn Fn(f64) -> f64, g: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
            s.iter()
                .map(|o| (t(f64::from(o[0])), 2.0 * PI * g(f64::from(o[1]))))
                .collect()
        };
        let grid = Grid::from_inverse_cdf(32, 32, |p| p);
        let uniform = |a0: f64, a1: f64, p0: f64, p1: f64| (a1 - a0) * (p1 - p0) / (2.0 * PI);
        let name = format!("cut to [{lo}, {hi}]");
        assert_fits(
            &name,
            &grid.chi2(&coords(&|x| cut(&tent, x), &|x| cut(&gauss, x)), &uniform),
        );
        if hi - lo < 2.0 {
            assert_rejects(
                &format!("{name}, the uncut filters"),
                &grid.chi2(&coords(&tent, &gauss), &uniform),
                5.0,
            );
        } else {
            let whole = warp(Warp::Tent { radius: r as f32 }, 11, N);
            assert!(
                s.iter()
                    .zip(&whole)
                    .all(|(a, b)| a[0].to_bits() == b[0].to_bits())
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Box–Muller.

const SIGMA: f32 = 0.7;

fn gaussian_samples() -> &'static [[f32; 4]] {
    static S: OnceLock<Vec<[f32; 4]>> = OnceLock::new();
    S.get_or_init(|| warp(Warp::Gaussian { sigma: SIGMA }, 3000, N))
}

/// Samples as (F(r), phi), with F(r) = 1 - exp(-r^2 / (2 sigma^2)) the Rayleigh CDF of the radius: for a
/// 2-D normal, F(r) and phi are independent and uniform on [0, 1) x [0, 2 pi).
fn gaussian_coords(sigma: f64) -> Vec<(f64, f64)> {
    gaussian_samples()
        .iter()
        .map(|o| {
            let (x, y) = (o[0] as f64, o[1] as f64);
            (
                -(-(x * x + y * y) / (2.0 * sigma * sigma)).exp_m1(),
                y.atan2(x).rem_euclid(2.0 * PI),
            )
        })
        .collect()
}

/// A density per unit area in (F, phi) coordinates, by quadrature in (r, phi): the cell [F0, F1] x
/// [p0, p1] is the annulus sector [r(F0), r(F1)], r(F) = sigma sqrt(-2 ln(1 - F)), integrated as
/// `area_pdf(r, phi) r dr dphi` (dA = r dr dphi). The outermost cell is cut at `r_max`.
fn annulus_cell(
    sigma: f64,
    r_max: f64,
    area_pdf: impl Fn(f64, f64) -> f64,
) -> impl Fn(f64, f64, f64, f64) -> f64 {
    move |f0, f1, p0, p1| {
        let r = |f: f64| {
            if f >= 1.0 {
                r_max
            } else {
                sigma * (-2.0 * (-f).ln_1p()).sqrt()
            }
        };
        let (r0, r1) = (r(f0), r(f1));
        let density = |r: f64, phi: f64| area_pdf(r, phi) * r;
        // Split the radial range into pieces of sigma/8 so that the quadrature stays exact to ~1e-15.
        let pieces = (((r1 - r0) / (sigma / 8.0)).ceil() as usize).max(1);
        let h = (r1 - r0) / pieces as f64;
        (0..pieces)
            .map(|i| quad2(&density, r0 + i as f64 * h, r0 + (i + 1) as f64 * h, p0, p1))
            .sum()
    }
}

/// The 2-D normal N(r) = exp(-r^2 / 2 sigma^2) / (2 pi sigma^2) in (F, phi) coordinates, written on the
/// CPU for the negative tests. The outermost cell is cut at 40 sigma (the mass beyond is e^-800).
fn gaussian_cell(sigma: f64) -> impl Fn(f64, f64, f64, f64) -> f64 {
    annulus_cell(sigma, 40.0 * sigma, move |r, _| {
        (-(r * r) / (2.0 * sigma * sigma)).exp() / (2.0 * PI * sigma * sigma)
    })
}

/// Box–Muller against the shader's `gaussian2_pdf` at (r cos phi, r sin phi) of each node (a density per
/// unit area, so the annulus quadrature's r dr dphi is its measure), and the moments.
#[test]
fn gaussian_chi_square_and_moments() {
    let sigma = SIGMA as f64;
    let grid = Grid::from_inverse_cdf(32, 32, |p| p);
    // The outermost cell is cut at 12 sigma: the mass beyond is e^-72, and the f32 density underflows
    // to 0 near 13-14 sigma anyway, so nodes further out would only add queries.
    let (p, total) = with_shader_pdf(|pdf| {
        grid.probabilities(&annulus_cell(sigma, 12.0 * sigma, |r, phi| {
            pdf([3.0, (r * phi.cos()) as f32, (r * phi.sin()) as f32, SIGMA])
        }))
    });
    assert_normalised("Box-Muller", total);
    assert_fits(
        "Box-Muller (F(r), phi)",
        &grid.chi2_of(&gaussian_coords(sigma), &p),
    );
    // Moments: E x = E y = 0, E x^2 = E y^2 = sigma^2, E xy = 0, each within 5 standard errors
    // (sd of x: sigma; of x^2: sqrt(2) sigma^2; of xy: sigma^2).
    let s = gaussian_samples();
    let n = s.len() as f64;
    let mean = |f: &dyn Fn(&[f32; 4]) -> f64| s.iter().map(f).sum::<f64>() / n;
    let (s2, sn) = (sigma * sigma, n.sqrt());
    let mx = mean(&|o| o[0] as f64);
    let my = mean(&|o| o[1] as f64);
    let mxx = mean(&|o| (o[0] as f64).powi(2));
    let myy = mean(&|o| (o[1] as f64).powi(2));
    let mxy = mean(&|o| o[0] as f64 * o[1] as f64);
    eprintln!("moments: {mx:.2e} {my:.2e} {mxx:.5} {myy:.5} {mxy:.2e} (sigma^2 = {s2})");
    assert!(mx.abs() < 5.0 * sigma / sn && my.abs() < 5.0 * sigma / sn);
    assert!(
        (mxx - s2).abs() < 5.0 * 2f64.sqrt() * s2 / sn
            && (myy - s2).abs() < 5.0 * 2f64.sqrt() * s2 / sn
    );
    assert!(mxy.abs() < 5.0 * s2 / sn);
}

/// The test rejects a 5% wider Gaussian, and the classic Box–Muller slip of dropping the factor 2 under
/// the root (a Gaussian of sigma / sqrt 2).
#[test]
fn gaussian_chi_square_rejects_wrong_sigma() {
    let sigma = SIGMA as f64;
    let grid = Grid::from_inverse_cdf(32, 32, |p| p);
    let s = gaussian_coords(sigma);
    // The same cells, with probabilities of a Gaussian of another width.
    for (what, other) in [
        ("sigma x 1.05", 1.05 * sigma),
        ("sigma / sqrt 2", sigma / 2f64.sqrt()),
    ] {
        let cell = gaussian_cell(other);
        let shifted = move |f0: f64, f1: f64, p0: f64, p1: f64| {
            // A cell in the F of sigma is the annulus [r0, r1]: its F under `other`.
            let r = |f: f64| {
                if f >= 1.0 {
                    f64::INFINITY
                } else {
                    sigma * (-2.0 * (-f).ln_1p()).sqrt()
                }
            };
            let g = |r: f64| -(-(r * r) / (2.0 * other * other)).exp_m1();
            cell(g(r(f0)), g(r(f1)).min(1.0), p0, p1)
        };
        assert_rejects(what, &grid.chi2(&s, &shifted), 5.0);
    }
}

/// Box–Muller at extreme uniforms: u1 = 0 gives r = 0, u1 = 1 - 2^-24 (the largest the RNG returns) gives
/// the largest radius, sigma sqrt(2 ln 2^24) = 5.77 sigma (the tail beyond, of mass 2^-24, is cut); all
/// finite, and the radius matches sigma sqrt(-2 ln(1 - u1)) where the logarithm is well conditioned.
#[test]
fn gaussian_extremes() {
    let us = extreme_us();
    let out = warp_given(Warp::Gaussian { sigma: SIGMA }, &us);
    let sigma = SIGMA as f64;
    for (u, o) in us.iter().zip(&out) {
        let (x, y) = (o[0] as f64, o[1] as f64);
        assert!(x.is_finite() && y.is_finite(), "u {u:?}: ({x}, {y})");
        let r = x.hypot(y);
        let want = sigma * (-2.0 * (-(u[0] as f64)).ln_1p()).sqrt();
        if u[0] == 0.0 {
            assert_eq!(r, 0.0);
        } else if u[0] >= 0.25 {
            // |log(1 - u1)| >= 0.29 here, so Vulkan's absolute bound 2^-21 on log is a relative error
            // below 2e-6 (1e-6 in r); sqrt and the products add a few ulps.
            assert!((r - want).abs() <= 1e-5 * want, "u {u:?}: r {r} vs {want}");
        } else {
            // Near u1 = 0 the GPU's log(1 - u1) is only bounded to an absolute 2^-21 (lavapipe's radius
            // at u1 = 2^-24 is 32% too large), so only r^2 <= 2 sigma^2 (u1 + 2^-21), +1%, is asserted.
            let bound = sigma * (2.0 * (u[0] as f64 + 2f64.powi(-21))).sqrt() * 1.01;
            assert!(r <= bound, "u {u:?}: r {r} vs {want} (bound {bound})");
        }
    }
    let top = us
        .iter()
        .position(|u| u[0] == U_MAX)
        .expect("U_MAX in the grid");
    let r = (out[top][0] as f64).hypot(out[top][1] as f64);
    assert!(
        (r / sigma - (48.0 * 2f64.ln()).sqrt()).abs() < 1e-5,
        "largest radius {r}"
    );
}

// ---------------------------------------------------------------------------------------------------
// Uniform disk.

fn disk_coords() -> Vec<(f64, f64)> {
    warp(Warp::Disk, 4000, N)
        .iter()
        .map(|o| {
            let (x, y) = (o[0] as f64, o[1] as f64);
            (x * x + y * y, y.atan2(x).rem_euclid(2.0 * PI))
        })
        .collect()
}

fn disk_samples() -> &'static [(f64, f64)] {
    static S: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    S.get_or_init(disk_coords)
}

/// Uniform on the unit disk, against the shader's `uniform_disk_pdf` (per unit area) at the point
/// (sqrt(a) cos phi, sqrt(a) sin phi) of each node; in (a = r^2, phi), dA = r dr dphi = da dphi / 2, so
/// the density per unit (a, phi) is half the pdf. 32 equal bins of r^2.
#[test]
fn disk_chi_square() {
    let grid = Grid::from_inverse_cdf(32, 32, |p| p);
    let (p, total) = with_shader_pdf(|pdf| {
        grid.probabilities(&by_quadrature(|a, phi| {
            let r = a.sqrt();
            0.5 * pdf([4.0, (r * phi.cos()) as f32, (r * phi.sin()) as f32, 0.0])
        }))
    });
    assert_normalised("uniform disk", total);
    let s = disk_samples();
    assert_fits("uniform disk", &grid.chi2_of(s, &p));
    assert!(
        s.iter().all(|&(a, _)| a < 1.0),
        "a sample outside the unit disk"
    );
}

/// The test rejects the naive polar mapping r = u1 (uniform in radius, crowding the centre):
/// P(r^2 in [a0, a1]) = sqrt(a1) - sqrt(a0).
#[test]
fn disk_chi_square_rejects_uniform_radius() {
    let grid = Grid::from_inverse_cdf(32, 32, |p| p);
    let naive =
        |a0: f64, a1: f64, p0: f64, p1: f64| (a1.sqrt() - a0.sqrt()) * (p1 - p0) / (2.0 * PI);
    assert_rejects(
        "disk uniform in r",
        &grid.chi2(disk_samples(), &naive),
        50.0,
    );
}

#[test]
fn disk_extremes() {
    let us = extreme_us();
    let out = warp_given(Warp::Disk, &us);
    for (u, o) in us.iter().zip(&out) {
        let (x, y) = (o[0] as f64, o[1] as f64);
        assert!(x.is_finite() && y.is_finite());
        let r = x.hypot(y);
        assert!(r <= 1.0, "u {u:?}: r {r}");
        assert!(
            (r - (u[0] as f64).sqrt()).abs() < 8.0 * U32,
            "u {u:?}: r {r}"
        );
    }
}

/// Far below any useful light size, r^2 leaves the f32 range: for r >= 1e-18 (r^2 >= 1e-36, a normal
/// f32) the cone is still exact to 32 ulps; below ~1.1e-19 r^2 is subnormal (lavapipe keeps subnormals:
/// r/d = 1e-20 still gives 5e-41; a device that flushes them gives 0) and below ~3.7e-23 it is 0. The
/// cone then comes out smaller than the truth or 0, never negative or NaN. (The host's sphere-light
/// radiance P / (4 pi^2 r^2) overflows to inf at such radii, and inf * 0 is NaN: see the report.)
#[test]
fn sphere_cone_underflow_limit() {
    let input: Vec<[f32; 4]> = [1e-10f32, 1e-15, 1e-18, 1e-19, 1e-20, 1e-25, 1e-30]
        .iter()
        .map(|&r| [r, 1.0, 0.0, 0.0])
        .collect();
    let out: Vec<f32> =
        testing::run_kernel(&testing::context(), SPHERE_CONE, &input, input.len()).expect("kernel");
    for (q, &got) in input.iter().zip(&out) {
        let want = one_minus_cos_f64(q[0] as f64, 1.0);
        eprintln!("r/d = {:e}: {got:e} vs {want:e}", q[0]);
        assert!(got.is_finite() && got >= 0.0, "r {}: {got}", q[0]);
        if q[0] >= 1e-18 {
            assert!(
                (got as f64 - want).abs() <= 32.0 * U32 * want,
                "r {}: {got} vs {want}",
                q[0]
            );
        } else {
            assert!(
                (got as f64) <= want * (1.0 + 32.0 * U32),
                "r {}: {got} vs {want}",
                q[0]
            );
        }
    }
}
