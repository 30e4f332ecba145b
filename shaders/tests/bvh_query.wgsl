// Test kernel, composed after the render kernel's data and scene queries (scene_data, bvh, texture,
// scene): one ray per invocation against the scene's triangles (or, with query.w = 1, its spheres),
// through their BVH and by brute force.
// rays[i].o: origin, w = t_max; rays[i].d: direction (unit), w unused.
// query.xy: the brute force tests primitives [x, y) only (the caller splits the triangles into chunks, to
// stay within lavapipe's loop budget); query.z = 1: also walk the BVH; query.w = 1: the spheres' tree
// (sphere_bvh_intersect) and the loop over spheres, else the triangles'.
// out[2 i]     = (BVH closest t, its primitive index (bits), iterations of the walk, any-hit walk's t < t_max)
// out[2 i + 1] = (brute-force closest t over the chunk, its index (bits; 0xffffffff none), 0, 0)
//
// requires: scene.wgsl

struct TestRay {
    o: vec4<f32>,
    d: vec4<f32>,
}

@group(0) @binding(60) var<storage, read> rays: array<TestRay>;
@group(0) @binding(61) var<storage, read_write> out: array<vec4<f32>>;
@group(0) @binding(62) var<uniform> query: vec4<u32>;

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
    let spheres_only = query.w == 1u;
    if query.z == 1u {
        var h: Hit;
        var any: Hit;
        if spheres_only {
            h = sphere_bvh_intersect(o, d, t_max, false);
        } else {
            h = bvh_intersect(o, d, t_max, false);
        }
        let steps = bvh_last_steps;
        if spheres_only {
            any = sphere_bvh_intersect(o, d, t_max, true);
        } else {
            any = bvh_intersect(o, d, t_max, true);
        }
        let idx = select(0xffffffffu, h.prim_index, h.prim_kind != PRIM_NONE);
        out[2u * i] = vec4<f32>(h.t, bitcast<f32>(idx), f32(steps), select(0.0, 1.0, any.prim_kind != PRIM_NONE));
    }
    var best_t = t_max;
    var best = 0xffffffffu;
    for (var k = query.x; k < query.y; k++) {
        var t: f32;
        if spheres_only {
            let s = spheres[k];
            t = intersect_sphere(o, d, s.center, s.radius, 0.0, best_t);
        } else {
            let tri = triangles[k];
            t = intersect_triangle(o, d, tri.v0, tri.v1, tri.v2, 0.0, best_t).t;
        }
        if t < best_t {
            best_t = t;
            best = k;
        }
    }
    out[2u * i + 1u] = vec4<f32>(best_t, bitcast<f32>(best), 0.0, 0.0);
}
