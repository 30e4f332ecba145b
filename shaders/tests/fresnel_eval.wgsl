// Test kernel for bsdf.wgsl (tests/shader_bsdf.rs): the Fresnel reflectance on given inputs.
// input[i] = (cos_i, eta, _, _) -> output[i] = fresnel_dielectric(cos_i, eta).
//
// requires: bsdf.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    output[i] = fresnel_dielectric(input[i].x, input[i].y);
}
