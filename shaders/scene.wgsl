// scene.wgsl: closest-hit and visibility queries over the scene buffers (scene_data.wgsl), and direct
// lighting, with the override constants that specialise them.

// --- Specialisation ---------------------------------------------------------------------------------
// Pipeline-overridable constants, one per feature a scene may or may not use. The generic kernel keeps
// the defaults (everything on); for a given scene the host sets each from the scene's feature set
// (src/gpu/features.rs), naga folds them into constants, and src/gpu/shader.rs prunes every
// `if FEATURE { ... }` whose condition became `false` before the SPIR-V is written: an absent feature
// leaves no code at all. Guards are written `if HAS_X { if runtime_test { ... } }` so that the outer
// condition is a bare constant. A present feature runs exactly the generic code, so both kernels give
// the same bits.
override HAS_SPHERES: bool = true;
override HAS_TRIANGLES: bool = true;
// Triangles are found through the BVH (bvh.wgsl) when the scene has one (more than 16 triangles: the
// host uploads no nodes for fewer, and the generic kernel then finds `bvh_nodes` empty); otherwise by a
// loop over every triangle, which is also the reference the BVH is tested and benchmarked against.
override HAS_BVH: bool = true;
override HAS_TRIANGLE_LOOP: bool = true;
// Meshes: interpolated vertex normals, albedo textures, and either (the per-triangle shading data).
override HAS_SMOOTH_NORMALS: bool = true;
override HAS_TEXTURES: bool = true;
override HAS_MESH_SHADING: bool = true;
override HAS_DIFFUSE: bool = true;
override HAS_MIRROR: bool = true;
override HAS_DIELECTRIC: bool = true;
override HAS_EMITTERS: bool = true; // sphere lights are visible spheres with an emitting material
override HAS_POINT_LIGHTS: bool = true;
override HAS_SPHERE_LIGHTS: bool = true;
override HAS_LENS: bool = true; // aperture > 0
override HAS_ROULETTE: bool = true;
override HAS_BACKGROUND: bool = true;
// Exactly one material kind (counting emitters) / one light kind in the scene: the kind tests go.
override SINGLE_MATERIAL_KIND: bool = false;
override SINGLE_LIGHT_KIND: bool = false;

const PRIM_NONE: u32 = 0u;
const PRIM_SPHERE: u32 = 1u;
const PRIM_TRIANGLE: u32 = 2u;

struct Hit {
    t: f32,
    prim_kind: u32,
    prim_index: u32,
    b: vec3<f32>, // triangle barycentrics
}

// The closest intersection along the ray in (0, t_max). The origin has already been offset off its
// surface (offset_ray_origin), so t_min is 0.
fn scene_intersect(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Hit {
    var hit = Hit(t_max, PRIM_NONE, 0u, vec3<f32>(0.0));
    if HAS_SPHERES {
        for (var i = 0u; i < params.num_spheres; i++) {
            let s = spheres[i];
            let t = intersect_sphere(o, d, s.center, s.radius, 0.0, hit.t);
            if t < hit.t {
                hit = Hit(t, PRIM_SPHERE, i, vec3<f32>(0.0));
            }
        }
    }
    // Spheres first: a hit on one (a wall of the course's box, say) shortens the ray the BVH then walks.
    if HAS_BVH {
        if arrayLength(&bvh_nodes) > 0u {
            let th = bvh_intersect(o, d, hit.t, false);
            if th.prim_kind != PRIM_NONE {
                hit = th;
            }
            return hit;
        }
    }
    if HAS_TRIANGLE_LOOP {
        for (var i = 0u; i < params.num_triangles; i++) {
            let tri = triangles[i];
            let th = intersect_triangle(o, d, tri.v0, tri.v1, tri.v2, 0.0, hit.t);
            if th.t < hit.t {
                hit = Hit(th.t, PRIM_TRIANGLE, i, th.b);
            }
        }
    }
    return hit;
}

// Is anything in the way over (0, t_max)? Stops at the first blocker.
fn scene_occluded(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    if HAS_SPHERES {
        for (var i = 0u; i < params.num_spheres; i++) {
            let s = spheres[i];
            if intersect_sphere(o, d, s.center, s.radius, 0.0, t_max) < t_max {
                return true;
            }
        }
    }
    if HAS_BVH {
        if arrayLength(&bvh_nodes) > 0u {
            return bvh_intersect(o, d, t_max, true).prim_kind != PRIM_NONE;
        }
    }
    if HAS_TRIANGLE_LOOP {
        for (var i = 0u; i < params.num_triangles; i++) {
            let tri = triangles[i];
            if intersect_triangle(o, d, tri.v0, tri.v1, tri.v2, 0.0, t_max).t < t_max {
                return true;
            }
        }
    }
    return false;
}

// Surface data at a hit: position with its error bound, geometric normal (outward for spheres,
// (v1 - v0) x (v2 - v0) for triangles), material index; for meshes, the shading normal and the texture's
// albedo.
struct Surface {
    p: vec3<f32>,
    err: vec3<f32>,
    n: vec3<f32>,
    material: u32,
    // The shading normal, on the same side as n: the interpolated vertex normal when `shading_normal`, else n.
    ns: vec3<f32>,
    shading_normal: bool,
    // The texture's albedo at the hit, when `textured`: it replaces the material's albedo (or tint).
    albedo: vec3<f32>,
    textured: bool,
}

fn sphere_surface(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> Surface {
    let s = spheres[hit.prim_index];
    let sp = sphere_surface_point(o, d, hit.t, s.center, s.radius);
    let n = normalize(sp.p - s.center);
    return Surface(sp.p, sp.err, n, s.material, n, false, vec3<f32>(0.0), false);
}

fn mesh_normal(v: MeshVertex) -> vec3<f32> {
    return vec3<f32>(v.nx, v.ny, v.nz);
}

fn triangle_surface(hit: Hit) -> Surface {
    let tri = triangles[hit.prim_index];
    let sp = triangle_surface_point(tri.v0, tri.v1, tri.v2, hit.b);
    let n = normalize(cross(tri.v1 - tri.v0, tri.v2 - tri.v0));
    var s = Surface(sp.p, sp.err, n, tri.material, n, false, vec3<f32>(0.0), false);
    if HAS_MESH_SHADING {
        let face = mesh_faces[hit.prim_index];
        if face.mesh != NO_MESH {
            let mesh = meshes[face.mesh];
            let v0 = mesh_vertices[face.vertices.x];
            let v1 = mesh_vertices[face.vertices.y];
            let v2 = mesh_vertices[face.vertices.z];
            let b = hit.b;
            if HAS_SMOOTH_NORMALS {
                if (mesh.flags & MESH_SMOOTH) != 0u {
                    // Phong normal interpolation: the barycentric mix of the vertex normals, renormalised.
                    // Shared vertices give both triangles of an edge the same normal along it, so shading
                    // is continuous across edges. A mix that vanishes (opposed or missing normals) keeps
                    // the geometric normal.
                    let ns = b.x * mesh_normal(v0) + b.y * mesh_normal(v1) + b.z * mesh_normal(v2);
                    let len2 = dot(ns, ns);
                    if len2 > 1.0e-12 {
                        let unit = ns * inverseSqrt(len2);
                        s.ns = select(-unit, unit, dot(unit, n) >= 0.0);
                        s.shading_normal = true;
                    }
                }
            }
            if HAS_TEXTURES {
                if (mesh.flags & MESH_TEXTURED) != 0u {
                    let uv = b.x * vec2<f32>(v0.u, v0.v) + b.y * vec2<f32>(v1.u, v1.v)
                           + b.z * vec2<f32>(v2.u, v2.v);
                    s.albedo = texture_bilinear(mesh, uv);
                    s.textured = true;
                }
            }
        }
    }
    return s;
}

// The material index of a hit, without computing the surface point.
fn hit_material(hit: Hit) -> u32 {
    if HAS_TRIANGLES {
        if HAS_SPHERES {
            if hit.prim_kind == PRIM_SPHERE {
                return spheres[hit.prim_index].material;
            }
        }
        return triangles[hit.prim_index].material;
    }
    return spheres[hit.prim_index].material;
}

fn surface_at(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> Surface {
    if HAS_TRIANGLES {
        if HAS_SPHERES {
            if hit.prim_kind == PRIM_SPHERE {
                return sphere_surface(o, d, hit);
            }
        }
        return triangle_surface(hit);
    }
    return sphere_surface(o, d, hit);
}

// How sphere lights are sampled (params.light_sampling, `render.light_sampling`): read from params by
// the generic kernel, a constant when specialised (the other strategies' code is then pruned).
const LIGHT_SAMPLING_CONE: u32 = 0u;
const LIGHT_SAMPLING_AREA: u32 = 1u;
const LIGHT_SAMPLING_NONE: u32 = 2u;
override LIGHT_SAMPLING_FROM_PARAMS: bool = true;
override LIGHT_SAMPLING_IS_AREA: bool = false;
override LIGHT_SAMPLING_IS_NONE: bool = false;

// Whether sphere lights are sampled by next-event estimation at all.
fn sphere_lights_sampled() -> bool {
    if LIGHT_SAMPLING_FROM_PARAMS {
        return params.light_sampling != LIGHT_SAMPLING_NONE;
    }
    return !LIGHT_SAMPLING_IS_NONE;
}

// One next-event estimate of a sphere light with the configured strategy.
fn sphere_light_estimate(sp: Surface, n: vec3<f32>, ns: vec3<f32>, light: Light, u: vec2<f32>) -> vec3<f32> {
    if LIGHT_SAMPLING_FROM_PARAMS {
        switch params.light_sampling {
            case LIGHT_SAMPLING_AREA: {
                return sphere_light_irradiance_area(sp, n, ns, light, u);
            }
            case LIGHT_SAMPLING_NONE: {
                return vec3<f32>(0.0);
            }
            default: {
                return sphere_light_irradiance(sp, n, ns, light, u);
            }
        }
    }
    if LIGHT_SAMPLING_IS_AREA {
        return sphere_light_irradiance_area(sp, n, ns, light, u);
    }
    if LIGHT_SAMPLING_IS_NONE {
        return vec3<f32>(0.0);
    }
    return sphere_light_irradiance(sp, n, ns, light, u);
}

// Irradiance-like sum over all lights of Le * cos(theta) / pdf at a surface point with facing normal n
// (one sample per sphere light): the caller multiplies by the BRDF (albedo / pi).
//  * Point light of intensity I at distance r: E = I cos(theta) / r^2 (the course's formula, with
//    I = P / (4 pi)).
//  * Sphere light: sample a direction uniformly in the cone the sphere subtends (pdf 1/(2 pi (1-cos_max)));
//    the estimate Le cos(theta) / pdf is unbiased for the irradiance from the sphere, light-side cosine
//    included (the cone measure already accounts for it), and converges to the point light as r -> 0.
//
// n is the facing geometric normal and ns the facing shading normal (the same vector except on smooth
// meshes). With shading normals, a light counts only when it is above the geometric surface too (a
// shadow ray towards a light below it would start on the far side), and its cosine is the shading one.
fn direct_light(sp: Surface, n: vec3<f32>, ns: vec3<f32>, rng: ptr<function, Rng>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < params.num_lights; i++) {
        let light = lights[i];
        if HAS_POINT_LIGHTS {
            if SINGLE_LIGHT_KIND || light.kind == LIGHT_POINT {
                e += point_light_irradiance(sp, n, ns, light);
            }
        }
        if HAS_SPHERE_LIGHTS {
            if SINGLE_LIGHT_KIND || light.kind == LIGHT_SPHERE {
                // The light sample's dimension is drawn whatever the strategy, so that the numbers
                // drawn after it are at the same dimensions in every variant.
                let u = rng_next2(rng);
                e += sphere_light_estimate(sp, n, ns, light, u);
            }
        }
    }
    return e;
}

// The cosine factor of direct light arriving along wi: dot(n, wi), or with a shading normal dot(ns, wi)
// provided the light is above the geometric surface.
fn light_cosine(sp: Surface, n: vec3<f32>, ns: vec3<f32>, wi: vec3<f32>) -> f32 {
    var cos_theta = dot(n, wi);
    if HAS_SMOOTH_NORMALS {
        if sp.shading_normal && cos_theta > 0.0 {
            cos_theta = dot(ns, wi);
        }
    }
    return cos_theta;
}

fn point_light_irradiance(sp: Surface, n: vec3<f32>, ns: vec3<f32>, light: Light) -> vec3<f32> {
    let to_light = light.position - sp.p;
    let dist2 = dot(to_light, to_light);
    let dist = sqrt(dist2);
    let wi = to_light / dist;
    let cos_theta = light_cosine(sp, n, ns, wi);
    if cos_theta <= 0.0 || dist2 == 0.0 {
        return vec3<f32>(0.0);
    }
    let o = offset_ray_origin(sp.p, sp.err, n, wi);
    // Stop short of the light itself by a relative 1e-4, since a point light has no surface.
    if scene_occluded(o, wi, dist * (1.0 - 1.0e-4)) {
        return vec3<f32>(0.0);
    }
    return light.intensity * cos_theta / dist2;
}

fn sphere_light_irradiance(sp: Surface, n: vec3<f32>, ns: vec3<f32>, light: Light, u: vec2<f32>) -> vec3<f32> {
    let to_center = light.position - sp.p;
    let d2 = dot(to_center, to_center);
    if d2 <= light.radius * light.radius {
        return vec3<f32>(0.0); // inside the light: it does not illuminate its own interior
    }
    let omc = sphere_cone_one_minus_cos(light.radius, d2);
    let wi = sample_cone(to_center / sqrt(d2), omc, u);
    let cos_theta = light_cosine(sp, n, ns, wi);
    if cos_theta <= 0.0 {
        return vec3<f32>(0.0);
    }
    // Visible if the first thing the ray meets is this light's own sphere.
    let o = offset_ray_origin(sp.p, sp.err, n, wi);
    let hit = scene_intersect(o, wi, T_MISS);
    if hit.prim_kind == PRIM_SPHERE && hit.prim_index == light.sphere_index {
        return light.intensity * cos_theta * (TWO_PI * omc);
    }
    return vec3<f32>(0.0);
}

// Area sampling, the course's method: a point x_l = c + R m on the hemisphere of the light that faces the
// shaded point p, with m cosine-distributed about the axis a = (p - c)/|p - c|. Its density per unit area
// is pdf_A = (m . a) / (pi R^2), and the irradiance estimate is Le cos(theta) cos(theta_l) / (d^2 pdf_A),
// with d = |x_l - p| and theta_l the angle at x_l between m and the direction back to p. Every point of the
// sphere visible from p lies on that hemisphere, and a point of it with cos(theta_l) <= 0 is hidden by the
// sphere itself (for a sphere, visible from p exactly when m . (p - x_l) > 0), so the estimate is unbiased.
// Compared with cone sampling it wastes the samples near the hemisphere's rim that p cannot see, and its
// 1 / pdf_A varies across the light: more noise, most of all when p is close to the light.
fn sphere_light_irradiance_area(sp: Surface, n: vec3<f32>, ns: vec3<f32>, light: Light, u: vec2<f32>) -> vec3<f32> {
    let to_p = sp.p - light.position;
    let dc2 = dot(to_p, to_p);
    if dc2 <= light.radius * light.radius {
        return vec3<f32>(0.0); // inside the light: it does not illuminate its own interior
    }
    let axis = to_p / sqrt(dc2);
    let m = sample_cosine_hemisphere(axis, u);
    let cos_m = dot(m, axis);
    let x_l = light.position + light.radius * m;
    let to_light = x_l - sp.p;
    let d2 = dot(to_light, to_light);
    let d = sqrt(d2);
    let wi = to_light / d;
    let cos_l = -dot(m, wi);
    let cos_theta = light_cosine(sp, n, ns, wi);
    if cos_theta <= 0.0 || cos_l <= 0.0 || cos_m <= 0.0 {
        return vec3<f32>(0.0);
    }
    // Visible if the first thing the ray meets is this light's own sphere (where it meets it, x_l, is
    // guaranteed by cos_l > 0).
    let o = offset_ray_origin(sp.p, sp.err, n, wi);
    let hit = scene_intersect(o, wi, T_MISS);
    if hit.prim_kind == PRIM_SPHERE && hit.prim_index == light.sphere_index {
        return light.intensity * cos_theta * cos_l * (PI * light.radius * light.radius) / (d2 * cos_m);
    }
    return vec3<f32>(0.0);
}
