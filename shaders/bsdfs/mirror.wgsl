// bsdfs/mirror.wgsl: a perfect mirror.
//
// requires: bsdfs/common.wgsl
//
// A perfect mirror tinted by `albedo`: f = albedo delta(wi - R(wo)) / |cos theta_i|, so the weight is the
// tint. It draws no random number.

fn mirror_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    return BsdfSample(reflect_dir(-wo, sh.ns), mat.albedo, 1.0, BSDF_REFLECTION | BSDF_DELTA);
}

fn mirror_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return vec3<f32>(0.0); // a delta lobe
}

fn mirror_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return 0.0;
}

// The tint, should a mirror be the surface counted (after max_bounces delta bounces).
fn mirror_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo;
}

fn mirror_is_delta(mat: Material) -> bool {
    return true;
}

fn mirror_transmits(mat: Material) -> bool {
    return false;
}
