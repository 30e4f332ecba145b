// Test kernel for bsdf.wgsl (tests/shader_bsdf.rs): refraction as the renderer calls it.
// input[2i] = (d.xyz, eta), input[2i + 1] = (n.xyz, _), with n facing the incoming side (dot(d, n) <= 0).
// output[i] = (refract_dir(d, n, eta), fresnel_dielectric(-dot(d, n), eta)).
//
// requires: bsdf.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let d = input[2u * i].xyz;
    let eta = input[2u * i].w;
    let n = input[2u * i + 1u].xyz;
    output[i] = vec4<f32>(refract_dir(d, n, eta), fresnel_dielectric(-dot(d, n), eta));
}
