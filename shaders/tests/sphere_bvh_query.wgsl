// Test kernel, composed after the render kernel's data and scene queries: one ray per invocation against
// the scene's spheres, through their BVH (closest and any hit) and by the loop over every sphere.
// rays[i].o: origin, w = t_max; rays[i].d: direction (unit), w unused.
// out[2 i]     = (the walk's closest t, its sphere index (bits; 0xffffffff none), iterations of the walk,
//                 1 if the any-hit walk found something)
// out[2 i + 1] = (the loop's closest t, its sphere index (bits; 0xffffffff none), 0, 0)
//
// requires: scene.wgsl

struct TestRay {
    o: vec4<f32>,
    d: vec4<f32>,
}

@group(0) @binding(40) var<storage, read> rays: array<TestRay>;
@group(0) @binding(41) var<storage, read_write> out: array<vec4<f32>>;

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
    let h = sphere_bvh_intersect(o, d, t_max, false);
    let steps = bvh_last_steps;
    let any = sphere_bvh_intersect(o, d, t_max, true);
    let idx = select(0xffffffffu, h.prim_index, h.prim_kind != PRIM_NONE);
    out[2u * i] = vec4<f32>(h.t, bitcast<f32>(idx), f32(steps), select(0.0, 1.0, any.prim_kind != PRIM_NONE));
    var best_t = t_max;
    var best = 0xffffffffu;
    for (var k = 0u; k < arrayLength(&spheres); k++) {
        let s = spheres[k];
        let t = intersect_sphere(o, d, s.center, s.radius, 0.0, best_t);
        if t < best_t {
            best_t = t;
            best = k;
        }
    }
    out[2u * i + 1u] = vec4<f32>(best_t, bitcast<f32>(best), 0.0, 0.0);
}
