//! The shared BSDF test adapter (after Mitsuba 3's `BSDFAdapter` and chi-square test): any material, as
//! the host uploads it (`GpuMaterial`), seen through the interface the integrator calls (bsdf_sample,
//! bsdf_eval, bsdf_pdf, bsdf_is_delta, bsdf_transmits; shaders/tests/glossy_sample.wgsl), read back from
//! the GPU. A material's tests are then a few lines:
//! * [`chi2_sampler`]: the chi-square of its sampler against its own pdf, over [`Bins`] of the sphere
//!   (each bin's expectation the shader's pdf integrated by 4 x 4 Gauss–Legendre nodes; absorbed and delta
//!   samples a cell each);
//! * [`assert_sample_eval_pdf_agree`]: every sample's weight is f cos / pdf and its pdf is bsdf_pdf(wi);
//!   f is reciprocal for reflection and obeys f_t(wo, wi) = eta^2 f_t(wi, wo) for transmission;
//! * [`assert_reciprocal_and_one_sided_at_the_horizon`]: exactly at the horizon f and the pdf are 0 both
//!   ways and a sample is absorbed;
//! * [`material_from_toml`]: the material as a scene file gives it, read and uploaded by the renderer's
//!   own code;
//! * [`assert_albedo_matches`]: the sampler's directional albedo (the mean of its weights) against an f64
//!   quadrature of the model's f cos (a furnace test against the model, not against the shader's eval).

use super::stats::{GAUSS_LEGENDRE_4, assert_fits, chi2};
use super::vec::{V3, basis, dot, from_angles, normalize, xyz};
use vkpath::gpu::testing;
use vkpath::kernel::abi::{BSDF_DELTA, GpuMaterial};

pub const KERNEL: &str = include_str!("../../shaders/tests/glossy_sample.wgsl");

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Case {
    pub mat: GpuMaterial,
    pub wo: [f32; 4],
    pub ns: [f32; 4],
    pub t: [f32; 4],
    pub q: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Out {
    pub s: [f32; 4],
    pub w: [f32; 4],
    pub at: [f32; 4],
    pub aq: [f32; 4],
    pub r: [f32; 4],
    pub rp: [f32; 4],
}

pub fn v4(v: V3, w: f32) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, w]
}

/// Runs the kernel on `cases`, in batches of 2^18 (a case is 144 bytes; a storage buffer may be limited to
/// 128 MiB).
pub fn gpu(cases: &[Case]) -> Vec<Out> {
    let mut out = Vec::with_capacity(cases.len());
    for batch in cases.chunks(1 << 18) {
        let o: Vec<Out> =
            testing::run_kernel(&testing::context(), KERNEL, batch, batch.len()).expect("kernel");
        out.extend(o);
    }
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// One material seen from one direction.
#[derive(Clone, Copy)]
pub struct Setup {
    pub mat: GpuMaterial,
    pub wo: V3,
    pub ns: V3,
    pub tangent: V3,
    pub entering: bool,
}

impl Setup {
    pub fn new(mat: GpuMaterial, cos_o: f64) -> Setup {
        let ns = normalize([0.3, -0.5, 0.81]);
        Setup {
            mat,
            wo: from_angles(ns, cos_o, 1.0),
            ns,
            tangent: basis(ns).0,
            entering: true,
        }
    }

    pub fn case(&self, seed: u32, q: V3) -> Case {
        Case {
            mat: self.mat,
            wo: v4(self.wo, self.entering as u32 as f32),
            ns: v4(self.ns, seed as f32),
            t: v4(self.tangent, 0.0),
            q: v4(q, 0.0),
        }
    }

    pub fn samples(&self, seed: u32, n: usize) -> Vec<Out> {
        gpu(&vec![self.case(seed, self.ns); n])
    }

    /// The mirror direction of wo about ns.
    pub fn mirror(&self) -> V3 {
        let c = dot(self.wo, self.ns);
        std::array::from_fn(|k| 2.0 * c * self.ns[k] - self.wo[k])
    }
}

// --- Chi-square ------------------------------------------------------------------------------------

/// Bins over the whole sphere of directions, in polar coordinates (theta, phi) about a centre c: the
/// polar coordinate is s = ln(1 + (1 - cos theta) / sigma^2) / ln(1 + 2 / sigma^2) in [0, 1], which
/// spreads the rings over a lobe of angular width about sigma round c and still covers the sphere
/// (sigma = 1: nearly uniform in cos theta). cos theta = 1 - sigma^2 (e^{s L} - 1) with
/// L = ln(1 + 2 / sigma^2), so d omega = sigma^2 L e^{s L} ds dphi.
///
/// Two other mappings, about c = ns, make the horizon a ring boundary (with an even ring count), so that
/// no bin straddles the discontinuity of a lobe's pdf there (Gauss–Legendre integrates smooth integrands
/// only): `sigma = 0`, rings uniform in theta (`Bins::polar`, for lobes that reach the horizon), and
/// `sigma < 0`, rings uniform in sqrt|cos theta| on each hemisphere, cos theta = (1 - 2s)^2 above and
/// edge - (1 + edge) (2s - 1)^2 below (`Bins::horizon`, for grazing incidence): finest next to the horizon
/// (and the edge), where a grazing lobe peaks (the integrand, pdf x d(-cos)/ds, then vanishes there).
pub struct Bins {
    pub c: V3,
    pub sigma: f64,
    /// `Bins::horizon` only: where the lower hemisphere's rings start (cos theta <= edge <= 0); the band
    /// (edge, 0) is one boundary, not binned (see `Bins::transmission`).
    pub edge: f64,
    pub rings: usize,
    pub sectors: usize,
}

impl Bins {
    pub fn polar(c: V3, rings: usize, sectors: usize) -> Bins {
        Bins {
            c,
            sigma: 0.0,
            edge: 0.0,
            rings,
            sectors,
        }
    }

    pub fn horizon(c: V3, rings: usize, sectors: usize) -> Bins {
        Bins {
            c,
            sigma: -1.0,
            edge: 0.0,
            rings,
            sectors,
        }
    }

    /// Horizon bins for a dielectric seen from wo. Refraction through a microfacet h gives
    /// wi = -wo / eta + (cos_oh / eta - cos_t) h, whose z is -cos_o / eta + (cos_oh / eta - cos_t) h.z; for
    /// eta > 1 the bracket is negative and h.z >= 0, so wi.z <= -cos_o / eta (equality through
    /// microfacets at the horizon): the transmitted density stops there, a discontinuity that the lower
    /// hemisphere's rings start at (finest next to it). For eta < 1 there is no such edge.
    pub fn transmission(c: V3, cos_o: f64, eta: f64, rings: usize, sectors: usize) -> Bins {
        Bins {
            edge: if eta > 1.0 { -cos_o / eta } else { 0.0 },
            ..Bins::horizon(c, rings, sectors)
        }
    }

    pub fn l(&self) -> f64 {
        (1.0 + 2.0 / (self.sigma * self.sigma)).ln()
    }

    /// The polar coordinate in [0, 1] of a direction whose cosine to c is `cos`.
    pub fn s_of(&self, cos: f64) -> f64 {
        if self.sigma == 0.0 {
            return cos.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        }
        if self.sigma < 0.0 {
            let c = cos.clamp(-1.0, 1.0);
            if c >= 0.0 {
                return 0.5 * (1.0 - c.sqrt());
            }
            let y = ((self.edge - c).max(0.0) / (1.0 + self.edge)).sqrt();
            return 0.5 * (1.0 + y);
        }
        let one_minus_cos = (1.0 - cos).clamp(0.0, 2.0);
        (1.0 + one_minus_cos / (self.sigma * self.sigma)).ln() / self.l()
    }

    /// cos theta at polar coordinate s, and d(-cos theta)/ds.
    pub fn cos_of(&self, s: f64) -> (f64, f64) {
        if self.sigma == 0.0 {
            let theta = s * std::f64::consts::PI;
            return (theta.cos(), std::f64::consts::PI * theta.sin());
        }
        if self.sigma < 0.0 {
            if s < 0.5 {
                let x = 1.0 - 2.0 * s;
                return (x * x, 4.0 * x);
            }
            let y = 2.0 * s - 1.0;
            let e = self.edge;
            return (e - (1.0 + e) * y * y, 4.0 * (1.0 + e) * y);
        }
        let (l, s2) = (self.l(), self.sigma * self.sigma);
        (
            (1.0 - s2 * ((s * l).exp() - 1.0)).clamp(-1.0, 1.0),
            s2 * l * (s * l).exp(),
        )
    }

    pub fn cell(&self, w: V3) -> usize {
        let (t, b) = basis(self.c);
        let s = self.s_of(dot(w, self.c));
        let phi = dot(w, b)
            .atan2(dot(w, t))
            .rem_euclid(2.0 * std::f64::consts::PI);
        let i = ((s * self.rings as f64) as usize).min(self.rings - 1);
        let j = ((phi / (2.0 * std::f64::consts::PI) * self.sectors as f64) as usize)
            .min(self.sectors - 1);
        i * self.sectors + j
    }

    /// Every cell's quadrature nodes: (direction, weight d omega), 16 per cell, in cell order.
    pub fn nodes(&self) -> Vec<(V3, f64)> {
        let ds = 1.0 / self.rings as f64;
        let dphi = 2.0 * std::f64::consts::PI / self.sectors as f64;
        let mut nodes = Vec::with_capacity(self.rings * self.sectors * 16);
        for i in 0..self.rings {
            for j in 0..self.sectors {
                for &(x, wx) in &GAUSS_LEGENDRE_4 {
                    for &(y, wy) in &GAUSS_LEGENDRE_4 {
                        let s = (i as f64 + 0.5 * (x + 1.0)) * ds;
                        let phi = (j as f64 + 0.5 * (y + 1.0)) * dphi;
                        let (cos, jac) = self.cos_of(s);
                        let w = 0.25 * wx * wy * ds * dphi * jac;
                        nodes.push((from_angles(self.c, cos, phi), w));
                    }
                }
            }
        }
        nodes
    }
}

/// The chi-square of `setup`'s sampler against its own pdf, over `bins` (plus a cell for absorbed
/// samples and one for delta samples). Returns the statistic's p-value.
pub fn chi2_sampler(what: &str, setup: &Setup, bins: &Bins, seed: u32) -> f64 {
    const N: usize = 1 << 18;
    let cells = bins.rings * bins.sectors;
    let (absorbed, delta) = (cells, cells + 1);
    let out = setup.samples(seed, N);
    let mut observed = vec![0.0; cells + 2];
    let mut p_delta = 0.0;
    for o in &out {
        let flags = o.w[3] as u32;
        let cell = if flags == 0 {
            absorbed
        } else if flags & BSDF_DELTA != 0 {
            p_delta = o.s[3] as f64; // the lobe's probability (it depends on wo only)
            delta
        } else {
            bins.cell(xyz(o.s))
        };
        observed[cell] += 1.0;
    }
    let nodes = bins.nodes();
    let queries: Vec<Case> = nodes.iter().map(|(q, _)| setup.case(0, *q)).collect();
    let pdfs = gpu(&queries);
    let mut expected = vec![0.0; cells + 2];
    for (n, ((_, weight), o)) in nodes.iter().zip(&pdfs).enumerate() {
        let pdf = o.aq[3] as f64;
        assert!(pdf.is_finite() && pdf >= 0.0, "{what}: pdf {pdf}");
        expected[n / 16] += weight * pdf;
    }
    let total: f64 = expected[..cells].iter().sum();
    assert!(
        total + p_delta <= 1.0 + 2e-3,
        "{what}: the pdf integrates to {total} (+ delta {p_delta}), more than 1"
    );
    expected[delta] = p_delta;
    expected[absorbed] = (1.0 - total - p_delta).max(0.0);
    let scaled: Vec<f64> = expected.iter().map(|p| p * N as f64).collect();
    // GLOSSY_DEBUG=1: print the absorbed cell and the worst cells (for investigating a failure).
    if std::env::var("GLOSSY_DEBUG").is_ok() {
        eprintln!(
            "absorbed: observed {} expected {}",
            observed[absorbed], scaled[absorbed]
        );
        for ring in 0..bins.rings {
            let o: f64 = observed[ring * bins.sectors..(ring + 1) * bins.sectors]
                .iter()
                .sum();
            let e: f64 = scaled[ring * bins.sectors..(ring + 1) * bins.sectors]
                .iter()
                .sum();
            eprintln!("ring {ring}: observed {o} expected {e:.1}");
        }
        let mut worst: Vec<(f64, usize)> = (0..cells)
            .map(|c| ((observed[c] - scaled[c]).powi(2) / scaled[c].max(1e-9), c))
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(x, c) in &worst[..8] {
            eprintln!(
                "cell ring {} sector {}: observed {} expected {:.1} (chi {x:.0})",
                c / bins.sectors,
                c % bins.sectors,
                observed[c],
                scaled[c]
            );
        }
    }
    let t = chi2(&observed, &scaled);
    assert_fits(
        &format!("{what} (pdf integral {total:.4}, delta {p_delta:.4})"),
        &t,
    );
    t.p_value()
}

/// Bins for a reflection lobe of GGX alpha `alpha` seen from cos_o: around the mirror direction, rings
/// about alpha wide (the reflected lobe is about 2 alpha wide); where the lobe reaches the horizon
/// (grazing incidence, or a wide lobe), polar bins about ns.
pub fn reflection_bins(setup: &Setup, alpha: f64, cos_o: f64) -> Bins {
    if cos_o < 0.2 {
        // Near the horizon the lobe is a few degrees wide in both theta and phi: rings finest at the
        // horizon, 0.7-degree sectors.
        return Bins::horizon(setup.ns, 128, 512);
    }
    if alpha > 0.15 {
        // A wide lobe reaches the horizon from any angle.
        return Bins::polar(setup.ns, 64, 64);
    }
    Bins {
        c: setup.mirror(),
        sigma: alpha.clamp(0.005, 1.0),
        edge: 0.0,
        rings: 32,
        sectors: 24,
    }
}

// --- Consistency of sample, eval and pdf ------------------------------------------------------------

/// For a spread of query directions seen from cos_o = 0.6, entering and leaving: each sample's weight
/// is f cos / pdf and its pdf is bsdf_pdf(wi); f is reciprocal for reflection (f(wo, q) = f(q, wo)) and
/// obeys f(wo, q) = eta^2 f(q, wo) for transmission, eta = n_t / n_i seen from wo.
pub fn assert_sample_eval_pdf_agree(what: &str, mat: GpuMaterial) {
    for entering in [true, false] {
        let mut setup = Setup::new(mat, 0.6);
        setup.entering = entering;
        let ior = mat.ior as f64;
        let eta = if entering { ior } else { 1.0 / ior };
        let qs: Vec<V3> = (0..4096)
            .map(|i| {
                let c = -1.0 + 2.0 * ((i * 37 % 4096) as f64 + 0.5) / 4096.0;
                from_angles(setup.ns, c, i as f64 * 0.7)
            })
            .collect();
        let cases: Vec<Case> = qs.iter().map(|&q| setup.case(11, q)).collect();
        let out = gpu(&cases);
        for (q, o) in qs.iter().zip(&out) {
            let flags = o.w[3] as u32;
            if flags != 0 && flags & BSDF_DELTA == 0 {
                let wi = xyz(o.s);
                let cos = dot(wi, setup.ns).abs();
                let pdf = o.s[3] as f64;
                let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(b.abs()).max(1e-30);
                assert!(
                    rel(pdf, o.at[3] as f64) < 1e-4,
                    "{what}: sampled pdf {pdf} vs bsdf_pdf {}",
                    o.at[3]
                );
                for c in 0..3 {
                    let want = o.at[c] as f64 * cos / pdf;
                    assert!(
                        rel(want, o.w[c] as f64) < 1e-3 || cos < 1e-4,
                        "{what}: weight {} vs f cos / pdf {want} ({o:?})",
                        o.w[c]
                    );
                }
            }
            let above = dot(*q, setup.ns) > 1e-3;
            let below = dot(*q, setup.ns) < -1e-3;
            let (f, back) = (o.aq[0] as f64, o.r[0] as f64);
            assert!(f.is_finite() && f >= 0.0, "{what}: f = {f}");
            if above {
                assert!(
                    (f - back).abs() <= 1e-4 * f.max(back) + 1e-7,
                    "{what}: reflection not reciprocal: f(wo, q) = {f}, f(q, wo) = {back}"
                );
            } else if below && o.rp[1] == 1.0 {
                // (Near the critical angle 1 - F has an infinite derivative: f32 rounding of the
                // cosines moves the tiny values there by a few percent, hence the absolute term.)
                let want = eta * eta * back;
                assert!(
                    (f - want).abs() <= 1e-3 * f.max(want) + 1e-5,
                    "{what}: f_t(wo, q) = {f} but eta^2 f_t(q, wo) = {want} (eta {eta})"
                );
            }
        }
    }
}

/// Reciprocity and sidedness exactly at the horizon, for a material with a non-delta lobe: with
/// ns = +z, wo = (0.28, 0.96, 0) lies in the tangent plane (cos 0) and wi = (-0.6, 0, 0.8) above it.
/// f(wo, wi) must equal f(wi, wo), and both are 0 (a direction along the surface neither gives nor
/// receives light; the convention of pbrt-v4 and Mitsuba 3); so is the pdf of sampling either from the
/// other, and a sample seen from the horizon is absorbed. (The diffuse BSDF once tested only wi's side:
/// albedo / pi one way, 0 the other.)
pub fn assert_reciprocal_and_one_sided_at_the_horizon(what: &str, mat: GpuMaterial) {
    let ns = [0.0, 0.0, 1.0];
    let horizon = [0.28, 0.96, 0.0];
    let above = [-0.6, 0.0, 0.8];
    let case = |wo: V3, q: V3| Case {
        mat,
        wo: v4(wo, 1.0),
        ns: v4(ns, 3.0),
        t: v4([1.0, 0.0, 0.0], 0.0),
        q: v4(q, 0.0),
    };
    let out = gpu(&[case(horizon, above), case(above, horizon)]);
    for (o, way) in out.iter().zip(["wo on the horizon", "wi on the horizon"]) {
        let (f, back) = (o.aq, o.r);
        for c in 0..3 {
            assert_eq!(
                f[c], back[c],
                "{what}, {way}: f(wo, wi) {f:?} but f(wi, wo) {back:?}"
            );
            assert_eq!(f[c], 0.0, "{what}, {way}: f = {f:?} along the surface");
        }
        assert_eq!((o.aq[3], o.rp[0]), (0.0, 0.0), "{what}, {way}: pdfs");
    }
    assert_eq!(
        out[0].w[3], 0.0,
        "{what}: a sample seen from the horizon is absorbed"
    );
}

/// The error a scene file gives for the material `spec` (an inline table) on a sphere, as text; empty
/// when it loads.
pub fn material_error(spec: &str) -> String {
    let text = format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[materials]\nm = {spec}\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
    );
    vkpath::Scene::from_toml_str(&text, None)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
}

/// The material `spec` (a scene file's inline table, e.g. `{ type = "diffuse", albedo = [0.5, 0.5, 0.5] }`)
/// as the renderer reads and uploads it.
pub fn material_from_toml(spec: &str) -> GpuMaterial {
    let text = format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[materials]\nm = {spec}\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
    );
    let scene = vkpath::Scene::from_toml_str(&text, None).unwrap_or_else(|e| panic!("{spec}: {e}"));
    vkpath::kernel::upload::gpu_material(&scene.materials[0])
}

/// f at 512 directions spread over the hemisphere above `setup.ns` (stratified in cos theta, azimuths
/// stepping by 0.37 rad) against `model(wi)` per channel, within `rel` relative (plus 1e-6 absolute, for
/// f32 rounding near zero).
pub fn assert_eval_matches(what: &str, setup: &Setup, rel: f64, model: impl Fn(V3) -> [f64; 3]) {
    let qs: Vec<V3> = (0..512)
        .map(|i| {
            let c = ((i * 29 % 512) as f64 + 0.5) / 512.0;
            from_angles(setup.ns, c, i as f64 * 0.37)
        })
        .collect();
    let out = gpu(&qs.iter().map(|&q| setup.case(0, q)).collect::<Vec<_>>());
    for (q, o) in qs.iter().zip(&out) {
        for (k, want) in model(*q).iter().enumerate() {
            let got = f64::from(o.aq[k]);
            assert!(
                (got - want).abs() <= rel * want + 1e-6,
                "{what}, cos_i {}: channel {k}: f = {got}, model {want}",
                dot(*q, setup.ns)
            );
        }
    }
}

/// The directional albedo two ways: the mean of `samples`' weights f cos / pdf per channel (the sampler's
/// estimate, with its standard error), and the integral of the model's `f(wi)` |cos theta_i| over the
/// hemispheres on `sides` of `ns` (1: the one ns points to, -1: the other), by the midpoint rule in
/// (|cos theta|, phi) over `cells` = (nc, np) cells. Asserts, per channel, that they agree within 5
/// standard errors plus `slack` (the quadrature's own error), and returns the integrals.
pub fn assert_albedo_matches(
    what: &str,
    samples: &[Out],
    ns: V3,
    sides: &[f64],
    cells: (usize, usize),
    slack: f64,
    f: impl Fn(V3) -> [f64; 3],
) -> [f64; 3] {
    let (nc, np) = cells;
    let cell = 2.0 * std::f64::consts::PI / (nc * np) as f64;
    let mut integral = [0.0f64; 3];
    for &side in sides {
        for i in 0..nc {
            let c = (i as f64 + 0.5) / nc as f64;
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let fi = f(from_angles(ns, side * c, phi));
                for k in 0..3 {
                    integral[k] += fi[k] * c * cell;
                }
            }
        }
    }
    for (k, integral) in integral.iter().enumerate() {
        let w: Vec<f64> = samples.iter().map(|o| f64::from(o.w[k])).collect();
        let mean = w.iter().sum::<f64>() / w.len() as f64;
        let var = w.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (w.len() - 1) as f64;
        let se = (var / w.len() as f64).sqrt();
        assert!(
            (mean - integral).abs() < 5.0 * se + slack,
            "{what} channel {k}: sampled albedo {mean} +- {se}, integral {integral}"
        );
    }
    integral
}
