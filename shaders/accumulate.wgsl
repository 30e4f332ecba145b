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
// What exactness costs is measured against the Kahan accumulator it replaced in docs/performance.md
// (lavapipe: nothing measurable on scenes whose paths cost anything; a large share on 01-sphere, whose
// paths are so cheap that the six limb additions per sample dominate).
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
// Neither change is silent: accumulate_into returns SAMPLE_CLAMPED when some channel was at or above
// 2^64 (clamped to just below it: a point light of intensity 1e36 next to a wall gives such samples) and
// SAMPLE_NOT_FINITE when the sample was dropped, and the render kernel counts both for the host to
// report. Counting was chosen over a window wide enough for every finite f32 (277 bits, 9 limbs: 132
// bytes per pixel, so 4096x4096 would no longer fit lavapipe's 2 GiB, and three more limb additions per
// sample) because such radiance is a scene error to be told about, not a value to be kept: its cost is
// one comparison per sample (docs/robustness.md).
//
// accumulate_into updates an entry the caller holds in registers (the render kernel reads a pixel's entry
// once per dispatch and writes it once); add_exact adds to the exact sums alone (the splat gather,
// splat.wgsl, which keeps its weighted sums in a SplatAccum).
//
// requires: (nothing)

const ACCUM_LIMBS: u32 = 6u;
// The largest f32 below 2^64, (2^24 - 1) 2^40, as bits: larger samples are clamped to it. For positive
// floats the order of the bit patterns is the order of the values, so min() on the bits clamps.
const ACCUM_MAX_BITS: u32 = 0x5f7fffffu;
// accumulate_into's result: bit flags, 0 when the sample went in exactly as it was.
const SAMPLE_CLAMPED: u32 = 1u;
const SAMPLE_NOT_FINITE: u32 = 2u;

struct Accum {
    // Limb-major: sum[3 k + c] is limb k (k = 0..5, least significant first) of channel c. Channel c's
    // sum is the integer sum over k of sum[3 k + c] 2^(32 k), times 2^-96. Keeping a limb's three
    // channels together lets one vec3<u32> operation add all three.
    sum: array<u32, 18>,
    sum_sq: array<f32, 3>,
    sum_sq_c: array<f32, 3>, // Kahan compensation of sum_sq
}

// A pixel's splatted sums (render.splat; splat.wgsl): per channel the exact sum of w L over the samples
// whose filter covers the pixel, laid out as Accum.sum, and the exact sum of their weights w as a 64-bit
// integer in units of 2^-SPLAT_WEIGHT_BITS (weight[0] the low word). Mirrored by GpuSplatAccum.
const SPLAT_WEIGHT_BITS: u32 = 24u;
struct SplatAccum {
    sum: array<u32, 18>,
    weight: array<u32, 2>,
}

fn is_finite_f32(x: f32) -> bool {
    // Exponent bits all ones means Inf or NaN. Tested on the bits, which no fast-math rule may fold away.
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite_vec3(v: vec3<f32>) -> bool {
    return is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z);
}

// A sample as a 192-bit integer on the 2^-96 grid, per channel: the value lo + hi 2^32 placed at limb k
// (hi < 2^24, k <= 4).
struct GridTerm {
    k: vec3<u32>,
    lo: vec3<u32>,
    hi: vec3<u32>,
}

// The grid integer of x >= 0 (any sign bit, -0 included, gives 0; the caller has removed non-finite x).
//
// x's bits: biased exponent e and 23 fraction bits f. A normal x (e >= 1) is (2^23 + f) 2^(e - 150),
// a subnormal f 2^-149: in both cases x = m 2^(s - 149) with m < 2^24 and s = max(e, 1) - 1, so
// x / 2^-96 = m 2^(s - 53). For s >= 53 that is the integer m shifted left by p = s - 53 <= 136: limb
// p / 32, bit p % 32, spilling into the next limb. For s < 53 it is m / 2^r, r = 53 - s, rounded to the
// nearest integer, ties to even: at most 2^24, in limb 0 (and 0 for r >= 25, where m < 2^(r - 1)).
// Every step is a select rather than a branch: the three channels (and, on a SIMD machine, neighbouring
// pixels) take different paths, and divergent branches or lane-dependent indexing would serialise them.
fn grid_term(x: vec3<f32>) -> GridTerm {
    let raw = bitcast<vec3<u32>>(x);
    let positive = (raw != vec3<u32>(0u)) & (raw < vec3<u32>(0x80000000u));
    let bits = min(raw, vec3<u32>(ACCUM_MAX_BITS));
    let e = bits >> vec3<u32>(23u);
    let f = bits & vec3<u32>(0x7fffffu);
    let m = select(f, f | vec3<u32>(0x800000u), e != vec3<u32>(0u));
    let s = max(e, vec3<u32>(1u)) - vec3<u32>(1u);
    let large = s >= vec3<u32>(53u);
    // s >= 53: shift left by p.
    let p = select(vec3<u32>(0u), s - vec3<u32>(53u), large);
    let o = p % vec3<u32>(32u);
    // m >> (32 - o) for o = 0 would be a shift by 32, which WGSL takes modulo 32: select it out.
    let spill = select(vec3<u32>(0u), m >> (vec3<u32>(32u) - o), o != vec3<u32>(0u));
    // s < 53: divide by 2^r and round half to even (r clamped to 1..24 so that every shift is in range;
    // r >= 25 rounds to 0).
    let r = clamp(vec3<u32>(53u) - min(s, vec3<u32>(52u)), vec3<u32>(1u), vec3<u32>(24u));
    let half = vec3<u32>(1u) << (r - vec3<u32>(1u));
    let q0 = m >> r;
    let rem = m & ((half << vec3<u32>(1u)) - vec3<u32>(1u));
    let round_up = (rem > half) | ((rem == half) & ((q0 & vec3<u32>(1u)) == vec3<u32>(1u)));
    let q = select(q0, q0 + vec3<u32>(1u), round_up);
    let tiny = s + vec3<u32>(25u) <= vec3<u32>(53u); // r >= 25
    let small_q = select(q, vec3<u32>(0u), tiny);
    let zero = vec3<u32>(0u);
    return GridTerm(
        select(zero, p / vec3<u32>(32u), large),
        select(zero, select(small_q, m << o, large), positive),
        select(zero, select(zero, spill, large), positive),
    );
}

// Limb j of *acc += the term's limb j + carry_in (vec3 of 0/1); returns the carry out.
fn add_limb(acc: ptr<function, Accum>, j: u32, t: GridTerm, carry_in: vec3<u32>) -> vec3<u32> {
    let zero = vec3<u32>(0u);
    let jj = vec3<u32>(j);
    let term = select(zero, t.lo, t.k == jj) | select(zero, t.hi, t.k + vec3<u32>(1u) == jj);
    let i = 3u * j;
    let a = vec3<u32>((*acc).sum[i], (*acc).sum[i + 1u], (*acc).sum[i + 2u]);
    let s1 = a + term;
    let s2 = s1 + carry_in;
    (*acc).sum[i] = s2.x;
    (*acc).sum[i + 1u] = s2.y;
    (*acc).sum[i + 2u] = s2.z;
    return select(zero, vec3<u32>(1u), (s1 < a) | (s2 < s1));
}

// The exact sums += l (finite, >= 0 per channel; larger than 2^64 clamped): a 192-bit add with carry,
// limb by limb, unrolled (lavapipe counts every loop iteration against its per-invocation budget,
// trace.wgsl). The squares are left alone.
fn add_exact(acc: ptr<function, Accum>, l: vec3<f32>) {
    let t = grid_term(l);
    var carry = add_limb(acc, 0u, t, vec3<u32>(0u));
    carry = add_limb(acc, 1u, t, carry);
    carry = add_limb(acc, 2u, t, carry);
    carry = add_limb(acc, 3u, t, carry);
    carry = add_limb(acc, 4u, t, carry);
    carry = add_limb(acc, 5u, t, carry);
}

// Adds one sample (linear RGB radiance) to an accumulator held in registers; returns SAMPLE_* flags
// saying what was changed. The render kernel reads a pixel's entry once, adds the samples of its dispatch
// to it in index order, and writes it once (trace.wgsl); the sums are exact, so the bits do not depend on
// how many samples one dispatch adds.
fn accumulate_into(acc: ptr<function, Accum>, radiance: vec3<f32>, guard: f32) -> u32 {
    var l = max(radiance, vec3<f32>(0.0));
    var fault = 0u;
    if !is_finite_vec3(radiance) {
        l = vec3<f32>(0.0);
        fault = SAMPLE_NOT_FINITE;
    }
    // Positive finite floats order as their bits; -0 (which max may return) has the sign bit set.
    let l_bits = bitcast<vec3<u32>>(l);
    if any((l_bits > vec3<u32>(ACCUM_MAX_BITS)) & (l_bits < vec3<u32>(0x7f800000u))) {
        fault |= SAMPLE_CLAMPED;
    }
    add_exact(acc, l);

    // Kahan step on the squares: y = x - c; t = sum + y; c' = (t - sum) - y.
    let sq = vec3<f32>((*acc).sum_sq[0], (*acc).sum_sq[1], (*acc).sum_sq[2]);
    let comp = vec3<f32>((*acc).sum_sq_c[0], (*acc).sum_sq_c[1], (*acc).sum_sq_c[2]);
    // A square past the largest f32 (radiance above 1.8e19) is clamped to it rather than made infinite.
    let y = min(l * l, vec3<f32>(3.4028235e38)) - comp;
    let ts = sq + y;
    let c2 = (ts * guard - sq) - y;
    (*acc).sum_sq[0] = ts.x;
    (*acc).sum_sq[1] = ts.y;
    (*acc).sum_sq[2] = ts.z;
    (*acc).sum_sq_c[0] = c2.x;
    (*acc).sum_sq_c[1] = c2.y;
    (*acc).sum_sq_c[2] = c2.z;
    return fault;
}
