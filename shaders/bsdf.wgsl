// bsdf.wgsl: the materials, behind one interface the integrator calls (after pbrt-v4's BSDF::Sample_f,
// f and PDF; Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §9.1).
//
// requires: features.wgsl, sampling.wgsl, rng.wgsl, microfacet.wgsl
//
// Conventions. Directions point away from the surface: wo towards where the light goes (the previous
// path vertex), wi towards where it comes from. `ns` is the unit shading normal on wo's side (the caller
// flips it; a smooth mesh's interpolated normal, else the geometric normal), `tangent` the direction the
// anisotropic roughness alpha_x runs along (any vector not parallel to ns; zero when no material of the
// scene is anisotropic: the frame is then arbitrary about ns), and `entering` says whether wo is on the
// outside of the surface (for a dielectric: which index is on which side). Every material has three
// functions, dispatched on `Material::kind` by bsdf_sample / bsdf_eval / bsdf_pdf below:
//  * <kind>_sample(mat, wo, frame, entering, rng): an incident direction wi drawn with density pdf(wi), and
//    the weight f(wo, wi) |cos theta_i| / pdf(wi) that the path throughput is multiplied by. A material
//    draws from the generator a fixed count of numbers per kind (diffuse and conductor two, smooth
//    dielectric one, rough dielectric and the two-lobe materials three, mirror none), whatever it
//    samples, so that every later dimension of the path is drawn at the same index whichever lobes it met.
//  * <kind>_eval(mat, wo, wi, frame, entering): f(wo, wi) in sr^-1 (0 for a delta lobe: a given direction
//    has zero probability of being the mirror direction).
//  * <kind>_pdf(mat, wo, wi, frame, entering): the solid-angle density bsdf_sample draws wi with (0 for
//    delta lobes).
// A delta (specular) sample has BSDF_DELTA set: its `pdf` is then the discrete probability of the lobe
// chosen (1 for a mirror, F or 1 - F for glass) rather than a density, and next-event estimation skips
// the vertex (bsdf_is_delta).
//
// Adding a material: a MAT_* constant (mirrored in src/kernel/abi.rs), its three functions here, one line
// in each dispatcher under its feature constant (features.wgsl), and a row in src/kernel/features.rs.
//
// The glossy materials work in the local frame of ns (z up), where the microfacet functions of
// microfacet.wgsl are written; the dispatchers build their `frame` with material_frame, inside each
// glossy branch (so that a kernel without glossy materials keeps none of it).

const MAT_DIFFUSE: u32 = 0u;
const MAT_MIRROR: u32 = 1u;
const MAT_DIELECTRIC: u32 = 2u;
// The `emitter` material (a lamp's surface, and a sphere light's): emits `emission`, scatters nothing
// (a path ends there).
const MAT_EMITTER: u32 = 3u;
// Glossy materials: GGX microfacet lobes (microfacet.wgsl).
const MAT_CONDUCTOR: u32 = 4u; // a metal: rough (or smooth) reflection with a conductor's Fresnel
const MAT_ROUGH_DIELECTRIC: u32 = 5u; // rough glass (smooth glass is MAT_DIELECTRIC)
const MAT_PLASTIC: u32 = 6u; // a diffuse base under a dielectric coat
const MAT_METALLIC_ROUGHNESS: u32 = 7u; // glTF 2.0's material

// Material::flags: emission leaves both faces, not only the front.
const MATERIAL_TWO_SIDED_EMISSION: u32 = 1u;
// Material::flags: a conductor's Fresnel is Schlick's from `albedo` (the reflectance at normal
// incidence, a base colour) rather than the exact one from eta + i k.
const MATERIAL_SCHLICK: u32 = 2u;

// One material's parameters, as uploaded (`materials` in scene_data.wgsl; GpuMaterial in Rust). What a
// field means depends on the kind; unused fields are zero.
struct Material {
    albedo: vec3<f32>, // diffuse albedo, mirror tint, plastic base, glTF base colour, Schlick f0, conductor tint
    kind: u32,
    emission: vec3<f32>, // emitted radiance, W sr^-1 m^-2 (any kind may emit; zero: it does not)
    ior: f32, // dielectrics and plastic: index of refraction inside over outside
    eta: vec3<f32>, // conductor: real part of the complex index of refraction, per channel
    alpha_x: f32, // GGX roughness alpha (= roughness^2) along the tangent
    k: vec3<f32>, // conductor: imaginary part (extinction coefficient), per channel
    alpha_y: f32, // GGX alpha along the bitangent (= alpha_x when isotropic)
    flags: u32, // MATERIAL_TWO_SIDED_EMISSION | MATERIAL_SCHLICK
    metallic: f32, // metallic_roughness: the metal's weight in [0, 1]
    fdr_int: f32, // plastic: the coat's internal diffuse reflectance (see plastic_eval)
    _pad0: u32,
}

// The GGX alpha on both axes, at least 1e-4 each: an anisotropic lobe may be smooth along one axis only
// (roughness [0, 0.5]), and D divides by each alpha. (Both below SMOOTH_ALPHA is the delta lobe, which
// the clamp does not change.)
fn material_alpha(mat: Material) -> vec2<f32> {
    return max(vec2<f32>(mat.alpha_x, mat.alpha_y), vec2<f32>(1e-4));
}

// The radiance the material emits towards a viewer on its front side (`front`: the side the geometric
// normal faces) or its back: its emission, on the back only if two-sided.
fn material_emission(mat: Material, front: bool) -> vec3<f32> {
    let seen = front || (mat.flags & MATERIAL_TWO_SIDED_EMISSION) != 0u;
    return select(vec3<f32>(0.0), mat.emission, seen);
}

// BsdfSample::flags.
const BSDF_REFLECTION: u32 = 1u; // wi leaves on wo's side
const BSDF_TRANSMISSION: u32 = 2u; // wi crosses the surface
const BSDF_DELTA: u32 = 4u; // a specular lobe (a Dirac delta in direction)

struct BsdfSample {
    wi: vec3<f32>,
    weight: vec3<f32>, // f |cos theta_i| / pdf
    pdf: f32,
    flags: u32, // 0: nothing sampled (the path is absorbed)
}

fn bsdf_absorbed() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0u);
}

// --- Diffuse (Lambert) -----------------------------------------------------------------------------
// f = albedo / pi when wo and wi both lie strictly above the surface (on ns's side), 0 otherwise: the
// condition is symmetric in wo and wi, so f is reciprocal even at the horizon (Mitsuba 3's `diffuse`
// tests both cosines likewise). Sampled cosine-weighted, pdf = cos(theta_i) / pi, so that
// f cos / pdf = albedo: the weight does not depend on the direction. Seen from below or along the
// surface (wo.ns <= 0, possible with a shading normal) it reflects nothing: the sample is absorbed (after
// drawing its two numbers) and the pdf is 0.

fn diffuse_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>, rng: ptr<function, Rng>) -> BsdfSample {
    let wi = sample_cosine_hemisphere(ns, rng_next2(rng));
    var s = BsdfSample(wi, mat.albedo, cosine_hemisphere_pdf(dot(wi, ns)), BSDF_REFLECTION);
    if dot(wo, ns) <= 0.0 {
        s = bsdf_absorbed();
    }
    return s;
}

fn diffuse_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> vec3<f32> {
    if dot(wi, ns) <= 0.0 || dot(wo, ns) <= 0.0 {
        return vec3<f32>(0.0);
    }
    return mat.albedo * INV_PI;
}

fn diffuse_pdf(wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> f32 {
    return select(cosine_hemisphere_pdf(dot(wi, ns)), 0.0, dot(wo, ns) <= 0.0);
}

// --- Mirror ----------------------------------------------------------------------------------------
// A perfect mirror tinted by `albedo`: f = albedo delta(wi - R(wo)) / |cos theta_i|, so the weight is the
// tint.

// Mirror reflection of the incoming direction d (pointing at the surface) about the unit normal n.
fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

fn mirror_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>) -> BsdfSample {
    return BsdfSample(reflect_dir(-wo, ns), mat.albedo, 1.0, BSDF_REFLECTION | BSDF_DELTA);
}

// --- Smooth dielectric (glass) -----------------------------------------------------------------------
// Reflection with probability F (Fresnel) and refraction with 1 - F: both lobes are deltas, and choosing
// each with its own weight's probability makes the weight 1 (F / F, (1 - F) / (1 - F)). The eta^2
// radiance scaling of refraction is not applied: it cancels along any path that enters and leaves the
// same medium, and every path here ends outside (camera and lights are in the outer medium).

// Exact Fresnel reflectance of a smooth dielectric interface for unpolarised light.
// cos_i: cosine of the incidence angle (>= 0); eta = n_t / n_i (transmitted over incident index).
// F = (r_par^2 + r_perp^2) / 2 with r_par = (eta cos_i - cos_t)/(eta cos_i + cos_t),
// r_perp = (cos_i - eta cos_t)/(cos_i + eta cos_t); total internal reflection (sin_t >= 1) gives F = 1.
fn fresnel_dielectric(cos_i_in: f32, eta: f32) -> f32 {
    if eta == 1.0 {
        return 0.0; // index-matched: no interface at all (exactly, not up to rounding)
    }
    let cos_i = clamp(cos_i_in, 0.0, 1.0);
    let sin2_i = max(0.0, 1.0 - cos_i * cos_i);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

// Snell refraction of unit direction d through a surface with unit normal n facing the incoming side
// (dot(d, n) < 0), eta = n_t / n_i. w_t = d/eta + (cos_i/eta - cos_t) n. The caller has excluded total
// internal reflection (fresnel_dielectric returned < 1). eta = 1 returns d unchanged, bit for bit.
fn refract_dir(d: vec3<f32>, n: vec3<f32>, eta: f32) -> vec3<f32> {
    if eta == 1.0 {
        return d;
    }
    let cos_i = clamp(-dot(d, n), 0.0, 1.0);
    let sin2_t = max(0.0, 1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = sqrt(max(0.0, 1.0 - sin2_t));
    return normalize(d / eta + (cos_i / eta - cos_t) * n);
}

fn dielectric_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>, entering: bool,
                     rng: ptr<function, Rng>) -> BsdfSample {
    // eta = n_t / n_i: entering goes from the outside (index 1) into the material.
    let eta = select(1.0 / mat.ior, mat.ior, entering);
    let f = fresnel_dielectric(dot(wo, ns), eta);
    var s = BsdfSample(vec3<f32>(0.0), vec3<f32>(1.0), f, BSDF_REFLECTION | BSDF_DELTA);
    if rng_next(rng) < f {
        s.wi = reflect_dir(-wo, ns);
    } else {
        s.wi = refract_dir(-wo, ns, eta);
        s.pdf = 1.0 - f;
        s.flags = BSDF_TRANSMISSION | BSDF_DELTA;
    }
    return s;
}

// --- The shading frame -----------------------------------------------------------------------------

// The local frame of the glossy lobes: z = ns, x = the tangent's component perpendicular to ns (the
// direction alpha_x runs along). A zero or parallel tangent (isotropic scenes pass zero) gives Duff et
// al.'s frame about ns, which an isotropic lobe does not depend on.
fn shading_frame(ns: vec3<f32>, tangent: vec3<f32>) -> Frame {
    let t = tangent - dot(tangent, ns) * ns;
    let len2 = dot(t, t);
    if len2 < 1e-12 {
        return frame_from_normal(ns);
    }
    let tx = t * inverseSqrt(len2);
    return Frame(tx, cross(ns, tx), ns);
}

// The frame a material is shaded in: about the tangent only when the material is anisotropic. An
// isotropic lobe does not depend on the frame's rotation about ns, but the direction it samples from given
// random numbers does; ignoring the tangent for isotropic materials keeps the generic kernel (which computes
// a tangent at every hit) drawing exactly the directions of a kernel specialised without anisotropy.
fn material_frame(mat: Material, ns: vec3<f32>, tangent: vec3<f32>) -> Frame {
    return shading_frame(ns, select(vec3<f32>(0.0), tangent, mat.alpha_x != mat.alpha_y));
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

// --- The GGX reflection lobe (shared by conductor, plastic and metallic_roughness) -----------------
// f_r(wo, wi) = F(wo.h) D(h) G2(wo, wi) / (4 cos_o cos_i), h = (wo + wi) / |wo + wi| (Cook & Torrance
// 1982; Walter et al. 2007, eq. 20). Sampled through the visible normals: h ~ D_wo, wi = reflect(wo, h),
// so pdf(wi) = D_wo(h) / (4 wo.h) (the Jacobian of the reflection, Walter eq. 14), and
// f cos_i / pdf = F G2 / G1(wo): nearly F, which is why VNDF sampling has so little variance.

struct GgxReflection {
    f: f32, // D G2 / (4 cos_o cos_i), without the Fresnel factor
    pdf: f32, // D_wo(h) / (4 wo.h)
    cos_oh: f32, // wo.h, where the Fresnel factor is evaluated
}

// The lobe at (wo, wi) in the local frame; all zero unless both are above the surface.
fn ggx_reflection(wo: vec3<f32>, wi: vec3<f32>, alpha: vec2<f32>) -> GgxReflection {
    var r = GgxReflection(0.0, 0.0, 0.0);
    let sum = wo + wi;
    if wo.z > 0.0 && wi.z > 0.0 && dot(sum, sum) > 0.0 {
        let h = normalize(sum);
        let d = ggx_d(h, alpha);
        r.cos_oh = max(0.0, dot(wo, h));
        r.f = d * ggx_g2(wo, wi, alpha) / (4.0 * wo.z * wi.z);
        r.pdf = ggx_g1(wo, alpha) * d / (4.0 * wo.z);
    }
    return r;
}

// --- Conductor ------------------------------------------------------------------------------------
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

fn conductor_sample(mat: Material, wo_w: vec3<f32>, fr: Frame, rng: ptr<function, Rng>) -> BsdfSample {
    let u = rng_next2(rng);
    let alpha = material_alpha(mat);
    let wo = to_local(fr, wo_w);
    var s = bsdf_absorbed();
    if wo.z > 0.0 {
        if microfacet_smooth(alpha) {
            s = BsdfSample(reflect_dir(-wo_w, fr.n), conductor_fresnel(mat, wo.z), 1.0,
                           BSDF_REFLECTION | BSDF_DELTA);
        } else {
            let h = ggx_sample_visible(wo, alpha, u);
            let wi = reflect_dir(-wo, h);
            let r = ggx_reflection(wo, wi, alpha);
            if r.pdf > 0.0 {
                let weight = conductor_fresnel(mat, r.cos_oh) * (r.f * wi.z / r.pdf);
                s = BsdfSample(frame_to_world(fr, wi), weight, r.pdf, BSDF_REFLECTION);
            }
        }
    }
    return s;
}

fn conductor_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame) -> vec3<f32> {
    let alpha = material_alpha(mat);
    if microfacet_smooth(alpha) {
        return vec3<f32>(0.0);
    }
    let r = ggx_reflection(to_local(fr, wo), to_local(fr, wi), alpha);
    return conductor_fresnel(mat, r.cos_oh) * r.f;
}

fn conductor_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame) -> f32 {
    let alpha = material_alpha(mat);
    if microfacet_smooth(alpha) {
        return 0.0;
    }
    return ggx_reflection(to_local(fr, wo), to_local(fr, wi), alpha).pdf;
}

// --- Rough dielectric -----------------------------------------------------------------------------
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

fn rough_dielectric_sample(mat: Material, wo_w: vec3<f32>, fr: Frame, entering: bool,
                           rng: ptr<function, Rng>) -> BsdfSample {
    var s = bsdf_absorbed();
    if rough_dielectric_is_smooth(mat) {
        s = dielectric_sample(mat, wo_w, fr.n, entering, rng);
        (*rng).dim += 2u; // three numbers, as the rough branch draws
    } else {
        let u = rng_next2(rng);
        let uc = rng_next(rng);
        let alpha = material_alpha(mat);
        let eta = rough_dielectric_eta(mat, entering);
        let wo = to_local(fr, wo_w);
        if wo.z > 0.0 {
            let h = ggx_sample_visible(wo, alpha, u);
            let cos_oh = dot(wo, h);
            let f = fresnel_dielectric(cos_oh, eta);
            var wi = vec3<f32>(0.0);
            var flags = 0u;
            var pdf = 0.0;
            if uc < f {
                wi = reflect_dir(-wo, h);
                if wi.z > 0.0 {
                    flags = BSDF_REFLECTION;
                    pdf = ggx_visible_pdf(wo, h, alpha) * f / (4.0 * cos_oh);
                }
            } else {
                wi = refract_dir(-wo, h, eta);
                let cos_ih = dot(wi, h);
                let denom = cos_ih + cos_oh / eta;
                if wi.z < 0.0 && cos_ih < 0.0 && denom != 0.0 {
                    flags = BSDF_TRANSMISSION;
                    pdf = ggx_visible_pdf(wo, h, alpha) * (1.0 - f) * abs(cos_ih) / (denom * denom);
                }
            }
            if flags != 0u && pdf > 0.0 {
                let weight = ggx_g2(wo, wi, alpha) / ggx_g1(wo, alpha);
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
        let g = ggx_reflection(wo, wi, alpha);
        let f = fresnel_dielectric(g.cos_oh, eta);
        r = RoughDielectricEval(f * g.f, f * g.pdf);
    } else if wo.z > 0.0 && wi.z < 0.0 {
        let sum = wo + eta * wi;
        if dot(sum, sum) > 0.0 {
            var h = normalize(sum);
            h = select(h, -h, h.z < 0.0);
            let cos_oh = dot(wo, h);
            let cos_ih = dot(wi, h);
            let denom = cos_ih + cos_oh / eta;
            // Only microfacets that face wo and that wi crosses from below.
            if cos_oh > 0.0 && cos_ih < 0.0 && denom != 0.0 {
                let t = 1.0 - fresnel_dielectric(cos_oh, eta);
                let d = ggx_d(h, alpha);
                let jac = abs(cos_ih) / (denom * denom);
                r.f = t * d * ggx_g2(wo, wi, alpha) * jac * cos_oh / (wo.z * abs(wi.z));
                r.pdf = t * ggx_visible_pdf(wo, h, alpha) * jac;
            }
        }
    }
    return r;
}

fn rough_dielectric_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame, entering: bool) -> vec3<f32> {
    if rough_dielectric_is_smooth(mat) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(rough_dielectric_at(mat, to_local(fr, wo), to_local(fr, wi), entering).f);
}

fn rough_dielectric_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame, entering: bool) -> f32 {
    if rough_dielectric_is_smooth(mat) {
        return 0.0;
    }
    return rough_dielectric_at(mat, to_local(fr, wo), to_local(fr, wi), entering).pdf;
}

// --- Two-lobe materials: plastic and glTF's metallic-roughness ---------------------------------------
// Both are a GGX reflection lobe (a delta below SMOOTH_ALPHA) over a diffuse lobe; they differ in the
// specular lobe's Fresnel factor Fs and the diffuse lobe's value fd:
//
// Plastic (a diffuse base of albedo a under a smooth-interfaced dielectric coat of index eta; the model of
// Mitsuba 3's `plastic` with `nonlinear = true`, and of Weidlich & Wilkie 2007's layer without
// absorption): Fs = F(wo.h, eta), and light that enters the coat (1 - F(cos_i)), reflects diffusely off
// the base, and leaves it (1 - F(cos_o)), with the internal reflections at the coat summed as a geometric
// series, gives
//   fd = (1 - F(cos_i)) (1 - F(cos_o)) a / (pi eta^2 (1 - a Fdr_int)),
// where Fdr_int = the cosine-weighted hemispherical average of the coat's reflectance seen from inside
// (computed once on the host, `fdr_int`) and 1 / eta^2 the compression of solid angle on leaving.
// Energy: with a = 1 and a smooth coat the diffuse albedo is exactly 1 - F(cos_o) (since
// eta^2 (1 - Fdr_int) = 1 - Fdr_ext), so the material reflects all the light at every angle. A rough coat
// gives E(cos_o) = E_ggx(cos_o) + 1 - F(cos_o), E_ggx the albedo of the coat's GGX lobe (Fresnel-weighted):
// within a fraction of a percent of 1 (above or below) near normal incidence, where the coat reflects
// little, but well below 1 at grazing angles, where F(cos_o) is large and single-scattering GGX loses much
// of it to masking; the diffuse transmission uses the smooth interface's 1 - F (Mitsuba's `roughplastic`
// uses the rough coat's own transmittance instead, and loses energy differently). tests/shader_glossy.rs
// measures E against an f64 quadrature of this model.
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

// fd at (wo, wi), local frame, both above the surface.
fn coated_diffuse(mat: Material, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if mat.kind == MAT_PLASTIC {
        let t = (1.0 - fresnel_dielectric(wi.z, mat.ior)) * (1.0 - fresnel_dielectric(wo.z, mat.ior));
        let a = mat.albedo;
        return a * (t * INV_PI / (mat.ior * mat.ior)) / (vec3<f32>(1.0) - a * mat.fdr_int);
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
            let g = ggx_reflection(wo, wi, alpha);
            r.f += coated_specular_fresnel(mat, g.cos_oh) * g.f;
            r.pdf += p_s * g.pdf;
        }
    }
    return r;
}

fn coated_sample(mat: Material, wo_w: vec3<f32>, fr: Frame, rng: ptr<function, Rng>) -> BsdfSample {
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
                wi = reflect_dir(-wo, ggx_sample_visible(wo, alpha, u));
            }
        } else {
            let r = sqrt(u.x);
            let phi = TWO_PI * u.y;
            wi = vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
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

fn coated_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame) -> vec3<f32> {
    return coated_at(mat, to_local(fr, wo), to_local(fr, wi)).f;
}

fn coated_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, fr: Frame) -> f32 {
    return coated_at(mat, to_local(fr, wo), to_local(fr, wi)).pdf;
}

// --- The dispatchers -------------------------------------------------------------------------------
// Each material's branch sits under its feature constant, so a kernel specialised for a scene keeps only
// the materials the scene uses; with one material kind (SINGLE_MATERIAL_KIND) the kind test goes too.
// Emitters (and any kind the kernel was specialised without) absorb. Each dispatcher has one exit: on
// lavapipe, whose invocations run as SIMD lanes, a return inside a branch costs mask bookkeeping at every
// later statement.

fn bsdf_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>, tangent: vec3<f32>, entering: bool,
               rng: ptr<function, Rng>) -> BsdfSample {
    var s = bsdf_absorbed();
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            s = diffuse_sample(mat, wo, ns, rng);
        }
    }
    if HAS_MIRROR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_MIRROR {
            s = mirror_sample(mat, wo, ns);
        }
    }
    if HAS_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIELECTRIC {
            s = dielectric_sample(mat, wo, ns, entering, rng);
        }
    }
    if HAS_CONDUCTOR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_CONDUCTOR {
            s = conductor_sample(mat, wo, material_frame(mat, ns, tangent), rng);
        }
    }
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            s = rough_dielectric_sample(mat, wo, material_frame(mat, ns, tangent), entering, rng);
        }
    }
    // (Two guards for the one two-lobe implementation: the specialiser prunes `if CONSTANT` only.)
    if HAS_PLASTIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_PLASTIC {
            s = coated_sample(mat, wo, material_frame(mat, ns, tangent), rng);
        }
    }
    if HAS_METALLIC_ROUGHNESS {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_METALLIC_ROUGHNESS {
            s = coated_sample(mat, wo, material_frame(mat, ns, tangent), rng);
        }
    }
    return s;
}

fn bsdf_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>, tangent: vec3<f32>,
             entering: bool) -> vec3<f32> {
    var f = vec3<f32>(0.0); // delta lobes and emitters
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            f = diffuse_eval(mat, wo, wi, ns);
        }
    }
    if HAS_CONDUCTOR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_CONDUCTOR {
            f = conductor_eval(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            f = rough_dielectric_eval(mat, wo, wi, material_frame(mat, ns, tangent), entering);
        }
    }
    if HAS_PLASTIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_PLASTIC {
            f = coated_eval(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    if HAS_METALLIC_ROUGHNESS {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_METALLIC_ROUGHNESS {
            f = coated_eval(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    return f;
}

fn bsdf_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>, tangent: vec3<f32>,
            entering: bool) -> f32 {
    var pdf = 0.0; // delta lobes and emitters
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            pdf = diffuse_pdf(wo, wi, ns);
        }
    }
    if HAS_CONDUCTOR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_CONDUCTOR {
            pdf = conductor_pdf(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            pdf = rough_dielectric_pdf(mat, wo, wi, material_frame(mat, ns, tangent), entering);
        }
    }
    if HAS_PLASTIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_PLASTIC {
            pdf = coated_pdf(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    if HAS_METALLIC_ROUGHNESS {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_METALLIC_ROUGHNESS {
            pdf = coated_pdf(mat, wo, wi, material_frame(mat, ns, tangent));
        }
    }
    return pdf;
}

// Whether the material has only delta lobes (or none): next-event estimation cannot help there, since
// bsdf_eval is 0 for every direction a light sample could give.
// The material's albedo for the `--aov albedo` layer (what denoisers call albedo: the colour of the
// surface, not lit): the diffuse albedo, the plastic's base, glTF's base colour; a conductor's
// reflectance at normal incidence, F(1) (from eta + i k, or the Schlick base colour); white for
// dielectrics (they scatter all the light they do not absorb, and absorb none); black for the emitter
// material, which reflects nothing. A mirror's tint, should a mirror be the surface counted (after
// max_bounces delta bounces).
fn bsdf_albedo(mat: Material) -> vec3<f32> {
    var a = mat.albedo;
    if HAS_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIELECTRIC {
            a = vec3<f32>(1.0);
        }
    }
    if HAS_EMITTERS {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_EMITTER {
            a = vec3<f32>(0.0);
        }
    }
    if HAS_CONDUCTOR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_CONDUCTOR {
            a = conductor_fresnel(mat, 1.0);
        }
    }
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            a = vec3<f32>(1.0);
        }
    }
    return a;
}

fn bsdf_is_delta(mat: Material) -> bool {
    var delta = true;
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            delta = false;
        }
    }
    if HAS_CONDUCTOR {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_CONDUCTOR {
            delta = microfacet_smooth(material_alpha(mat));
        }
    }
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            delta = rough_dielectric_is_smooth(mat);
        }
    }
    if HAS_PLASTIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_PLASTIC {
            delta = false;
        }
    }
    if HAS_METALLIC_ROUGHNESS {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_METALLIC_ROUGHNESS {
            delta = false;
        }
    }
    return delta;
}

// Whether light from below the surface (the side opposite wo) can reach wo through it: next-event
// estimation then samples lights on both sides.
fn bsdf_transmits(mat: Material) -> bool {
    var transmits = false;
    if HAS_ROUGH_DIELECTRIC {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_ROUGH_DIELECTRIC {
            transmits = !rough_dielectric_is_smooth(mat);
        }
    }
    return transmits;
}
