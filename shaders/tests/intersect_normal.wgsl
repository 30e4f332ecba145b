// Test kernel for intersect.wgsl (tests/shader_intersect.rs): the geometric normal the renderer gives a
// triangle. input[3i .. 3i+3] = the vertices (w unused) -> output[i] = (triangle_normal(v0, v1, v2), 0).
//
// requires: intersect.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let n = triangle_normal(input[3u * i].xyz, input[3u * i + 1u].xyz, input[3u * i + 2u].xyz);
    output[i] = vec4<f32>(n, 0.0);
}
