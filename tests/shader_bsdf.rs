//! The materials of shaders/bsdfs/, read back from the GPU.
//!
//! * The BSDF interface (end of this file): each material's `sample` against its own `eval` and `pdf`
//!   (weight = f cos / pdf, pdf(sampled wi) = the pdf it reported), a chi-square of the diffuse sampler's
//!   directions against the shader's own `bsdf_pdf` integrated over each bin on the GPU, reciprocity,
//!   the delta lobes' directions and probabilities (mirror, glass: reflection chosen with probability F),
//!   and the emitter absorbing.
//! * Fresnel reflectance and Snell refraction, compared with f64 references evaluated on the same f32
//!   inputs.
//!
//! Tolerances. u = 2^-24 is the f32 unit roundoff; Vulkan allows 2.5 ulps (5u) for division and 3 ulps
//! (6u) for sqrt, the other operations being correctly rounded.
//! * `fresnel_dielectric` is well conditioned except through sin^2(theta_t) = (1 - cos_i^2) / eta^2 near
//!   the critical angle, where cos_t = sqrt(1 - sin^2 t) has an infinite derivative. The reference is
//!   therefore evaluated with sin^2 t perturbed by up to +-4u max(1, 1/eta^2): the absolute error of its
//!   f32 evaluation is u for 1 - cos_i^2 (u/2 for the square, u/2 for the difference), amplified by the
//!   division by eta^2, plus u sin^2 t for rounding eta^2 and the quotient; a factor-2 margin on top. The
//!   GPU value must lie in that envelope, widened by the forward error of the rest: each reflection
//!   amplitude r = (a - b) / (a + b) with a, b >= 0 carries an absolute error <= 8u (errors of a and b
//!   relative to a + b, plus the division), so |dF| <= 16u (|r_par| + |r_perp|) + 16u F (factor 2 again).
//!   This is a mixed forward-backward bound; it is what lets the tests go right up to the critical angle,
//!   where a 1-ulp change of cos_i itself moves F by ~1e-4 (F's own conditioning, not the code's).
//! * `refract_dir` returns a normalised f32 vector whose components carry absolute errors of a few ulps of
//!   max(1, 1/eta) (the size of d / eta before normalisation): Snell's law, unit length and coplanarity
//!   are checked to 16u max(1, 1/eta).

mod common;

use common::vec::{V3, basis, cross, dot, from_angles, length, normalize, xyz};
use vkpath::gpu::testing;

const EVAL: &str = include_str!("../shaders/tests/fresnel_eval.wgsl");
const BSDF: &str = include_str!("../shaders/tests/bsdf_sample.wgsl");
const REFRACT: &str = include_str!("../shaders/tests/fresnel_refract.wgsl");

/// Unit roundoff of f32.
const U: f64 = f32::EPSILON as f64 / 2.0;

/// Relative indices: entering glass, water, diamond, leaving them, index-matched and almost.
const ETAS: [f32; 11] = [
    1.5,
    1.0 / 1.5,
    1.333,
    1.0 / 1.333,
    2.42,
    1.0 / 2.42,
    1.0001,
    0.9999,
    4.0,
    0.25,
    1.000_000_1, // 1 + 1 ulp
];

fn fresnel_gpu(cases: &[(f32, f32)]) -> Vec<f32> {
    let input: Vec<[f32; 4]> = cases.iter().map(|&(c, e)| [c, e, 0.0, 0.0]).collect();
    let out = testing::run_kernel(&testing::context(), EVAL, &input, input.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// The f64 reference: F and the two amplitudes, with sin^2(theta_t) shifted by `ds`.
fn fresnel_ref(cos_i: f64, eta: f64, ds: f64) -> (f64, f64, f64) {
    let c = cos_i.clamp(0.0, 1.0);
    // sin^2 t = (1 - c^2) / eta^2, and 1 - sin^2 t = (eta^2 - 1 + c^2) / eta^2 without cancellation
    // beyond f64's own.
    let sin2_t = (1.0 - c * c) / (eta * eta) + ds;
    if sin2_t >= 1.0 {
        return (1.0, 1.0, 1.0);
    }
    let cos_t = if ds == 0.0 {
        ((eta * eta - 1.0 + c * c) / (eta * eta)).max(0.0).sqrt()
    } else {
        (1.0 - sin2_t).sqrt()
    };
    let r_par = (eta * c - cos_t) / (eta * c + cos_t);
    let r_perp = (c - eta * cos_t) / (c + eta * cos_t);
    (0.5 * (r_par * r_par + r_perp * r_perp), r_par, r_perp)
}

/// The interval the GPU's F(cos_i, eta) must fall in (see the module comment).
fn fresnel_envelope(cos_i: f32, eta: f32) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let amp = (1.0f64).max(1.0 / (eta as f64 * eta as f64));
    for ds in [-4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0].map(|k| k * U * amp) {
        let (f, rp, rs) = fresnel_ref(cos_i as f64, eta as f64, ds);
        let err = 16.0 * U * (rp.abs() + rs.abs()) + 16.0 * U * f;
        lo = lo.min(f - err);
        hi = hi.max(f + err);
    }
    (lo.max(0.0), hi.min(1.0))
}

fn assert_in_envelope(cos_i: f32, eta: f32, got: f32) {
    let (lo, hi) = fresnel_envelope(cos_i, eta);
    let g = got as f64;
    assert!(
        got.is_finite() && g >= lo && g <= hi,
        "F({cos_i}, {eta}) = {got}, expected in [{lo}, {hi}] (f64: {})",
        fresnel_ref(cos_i as f64, eta as f64, 0.0).0
    );
}

/// Normal incidence: F = ((eta - 1) / (eta + 1))^2. There sin^2 t = 0 and cos_t = 1 exactly, eta - 1 is
/// exact (Sterbenz) for eta in [1/2, 2], and what is left (eta + 1, the division, squares, the mean)
/// stays within 16 ulps relative (2^-19), even for eta = 1.0001 where F = 2.5e-9.
#[test]
fn normal_incidence() {
    let cases: Vec<(f32, f32)> = ETAS.iter().map(|&e| (1.0, e)).collect();
    let out = fresnel_gpu(&cases);
    for (&(_, eta), &got) in cases.iter().zip(&out) {
        let e = eta as f64;
        let want = ((e - 1.0) / (e + 1.0)).powi(2);
        let rel = (got as f64 - want).abs() / want;
        eprintln!("eta {eta}: F(1) = {got:e} vs {want:e}, rel err {rel:.1e}");
        assert!(
            rel <= 32.0 * U,
            "eta {eta}: F(1) = {got} vs {want} (rel {rel:.2e})"
        );
    }
    // Glass: 4%.
    assert!((out[0] - 0.04).abs() < 1e-6);
}

/// Grazing incidence: F -> 1, and F(0) is exactly 1 (both amplitudes are exactly -1, or total internal
/// reflection for eta < 1); F increases towards grazing; every value is inside the envelope.
#[test]
fn grazing_incidence() {
    let cos = [0.0f32, 1e-30, 1e-7, 1e-5, 1e-3, 1e-2, 0.1];
    let mut cases = Vec::new();
    for &e in &ETAS {
        for &c in &cos {
            cases.push((c, e));
        }
    }
    let out = fresnel_gpu(&cases);
    for (k, &e) in ETAS.iter().enumerate() {
        let f = &out[k * cos.len()..(k + 1) * cos.len()];
        assert_eq!(f[0], 1.0, "eta {e}: F(0) = {}", f[0]);
        for (j, &c) in cos.iter().enumerate() {
            assert_in_envelope(c, e, f[j]);
            if j > 0 {
                assert!(
                    f[j] <= f[j - 1],
                    "eta {e}: F not decreasing away from grazing: {f:?}"
                );
            }
        }
        // Within 1e-6 of grazing, F is within 1e-4 of 1 (for these etas; dF/dcos = -4 eta/sqrt(eta^2-1)
        // and its analogues at grazing are at most ~2000 here, for eta = 1 + 1 ulp, whose F drops faster).
        if (e - 1.0).abs() > 1e-3 {
            assert!(f[2] > 1.0 - 1e-4, "eta {e}: F(1e-7) = {}", f[2]);
        }
    }
}

/// Around the critical angle of each eta < 1 (cos_c = sqrt(1 - eta^2)): the f32 neighbours of cos_c
/// within +-64 ulps and relative offsets up to 1%. Inside total internal reflection F is exactly 1 (no
/// NaN from the square root of a negative), just outside it F is finite, < 1 and inside the envelope,
/// and F is continuous: it approaches 1 as the angle nears the critical one.
#[test]
fn critical_angle() {
    let mut cases = Vec::new();
    for &e in ETAS.iter().filter(|&&e| e < 1.0) {
        let cos_c = (1.0 - (e as f64) * (e as f64)).sqrt() as f32;
        let mut c = cos_c;
        for _ in 0..64 {
            c = f32::from_bits(c.to_bits() - 1);
        }
        for _ in 0..129 {
            cases.push((c, e));
            c = f32::from_bits(c.to_bits() + 1);
        }
        for rel in [1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
            cases.push(((cos_c as f64 * (1.0 - rel)) as f32, e));
            cases.push(((cos_c as f64 * (1.0 + rel)) as f32, e));
        }
    }
    let out = fresnel_gpu(&cases);
    let (mut tir, mut near) = (0, 0);
    for (&(c, e), &got) in cases.iter().zip(&out) {
        assert!(
            got.is_finite() && (0.0..=1.0).contains(&got),
            "F({c}, {e}) = {got}"
        );
        assert_in_envelope(c, e, got);
        let (c64, e64) = (c as f64, e as f64);
        // Exact f64 test of the regime, with a margin of 8u in sin^2 t.
        let sin2_t = (1.0 - c64 * c64) / (e64 * e64);
        if sin2_t >= 1.0 + 8.0 * U {
            assert_eq!(got, 1.0, "TIR at F({c}, {e})");
            tir += 1;
        } else if sin2_t <= 1.0 - 8.0 * U {
            assert!(got < 1.0, "not TIR at F({c}, {e}) = {got}");
            // Continuity: 1 - F ~ k sqrt(1 - sin^2 t) with k = 4 / (eta cos_c) < 11 here (eta >= 1/2.42).
            let k = 4.0 / (e64 * (1.0 - e64 * e64).sqrt());
            assert!(
                1.0 - got as f64 <= 1.5 * k * (1.0 - sin2_t).sqrt() + 1e-6,
                "F({c}, {e}) = {got}"
            );
            near += 1;
        }
    }
    assert!(
        tir > 100 && near > 100,
        "the sweep should straddle the critical angle: {tir} TIR, {near} not"
    );
}

/// eta exactly 1: F is exactly 0 at every angle (no interface). One ulp away, F is tiny but finite and
/// non-negative, and inside the envelope (its relative error is large since the amplitudes cancel, but
/// F itself is below 1e-12 except at grazing).
#[test]
fn index_matched() {
    let cos = [0.0f32, 1e-7, 1e-3, 0.3, 0.7, 0.999_999, 1.0];
    let mut cases = Vec::new();
    for e in [1.0f32, 1.000_000_1, 0.999_999_94] {
        for &c in &cos {
            cases.push((c, e));
        }
    }
    let out = fresnel_gpu(&cases);
    for (&(c, e), &got) in cases.iter().zip(&out) {
        if e == 1.0 {
            assert_eq!(got.to_bits(), 0, "F({c}, 1) = {got}");
        } else {
            assert!(got.is_finite() && got >= 0.0, "F({c}, {e}) = {got}");
            assert_in_envelope(c, e, got);
        }
    }
}

/// A sweep of 1001 angles (cos_i = 0, 0.001, ..., 1) for each eta: no NaN, F in [0, 1], inside the
/// envelope.
#[test]
fn sweep_against_reference() {
    let mut cases = Vec::new();
    for &e in &ETAS {
        for k in 0..=1000 {
            cases.push((k as f32 / 1000.0, e));
        }
    }
    let out = fresnel_gpu(&cases);
    let mut worst: f64 = 0.0;
    for (&(c, e), &got) in cases.iter().zip(&out) {
        assert!(
            got.is_finite() && (0.0..=1.0).contains(&got),
            "F({c}, {e}) = {got}"
        );
        assert_in_envelope(c, e, got);
        worst = worst.max((got as f64 - fresnel_ref(c as f64, e as f64, 0.0).0).abs());
    }
    eprintln!("largest |F - F_f64| over the sweep: {worst:.1e}");
}

// ---------------------------------------------------------------------------------------------------
// Refraction.

fn to_f64(a: [f32; 4]) -> V3 {
    [a[0] as f64, a[1] as f64, a[2] as f64]
}

/// One refraction query: incoming direction d, normal n facing the incoming side, eta.
#[derive(Clone, Copy, Debug)]
struct Query {
    d: [f32; 3],
    n: [f32; 3],
    eta: f32,
}

/// Returns (refract_dir(d, n, eta), fresnel_dielectric(-dot(d, n), eta)) for each query.
fn refract_gpu(qs: &[Query]) -> Vec<[f32; 4]> {
    let input: Vec<[f32; 4]> = qs
        .iter()
        .flat_map(|q| {
            [
                [q.d[0], q.d[1], q.d[2], q.eta],
                [q.n[0], q.n[1], q.n[2], 0.0],
            ]
        })
        .collect();
    let out = testing::run_kernel(&testing::context(), REFRACT, &input, qs.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// Incoming directions over a sweep of angles, cos_i = 0 (grazing) to 1 (normal), at a few azimuths,
/// about the +z normal and a generic one.
fn sweep_queries(eta: f32) -> Vec<Query> {
    let normals: [V3; 2] = [[0.0, 0.0, 1.0], normalize([0.3, -0.5, 0.8])];
    let mut cos: Vec<f64> = vec![0.0, 1e-7, 1e-4, 1e-2];
    cos.extend((1..200).map(|k| k as f64 / 200.0));
    cos.extend([1.0 - 1e-4, 1.0 - 1e-7, 1.0]);
    let mut qs = Vec::new();
    for n in normals {
        let helper = if n[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let t = normalize(cross(helper, n));
        let b = cross(n, t);
        for &c in &cos {
            let s = (1.0 - c * c).sqrt();
            for phi in [0.3f64, 2.0, 4.5] {
                let d: V3 =
                    std::array::from_fn(|k| s * (phi.cos() * t[k] + phi.sin() * b[k]) - c * n[k]);
                qs.push(Query {
                    d: d.map(|x| x as f32),
                    n: n.map(|x| x as f32),
                    eta,
                });
            }
        }
    }
    qs
}

/// Snell's law and geometry for entering (1.5, 1.333, 2.42) and leaving (their inverses) glass, water,
/// diamond, at every angle of the sweep that is not total internal reflection:
/// sin_t = sin_i / eta (to 16u max(1, 1/eta)), |w| = 1, w in the plane of d and n, on the far side of the
/// surface, with its tangential part along d's. Everywhere (TIR included): finite.
#[test]
fn refraction_obeys_snell() {
    for eta in [1.5f32, 1.0 / 1.5, 1.333, 1.0 / 1.333, 2.42, 1.0 / 2.42] {
        let qs = sweep_queries(eta);
        let out = refract_gpu(&qs);
        let tol = 16.0 * U * (1.0f64).max(1.0 / eta as f64);
        let (mut worst_snell, mut refracted) = (0.0f64, 0);
        for (q, o) in qs.iter().zip(&out) {
            let w = to_f64(*o);
            assert!(o.iter().all(|x| x.is_finite()), "{q:?}: {o:?}");
            assert!((0.0..=1.0).contains(&o[3]), "{q:?}: F = {}", o[3]);
            let d = normalize(q.d.map(|x| x as f64));
            let n = normalize(q.n.map(|x| x as f64));
            let sin_i = length(cross(d, n));
            let sin_t_want = sin_i / eta as f64;
            if sin_t_want >= 1.0 - 1e-6 {
                continue; // TIR or at its edge: the renderer reflects; only finiteness is required
            }
            refracted += 1;
            assert!((length(w) - 1.0).abs() <= tol, "{q:?}: |w| = {}", length(w));
            let sin_t = length(cross(w, n)) / length(w);
            let err = (sin_t - sin_t_want).abs();
            worst_snell = worst_snell.max(err);
            assert!(
                err <= tol,
                "{q:?}: sin_t {sin_t} vs sin_i / eta {sin_t_want} (err {err:.2e})"
            );
            assert!(dot(w, n) < 0.0, "{q:?}: w = {w:?} is on the incoming side");
            if sin_i > 1e-3 {
                let m = normalize(cross(d, n));
                assert!(
                    dot(w, m).abs() <= tol,
                    "{q:?}: w off the plane of d and n by {}",
                    dot(w, m)
                );
                let tan = |v: V3| std::array::from_fn::<f64, 3, _>(|k| v[k] - dot(v, n) * n[k]);
                assert!(
                    dot(tan(w), tan(d)) > 0.0,
                    "{q:?}: tangential direction reversed"
                );
            }
        }
        eprintln!(
            "eta {eta}: {refracted} refracted, largest Snell error {worst_snell:.1e} (tol {tol:.1e})"
        );
        assert!(refracted >= 100, "only {refracted} refracted");
    }
}

/// eta = 1: refract_dir returns d bit for bit and F = 0, at every angle (including grazing and normal).
#[test]
fn refraction_index_matched_is_identity() {
    let qs = sweep_queries(1.0);
    let out = refract_gpu(&qs);
    for (q, o) in qs.iter().zip(&out) {
        for k in 0..3 {
            assert_eq!(o[k].to_bits(), q.d[k].to_bits(), "{q:?}: {o:?}");
        }
        assert_eq!(o[3].to_bits(), 0, "{q:?}: F = {}", o[3]);
    }
}

/// Through a slab with parallel faces (enter at eta = 1.5, leave at 1/1.5 through a face with the same
/// normal), a ray comes out parallel to how it went in. The tangential part (the sine, well conditioned)
/// matches to the error of two refractions, 16u (1 + 1.5). The normal part cos_out = sqrt(1 - 2.25 (1 -
/// cos_in^2)) amplifies the error of the inside direction by d cos_out / d cos_in = 2.25 cos_in / cos_out,
/// large near grazing (a ray entering at cos = 0.01 leaves through a face near its critical angle), so
/// the full direction is held to 16u (1.5 + 2.25 cos_in / cos_out).
#[test]
fn slab_round_trip() {
    let enter = sweep_queries(1.5);
    let inside = refract_gpu(&enter);
    // The far face: same orientation, so the normal facing the ray inside is the same n.
    let leave: Vec<Query> = enter
        .iter()
        .zip(&inside)
        .map(|(q, o)| Query {
            d: [o[0], o[1], o[2]],
            n: q.n,
            eta: 1.0 / 1.5,
        })
        .collect();
    let out = refract_gpu(&leave);
    let mut worst_amp: f64 = 0.0;
    for ((q, o), i) in enter.iter().zip(&out).zip(&inside) {
        let n = normalize(q.n.map(|x| x as f64));
        let d = normalize(q.d.map(|x| x as f64));
        let w = to_f64(*o);
        assert!(w.iter().all(|x| x.is_finite()), "{q:?}: exit {w:?}");
        let tan = |v: V3| std::array::from_fn::<f64, 3, _>(|k| v[k] - dot(v, n) * n[k]);
        let diff = |a: V3, b: V3| length(std::array::from_fn::<f64, 3, _>(|k| a[k] - b[k]));
        let err_tan = diff(tan(w), tan(d));
        assert!(
            err_tan <= 16.0 * U * 2.5,
            "{q:?}: tangential exit {w:?} vs entry {d:?} (err {err_tan:.2e})"
        );
        let (cos_in, cos_out) = (-dot(to_f64(*i), n), -dot(d, n));
        if cos_out < 1e-6 {
            continue; // grazing entry: the exit is at the critical angle, conditioning unbounded
        }
        let amp = 2.25 * cos_in / cos_out;
        worst_amp = worst_amp.max(amp);
        let err = diff(w, d);
        assert!(
            err <= 16.0 * U * (1.5 + amp),
            "{q:?}: exit {w:?} vs entry {d:?} (err {err:.2e}, amp {amp:.0})"
        );
    }
    eprintln!("slab: largest amplification {worst_amp:.0}");
}

// --- The BSDF interface (bsdf_sample / bsdf_eval / bsdf_pdf) -----------------------------------------

use common::stats::{assert_fits, assert_rejects, chi2};
use vkpath::kernel::abi::{
    BSDF_DELTA, BSDF_REFLECTION, BSDF_TRANSMISSION, MAT_DIELECTRIC, MAT_DIFFUSE, MAT_EMITTER,
    MAT_MIRROR,
};

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BsdfCase {
    m: [f32; 4],
    k: [f32; 4],
    wo: [f32; 4],
    ns: [f32; 4],
    q: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BsdfOut {
    s: [f32; 4],
    w: [f32; 4],
    at: [f32; 4],
    aq: [f32; 4],
    r: [f32; 4],
}

fn v4(v: V3) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, 0.0]
}

/// A material and a shading configuration; `q` per case.
#[derive(Clone, Copy)]
struct Setup {
    kind: u32,
    albedo: [f32; 3],
    ior: f32,
    entering: bool,
    wo: V3,
    ns: V3,
}

impl Setup {
    fn case(&self, seed: u32, q: V3) -> BsdfCase {
        BsdfCase {
            m: [
                self.albedo[0],
                self.albedo[1],
                self.albedo[2],
                self.kind as f32,
            ],
            k: [self.ior, self.entering as u32 as f32, seed as f32, 0.0],
            wo: v4(self.wo),
            ns: v4(self.ns),
            q: v4(q),
        }
    }
}

fn bsdf_gpu(cases: &[BsdfCase]) -> Vec<BsdfOut> {
    let out = testing::run_kernel(&testing::context(), BSDF, cases, cases.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// `n` samples of one setup, invocation i drawing from rng_new(i, 0, seed).
fn samples(setup: &Setup, seed: u32, n: usize) -> Vec<BsdfOut> {
    bsdf_gpu(&vec![setup.case(seed, setup.ns); n])
}

fn reflect64(wo: V3, n: V3) -> V3 {
    let c = dot(wo, n);
    std::array::from_fn(|k| 2.0 * c * n[k] - wo[k])
}

/// Shading normals for the tests: the axes (both branches of the shader's frame) and a generic one.
fn normals() -> [V3; 3] {
    [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        normalize([0.3, -0.5, 0.81]),
    ]
}

/// Diffuse: the sampler against its own pdf. Directions binned in (cos^2 theta, phi) (16 x 16 cells of
/// equal probability for a cosine lobe); each bin's expected count is the shader's bsdf_pdf integrated
/// over it on the GPU (4 x 4 Gauss–Legendre nodes, d omega = d(cos^2) dphi / (2 cos)). The probabilities
/// sum to 1 (the pdf is normalised over the hemisphere); the same samples are rejected against the
/// uniform hemisphere (a negative control).
#[test]
fn diffuse_sampler_matches_its_own_pdf() {
    const N: usize = 1 << 18;
    const K: usize = 16;
    let gl = common::stats::GAUSS_LEGENDRE_4;
    for (k, ns) in normals().into_iter().enumerate() {
        let wo = from_angles(ns, 0.6, 1.0);
        let setup = Setup {
            kind: MAT_DIFFUSE,
            albedo: [0.8, 0.5, 0.2],
            ior: 1.0,
            entering: true,
            wo,
            ns,
        };
        let out = samples(&setup, 100 + k as u32, N);
        let (t, b) = basis(ns);
        let step = 2.0 * std::f64::consts::PI / K as f64;
        let mut observed = vec![0.0; K * K + 1];
        for o in &out {
            let w = xyz(o.s);
            let c = dot(w, ns);
            let phi = dot(w, b)
                .atan2(dot(w, t))
                .rem_euclid(2.0 * std::f64::consts::PI);
            let cell = if c > 0.0 {
                let i = ((c * c * K as f64) as usize).min(K - 1);
                let j = ((phi / step) as usize).min(K - 1);
                i * K + j
            } else {
                K * K // below the surface: expected never
            };
            observed[cell] += 1.0;
        }
        // The quadrature nodes of every cell, queried on the GPU as `q`.
        let mut nodes = Vec::new();
        for i in 0..K {
            for j in 0..K {
                for &(x, wx) in &gl {
                    for &(y, wy) in &gl {
                        let a = (i as f64 + 0.5 * (x + 1.0)) / K as f64;
                        let phi = (j as f64 + 0.5 * (y + 1.0)) * step;
                        let jac = 1.0 / (2.0 * a.sqrt());
                        let weight = wx * wy * 0.25 / K as f64 * step * jac;
                        nodes.push((from_angles(ns, a.sqrt(), phi), weight));
                    }
                }
            }
        }
        let cases: Vec<BsdfCase> = nodes.iter().map(|(q, _)| setup.case(0, *q)).collect();
        let pdfs = bsdf_gpu(&cases);
        let mut expected = vec![0.0; K * K + 1];
        for (n, ((_, weight), o)) in nodes.iter().zip(&pdfs).enumerate() {
            expected[n / 16] += weight * o.aq[3] as f64;
        }
        let total: f64 = expected.iter().sum();
        assert!(
            (total - 1.0).abs() < 1e-4,
            "normal {ns:?}: bsdf_pdf integrates to {total}"
        );
        let scaled: Vec<f64> = expected.iter().map(|p| p * N as f64).collect();
        assert_fits(
            &format!("diffuse sampler, ns = {ns:?}"),
            &chi2(&observed, &scaled),
        );
        let uniform: Vec<f64> = (0..=K * K)
            .map(|c| {
                if c == K * K {
                    0.0
                } else {
                    // P(cos^2 in [a0, a1]) for a uniform hemisphere: sqrt(a1) - sqrt(a0), per phi bin.
                    let i = c / K;
                    let (a0, a1) = (i as f64 / K as f64, (i + 1) as f64 / K as f64);
                    (a1.sqrt() - a0.sqrt()) / K as f64 * N as f64
                }
            })
            .collect();
        assert_rejects(
            "diffuse vs uniform hemisphere",
            &chi2(&observed, &uniform),
            10.0,
        );
    }
}

/// Diffuse: every sample is consistent with eval and pdf: the weight is albedo = f cos / pdf, the pdf
/// reported is bsdf_pdf at the sampled direction, f = albedo / pi above the surface and 0 below, and
/// f is reciprocal (f(wo, q) = f(q, wo) for directions above the surface).
#[test]
fn diffuse_sample_eval_pdf_agree() {
    for (k, ns) in normals().into_iter().enumerate() {
        let setup = Setup {
            kind: MAT_DIFFUSE,
            albedo: [0.8, 0.5, 0.2],
            ior: 1.0,
            entering: true,
            wo: from_angles(ns, 0.3, 2.0),
            ns,
        };
        let qs: Vec<V3> = (0..4096)
            .map(|i| {
                from_angles(
                    ns,
                    -1.0 + 2.0 * ((i * 37 % 4096) as f64 + 0.5) / 4096.0,
                    i as f64,
                )
            })
            .collect();
        let cases: Vec<BsdfCase> = qs.iter().map(|&q| setup.case(7 + k as u32, q)).collect();
        for (q, o) in qs.iter().zip(bsdf_gpu(&cases)) {
            assert_eq!(o.w[3] as u32, BSDF_REFLECTION);
            assert_eq!(o.r[3], 0.0, "diffuse is not delta");
            assert_eq!(&o.w[..3], &setup.albedo, "weight = albedo");
            assert_eq!(o.s[3], o.at[3], "pdf reported = bsdf_pdf(wi)");
            let cos = dot(xyz(o.s), ns);
            assert!(cos >= 0.0, "sampled below the surface: {o:?}");
            for c in 0..3 {
                let f_cos_over_pdf = o.at[c] as f64 * cos / o.s[3] as f64;
                assert!(
                    (f_cos_over_pdf - o.w[c] as f64).abs() <= 1e-5 * o.w[c] as f64 || cos < 1e-6,
                    "f cos / pdf = {f_cos_over_pdf} vs weight {}",
                    o.w[c]
                );
            }
            let above = dot(*q, ns) > 0.0;
            let f = if above {
                setup.albedo[0] as f64 / std::f64::consts::PI
            } else {
                0.0
            };
            assert!(
                (o.aq[0] as f64 - f).abs() <= 1e-6,
                "f at {q:?}: {}",
                o.aq[0]
            );
            if above {
                // (The integrator always passes wo above ns: it flips ns to wo's side.)
                assert_eq!(o.aq[0], o.r[0], "reciprocity");
            }
            let pdf = dot(*q, ns).max(0.0) / std::f64::consts::PI;
            assert!(
                (o.aq[3] as f64 - pdf).abs() <= 1e-6,
                "pdf at {q:?}: {}",
                o.aq[3]
            );
        }
    }
}

/// Mirror: the exact reflection about ns, weight = tint, a delta lobe of probability 1; f and pdf are 0
/// for every given direction (no direction but the sampled one has probability).
#[test]
fn mirror_is_a_delta_reflection() {
    for ns in normals() {
        for cos in [1.0, 0.5, 1e-3] {
            let setup = Setup {
                kind: MAT_MIRROR,
                albedo: [0.9, 0.8, 0.7],
                ior: 1.0,
                entering: true,
                wo: from_angles(ns, cos, 0.7),
                ns,
            };
            let q = reflect64(setup.wo, ns);
            let o = bsdf_gpu(&[setup.case(0, q)])[0];
            let err = length(std::array::from_fn::<f64, 3, _>(|k| xyz(o.s)[k] - q[k]));
            assert!(err < 1e-6, "mirror direction off by {err}");
            assert_eq!(o.w[3] as u32, BSDF_REFLECTION | BSDF_DELTA);
            assert_eq!((o.s[3], &o.w[..3]), (1.0, &setup.albedo[..]));
            assert_eq!(
                &o.aq, &[0.0; 4],
                "f and pdf of a delta lobe at any direction"
            );
            assert_eq!(o.r[3], 1.0, "mirror is delta");
        }
    }
}

/// Glass: reflection is chosen with probability F (the f64 Fresnel reference), within 5 binomial
/// standard errors over 2^16 samples, entering and leaving, below and beyond the critical angle; each
/// sample reports its lobe's probability as its pdf and weight 1; refracted directions obey Snell's law.
#[test]
fn dielectric_chooses_reflection_with_probability_fresnel() {
    const N: usize = 1 << 16;
    let ns = normals()[2];
    for entering in [true, false] {
        for cos in [1.0, 0.8, 0.5, 0.2, 0.05] {
            let ior = 1.5f32;
            let setup = Setup {
                kind: MAT_DIELECTRIC,
                albedo: [1.0; 3],
                ior,
                entering,
                wo: from_angles(ns, cos, 0.3),
                ns,
            };
            let eta = if entering {
                ior as f64
            } else {
                1.0 / ior as f64
            };
            let cos_i = dot(setup.wo, ns);
            let (f, ..) = fresnel_ref(cos_i, eta, 0.0);
            let out = samples(&setup, 11, N);
            let reflected = out
                .iter()
                .filter(|o| o.w[3] as u32 == BSDF_REFLECTION | BSDF_DELTA)
                .count() as f64;
            let se = (f * (1.0 - f) / N as f64).sqrt().max(1.0 / N as f64);
            let frac = reflected / N as f64;
            assert!(
                (frac - f).abs() <= 5.0 * se + 1e-6,
                "entering {entering} cos {cos_i}: reflected {frac} vs F = {f}"
            );
            for o in &out {
                let flags = o.w[3] as u32;
                assert_eq!(&o.w[..3], &[1.0, 1.0, 1.0], "glass weight");
                let wi = xyz(o.s);
                if flags == BSDF_REFLECTION | BSDF_DELTA {
                    assert!(
                        (o.s[3] as f64 - f).abs() < 1e-5,
                        "pdf of reflection {}",
                        o.s[3]
                    );
                    let q = reflect64(setup.wo, ns);
                    assert!(length(std::array::from_fn::<f64, 3, _>(|k| wi[k] - q[k])) < 1e-5);
                } else {
                    assert_eq!(flags, BSDF_TRANSMISSION | BSDF_DELTA);
                    assert!((o.s[3] as f64 - (1.0 - f)).abs() < 1e-5);
                    // Snell: sin_t = sin_i / eta, on the other side.
                    let cos_t = -dot(wi, ns);
                    assert!(cos_t > 0.0, "refracted to the wrong side");
                    // Sines from cross products: exact near normal incidence, unlike sqrt(1 - cos^2).
                    let sin_i = length(cross(setup.wo, ns));
                    let sin_t = length(cross(wi, ns)) / length(wi);
                    assert!(
                        (sin_t * eta - sin_i).abs() < 1e-5,
                        "Snell: {sin_t} {sin_i} {eta}"
                    );
                }
            }
        }
    }
}

/// The emitter scatters nothing: the path ends there (flags 0, zero weight and pdf).
#[test]
fn emitter_absorbs() {
    let setup = Setup {
        kind: MAT_EMITTER,
        albedo: [1.0; 3],
        ior: 1.0,
        entering: true,
        wo: [0.0, 0.0, 1.0],
        ns: [0.0, 0.0, 1.0],
    };
    let o = bsdf_gpu(&[setup.case(0, [0.0, 0.0, 1.0])])[0];
    assert_eq!((o.w, o.s[3], o.aq), ([0.0; 4], 0.0, [0.0; 4]));
    assert_eq!(o.r[3], 1.0, "no next-event estimation on an emitter");
}
