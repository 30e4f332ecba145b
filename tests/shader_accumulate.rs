//! The accumulator (shaders/accumulate.wgsl) over millions of samples, read back from the GPU.
//!
//! Each test streams samples through `accumulate_into`, the function the render kernel uses. The sums
//! of samples are exact (a long accumulator): they are compared for EQUALITY with sums known exactly on
//! the host (in f64 or u128 where every partial sum is representable), and with the CPU mirror
//! `vkpath::accum::add_f32` limb for limb. The sums of squares are Kahan-compensated f32 and are held to
//! a relative bound. Beside each GPU check, a CPU f32 naive running sum (`sum += x`) is asserted to FAIL
//! the same case: the evidence that the accumulator is what makes it pass.

use bytemuck::{Pod, Zeroable};
use vkpath::accum;
use vkpath::gpu::testing;
use vkpath::kernel::abi::{ACCUM_LIMBS, GpuAccum};

const KERNEL: &str = include_str!("../shaders/tests/accumulate_stream.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Stream {
    state: GpuAccum,
    first: f32,
    value: f32,
    start: u32,
    count: u32,
    guard: f32,
    nan_every: u32,
    inf_every: u32,
    _pad: u32,
}

fn stream(first: f32, value: f32, count: u32) -> Stream {
    Stream {
        first,
        value,
        count,
        guard: 1.0,
        ..Default::default()
    }
}

/// Samples per kernel run: well inside lavapipe's 65535 loop iterations per invocation.
const CHUNK: u32 = 50_000;

/// Runs every stream to its end, CHUNK samples per dispatch, carrying the Accum state across runs
/// (through the host, bit for bit, as the renderer's accumulator persists across dispatches).
fn run(streams: &[Stream]) -> Vec<GpuAccum> {
    let mut kernel =
        testing::TestKernel::new(&testing::context(), KERNEL).expect("kernel compiles");
    let longest = streams.iter().map(|s| s.count).max().unwrap_or(0);
    let mut state = vec![GpuAccum::default(); streams.len()];
    let mut start = 0u32;
    while start < longest {
        let chunk: Vec<Stream> = streams
            .iter()
            .zip(&state)
            .map(|(s, acc)| Stream {
                state: *acc,
                start,
                count: s.count.saturating_sub(start).min(CHUNK),
                ..*s
            })
            .collect();
        state = kernel.run(&chunk, chunk.len()).expect("kernel runs");
        start += CHUNK;
    }
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    state
}

/// The exact total of channel `ch` rounded once to f64, as the host reads it (film.rs).
fn total(a: &GpuAccum, ch: usize) -> f64 {
    accum::to_f64(&accum::channel(a, ch))
}

/// The limbs the CPU mirror of the accumulator gives for the same stream (same rules for NaN/Inf).
fn cpu_limbs(s: &Stream, scale: f32) -> Vec<u32> {
    let mut limbs = vec![0u32; ACCUM_LIMBS];
    for i in 0..s.count {
        let mut x = if i == 0 { s.first } else { s.value };
        if s.nan_every > 0 && i % s.nan_every == s.nan_every - 1 {
            x = f32::NAN;
        }
        if s.inf_every > 0 && i % s.inf_every == s.inf_every - 1 {
            x = f32::INFINITY;
        }
        accum::add_f32(&mut limbs, scale * x);
    }
    limbs
}

fn naive_f32_sum(first: f32, value: f32, count: u32) -> f32 {
    let mut s = 0f32;
    for i in 0..count {
        s += if i == 0 { first } else { value };
    }
    s
}

/// 10^7 samples of 0.1 (not representable: the f32 nearest it). The exact sum of those f32 values is
/// n x (a 24-bit mantissa), 48 significant bits: exact in f64, so the GPU's sum must EQUAL it. The
/// negated channel adds nothing (negative radiance counts as 0). The sum of squares is a Kahan sum: its
/// error stays within a few ulps of the total (bound 2u|sum| + O(n u^2), Higham, "Accuracy and Stability
/// of Numerical Algorithms", §4.3), i.e. ~1e-7 relative: we allow 4e-7. The naive f32 running sum drifts
/// by ~1e-2 relative here.
#[test]
fn constant_stream_of_ten_million_is_exact() {
    let n = 10_000_000u32;
    let x = 0.1f32;
    let exact = n as f64 * x as f64;
    let acc = run(&[stream(x, x, n)]);
    assert_eq!(total(&acc[0], 0), exact);
    assert_eq!(total(&acc[0], 1), 0.0);
    assert_eq!(total(&acc[0], 2), 0.5 * exact);
    // Sum of squares (the variance depends on it): squares are rounded to f32, then summed.
    let exact_sq = n as f64 * f64::from(x * x);
    let sq = acc[0].sum_sq[0] as f64 - acc[0].sum_sq_c[0] as f64;
    assert!(
        (sq - exact_sq).abs() / exact_sq < 4e-7,
        "sum of squares {sq} vs {exact_sq}"
    );
    // Evidence: the naive running sum fails this case by orders of magnitude.
    let naive = naive_f32_sum(x, x, n) as f64;
    let naive_rel = (naive - exact).abs() / exact;
    assert!(
        naive_rel > 1e-3,
        "naive f32 sum unexpectedly accurate: relative error {naive_rel:e}"
    );
}

/// A 1e5 firefly followed by 10^6 samples of 0.01: in f32, 1e5 + 0.01 rounds to 1e5 + 0.0078125 (the
/// spacing of floats near 1e5 is 2^-7), so a naive sum loses ~22% of every later sample. The exact sum
/// spans 2^-34 (0.01's last bit) to 2^17 with 20 bits of count: 71 bits, too many for f64, so the
/// reference is a u128 in units of 2^-34, rounded once to f64; the limbs must equal the CPU mirror's.
#[test]
fn firefly_does_not_swallow_small_samples() {
    let (big, small, n) = (1.0e5f32, 0.01f32, 1_000_001u32);
    let units = |x: f32| -> u128 {
        let u = f64::from(x) * 2f64.powi(34);
        assert_eq!(u.fract(), 0.0, "{x} is a multiple of 2^-34");
        u as u128
    };
    let exact_units = units(big) + u128::from(n - 1) * units(small);
    let exact = exact_units as f64 * 2f64.powi(-34);
    let s = stream(big, small, n);
    let acc = run(&[s]);
    assert_eq!(total(&acc[0], 0), exact);
    assert_eq!(accum::channel(&acc[0], 0).to_vec(), cpu_limbs(&s, 1.0));
    let naive = naive_f32_sum(big, small, n) as f64;
    assert!(
        (naive - exact).abs() / exact > 1e-2,
        "naive sum {naive} unexpectedly close to {exact}"
    );
}

/// The ends of the accumulator's window, 60,000 samples each: its unit 2^-96 (bit 0) adds exactly;
/// 0.75 units round to 1 and 1.5 units to 2 (ties to even), the smallest subnormal to 0; the largest
/// f32 is clamped to the largest value held, just below 2^64 (whose top bit is bit 159 of 192). The
/// CPU mirror, written with f64 rounding instead of shifts, must give the same limbs.
#[test]
fn window_ends_round_and_clamp_as_specified() {
    let n = 60_000u32;
    let unit = 2f32.powi(-96);
    let values = [unit, 0.75 * unit, 1.5 * unit, f32::from_bits(1), f32::MAX];
    let streams: Vec<Stream> = values.iter().map(|&x| stream(x, x, n)).collect();
    let acc = run(&streams);
    let per_sample = [1u64, 1, 2, 0];
    for (k, &units) in per_sample.iter().enumerate() {
        let limbs = accum::channel(&acc[k], 0);
        let expected = units * u64::from(n);
        assert_eq!(
            [limbs[0], limbs[1]],
            [expected as u32, (expected >> 32) as u32],
            "value {:e}",
            values[k]
        );
        assert!(limbs[2..].iter().all(|&l| l == 0));
    }
    assert_eq!(
        total(&acc[4], 0),
        f64::from(n) * f64::from(accum::MAX_SAMPLE)
    );
    for (a, s) in acc.iter().zip(&streams) {
        assert_eq!(accum::channel(a, 0).to_vec(), cpu_limbs(s, 1.0));
        assert_eq!(accum::channel(a, 2).to_vec(), cpu_limbs(s, 0.5));
    }
    // A naive f32 sum of the largest f32 overflows at the second sample.
    assert!(naive_f32_sum(f32::MAX, f32::MAX, 2).is_infinite());
}

/// Non-finite samples never reach the sums: the convention is that a NaN or Inf sample counts as black
/// (zero radiance) — the divisor stays the number of samples taken, so the estimate stays finite and is
/// biased low only by the (rare) lost paths. Here 1 in 3 samples is NaN and 1 in 5 is +Inf.
#[test]
fn nan_and_inf_samples_count_as_black() {
    let n = 3000u32;
    let mut s = stream(0.25, 0.25, n);
    s.nan_every = 3;
    s.inf_every = 5;
    let acc = run(&[s]);
    let finite = (0..n).filter(|i| i % 3 != 2 && i % 5 != 4).count() as f64;
    for (ch, scale) in [(0, 1.0), (1, 0.0), (2, 0.5)] {
        let got = total(&acc[0], ch);
        assert_eq!(got, scale * 0.25 * finite, "channel {ch}");
        assert!(acc[0].sum_sq[ch].is_finite() && acc[0].sum_sq_c[ch].is_finite());
    }
    assert_eq!(accum::channel(&acc[0], 0).to_vec(), cpu_limbs(&s, 1.0));
}

/// Many independent streams at once (one per invocation) must not interfere: stream k of value k sums to
/// exactly count * k.
#[test]
fn parallel_streams_are_independent() {
    let streams: Vec<Stream> = (0..256).map(|k| stream(k as f32, k as f32, 1000)).collect();
    let acc = run(&streams);
    for (k, a) in acc.iter().enumerate() {
        assert_eq!(total(a, 0), 1000.0 * k as f64, "stream {k}");
    }
}
