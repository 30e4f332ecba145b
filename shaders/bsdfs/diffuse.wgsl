// bsdfs/diffuse.wgsl: the Lambertian (diffuse) reflector.
//
// requires: bsdfs/common.wgsl
//
// f = albedo / pi when wo and wi both lie strictly above the surface (on ns's side), 0 otherwise: the
// condition is symmetric in wo and wi, so f is reciprocal even at the horizon (Mitsuba 3's `diffuse`
// tests both cosines likewise). Sampled cosine-weighted, pdf = cos(theta_i) / pi, so that
// f cos / pdf = albedo: the weight does not depend on the direction. Seen from below or along the
// surface (wo.ns <= 0, possible with a shading normal) it reflects nothing: the sample is absorbed (after
// drawing its two numbers) and the pdf is 0. The side of wo is tested through wo_above (common.wgsl),
// and as selects rather than branches: this function is the inner loop of every diffuse scene.

fn diffuse_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let wi = sample_cosine_hemisphere(sh.ns, rng_next2(rng));
    let above = wo_above(wo, sh);
    let pdf = select(0.0, cosine_hemisphere_pdf(dot(wi, sh.ns)), above);
    let zero = vec3<f32>(0.0);
    return BsdfSample(select(zero, wi, above), select(zero, mat.albedo, above), pdf,
                      select(0u, BSDF_REFLECTION, above));
}

fn diffuse_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    let above = dot(wi, sh.ns) > 0.0 && wo_above(wo, sh);
    return select(vec3<f32>(0.0), mat.albedo * INV_PI, above);
}

fn diffuse_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return select(0.0, cosine_hemisphere_pdf(dot(wi, sh.ns)), wo_above(wo, sh));
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
