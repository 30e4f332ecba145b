//! The rough plastic's coat (Mitsuba 3's `roughplastic`): how much light its rough dielectric interface
//! lets through, tabulated on the host for bsdfs/coated.wgsl.
//!
//! A plastic is a diffuse base under a dielectric coat of relative index eta (coated.wgsl). Light
//! reaching the base must cross the coat twice; with a smooth coat the fraction that crosses at cosine mu
//! is 1 - F(mu, eta). A rough coat reflects the fraction R(mu) of what arrives at mu into its glossy lobe,
//! and Mitsuba's roughplastic lets the rest, t(mu) = 1 - R(mu), through to the base:
//!
//!   R(mu) = \int_{H^2} F(wi.m, eta) G1(wi, m) G1(wo, m) D(m) / (4 mu) d wo,   wo = reflect(wi, m),
//!
//! the directional albedo of the coat's microfacet reflection with the separable masking-shadowing
//! G1(wi) G1(wo) (Mitsuba's `eval_reflectance`, which integrates F G1(wo) over visible normals by
//! Gauss-Legendre quadrature). Light the base scatters back up is reflected down again by the coat's
//! inside with the cosine-weighted mean
//!
//!   Fdr_int = 2 mean_{k = 0..63} R(mu_k; 1 / eta) mu_k,   mu_k = max(1e-6, k / 63),
//!
//! Mitsuba's own 64-point sum (its definition of the quantity, kept so the materials agree), and the
//! diffuse lobe is a t(mu_i) t(mu_o) / (pi eta^2 (1 - Fdr_int)) (a Fdr_int in place of Fdr_int for the
//! nonlinear form).
//!
//! Here R is integrated over the microfacet normals m in the coordinates where D(m) cos(theta_m) is
//! uniform (u: tan^2 theta_m = alpha^2 u / (1 - u) for GGX, -alpha^2 ln(1 - u) for Beckmann; v = phi / pi
//! over the half circle, the other half by symmetry), where the integrand
//!   F(wi.m) G1(wi, m) G1(wo, m) max(0, wi.m) / (mu cos theta_m) [wo above the surface]
//! is bounded; composite Gauss-Legendre (4 nodes on 48 x 24 panels). The coat's table holds t at
//! [`COAT_NODES`] cosines mu_j = (j / (COAT_NODES - 1))^2, denser towards grazing where T changes
//! fastest; the shader interpolates it by a Catmull-Rom cubic in sqrt(mu) (coat_transmittance), within
//! 5e-4 of T at every cosine (3e-5 over most of them), where linear interpolation was 1e-3 off.
//!
//! The smooth interface's Fresnel reflectance and its diffuse reflectance Fdr (a smooth plastic's
//! `fdr_int`, integrated here by the same quadrature) live here too, so that the upload reads the tables
//! of this module and this module reads nothing of the upload.

/// Entries in a plastic's transmittance table (`GpuMaterial::coat`).
pub const COAT_NODES: usize = 16;

/// Gauss-Legendre nodes and weights on [-1, 1], 4 points (also upload.rs's Fdr quadrature).
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
];

/// erfc(x): the Chebyshev fit of Numerical Recipes in C (2nd ed., section 6.2, `erfcc`), fractional error
/// below 1.2e-7 for every x, ample for a table the shader reads in f32.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    const C: [f64; 10] = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let poly = C.iter().rev().fold(0.0, |acc, &c| c + t * acc);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Smith's Lambda of direction `w` (unit, local frame, w.z > 0) for isotropic roughness alpha, with
/// tan the tangent of w's polar angle: GGX (sqrt(1 + alpha^2 tan^2) - 1) / 2; Beckmann, with
/// a = 1 / (alpha tan), (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 (Walter et al. 2007; Heitz 2014).
fn lambda(w: [f64; 3], alpha: f64, beckmann: bool) -> f64 {
    let tan2 = (w[0] * w[0] + w[1] * w[1]) / (w[2] * w[2]);
    if tan2 == 0.0 {
        return 0.0;
    }
    if beckmann {
        let a = 1.0 / (alpha * tan2.sqrt());
        0.5 * ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - erfc(a))
    } else {
        0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
    }
}

/// G1(w, m): 1 / (1 + Lambda(w)) where w is on the side of both the surface and the microfacet.
fn g1(w: [f64; 3], m: [f64; 3], alpha: f64, beckmann: bool) -> f64 {
    let wm = w[0] * m[0] + w[1] * m[1] + w[2] * m[2];
    if wm <= 0.0 || w[2] <= 0.0 {
        return 0.0;
    }
    1.0 / (1.0 + lambda(w, alpha, beckmann))
}

/// \int F(wi.m) G1(wi, m) g(wi, m, wi.m) D(m) max(0, wi.m) / mu d omega_m: the expectation over visible
/// normals seen from cosine `mu` (Heitz 2014's D_wi, the distribution Mitsuba's quadrature samples) of
/// `g`, which gives the lobe's factor (Fresnel and the far side's G1) and is zero where the scattered
/// direction leaves the lobe. In the coordinates where D cos(theta_m) d omega_m is uniform (the module's
/// docs), composite Gauss-Legendre.
fn over_visible_normals(
    mu: f64,
    alpha: f64,
    beckmann: bool,
    g: impl Fn([f64; 3], [f64; 3], f64) -> f64,
) -> f64 {
    let wi = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let (nu, nv) = (48, 24);
    let mut sum = 0.0;
    for i in 0..nu {
        for j in 0..nv {
            for (x, wx) in GL4 {
                for (y, wy) in GL4 {
                    // u = 1 - (1 - w)^2, du = 2 (1 - w) dw: GGX's integrand grows as 1 / sqrt(1 - u)
                    // towards grazing normals (wi.m / cos(theta_m)); in w it is bounded.
                    let w = (i as f64 + 0.5 * (x + 1.0)) / nu as f64;
                    let u = 1.0 - (1.0 - w) * (1.0 - w);
                    let du_dw = 2.0 * (1.0 - w);
                    let phi = (j as f64 + 0.5 * (y + 1.0)) / nv as f64 * std::f64::consts::PI;
                    let tan2 = if beckmann {
                        -alpha * alpha * (1.0 - u).ln()
                    } else {
                        alpha * alpha * u / (1.0 - u)
                    };
                    let cos_m = 1.0 / (1.0 + tan2).sqrt();
                    let sin_m = (1.0 - cos_m * cos_m).max(0.0).sqrt();
                    let m = [sin_m * phi.cos(), sin_m * phi.sin(), cos_m];
                    let im = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2];
                    if im <= 0.0 {
                        continue;
                    }
                    let visible = g1(wi, m, alpha, beckmann) * im / (mu * cos_m);
                    // D cos(theta_m) d omega_m = du dphi / (2 pi); the half circle doubled by symmetry
                    // makes it du dv on the unit square, and a panel's Gauss-Legendre weight is
                    // (wx / 2)(1 / nu)(wy / 2)(1 / nv).
                    sum += 0.25 * wx * wy / (nu * nv) as f64 * du_dw * visible * g(wi, m, im);
                }
            }
        }
    }
    sum
}

/// R(mu): the fraction of light arriving at cosine `mu` that the rough interface of relative index `eta`
/// reflects (F G1(wo) over visible normals; Mitsuba's eval_reflectance).
pub fn rough_reflectance(mu: f64, eta: f64, alpha: f64, beckmann: bool) -> f64 {
    over_visible_normals(mu, alpha, beckmann, |wi, m, im| {
        let wo: [f64; 3] = std::array::from_fn(|k| 2.0 * im * m[k] - wi[k]);
        fresnel_dielectric(im, eta) * g1(wo, m, alpha, beckmann)
    })
}

/// T(mu): the fraction it transmits, (1 - F) G1(wt) over visible normals with wt the refracted
/// direction, below the surface (Mitsuba's eval_transmittance). Less than 1 - R(mu): light the far
/// side's masking stops is lost to both.
pub fn rough_transmittance(mu: f64, eta: f64, alpha: f64, beckmann: bool) -> f64 {
    over_visible_normals(mu, alpha, beckmann, |wi, m, im| {
        let sin2_t = (1.0 - im * im) / (eta * eta);
        if sin2_t >= 1.0 {
            return 0.0; // total internal reflection
        }
        let cos_t = (1.0 - sin2_t).sqrt();
        let wt: [f64; 3] = std::array::from_fn(|k| -wi[k] / eta + (im / eta - cos_t) * m[k]);
        if wt[2] >= 0.0 {
            return 0.0;
        }
        // The far side's G1, seen from below: wt is on the back of both the surface and the facet.
        let below = [wt[0], wt[1], -wt[2]];
        let mirrored_m = [-m[0], -m[1], m[2]];
        (1.0 - fresnel_dielectric(im, eta)) * g1(below, mirrored_m, alpha, beckmann)
    })
}

/// A rough plastic coat's table and internal reflectance: (t at mu_j = (j / 15)^2, Fdr_int), for index
/// `ior` (inside over outside) and isotropic alpha.
pub fn coat_table(ior: f64, alpha: f64, beckmann: bool) -> ([f32; COAT_NODES], f32) {
    let last = (COAT_NODES - 1) as f64;
    let table = std::array::from_fn(|j| {
        let s = j as f64 / last;
        let mu = (s * s).max(1e-6);
        rough_transmittance(mu, ior, alpha, beckmann) as f32
    });
    let fdr_int = (0..64)
        .map(|k| {
            let mu = (k as f64 / 63.0).max(1e-6);
            rough_reflectance(mu, 1.0 / ior, alpha, beckmann) * mu
        })
        .sum::<f64>()
        * 2.0
        / 64.0;
    (table, fdr_int as f32)
}

// --- Smooth interfaces -----------------------------------------------------------------------------

/// Unpolarised Fresnel reflectance of a smooth dielectric interface of relative index eta = n_t / n_i
/// at incidence cosine c, in f64 (the shader's fresnel_dielectric, same formula); 1 under total internal
/// reflection.
fn fresnel_dielectric(c: f64, eta: f64) -> f64 {
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_par = (eta * c - cos_t) / (eta * c + cos_t);
    let r_perp = (c - eta * cos_t) / (c + eta * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

/// The diffuse (cosine-weighted hemispherical) reflectance of a smooth interface of relative index eta,
/// Fdr(eta) = 2 \int_0^1 F(c, eta) c dc: what a plastic's coat reflects back of the light its base
/// scatters diffusely (eta = 1 / ior, from inside). Below the critical cosine sqrt(1 - eta^2) (eta < 1)
/// F = 1 and that part is c_crit^2 exactly; the rest by Gauss–Legendre on 64 panels in u with
/// c = c_crit + (1 - c_crit) u^2, which removes the square-root kink of cos_t at the critical angle (the
/// integrand becomes smooth in u). Accurate to about 1e-12.
pub fn fresnel_diffuse_reflectance(eta: f64) -> f64 {
    let c_crit = if eta < 1.0 {
        (1.0 - eta * eta).sqrt()
    } else {
        0.0
    };
    let panels = 64;
    let mut sum = 0.0;
    for p in 0..panels {
        let (u0, u1) = (p as f64 / panels as f64, (p + 1) as f64 / panels as f64);
        for (x, w) in GL4 {
            let u = 0.5 * (u0 + u1) + 0.5 * (u1 - u0) * x;
            let c = c_crit + (1.0 - c_crit) * u * u;
            let dc_du = 2.0 * (1.0 - c_crit) * u;
            sum += 0.5 * (u1 - u0) * w * fresnel_dielectric(c, eta) * c * dc_du;
        }
    }
    c_crit * c_crit + 2.0 * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reciprocity of hemispherical reflectance across an interface: 1 - Fdr(eta) = eta^2 (1 - Fdr(1/eta))
    /// (what makes a smooth white plastic reflect all the light), for the integral computed here.
    /// Normal incidence alone bounds Fdr from below for eta > 1: Fdr(eta) >= ((eta - 1) / (eta + 1))^2.
    #[test]
    fn fresnel_diffuse_reflectance_obeys_reciprocity() {
        for eta in [1.01, 1.33, 1.5, 2.0, 2.42, 4.0] {
            let outside = fresnel_diffuse_reflectance(eta);
            let inside = fresnel_diffuse_reflectance(1.0 / eta);
            let lhs = 1.0 - outside;
            let rhs = eta * eta * (1.0 - inside);
            assert!((lhs - rhs).abs() < 1e-9, "eta {eta}: {lhs} vs {rhs}");
            assert!(outside >= ((eta - 1.0) / (eta + 1.0)).powi(2));
            assert!(inside > outside && inside < 1.0);
        }
        assert!(fresnel_diffuse_reflectance(1.0) < 1e-15); // no interface (up to f64 rounding)
    }

    /// As alpha goes to 0 the rough interface becomes the smooth one: R(mu) -> F(mu), T(mu) -> 1 - F(mu),
    /// from outside and (below the critical angle) from inside.
    #[test]
    fn a_nearly_smooth_coat_is_fresnel() {
        for beckmann in [false, true] {
            for eta in [1.5, 1.0 / 1.5] {
                for mu in [1.0, 0.9, 0.7, 0.3] {
                    let f = fresnel_dielectric(mu, eta);
                    let r = rough_reflectance(mu, eta, 1e-3, beckmann);
                    let t = rough_transmittance(mu, eta, 1e-3, beckmann);
                    assert!((r - f).abs() < 2e-4, "{eta} {mu}: R {r} vs {f}");
                    assert!(
                        (t - (1.0 - f)).abs() < 2e-4,
                        "{eta} {mu}: T {t} vs {}",
                        1.0 - f
                    );
                }
            }
        }
    }

    /// A rough interface loses light to masking: R + T < 1, more so at grazing incidence and for
    /// rougher coats; nothing is created.
    #[test]
    fn a_rough_coat_loses_light_to_masking() {
        for beckmann in [false, true] {
            let loss = |mu: f64, alpha: f64| {
                1.0 - rough_reflectance(mu, 1.5, alpha, beckmann)
                    - rough_transmittance(mu, 1.5, alpha, beckmann)
            };
            for alpha in [0.1, 0.3, 0.6] {
                assert!(loss(1.0, alpha) >= -1e-6 && loss(0.2, alpha) > loss(1.0, alpha));
            }
            assert!(loss(0.3, 0.6) > loss(0.3, 0.1));
        }
        let (table, fdr_int) = coat_table(1.5, 0.2 * 0.2, false);
        // At normal incidence nearly the smooth 1 - F(1) = 0.96; at grazing, where the visible facets
        // face the light, still a good part (not the smooth coat's 0).
        assert!((table[COAT_NODES - 1] - 0.96).abs() < 2e-3, "{table:?}");
        assert!(table.iter().all(|&t| t > 0.3 && t < 0.97), "{table:?}");
        assert!(fdr_int > 0.5 && fdr_int < 0.7, "{fdr_int}");
    }

    /// An interface of index 1 reflects nothing; erfc against known values.
    #[test]
    fn no_interface_reflects_nothing_and_erfc_is_right() {
        assert!(rough_reflectance(0.5, 1.0, 0.3, false).abs() < 1e-12);
        for (x, want) in [
            (0.0, 1.0),
            (0.5, 0.479_500_122_2),
            (1.0, 0.157_299_207_1),
            (2.0, 0.004_677_734_981),
        ] {
            assert!((erfc(x) - want).abs() < 2e-7 * want.max(1e-3), "erfc({x})");
        }
    }
}
