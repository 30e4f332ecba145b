// Test kernel for sampling.wgsl (tests/shader_sampling.rs): draws one sample per invocation from the warp
// selected by input[0].x.
//
// input[0] = (mode, seed, p0, p1), input[1] = (axis.xyz, p2). When the input holds more than these two
// elements, invocation i warps the given u = input[2 + i].xy; otherwise it warps rng_next2 of
// rng_new(i, 0, seed): the renderer's own random numbers.
//
// mode 0: sample_cosine_hemisphere(axis, u)                           -> (w.xyz, 0)
// mode 1: sample_cone(axis, p2 = one_minus_cos_max, u)                -> (w.xyz, p2)
// mode 2: sample_cone(axis, omc, u), omc = sphere_cone_one_minus_cos(r = p0, d2 = p1)
//                                                                     -> (w.xyz, omc)
// mode 3: sample_gaussian2(u, sigma = p2)                             -> (g.xy, 0, 0)
// mode 4: sample_uniform_disk(u)                                      -> (p.xy, 0, 0)
// mode 5: sample_tent2(u, radius = p2)                                -> (t.xy, 0, 0)
// mode 6: the filters cut off to [lo, hi] = [p0, p1]: sample_tent_within(u.x, radius = p2, lo, hi) and
//         sample_gaussian_within(u.y, sigma = axis.x, lo, hi)         -> (t, g, 0, 0)
//
// requires: sampling.wgsl, rng.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&output) {
        return;
    }
    let head = input[0];
    let mode = u32(head.x);
    let axis = input[1].xyz;
    let p2 = input[1].w;
    var u: vec2<f32>;
    if arrayLength(&input) > 2u {
        u = input[2u + i].xy;
    } else {
        var rng = rng_new(i, 0u, u32(head.y));
        u = rng_next2(&rng);
    }
    var out = vec4<f32>(0.0);
    switch mode {
        case 0u: {
            out = vec4<f32>(sample_cosine_hemisphere(axis, u), 0.0);
        }
        case 1u: {
            out = vec4<f32>(sample_cone(axis, p2, u), p2);
        }
        case 2u: {
            let omc = sphere_cone_one_minus_cos(head.z, head.w);
            out = vec4<f32>(sample_cone(axis, omc, u), omc);
        }
        case 3u: {
            out = vec4<f32>(sample_gaussian2(u, p2), 0.0, 0.0);
        }
        case 5u: {
            out = vec4<f32>(sample_tent2(u, p2), 0.0, 0.0);
        }
        case 6u: {
            out = vec4<f32>(sample_tent_within(u.x, p2, head.z, head.w),
                            sample_gaussian_within(u.y, axis.x, head.z, head.w), 0.0, 0.0);
        }
        default: {
            out = vec4<f32>(sample_uniform_disk(u), 0.0, 0.0);
        }
    }
    output[i] = out;
}
