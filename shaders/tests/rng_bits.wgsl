// Test kernel for rng.wgsl (tests/shader_rng.rs): the raw hash and the float conversion.
// input[i] = (x, y, z, w) -> output[i].hash = pcg4d(input[i]),
// output[i].unit = the bits of u32_to_unit_float applied to each of x, y, z, w.
//
// requires: rng.wgsl

struct BitsOut {
    hash: vec4<u32>,
    unit: vec4<u32>, // bitcast<u32>(u32_to_unit_float(input[i].c)) for each component c
}

@group(0) @binding(0) var<storage, read> input: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> output: array<BitsOut>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let q = input[i];
    let unit = vec4<u32>(bitcast<u32>(u32_to_unit_float(q.x)), bitcast<u32>(u32_to_unit_float(q.y)),
                         bitcast<u32>(u32_to_unit_float(q.z)), bitcast<u32>(u32_to_unit_float(q.w)));
    output[i] = BitsOut(pcg4d(q), unit);
}
