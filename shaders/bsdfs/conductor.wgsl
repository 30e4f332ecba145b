// bsdfs/conductor.wgsl: a metal (GGX or smooth; complex-index or Schlick Fresnel).
//
// requires: bsdfs/common.wgsl
//
// A metal: the GGX lobe with the Fresnel reflectance of a conductor, from its complex index of
// refraction eta + i k per channel (fresnel_conductor) or, with MATERIAL_SCHLICK, Schlick's form from a
// base colour f0. alpha below SMOOTH_ALPHA: a perfect mirror whose tint is F(cos_o).

// The reflectance times the tint (the material's `tint`, Mitsuba's specular_reflectance): held in
// `eta` for Schlick's form (whose f0 is in `albedo`), in `albedo` for the complex index's (whose eta and
// k fill their own fields). A textured albedo therefore tints a complex conductor and is the base colour
// of a Schlick one.
fn conductor_fresnel(mat: Material, cos_theta: f32) -> vec3<f32> {
    if (mat.flags & MATERIAL_SCHLICK) != 0u {
        return fresnel_schlick(cos_theta, mat.albedo) * mat.eta;
    }
    return fresnel_conductor(cos_theta, mat.eta, mat.k) * mat.albedo;
}

fn conductor_sample(mat: Material, wo_w: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let u = rng_next2(rng);
    let alpha = material_alpha(mat);
    let wo = to_local(fr, wo_w);
    var s = bsdf_absorbed();
    if wo.z > 0.0 {
        if microfacet_smooth(alpha) {
            s = BsdfSample(reflect_dir(-wo_w, fr.n), conductor_fresnel(mat, wo.z), 1.0,
                           BSDF_REFLECTION | BSDF_DELTA);
        } else {
            let h = microfacet_sample_visible(wo, material_microfacet(mat), u);
            let wi = reflect_dir(-wo, h);
            let r = ggx_reflection(wo, wi, material_microfacet(mat));
            if r.pdf > 0.0 {
                let weight = conductor_fresnel(mat, r.cos_oh) * (r.f * wi.z / r.pdf);
                s = BsdfSample(frame_to_world(fr, wi), weight, r.pdf, BSDF_REFLECTION);
            }
        }
    }
    return s;
}

fn conductor_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let alpha = material_alpha(mat);
    if microfacet_smooth(alpha) {
        return vec3<f32>(0.0);
    }
    let r = ggx_reflection(to_local(fr, wo), to_local(fr, wi), material_microfacet(mat));
    return conductor_fresnel(mat, r.cos_oh) * r.f;
}

fn conductor_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let alpha = material_alpha(mat);
    if microfacet_smooth(alpha) {
        return 0.0;
    }
    return ggx_reflection(to_local(fr, wo), to_local(fr, wi), material_microfacet(mat)).pdf;
}

// The reflectance at normal incidence, F(1), times the tint.
fn conductor_albedo(mat: Material) -> vec3<f32> {
    return conductor_fresnel(mat, 1.0);
}

// A smooth conductor (alpha below SMOOTH_ALPHA) is a tinted mirror.
fn conductor_is_delta(mat: Material) -> bool {
    return microfacet_smooth(material_alpha(mat));
}

fn conductor_transmits(mat: Material) -> bool {
    return false;
}
