// Test kernel for tests/shader_bounds.rs: a storage buffer read past its end.
// output[i].x = input[input[i].x].y
//
// requires: (nothing)

@group(0) @binding(0) var<storage, read> input: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    output[id.x] = vec4<u32>(input[input[id.x].x].y, 0u, 0u, 0u);
}
