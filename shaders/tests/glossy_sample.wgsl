// Test kernel for the glossy materials of bsdf.wgsl (tests/shader_glossy.rs): the BSDF interface as the
// integrator calls it, for any material as the host uploads it.
// Case: the material (GpuMaterial), wo = (wo, entering 0/1), ns = (shading normal, seed), t = (tangent, _),
// q = (a query direction, _); unit vectors in .xyz. The generator is rng_new(invocation, 0, seed).
// Out: s = (sampled wi, pdf), w = (weight, flags), at = (bsdf_eval at wi, bsdf_pdf at wi),
// aq = (bsdf_eval at q, bsdf_pdf at q), r = (bsdf_eval with wo and q swapped, bsdf_is_delta): the swap
// puts the normal on q's side and flips `entering` when q is below the surface, as the integrator would
// see the reversed path; rp = (bsdf_pdf with wo and q swapped, bsdf_transmits, _, _).
//
// requires: bsdf.wgsl, rng.wgsl

struct Case {
    mat: Material,
    wo: vec4<f32>,
    ns: vec4<f32>,
    t: vec4<f32>,
    q: vec4<f32>,
}

struct Out {
    s: vec4<f32>,
    w: vec4<f32>,
    at: vec4<f32>,
    aq: vec4<f32>,
    r: vec4<f32>,
    rp: vec4<f32>,
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
    let mat = c.mat;
    let wo = c.wo.xyz;
    let entering = c.wo.w != 0.0;
    let ns = c.ns.xyz;
    let t = c.t.xyz;
    let q = c.q.xyz;
    var rng = rng_new(i, 0u, u32(c.ns.w));
    // A perturbed frame: the cases put wo anywhere, on or below ns's horizon included.
    let sh = Shading(ns, t, entering, true);
    let bs = bsdf_sample(mat, wo, sh, &rng);
    var o: Out;
    o.s = vec4<f32>(bs.wi, bs.pdf);
    o.w = vec4<f32>(bs.weight, f32(bs.flags));
    o.at = vec4<f32>(bsdf_eval(mat, wo, bs.wi, sh), bsdf_pdf(mat, wo, bs.wi, sh));
    o.aq = vec4<f32>(bsdf_eval(mat, wo, q, sh), bsdf_pdf(mat, wo, q, sh));
    let above = dot(q, ns) >= 0.0;
    let ns2 = select(-ns, ns, above);
    let entering2 = select(!entering, entering, above);
    let sh2 = Shading(ns2, t, entering2, true);
    o.r = vec4<f32>(bsdf_eval(mat, q, wo, sh2), select(0.0, 1.0, bsdf_is_delta(mat)));
    o.rp = vec4<f32>(bsdf_pdf(mat, q, wo, sh2), select(0.0, 1.0, bsdf_transmits(mat)), 0.0, 0.0);
    output[i] = o;
}
