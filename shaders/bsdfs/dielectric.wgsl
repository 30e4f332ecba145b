// bsdfs/dielectric.wgsl: smooth glass.
//
// requires: bsdfs/common.wgsl
//
// Reflection with probability F (Fresnel) and refraction with 1 - F: both lobes are deltas, and choosing
// each with its own weight's probability makes the weight 1 (F / F, (1 - F) / (1 - F)). The eta^2
// radiance scaling of refraction is not applied: it cancels along any path that enters and leaves the
// same medium, and every path here ends outside (camera and lights are in the outer medium).

fn dielectric_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    // eta = n_t / n_i: entering goes from the outside (index 1) into the material.
    let eta = select(1.0 / mat.ior, mat.ior, sh.entering);
    let f = fresnel_dielectric(dot(wo, sh.ns), eta);
    var s = BsdfSample(vec3<f32>(0.0), vec3<f32>(1.0), f, BSDF_REFLECTION | BSDF_DELTA);
    if rng_next(rng) < f {
        s.wi = reflect_dir(-wo, sh.ns);
    } else {
        s.wi = refract_dir(-wo, sh.ns, eta);
        s.pdf = 1.0 - f;
        s.flags = BSDF_TRANSMISSION | BSDF_DELTA;
    }
    return s;
}

fn dielectric_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return vec3<f32>(0.0); // delta lobes only
}

fn dielectric_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return 0.0;
}

// White: a dielectric scatters all the light it does not absorb, and absorbs none.
fn dielectric_albedo(mat: Material) -> vec3<f32> {
    return vec3<f32>(1.0);
}

fn dielectric_is_delta(mat: Material) -> bool {
    return true;
}

// Its transmission is a delta lobe, which next-event estimation cannot sample.
fn dielectric_transmits(mat: Material) -> bool {
    return false;
}
