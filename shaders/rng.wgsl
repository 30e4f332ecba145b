// rng.wgsl: counter-based random numbers.
//
// Every random number is a pure function of (pixel, sample index, dimension, seed): no state survives
// between invocations, so a render can be split into passes, dispatches or machines and merged exactly.
// The generator is the 4-D PCG hash "pcg4d" of Jarzynski & Olano, "Hash Functions for GPU Rendering",
// JCGT 9(3), 2020. Each of its steps (multiply-add by odd constants, x += y*z, xor-shift) is invertible,
// so distinct inputs (pixel, sample, dim, seed) give distinct 128-bit outputs: no two paths share numbers.

struct Rng {
    pixel: u32,
    sample: u32,
    seed: u32,
    dim: u32, // the next dimension to draw; each draw consumes one
}

fn pcg4d(v_in: vec4<u32>) -> vec4<u32> {
    var v = v_in * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

fn rng_new(pixel: u32, sample: u32, seed: u32) -> Rng {
    return Rng(pixel, sample, seed, 0u);
}

// Maps the top 24 bits to [0, 1): k * 2^-24 for k in [0, 2^24), so 1.0 is never returned and every value
// is exactly representable in f32.
fn u32_to_unit_float(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// One uniform number in [0, 1).
fn rng_next(rng: ptr<function, Rng>) -> f32 {
    let h = pcg4d(vec4<u32>((*rng).pixel, (*rng).sample, (*rng).dim, (*rng).seed));
    (*rng).dim += 1u;
    return u32_to_unit_float(h.x);
}

// Two uniform numbers in [0, 1)^2 from one hash (its x and y words are independent outputs).
fn rng_next2(rng: ptr<function, Rng>) -> vec2<f32> {
    let h = pcg4d(vec4<u32>((*rng).pixel, (*rng).sample, (*rng).dim, (*rng).seed));
    (*rng).dim += 1u;
    return vec2<f32>(u32_to_unit_float(h.x), u32_to_unit_float(h.y));
}
