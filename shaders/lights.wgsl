// lights.wgsl: the light sources, behind one interface the integrator calls (after pbrt-v4's
// Light::SampleLi / PDF_Li / L; Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §12.1).
//
// requires: features.wgsl, sampling.wgsl, rng.wgsl, intersect.wgsl, bsdf.wgsl
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
// Adding a light kind: a LIGHT_* constant (mirrored in src/kernel/abi.rs), its sample and pdf here under
// its feature constant (features.wgsl), and a row in src/kernel/features.rs.

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPHERE: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
// Every emitting triangle of the scene, as one light: a sample picks one in proportion to its power.
const LIGHT_TRIANGLES: u32 = 3u;
// Light from infinity: uniform, or an equirectangular map.
const LIGHT_ENVIRONMENT: u32 = 4u;
const NO_LIGHT: u32 = 0xffffffffu;

// One light, as uploaded (`lights` in scene_data.wgsl; GpuLight in Rust).
struct Light {
    // point position or sphere centre; directional: the unit direction to the light; environment:
    // (cos, sin) of its rotation about +y
    position: vec3<f32>,
    // sphere radius; directional: 1 - cos of the cone's half-angle (0 for a delta light); triangles:
    // their total power (triangle_light_power summed)
    radius: f32,
    // point: radiant intensity I = P color / (4 pi) (W/sr); sphere: radiance Le = P color / (4 pi^2 r^2);
    // directional: the irradiance E color (delta) or the disc's radiance E color / (pi sin^2 a);
    // environment: its radiance (with a map: the map's multiplier)
    intensity: vec3<f32>,
    kind: u32,
    // sphere: the index of its emitter sphere in `spheres`; triangles: how many (`light_triangles`)
    index: u32,
    map_width: u32, // environment: the map's size in pixels; 0 x 0 without a map
    map_height: u32,
    _pad0: u32,
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
    return LightLiSample(light.intensity / d2, to_light / dist, 1.0, light.position, dist, true, NO_LIGHT);
}

// --- Directional light (a sun) -------------------------------------------------------------------------
// From infinitely far: every point sees it along the same directions. A delta light (radius = 0) arrives
// along `position` with L = E (pdf 1); a sun of angular radius a fills the cone of half-angle a around
// it with radiance Le, sampled uniformly in that cone (pdf 1 / (2 pi (1 - cos a))), so that
// L cos / pdf averages to Le pi sin^2(a) cos = E cos on a surface whose horizon the cone clears.
// The two numbers are drawn in both cases (so that later dimensions line up).
fn directional_light_sample(light: Light, u: vec2<f32>) -> LightLiSample {
    if light.radius == 0.0 {
        return LightLiSample(light.intensity, light.position, 1.0, vec3<f32>(0.0), T_MISS, true, NO_LIGHT);
    }
    let cone = sample_cone_local(light.radius, u);
    let wi = frame_to_world(frame_from_normal(light.position), cone.local);
    return LightLiSample(light.intensity, wi, cone_pdf(cone.one_minus_cos, light.radius), vec3<f32>(0.0),
                         T_MISS, false, NO_LIGHT);
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
                         length(p_light - p), false, NO_LIGHT);
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
    return LightLiSample(light.intensity, wi, pdf, x_l, d, false, NO_LIGHT);
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

// --- Emissive triangles (LIGHT_TRIANGLES) --------------------------------------------------------------
// Every emitting triangle, with its column of the alias table (src/kernel/alias.rs) that picks triangle i
// with probability pmf_i = power_i / total, power_i = area_i x mean(Le_i) x faces_i (the power up to the
// common factor pi): O(1) per sample however many triangles emit.
struct LightTriangle {
    v0: vec3<f32>,
    alias_triangle: u32,
    v1: vec3<f32>,
    keep: f32,
    v2: vec3<f32>,
    flags: u32, // MATERIAL_TWO_SIDED_EMISSION
    emission: vec3<f32>,
    triangle: u32, // its index in `triangles` (for a textured mesh's texture)
}

@group(0) @binding(13) var<storage, read> light_triangles: array<LightTriangle>;

// Below this solid angle (sr) a triangle is sampled by area: Arvo's construction loses its f32 precision
// on tiny spherical triangles, while area sampling is then nearly uniform in solid angle anyway (the
// 1 / cos and 1 / d^2 of its pdf hardly vary across the triangle). Above the upper bound (near 2 pi, a
// triangle seen from right beside it) the construction's angles degenerate. pbrt-v4 (§12.3.2) draws
// the same line at the same values.
const TRIANGLE_SPHERICAL_MIN_SR: f32 = 3.0e-4;
const TRIANGLE_SPHERICAL_MAX_SR: f32 = 6.22;

// The power of an emitting triangle up to the factor pi, as the host weighs it (upload.rs).
fn triangle_light_power(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, emission: vec3<f32>,
                        flags: u32) -> f32 {
    let area = 0.5 * length(cross(v1 - v0, v2 - v0));
    let faces = select(1.0, 2.0, (flags & MATERIAL_TWO_SIDED_EMISSION) != 0u);
    return area * (emission.x + emission.y + emission.z) * (faces / 3.0);
}

// The alias table's pick among `count` triangles: column floor(u.x count), kept if u.y < keep.
fn triangle_light_pick(count: u32, u: vec2<f32>) -> u32 {
    let j = min(u32(u.x * f32(count)), count - 1u);
    let column = light_triangles[j];
    return select(column.alias_triangle, j, u.y < column.keep);
}

// Whether the emitting side of the triangle faces p (n = (v1 - v0) x (v2 - v0) is the front), and p is
// off its plane.
fn triangle_light_faces(v0: vec3<f32>, n: vec3<f32>, flags: u32, p: vec3<f32>) -> bool {
    let side = dot(n, p - v0);
    return side > 0.0 || (side < 0.0 && (flags & MATERIAL_TWO_SIDED_EMISSION) != 0u);
}

// Solid angle the triangle subtends from p, and whether it is sampled by solid angle from there.
struct TriangleView {
    solid_angle: f32,
    spherical: bool,
}

fn triangle_view(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, p: vec3<f32>, strategy: u32) -> TriangleView {
    let omega = spherical_triangle_area(normalize(v0 - p), normalize(v1 - p), normalize(v2 - p));
    let spherical = !lights_by_area(strategy) && omega >= TRIANGLE_SPHERICAL_MIN_SR
                    && omega <= TRIANGLE_SPHERICAL_MAX_SR;
    return TriangleView(omega, spherical);
}

// A direction towards the triangle from p: uniform in the solid angle it subtends (pdf 1 / omega), or
// through a point uniform on its area (pdf_A = 1 / A, per unit solid angle d^2 / (A |cos theta_l|)).
// The caller has checked triangle_light_faces. L is the emitted radiance; the pdf does not include the
// triangle's pick.
fn triangle_light_sample(t: LightTriangle, p: vec3<f32>, strategy: u32, u: vec2<f32>) -> LightLiSample {
    let n = cross(t.v1 - t.v0, t.v2 - t.v0);
    let view = triangle_view(t.v0, t.v1, t.v2, p, strategy);
    var ls = no_light_sample();
    if view.spherical {
        let wi = sample_spherical_triangle(normalize(t.v0 - p), normalize(t.v1 - p),
                                           normalize(t.v2 - p), view.solid_angle, u);
        // Where wi meets the triangle's plane: the point the shadow ray aims at.
        let dist = dot(n, t.v0 - p) / dot(n, wi);
        if dist > 0.0 {
            ls = LightLiSample(t.emission, wi, 1.0 / view.solid_angle, p + dist * wi, dist, false, NO_LIGHT);
        }
    } else {
        let b = sample_uniform_triangle(u);
        let x = b.x * t.v0 + b.y * t.v1 + b.z * t.v2;
        let to_light = x - p;
        let d2 = dot(to_light, to_light);
        let dist = sqrt(d2);
        let wi = to_light / dist;
        let len_n = length(n);
        let cos_l = abs(dot(n, wi)) / len_n;
        if cos_l > 0.0 && dist > 0.0 {
            // A = |n| / 2.
            ls = LightLiSample(t.emission, wi, 2.0 * d2 / (len_n * cos_l), x, dist, false, NO_LIGHT);
        }
    }
    return ls;
}

// The solid-angle density triangle_light_sample gives direction wi from p, for a wi that meets the
// triangle (not including the pick; 0 if its emitting side does not face p).
fn triangle_light_pdf(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, flags: u32, p: vec3<f32>,
                      wi: vec3<f32>, strategy: u32) -> f32 {
    let n = cross(v1 - v0, v2 - v0);
    var pdf = 0.0;
    if lights_sampled(strategy) && triangle_light_faces(v0, n, flags, p) {
        let view = triangle_view(v0, v1, v2, p, strategy);
        if view.spherical {
            pdf = 1.0 / view.solid_angle;
        } else {
            let cos_n = abs(dot(n, wi)); // |n| cos theta_l
            let dist = dot(n, v0 - p) / dot(n, wi);
            if cos_n > 0.0 {
                pdf = 2.0 * dist * dist / cos_n;
            }
        }
    }
    return pdf;
}

// A sample of the emitting triangles from p: one picked by the alias table (two numbers), then a direction
// towards it (two more; all four drawn whatever happens, so that later dimensions line up). pdf is the
// density of wi including the pick's probability.
fn triangle_lights_sample(light: Light, p: vec3<f32>, strategy: u32,
                          rng: ptr<function, Rng>) -> LightLiSample {
    let u_pick = rng_next2(rng);
    let u = rng_next2(rng);
    var ls = no_light_sample();
    if lights_sampled(strategy) {
        let t = light_triangles[triangle_light_pick(light.index, u_pick)];
        let n = cross(t.v1 - t.v0, t.v2 - t.v0);
        if triangle_light_faces(t.v0, n, t.flags, p) {
            ls = triangle_light_sample(t, p, strategy, u);
            ls.triangle = t.triangle;
            ls.pdf *= triangle_light_power(t.v0, t.v1, t.v2, t.emission, t.flags) / light.radius;
        }
    }
    return ls;
}

// --- Environment light (LIGHT_ENVIRONMENT) ---------------------------------------------------------------
// Radiance arriving from infinitely far: uniform (`intensity`), or `intensity` times an equirectangular
// map laid out as Mitsuba 3's `envmap` (src/scene/environment.rs states the convention: u from
// atan2(x, -z), v = theta / pi, pixel columns at u = (k + 1/2) / W, rows at v = j / (H - 1), bilinear
// between them). Sampled uniformly over the sphere without a map (pdf 1 / (4 pi)); with one, a cell of
// the (H - 1) x W grid between pixel samples from the tabulated 2-D distribution (its probability P, by
// the marginal CDF over rows then the row's CDF over columns), uniformly within it:
// pdf(u, v) = P W (H - 1), and per unit solid angle pdf(u, v) / (2 pi^2 sin theta).

// The map's RGB radiance, three floats per pixel, rows from the top; and its distribution: the H - 1
// values of the CDF over rows, then per row the W values of its CDF over columns (environment.rs).
@group(0) @binding(14) var<storage, read> env_texels: array<f32>;
@group(0) @binding(15) var<storage, read> env_cdf: array<f32>;

// World direction -> the map's frame (the inverse of the rotation by the light's angle about +y), and back.
fn env_to_map(light: Light, w: vec3<f32>) -> vec3<f32> {
    let c = light.position.x;
    let s = light.position.y;
    return vec3<f32>(c * w.x - s * w.z, w.y, s * w.x + c * w.z);
}

fn env_to_world(light: Light, m: vec3<f32>) -> vec3<f32> {
    let c = light.position.x;
    let s = light.position.y;
    return vec3<f32>(c * m.x + s * m.z, m.y, -s * m.x + c * m.z);
}

fn env_uv(m: vec3<f32>) -> vec2<f32> {
    let u = atan2(m.x, -m.z) / TWO_PI;
    return vec2<f32>(u - floor(u), acos(clamp(m.y, -1.0, 1.0)) * INV_PI);
}

fn env_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = TWO_PI * uv.x;
    let theta = PI * uv.y;
    let st = sin(theta);
    return vec3<f32>(st * sin(phi), cos(theta), -st * cos(phi));
}

// The cell of (u, v) (column k, row j of cells) and the position inside it, in [0, 1]^2.
struct EnvCell {
    k: u32,
    j: u32,
    f: vec2<f32>,
}

fn env_cell(light: Light, uv: vec2<f32>) -> EnvCell {
    let w = f32(light.map_width);
    let x = fract(uv.x - 0.5 / w) * w;
    let y = uv.y * f32(light.map_height - 1u);
    let k = min(u32(x), light.map_width - 1u);
    let j = min(u32(y), light.map_height - 2u);
    return EnvCell(k, j, vec2<f32>(x - f32(k), y - f32(j)));
}

fn env_texel(light: Light, k: u32, j: u32) -> vec3<f32> {
    let i = 3u * (j * light.map_width + k);
    return vec3<f32>(env_texels[i], env_texels[i + 1u], env_texels[i + 2u]);
}

// The map's bilinear radiance in cell `cell` (columns wrap around).
fn env_map_radiance(light: Light, cell: EnvCell) -> vec3<f32> {
    let k1 = select(cell.k + 1u, 0u, cell.k + 1u == light.map_width);
    let top = mix(env_texel(light, cell.k, cell.j), env_texel(light, k1, cell.j), cell.f.x);
    let bottom = mix(env_texel(light, cell.k, cell.j + 1u), env_texel(light, k1, cell.j + 1u), cell.f.x);
    return mix(top, bottom, cell.f.y);
}

// The CDF value before entry i of the CDF that starts at env_cdf[first]: 0 for i = 0. (select evaluates
// both of its values, and the kernel's buffer accesses are not bounds-checked, so the index must stay in
// the buffer either way.)
fn env_cdf_before(first: u32, i: u32) -> f32 {
    return select(0.0, env_cdf[first + max(i, 1u) - 1u], i > 0u);
}

// The probability of cell (k, j), from its CDFs.
fn env_cell_probability(light: Light, k: u32, j: u32) -> f32 {
    let rows = light.map_height - 1u;
    let p_row = env_cdf[j] - env_cdf_before(0u, j);
    let base = rows + j * light.map_width;
    let p_col = env_cdf[base + k] - env_cdf_before(base, k);
    return p_row * p_col;
}

// The first of the `count` CDF values from env_cdf[first] that exceeds u (binary search; the last is 1).
fn env_cdf_search(first: u32, count: u32, u: f32) -> u32 {
    var lo = 0u;
    var hi = count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if env_cdf[first + mid] > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

fn has_env_map(light: Light) -> bool {
    if HAS_ENVIRONMENT_MAP {
        return light.map_width > 0u;
    }
    return false;
}

// The radiance arriving along -w, i.e. seen looking in direction w.
fn environment_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    var l = light.intensity;
    if has_env_map(light) {
        l *= env_map_radiance(light, env_cell(light, env_uv(env_to_map(light, w))));
    }
    return l;
}

fn environment_pdf(light: Light, w: vec3<f32>) -> f32 {
    var pdf = 1.0 / (4.0 * PI);
    if has_env_map(light) {
        let m = env_to_map(light, w);
        let sin_theta = length(m.xz); // not sqrt(1 - y^2), which is 0 in f32 within 3e-4 rad of a pole
        let cell = env_cell(light, env_uv(m));
        let cells = f32(light.map_width * (light.map_height - 1u));
        pdf = select(0.0, env_cell_probability(light, cell.k, cell.j) * cells / (2.0 * PI * PI * sin_theta),
                     sin_theta > 0.0);
    }
    return pdf;
}

// A direction to the environment (two numbers: the row and the column, each reused within its cell).
fn environment_sample(light: Light, strategy: u32, u: vec2<f32>) -> LightLiSample {
    var ls = no_light_sample();
    if lights_sampled(strategy) {
        if has_env_map(light) {
            let rows = light.map_height - 1u;
            let w = light.map_width;
            let j = env_cdf_search(0u, rows, u.x);
            let row_lo = env_cdf_before(0u, j);
            let fy = clamp((u.x - row_lo) / (env_cdf[j] - row_lo), 0.0, 1.0);
            let base = rows + j * w;
            let k = env_cdf_search(base, w, u.y);
            let col_lo = env_cdf_before(base, k);
            let fx = clamp((u.y - col_lo) / (env_cdf[base + k] - col_lo), 0.0, 1.0);
            let uv = vec2<f32>(fract((f32(k) + 0.5 + fx) / f32(w)), (f32(j) + fy) / f32(rows));
            let m = env_direction(uv);
            let sin_theta = sin(PI * uv.y);
            let p = env_cell_probability(light, k, j) * f32(w * rows);
            if sin_theta > 0.0 && p > 0.0 {
                let l = light.intensity * env_map_radiance(light, EnvCell(k, j, vec2<f32>(fx, fy)));
                ls = LightLiSample(l, env_to_world(light, m), p / (2.0 * PI * PI * sin_theta), vec3<f32>(0.0),
                                   T_MISS, false, NO_LIGHT);
            }
        } else {
            let wi = sample_cone(vec3<f32>(0.0, 1.0, 0.0), 2.0, u);
            ls = LightLiSample(light.intensity, wi, 1.0 / (4.0 * PI), vec3<f32>(0.0), T_MISS, false, NO_LIGHT);
        }
    }
    return ls;
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
    if HAS_TRIANGLE_LIGHTS {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_TRIANGLES {
            ls = triangle_lights_sample(light, p, strategy, rng);
        }
    }
    if HAS_ENVIRONMENT {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_ENVIRONMENT {
            ls = environment_sample(light, strategy, rng_next2(rng));
        }
    }
    return ls;
}

// The solid-angle density light_sample_li gives direction wi from p (0 for delta lights: no direction
// found by another strategy can be the one point). Not for LIGHT_TRIANGLES, whose density depends on
// which triangle wi meets: triangle_light_pdf, times the triangle's pick (trace.wgsl).
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
    if HAS_ENVIRONMENT {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_ENVIRONMENT {
            pdf = select(0.0, environment_pdf(light, wi), lights_sampled(strategy));
        }
    }
    return pdf;
}

// The radiance a ray along w receives from the light when it reaches it (a sphere light's surface
// radiance for a ray that hit it; a sun's for an escaping ray inside its cone, the environment's for
// any escaping ray; a point light and a delta sun cannot be reached; triangles: see material_emission).
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
    if HAS_ENVIRONMENT {
        if SINGLE_LIGHT_KIND || light.kind == LIGHT_ENVIRONMENT {
            l = environment_radiance(light, w);
        }
    }
    return l;
}
