// Test kernel for bsdf.wgsl (tests/shader_bsdf.rs): the BSDF interface as the integrator calls it.
// Case (5 vec4): m = (albedo.xyz, kind), k = (ior, entering (0/1), seed, _), wo, ns, q (a query
// direction), all unit vectors in .xyz. The generator is rng_new(invocation, 0, seed).
// Out (4 vec4): s = (sampled wi, pdf), w = (weight, flags), at = (bsdf_eval at wi, bsdf_pdf at wi),
// aq = (bsdf_eval at q, bsdf_pdf at q); plus r = (bsdf_eval(q -> wo), bsdf_is_delta) for reciprocity.
//
// requires: bsdf.wgsl, rng.wgsl

struct Case {
    m: vec4<f32>,
    k: vec4<f32>,
    wo: vec4<f32>,
    ns: vec4<f32>,
    q: vec4<f32>,
}

struct Out {
    s: vec4<f32>,
    w: vec4<f32>,
    at: vec4<f32>,
    aq: vec4<f32>,
    r: vec4<f32>,
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
    var mat: Material; // zero: the fields these kinds do not use
    mat.albedo = c.m.xyz;
    mat.kind = u32(c.m.w);
    mat.ior = c.k.x;
    let wo = c.wo.xyz;
    let ns = c.ns.xyz;
    let t = vec3<f32>(0.0); // isotropic materials only
    let entering = c.k.y != 0.0;
    var rng = rng_new(i, 0u, u32(c.k.z));
    let sh = Shading(ns, t, entering, true); // perturbed: the cases put wo anywhere
    let bs = bsdf_sample(mat, wo, sh, &rng);
    var o: Out;
    o.s = vec4<f32>(bs.wi, bs.pdf);
    o.w = vec4<f32>(bs.weight, f32(bs.flags));
    o.at = vec4<f32>(bsdf_eval(mat, wo, bs.wi, sh), bsdf_pdf(mat, wo, bs.wi, sh));
    o.aq = vec4<f32>(bsdf_eval(mat, wo, c.q.xyz, sh), bsdf_pdf(mat, wo, c.q.xyz, sh));
    o.r = vec4<f32>(bsdf_eval(mat, c.q.xyz, wo, sh), select(0.0, 1.0, bsdf_is_delta(mat)));
    output[i] = o;
}
