// Test kernel, composed after the render kernel's data and scene queries (scene_data, bvh, texture,
// scene): one ray per invocation against the scene's triangles, through the BVH and by brute force.
// rays[i].o: origin, w = t_max; rays[i].d: direction (unit), w unused.
// query.xy: the brute force tests triangles [x, y) only (the caller splits the triangles into chunks, to
// stay within lavapipe's loop budget); query.z = 1: also walk the BVH.
// out[2 i]     = (BVH closest t, its triangle index (bits), iterations of the walk, any-hit walk's t < t_max)
// out[2 i + 1] = (brute-force closest t over the chunk, its index (bits; 0xffffffff none), 0, 0)
//
// requires: scene.wgsl

struct TestRay {
    o: vec4<f32>,
    d: vec4<f32>,
}

@group(0) @binding(40) var<storage, read> rays: array<TestRay>;
@group(0) @binding(41) var<storage, read_write> out: array<vec4<f32>>;
@group(0) @binding(42) var<uniform> query: vec4<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&rays) {
        return;
    }
    let r = rays[i];
    let o = r.o.xyz;
    let d = r.d.xyz;
    let t_max = r.o.w;
    if query.z == 1u {
        let h = bvh_intersect(o, d, t_max, false);
        let steps = bvh_last_steps;
        let any = bvh_intersect(o, d, t_max, true);
        let idx = select(0xffffffffu, h.prim_index, h.prim_kind != PRIM_NONE);
        out[2u * i] = vec4<f32>(h.t, bitcast<f32>(idx), f32(steps), select(0.0, 1.0, any.prim_kind != PRIM_NONE));
    }
    var best_t = t_max;
    var best = 0xffffffffu;
    for (var k = query.x; k < query.y; k++) {
        let tri = triangles[k];
        let th = intersect_triangle(o, d, tri.v0, tri.v1, tri.v2, 0.0, best_t);
        if th.t < best_t {
            best_t = th.t;
            best = k;
        }
    }
    out[2u * i + 1u] = vec4<f32>(best_t, bitcast<f32>(best), 0.0, 0.0);
}
