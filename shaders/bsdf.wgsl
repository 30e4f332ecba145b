// bsdf.wgsl: the materials, behind one interface the integrator calls (after pbrt-v4's BSDF::Sample_f,
// f and PDF; Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §9.1).
//
// requires: features.wgsl, sampling.wgsl, rng.wgsl
//
// Conventions. Directions point away from the surface: wo towards where the light goes (the previous
// path vertex), wi towards where it comes from. `ns` is the unit shading normal on wo's side (the caller
// flips it; a smooth mesh's interpolated normal, else the geometric normal), and `entering` says whether
// wo is on the outside of the surface (for a dielectric: which index is on which side). Every material
// has three functions, dispatched on `Material::kind` by bsdf_sample / bsdf_eval / bsdf_pdf below:
//  * <kind>_sample(mat, wo, ns, entering, rng): an incident direction wi drawn with density pdf(wi), and
//    the weight f(wo, wi) |cos theta_i| / pdf(wi) that the path throughput is multiplied by. A material
//    draws from the generator only the numbers it needs (diffuse two, dielectric one, mirror none), so
//    that every later dimension of the path is drawn at the same index whichever materials it met.
//  * <kind>_eval(mat, wo, wi, ns): f(wo, wi) in sr^-1 (0 for a delta lobe: a given direction has zero
//    probability of being the mirror direction).
//  * <kind>_pdf(mat, wo, wi, ns): the solid-angle density bsdf_sample draws wi with (0 for delta lobes).
// A delta (specular) sample has BSDF_DELTA set: its `pdf` is then the discrete probability of the lobe
// chosen (1 for a mirror, F or 1 - F for glass) rather than a density, and next-event estimation skips
// the vertex (bsdf_is_delta).
//
// Adding a material: a MAT_* constant (mirrored in src/kernel/abi.rs), its three functions here, one line
// in each dispatcher under its feature constant (features.wgsl), and a row in src/kernel/features.rs.

const MAT_DIFFUSE: u32 = 0u;
const MAT_MIRROR: u32 = 1u;
const MAT_DIELECTRIC: u32 = 2u;
// The `emitter` material (a lamp's surface, and a sphere light's): emits `emission`, scatters nothing
// (a path ends there).
const MAT_EMITTER: u32 = 3u;

// Material::flags: emission leaves both faces, not only the front.
const MATERIAL_TWO_SIDED_EMISSION: u32 = 1u;

// One material's parameters, as uploaded (`materials` in scene_data.wgsl; GpuMaterial in Rust).
struct Material {
    albedo: vec3<f32>, // diffuse albedo or mirror tint (a texture replaces it per hit)
    kind: u32,
    emission: vec3<f32>, // emitted radiance, W sr^-1 m^-2 (any kind may emit; zero: it does not)
    ior: f32, // dielectric: index of refraction inside over outside
    flags: u32, // MATERIAL_TWO_SIDED_EMISSION
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
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
// f = albedo / pi on the hemisphere of ns. Sampled cosine-weighted, pdf = cos(theta_i) / pi, so that
// f cos / pdf = albedo: the weight does not depend on the direction.

fn diffuse_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>, rng: ptr<function, Rng>) -> BsdfSample {
    let wi = sample_cosine_hemisphere(ns, rng_next2(rng));
    return BsdfSample(wi, mat.albedo, cosine_hemisphere_pdf(dot(wi, ns)), BSDF_REFLECTION);
}

fn diffuse_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> vec3<f32> {
    if dot(wi, ns) <= 0.0 {
        return vec3<f32>(0.0);
    }
    return mat.albedo * INV_PI;
}

fn diffuse_pdf(wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> f32 {
    return cosine_hemisphere_pdf(dot(wi, ns));
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

// --- The dispatchers -------------------------------------------------------------------------------
// Each material's branch sits under its feature constant, so a kernel specialised for a scene keeps only
// the materials the scene uses; with one material kind (SINGLE_MATERIAL_KIND) the kind test goes too.
// Emitters (and any kind the kernel was specialised without) absorb. Each dispatcher has one exit: on
// lavapipe, whose invocations run as SIMD lanes, a return inside a branch costs mask bookkeeping at every
// later statement.

fn bsdf_sample(mat: Material, wo: vec3<f32>, ns: vec3<f32>, entering: bool,
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
    return s;
}

fn bsdf_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> vec3<f32> {
    var f = vec3<f32>(0.0); // delta lobes and emitters
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            f = diffuse_eval(mat, wo, wi, ns);
        }
    }
    return f;
}

fn bsdf_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, ns: vec3<f32>) -> f32 {
    var pdf = 0.0; // delta lobes and emitters
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            pdf = diffuse_pdf(wo, wi, ns);
        }
    }
    return pdf;
}

// Whether the material has only delta lobes (or none): next-event estimation cannot help there, since
// bsdf_eval is 0 for every direction a light sample could give.
fn bsdf_is_delta(mat: Material) -> bool {
    var delta = true;
    if HAS_DIFFUSE {
        if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
            delta = false;
        }
    }
    return delta;
}
