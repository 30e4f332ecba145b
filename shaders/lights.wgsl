// lights.wgsl: the light sources, behind one interface the integrator calls (after pbrt-v4's
// Light::SampleLi / PDF_Li / L; Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §12.1).
//
// requires: features.wgsl, sampling.wgsl, rng.wgsl, intersect.wgsl
//
// A light is sampled from a reference point p (the shaded point): light_sample_li returns the radiance L
// arriving at p along a direction wi, the solid-angle density of wi, the point sampled on the light and
// its distance, and whether the light is a delta light (a point: then pdf is 1 and L already holds the
// delta's weight, I / r^2). The integrator, not the light, multiplies by the BSDF and the cosine and
// divides by the pdf, and casts the shadow ray towards p_light (spawn_ray_to, intersect.wgsl) — so any
// material can use any light, and multiple importance sampling can weigh light_pdf_li against bsdf_pdf.
// pdf == 0 means "no sample" (p inside the light, or a sample the light cannot see p from).
//
// Adding a light kind: a LIGHT_* constant (mirrored in src/kernel/abi.rs), its sample and pdf here under
// its feature constant (features.wgsl), and a row in src/kernel/features.rs.

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPHERE: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;

// One light, as uploaded (`lights` in scene_data.wgsl; GpuLight in Rust).
struct Light {
    position: vec3<f32>, // point position or sphere centre; directional: the unit direction to the light
    radius: f32, // sphere radius; directional: 1 - cos of the cone's half-angle (0 for a delta light)
    // point: radiant intensity I = P color / (4 pi) (W/sr); sphere: radiance Le = P color / (4 pi^2 r^2);
    // directional: the irradiance E color (delta) or the disc's radiance E color / (pi sin^2 a)
    intensity: vec3<f32>,
    kind: u32,
    sphere_index: u32, // for sphere lights: the index of its emitter sphere in `spheres`
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
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
}

fn no_light_sample() -> LightLiSample {
    return LightLiSample(vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, vec3<f32>(0.0), 0.0, false);
}

// Whether next-event estimation samples sphere lights at all with this strategy (with "none", emission
// found by BSDF-sampled rays is what lights the scene).
fn sphere_lights_sampled(strategy: u32) -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return strategy != LIGHT_SAMPLING_NONE;
    }
    return !LIGHT_SAMPLING_IS_NONE;
}

// Whether light samples and BSDF-sampled hits of sphere lights are combined by multiple importance
// sampling ("mis"; its light samples are the cone's).
fn sphere_lights_mis(strategy: u32) -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return strategy == LIGHT_SAMPLING_MIS;
    }
    return LIGHT_SAMPLING_IS_MIS;
}

// --- Point light -------------------------------------------------------------------------------------
// Intensity I (W/sr) at `position`: irradiance I cos(theta) / r^2 on a surface at distance r. Delta in
// position, so pdf = 1 and L = I / r^2.
fn point_light_sample(light: Light, p: vec3<f32>) -> LightLiSample {
    let to_light = light.position - p;
    let d2 = dot(to_light, to_light);
    if d2 == 0.0 {
        return no_light_sample();
    }
    let dist = sqrt(d2);
    return LightLiSample(light.intensity / d2, to_light / dist, 1.0, light.position, dist, true);
}

// --- Directional light (a sun) -------------------------------------------------------------------------
// From infinitely far: every point sees it along the same directions. A delta light (radius = 0) arrives
// along `position` with L = E (pdf 1); a sun of angular radius a fills the cone of half-angle a around
// it with radiance Le, sampled uniformly in that cone (pdf 1 / (2 pi (1 - cos a))), so that
// L cos / pdf averages to Le pi sin^2(a) cos = E cos on a surface whose horizon the cone clears.
// The two numbers are drawn in both cases (so that later dimensions line up).
fn directional_light_sample(light: Light, u: vec2<f32>) -> LightLiSample {
    if light.radius == 0.0 {
        return LightLiSample(light.intensity, light.position, 1.0, vec3<f32>(0.0), T_MISS, true);
    }
    let cone = sample_cone_local(light.radius, u);
    let wi = frame_to_world(frame_from_normal(light.position), cone.local);
    return LightLiSample(light.intensity, wi, cone_pdf(cone.one_minus_cos, light.radius), vec3<f32>(0.0),
                         T_MISS, false);
}

// Whether direction w (unit) lies in a directional light's cone (never, for a delta light).
fn directional_light_covers(light: Light, w: vec3<f32>) -> bool {
    let delta = w - light.position;
    return light.radius > 0.0 && 0.5 * dot(delta, delta) <= light.radius;
}

// --- Sphere light, cone strategy ---------------------------------------------------------------------
// A direction uniform in the cone the sphere subtends from p (pdf 1 / (2 pi (1 - cos theta_max)) per
// sr, sampling.wgsl's sample_cone_local): every direction in it sees the sphere, so no sample is wasted,
// and L = Le on all of them. The point on the sphere where wi meets it, which shadow rays aim at, comes
// from the sampled angle rather than from intersecting the ray (which loses the point at the cone's rim
// to rounding): with D = |c - p|, sin(theta_max) = r / D and theta the sampled angle from the axis, the
// near root t = D cos(theta) - sqrt(r^2 - D^2 sin^2(theta)) puts the point's normal at the angle alpha
// from -axis with cos(alpha) = (D - t cos(theta)) / r = sin^2(theta) / sin(theta_max)
// + cos(theta) sqrt(1 - sin^2(theta) / sin^2(theta_max)) (pbrt-v4 §6.2.4 derives the same), in the
// plane of the axis and wi. The point c + r n is then on the sphere to rounding, whatever the error in
// alpha.
fn sphere_light_sample_cone(light: Light, p: vec3<f32>, u: vec2<f32>) -> LightLiSample {
    let to_center = light.position - p;
    let d2 = dot(to_center, to_center);
    let r = light.radius;
    if d2 <= r * r {
        return no_light_sample(); // inside the light: it does not illuminate its own interior
    }
    let dc = sqrt(d2);
    let axis = to_center / dc;
    let omc_max = sphere_cone_one_minus_cos(r, d2);
    let cone = sample_cone_local(omc_max, u);
    let frame = frame_from_normal(axis);
    let wi = frame_to_world(frame, cone.local);
    let cos_t = cone.local.z;
    let sin2_t = cone.sin2;
    let sin_max = min(1.0, r / dc);
    let ratio = min(1.0, sin2_t / (sin_max * sin_max));
    let cos_alpha = min(1.0, sin2_t / sin_max + cos_t * sqrt(1.0 - ratio));
    let sin_alpha = sqrt(max(0.0, 1.0 - cos_alpha * cos_alpha));
    let n_light = frame_to_world(frame, vec3<f32>(sin_alpha * cone.cos_phi, sin_alpha * cone.sin_phi,
                                                  -cos_alpha));
    let p_light = light.position + r * n_light;
    return LightLiSample(light.intensity, wi, cone_pdf(cone.one_minus_cos, omc_max), p_light,
                         length(p_light - p), false);
}

// --- Sphere light, area strategy (the course's method) -----------------------------------------------
// A point x_l = c + R m on the hemisphere of the light that faces p, with m cosine-distributed about
// a = (p - c)/|p - c|: density per unit area pdf_A = (m . a) / (pi R^2), per unit solid angle at p
// pdf = pdf_A d^2 / cos(theta_l), with d = |x_l - p| and theta_l the angle at x_l between m and the
// direction back to p. Every point of the sphere visible from p lies on that hemisphere, and a point of it
// with cos(theta_l) <= 0 is hidden by the sphere itself, so the estimate is unbiased. Compared with the
// cone it wastes the samples near the hemisphere's rim that p cannot see, and its pdf varies across the
// light: more noise, most of all when p is close to the light.
fn sphere_light_sample_area(light: Light, p: vec3<f32>, u: vec2<f32>) -> LightLiSample {
    let to_p = p - light.position;
    let dc2 = dot(to_p, to_p);
    let r = light.radius;
    if dc2 <= r * r {
        return no_light_sample();
    }
    let axis = to_p / sqrt(dc2);
    let m = sample_cosine_hemisphere(axis, u);
    let cos_m = dot(m, axis);
    let x_l = light.position + r * m;
    let to_light = x_l - p;
    let d2 = dot(to_light, to_light);
    let d = sqrt(d2);
    let wi = to_light / d;
    let cos_l = -dot(m, wi);
    if cos_l <= 0.0 || cos_m <= 0.0 {
        return no_light_sample();
    }
    let pdf = cos_m * d2 / (PI * r * r * cos_l);
    return LightLiSample(light.intensity, wi, pdf, x_l, d, false);
}

// The density sphere_light_sample_area gives direction wi from p (0 if wi misses the sphere).
fn sphere_light_pdf_area(light: Light, p: vec3<f32>, wi: vec3<f32>) -> f32 {
    let r = light.radius;
    let t = intersect_sphere(p, wi, light.position, r, 0.0, T_MISS);
    if t == T_MISS {
        return 0.0;
    }
    let x_l = p + t * wi;
    let m = (x_l - light.position) / r;
    let to_p = p - light.position;
    let cos_m = dot(m, to_p) / length(to_p);
    let cos_l = -dot(m, wi);
    if cos_l <= 0.0 || cos_m <= 0.0 {
        return 0.0;
    }
    return cos_m * t * t / (PI * r * r * cos_l);
}

// The density sphere_light_sample_cone gives direction wi from p: uniform over the directions that
// meet the sphere (decided by intersecting the ray, as for a BSDF-sampled ray that found the light; at the
// cone's rim the two tests can disagree by rounding, on a set of directions of negligible measure).
fn sphere_light_pdf_cone(light: Light, p: vec3<f32>, wi: vec3<f32>) -> f32 {
    let to_center = light.position - p;
    let d2 = dot(to_center, to_center);
    if d2 <= light.radius * light.radius {
        return 0.0;
    }
    if intersect_sphere(p, wi, light.position, light.radius, 0.0, T_MISS) == T_MISS {
        return 0.0;
    }
    return 1.0 / (TWO_PI * sphere_cone_one_minus_cos(light.radius, d2));
}

// The strategy's sample: read from params by the generic kernel (LIGHT_SAMPLING_FROM_PARAMS), fixed by a
// constant in a specialised one. Every guard is a bare constant, so pruning keeps only the strategy used.
fn sphere_light_sample(light: Light, p: vec3<f32>, strategy: u32, u: vec2<f32>) -> LightLiSample {
    var ls = no_light_sample();
    if LIGHT_SAMPLING_FROM_PARAMS {
        if strategy == LIGHT_SAMPLING_AREA {
            ls = sphere_light_sample_area(light, p, u);
        } else if strategy != LIGHT_SAMPLING_NONE {
            ls = sphere_light_sample_cone(light, p, u); // cone, and the light half of mis
        }
    }
    if LIGHT_SAMPLING_IS_AREA {
        ls = sphere_light_sample_area(light, p, u);
    }
    if LIGHT_SAMPLING_IS_CONE {
        ls = sphere_light_sample_cone(light, p, u);
    }
    if LIGHT_SAMPLING_IS_MIS {
        ls = sphere_light_sample_cone(light, p, u);
    }
    return ls;
}

fn sphere_light_pdf(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    var pdf = 0.0;
    if LIGHT_SAMPLING_FROM_PARAMS {
        if strategy == LIGHT_SAMPLING_AREA {
            pdf = sphere_light_pdf_area(light, p, wi);
        } else if strategy != LIGHT_SAMPLING_NONE {
            pdf = sphere_light_pdf_cone(light, p, wi);
        }
    }
    if LIGHT_SAMPLING_IS_AREA {
        pdf = sphere_light_pdf_area(light, p, wi);
    }
    if LIGHT_SAMPLING_IS_CONE {
        pdf = sphere_light_pdf_cone(light, p, wi);
    }
    if LIGHT_SAMPLING_IS_MIS {
        pdf = sphere_light_pdf_cone(light, p, wi);
    }
    return pdf;
}

// --- The dispatchers -----------------------------------------------------------------------------------
// One exit each, as in bsdf.wgsl.

// A sample of `light` seen from p. Sphere lights draw their two numbers whatever the strategy ("none"
// included), so that the numbers drawn after them are at the same dimensions in every variant.
fn light_sample_li(light: Light, p: vec3<f32>, strategy: u32, rng: ptr<function, Rng>) -> LightLiSample {
    var ls = no_light_sample();
    if HAS_POINT_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_POINT {
            ls = point_light_sample(light, p);
        }
    }
    if HAS_SPHERE_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_SPHERE {
            let u = rng_next2(rng);
            ls = sphere_light_sample(light, p, strategy, u);
        }
    }
    if HAS_DIRECTIONAL_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_DIRECTIONAL {
            ls = directional_light_sample(light, rng_next2(rng));
        }
    }
    return ls;
}

// The solid-angle density light_sample_li gives direction wi from p (0 for delta lights: no direction
// found by another strategy can be the one point).
fn light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    var pdf = 0.0;
    if HAS_SPHERE_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_SPHERE {
            pdf = sphere_light_pdf(light, p, wi, strategy);
        }
    }
    if HAS_DIRECTIONAL_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_DIRECTIONAL {
            if directional_light_covers(light, wi) {
                pdf = 1.0 / (TWO_PI * light.radius);
            }
        }
    }
    return pdf;
}

// The radiance a ray along w receives from the light when it reaches it (a sphere light's surface
// radiance for a ray that hit it; a sun's for an escaping ray inside its cone; a point light and a delta
// sun cannot be reached).
fn light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    var l = vec3<f32>(0.0);
    if HAS_SPHERE_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_SPHERE {
            l = light.intensity;
        }
    }
    if HAS_DIRECTIONAL_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_DIRECTIONAL {
            if directional_light_covers(light, w) {
                l = light.intensity;
            }
        }
    }
    return l;
}
