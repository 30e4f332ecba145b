// Test kernel: intersect_sphere over a list of rays, one sphere each.
// Case: o.xyz origin, o.w t_min; d.xyz direction, d.w t_max; s.xyz centre, s.w radius.
// Out: x = t (T_MISS on a miss), yzw = sphere_surface_point(...).p when it hit (else 0).
//
// requires: intersect.wgsl

struct SphereCase {
    o: vec4<f32>,
    d: vec4<f32>,
    s: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<SphereCase>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    let c = input[id.x];
    let t = intersect_sphere(c.o.xyz, c.d.xyz, c.s.xyz, c.s.w, c.o.w, c.d.w);
    var p = vec3<f32>(0.0);
    if t < T_MISS {
        p = sphere_surface_point(c.o.xyz, c.d.xyz, t, c.s.xyz, c.s.w).p;
    }
    output[id.x] = vec4<f32>(t, p);
}
