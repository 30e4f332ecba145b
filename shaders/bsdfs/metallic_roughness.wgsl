// bsdfs/metallic_roughness.wgsl: glTF 2.0's metallic-roughness material.
//
// requires: bsdfs/coated.wgsl
//
// See coated.wgsl for the model (glTF 2.0, Appendix B).

fn metallic_roughness_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    return coated_sample(mat, wo, sh, rng);
}

fn metallic_roughness_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return coated_eval(mat, wo, wi, sh);
}

fn metallic_roughness_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return coated_pdf(mat, wo, wi, sh);
}

fn metallic_roughness_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo; // the base colour
}

fn metallic_roughness_is_delta(mat: Material) -> bool {
    return false; // the diffuse lobe is never a delta
}

fn metallic_roughness_transmits(mat: Material) -> bool {
    return false;
}
