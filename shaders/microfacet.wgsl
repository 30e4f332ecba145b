// microfacet.wgsl: the GGX (Trowbridge–Reitz) microfacet distribution and the Fresnel terms of the glossy
// materials (bsdfs/): the normal distribution D, Smith's masking-shadowing G1 and G2, sampling by the
// distribution of visible normals, and Fresnel for conductors (complex index) and Schlick's form.
//
// requires: sampling.wgsl
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
