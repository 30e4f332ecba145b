// lights/triangles.wgsl: every emitting triangle of the scene, as one light.
//
// requires: lights/common.wgsl

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
// Its uniform twin (scene_data.wgsl, "Uniform twins"): 65536 / 64 bytes.
@group(0) @binding(45) var<uniform> light_triangles_uniform: array<LightTriangle, 1024>;

fn light_triangle_at(i: u32) -> LightTriangle {
    if UNIFORM_LIGHT_TRIANGLES {
        return light_triangles_uniform[i];
    } else {
        return light_triangles[i];
    }
}

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
    let column = light_triangle_at(j);
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
        let t = light_triangle_at(triangle_light_pick(light.index, u_pick));
        let n = cross(t.v1 - t.v0, t.v2 - t.v0);
        if triangle_light_faces(t.v0, n, t.flags, p) {
            ls = triangle_light_sample(t, p, strategy, u);
            ls.triangle = t.triangle;
            ls.pdf *= triangle_light_power(t.v0, t.v1, t.v2, t.emission, t.flags) / light.radius;
        }
    }
    return ls;
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

fn triangles_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                             rng: ptr<function, Rng>) -> LightLiSample {
    return triangle_lights_sample(light, p, strategy, rng);
}

// Not from here: the density depends on which triangle wi meets, so the integrator computes it from the
// hit (triangle_light_pdf times the triangle's pick: trace.wgsl).
fn triangles_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    return 0.0;
}

// Not from here either: a ray that hits an emitting triangle sees its material's emission
// (material_emission, bsdfs/common.wgsl).
fn triangles_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}
