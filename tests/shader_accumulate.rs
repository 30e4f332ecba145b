//! The accumulator (shaders/accumulate.wgsl) over millions of samples, read back from the GPU.
//!
//! Each test streams samples through `accumulate_sample`, the function the render kernel uses, and
//! compares the compensated sum (sum - c, evaluated in f64 on the host as `Film` does) with the exact
//! sum computed in f64. Beside each GPU check, a CPU f32 naive running sum (`sum += x`) is asserted to
//! FAIL the same case: the evidence that compensation is what makes it pass.

use bytemuck::{Pod, Zeroable};
use vkpath::gpu::testing;
use vkpath::gpu::types::GpuAccum;

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

/// The compensated total of channel `ch`, as the host reads it (film.rs).
fn total(a: &GpuAccum, ch: usize) -> f64 {
    a.sum[ch] as f64 - a.sum_c[ch] as f64
}

fn naive_f32_sum(first: f32, value: f32, count: u32) -> f32 {
    let mut s = 0f32;
    for i in 0..count {
        s += if i == 0 { first } else { value };
    }
    s
}

/// 10^7 samples of 0.1 (not representable: the f32 nearest it). The exact sum of those f32 values is
/// known in f64. Kahan summation keeps the error within a few ulps of the total (bound: 2u|sum| + O(n u^2),
/// Higham, "Accuracy and Stability of Numerical Algorithms", §4.3), i.e. ~1e-7 relative: we allow 4e-7.
/// The naive f32 running sum drifts by ~1e-2 relative here.
#[test]
fn constant_stream_of_ten_million_stays_exact() {
    let n = 10_000_000u32;
    let x = 0.1f32;
    let exact = n as f64 * x as f64;
    let acc = run(&[stream(x, x, n)]);
    for (ch, scale) in [(0, 1.0), (1, -1.0), (2, 0.5)] {
        let got = total(&acc[0], ch);
        let rel = (got - scale * exact).abs() / exact.abs();
        assert!(
            rel < 4e-7,
            "channel {ch}: compensated sum {got} vs {} (relative error {rel:e})",
            scale * exact
        );
    }
    // Sum of squares too (the variance depends on it).
    let exact_sq = n as f64 * (x as f64 * x as f64);
    let sq = acc[0].sum_sq[0] as f64 - acc[0].sum_sq_c[0] as f64;
    assert!(
        (sq - exact_sq).abs() / exact_sq < 4e-7,
        "sum of squares {sq} vs {exact_sq}"
    );
    // Evidence: the naive running sum fails this case by orders of magnitude more.
    let naive = naive_f32_sum(x, x, n) as f64;
    let naive_rel = (naive - exact).abs() / exact;
    assert!(
        naive_rel > 1e-3,
        "naive f32 sum unexpectedly accurate: relative error {naive_rel:e}"
    );
}

/// A 1e5 firefly followed by 10^6 samples of 0.01: in f32, 1e5 + 0.01 rounds to 1e5 + 0.0078125 (the
/// spacing of floats near 1e5 is 2^-7), so a naive sum loses ~22% of every later sample. The compensated
/// sum must keep them: total = 1e5 + 10^6 * 0.01 within 4e-7 relative.
#[test]
fn firefly_does_not_swallow_small_samples() {
    let (big, small, n) = (1.0e5f32, 0.01f32, 1_000_001u32);
    let exact = big as f64 + (n - 1) as f64 * small as f64;
    let acc = run(&[stream(big, small, n)]);
    let got = total(&acc[0], 0);
    assert!(
        (got - exact).abs() / exact < 4e-7,
        "compensated {got} vs exact {exact}"
    );
    let naive = naive_f32_sum(big, small, n) as f64;
    assert!(
        (naive - exact).abs() / exact > 1e-2,
        "naive sum {naive} unexpectedly close to {exact}"
    );
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
    for (ch, scale) in [(0, 1.0), (1, -1.0), (2, 0.5)] {
        let got = total(&acc[0], ch);
        assert!(got.is_finite(), "channel {ch} is not finite: {got}");
        assert_eq!(got, scale * 0.25 * finite, "channel {ch}");
        assert!(acc[0].sum_sq[ch].is_finite() && acc[0].sum_c[ch].is_finite());
    }
}

/// The film's mean and variance from the sums: a stream alternating... is covered by the render tests;
/// here, many independent streams at once (one per invocation) must not interfere: stream k of value k
/// sums to exactly count * k.
#[test]
fn parallel_streams_are_independent() {
    let streams: Vec<Stream> = (0..256).map(|k| stream(k as f32, k as f32, 1000)).collect();
    let acc = run(&streams);
    for (k, a) in acc.iter().enumerate() {
        assert_eq!(total(a, 0), 1000.0 * k as f64, "stream {k}");
    }
}
