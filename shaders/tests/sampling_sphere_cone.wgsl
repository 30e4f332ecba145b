// Test kernel for sampling.wgsl (tests/shader_sampling.rs): the cone a sphere light subtends.
// input[i] = (r, d2, _, _) -> output[i] = sphere_cone_one_minus_cos(r, d2).
//
// requires: sampling.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    output[i] = sphere_cone_one_minus_cos(input[i].x, input[i].y);
}
