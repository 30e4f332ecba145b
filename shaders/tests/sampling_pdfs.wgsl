// Test kernel for sampling.wgsl (tests/shader_sampling.rs): the warps' own densities, evaluated where the
// chi-square tests' quadrature asks for them, so that the expected bin counts come from the shader's pdfs
// and not from a density re-derived on the CPU.
//
// input[i] = (mode, x, y, param), the arguments of one pdf call, passed as they are -> output[i]:
//
// mode 0: cosine_hemisphere_pdf(cos_theta = x)
// mode 1: cone_pdf(one_minus_cos = x, one_minus_cos_max = y)
// mode 3: gaussian2_pdf(vec2(x, y), sigma = param)
// mode 4: uniform_disk_pdf(vec2(x, y))
//
// The modes are those of the warps in sampling_warps.wgsl; its mode 2 (the sphere-light cone) samples
// sample_cone too, so its density is mode 1's. Any other mode gives -1, which no density is: the test
// asserts every value is finite and non-negative.
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
    let q = input[i];
    var pdf = -1.0;
    switch u32(q.x) {
        case 0u: {
            pdf = cosine_hemisphere_pdf(q.y);
        }
        case 1u: {
            pdf = cone_pdf(q.y, q.z);
        }
        case 3u: {
            pdf = gaussian2_pdf(vec2<f32>(q.y, q.z), q.w);
        }
        case 4u: {
            pdf = uniform_disk_pdf(vec2<f32>(q.y, q.z));
        }
        default: {}
    }
    output[i] = pdf;
}
