// bsdfs/diffuse.wgsl: the Lambertian (diffuse) reflector.
//
// requires: bsdfs/common.wgsl
//
// f = albedo / pi when wo and wi both lie strictly above the surface (on ns's side), 0 otherwise: the
// condition is symmetric in wo and wi, so f is reciprocal even at the horizon (Mitsuba 3's `diffuse`
// tests both cosines likewise). Sampled cosine-weighted, pdf = cos(theta_i) / pi, so that
// f cos / pdf = albedo: the weight does not depend on the direction. Seen from below or along the
// surface (wo.ns <= 0, possible with a shading normal) it reflects nothing: the sample is absorbed (after
// drawing its two numbers) and the pdf is 0.

fn diffuse_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let wi = sample_cosine_hemisphere(sh.ns, rng_next2(rng));
    var s = BsdfSample(wi, mat.albedo, cosine_hemisphere_pdf(dot(wi, sh.ns)), BSDF_REFLECTION);
    if dot(wo, sh.ns) <= 0.0 {
        s = bsdf_absorbed();
    }
    return s;
}

fn diffuse_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    if dot(wi, sh.ns) <= 0.0 || dot(wo, sh.ns) <= 0.0 {
        return vec3<f32>(0.0);
    }
    return mat.albedo * INV_PI;
}

fn diffuse_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return select(cosine_hemisphere_pdf(dot(wi, sh.ns)), 0.0, dot(wo, sh.ns) <= 0.0);
}

fn diffuse_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo;
}

fn diffuse_is_delta(mat: Material) -> bool {
    return false;
}

fn diffuse_transmits(mat: Material) -> bool {
    return false;
}
