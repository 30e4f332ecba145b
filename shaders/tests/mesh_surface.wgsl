// Test kernel, composed after the render kernel's data and scene queries: the surface the renderer shades
// where each ray first hits the scene (scene_intersect, then surface_at, exactly as trace.wgsl does).
// rays[i] = (origin, direction) as in bvh_query.wgsl. out[3 i] = (geometric normal n, triangle index bits
// or -1 on a miss); out[3 i + 1] = (shading normal ns, 1 if interpolated); out[3 i + 2] = (texture
// albedo, 1 if textured).
//
// requires: scene.wgsl

struct TestRay {
    o: vec4<f32>,
    d: vec4<f32>,
}

@group(0) @binding(60) var<storage, read> rays: array<TestRay>;
@group(0) @binding(61) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&rays) {
        return;
    }
    let o = rays[i].o.xyz;
    let d = rays[i].d.xyz;
    let hit = scene_intersect(o, d, T_MISS);
    if hit.prim_kind != PRIM_TRIANGLE {
        out[3u * i] = vec4<f32>(-1.0);
        out[3u * i + 1u] = vec4<f32>(-1.0);
        out[3u * i + 2u] = vec4<f32>(-1.0);
        return;
    }
    let s = surface_at(o, d, hit);
    out[3u * i] = vec4<f32>(s.n, bitcast<f32>(hit.prim_index));
    out[3u * i + 1u] = vec4<f32>(s.ns, select(0.0, 1.0, s.shading_normal));
    let textured = material_textures_of(s.material).albedo_texture != NO_TEXTURE;
    out[3u * i + 2u] = vec4<f32>(textured_material(materials[s.material], s).albedo, select(0.0, 1.0, textured));
}
