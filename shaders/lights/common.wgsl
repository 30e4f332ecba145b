// lights/common.wgsl: what every light kind shares, behind one interface the integrator calls (after
// pbrt-v4's Light::SampleLi / PDF_Li / L; Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th
// ed., §12.1).
//
// requires: features.wgsl, light_kinds.wgsl, sampling.wgsl, rng.wgsl, intersect.wgsl, bsdf.wgsl
//
// A light is sampled from a reference point p (the shaded point): light_sample_li returns the radiance L
// arriving at p along a direction wi, the solid-angle density of wi, the point sampled on the light and
// its distance, and whether the light is a delta light (a point: then pdf is 1 and L already holds the
// delta's weight, I / r^2). The integrator, not the light, multiplies by the BSDF and the cosine and
// divides by the pdf, and casts the shadow ray towards p_light (spawn_ray_to, intersect.wgsl) — so any
// material can use any light, and multiple importance sampling can weigh light_pdf_li against bsdf_pdf.
// pdf == 0 means "no sample" (p inside the light, or a sample the light cannot see p from).
//
// Which lights are sampled, and how, is the strategy (`render.light_sampling`): "cone" and "area" sample
// every light (light sampling only: emission that a BSDF-sampled ray finds counts only where the light
// could not have been sampled), "none" samples only the delta lights (point lights and delta suns, which
// nothing else can find), "mis" samples every light and weighs its samples against BSDF sampling by the
// power heuristic (trace.wgsl). "cone" and "area" differ for sphere lights (the cone they subtend, or
// their visible cap by area) and emissive triangles (by solid angle or by area).
//
// Each kind is a file, lights/<kind>.wgsl, with three functions: <kind>_light_sample_li(light, p,
// strategy, rng) -> LightLiSample (drawing its own numbers), <kind>_light_pdf_li(light, p, wi, strategy)
// -> f32 (the solid-angle density its sample gives wi; 0 for a delta light and for a kind whose density
// the integrator computes itself) and <kind>_light_radiance(light, w) -> vec3<f32> (what a ray along w
// receives on reaching it; 0 for a light no ray can reach). The dispatchers the integrator calls
// (light_sample_li, light_pdf_li, light_radiance in lights.wgsl), the LIGHT_* constants and the HAS_*
// overrides (light_kinds.wgsl) are generated from the light registry (src/kernel/light_kinds.rs).
// Adding a light kind: its file and a row there; its uploads (src/kernel/upload.rs) and scene keys.


const NO_LIGHT: u32 = 0xffffffffu;

// One light, as uploaded (`lights` in scene_data.wgsl; GpuLight in Rust).
struct Light {
    // point position or sphere centre; directional: the unit direction to the light; environment:
    // (cos, sin) of its rotation about +y
    position: vec3<f32>,
    // sphere radius; directional: 1 - cos of the cone's half-angle (0 for a delta light); triangles:
    // their total power (triangle_light_power summed)
    radius: f32,
    // point: radiant intensity I = P color / (4 pi) (W/sr); spot: I on its axis; sphere: radiance Le = P color / (4 pi^2 r^2);
    // directional: the irradiance E color (delta) or the disc's radiance E color / (pi sin^2 a);
    // environment: its radiance (with a map: the map's multiplier)
    intensity: vec3<f32>,
    kind: u32,
    // sphere: the index of its emitter sphere in `spheres`; triangles: how many (`light_triangles`)
    index: u32,
    map_width: u32, // environment: the map's size in pixels; 0 x 0 without a map
    map_height: u32,
    spot_falloff: u32, // spot: 0 linear in the angle (Mitsuba's), 1 smooth (glTF's)
    // spot: the unit axis its cone opens around, 1 / (cutoff - beam) (the angles in radians; smooth:
    // 1 / max(0.001, cos beam - cos cutoff)), and (cos, sin) of the cutoff and of the beam half-angles
    // (lights/spot.wgsl)
    axis: vec3<f32>,
    spot_inv_width: f32,
    spot_cone: vec4<f32>,
}

// How sphere lights are sampled (params.light_sampling, `render.light_sampling`): read from params by
// the generic kernel, a constant when specialised (the other strategies' code is then pruned).
const LIGHT_SAMPLING_CONE: u32 = 0u;
const LIGHT_SAMPLING_AREA: u32 = 1u;
const LIGHT_SAMPLING_NONE: u32 = 2u;
// Multiple importance sampling: the cone's sample weighted against the BSDF's (trace.wgsl).
const LIGHT_SAMPLING_MIS: u32 = 3u;
override LIGHT_SAMPLING_FROM_PARAMS: bool = true;
override LIGHT_SAMPLING_IS_AREA: bool = false;
override LIGHT_SAMPLING_IS_NONE: bool = false;
override LIGHT_SAMPLING_IS_CONE: bool = false;
override LIGHT_SAMPLING_IS_MIS: bool = false;

struct LightLiSample {
    L: vec3<f32>, // radiance arriving at p along wi (point light: I / r^2)
    wi: vec3<f32>, // unit, from p towards p_light
    pdf: f32, // per unit solid angle; 1 for a delta light; 0: no sample
    p_light: vec3<f32>, // the point on the light the shadow ray aims at
    dist: f32, // |p_light - p|; T_MISS for a light at infinity (the shadow ray goes along wi, unbounded)
    delta: bool,
    // LIGHT_TRIANGLES: the triangle sampled (its index in `triangles`), whose texture, if any, the
    // integrator applies to L (trace.wgsl); NO_LIGHT for every other light.
    triangle: u32,
}

fn no_light_sample() -> LightLiSample {
    return LightLiSample(vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, vec3<f32>(0.0), 0.0, false, NO_LIGHT);
}

// Whether next-event estimation samples the non-delta lights at all with this strategy (with "none",
// emission found by BSDF-sampled rays is what lights the scene).
fn lights_sampled(strategy: u32) -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return strategy != LIGHT_SAMPLING_NONE;
    }
    return !LIGHT_SAMPLING_IS_NONE;
}

// Whether light samples and BSDF-sampled hits of lights are combined by multiple importance sampling
// ("mis"; its light samples are the cone's, and the solid angle's for triangles).
fn lights_mis(strategy: u32) -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return strategy == LIGHT_SAMPLING_MIS;
    }
    return LIGHT_SAMPLING_IS_MIS;
}

// Whether the strategy samples by area ("area") rather than by solid angle.
fn lights_by_area(strategy: u32) -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return strategy == LIGHT_SAMPLING_AREA;
    }
    return LIGHT_SAMPLING_IS_AREA;
}

// The weight of emission that a BSDF-sampled ray (direction density bsdf_pdf) found, where the light's
// own sampling from the ray's origin has density light_pdf for the same direction. With "mis", the power
// heuristic (the light sample's weight is the complement, trace.wgsl); with light sampling alone, 0 where
// the light could have been sampled (its sample counted instead) and 1 where it could not (inside a
// sphere light, say); with "none", 1.
fn emission_weight(bsdf_pdf: f32, light_pdf: f32, strategy: u32) -> f32 {
    var w = 1.0;
    if lights_sampled(strategy) {
        if lights_mis(strategy) {
            w = power_heuristic(bsdf_pdf, light_pdf);
        } else {
            w = select(0.0, 1.0, light_pdf == 0.0);
        }
    }
    return w;
}
