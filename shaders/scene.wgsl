// scene.wgsl: closest-hit and visibility queries over the scene buffers (scene_data.wgsl), the surface
// at a hit, and which lights a next-event estimate samples (light selection).
//
// requires: features.wgsl, scene_data.wgsl, intersect.wgsl, bvh.wgsl, texture.wgsl

// How many spheres, loop-tested triangles (scenes without a BVH) and lights the scene has. The generic
// kernel reads them from `params`; a kernel specialised for a scene has them as constants (the
// `sphere_count`, `triangle_count` and `light_count` knobs of src/kernel/features.rs), so that the loops
// over them have a constant trip count the shader compiler can unroll: on lavapipe a loop costs, besides
// its body, the execution-mask bookkeeping of every iteration and a jump, which for a handful of
// primitives is a sizeable part of a ray cast. Written with bare constant conditions (the pruning
// scheme, features.wgsl).
override SPHERE_COUNT_FROM_PARAMS: bool = true;
override SPHERE_COUNT: u32 = 0u;
override TRIANGLE_COUNT_FROM_PARAMS: bool = true;
override TRIANGLE_COUNT: u32 = 0u;
override LIGHT_COUNT_FROM_PARAMS: bool = true;
override LIGHT_COUNT: u32 = 0u;

fn sphere_count() -> u32 {
    if SPHERE_COUNT_FROM_PARAMS {
        return params.num_spheres;
    }
    return SPHERE_COUNT;
}

fn triangle_count() -> u32 {
    if TRIANGLE_COUNT_FROM_PARAMS {
        return params.num_triangles;
    }
    return TRIANGLE_COUNT;
}

// The closest intersection along the ray in (0, t_max). The origin has already been offset off its
// surface (offset_ray_origin), so t_min is 0.
fn scene_intersect(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Hit {
    var hit = Hit(t_max, PRIM_NONE, 0u, vec3<f32>(0.0));
    if HAS_SPHERES {
        for (var i = 0u; i < sphere_count(); i++) {
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
        for (var i = 0u; i < triangle_count(); i++) {
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
        for (var i = 0u; i < sphere_count(); i++) {
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
        for (var i = 0u; i < triangle_count(); i++) {
            let tri = triangles[i];
            if intersect_triangle(o, d, tri.v0, tri.v1, tri.v2, 0.0, t_max).t < t_max {
                return true;
            }
        }
    }
    return false;
}

// Surface data at a hit: position with its error bound, geometric normal (outward for spheres,
// (v1 - v0) x (v2 - v0) for triangles), material index; for meshes, the shading normal and what the
// mesh's textures make of the material there (textured_material).
struct Surface {
    p: vec3<f32>,
    err: vec3<f32>,
    n: vec3<f32>,
    material: u32,
    // The shading normal, on the same side as n: the interpolated vertex normal, perturbed by a normal
    // map, when `shading_normal`, else n.
    ns: vec3<f32>,
    shading_normal: bool,
    // The albedo at the hit, when `textured`: the base colour texture's value (TOML and OBJ meshes), or
    // that times the material's albedo (glTF's baseColorFactor, MESH_BASE_COLOR_FACTOR). It replaces the
    // material's albedo (or tint).
    albedo: vec3<f32>,
    textured: bool,
    // What multiplies the material's emission: the emissive texture's value, or 1.
    emission_scale: vec3<f32>,
    // With a metallic-roughness texture (`metallic_roughness_textured`): metallic at the hit
    // (metallicFactor x B) and the factor of roughness (G).
    metallic_roughness: vec2<f32>,
    metallic_roughness_textured: bool,
}

fn sphere_surface(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> Surface {
    let s = spheres[hit.prim_index];
    let sp = sphere_surface_point(o, d, hit.t, s.center, s.radius);
    let n = normalize(sp.p - s.center);
    return Surface(sp.p, sp.err, n, s.material, n, false, vec3<f32>(0.0), false, vec3<f32>(1.0),
                   vec2<f32>(1.0), false);
}

fn mesh_normal(v: MeshVertex) -> vec3<f32> {
    return vec3<f32>(v.nx, v.ny, v.nz);
}

fn triangle_surface(hit: Hit) -> Surface {
    let tri = triangles[hit.prim_index];
    let sp = triangle_surface_point(tri.v0, tri.v1, tri.v2, hit.b);
    let n = triangle_normal(tri.v0, tri.v1, tri.v2);
    var s = Surface(sp.p, sp.err, n, tri.material, n, false, vec3<f32>(0.0), false, vec3<f32>(1.0),
                    vec2<f32>(1.0), false);
    if HAS_MESH_SHADING {
        // (The generic kernel also runs scenes without shading data, whose mesh_faces is empty.)
        var face = MeshFace(vec3<u32>(0u), NO_MESH);
        if hit.prim_index < arrayLength(&mesh_faces) {
            face = mesh_faces[hit.prim_index];
        }
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
            let uv = b.x * vec2<f32>(v0.u, v0.v) + b.y * vec2<f32>(v1.u, v1.v) + b.z * vec2<f32>(v2.u, v2.v);
            if HAS_TEXTURES {
                if (mesh.flags & MESH_TEXTURED) != 0u {
                    // glTF: base colour = baseColorFactor x texel, both linear (the material's albedo
                    // holds the factor); TOML and OBJ: the texel.
                    var factor = vec3<f32>(1.0);
                    if (mesh.flags & MESH_BASE_COLOR_FACTOR) != 0u {
                        factor = materials[tri.material].albedo;
                    }
                    s.albedo = texture_bilinear_scaled(mesh.base_color, uv, factor);
                    s.textured = true;
                }
            }
            if HAS_EMISSIVE_TEXTURES {
                if (mesh.flags & MESH_EMISSIVE_TEXTURED) != 0u {
                    s.emission_scale = texture_bilinear(mesh.emissive, uv);
                }
            }
            if HAS_NORMAL_MAPS {
                if (mesh.flags & MESH_NORMAL_MAPPED) != 0u {
                    s = normal_mapped(s, mesh, tri, v0, v1, v2, uv);
                }
            }
            if HAS_METALLIC_ROUGHNESS_TEXTURES {
                if (mesh.flags & MESH_METALLIC_ROUGHNESS_TEXTURED) != 0u {
                    // glTF 2.0 §3.9.2: metalness in B, roughness in G, both linear; metallic =
                    // metallicFactor x B (the material holds the factor).
                    let metallic = materials[tri.material].metallic;
                    s.metallic_roughness =
                        texture_bilinear_scaled(mesh.metallic_roughness, uv, vec3<f32>(1.0, 1.0, metallic)).bg;
                    s.metallic_roughness_textured = true;
                }
            }
        }
    }
    return s;
}

// A tangent-space normal map (glTF 2.0 §3.9.3) applied to surface s: texel t (linear data) encodes
// m = 2 t - 1 in the frame (T, B, N) of the surface at the hit, N the shading normal so far (interpolated
// or geometric), T the direction in which u increases, dp/du, made perpendicular to N, and B = +-N x T,
// on the side in which v increases (dp/dv: the image's up, glTF's +Y). The shading normal becomes
//   normalize(T (scale m.x) + B (scale m.y) + N m.z),  scale = normalTexture.scale.
// dp/du and dp/dv are the triangle's own (pbrt-v4 §6.5.1): p_i - p_2 = (u_i - u_2) dp/du + (v_i - v_2) dp/dv
// for i = 0, 1, solved by Cramer's rule with det = (u_0 - u_2)(v_1 - v_2) - (v_0 - v_2)(u_1 - u_2). A
// triangle with degenerate uvs (det = 0), or a mapped normal on the far side of the geometric surface
// (which no shading frame can use), keeps the normal it had.
fn normal_mapped(s: Surface, mesh: MeshInfo, tri: Triangle, a: MeshVertex, b: MeshVertex, c: MeshVertex,
                 uv: vec2<f32>) -> Surface {
    var out = s;
    let duv02 = vec2<f32>(a.u - c.u, a.v - c.v);
    let duv12 = vec2<f32>(b.u - c.u, b.v - c.v);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    if det != 0.0 {
        let dp02 = tri.v0 - tri.v2;
        let dp12 = tri.v1 - tri.v2;
        let dpdu = (duv12.y * dp02 - duv02.y * dp12) / det;
        let dpdv = (duv02.x * dp12 - duv12.x * dp02) / det;
        let n = s.ns;
        let t_raw = dpdu - dot(dpdu, n) * n;
        let t_len2 = dot(t_raw, t_raw);
        if t_len2 > 0.0 && t_len2 < 1e30 {
            let t = t_raw * inverseSqrt(t_len2);
            let bt = select(cross(n, t), -cross(n, t), dot(cross(n, t), dpdv) < 0.0);
            let m = 2.0 * texture_bilinear(mesh.normal, uv) - vec3<f32>(1.0);
            let p = t * (m.x * mesh.normal_scale) + bt * (m.y * mesh.normal_scale) + n * m.z;
            let len2 = dot(p, p);
            if len2 > 1e-12 {
                let unit = p * inverseSqrt(len2);
                if dot(unit, s.n) > 0.0 {
                    out.ns = unit;
                    out.shading_normal = true;
                }
            }
        }
    }
    return out;
}

// What a mesh's emissive texture makes of the emission at point p of triangle `tri` (p from a light
// sample, on the triangle up to rounding): the texture's value there, which multiplies the emission, or 1
// off such meshes.
fn emission_texture(tri: u32, p: vec3<f32>) -> vec3<f32> {
    var scale = vec3<f32>(1.0);
    if HAS_EMISSIVE_TEXTURES {
        let t = triangles[tri];
        let e1 = t.v1 - t.v0;
        let e2 = t.v2 - t.v0;
        let n = cross(e1, e2);
        let inv = 1.0 / dot(n, n);
        let b1 = clamp(dot(cross(p - t.v0, e2), n) * inv, 0.0, 1.0);
        let b2 = clamp(dot(cross(e1, p - t.v0), n) * inv, 0.0, 1.0 - b1);
        let s = triangle_surface(Hit(0.0, PRIM_TRIANGLE, tri, vec3<f32>(1.0 - b1 - b2, b1, b2)));
        scale = s.emission_scale;
    }
    return scale;
}

// The material `mat` as the hit's surface makes it: the textured albedo replacing the albedo (or
// tint), and with a metallic-roughness texture (glTF) metallic = metallicFactor x B and roughness =
// roughnessFactor x G. The material holds alpha = roughnessFactor^2 (on each axis), so the textured
// alpha is (roughnessFactor G)^2 = alpha G^2 (below SMOOTH_ALPHA, the smooth lobe: microfacet_smooth).
// (That product reaches the BSDF only through material_alpha's max, never an addition, so it rounds the
// same in every kernel: see texture_bilinear_scaled.)
fn textured_material(mat: Material, sp: Surface) -> Material {
    var m = mat;
    if HAS_TEXTURES {
        if sp.textured {
            m.albedo = sp.albedo;
        }
    }
    if HAS_METALLIC_ROUGHNESS_TEXTURES {
        if sp.metallic_roughness_textured {
            m.metallic = sp.metallic_roughness.x;
            let g2 = sp.metallic_roughness.y * sp.metallic_roughness.y;
            m.alpha_x *= g2;
            m.alpha_y *= g2;
        }
    }
    return m;
}

// The direction an anisotropic material's roughness alpha_x runs along at a hit (the BSDF keeps its
// component perpendicular to the shading normal): on a sphere of centre c, the direction of increasing
// longitude about +y, (0, 1, 0) x n (at the poles, +x); on a mesh with texture coordinates, dp/du, the
// direction in which u increases (pbrt-v4 §6.5.1, from the triangle's positions and uvs); on other
// triangles, the first edge v1 - v0. n is the geometric normal.
fn surface_tangent(hit: Hit, n: vec3<f32>) -> vec3<f32> {
    var t = vec3<f32>(1.0, 0.0, 0.0);
    if HAS_SPHERES {
        if hit.prim_kind == PRIM_SPHERE {
            let c = vec3<f32>(n.z, 0.0, -n.x); // (0, 1, 0) x n
            if dot(c, c) > 1e-12 {
                t = c;
            }
        }
    }
    if HAS_TRIANGLES {
        if hit.prim_kind == PRIM_TRIANGLE {
            let tri = triangles[hit.prim_index];
            t = tri.v1 - tri.v0;
            if HAS_TEXTURES {
                var face = MeshFace(vec3<u32>(0u), NO_MESH);
                if hit.prim_index < arrayLength(&mesh_faces) {
                    face = mesh_faces[hit.prim_index];
                }
                if face.mesh != NO_MESH {
                    if (meshes[face.mesh].flags & MESH_TEXTURED) != 0u {
                        let a = mesh_vertices[face.vertices.x];
                        let b = mesh_vertices[face.vertices.y];
                        let c = mesh_vertices[face.vertices.z];
                        // p - p2 = (u - u2) dp/du + (v - v2) dp/dv at the vertices 0 and 1, solved for dp/du.
                        let duv02 = vec2<f32>(a.u - c.u, a.v - c.v);
                        let duv12 = vec2<f32>(b.u - c.u, b.v - c.v);
                        let det = duv02.x * duv12.y - duv02.y * duv12.x;
                        let dpdu = (duv12.y * (tri.v0 - tri.v2) - duv02.y * (tri.v1 - tri.v2)) / det;
                        if abs(det) > 1e-12 && dot(dpdu, dpdu) > 0.0 {
                            t = dpdu;
                        }
                    }
                }
            }
        }
    }
    return t;
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

// --- Lights ------------------------------------------------------------------------------------------
// Light selection: which lights one next-event estimate samples, each with its selection probability.
// Every light is sampled once at each vertex (probability 1, light_selection_count() of them): exact,
// and cheapest in noise, for the few lights a scene lists (its point, sphere and directional lights, the
// environment). The many emissive triangles of a mesh are one light among them (LIGHT_TRIANGLES),
// whose sample picks one triangle in proportion to its power with an alias table: O(1) per sample.
struct SelectedLight {
    light: Light,
    pmf: f32,
}

fn light_selection_count() -> u32 {
    if LIGHT_COUNT_FROM_PARAMS {
        return params.num_lights;
    }
    return LIGHT_COUNT;
}

fn light_select(k: u32) -> SelectedLight {
    return SelectedLight(lights[k], 1.0);
}

// The light whose emitter sphere is spheres[i], as light_select would give it (with its selection
// probability), for weighing a BSDF-sampled ray that hit it against the light's own sampling.
fn light_of_sphere(i: u32) -> SelectedLight {
    var chosen = SelectedLight(lights[0], 0.0);
    for (var k = 0u; k < light_selection_count(); k++) {
        let light = lights[k];
        if light.kind == LIGHT_SPHERE && light.index == i {
            chosen = SelectedLight(light, 1.0);
        }
    }
    return chosen;
}

// The density with which next-event estimation from p samples direction wi towards the emitting surface
// of `hit` (the MIS weight of a BSDF-sampled ray that found it): the light's selection probability times
// its direction density (for a triangle, its pick by the alias table too). A sphere light is not sampled
// from its own surface (`p_sphere`, see direct_light): 0 there.
fn emitter_light_pdf(hit: Hit, p: vec3<f32>, p_sphere: u32, wi: vec3<f32>, strategy: u32) -> f32 {
    var pdf = 0.0;
    if HAS_SPHERE_LIGHTS {
        if hit.prim_kind == PRIM_SPHERE && hit.prim_index != p_sphere {
            let chosen = light_of_sphere(hit.prim_index);
            pdf = chosen.pmf * light_pdf_li(chosen.light, p, wi, strategy);
        }
    }
    if HAS_TRIANGLE_LIGHTS {
        if hit.prim_kind == PRIM_TRIANGLE && params.triangle_light != NO_LIGHT {
            let tri = triangles[hit.prim_index];
            let mat = materials[tri.material];
            let total = lights[params.triangle_light].radius;
            let pick = triangle_light_power(tri.v0, tri.v1, tri.v2, mat.emission, mat.flags) / total;
            pdf = pick * triangle_light_pdf(tri.v0, tri.v1, tri.v2, mat.flags, p, wi, strategy);
        }
    }
    return pdf;
}

// The sphere-light strategy (`render.light_sampling`) for the lights.wgsl dispatchers (a constant there
// when the kernel is specialised).
fn light_sampling_strategy() -> u32 {
    return params.light_sampling;
}
