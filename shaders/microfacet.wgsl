// microfacet.wgsl: the microfacet distributions of the glossy materials (bsdfs/), GGX (Trowbridge–Reitz)
// and Beckmann, and their Fresnel terms: the normal distribution D, Smith's masking-shadowing G1 and G2,
// sampling by the distribution of visible normals, and Fresnel for conductors (complex index) and
// Schlick's form. The materials call the microfacet_* functions, which pick the distribution a
// material's Microfacet names (Beckmann's code only in kernels whose scene has it: HAS_BECKMANN).
//
// requires: sampling.wgsl, features.wgsl
//
// Everything here works in the local shading frame: z is the shading normal, x the tangent along which
// the roughness is alpha_x, y the bitangent (alpha_y). A user's `roughness` r maps to alpha = r^2 (the
// contract's, and glTF's and Disney's perceptual roughness), so that equal steps of r look like equal
// steps of blur.
//
// References: Trowbridge & Reitz 1975; Walter, Marschner, Li & Torrance, "Microfacet Models for Refraction
// through Rough Surfaces", EGSR 2007; Heitz, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs", JCGT 3(2), 2014; Heitz, "Sampling the GGX Distribution of Visible Normals",
// JCGT 7(4), 2018; pbrt-v4 §9.6 (Pharr, Jakob & Humphreys).

// Below this alpha (on both axes) a surface is treated as smooth: its lobe is a delta (the smooth mirror
// or glass). D's peak 1 / (pi alpha^2) passes 3e5 there and the lobe is narrower than 0.1 degree, so the
// delta is indistinguishable, and f32's range is kept clear of D's overflow (pbrt-v4 uses the same
// threshold). Mirrored in src/kernel/abi.rs (SMOOTH_ALPHA).
const SMOOTH_ALPHA: f32 = 1e-3;

fn microfacet_smooth(alpha: vec2<f32>) -> bool {
    return max(alpha.x, alpha.y) < SMOOTH_ALPHA;
}

// The GGX normal distribution, anisotropic: for a microfacet normal h (unit, local frame),
// D(h) = 1 / (pi ax ay ((hx/ax)^2 + (hy/ay)^2 + hz^2)^2) on the upper hemisphere, 0 below. It is
// normalised so that the projected microfacet area is the macro surface's: the integral of D(h) hz over
// the hemisphere is 1 (that is what ggx_sample_visible's pdf relies on, and what the tests check).
fn ggx_d(h: vec3<f32>, alpha: vec2<f32>) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let s = vec3<f32>(h.x / alpha.x, h.y / alpha.y, h.z);
    let q = dot(s, s);
    return 1.0 / (PI * alpha.x * alpha.y * q * q);
}

// Smith's auxiliary function for GGX, Lambda(w) = (sqrt(1 + alpha(w)^2 tan^2 theta) - 1) / 2, where
// a = alpha(w)^2 tan^2 theta = (ax^2 wx^2 + ay^2 wy^2) / wz^2 (Heitz 2014, eq. 86). Evaluated as
// a / (2 (1 + sqrt(1 + a))), the same number without the cancellation of sqrt(1 + a) - 1 when a is small
// (a nearly smooth surface seen from above); a is capped at 1e30 so that a nearly grazing w (wz^2 a
// denormal) gives a huge Lambda rather than Inf / Inf.
fn ggx_lambda(w: vec3<f32>, alpha: vec2<f32>) -> f32 {
    let z2 = w.z * w.z;
    if z2 == 0.0 {
        return 3.4e38; // grazing: everything is masked (G1 = 0), without an Inf to multiply
    }
    let a = min((alpha.x * alpha.x * w.x * w.x + alpha.y * alpha.y * w.y * w.y) / z2, 1e30);
    return 0.5 * a / (1.0 + sqrt(1.0 + a));
}

// Smith masking: the fraction of microfacets with normal h that direction w sees unblocked (for a w on the
// side of the macro surface h faces), G1(w) = 1 / (1 + Lambda(w)).
fn ggx_g1(w: vec3<f32>, alpha: vec2<f32>) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(w, alpha));
}

// Height-correlated masking-shadowing (Heitz 2014, eq. 99): G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
// Used for reflection and transmission alike (Lambda is even in w.z).
fn ggx_g2(wo: vec3<f32>, wi: vec3<f32>, alpha: vec2<f32>) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

// The distribution of normals visible from wo (wo.z > 0): D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z,
// a density over solid angle of h that integrates to 1 (Heitz 2014, eq. 38).
fn ggx_visible_pdf(wo: vec3<f32>, h: vec3<f32>, alpha: vec2<f32>) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    return ggx_g1(wo, alpha) * max(0.0, dot(wo, h)) * ggx_d(h, alpha) / wo.z;
}

// A microfacet normal drawn from D_wo (Heitz 2018, listing 1): stretch wo into the configuration where the
// roughness is 1, sample the visible half of the unit disk's projection (a uniform disk point, its y
// squeezed onto the half seen from wo), lift it onto the hemisphere, and unstretch. wo.z > 0.
fn ggx_sample_visible(wo: vec3<f32>, alpha: vec2<f32>, u: vec2<f32>) -> vec3<f32> {
    let vh = normalize(vec3<f32>(alpha.x * wo.x, alpha.y * wo.y, wo.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if len2 > 0.0 {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) * inverseSqrt(len2);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3<f32>(alpha.x * nh.x, alpha.y * nh.y, max(1e-6, nh.z)));
}

// --- Beckmann ---------------------------------------------------------------------------------------
// Beckmann & Spizzichino 1963, anisotropic as in Walter et al. 2007 and Heitz 2014 (§5.2): the slopes of
// the microfacets are Gaussian, D(h) = exp(-((hx/ax)^2 + (hy/ay)^2) / hz^2) / (pi ax ay hz^4), normalised
// as GGX's (the integral of D(h) hz is 1). Mitsuba 3's default distribution.

// (erf_approx and erfinv_approx: sampling.wgsl.)

const INV_SQRT_PI: f32 = 0.56418958354775628695;

fn beckmann_d(h: vec3<f32>, alpha: vec2<f32>) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let c2 = h.z * h.z;
    let t = (h.x * h.x / (alpha.x * alpha.x) + h.y * h.y / (alpha.y * alpha.y)) / c2;
    return exp(-t) / (PI * alpha.x * alpha.y * c2 * c2);
}

// Smith's Lambda for Beckmann (Heitz 2014, eq. 80): with a = 1 / (alpha(w) tan theta) =
// |wz| / sqrt(ax^2 wx^2 + ay^2 wy^2), Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)), written as
// (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 so that erf's cancellation near 1 is avoided; it falls below
// 1e-7 past a = 3.5 (0 there, and at normal incidence).
fn beckmann_lambda(w: vec3<f32>, alpha: vec2<f32>) -> f32 {
    let s = sqrt(alpha.x * alpha.x * w.x * w.x + alpha.y * alpha.y * w.y * w.y);
    if w.z == 0.0 {
        return 3.4e38; // grazing: everything is masked (G1 = 0)
    }
    let a = abs(w.z) / s;
    if !(a < 3.5) {
        return 0.0; // (also s = 0: a is +inf)
    }
    return max(0.0, 0.5 * (exp(-a * a) * INV_SQRT_PI / a - erfc_nonneg(a)));
}

// A visible slope of the isotropic, unit-roughness Beckmann distribution seen from a direction in the
// xz-plane at cosine cos_t (> 0) from the normal: the microfacet normal is normalize(-sx, -sy, 1). The
// slopes visible from that direction are distributed as D's slopes weighted by the projected area
// max(0, cos_t - sx sin_t) (Heitz & d'Eon, "Importance Sampling Microfacet-Based BSDFs using the
// Distribution of Visible Normals", EGSR 2014). sy is independent of sx: a standard Gaussian of variance
// 1/2, erfinv(2 u.y - 1). sx has the marginal CDF, in b = erf(sx) on [-1, erf(cot)],
//   C(b) = (1 + b + tan_t exp(-erfinv(b)^2) / sqrt(pi)) / (1 + erf(cot) + tan_t exp(-cot^2) / sqrt(pi)),
// inverted at u.x by Newton's method safeguarded by bisection, from Jakob's fitted initial guess
// ("An Improved Visible Normal Sampling Routine for the Beckmann Distribution", 2014).
fn beckmann_sample_slope(cos_t: f32, u: vec2<f32>) -> vec2<f32> {
    if cos_t > 0.9999 {
        // Seen from straight above, every slope is visible alike: a 2D Gaussian by Box-Muller.
        let r = sqrt(-log(max(1.0 - u.x, 1e-30)));
        let phi = TWO_PI * u.y;
        return vec2<f32>(r * cos(phi), r * sin(phi));
    }
    let sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    let tan_t = sin_t / cos_t;
    let cot_t = cos_t / sin_t;
    var lo = -1.0;
    var hi = erf_approx(cot_t);
    let goal = max(u.x, 1e-6);
    let theta = acos(cos_t);
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    var b = hi - (1.0 + hi) * pow(1.0 - goal, fit);
    let norm = 1.0 / (1.0 + hi + INV_SQRT_PI * tan_t * exp(-cot_t * cot_t));
    for (var k = 0; k < 10; k++) {
        if !(b >= lo && b <= hi) {
            b = 0.5 * (lo + hi);
        }
        let x = erfinv_approx(b);
        let value = norm * (1.0 + b + INV_SQRT_PI * tan_t * exp(-x * x)) - goal;
        if abs(value) < 1e-5 {
            break;
        }
        if value > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        b -= value / (norm * (1.0 - x * tan_t));
    }
    return vec2<f32>(erfinv_approx(b), erfinv_approx(2.0 * max(u.y, 1e-6) - 1.0));
}

// A microfacet normal drawn from Beckmann's D_wo (wo.z > 0): stretch wo to unit roughness, sample a
// visible slope in the frame where wo lies in the xz-plane, turn it back by wo's azimuth, unstretch
// (slopes scale by alpha), and make the normal of the slope.
fn beckmann_sample_visible(wo: vec3<f32>, alpha: vec2<f32>, u: vec2<f32>) -> vec3<f32> {
    let ws = normalize(vec3<f32>(alpha.x * wo.x, alpha.y * wo.y, wo.z));
    let slope = beckmann_sample_slope(ws.z, u);
    let len2 = ws.x * ws.x + ws.y * ws.y;
    var c = 1.0;
    var s = 0.0;
    if len2 > 0.0 {
        let inv = inverseSqrt(len2);
        c = ws.x * inv;
        s = ws.y * inv;
    }
    let sx = alpha.x * (c * slope.x - s * slope.y);
    let sy = alpha.y * (s * slope.x + c * slope.y);
    return normalize(vec3<f32>(-sx, -sy, 1.0));
}

// --- The distribution a material names -------------------------------------------------------------

struct Microfacet {
    alpha: vec2<f32>,
    beckmann: bool,
}

fn microfacet_d(h: vec3<f32>, m: Microfacet) -> f32 {
    if HAS_BECKMANN {
        if m.beckmann {
            return beckmann_d(h, m.alpha);
        }
    }
    return ggx_d(h, m.alpha);
}

fn microfacet_lambda(w: vec3<f32>, m: Microfacet) -> f32 {
    if HAS_BECKMANN {
        if m.beckmann {
            return beckmann_lambda(w, m.alpha);
        }
    }
    return ggx_lambda(w, m.alpha);
}

// G1 = 1 / (1 + Lambda(w)); height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014, eq. 99)
// for either distribution.
fn microfacet_g1(w: vec3<f32>, m: Microfacet) -> f32 {
    return 1.0 / (1.0 + microfacet_lambda(w, m));
}

fn microfacet_g2(wo: vec3<f32>, wi: vec3<f32>, m: Microfacet) -> f32 {
    return 1.0 / (1.0 + microfacet_lambda(wo, m) + microfacet_lambda(wi, m));
}

// D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z (Heitz 2014, eq. 38), for either distribution.
fn microfacet_visible_pdf(wo: vec3<f32>, h: vec3<f32>, m: Microfacet) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    return microfacet_g1(wo, m) * max(0.0, dot(wo, h)) * microfacet_d(h, m) / wo.z;
}

fn microfacet_sample_visible(wo: vec3<f32>, m: Microfacet, u: vec2<f32>) -> vec3<f32> {
    if HAS_BECKMANN {
        if m.beckmann {
            return beckmann_sample_visible(wo, m.alpha, u);
        }
    }
    return ggx_sample_visible(wo, m.alpha, u);
}

// --- Fresnel ---------------------------------------------------------------------------------------

// Fresnel reflectance of a conductor of complex relative index eta + i k (per RGB channel) for
// unpolarised light at incidence cosine c in [0, 1]. With s2 = 1 - c^2 and
// a^2 + b^2 = sqrt((eta^2 - k^2 - s2)^2 + 4 eta^2 k^2), a^2 = (a^2 + b^2 + eta^2 - k^2 - s2) / 2:
//   R_s = (a^2 + b^2 - 2 a c + c^2) / (a^2 + b^2 + 2 a c + c^2)
//   R_p = R_s (c^2 (a^2 + b^2) - 2 a c s2 + s2^2) / (c^2 (a^2 + b^2) + 2 a c s2 + s2^2)
// and F = (R_s + R_p) / 2 (Born & Wolf, "Principles of Optics", §14.2; the real-arithmetic form of the
// complex Fresnel equations). k = 0 gives a dielectric's reflectance for eta > 1.
fn fresnel_conductor(c_in: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let c = clamp(c_in, 0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - vec3<f32>(s2);
    let a2b2 = sqrt(t0 * t0 + 4.0 * eta * eta * k * k);
    let a = sqrt(max(vec3<f32>(0.0), 0.5 * (a2b2 + t0)));
    let t1 = a2b2 + vec3<f32>(c2);
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / max(t1 + t2, vec3<f32>(1e-30));
    let t3 = c2 * a2b2 + vec3<f32>(s2 * s2);
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / max(t3 + t4, vec3<f32>(1e-30));
    return clamp(0.5 * (rp + rs), vec3<f32>(0.0), vec3<f32>(1.0));
}

// Schlick's approximation from the reflectance at normal incidence f0:
// F = f0 + (1 - f0) (1 - c)^5 (Schlick, "An Inexpensive BRDF Model for Physically-based Rendering", 1994).
fn fresnel_schlick(c_in: f32, f0: vec3<f32>) -> vec3<f32> {
    let m = 1.0 - clamp(c_in, 0.0, 1.0);
    let m2 = m * m;
    return f0 + (vec3<f32>(1.0) - f0) * (m2 * m2 * m);
}
