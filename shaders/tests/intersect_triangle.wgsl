// Test kernel: intersect_triangle over a list of rays, one triangle each.
// Case: o.xyz origin, o.w t_min; d.xyz direction, d.w t_max; v0, v1, v2 the vertices (w unused).
// Out: (t, b0, b1, b2); t = T_MISS on a miss.
//
// requires: intersect.wgsl

struct TriangleCase {
    o: vec4<f32>,
    d: vec4<f32>,
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<TriangleCase>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    let c = input[id.x];
    let h = intersect_triangle(c.o.xyz, c.d.xyz, c.v0.xyz, c.v1.xyz, c.v2.xyz, c.o.w, c.d.w);
    output[id.x] = vec4<f32>(h.t, h.b);
}
