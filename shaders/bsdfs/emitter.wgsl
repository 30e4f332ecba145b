// bsdfs/emitter.wgsl: a lamp's surface.
//
// requires: bsdfs/common.wgsl
//
// The `emitter` material (a lamp's surface, and a sphere light's): emits `emission` (material_emission),
// scatters nothing: every sample is absorbed, and the integrator ends the path there (trace.wgsl).

fn emitter_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    return bsdf_absorbed();
}

fn emitter_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn emitter_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return 0.0;
}

// Black: it reflects nothing.
fn emitter_albedo(mat: Material) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn emitter_is_delta(mat: Material) -> bool {
    return true; // no lobe at all: nothing for next-event estimation to weigh
}

fn emitter_transmits(mat: Material) -> bool {
    return false;
}
