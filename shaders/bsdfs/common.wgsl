// bsdfs/common.wgsl: what every material's file shares: the uploaded `Material`, the sample record, the
// shading frame, the Fresnel equations of a dielectric, and the GGX reflection lobe.
//
// requires: features.wgsl, sampling.wgsl, rng.wgsl, microfacet.wgsl
//
// The materials sit behind one interface the integrator calls (after pbrt-v4's BSDF::Sample_f, f and PDF;
// Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §9.1): bsdf_sample, bsdf_eval,
// bsdf_pdf, bsdf_albedo, bsdf_is_delta and bsdf_transmits, in the module `bsdf.wgsl`, which the host
// generates from the registry of materials (src/scene/bsdfs.rs): one branch per material kind, each
// under its feature constant. A material is one file (shaders/bsdfs/<name>.wgsl for the built-in kinds,
// src/materials/<name>/<name>.wgsl for the plugins) defining six functions:
//  * <name>_sample(mat, wo, sh, rng) -> BsdfSample: an incident direction wi drawn with density pdf(wi),
//    and the weight f(wo, wi) |cos theta_i| / pdf(wi) that the path throughput is multiplied by. A
//    material draws a fixed count of numbers from the generator (diffuse and conductor two, smooth
//    dielectric one, rough dielectric and the two-lobe materials three, mirror none), whatever it
//    samples, so that every later dimension of the path is drawn at the same index whichever lobes it met.
//  * <name>_eval(mat, wo, wi, sh) -> vec3<f32>: f(wo, wi) in sr^-1 (0 for a delta lobe: a given direction
//    has zero probability of being the mirror direction).
//  * <name>_pdf(mat, wo, wi, sh) -> f32: the solid-angle density <name>_sample draws wi with (0 for delta
//    lobes).
//  * <name>_albedo(mat) -> vec3<f32>: the colour of the surface for the `--aov albedo` layer (what
//    denoisers call albedo: the surface's reflectance, not lit).
//  * <name>_is_delta(mat) -> bool: whether the material has only delta lobes (or none): next-event
//    estimation cannot help there, since eval is 0 for every direction a light sample could give.
//  * <name>_transmits(mat) -> bool: whether light from below the surface (the side opposite wo) reaches
//    wo through a non-delta lobe: next-event estimation then samples lights on both sides.
// A delta (specular) sample has BSDF_DELTA set: its `pdf` is then the discrete probability of the lobe
// chosen (1 for a mirror, F or 1 - F for glass) rather than a density.
//
// Conventions. Directions point away from the surface: wo towards where the light goes (the previous
// path vertex), wi towards where it comes from. `sh.ns` is the unit shading normal on wo's side (the
// caller flips it; a smooth mesh's interpolated normal, else the geometric normal), `sh.tangent` the
// direction the anisotropic roughness alpha_x runs along (any vector not parallel to ns; zero when no
// material of the scene is anisotropic: the frame is then arbitrary about ns), and `sh.entering` says
// whether wo is on the outside of the surface (for a dielectric: which index is on which side). The
// glossy materials work in the local frame of ns (z up), where the microfacet functions of
// microfacet.wgsl are written: they build it with material_frame inside their own functions, so that a
// kernel without glossy materials keeps none of it.
//
// Adding a material: a plugin folder src/materials/<name>/ (its declared parameters in mod.rs, the six
// functions in <name>.wgsl, reading the parameters through the generated <name>_params(mat); see
// src/materials/mod.rs). The dispatchers, its MAT_* kind and HAS_* feature constant, and the
// specialisation tables follow. The built-in kinds here (shaders/bsdfs/<name>.wgsl, rows of
// src/scene/bsdfs.rs) predate the plugins.

// Material::flags: emission leaves both faces, not only the front.
const MATERIAL_TWO_SIDED_EMISSION: u32 = 1u;
// Material::flags: a conductor's Fresnel is Schlick's from `albedo` (the reflectance at normal
// incidence, a base colour) rather than the exact one from eta + i k.
const MATERIAL_SCHLICK: u32 = 2u;
// A plastic whose base's internal reflections are not tinted by its albedo (bsdfs/coated.wgsl).
const MATERIAL_LINEAR: u32 = 4u;
// Material::flags: Beckmann microfacets instead of GGX (microfacet.wgsl).
const MATERIAL_BECKMANN: u32 = 8u;
// Material::flags: a rough plastic's coat transmits by its tabulated `coat` (bsdfs/coated.wgsl).
const MATERIAL_ROUGH_COAT: u32 = 16u;
// Material::flags: only the front face scatters; a path reaching the back ends (trace.wgsl, path_step).
const MATERIAL_ONE_SIDED: u32 = 32u;
// Material::flags: a gltf_pbr material's transmission bounds an absorbing medium (bsdfs/gltf_pbr.wgsl;
// path_step absorbs along the segments inside).
const MATERIAL_VOLUME: u32 = 64u;
// Entries of Material::coat (src/kernel/coat.rs).
const COAT_NODES: u32 = 16u;

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
    flags: u32, // MATERIAL_TWO_SIDED_EMISSION | MATERIAL_SCHLICK | MATERIAL_LINEAR | MATERIAL_BECKMANN | MATERIAL_ROUGH_COAT
    metallic: f32, // metallic_roughness: the metal's weight in [0, 1]
    fdr_int: f32, // plastic: the coat's internal diffuse reflectance (bsdfs/coated.wgsl)
    back: u32, // 1 + the material the back face shows (surface_at, scene.wgsl); 0: this one
    // The kind's own parameters, 16 numbers: a material plugin's, which its generated <kind>_params
    // reads by name (src/materials/mod.rs); a plastic with MATERIAL_ROUGH_COAT: the rough coat's
    // transmittance at mu_j = (j / 15)^2, entry j read with material_coat; gltf_pbr's layers. Four floats
    // to an element, so that the struct may also live in a uniform buffer (scene_data.wgsl, "Uniform
    // twins"), whose arrays need a stride of 16 bytes.
    block: array<vec4<f32>, 4>,
}

// Entry j of a rough coat's table in Material::block. By selects over constant indices rather than `mat.block[j / 4u][j % 4u]`:
// a lane-varying index into a value's array makes the compiler store the array in private memory and
// read it back lane by lane (the whole vec4 of each entry), which cost rough plastic 4-7 % on lavapipe.
fn material_coat(mat: Material, j: u32) -> f32 {
    let q = j / 4u;
    let r = j % 4u;
    let lo = select(mat.block[0], mat.block[1], q == 1u);
    let hi = select(mat.block[2], mat.block[3], q == 3u);
    let v = select(lo, hi, q >= 2u);
    return select(select(v.x, v.y, r == 1u), select(v.z, v.w, r == 3u), r >= 2u);
}

// The GGX alpha on both axes, at least 1e-4 each: an anisotropic lobe may be smooth along one axis only
// (roughness [0, 0.5]), and D divides by each alpha. (Both below SMOOTH_ALPHA is the delta lobe, which
// the clamp does not change.)
fn material_alpha(mat: Material) -> vec2<f32> {
    return max(vec2<f32>(mat.alpha_x, mat.alpha_y), vec2<f32>(1e-4));
}

// The material's microfacet distribution: its alpha, and GGX or Beckmann (microfacet.wgsl).
fn material_microfacet(mat: Material) -> Microfacet {
    return Microfacet(material_alpha(mat), (mat.flags & MATERIAL_BECKMANN) != 0u);
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

// Where a material is shaded: the shading normal on wo's side, the anisotropy's tangent, which side
// of the surface wo is on (see the conventions above), and whether ns may differ from the geometric
// normal n turned to wo's side (`perturbed`: a smooth mesh's interpolated normal, a normal or bump map).
// Only a perturbed frame can put wo below ns's horizon: otherwise ns = n and wo.ns = |d.n| >= 0, zero
// only for a ray exactly tangent to the surface, a set of directions of measure zero that no estimate
// depends on (catching it would cost a branch per bounce on the hottest path).
struct Shading {
    ns: vec3<f32>,
    tangent: vec3<f32>,
    entering: bool,
    perturbed: bool,
}

// Whether wo lies above ns's horizon (strictly, on a perturbed frame: see Shading). Unperturbed frames
// skip the dot product, so the kernel specialised for a scene without shading normals folds the test
// away: the diffuse BSDF is called for every bounce and every light sample.
fn wo_above(wo: vec3<f32>, sh: Shading) -> bool {
    return !sh.perturbed || dot(wo, sh.ns) > 0.0;
}

// Mirror reflection of the incoming direction d (pointing at the surface) about the unit normal n.
fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

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

// --- The microfacet reflection lobe (shared by conductor, plastic and metallic_roughness) -----------
// (GGX, or Beckmann where the material says so: the D, G and sampling of microfacet.wgsl.)
// f_r(wo, wi) = F(wo.h) D(h) G2(wo, wi) / (4 cos_o cos_i), h = (wo + wi) / |wo + wi| (Cook & Torrance
// 1982; Walter et al. 2007, eq. 20). Sampled through the visible normals: h ~ D_wo, wi = reflect(wo, h),
// so pdf(wi) = D_wo(h) / (4 wo.h) (the Jacobian of the reflection, Walter eq. 14), and
// f cos_i / pdf = F G2 / G1(wo): nearly F, which is why VNDF sampling has so little variance.

// The generalised half vector of a refraction from wo into wi (local frame, wo above, wi below), eta =
// n_t / n_i (Walter et al. 2007, eq. 16): h = (wo + eta wi) / |wo + eta wi| turned to the macro normal's
// side, with wo.h, wi.h and denom = wi.h + wo.h / eta, the Jacobian d omega_h / d omega_i being
// |wi.h| / denom^2 (eq. 17 divided by eta^2). `valid`: the microfacet faces wo and wi crosses it from
// below, denom != 0 (shared by rough_dielectric.wgsl and gltf_pbr.wgsl).
struct Refraction {
    h: vec3<f32>,
    cos_oh: f32,
    cos_ih: f32,
    denom: f32,
    valid: bool,
}

fn refraction_half_vector(wo: vec3<f32>, wi: vec3<f32>, eta: f32) -> Refraction {
    var r = Refraction(vec3<f32>(0.0), 0.0, 0.0, 0.0, false);
    let sum = wo + eta * wi;
    if dot(sum, sum) > 0.0 {
        var h = normalize(sum);
        h = select(h, -h, h.z < 0.0);
        r.h = h;
        r.cos_oh = dot(wo, h);
        r.cos_ih = dot(wi, h);
        r.denom = r.cos_ih + r.cos_oh / eta;
        r.valid = r.cos_oh > 0.0 && r.cos_ih < 0.0 && r.denom != 0.0;
    }
    return r;
}

struct GgxReflection {
    f: f32, // D G2 / (4 cos_o cos_i), without the Fresnel factor
    pdf: f32, // D_wo(h) / (4 wo.h)
    cos_oh: f32, // wo.h, where the Fresnel factor is evaluated
}

// The lobe at (wo, wi) in the local frame; all zero unless both are above the surface.
fn ggx_reflection(wo: vec3<f32>, wi: vec3<f32>, m: Microfacet) -> GgxReflection {
    var r = GgxReflection(0.0, 0.0, 0.0);
    let sum = wo + wi;
    if wo.z > 0.0 && wi.z > 0.0 && dot(sum, sum) > 0.0 {
        let h = normalize(sum);
        let d = microfacet_d(h, m);
        r.cos_oh = max(0.0, dot(wo, h));
        r.f = d * microfacet_g2(wo, wi, m) / (4.0 * wo.z * wi.z);
        r.pdf = microfacet_g1(wo, m) * d / (4.0 * wo.z);
    }
    return r;
}
