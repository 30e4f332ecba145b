// accumulate.wgsl: per-pixel sums that are exact, so that any split of a render merges to the same bits.
//
// The mean. Each pixel keeps, per channel, the EXACT sum of its samples on a fixed grid: a long
// (Kulisch) accumulator, a 192-bit unsigned fixed-point integer whose unit is 2^-96. A sample x in
// [2^-73, 2^64) (1e-22 to 1.8e19: every radiance a scene produces) is an integer multiple of 2^-96 (its
// 24-bit significand ends at or above 2^-96), so it adds in without any rounding; a smaller sample is
// rounded to the nearest multiple of 2^-96 (ties to even: an absolute error of at most 6.3e-30), a
// larger one is clamped below 2^64. The top 32 bits leave room for 2^32 samples of the largest value.
// Integer addition is associative, so the sum does not depend on the order or grouping of the samples:
// a render cut into passes, tiles, checkpoints or `--sample-range` parts and merged gives the same bits,
// and the host rounds the exact total once when it divides by n (film.rs, accum.rs). See Kulisch &
// Miranker, "The arithmetic of the digital computer" (SIAM Review 1986), and Neal, "Fast exact summation
// using small and large superaccumulators" (2015). The window is 192 bits rather than the 277 that would
// hold every f32 so that the accumulator (96 bytes per pixel) of a 4096x4096 image fits the 2 GiB that
// lavapipe offers.
//
// The variance. The sums of squares only feed the error estimate, so they stay f32 with a Kahan
// compensation (Kahan 1965): the rounding error of every addition is carried into the next, so the total
// error is O(eps) rather than O(n eps). A merge adds them in f64 (a few ulps from a single render's).
// Shader compilers may simplify (a + b) - a to b when they treat float arithmetic as associative, which
// would remove the compensation. `guard` is a uniform equal to 1.0 that the compiler cannot see through:
// multiplying by it is exact, and it stops the algebraic shortcut.
//
// Samples that are not finite (NaN or +-Inf in any channel) never enter the sums: they are counted as
// black (zero radiance), so the divisor stays the number of samples taken and the image stays finite.
// Radiance is never negative (every factor of the estimator is >= 0); a negative channel, which only a
// bug could produce, is counted as 0 like a non-finite one, keeping the accumulator unsigned.
//
// The including kernel declares `accum: array<Accum>` (read_write storage); the functions below update
// one entry of it in place, touching only the two or three limbs a sample reaches.

const ACCUM_LIMBS: u32 = 6u;
// The largest f32 below 2^64, (2^24 - 1) 2^40, as bits: larger samples are clamped to it. For positive
// floats the order of the bit patterns is the order of the values, so min() on the bits clamps.
const ACCUM_MAX_BITS: u32 = 0x5f7fffffu;

struct Accum {
    // Channel c's sum is the integer sum[c * ACCUM_LIMBS + k] * 2^(32 k), k = 0..5 (little-endian
    // limbs), times 2^-96.
    sum: array<u32, 18>,
    sum_sq: array<f32, 3>,
    sum_sq_c: array<f32, 3>, // Kahan compensation of sum_sq
}

fn is_finite_f32(x: f32) -> bool {
    // Exponent bits all ones means Inf or NaN. Tested on the bits, which no fast-math rule may fold away.
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite_vec3(v: vec3<f32>) -> bool {
    return is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z);
}

// Adds x (finite) to channel c of accum[slot], exactly on the 2^-96 grid.
//
// x's bits: biased exponent e and 23 fraction bits f. A normal x (e >= 1) is (2^23 + f) 2^(e - 150),
// a subnormal f 2^-149: in both cases x = m 2^(s - 149) with m < 2^24 and s = max(e, 1) - 1, so
// x / 2^-96 = m 2^(s - 53). For s >= 53 that is the integer m shifted left by p = s - 53 <= 136: it lands
// in limb p / 32 at bit p % 32 and spills into the next limb; the carry out of those two limbs then
// ripples up (rarely more than one limb). For s < 53 it is m / 2^r, r = 53 - s, rounded to the nearest
// integer, ties to even: at most 2^24, in limb 0.
fn accumulate_exact(slot: u32, c: u32, x: f32) {
    var bits = bitcast<u32>(x);
    // +0 adds nothing; a set sign bit (-0, or a negative value the caller let through) counts as 0.
    if bits == 0u || bits >= 0x80000000u {
        return;
    }
    bits = min(bits, ACCUM_MAX_BITS);
    let e = bits >> 23u;
    let m = select(bits & 0x7fffffu, (bits & 0x7fffffu) | 0x800000u, e != 0u);
    let s = max(e, 1u) - 1u;
    let base = c * ACCUM_LIMBS;
    if s < 53u {
        let r = 53u - s;
        // For r >= 25, m < 2^24 <= 2^(r - 1) is below half a unit: it rounds to 0 (and a shift by 32 or
        // more would be taken modulo 32 in WGSL, so those never reach the shifts).
        if r >= 25u {
            return;
        }
        let half = 1u << (r - 1u);
        var q = m >> r;
        let rem = m & ((half << 1u) - 1u);
        if rem > half || (rem == half && (q & 1u) == 1u) {
            q += 1u;
        }
        add_to_limbs(slot, base, 0u, q, 0u);
        return;
    }
    let p = s - 53u;
    let o = p % 32u;
    // m >> (32 - o) for o = 0 would be a shift by 32, which WGSL takes modulo 32: select it out.
    add_to_limbs(slot, base, p / 32u, m << o, select(0u, m >> (32u - o), o != 0u));
}

// Adds lo + hi 2^32 (hi < 2^24) at limb k (k <= 4) of the channel whose limbs start at `base`.
fn add_to_limbs(slot: u32, base: u32, k: u32, lo: u32, hi: u32) {
    let i = base + k;
    let t0 = accum[slot].sum[i] + lo;
    accum[slot].sum[i] = t0;
    // hi < 2^24, so hi + carry cannot wrap.
    let h = hi + select(0u, 1u, t0 < lo);
    let t1 = accum[slot].sum[i + 1u] + h;
    accum[slot].sum[i + 1u] = t1;
    // The carry ripples up through limbs k + 2 .. 5 of the channel. Unrolled: lavapipe counts every loop
    // iteration against its per-invocation budget (trace.wgsl), even that of a loop that exits at once.
    let end = base + ACCUM_LIMBS;
    var carry = t1 < h;
    carry = ripple_carry(slot, i + 2u, end, carry);
    carry = ripple_carry(slot, i + 3u, end, carry);
    carry = ripple_carry(slot, i + 4u, end, carry);
    carry = ripple_carry(slot, i + 5u, end, carry);
}

// Adds an incoming carry to limb j (if j is still inside the channel, below `end`); returns the carry out.
fn ripple_carry(slot: u32, j: u32, end: u32, carry: bool) -> bool {
    if !carry || j >= end {
        return false;
    }
    let v = accum[slot].sum[j] + 1u;
    accum[slot].sum[j] = v;
    return v == 0u;
}

// Adds one sample (linear RGB radiance) to accum[slot].
fn accumulate_sample(slot: u32, radiance: vec3<f32>, guard: f32) {
    var l = max(radiance, vec3<f32>(0.0));
    if !is_finite_vec3(radiance) {
        l = vec3<f32>(0.0);
    }
    accumulate_exact(slot, 0u, l.x);
    accumulate_exact(slot, 1u, l.y);
    accumulate_exact(slot, 2u, l.z);

    // Kahan step on the squares: y = x - c; t = sum + y; c' = (t - sum) - y.
    let sq = vec3<f32>(accum[slot].sum_sq[0], accum[slot].sum_sq[1], accum[slot].sum_sq[2]);
    let comp = vec3<f32>(accum[slot].sum_sq_c[0], accum[slot].sum_sq_c[1], accum[slot].sum_sq_c[2]);
    // A square past the largest f32 (radiance above 1.8e19) is clamped to it rather than made infinite.
    let y = min(l * l, vec3<f32>(3.4028235e38)) - comp;
    let t = sq + y;
    let c2 = (t * guard - sq) - y;
    accum[slot].sum_sq[0] = t.x;
    accum[slot].sum_sq[1] = t.y;
    accum[slot].sum_sq[2] = t.z;
    accum[slot].sum_sq_c[0] = c2.x;
    accum[slot].sum_sq_c[1] = c2.y;
    accum[slot].sum_sq_c[2] = c2.z;
}
