// Test kernel for camera.wgsl (tests/shader_camera.rs): primary rays for given film and lens positions.
// input[0] = (position.xyz, tan_half_fov), input[1] = (right.xyz, lens_radius),
// input[2] = (up.xyz, focus_distance), input[3] = (forward.xyz, _), input[4] = (width, height, kind, _),
// input[5 + i] = (film.xy, lens.xy) -> output[i] = camera_ray(...) as (o, 0), (d, 0); with kind = 1,
// orthographic_ray(...) with input[0].w as the half-width of the view.
//
// requires: camera.wgsl

struct RayOut {
    o: vec4<f32>,
    d: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<RayOut>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let q = input[5u + i];
    var ray = camera_ray(input[0].xyz, input[1].xyz, input[2].xyz, input[3].xyz, input[0].w,
                         u32(input[4].x), u32(input[4].y), q.xy, input[1].w, input[2].w, q.zw);
    if u32(input[4].z) == CAMERA_ORTHOGRAPHIC {
        ray = orthographic_ray(input[0].xyz, input[1].xyz, input[2].xyz, input[3].xyz, input[0].w,
                               u32(input[4].x), u32(input[4].y), q.xy);
    }
    output[i] = RayOut(vec4<f32>(ray.o, 0.0), vec4<f32>(ray.d, 0.0));
}
