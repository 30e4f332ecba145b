// accumulate.wgsl: per-pixel running sums that stay exact over millions of samples.
//
// Each pixel keeps the sum of its samples and the sum of their squares (for the variance), each with a
// Kahan compensation term (Kahan 1965): the rounding error of every addition is carried to the next one,
// so the total error stays O(eps) instead of O(n eps). A constant sample summed 10^7 times stays exact to a
// few ulps and a 1e5 firefly does not swallow the small samples that follow it.
//
// Shader compilers may simplify (a + b) - a to b when they treat float arithmetic as associative, which
// would remove the compensation. `guard` is a uniform equal to 1.0 that the compiler cannot see through:
// multiplying by it is exact, and it stops the algebraic shortcut.
//
// Samples that are not finite (NaN or +-Inf in any channel) never enter the sums: they are counted as
// black (zero radiance), so the divisor stays the number of samples taken and the image stays finite.

struct Accum {
    sum: vec4<f32>,
    sum_c: vec4<f32>, // Kahan compensation of sum
    sum_sq: vec4<f32>,
    sum_sq_c: vec4<f32>, // Kahan compensation of sum_sq
}

fn is_finite_f32(x: f32) -> bool {
    // Exponent bits all ones means Inf or NaN. Tested on the bits, which no fast-math rule may fold away.
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite_vec3(v: vec3<f32>) -> bool {
    return is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z);
}

// One compensated addition: returns the new (sum, compensation) as a pair of vec4s.
struct Kahan {
    sum: vec4<f32>,
    c: vec4<f32>,
}

fn kahan_add(sum: vec4<f32>, c: vec4<f32>, x: vec4<f32>, guard: f32) -> Kahan {
    let y = x - c;
    let t = sum + y;
    return Kahan(t, (t * guard - sum) - y);
}

fn accumulate_sample(acc: Accum, radiance: vec3<f32>, guard: f32) -> Accum {
    var l = radiance;
    if !is_finite_vec3(l) {
        l = vec3<f32>(0.0);
    }
    let x = vec4<f32>(l, 0.0);
    let s = kahan_add(acc.sum, acc.sum_c, x, guard);
    let q = kahan_add(acc.sum_sq, acc.sum_sq_c, x * x, guard);
    return Accum(s.sum, s.c, q.sum, q.c);
}
