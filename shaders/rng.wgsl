// rng.wgsl: counter-based random numbers.
//
// Every random number is a pure function of (pixel, sample index, dimension, seed): no state survives
// between invocations, so a render can be split into passes, dispatches or machines and merged exactly.
// The generator is the 4-D PCG hash "pcg4d" of Jarzynski & Olano, "Hash Functions for GPU Rendering",
// JCGT 9(3), 2020. Each of its steps (multiply-add by odd constants, x += y*z, xor-shift) is invertible,
// so distinct inputs (pixel, sample, dim, seed) give distinct 128-bit outputs: no two paths share numbers.
//
// Two samplers share that contract (`render.sampler`):
// * SAMPLER_INDEPENDENT: each draw is hashed from (pixel, sample, dim, seed).
// * SAMPLER_SOBOL: each draw is a point of a 2-D Sobol' sequence over the pixel's sample index, with its
//   own randomisation per (pixel, dim, seed), i.e. "padded" 2-D (0,2)-sequences: the first 2^m samples of
//   a pixel form a (0,m,2)-net in every pair of dimensions (one point in every dyadic box of area 2^-m),
//   which stratifies the film position, the lens, and each bounce's light and BSDF samples. Following
//   Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020: the point is Owen-scrambled (nested
//   uniform scrambling, by a hash that flips each bit depending only on the bits above it), which keeps
//   the net property and makes every point uniformly distributed, so estimates stay unbiased; and the
//   sample index is itself scrambled the same way ("shuffled"), which decorrelates the dimension pairs
//   (without it, every pair would walk the same sequence in the same order).
//
// requires: (nothing)

const SAMPLER_INDEPENDENT: u32 = 0u;
const SAMPLER_SOBOL: u32 = 1u;
// Specialisation (features.wgsl explains the scheme): the generic kernel and the test kernels read the
// sampler from the Rng at run time; a kernel specialised for a scene has it as a constant, and the other
// sampler's code is pruned away (a scene that does not use Sobol' points pays nothing for them).
override SAMPLER_FROM_RNG: bool = true;
override SAMPLER_IS_SOBOL: bool = false;

struct Rng {
    pixel: u32,
    sample: u32,
    seed: u32,
    dim: u32, // the next dimension to draw; each draw consumes one
    sampler: u32, // SAMPLER_INDEPENDENT or SAMPLER_SOBOL
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
    return Rng(pixel, sample, seed, 0u, SAMPLER_INDEPENDENT);
}

fn rng_new_sampler(pixel: u32, sample: u32, seed: u32, sampler: u32) -> Rng {
    return Rng(pixel, sample, seed, 0u, sampler);
}

// Maps the top 24 bits to [0, 1): k * 2^-24 for k in [0, 2^24), so 1.0 is never returned and every value
// is exactly representable in f32.
fn u32_to_unit_float(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// One uniform number in [0, 1).
fn rng_next(rng: ptr<function, Rng>) -> f32 {
    return u32_to_unit_float(rng_next_bits(rng).x);
}

// Two uniform numbers in [0, 1)^2.
fn rng_next2(rng: ptr<function, Rng>) -> vec2<f32> {
    let u = rng_next_bits(rng);
    return vec2<f32>(u32_to_unit_float(u.x), u32_to_unit_float(u.y));
}

// The next draw as two 32-bit words; consumes one dimension. Independent: the x and y words of one hash
// (independent outputs). Sobol': the point of the dimension pair (x alone, a scrambled and shuffled van
// der Corput sequence, serves rng_next). The sampler test is written with bare constant conditions so
// that a specialised kernel keeps only one sampler's code (features.wgsl explains the pruning).
fn rng_next_bits(rng: ptr<function, Rng>) -> vec2<u32> {
    let r = *rng;
    (*rng).dim += 1u;
    if SAMPLER_FROM_RNG {
        if r.sampler == SAMPLER_SOBOL {
            return sobol_owen2(r.pixel, r.sample, r.dim, r.seed);
        }
    } else {
        if SAMPLER_IS_SOBOL {
            return sobol_owen2(r.pixel, r.sample, r.dim, r.seed);
        }
    }
    return pcg4d(vec4<u32>(r.pixel, r.sample, r.dim, r.seed)).xy;
}

// --- Sobol' ---------------------------------------------------------------------------------------------

// Point `sample` of pixel `pixel`'s sequence for dimension pair `dim`, as two 32-bit fractions. Its three
// seeds (index shuffle, x scramble, y scramble) are hashed from (pixel, dim, seed) with the sample slot
// fixed, so that all samples of a pixel walk one sequence.
fn sobol_owen2(pixel: u32, sample: u32, dim: u32, seed: u32) -> vec2<u32> {
    let k = pcg4d(vec4<u32>(pixel, 0xffffffffu, dim, seed));
    let i = nested_uniform_scramble(sample, k.x);
    return vec2<u32>(nested_uniform_scramble(reverseBits(i), k.y),
                     nested_uniform_scramble(sobol_dim1(i), k.z));
}

// Laine & Karras' hash (as improved by Burley 2020, §3): x + seed, then x ^= x * c for even constants c.
// Multiplying by an even number only moves bits up, so output bit j depends on input bits 0..j only: on
// bit-reversed values, each bit of the result depends only on itself and the bits more significant than it
// in the [0, 1) fraction, which is what nested uniform (Owen) scrambling requires.
fn laine_karras_permutation(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Owen scrambling of a 32-bit fraction (bit 31 = 1/2) by a hash of its reversed bits.
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras_permutation(reverseBits(x), seed));
}

// The second dimension of Sobol's sequence as a 32-bit fraction: the sum (xor) of the direction numbers
// v_k over the set bits k of i, where v_0 = 2^31 and v_k = v_(k-1) ^ (v_(k-1) >> 1) (primitive polynomial
// x + 1). Bit 31 - j of v_k is C(k, j) mod 2, which by Lucas' theorem is 1 exactly when the bits of j are
// a subset of those of k. So bit 31 - j of the result is the parity of the set bits k of i with k a
// superset of j: a superset (zeta) transform over the five bits of a bit position, five masked shift-xors
// (no loop: lavapipe counts every loop iteration against its budget), then a reversal.
fn sobol_dim1(i: u32) -> u32 {
    var x = i;
    x ^= (x >> 1u) & 0x55555555u; // positions j with bit 0 clear take position j + 1
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return reverseBits(x);
}
