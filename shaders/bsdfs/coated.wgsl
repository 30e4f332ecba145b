// bsdfs/coated.wgsl: the two-lobe materials' shared implementation (plastic.wgsl and
// metallic_roughness.wgsl are its two kinds; it is not a kind itself).
//
// requires: bsdfs/common.wgsl, bsdf_kinds.wgsl
//
// Both are a GGX reflection lobe (a delta below SMOOTH_ALPHA) over a diffuse lobe; they differ in the
// specular lobe's Fresnel factor Fs and the diffuse lobe's value fd:
//
// Plastic (a diffuse base of albedo a under a smooth-interfaced dielectric coat of index eta; the model of
// Mitsuba 3's `plastic` with `nonlinear = true`, and of Weidlich & Wilkie 2007's layer without
// absorption): Fs = F(wo.h, eta), and light that enters the coat (1 - F(cos_i)), reflects diffusely off
// the base, and leaves it (1 - F(cos_o)), with the internal reflections at the coat summed as a geometric
// series, gives
//   fd = (1 - F(cos_i)) (1 - F(cos_o)) a / (pi eta^2 (1 - a Fdr_int)),
// or with MATERIAL_LINEAR (Mitsuba's `nonlinear = false`, its default) 1 - Fdr_int in place of
// 1 - a Fdr_int: linear in a, the internal reflections not tinted again at each bounce. Fdr_int is the
// cosine-weighted hemispherical average of the coat's reflectance seen from inside
// (computed once on the host, `fdr_int`) and 1 / eta^2 the compression of solid angle on leaving.
// Energy: with a = 1 and a smooth coat the diffuse albedo is exactly 1 - F(cos_o) (since
// eta^2 (1 - Fdr_int) = 1 - Fdr_ext), so the material reflects all the light at every angle.
// A rough coat (MATERIAL_ROUGH_COAT; Mitsuba 3's `roughplastic`) lets light through with its own
// transmittance T(cos), the refracted part of its microfacet lobe (less than 1 - F: light the facets
// mask is lost), in place of 1 - F(cos), and Fdr_int is its rough internal reflectance (both computed
// once on the host, src/kernel/coat.rs, which gives the integrals; T tabulated in `coat`):
//   fd = T(cos_i) T(cos_o) a / (pi eta^2 (1 - a Fdr_int)).
// The specular lobe is the coat's GGX or Beckmann reflection either way. tests/shader_glossy.rs measures
// the albedo against an f64 quadrature of this model.
//
// metallic_roughness (glTF 2.0, Appendix B): metal_brdf = specular_brdf * Schlick(base, VdotH);
// dielectric_brdf = mix(diffuse(base), specular_brdf, F_d(VdotH)) with F_d = 0.04 + 0.96 (1 - VdotH)^5
// (an ior of 1.5); material = mix(dielectric_brdf, metal_brdf, metallic). So
//   Fs = mix(F_d(VdotH), Schlick(base, VdotH), metallic),  fd = (1 - metallic) (1 - F_d(VdotH)) base / pi,
// with H the half vector of wo and wi (for the diffuse lobe as well, as the specification writes it).
//
// Sampling: the specular lobe with probability p_s (of wo only: an estimate of its share of the
// reflected light, Fs(cos_o) against the diffuse lobe's weight), else cosine-weighted; the pdf is the
// mixture p_s pdf_spec + (1 - p_s) cos_i / pi, and the weight f cos_i / pdf evaluates both lobes (one-
// sample MIS with the balance heuristic). With a smooth coat the specular sample is a delta of
// probability p_s and weight Fs(cos_o) / p_s, and eval and pdf hold only the diffuse lobe.

fn gltf_dielectric_fresnel(c: f32) -> f32 {
    let m = 1.0 - clamp(c, 0.0, 1.0);
    let m2 = m * m;
    return 0.04 + 0.96 * m2 * m2 * m;
}

// Fs at cosine c between wo and the microfacet normal.
fn coated_specular_fresnel(mat: Material, c: f32) -> vec3<f32> {
    if mat.kind == MAT_PLASTIC {
        return vec3<f32>(fresnel_dielectric(c, mat.ior));
    }
    return mix(vec3<f32>(gltf_dielectric_fresnel(c)), fresnel_schlick(c, mat.albedo), mat.metallic);
}

// A rough coat's transmittance at cosine c in [0, 1]: its table (nodes at c_j = (j / 15)^2, denser
// towards grazing, where it changes fastest) interpolated in x = 15 sqrt(c) by the Catmull-Rom cubic
// through the four nearest nodes (the end nodes repeated beyond the table), within 5e-4 of the
// function (src/kernel/coat.rs).
fn coat_transmittance(mat: Material, c: f32) -> f32 {
    let x = sqrt(clamp(c, 0.0, 1.0)) * f32(COAT_NODES - 1u);
    let j = min(u32(x), COAT_NODES - 2u);
    let u = x - f32(j);
    let p0 = material_coat(mat, max(j, 1u) - 1u);
    let p1 = material_coat(mat, j);
    let p2 = material_coat(mat, j + 1u);
    let p3 = material_coat(mat, min(j + 2u, COAT_NODES - 1u));
    return p1 + 0.5 * u * (p2 - p0 + u * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + u * (3.0 * (p1 - p2) + p3 - p0)));
}

// fd at (wo, wi), local frame, both above the surface.
fn coated_diffuse(mat: Material, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if mat.kind == MAT_PLASTIC {
        var t = 0.0;
        if (mat.flags & MATERIAL_ROUGH_COAT) != 0u {
            t = coat_transmittance(mat, wi.z) * coat_transmittance(mat, wo.z);
        } else {
            t = (1.0 - fresnel_dielectric(wi.z, mat.ior)) * (1.0 - fresnel_dielectric(wo.z, mat.ior));
        }
        let a = mat.albedo;
        // Nonlinear: each internal reflection meets the base again, a geometric series in a Fdr_int;
        // linear (Mitsuba's default): the series without the albedo, 1 / (1 - Fdr_int).
        let tint = select(a, vec3<f32>(1.0), (mat.flags & MATERIAL_LINEAR) != 0u);
        return a * (t * INV_PI / (mat.ior * mat.ior)) / (vec3<f32>(1.0) - tint * mat.fdr_int);
    }
    let h = normalize(wo + wi);
    return mat.albedo * ((1.0 - mat.metallic) * (1.0 - gltf_dielectric_fresnel(dot(wo, h))) * INV_PI);
}

// The probability of sampling the specular lobe, seen from wo (cos_o > 0).
fn coated_specular_probability(mat: Material, cos_o: f32) -> f32 {
    let fs = coated_specular_fresnel(mat, cos_o);
    var diffuse = 0.0;
    if mat.kind == MAT_PLASTIC {
        diffuse = (1.0 - fs.x) * (mat.albedo.x + mat.albedo.y + mat.albedo.z) / 3.0;
    } else {
        diffuse = (1.0 - mat.metallic) * (1.0 - gltf_dielectric_fresnel(cos_o))
                * (mat.albedo.x + mat.albedo.y + mat.albedo.z) / 3.0;
    }
    let spec = (fs.x + fs.y + fs.z) / 3.0;
    return select(1.0, spec / (spec + diffuse), spec + diffuse > 0.0);
}

struct CoatedEval {
    f: vec3<f32>,
    pdf: f32,
}

// f and pdf of the non-delta part at (wo, wi), local frame.
fn coated_at(mat: Material, wo: vec3<f32>, wi: vec3<f32>) -> CoatedEval {
    var r = CoatedEval(vec3<f32>(0.0), 0.0);
    if wo.z > 0.0 && wi.z > 0.0 {
        let p_s = coated_specular_probability(mat, wo.z);
        let alpha = material_alpha(mat);
        r.f = coated_diffuse(mat, wo, wi);
        r.pdf = (1.0 - p_s) * wi.z * INV_PI;
        if !microfacet_smooth(alpha) {
            let g = ggx_reflection(wo, wi, material_microfacet(mat));
            r.f += coated_specular_fresnel(mat, g.cos_oh) * g.f;
            r.pdf += p_s * g.pdf;
        }
    }
    return r;
}

fn coated_sample(mat: Material, wo_w: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let uc = rng_next(rng);
    let u = rng_next2(rng);
    let alpha = material_alpha(mat);
    let wo = to_local(fr, wo_w);
    var s = bsdf_absorbed();
    if wo.z > 0.0 {
        let p_s = coated_specular_probability(mat, wo.z);
        var wi = vec3<f32>(0.0);
        if uc < p_s {
            if microfacet_smooth(alpha) {
                let weight = coated_specular_fresnel(mat, wo.z) / p_s;
                s = BsdfSample(reflect_dir(-wo_w, fr.n), weight, p_s, BSDF_REFLECTION | BSDF_DELTA);
            } else {
                wi = reflect_dir(-wo, microfacet_sample_visible(wo, material_microfacet(mat), u));
            }
        } else {
            wi = sample_cosine_local(u);
        }
        if wi.z > 0.0 {
            let e = coated_at(mat, wo, wi);
            if e.pdf > 0.0 {
                s = BsdfSample(frame_to_world(fr, wi), e.f * (wi.z / e.pdf), e.pdf, BSDF_REFLECTION);
            }
        }
    }
    return s;
}

fn coated_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return coated_at(mat, to_local(fr, wo), to_local(fr, wi)).f;
}

fn coated_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return coated_at(mat, to_local(fr, wo), to_local(fr, wi)).pdf;
}
