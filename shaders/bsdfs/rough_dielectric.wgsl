// bsdfs/rough_dielectric.wgsl: rough glass (Walter et al. 2007).
//
// requires: bsdfs/common.wgsl, bsdfs/dielectric.wgsl
//
// Walter et al. 2007: microfacets of the GGX distribution, each a smooth dielectric interface. Sampling
// draws h ~ D_wo, then reflects with probability F(wo.h) and refracts otherwise, so that F cancels:
//   reflection:   f = F D G2 / (4 cos_o cos_i),            pdf = D_wo(h) F / (4 wo.h)
//   transmission: f = (1 - F) D G2 |wi.h| |wo.h| / (cos_o |cos_i| (wi.h + wo.h / eta)^2),
//                 pdf = D_wo(h) (1 - F) |wi.h| / (wi.h + wo.h / eta)^2
// with eta = n_t / n_i (wi's side over wo's) and, for transmission, the generalised half vector
// h = -(wo + eta wi) / |wo + eta wi| (Walter eqs. 16, 17, 21; the last fraction is the Jacobian
// d omega_h / d omega_i). Both weights are G2 / G1(wo). As for smooth glass, transmission is not scaled
// by 1 / eta^2 (pbrt-v4's radiance mode does): the factor cancels on every path that leaves the medium it
// entered, so f_t(wo, wi) = eta^2 f_t(wi, wo) here rather than the symmetric form.
// An index-matched surface (eta = 1) has no interface and a roughness below SMOOTH_ALPHA none to speak
// of: both are the smooth dielectric (the host uploads those as MAT_DIELECTRIC; this is a second guard).

fn rough_dielectric_eta(mat: Material, entering: bool) -> f32 {
    return select(1.0 / mat.ior, mat.ior, entering);
}

fn rough_dielectric_is_smooth(mat: Material) -> bool {
    return microfacet_smooth(material_alpha(mat)) || mat.ior == 1.0;
}

fn rough_dielectric_sample(mat: Material, wo_w: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    var s = bsdf_absorbed();
    if rough_dielectric_is_smooth(mat) {
        s = dielectric_sample(mat, wo_w, sh, rng);
        (*rng).dim += 2u; // three numbers, as the rough branch draws
    } else {
        let u = rng_next2(rng);
        let uc = rng_next(rng);
        let alpha = material_alpha(mat);
        let eta = rough_dielectric_eta(mat, sh.entering);
        let wo = to_local(fr, wo_w);
        if wo.z > 0.0 {
            let h = microfacet_sample_visible(wo, material_microfacet(mat), u);
            let cos_oh = dot(wo, h);
            let f = fresnel_dielectric(cos_oh, eta);
            var wi = vec3<f32>(0.0);
            var flags = 0u;
            var pdf = 0.0;
            if uc < f {
                wi = reflect_dir(-wo, h);
                if wi.z > 0.0 {
                    flags = BSDF_REFLECTION;
                    pdf = microfacet_visible_pdf(wo, h, material_microfacet(mat)) * f / (4.0 * cos_oh);
                }
            } else {
                wi = refract_dir(-wo, h, eta);
                let cos_ih = dot(wi, h);
                let denom = cos_ih + cos_oh / eta;
                if wi.z < 0.0 && cos_ih < 0.0 && denom != 0.0 {
                    flags = BSDF_TRANSMISSION;
                    pdf = microfacet_visible_pdf(wo, h, material_microfacet(mat)) * (1.0 - f) * abs(cos_ih) / (denom * denom);
                }
            }
            if flags != 0u && pdf > 0.0 {
                let weight = microfacet_g2(wo, wi, material_microfacet(mat)) / microfacet_g1(wo, material_microfacet(mat));
                s = BsdfSample(frame_to_world(fr, wi), vec3<f32>(weight), pdf, flags);
            }
        }
    }
    return s;
}

// f and pdf of the rough dielectric at (wo, wi), local frame, wo above the surface.
struct RoughDielectricEval {
    f: f32,
    pdf: f32,
}

fn rough_dielectric_at(mat: Material, wo: vec3<f32>, wi: vec3<f32>, entering: bool) -> RoughDielectricEval {
    var r = RoughDielectricEval(0.0, 0.0);
    let alpha = material_alpha(mat);
    let eta = rough_dielectric_eta(mat, entering);
    if wo.z > 0.0 && wi.z > 0.0 {
        let g = ggx_reflection(wo, wi, material_microfacet(mat));
        let f = fresnel_dielectric(g.cos_oh, eta);
        r = RoughDielectricEval(f * g.f, f * g.pdf);
    } else if wo.z > 0.0 && wi.z < 0.0 {
        // Only microfacets that face wo and that wi crosses from below.
        let rf = refraction_half_vector(wo, wi, eta);
        if rf.valid {
            let t = 1.0 - fresnel_dielectric(rf.cos_oh, eta);
            let d = microfacet_d(rf.h, material_microfacet(mat));
            let jac = abs(rf.cos_ih) / (rf.denom * rf.denom);
            r.f = t * d * microfacet_g2(wo, wi, material_microfacet(mat)) * jac * rf.cos_oh / (wo.z * abs(wi.z));
            r.pdf = t * microfacet_visible_pdf(wo, rf.h, material_microfacet(mat)) * jac;
        }
    }
    return r;
}

fn rough_dielectric_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    if rough_dielectric_is_smooth(mat) {
        return vec3<f32>(0.0);
    }
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return vec3<f32>(rough_dielectric_at(mat, to_local(fr, wo), to_local(fr, wi), sh.entering).f);
}

fn rough_dielectric_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    if rough_dielectric_is_smooth(mat) {
        return 0.0;
    }
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return rough_dielectric_at(mat, to_local(fr, wo), to_local(fr, wi), sh.entering).pdf;
}

fn rough_dielectric_albedo(mat: Material) -> vec3<f32> {
    return vec3<f32>(1.0); // as smooth glass
}

fn rough_dielectric_is_delta(mat: Material) -> bool {
    return rough_dielectric_is_smooth(mat);
}

fn rough_dielectric_transmits(mat: Material) -> bool {
    return !rough_dielectric_is_smooth(mat);
}
