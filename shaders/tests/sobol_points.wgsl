// Test kernel for the Sobol' sampler of rng.wgsl (tests/shader_rng_sobol.rs): one query per invocation.
// input[i] = (pixel, sample, dim, seed); output[i] = (the scrambled point's x and y as 32-bit fractions,
// the unscrambled Sobol' point of index `sample`: reverseBits(sample) and sobol_dim1(sample)).
//
// requires: rng.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let q = input[i];
    let p = sobol_owen2(q.x, q.y, q.z, q.w);
    output[i] = vec4<u32>(p.x, p.y, reverseBits(q.y), sobol_dim1(q.y));
}
