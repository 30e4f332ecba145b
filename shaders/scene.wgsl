// scene.wgsl: closest-hit and visibility queries over the scene buffers (scene_data.wgsl), the surface
// at a hit, and which lights a next-event estimate samples (light selection).
//
// requires: features.wgsl, light_kinds.wgsl, scene_data.wgsl, intersect.wgsl, bvh.wgsl, texture.wgsl, opacity.wgsl, plugin_textures.wgsl

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
    var hit = Hit(t_max, PRIM_NONE, 0u, vec3<f32>(0.0), NO_INSTANCE);
    if HAS_SPHERES {
        // Through the spheres' own BVH when the scene has one, else every sphere in turn.
        var tree = false;
        if HAS_SPHERE_BVH {
            tree = has_sphere_nodes();
            if tree {
                hit = sphere_bvh_intersect(o, d, t_max, false);
            }
        }
        if !tree {
            for (var i = 0u; i < sphere_count(); i++) {
                let s = sphere_at(i);
                let t = intersect_sphere(o, d, s.center, s.radius, 0.0, hit.t);
                if t < hit.t {
                    let candidate = Hit(t, PRIM_SPHERE, i, vec3<f32>(0.0), NO_INSTANCE);
                    if !hit_is_transparent(o, d, candidate, s.material) {
                        hit = candidate;
                    }
                }
            }
        }
    }
    // Spheres first: a hit on one (a wall of the course's box, say) shortens the ray the BVH then walks.
    if HAS_BVH {
        if has_bvh_nodes() {
            let th = bvh_intersect(o, d, hit.t, false);
            if th.prim_kind != PRIM_NONE {
                hit = th;
            }
            return hit;
        }
    }
    if HAS_TRIANGLE_LOOP {
        let tr = triangle_ray(o, d);
        for (var i = 0u; i < triangle_count(); i++) {
            let tri = triangle_at(i);
            let th = intersect_triangle_ray(tr, tri.v0, tri.v1, tri.v2, 0.0, hit.t);
            if th.t < hit.t {
                let candidate = Hit(th.t, PRIM_TRIANGLE, i, th.b, NO_INSTANCE);
                if !hit_is_transparent(o, d, candidate, tri.material) {
                    hit = candidate;
                }
            }
        }
    }
    return hit;
}

// Is anything in the way over (0, t_max)? Stops at the first blocker.
fn scene_occluded(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    if HAS_SPHERES {
        var tree = false;
        if HAS_SPHERE_BVH {
            tree = has_sphere_nodes();
            if tree && sphere_bvh_intersect(o, d, t_max, true).prim_kind != PRIM_NONE {
                return true;
            }
        }
        if !tree {
            for (var i = 0u; i < sphere_count(); i++) {
                let s = sphere_at(i);
                let t = intersect_sphere(o, d, s.center, s.radius, 0.0, t_max);
                if t < t_max {
                    if !hit_is_transparent(o, d, Hit(t, PRIM_SPHERE, i, vec3<f32>(0.0), NO_INSTANCE), s.material) {
                        return true;
                    }
                }
            }
        }
    }
    if HAS_BVH {
        if has_bvh_nodes() {
            return bvh_intersect(o, d, t_max, true).prim_kind != PRIM_NONE;
        }
    }
    if HAS_TRIANGLE_LOOP {
        let tr = triangle_ray(o, d);
        for (var i = 0u; i < triangle_count(); i++) {
            let tri = triangle_at(i);
            let th = intersect_triangle_ray(tr, tri.v0, tri.v1, tri.v2, 0.0, t_max);
            if th.t < t_max {
                if !hit_is_transparent(o, d, Hit(th.t, PRIM_TRIANGLE, i, th.b, NO_INSTANCE), tri.material) {
                    return true;
                }
            }
        }
    }
    return false;
}

// Surface data at a hit: position with its error bound, geometric normal (outward for spheres,
// (v1 - v0) x (v2 - v0) for triangles), material index, texture coordinates, and the shading normal
// (interpolated on smooth meshes, then perturbed by the material's normal or bump map).
struct Surface {
    p: vec3<f32>,
    err: vec3<f32>,
    n: vec3<f32>,
    material: u32,
    // The shading normal, on the same side as n: the interpolated vertex normal, perturbed by a normal
    // or bump map, when `shading_normal`, else n.
    ns: vec3<f32>,
    shading_normal: bool,
    // Texture coordinates (when some material has a texture; else zero): a mesh's interpolated vertex
    // uvs, a triangle's barycentrics (b1, b2) when it has none, a sphere's longitude and latitude.
    uv: vec2<f32>,
}

fn sphere_surface(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> Surface {
    let s = sphere_at(hit.prim_index);
    let sp = sphere_surface_point(o, d, hit.t, s.center, s.radius);
    let n = normalize(sp.p - s.center);
    var uv = vec2<f32>(0.0);
    if HAS_MATERIAL_TEXTURES {
        uv = sphere_uv(sp.p - s.center, s.radius);
    }
    return Surface(sp.p, sp.err, n, s.material, n, false, uv);
}

fn mesh_normal(v: MeshVertex) -> vec3<f32> {
    return vec3<f32>(v.nx, v.ny, v.nz);
}

// --- Instances ---------------------------------------------------------------------------------------
// A hit on an instanced mesh (Hit::instance) holds the triangle in the mesh's own space; these map what
// shading needs into the world: points and surface directions (edges, tangents) by the placement's
// object-to-world map M, normals by its inverse transpose (pbrt-v4 §3.10), the transpose of the
// world-to-object map's linear part.
fn instance_point(m: Instance, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m.to_world_x.xyz, p) + m.to_world_x.w, dot(m.to_world_y.xyz, p) + m.to_world_y.w,
                     dot(m.to_world_z.xyz, p) + m.to_world_z.w);
}

fn instance_vector(m: Instance, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m.to_world_x.xyz, v), dot(m.to_world_y.xyz, v), dot(m.to_world_z.xyz, v));
}

fn instance_normal(m: Instance, n: vec3<f32>) -> vec3<f32> {
    return n.x * m.to_object_x.xyz + n.y * m.to_object_y.xyz + n.z * m.to_object_z.xyz;
}

// The triangle a hit is on, in world space: its vertices mapped by the placement when it is instanced.
fn hit_triangle(hit: Hit) -> Triangle {
    var tri = triangle_at(hit.prim_index);
    if HAS_INSTANCES {
        if hit.instance != NO_INSTANCE {
            let m = instance_at(hit.instance);
            tri.v0 = instance_point(m, tri.v0);
            tri.v1 = instance_point(m, tri.v1);
            tri.v2 = instance_point(m, tri.v2);
            if HAS_INSTANCE_MATERIALS {
                tri.material = select(tri.material, m.material, m.material != NO_MATERIAL);
            }
        }
    }
    return tri;
}

// What the placement adds to the error bound of a hit point p on an instanced triangle `tri` (in the
// mesh's space): the mapped vertices are each within gamma_3 (|M| |v| + |t|) of the exact images (per
// component), so the point interpolated between them is too; and a ray spawned from p is mapped back
// into the mesh's space by the walk, within gamma_3 (|M^-1| |p| + |t'|) there, |M| times that in the
// world. Both, with a margin (gamma_8 for two gamma_3), so that the spawned ray starts on its side of
// the triangle as the walk sees it.
fn instance_error(m: Instance, tri: Triangle, p: vec3<f32>) -> vec3<f32> {
    let v = max(max(abs(tri.v0), abs(tri.v1)), abs(tri.v2));
    let forward = vec3<f32>(dot(abs(m.to_world_x.xyz), v) + abs(m.to_world_x.w),
                            dot(abs(m.to_world_y.xyz), v) + abs(m.to_world_y.w),
                            dot(abs(m.to_world_z.xyz), v) + abs(m.to_world_z.w));
    let q = vec3<f32>(dot(abs(m.to_object_x.xyz), abs(p)) + abs(m.to_object_x.w),
                      dot(abs(m.to_object_y.xyz), abs(p)) + abs(m.to_object_y.w),
                      dot(abs(m.to_object_z.xyz), abs(p)) + abs(m.to_object_z.w));
    let back = vec3<f32>(dot(abs(m.to_world_x.xyz), q), dot(abs(m.to_world_y.xyz), q), dot(abs(m.to_world_z.xyz), q));
    return gamma_n(8.0) * (forward + back);
}

fn triangle_surface(hit: Hit) -> Surface {
    let tri = hit_triangle(hit);
    var sp = triangle_surface_point(tri.v0, tri.v1, tri.v2, hit.b);
    var n = triangle_normal(tri.v0, tri.v1, tri.v2);
    var mirrors = false;
    if HAS_INSTANCES {
        if hit.instance != NO_INSTANCE {
            let m = instance_at(hit.instance);
            sp.err += instance_error(m, triangle_at(hit.prim_index), sp.p);
            // A mirrored copy keeps its faces' fronts: the winding's normal flips (INSTANCE_MIRRORS).
            mirrors = (m.flags & INSTANCE_MIRRORS) != 0u;
            n = select(n, -n, mirrors);
        }
    }
    var s = Surface(sp.p, sp.err, n, tri.material, n, false, vec2<f32>(0.0));
    if HAS_SMOOTH_NORMALS {
        let face = triangle_face(hit.prim_index);
        if face.mesh != NO_MESH {
            if (meshes[face.mesh].flags & MESH_SMOOTH) != 0u {
                // Phong normal interpolation: the barycentric mix of the vertex normals, renormalised.
                // Shared vertices give both triangles of an edge the same normal along it, so shading
                // is continuous across edges. A mix that vanishes (opposed or missing normals) keeps
                // the geometric normal.
                let b = hit.b;
                var ns = b.x * mesh_normal(mesh_vertex_at(face.vertices.x))
                       + b.y * mesh_normal(mesh_vertex_at(face.vertices.y))
                       + b.z * mesh_normal(mesh_vertex_at(face.vertices.z));
                if HAS_INSTANCES {
                    if hit.instance != NO_INSTANCE {
                        ns = instance_normal(instance_at(hit.instance), ns);
                    }
                }
                let len2 = dot(ns, ns);
                if len2 > 1.0e-12 {
                    let unit = ns * inverseSqrt(len2);
                    s.ns = select(-unit, unit, dot(unit, n) >= 0.0);
                    s.shading_normal = true;
                }
            }
        }
    }
    if HAS_MATERIAL_TEXTURES {
        s.uv = triangle_uv(hit.prim_index, hit.b);
    }
    return s;
}

// The partial derivatives of the surface position with respect to the texture coordinates, dp/du and
// dp/dv (scene units per unit of uv), which orient the tangent frame of normal maps and the slopes of
// bump maps. Zero vectors where they do not exist (a sphere's poles, a triangle with degenerate uvs).
struct SurfaceDerivatives {
    dpdu: vec3<f32>,
    dpdv: vec3<f32>,
}

// A triangle's own dp/du and dp/dv (pbrt-v4 §6.5.1): p_i - p_2 = (u_i - u_2) dp/du + (v_i - v_2) dp/dv
// for i = 0, 1, solved by Cramer's rule with det = (u_0 - u_2)(v_1 - v_2) - (v_0 - v_2)(u_1 - u_2).
// A sphere's, from p = c + r (sin theta cos phi, cos theta, -sin theta sin phi), u = phi / (2 pi),
// v = 1 - theta / pi (sphere_uv): dp/du = 2 pi (q.z, 0, -q.x) and dp/dv = -pi dp/dtheta =
// -pi (q.y cos phi, -r sin theta, -q.y sin phi) for the offset q = p - c, where
// (cos phi, sin phi) = (q.x, -q.z) / (r sin theta).
fn surface_derivatives(hit: Hit, s: Surface) -> SurfaceDerivatives {
    var out = SurfaceDerivatives(vec3<f32>(0.0), vec3<f32>(0.0));
    if HAS_SPHERES {
        if hit.prim_kind == PRIM_SPHERE {
            let sphere = sphere_at(hit.prim_index);
            let q = s.p - sphere.center;
            let rho2 = q.x * q.x + q.z * q.z; // (r sin theta)^2
            if rho2 > 1e-12 * sphere.radius * sphere.radius {
                let rho = sqrt(rho2);
                let cos_phi = q.x / rho;
                let sin_phi = -q.z / rho;
                out.dpdu = TWO_PI * vec3<f32>(q.z, 0.0, -q.x);
                out.dpdv = -PI * vec3<f32>(q.y * cos_phi, -rho, -q.y * sin_phi);
            }
        }
    }
    if HAS_TRIANGLES {
        if hit.prim_kind == PRIM_TRIANGLE {
            out = triangle_derivatives(hit_triangle(hit), triangle_uv_deltas(hit.prim_index));
        }
    }
    return out;
}

// Triangle i's uv differences uv_0 - uv_2 and uv_1 - uv_2, and whether they are its vertices' own
// (without, the vertices are at uv (0, 0), (1, 0), (0, 1): triangle_uv).
struct TriangleUvDeltas {
    d02: vec2<f32>,
    d12: vec2<f32>,
    from_vertices: bool,
}

fn triangle_uv_deltas(i: u32) -> TriangleUvDeltas {
    var out = TriangleUvDeltas(vec2<f32>(0.0, -1.0), vec2<f32>(1.0, -1.0), false);
    if HAS_MESH_SHADING {
        let face = triangle_face(i);
        if face_has_uv(face) {
            let a = mesh_vertex_at(face.vertices.x);
            let b = mesh_vertex_at(face.vertices.y);
            let c = mesh_vertex_at(face.vertices.z);
            out = TriangleUvDeltas(vec2<f32>(a.u - c.u, a.v - c.v), vec2<f32>(b.u - c.u, b.v - c.v), true);
        }
    }
    return out;
}

// det of the uv differences' 2 x 2 system (zero: degenerate uvs, no derivatives).
fn uv_deltas_det(uv: TriangleUvDeltas) -> f32 {
    return uv.d02.x * uv.d12.y - uv.d02.y * uv.d12.x;
}

// dp/du and dp/dv of a triangle with uv differences `uv`, by Cramer's rule (surface_derivatives); zero
// when the uvs are degenerate.
fn triangle_derivatives(tri: Triangle, uv: TriangleUvDeltas) -> SurfaceDerivatives {
    var out = SurfaceDerivatives(vec3<f32>(0.0), vec3<f32>(0.0));
    let det = uv_deltas_det(uv);
    if det != 0.0 {
        let dp02 = tri.v0 - tri.v2;
        let dp12 = tri.v1 - tri.v2;
        out.dpdu = (uv.d12.y * dp02 - uv.d02.y * dp12) / det;
        out.dpdv = (uv.d02.x * dp12 - uv.d12.x * dp02) / det;
    }
    return out;
}

// The tangent at a mesh hit from its vertices' (glTF's TANGENT, or MikkTSpace's): the barycentric blend
// of the three directions (unnormalised, as MikkTSpace's reference shader interpolates them) and the
// sign of the blended w; w = 0 when the hit is not on a mesh whose three vertices have tangents.
fn vertex_tangent(hit: Hit) -> vec4<f32> {
    var out = vec4<f32>(0.0);
    if HAS_TRIANGLES && HAS_MESH_SHADING {
        if hit.prim_kind == PRIM_TRIANGLE {
            let face = triangle_face(hit.prim_index);
            if face.mesh != NO_MESH {
                let t0 = mesh_tangent(mesh_vertex_at(face.vertices.x).tangent);
                let t1 = mesh_tangent(mesh_vertex_at(face.vertices.y).tangent);
                let t2 = mesh_tangent(mesh_vertex_at(face.vertices.z).tangent);
                if t0.w != 0.0 && t1.w != 0.0 && t2.w != 0.0 {
                    let b = hit.b;
                    let t = b.x * t0 + b.y * t1 + b.z * t2;
                    out = vec4<f32>(t.xyz, select(1.0, -1.0, t.w < 0.0));
                    if HAS_INSTANCES {
                        if hit.instance != NO_INSTANCE {
                            // A tangent lies in the surface: mapped as edges are; a mirroring placement
                            // reverses cross(N, T), so the bitangent's sign flips with it (as
                            // scene::mesh::place maps a placed mesh's tangents).
                            let m = instance_at(hit.instance);
                            let flip = select(1.0, -1.0, (m.flags & INSTANCE_MIRRORS) != 0u);
                            out = vec4<f32>(instance_vector(m, out.xyz), out.w * flip);
                        }
                    }
                }
            }
        }
    }
    return out;
}

// A tangent-space normal map (glTF 2.0 §3.9.3) applied to surface s: texel t (linear data) encodes
// m = 2 t - 1 in the frame (T, B, N) of the surface at the hit, N the shading normal so far (interpolated
// or geometric). With the vertices' tangents (`tangent`, w != 0: glTF's TANGENT or MikkTSpace's, as the
// map was baked), T is theirs made perpendicular to N and B = w N x T (glTF 2.0 §3.7.2.1); without, T is
// the direction in which u increases, dp/du, made perpendicular to N, and B = +-N x T, on the side in
// which v increases (dp/dv: the image's up, glTF's +Y). The shading normal becomes
//   normalize(T (scale m.x) + B (scale m.y) + N m.z),  scale = the map's scale.
// Degenerate derivatives, or a mapped normal on the far side of the geometric surface (which no shading
// frame can use), keep the normal it had.
fn normal_mapped(s: Surface, dp: SurfaceDerivatives, tangent: vec4<f32>, texture: u32, scale: f32) -> Surface {
    var out = s;
    let n = s.ns;
    let given = tangent.w != 0.0;
    let along = select(dp.dpdu, tangent.xyz, given);
    let t_raw = along - dot(along, n) * n;
    let t_len2 = dot(t_raw, t_raw);
    if t_len2 > 0.0 && t_len2 < 1e30 {
        let t = t_raw * inverseSqrt(t_len2);
        var bt = select(cross(n, t), -cross(n, t), dot(cross(n, t), dp.dpdv) < 0.0);
        if given {
            bt = tangent.w * cross(n, t);
        }
        let m = 2.0 * texture_value(texture, s.uv) - vec3<f32>(1.0);
        let p = t * (m.x * scale) + bt * (m.y * scale) + n * m.z;
        let len2 = dot(p, p);
        if len2 > 1e-12 {
            let unit = p * inverseSqrt(len2);
            if dot(unit, s.n) > 0.0 {
                out.ns = unit;
                out.shading_normal = true;
            }
        }
    }
    return out;
}

// A bump map applied to surface s (Blinn 1978; pbrt-v4 §10.5.1, Mitsuba 3's `bumpmap`): the surface
// displaced along its shading normal N by the height h(u, v) = scale x texel has, to first order,
//   dp'/du = T_u + (dh/du) N,  dp'/dv = T_v + (dh/dv) N,
// with T_u, T_v the components of dp/du, dp/dv perpendicular to N (the curvature term h dN/du is left
// out, as Mitsuba does: heights are small against the surface's radius of curvature). The shading
// normal becomes dp'/du x dp'/dv, on N's side. The height's derivatives are central differences of the
// filtered texture one texel either side, du = 1 / width and dv = 1 / height: independent of the
// camera (no ray differentials), exact for a height that is linear between texel centres.
fn bump_mapped(s: Surface, dp: SurfaceDerivatives, texture: u32, scale: f32) -> Surface {
    var out = s;
    let n = s.ns;
    let tu = dp.dpdu - dot(dp.dpdu, n) * n;
    let tv = dp.dpdv - dot(dp.dpdv, n) * n;
    let tex = texture_info_at(texture);
    let du = 1.0 / f32(tex.width);
    let dv = 1.0 / f32(tex.height);
    // The heights at uv + (du, 0), - (du, 0), + (0, dv), - (0, dv), by one texture_value in a loop (see
    // textured_material; the trip count is 4, written so that the compiler cannot unroll it).
    var heights = vec4<f32>(0.0);
    let taps = select(4u, 0u, tex.width == 0u);
    for (var k = 0u; k < taps; k++) {
        let along_u = vec2<f32>(select(du, -du, k == 1u), 0.0);
        let along_v = vec2<f32>(0.0, select(dv, -dv, k == 3u));
        heights[k] = texture_value(texture, s.uv + select(along_v, along_u, k < 2u)).x;
    }
    let hu = (heights.x - heights.y) * (scale / (2.0 * du));
    let hv = (heights.z - heights.w) * (scale / (2.0 * dv));
    let c = cross(tu + hu * n, tv + hv * n);
    let len2 = dot(c, c);
    if len2 > 1e-30 && len2 < 1e30 {
        var unit = c * inverseSqrt(len2);
        unit = select(-unit, unit, dot(unit, n) >= 0.0);
        if dot(unit, s.n) > 0.0 {
            out.ns = unit;
            out.shading_normal = true;
        }
    }
    return out;
}

// The material's normal and bump maps applied to the surface (in that order, as Mitsuba nests them when
// both are given: the bump map perturbs the normal-mapped frame).
fn modified_surface(hit: Hit, s: Surface) -> Surface {
    var out = s;
    if HAS_NORMAL_MAPS || HAS_BUMP_MAPS {
        let mt = material_textures_of(s.material);
        if mt.normal_texture != NO_TEXTURE || mt.bump_texture != NO_TEXTURE {
            let dp = surface_derivatives(hit, s);
            if HAS_NORMAL_MAPS {
                if mt.normal_texture != NO_TEXTURE {
                    out = normal_mapped(out, dp, vertex_tangent(hit), mt.normal_texture, mt.normal_scale);
                }
            }
            if HAS_BUMP_MAPS {
                if mt.bump_texture != NO_TEXTURE {
                    out = bump_mapped(out, dp, mt.bump_texture, mt.bump_scale);
                }
            }
        }
    }
    return out;
}

// What a textured emission makes of the emission at point p of triangle `tri` (p from a light sample, on
// the triangle up to rounding): the emission texture's value there, which multiplies the emission, or 1.
fn emission_texture(tri: u32, p: vec3<f32>) -> vec3<f32> {
    var scale = vec3<f32>(1.0);
    if HAS_EMISSIVE_TEXTURES {
        let t = triangle_at(tri);
        let texture = material_textures_of(t.material).emission_texture;
        if texture != NO_TEXTURE {
            let e1 = t.v1 - t.v0;
            let e2 = t.v2 - t.v0;
            let n = cross(e1, e2);
            let inv = 1.0 / dot(n, n);
            let b1 = clamp(dot(cross(p - t.v0, e2), n) * inv, 0.0, 1.0);
            let b2 = clamp(dot(cross(e1, p - t.v0), n) * inv, 0.0, 1.0 - b1);
            scale = texture_value(texture, triangle_uv(tri, vec3<f32>(1.0 - b1 - b2, b1, b2)));
        }
    }
    return scale;
}

// The factor of a surface's emission at a hit: its material's emission texture there, or 1.
fn surface_emission_scale(sp: Surface) -> vec3<f32> {
    var scale = vec3<f32>(1.0);
    if HAS_EMISSIVE_TEXTURES {
        let texture = material_textures_of(sp.material).emission_texture;
        if texture != NO_TEXTURE {
            scale = texture_value(texture, sp.uv);
        }
    }
    return scale;
}

// The material `mat` as its textures make it at the hit: each textured parameter is the material's
// constant (its factor) times the texture's value. albedo = albedo x texel (the albedo, a mirror's tint,
// a plastic's base, a base colour, a Schlick conductor's f0); metallic = metallic x texel; roughness =
// roughness x texel, and since the material holds alpha = roughness^2 (on each axis), the textured alpha
// is alpha texel^2 (below SMOOTH_ALPHA, the smooth lobe: microfacet_smooth). (alpha's product reaches the
// BSDF only through material_alpha's max, never an addition, so it rounds the same in every kernel: see
// texture_lookup.)
//
// The lookups go through one call of texture_lookup in a loop over the textures the material has (see
// image_lookup for why: each call is compiled in full, and the loop's trip count is the data's).
fn textured_material(mat: Material, sp: Surface) -> Material {
    var m = mat;
    if HAS_TEXTURES || HAS_METALLIC_ROUGHNESS_TEXTURES {
        let mt = material_textures_of(sp.material);
        // Bit 0 albedo, bit 1 metallic, bit 2 roughness: the textures still to look up, in that order.
        var todo = 0u;
        if HAS_TEXTURES {
            todo |= select(0u, 1u, mt.albedo_texture != NO_TEXTURE);
        }
        if HAS_METALLIC_ROUGHNESS_TEXTURES {
            todo |= select(0u, 2u, mt.metallic_texture != NO_TEXTURE);
            todo |= select(0u, 4u, mt.roughness_texture != NO_TEXTURE);
        }
        while todo != 0u {
            let k = firstTrailingBit(todo);
            todo &= todo - 1u;
            var texture = mt.albedo_texture;
            var scale = mat.albedo;
            if k == 1u {
                texture = mt.metallic_texture;
                scale = vec3<f32>(mat.metallic);
            } else if k == 2u {
                texture = mt.roughness_texture;
                scale = vec3<f32>(1.0);
            }
            let value = texture_lookup(texture, sp.uv, scale);
            if k == 0u {
                m.albedo = value;
            } else if k == 1u {
                m.metallic = value.x;
            } else {
                let r2 = value.x * value.x;
                m.alpha_x *= r2;
                m.alpha_y *= r2;
            }
        }
    }
    // A material plugin's textured parameters (plugin_textures.wgsl, generated from its declaration).
    if HAS_PLUGIN_TEXTURES {
        m = plugin_textured(m, sp.uv);
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
            let tri = hit_triangle(hit);
            t = tri.v1 - tri.v0;
            let uv = triangle_uv_deltas(hit.prim_index);
            if uv.from_vertices {
                let dpdu = triangle_derivatives(tri, uv).dpdu;
                if abs(uv_deltas_det(uv)) > 1e-12 && dot(dpdu, dpdu) > 0.0 {
                    t = dpdu;
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
                return sphere_at(hit.prim_index).material;
            }
        }
        return placed_material(triangle_at(hit.prim_index).material, hit.instance);
    }
    return sphere_at(hit.prim_index).material;
}

fn surface_at(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> Surface {
    var s: Surface;
    if HAS_TRIANGLES {
        if HAS_SPHERES {
            if hit.prim_kind == PRIM_SPHERE {
                s = sphere_surface(o, d, hit);
            } else {
                s = triangle_surface(hit);
            }
        } else {
            s = triangle_surface(hit);
        }
    } else {
        s = sphere_surface(o, d, hit);
    }
    // A material with a back material (Mitsuba's twosided with two BSDFs) shows it on its back face,
    // the side the geometric normal points away from: its textures, maps and BSDF from here on.
    if HAS_BACK_MATERIALS {
        let back = material_at(s.material).back;
        if back != 0u && dot(d, s.n) >= 0.0 {
            s.material = back - 1u;
        }
    }
    // A blended material (Mitsuba's blendbsdf: f = (1 - w) f_a + w f_b) shows its blend material b at a
    // fraction w of its hits, itself at the rest (pbrt-v4's MixMaterial): the expected BSDF is the blend,
    // and each hit is shaded, sampled and light-sampled by one material. The choice hashes the ray and
    // the sample as the opacity test does (opacity.wgsl; another word of the hash): the same at every
    // call for the same hit, independent between samples, and the same for any split of the render.
    if HAS_BLEND_MATERIALS {
        let mt = material_textures_of(s.material);
        if mt.blend != 0u {
            var w = mt.blend_weight;
            if mt.blend_texture != NO_TEXTURE {
                w = texture_lookup(mt.blend_texture, s.uv, vec3<f32>(w)).x;
            }
            let h = pcg4d(vec4<u32>(bitcast<u32>(o.x) ^ bitcast<u32>(d.y), bitcast<u32>(o.y) ^ bitcast<u32>(d.z),
                                    bitcast<u32>(o.z) ^ bitcast<u32>(d.x), hit.prim_index ^ (hit.prim_kind << 30u)
                                    ^ opacity_seed));
            if u32_to_unit_float(h.y) < w {
                s.material = mt.blend - 1u;
            }
        }
    }
    if HAS_NORMAL_MAPS || HAS_BUMP_MAPS {
        s = modified_surface(hit, s);
    }
    return s;
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
    return SelectedLight(light_at(k), 1.0);
}

// The light whose emitter sphere is spheres[i], as light_select would give it (with its selection
// probability), for weighing a BSDF-sampled ray that hit it against the light's own sampling.
fn light_of_sphere(i: u32) -> SelectedLight {
    var chosen = SelectedLight(light_at(0), 0.0);
    for (var k = 0u; k < light_selection_count(); k++) {
        let light = light_at(k);
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
            let tri = hit_triangle(hit);
            let mat = material_at(tri.material);
            let total = light_at(params.triangle_light).radius;
            let pick = triangle_light_power(tri.v0, tri.v1, tri.v2, mat.emission, mat.flags) / total;
            pdf = pick * triangle_light_pdf(tri.v0, tri.v1, tri.v2, mat.flags, p, wi, strategy);
        }
    }
    return pdf;
}

// The sphere-light strategy (`render.light_sampling`) for the light dispatchers (lights.wgsl) (a constant there
// when the kernel is specialised).
fn light_sampling_strategy() -> u32 {
    return params.light_sampling;
}
