// Test kernel for the environment light (tests/shader_area_lights.rs), over the map the test binds
// (env_texels, env_cdf). Case (3 vec4): l0 = (cos, sin of the rotation, map width, map height),
// l1 = (radiance multiplier.xyz, seed), q = (query direction.xyz, strategy).
// Out (3 vec4): a = (wi.xyz, pdf) of one environment_sample with rng_new(invocation, 0, seed),
// b = (L.xyz, environment_pdf at wi), c = (environment_radiance(q).xyz, environment_pdf at q).
//
// requires: lights.wgsl, rng.wgsl

struct Case {
    l0: vec4<f32>,
    l1: vec4<f32>,
    q: vec4<f32>,
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
    let light = Light(vec3<f32>(c.l0.x, c.l0.y, 0.0), 0.0, c.l1.xyz, LIGHT_ENVIRONMENT, 0u, u32(c.l0.z),
                      u32(c.l0.w), 0u, vec3<f32>(0.0, 0.0, 1.0), 0.0, vec4<f32>(0.0));
    var rng = rng_new(i, 0u, u32(c.l1.w));
    let ls = environment_sample(light, u32(c.q.w), rng_next2(&rng));
    var o: Out;
    o.a = vec4<f32>(ls.wi, ls.pdf);
    o.b = vec4<f32>(ls.L, environment_pdf(light, ls.wi));
    o.c = vec4<f32>(environment_radiance(light, c.q.xyz), environment_pdf(light, c.q.xyz));
    output[i] = o;
}
