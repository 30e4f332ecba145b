// opacity.wgsl: the texture coordinates of a hit, and whether a ray passes through the surface it hit
// (its material's opacity). Tested during traversal, for every candidate hit (scene.wgsl's loops and
// bvh.wgsl's walk), so it needs only the hit, not the whole surface.
//
// requires: features.wgsl, scene_data.wgsl, texture.wgsl, rng.wgsl, sampling.wgsl

// A sphere's texture coordinates at the point whose offset from the centre is q: u the longitude about
// +y, phi / (2 pi) with phi = atan2(-q.z, q.x) in [0, 2 pi) (increasing from +x towards -z, right-handed
// about +y), v = 1 - theta / pi with theta the angle from +y (v = 1 at the north pole, the image's top row).
fn sphere_uv(q: vec3<f32>, radius: f32) -> vec2<f32> {
    var phi = atan2(-q.z, q.x);
    phi = select(phi, phi + TWO_PI, phi < 0.0);
    let theta = acos(clamp(q.y / radius, -1.0, 1.0));
    return vec2<f32>(phi / TWO_PI, 1.0 - theta / PI);
}

// Triangle i's mesh face, or one with mesh NO_MESH. (The generic kernel also runs scenes without shading
// data, whose mesh_faces is empty.)
fn triangle_face(i: u32) -> MeshFace {
    var face = MeshFace(vec3<u32>(0u), NO_MESH);
    // (A non-empty mesh_faces has an entry per triangle. With DATA_IMAGES the faces are in their image
    // and the storage binding is a witness of one entry, or none: render::upload_scene.)
    var there = false;
    if DATA_IMAGES {
        there = arrayLength(&mesh_faces) > 0u;
    } else {
        there = i < arrayLength(&mesh_faces);
    }
    if there {
        face = mesh_face_at(i);
    }
    return face;
}

// Whether a mesh face has texture coordinates.
fn face_has_uv(face: MeshFace) -> bool {
    return face.mesh != NO_MESH && (meshes[face.mesh].flags & MESH_UV) != 0u;
}

// The texture coordinates of triangle i at barycentrics b: its vertices' uvs interpolated, or (b1, b2)
// without (Mitsuba 3's convention: the vertices at uv (0, 0), (1, 0), (0, 1)).
fn triangle_uv(i: u32, b: vec3<f32>) -> vec2<f32> {
    var uv = vec2<f32>(b.y, b.z);
    if HAS_MESH_SHADING {
        let face = triangle_face(i);
        if face_has_uv(face) {
            let v0 = mesh_vertex_at(face.vertices.x);
            let v1 = mesh_vertex_at(face.vertices.y);
            let v2 = mesh_vertex_at(face.vertices.z);
            uv = b.x * vec2<f32>(v0.u, v0.v) + b.y * vec2<f32>(v1.u, v1.v) + b.z * vec2<f32>(v2.u, v2.v);
        }
    }
    return uv;
}

// --- Opacity ---------------------------------------------------------------------------------------
// A surface's opacity alpha (the material's `opacity`, times its opacity texture) is the fraction of light
// it stops. With an alpha_cutoff it is a cut-out: a hole where alpha < cutoff, solid elsewhere. Without,
// stochastic transparency: a ray meets the surface with probability alpha and passes through it (as if
// it were not there) otherwise, an unbiased estimate of the partial coverage (Enderton et al.,
// "Stochastic Transparency", 2010; pbrt-v4's alpha test). Every ray decides the same way (camera rays,
// BSDF-sampled rays and shadow rays alike), with a random number that is a hash of the ray, the primitive
// and the path's sample (opacity_seed): reproducible, and independent between rays and samples.

// The path's part of the hash (its pixel and sample: set by the integrator when a sample begins).
var<private> opacity_seed: u32;

// The texture coordinates of a hit, without the rest of the surface (opacity is tested during
// traversal, for every candidate hit).
fn hit_uv(o: vec3<f32>, d: vec3<f32>, hit: Hit) -> vec2<f32> {
    var uv = vec2<f32>(0.0);
    if HAS_SPHERES {
        if hit.prim_kind == PRIM_SPHERE {
            let s = sphere_at(hit.prim_index);
            uv = sphere_uv(o + hit.t * d - s.center, s.radius);
        }
    }
    if HAS_TRIANGLES {
        if hit.prim_kind == PRIM_TRIANGLE {
            uv = triangle_uv(hit.prim_index, hit.b);
        }
    }
    return uv;
}

// Whether the ray o + t d passes through the surface it hits at `hit` (material `material`).
fn hit_is_transparent(o: vec3<f32>, d: vec3<f32>, hit: Hit, material: u32) -> bool {
    var transparent = false;
    if HAS_OPACITY {
        let mt = material_textures_of(material);
        var alpha = mt.opacity;
        if mt.opacity_texture != NO_TEXTURE {
            alpha = texture_lookup(mt.opacity_texture, hit_uv(o, d, hit), vec3<f32>(mt.opacity)).x;
        }
        if (mt.flags & MATERIAL_CUTOUT) != 0u {
            transparent = alpha < mt.alpha_cutoff;
        } else if alpha < 1.0 {
            let h = pcg4d(vec4<u32>(bitcast<u32>(o.x) ^ bitcast<u32>(d.y), bitcast<u32>(o.y) ^ bitcast<u32>(d.z),
                                    bitcast<u32>(o.z) ^ bitcast<u32>(d.x), hit.prim_index ^ (hit.prim_kind << 30u)
                                    ^ opacity_seed));
            transparent = u32_to_unit_float(h.x) >= alpha;
        }
    }
    return transparent;
}
