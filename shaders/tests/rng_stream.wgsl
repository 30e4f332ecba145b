// Test kernel for rng.wgsl (tests/shader_rng.rs): one query per invocation.
// input[i] = (pixel, sample, seed, dim). The generator starts at rng_new(pixel, sample, seed) with its
// dimension set to dim; output[i] = (first rng_next, rng_next2 at dim .x, .y, second rng_next (dim + 1)).
//
// requires: rng.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let q = input[i];
    var a = rng_new(q.x, q.y, q.z);
    a.dim = q.w;
    let u0 = rng_next(&a);
    let u1 = rng_next(&a);
    var b = rng_new(q.x, q.y, q.z);
    b.dim = q.w;
    let v = rng_next2(&b);
    output[i] = vec4<f32>(u0, v.x, v.y, u1);
}
