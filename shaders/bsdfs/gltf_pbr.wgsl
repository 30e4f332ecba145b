// bsdfs/gltf_pbr.wgsl: glTF 2.0's metallic-roughness material with the Khronos PBR extensions
// KHR_materials_ior, _specular, _transmission, _volume, _clearcoat and _sheen (a material without
// any of them is uploaded as the plainer `metallic_roughness`, which this reduces to).
//
// requires: bsdfs/common.wgsl, bsdfs/coated.wgsl
//
// Fields (GpuMaterial, uploaded by src/kernel/upload.rs): albedo = baseColor b, metallic = m, alpha_x =
// alpha_y = roughness^2 = a, ior = the ior, eta = specularColor c_s, fdr_int = specular s, k = sheenColor
// c_sh; coat[0] = transmission t, coat[1] = clearcoat w_c, coat[2] = clearcoatRoughness^2 a_c, coat[3] =
// the sheen's alpha (sheenRoughness, at least 0.07), coat[4..7] = the volume's absorption coefficient
// sigma_a = -ln(attenuationColor) / attenuationDistance (per scene unit; MATERIAL_VOLUME), coat[8..16] =
// the sheen lobe's directional albedo E at mu_j = (j / 7)^3 (computed on the host, src/kernel/sheen.rs).
//
// The model, in the specification's words (glTF 2.0 Appendix B and each extension's "Implementation"):
//   fr(c)       = f0 + (1 - f0) (1 - c)^5,  f0 = min(((ior - 1) / (ior + 1))^2 c_s, 1)   (KHR_materials_ior, _specular)
//   dielectric  = s fr(VdotH) specular_brdf(a) + (1 - s max(fr(VdotH))) mix(b / pi, b specular_btdf(a), t)
//                                                                      (fresnel_mix; KHR_materials_transmission)
//   metal       = Schlick(b, VdotH) specular_brdf(a)
//   base        = mix(dielectric, metal, m)
//   sheened     = c_sh D_charlie Vis_charlie + base min(1 - max(c_sh) E(NdotV), 1 - max(c_sh) E(NdotL))
//                                                                      (KHR_materials_sheen, albedo scaling)
//   f           = (1 - w_c Fc(NdotV)) sheened + w_c Fc(NdotV) specular_brdf(a_c),  Fc = 0.04 + 0.96 (1 - c)^5
//                                                                      (KHR_materials_clearcoat, fresnel_coat)
// specular_brdf is GGX's D G2 / (4 |NdotL| |NdotV|) (Smith height-correlated G2, the specification's V).
// specular_btdf: without KHR_materials_volume the surface is thin (two interfaces back to back): the
// transmitted light goes on along the line of sight, blurred by the roughness, the reflection lobe
// mirrored through the surface (H_T = normalize(V + L - 2 (N.L) N), KHR_materials_transmission). With a
// volume (thicknessFactor > 0) the surface bounds a medium of index ior: the BTDF of Walter et al. 2007
// (as bsdfs/rough_dielectric.wgsl, without pbrt's 1 / eta^2, for the reason given there), and the path
// pays exp(-sigma_a d) over each distance d it travels inside (trace.wgsl, path_step). Inside such a
// medium fr is evaluated at the cosine on the outer side of the interface (Schlick's approximation holds
// there), which gives total internal reflection fr = 1; light that total internal reflection would keep
// in is lost to the transmission lobe's share (1 - s max(fr)) of 0 but kept by the reflection lobe only
// as far as s fr reflects it (s = 1: all of it). Sheen and clearcoat lie on the outside: a path meeting
// the surface from inside sees neither.
// The clearcoat's normal is the shading normal (the specification's clearcoatNormalTexture is not read);
// sheenRoughness is clamped to 0.07, below which the Charlie distribution's exponent 1 / alpha overflows
// f32 (Conty & Kulla 2017 use the same floor).
//
// Sampling: one of five lobes, chosen with uc by an estimate of its share of the light reflected or
// transmitted towards wo (the clearcoat GGX at a_c; the sheen and the diffuse lobe cosine-weighted; the
// specular GGX at a; the transmission GGX at a, mirrored or refracted); the pdf is the mixture and the
// weight f cos / pdf evaluates every lobe (one-sample MIS, balance heuristic), as coated.wgsl. A lobe
// below SMOOTH_ALPHA is a delta: chosen with probability p, its weight is its reflectance / p and eval /
// pdf leave it out.

// The Charlie sheen's directional albedo table size (coat[8..16]).
const SHEEN_NODES: u32 = 8u;

fn gltf_max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

fn gltf_mean3(v: vec3<f32>) -> f32 {
    return (v.x + v.y + v.z) / 3.0;
}

fn gltf_pow5(c: f32) -> f32 {
    let m = 1.0 - clamp(c, 0.0, 1.0);
    let m2 = m * m;
    return m2 * m2 * m;
}

fn gltf_volume(mat: Material) -> bool {
    return (mat.flags & MATERIAL_VOLUME) != 0u;
}

// The dielectric Fresnel fr at cosine c (on wo's side) between wo and the microfacet normal. Inside a
// volume (not entering) Schlick's form is evaluated at the refracted cosine on the outer side, which is 0
// (fr = 1) under total internal reflection.
fn gltf_fr(mat: Material, c: f32, entering: bool) -> vec3<f32> {
    let r = (mat.ior - 1.0) / (mat.ior + 1.0);
    let f0 = min(vec3<f32>(r * r) * mat.eta, vec3<f32>(1.0));
    var cos_outer = c;
    if gltf_volume(mat) && !entering {
        let sin2 = (1.0 - c * c) * mat.ior * mat.ior;
        cos_outer = select(sqrt(max(0.0, 1.0 - sin2)), 0.0, sin2 >= 1.0);
    }
    return f0 + (vec3<f32>(1.0) - f0) * gltf_pow5(cos_outer);
}

// The clearcoat's Fresnel weight w_c Fc(NdotV) (0 seen from inside a volume).
fn gltf_coat_weight(mat: Material, cos_o: f32, outside: bool) -> f32 {
    return select(0.0, material_coat(mat, 1) * (0.04 + 0.96 * gltf_pow5(cos_o)), outside);
}

// The Charlie sheen lobe's directional albedo E(mu) from its table (nodes at mu_j = (j / 7)^3),
// interpolated linearly in x = 7 cbrt(mu).
fn gltf_sheen_albedo(mat: Material, mu: f32) -> f32 {
    let x = pow(clamp(mu, 1e-6, 1.0), 1.0 / 3.0) * f32(SHEEN_NODES - 1u); // pow(0, y): undefined in WGSL
    let j = min(u32(x), SHEEN_NODES - 2u);
    let u = x - f32(j);
    return mix(material_coat(mat, 8u + j), material_coat(mat, 9u + j), u);
}

// The Charlie visibility's Lambda (Conty & Kulla 2017, its fitted l(x); KHR_materials_sheen).
fn gltf_sheen_l(x: f32, a: f32) -> f32 {
    let t = (1.0 - a) * (1.0 - a);
    let p = mix(21.5473, 25.3245, t);
    let q = mix(3.82987, 3.32435, t);
    let r = mix(0.19823, 0.16801, t);
    let s = mix(-1.97760, -1.27393, t);
    let u = mix(-4.32054, -4.85967, t);
    return p / (1.0 + q * pow(max(x, 1e-7), r)) + s * x + u; // pow(0, y) is undefined in WGSL
}

fn gltf_sheen_lambda(c: f32, a: f32) -> f32 {
    if c < 0.5 {
        return exp(gltf_sheen_l(c, a));
    }
    return exp(2.0 * gltf_sheen_l(0.5, a) - gltf_sheen_l(1.0 - c, a));
}

// The sheen lobe without its colour: D_charlie(h) / ((1 + Lambda(cos_o) + Lambda(cos_i)) 4 cos_o cos_i).
fn gltf_sheen_lobe(mat: Material, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let a = material_coat(mat, 3);
    let h = normalize(wo + wi);
    let sin2 = max(1e-12, 1.0 - h.z * h.z); // pow(0, y) is undefined in WGSL
    let d = (2.0 + 1.0 / a) * pow(sin2, 0.5 / a) * (0.5 * INV_PI);
    let lo = gltf_sheen_lambda(wo.z, a);
    let li = gltf_sheen_lambda(wi.z, a);
    return d / ((1.0 + lo + li) * 4.0 * wo.z * wi.z);
}

// 1 - max(c_sh) E(mu): the base's share under the sheen at one cosine.
fn gltf_sheen_scale(mat: Material, mu: f32, outside: bool) -> f32 {
    return select(1.0, 1.0 - gltf_max3(mat.k) * gltf_sheen_albedo(mat, mu), outside);
}

fn gltf_microfacet(mat: Material) -> Microfacet {
    return Microfacet(material_alpha(mat), false);
}

fn gltf_coat_microfacet(mat: Material) -> Microfacet {
    return Microfacet(vec2<f32>(max(material_coat(mat, 2), 1e-4)), false);
}

fn gltf_coat_smooth(mat: Material) -> bool {
    return microfacet_smooth(vec2<f32>(material_coat(mat, 2)));
}

// The probabilities of the five lobes seen from wo (cos_o > 0): clearcoat, sheen, specular reflection,
// diffuse, transmission; their sum is 1 unless nothing reflects (then all zero).
struct GltfLobes {
    coat: f32,
    sheen: f32,
    spec: f32,
    diffuse: f32,
    trans: f32,
}

fn gltf_lobes(mat: Material, cos_o: f32, outside: bool) -> GltfLobes {
    let wc = gltf_coat_weight(mat, cos_o, outside);
    let under = 1.0 - wc;
    let e_sheen = select(0.0, gltf_max3(mat.k) * gltf_sheen_albedo(mat, cos_o), outside);
    let base = under * (1.0 - e_sheen);
    let fr = gltf_fr(mat, cos_o, outside);
    let s = mat.fdr_int;
    let m = mat.metallic;
    let t = material_coat(mat, 0);
    let spec = base * mix(s * gltf_mean3(fr), gltf_mean3(fresnel_schlick(cos_o, mat.albedo)), m);
    let rest = base * (1.0 - m) * (1.0 - s * gltf_max3(fr)) * gltf_mean3(mat.albedo);
    var l = GltfLobes(wc, under * e_sheen, spec, rest * (1.0 - t), rest * t);
    let sum = l.coat + l.sheen + l.spec + l.diffuse + l.trans;
    if sum > 0.0 {
        l = GltfLobes(l.coat / sum, l.sheen / sum, l.spec / sum, l.diffuse / sum, l.trans / sum);
    }
    return l;
}

// The refraction's relative index, wi's side over wo's (volume only).
fn gltf_eta(mat: Material, entering: bool) -> f32 {
    return select(1.0 / mat.ior, mat.ior, entering);
}

struct GltfEval {
    f: vec3<f32>,
    pdf: f32,
}

// f and pdf of the non-delta lobes at (wo, wi), local frame, wo above the surface; `entering`: wo is on
// the outer side.
fn gltf_pbr_at(mat: Material, wo: vec3<f32>, wi: vec3<f32>, entering: bool) -> GltfEval {
    var r = GltfEval(vec3<f32>(0.0), 0.0);
    if wo.z <= 0.0 || wi.z == 0.0 {
        return r;
    }
    let outside = entering || !gltf_volume(mat);
    let p = gltf_lobes(mat, wo.z, outside);
    let wc = gltf_coat_weight(mat, wo.z, outside);
    let m = mat.metallic;
    let s = mat.fdr_int;
    let t = material_coat(mat, 0);
    let mf = gltf_microfacet(mat);
    let is_smooth = microfacet_smooth(material_alpha(mat));
    if wi.z > 0.0 {
        // Reflection: the clearcoat, the sheen, and the base under them.
        if !gltf_coat_smooth(mat) && wc > 0.0 {
            let g = ggx_reflection(wo, wi, gltf_coat_microfacet(mat));
            r.f += vec3<f32>(wc * g.f);
            r.pdf += p.coat * g.pdf;
        }
        let scale = min(gltf_sheen_scale(mat, wo.z, outside), gltf_sheen_scale(mat, wi.z, outside));
        if outside && gltf_max3(mat.k) > 0.0 {
            r.f += (1.0 - wc) * mat.k * gltf_sheen_lobe(mat, wo, wi);
        }
        r.pdf += (p.sheen + p.diffuse) * wi.z * INV_PI;
        let h = normalize(wo + wi);
        let c = max(0.0, dot(wo, h));
        let fr = gltf_fr(mat, c, outside);
        var base = mat.albedo * ((1.0 - m) * (1.0 - s * gltf_max3(fr)) * (1.0 - t) * INV_PI);
        if !is_smooth {
            let g = ggx_reflection(wo, wi, mf);
            base += mix(s * fr, fresnel_schlick(c, mat.albedo), m) * g.f;
            r.pdf += p.spec * g.pdf;
        }
        r.f += (1.0 - wc) * scale * base;
    } else if !is_smooth && t > 0.0 {
        let scale = min(gltf_sheen_scale(mat, wo.z, outside), gltf_sheen_scale(mat, -wi.z, outside));
        let tint = (1.0 - wc) * scale * (1.0 - m) * t * mat.albedo;
        if gltf_volume(mat) {
            let rf = refraction_half_vector(wo, wi, gltf_eta(mat, entering));
            if rf.valid {
                let fr = gltf_fr(mat, rf.cos_oh, entering);
                let jac = abs(rf.cos_ih) / (rf.denom * rf.denom);
                let d = microfacet_d(rf.h, mf);
                r.f = tint * (1.0 - s * gltf_max3(fr))
                    * (d * microfacet_g2(wo, wi, mf) * jac * rf.cos_oh / (wo.z * abs(wi.z)));
                r.pdf = p.trans * microfacet_visible_pdf(wo, rf.h, mf) * jac;
            }
        } else {
            // Thin: the reflection lobe at wi mirrored through the surface.
            let wm = vec3<f32>(wi.x, wi.y, -wi.z);
            let g = ggx_reflection(wo, wm, mf);
            let fr = gltf_fr(mat, g.cos_oh, true);
            r.f = tint * (1.0 - s * gltf_max3(fr)) * g.f;
            r.pdf = p.trans * g.pdf;
        }
    }
    return r;
}

// Whether light on wo's side at cosine c to the (micro)normal is totally reflected: inside a volume only.
fn gltf_tir(mat: Material, c: f32, entering: bool) -> bool {
    return gltf_volume(mat) && !entering && (1.0 - c * c) * mat.ior * mat.ior >= 1.0;
}

fn gltf_pbr_sample(mat: Material, wo_w: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let uc = rng_next(rng);
    let u = rng_next2(rng);
    let wo = to_local(fr, wo_w);
    if wo.z <= 0.0 {
        return bsdf_absorbed();
    }
    let outside = sh.entering || !gltf_volume(mat);
    let p = gltf_lobes(mat, wo.z, outside);
    let is_smooth = microfacet_smooth(material_alpha(mat));
    let wc = gltf_coat_weight(mat, wo.z, outside);
    // The base's weight under the clearcoat and the sheen, for wi at wo's cosine (the smooth lobes).
    let base = (1.0 - wc) * gltf_sheen_scale(mat, wo.z, outside);
    let f_o = gltf_fr(mat, wo.z, outside);
    let m = mat.metallic;
    let s = mat.fdr_int;
    var wi = vec3<f32>(0.0);
    var reflected = true;
    if uc < p.coat {
        if gltf_coat_smooth(mat) {
            return BsdfSample(reflect_dir(-wo_w, fr.n), vec3<f32>(wc / p.coat), p.coat, BSDF_REFLECTION | BSDF_DELTA);
        }
        wi = reflect_dir(-wo, microfacet_sample_visible(wo, gltf_coat_microfacet(mat), u));
    } else if uc < p.coat + p.sheen + p.diffuse {
        wi = sample_cosine_local(u);
    } else if uc < p.coat + p.sheen + p.diffuse + p.spec {
        if is_smooth {
            let weight = base * mix(s * f_o, fresnel_schlick(wo.z, mat.albedo), m) / p.spec;
            return BsdfSample(reflect_dir(-wo_w, fr.n), weight, p.spec, BSDF_REFLECTION | BSDF_DELTA);
        }
        wi = reflect_dir(-wo, microfacet_sample_visible(wo, gltf_microfacet(mat), u));
    } else if p.trans > 0.0 {
        reflected = false;
        if is_smooth {
            let weight = base * (1.0 - m) * material_coat(mat, 0) * mat.albedo * (1.0 - s * gltf_max3(f_o)) / p.trans;
            var wt = -wo_w; // thin: straight through
            if gltf_volume(mat) {
                if gltf_tir(mat, wo.z, sh.entering) {
                    return bsdf_absorbed();
                }
                wt = refract_dir(-wo_w, fr.n, gltf_eta(mat, sh.entering));
            }
            return BsdfSample(wt, weight, p.trans, BSDF_TRANSMISSION | BSDF_DELTA);
        }
        let h = microfacet_sample_visible(wo, gltf_microfacet(mat), u);
        if gltf_volume(mat) {
            if gltf_tir(mat, dot(wo, h), sh.entering) {
                return bsdf_absorbed();
            }
            wi = refract_dir(-wo, h, gltf_eta(mat, sh.entering));
        } else {
            let wr = reflect_dir(-wo, h);
            wi = vec3<f32>(wr.x, wr.y, -wr.z);
        }
    } else {
        return bsdf_absorbed(); // nothing reflects (all probabilities zero)
    }
    if (wi.z > 0.0) != reflected || wi.z == 0.0 {
        return bsdf_absorbed();
    }
    let e = gltf_pbr_at(mat, wo, wi, sh.entering);
    if e.pdf <= 0.0 {
        return bsdf_absorbed();
    }
    let flags = select(BSDF_TRANSMISSION, BSDF_REFLECTION, reflected);
    return BsdfSample(frame_to_world(fr, wi), e.f * (abs(wi.z) / e.pdf), e.pdf, flags);
}

fn gltf_pbr_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return gltf_pbr_at(mat, to_local(fr, wo), to_local(fr, wi), sh.entering).f;
}

fn gltf_pbr_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return gltf_pbr_at(mat, to_local(fr, wo), to_local(fr, wi), sh.entering).pdf;
}

fn gltf_pbr_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo; // the base colour
}

// Every lobe a delta: smooth, no diffuse lobe (metal or fully transmissive), no sheen, a smooth or
// absent clearcoat.
fn gltf_pbr_is_delta(mat: Material) -> bool {
    return microfacet_smooth(material_alpha(mat)) && (1.0 - mat.metallic) * (1.0 - material_coat(mat, 0)) == 0.0
        && gltf_max3(mat.k) == 0.0 && (material_coat(mat, 1) == 0.0 || gltf_coat_smooth(mat));
}

fn gltf_pbr_transmits(mat: Material) -> bool {
    return material_coat(mat, 0) > 0.0 && mat.metallic < 1.0;
}
