// rough_diffuse.wgsl: a rough diffuse reflector (Oren & Nayar 1994).
//
// requires: bsdfs/common.wgsl
//
// The surface is made of V-shaped Lambertian microfacets whose slopes are Gaussian; seen and lit from
// near the same direction it looks flatter and brighter than a Lambertian one (the Moon, clay, cloth).
// This is Oren & Nayar's "qualitative" model ("Generalization of Lambert's reflectance model",
// SIGGRAPH 1994, eq. 30; pbrt-v3's OrenNayar; Mitsuba 3's `roughdiffuse` with use_fast_approx = true):
//   f(wo, wi) = albedo / pi (A + B max(0, cos(phi_i - phi_o)) sin(a) tan(b)),
//   A = 1 - sigma^2 / (2 (sigma^2 + 0.33)),  B = 0.45 sigma^2 / (sigma^2 + 0.09),
//   a = max(theta_i, theta_o),  b = min(theta_i, theta_o),
// where sigma is the standard deviation of the facets' slope angle (radians). Without trigonometry:
// with cos_i, cos_o the cosines and sin_i, sin_o the sines, cos(phi_i - phi_o) sin_i sin_o =
// wi.wo - cos_i cos_o, and sin(a) tan(b) = sin_i sin_o / max(cos_i, cos_o), so the angular term is
// max(0, wi.wo - cos_i cos_o) / max(cos_i, cos_o). f is symmetric in wo and wi (reciprocal), and 0
// unless both lie above the surface (as `diffuse`).
//
// Parameters (src/materials/rough_diffuse/mod.rs; RoughDiffuseParams is generated from it): albedo, and
// the roughness r, which gives alpha = r^2, Mitsuba's `alpha`, the RMS slope of the microgeometry, and
// sigma = alpha / sqrt(2) (as Mitsuba converts it). r = 0 is Lambert exactly (A = 1, B = 0). A textured
// roughness is r x texel, squared here.
//
// Sampled cosine-weighted (pdf = cos_i / pi, two numbers, as `diffuse`): the weight f cos_i / pdf =
// albedo (A + B ...) is bounded by albedo (A + B), at most 1.45 albedo, so the cosine pdf suits it.

fn rough_diffuse_f(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> vec3<f32> {
    let cos_i = dot(wi, ns);
    let cos_o = dot(wo, ns);
    if cos_i <= 0.0 || cos_o <= 0.0 {
        return vec3<f32>(0.0);
    }
    let p = rough_diffuse_params(mat);
    let alpha = p.roughness * p.roughness;
    let sigma2 = 0.5 * alpha * alpha;
    let a = 1.0 - sigma2 / (2.0 * (sigma2 + 0.33));
    let b = 0.45 * sigma2 / (sigma2 + 0.09);
    let angular = max(0.0, dot(wi, wo) - cos_i * cos_o) / max(cos_i, cos_o);
    return p.albedo * (INV_PI * (a + b * angular));
}

fn rough_diffuse_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let wi = sample_cosine_hemisphere(sh.ns, rng_next2(rng));
    let pdf = cosine_hemisphere_pdf(dot(wi, sh.ns));
    var s = bsdf_absorbed();
    if pdf > 0.0 && dot(wo, sh.ns) > 0.0 {
        s = BsdfSample(wi, rough_diffuse_f(mat, wo, wi, sh.ns) * (dot(wi, sh.ns) / pdf), pdf, BSDF_REFLECTION);
    }
    return s;
}

fn rough_diffuse_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return rough_diffuse_f(mat, wo, wi, sh.ns);
}

fn rough_diffuse_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return select(cosine_hemisphere_pdf(dot(wi, sh.ns)), 0.0, dot(wo, sh.ns) <= 0.0);
}

fn rough_diffuse_albedo(mat: Material) -> vec3<f32> {
    return rough_diffuse_params(mat).albedo;
}

fn rough_diffuse_is_delta(mat: Material) -> bool {
    return false;
}

fn rough_diffuse_transmits(mat: Material) -> bool {
    return false;
}
