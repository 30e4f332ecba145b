// bsdfs/thin_dielectric.wgsl: a thin pane of glass (Mitsuba 3's `thindielectric`).
//
// requires: bsdfs/common.wgsl
//
// Two parallel smooth interfaces of relative index `ior`, infinitely close: light leaves on the side it
// came from or passes straight through, never bent. A ray meeting the pane at cosine c reflects with the
// Fresnel reflectance R = F(c, ior) at the first interface, and what enters bounces between the two,
// leaving through the front with each even number of internal reflections and through the back with each
// odd one. Summing the geometric series (the same R at both interfaces, by symmetry):
//   R' = R + T^2 R (1 + R^2 + R^4 + ...) = R + T^2 R / (1 - R^2) = 2 R / (1 + R),   T' = 1 - R',
// with T = 1 - R (no absorption). Both lobes are deltas; choosing each with its own probability makes
// the weight 1, as for the smooth dielectric.

fn thin_dielectric_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let r = fresnel_dielectric(abs(dot(wo, sh.ns)), mat.ior);
    let reflect_p = 2.0 * r / (1.0 + r);
    var s = BsdfSample(vec3<f32>(0.0), vec3<f32>(1.0), reflect_p, BSDF_REFLECTION | BSDF_DELTA);
    if rng_next(rng) < reflect_p {
        s.wi = reflect_dir(-wo, sh.ns);
    } else {
        s.wi = -wo;
        s.pdf = 1.0 - reflect_p;
        s.flags = BSDF_TRANSMISSION | BSDF_DELTA;
    }
    return s;
}

fn thin_dielectric_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    return vec3<f32>(0.0); // delta lobes only
}

fn thin_dielectric_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    return 0.0;
}

// White: the pane scatters all the light and absorbs none.
fn thin_dielectric_albedo(mat: Material) -> vec3<f32> {
    return vec3<f32>(1.0);
}

fn thin_dielectric_is_delta(mat: Material) -> bool {
    return true;
}

// Its transmission is a delta lobe, which next-event estimation cannot sample (as the smooth dielectric).
fn thin_dielectric_transmits(mat: Material) -> bool {
    return false;
}
