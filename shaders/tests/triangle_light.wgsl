// Test kernel for the emissive-triangle light (tests/shader_area_lights.rs).
// Case (4 vec4): v0 = (xyz, strategy), v1 = (xyz, seed), v2 = (xyz, two-sided flag), p = (xyz, mode).
// mode 0: one triangle_light_sample from p towards (v0, v1, v2) (radiance 1), drawn with
//   rng_new(invocation, 0, seed); out a = (wi.xyz, pdf), b = (p_light.xyz, dist),
//   c = (triangle_light_pdf at wi, faces p, 0, 0).
// mode 1: the alias table's pick (light_triangles, bound by the test) among u32(v0.w) triangles with
//   rng_next2; out a.x = the picked index.
//
// requires: lights.wgsl, rng.wgsl

struct Case {
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
    p: vec4<f32>,
}

struct Out {
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<Case>;
@group(0) @binding(1) var<storage, read_write> output: array<Out>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let c = input[i];
    var rng = rng_new(i, 0u, u32(c.v1.w));
    var o: Out;
    if u32(c.p.w) == 1u {
        o.a = vec4<f32>(f32(triangle_light_pick(u32(c.v0.w), rng_next2(&rng))), 0.0, 0.0, 0.0);
    } else {
        let strategy = u32(c.v0.w);
        let flags = u32(c.v2.w);
        let t = LightTriangle(c.v0.xyz, 0u, c.v1.xyz, 1.0, c.v2.xyz, flags, vec3<f32>(1.0), 0u);
        let n = cross(t.v1 - t.v0, t.v2 - t.v0);
        let faces = triangle_light_faces(t.v0, n, flags, c.p.xyz);
        let ls = triangle_light_sample(t, c.p.xyz, strategy, rng_next2(&rng));
        o.a = vec4<f32>(ls.wi, ls.pdf);
        o.b = vec4<f32>(ls.p_light, ls.dist);
        o.c = vec4<f32>(triangle_light_pdf(t.v0, t.v1, t.v2, flags, c.p.xyz, ls.wi, strategy),
                        select(0.0, 1.0, faces), 0.0, 0.0);
    }
    output[i] = o;
}
