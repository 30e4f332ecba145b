// bsdfs/principled.wgsl: Mitsuba 3's `principled` BSDF (Burley, "Physically Based Shading at Disney",
// SIGGRAPH 2012 course, and "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering",
// 2015), its reflection: every lobe but specular transmission (spec_trans = 0, which the readers
// require).
//
// requires: bsdfs/common.wgsl
//
// Written to give what Mitsuba 3 (3.9.1, mitsuba3/src/bsdfs/principled.cpp and principledhelpers.h) computes for
// the same parameters, so that a Mitsuba scene renders as its author saw it; where Mitsuba departs from
// Burley's notes, Mitsuba is followed and the departure is named. With the viewer's direction wo and the
// light's wi in the local frame (z the shading normal, both above it), h = normalize(wo + wi), cos_d = wi.h
// and SW(c) = (1 - c)^5 (Schlick's weight), f(wo, wi) is the sum of
//   specular:  F_p(wo.h) D(h) G1(wo) G1(wi) / (4 cos_o cos_i)   (anisotropic GGX, separable Smith G),
//   clearcoat: clearcoat / 4 Fcc(wo.h) Dcc(h) Gcc(wo) Gcc(wi)
//              (GTR1 of alpha lerp(0.1, 0.001, clearcoat_gloss), Schlick F0 0.04, separable GGX masking
//              of alpha 0.25; Mitsuba leaves out the microfacet 1 / (4 cos_o cos_i) that Burley's code
//              folds into its G, and the clearcoat here is Mitsuba's),
//   diffuse:   (1 - metallic) base / pi lerp(f_diff + f_retro, f_ss, flatness),
//              f_diff = (1 - SW(cos_o) / 2)(1 - SW(cos_i) / 2), Rr = 2 roughness cos_d^2,
//              f_retro = Rr (SW_o + SW_i + SW_o SW_i (Rr - 1)),
//              f_ss = 1.25 (Fss (1 / (cos_o + cos_i) - 1/2) + 1/2), Fss = lerp(1, Rr/2, SW_o) lerp(1, Rr/2, SW_i),
//   sheen:     sheen (1 - metallic) SW(cos_d) lerp(1, tint, sheen_tint),
// where tint = base / luminance(base) and F_p = (1 - metallic)(1 - spec_tint) F_dielectric(wo.h, eta)
// + metallic Schlick(base) + (1 - metallic) spec_tint Schlick(tint R0(eta)); eta = 2 / (1 - sqrt(0.08
// specular)) - 1 (Mitsuba's mapping) unless given. alpha_x, alpha_y = max(0.001, r^2 / aspect), max(0.001,
// r^2 aspect), aspect = sqrt(1 - 0.9 anisotropic). (Mitsuba's BSDF values are f cos_i.)
//
// Sampling (Mitsuba's): a lobe by the weights 1 (specular), clearcoat / 4 and 1 - metallic, normalised;
// the specular's h from GGX's visible normals, the clearcoat's from GTR1's D(h) cos(h), the diffuse
// cosine-weighted; the pdf is the mixture, the weight f cos / pdf. Three numbers, whatever the lobe.
//
// Material fields: albedo = base colour, metallic, ior = eta, alpha_x / alpha_y as above (unclamped;
// roughness = (alpha_x alpha_y)^(1/4)), eta = (spec_tint, sheen, sheen_tint), k = (clearcoat,
// clearcoat_gloss, flatness).

// Mitsuba's luminance of a linear sRGB colour (its Rec. 709 weights).
fn principled_luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.212671, 0.715160, 0.072169));
}

fn principled_schlick_weight(c: f32) -> f32 {
    let m = clamp(1.0 - c, 0.0, 1.0);
    let m2 = m * m;
    return m2 * m2 * m;
}

// Mitsuba's calc_schlick: Schlick's F = R0 + (1 - R0) SW(cos), with the cosine of the transmitted ray
// when the relative index is below 1 (seen from outside, cos_i >= 0).
fn principled_schlick(r0: vec3<f32>, cos_i: f32, eta: f32) -> vec3<f32> {
    var c = cos_i;
    if eta < 1.0 {
        c = sqrt(max(0.0, 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)));
    }
    return mix(vec3<f32>(principled_schlick_weight(c)), vec3<f32>(1.0), r0);
}

// The colour the tints lean towards: the base colour over its luminance (white for black).
fn principled_tint(base: vec3<f32>) -> vec3<f32> {
    let lum = principled_luminance(base);
    return select(vec3<f32>(1.0), base / lum, lum > 0.0);
}

fn principled_alpha(mat: Material) -> vec2<f32> {
    return max(vec2<f32>(mat.alpha_x, mat.alpha_y), vec2<f32>(0.001));
}

// Separable GGX masking of the clearcoat (Mitsuba's smith_ggx1): 2 / (1 + sqrt(1 + a^2 tan^2)).
fn principled_cc_g1(v: vec3<f32>, h: vec3<f32>, a: f32) -> f32 {
    let c2 = v.z * v.z;
    let t2 = max(0.0, 1.0 - c2) / max(c2, 1e-30);
    return select(2.0 / (1.0 + sqrt(1.0 + a * a * t2)), 0.0, dot(v, h) * v.z <= 0.0);
}

// GTR1 (Burley 2012, "Berry"): D(h) = (a^2 - 1) / (pi ln(a^2) (1 + (a^2 - 1) cos^2)).
fn principled_gtr1(cos_h: f32, a: f32) -> f32 {
    let a2 = a * a;
    return (a2 - 1.0) / (PI * log(a2) * (1.0 + (a2 - 1.0) * cos_h * cos_h));
}

// The probabilities of the specular, clearcoat and diffuse lobes (sum 1).
fn principled_lobes(mat: Material) -> vec3<f32> {
    let p = vec3<f32>(1.0, 0.25 * mat.k.x, 1.0 - mat.metallic);
    return p / (p.x + p.y + p.z);
}

struct PrincipledEval {
    f: vec3<f32>,
    pdf: f32,
}

// f and pdf at (wo, wi), local frame; zero unless both are above the surface.
fn principled_at(mat: Material, wo: vec3<f32>, wi: vec3<f32>) -> PrincipledEval {
    var r = PrincipledEval(vec3<f32>(0.0), 0.0);
    let sum = wo + wi;
    if wo.z <= 0.0 || wi.z <= 0.0 || dot(sum, sum) <= 0.0 {
        return r;
    }
    let h = normalize(sum);
    let cos_oh = dot(wo, h);
    let cos_d = dot(wi, h);
    if cos_oh <= 0.0 || cos_d <= 0.0 {
        return r;
    }
    let base = mat.albedo;
    let metallic = mat.metallic;
    let spec_tint = mat.eta.x;
    let sheen = mat.eta.y;
    let sheen_tint = mat.eta.z;
    let clearcoat = mat.k.x;
    let flatness = mat.k.z;
    let eta = mat.ior;
    let lobes = principled_lobes(mat);
    let jacobian = 1.0 / (4.0 * cos_d); // dh / dwi of a reflection

    // Specular.
    let m = Microfacet(principled_alpha(mat), false);
    let d = ggx_d(h, m.alpha);
    let tint = principled_tint(base);
    let r0 = (eta - 1.0) / (eta + 1.0);
    let f_p = (1.0 - metallic) * (1.0 - spec_tint) * vec3<f32>(fresnel_dielectric(cos_oh, eta))
        + metallic * principled_schlick(base, cos_oh, eta)
        + (1.0 - metallic) * spec_tint * principled_schlick(tint * (r0 * r0), cos_oh, eta);
    r.f = f_p * (d * ggx_g1(wo, m.alpha) * ggx_g1(wi, m.alpha) / (4.0 * wo.z * wi.z));
    r.pdf = lobes.x * ggx_visible_pdf(wo, h, m.alpha) * jacobian;

    // Clearcoat.
    if clearcoat > 0.0 {
        let a = mix(0.1, 0.001, mat.k.y);
        let dcc = principled_gtr1(h.z, a);
        let fcc = principled_schlick(vec3<f32>(0.04), cos_oh, eta).x;
        let gcc = principled_cc_g1(wo, h, 0.25) * principled_cc_g1(wi, h, 0.25);
        r.f += vec3<f32>(0.25 * clearcoat * fcc * dcc * gcc);
        r.pdf += lobes.y * dcc * h.z * jacobian;
    }

    // Diffuse, retro-reflection, fake subsurface, sheen.
    if metallic < 1.0 {
        let sw_o = principled_schlick_weight(wo.z);
        let sw_i = principled_schlick_weight(wi.z);
        let f_diff = (1.0 - 0.5 * sw_i) * (1.0 - 0.5 * sw_o);
        let roughness = sqrt(sqrt(mat.alpha_x * mat.alpha_y));
        let rr = 2.0 * roughness * cos_d * cos_d;
        let f_retro = rr * (sw_o + sw_i + sw_o * sw_i * (rr - 1.0));
        let fss90 = 0.5 * rr;
        let fss = mix(1.0, fss90, sw_o) * mix(1.0, fss90, sw_i);
        let f_ss = 1.25 * (fss * (1.0 / (wo.z + wi.z) - 0.5) + 0.5);
        r.f += (1.0 - metallic) * INV_PI * mix(f_diff + f_retro, f_ss, flatness) * base;
        if sheen > 0.0 {
            let c_sheen = mix(vec3<f32>(1.0), tint, sheen_tint);
            r.f += sheen * (1.0 - metallic) * principled_schlick_weight(cos_d) * c_sheen;
        }
        r.pdf += lobes.z * wi.z * INV_PI;
    }
    return r;
}

fn principled_sample(mat: Material, wo_w: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    let uc = rng_next(rng);
    let u = rng_next2(rng);
    let wo = to_local(fr, wo_w);
    var s = bsdf_absorbed();
    if wo.z > 0.0 {
        let lobes = principled_lobes(mat);
        var wi = vec3<f32>(0.0);
        if uc < lobes.z {
            wi = sample_cosine_local(u);
        } else if uc < lobes.z + lobes.y {
            // GTR1's D(h) cos(h): cos^2 = (1 - a^(2 (1 - u))) / (1 - a^2) (Burley 2012, eq. 2).
            let a2 = mix(0.1, 0.001, mat.k.y) * mix(0.1, 0.001, mat.k.y);
            let c2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
            let st = sqrt(max(0.0, 1.0 - c2));
            let phi = TWO_PI * u.x;
            let h = vec3<f32>(st * cos(phi), st * sin(phi), sqrt(max(0.0, c2)));
            wi = reflect_dir(-wo, h);
        } else {
            wi = reflect_dir(-wo, ggx_sample_visible(wo, principled_alpha(mat), u));
        }
        if wi.z > 0.0 {
            let e = principled_at(mat, wo, wi);
            if e.pdf > 0.0 {
                s = BsdfSample(frame_to_world(fr, wi), e.f * (wi.z / e.pdf), e.pdf, BSDF_REFLECTION);
            }
        }
    }
    return s;
}

fn principled_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32> {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return principled_at(mat, to_local(fr, wo), to_local(fr, wi)).f;
}

fn principled_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32 {
    let fr = material_frame(mat, sh.ns, sh.tangent);
    return principled_at(mat, to_local(fr, wo), to_local(fr, wi)).pdf;
}

fn principled_albedo(mat: Material) -> vec3<f32> {
    return mat.albedo; // the base colour (Mitsuba's eval_diffuse_reflectance)
}

fn principled_is_delta(mat: Material) -> bool {
    return false;
}

fn principled_transmits(mat: Material) -> bool {
    return false;
}
