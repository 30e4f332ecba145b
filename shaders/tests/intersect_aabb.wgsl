// Test kernel: a box and a primitive inside it, against one ray: the box test (intersect_aabb) and the
// primitive test (intersect_sphere / intersect_triangle) side by side, as a BVH leaf would run them.
// Case: o.xyz origin, o.w primitive (0 sphere, 1 triangle); d.xyz direction; inv.xyz = 1/d (computed on
// the host in IEEE f32, ±inf for zero components), inv.w = t_max; lo, hi the box; a: sphere centre and
// radius or triangle v0; b, c: triangle v1, v2.
// Out: (box entry distance or T_MISS, primitive t or T_MISS, 0, 0).
//
// requires: intersect.wgsl

struct BoxCase {
    o: vec4<f32>,
    d: vec4<f32>,
    inv: vec4<f32>,
    lo: vec4<f32>,
    hi: vec4<f32>,
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<BoxCase>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    let c = input[id.x];
    let t_box = intersect_aabb(c.o.xyz, c.inv.xyz, c.lo.xyz, c.hi.xyz, c.inv.w);
    var t_prim: f32;
    if c.o.w == 0.0 {
        t_prim = intersect_sphere(c.o.xyz, c.d.xyz, c.a.xyz, c.a.w, 0.0, c.inv.w);
    } else {
        t_prim = intersect_triangle(c.o.xyz, c.d.xyz, c.a.xyz, c.b.xyz, c.c.xyz, 0.0, c.inv.w).t;
    }
    output[id.x] = vec4<f32>(t_box, t_prim, 0.0, 0.0);
}
