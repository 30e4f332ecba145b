// Test kernel for lights.wgsl (tests/shader_lights.rs): light samples as the integrator takes them.
// Case (4 vec4): l0 = (position.xyz, radius), l1 = (intensity.xyz, kind), p = (p.xyz, strategy),
// q = (query direction.xyz, seed). The generator is rng_new(invocation, 0, seed).
// Out (4 vec4): a = (L.xyz, pdf), b = (wi.xyz, dist), c = (p_light.xyz, delta),
// d = (light_pdf_li at the sampled wi, light_pdf_li at q, light_radiance(q).x, 0).
//
// requires: lights.wgsl, rng.wgsl

struct Case {
    l0: vec4<f32>,
    l1: vec4<f32>,
    p: vec4<f32>,
    q: vec4<f32>,
}

struct Out {
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    d: vec4<f32>,
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
    let light = Light(c.l0.xyz, c.l0.w, c.l1.xyz, u32(c.l1.w), 0u, 0u, 0u, 0u, vec3<f32>(0.0, 0.0, 1.0), 0.0,
                      vec4<f32>(0.0));
    let strategy = u32(c.p.w);
    var rng = rng_new(i, 0u, u32(c.q.w));
    let ls = light_sample_li(light, c.p.xyz, strategy, &rng);
    var o: Out;
    o.a = vec4<f32>(ls.L, ls.pdf);
    o.b = vec4<f32>(ls.wi, ls.dist);
    o.c = vec4<f32>(ls.p_light, select(0.0, 1.0, ls.delta));
    o.d = vec4<f32>(light_pdf_li(light, c.p.xyz, ls.wi, strategy),
                    light_pdf_li(light, c.p.xyz, c.q.xyz, strategy),
                    light_radiance(light, c.q.xyz).x, 0.0);
    output[i] = o;
}
