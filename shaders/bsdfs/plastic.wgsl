// bsdfs/plastic.wgsl: a diffuse base under a dielectric coat.
//
// requires: bsdfs/coated.wgsl
//
// See coated.wgsl for the model (Mitsuba 3's `plastic` with `nonlinear = true`).

fn plastic_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    return coated_sample(mat, wo, sh, rng);
}

fn plastic_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return coated_eval(mat, wo, wi, sh);
}

fn plastic_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return coated_pdf(mat, wo, wi, sh);
}

fn plastic_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo; // the base colour
}

fn plastic_is_delta(mat: Material) -> bool {
    return false; // the diffuse lobe is never a delta
}

fn plastic_transmits(mat: Material) -> bool {
    return false;
}
