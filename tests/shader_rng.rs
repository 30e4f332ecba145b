//! The random number generator (shaders/rng.wgsl), read back from the GPU.
//!
//! * Exactness: the GPU hash equals a CPU twin of pcg4d bit for bit, and every float is k * 2^-24 with
//!   k < 2^24, so [0, 1) holds by construction (1.0 is never returned, even for the hash value 2^32 - 1).
//! * Uniformity: Pearson's chi-square on 256 equal bins of 2^20 draws.
//! * Independence of neighbouring pixels, consecutive samples, consecutive dimensions, the two words of
//!   `rng_next2` and neighbouring seeds: the correlation coefficient of 2^18 pairs is within 5/sqrt(N)
//!   of 0 (under independence it is ~N(0, 1/N), so 5 sigma: a false failure has probability 6e-7), and a
//!   2-D chi-square on 16 x 16 cells of the pairs.
//!
//! Statistical tests use fixed seeds, so they are deterministic; the significance level ALPHA = 1e-4 says
//! how rarely a correct generator would fail for an arbitrary seed. Each test is shown to have power by
//! a companion negative test that feeds it a slightly wrong distribution and asserts a huge statistic.

mod common;

use common::stats::{Chi2, assert_fits, chi2, chi2_critical, normal_upper_quantile};
use vkpath::gpu::testing;

const STREAM: &str = include_str!("../shaders/tests/rng_stream.wgsl");
const BITS: &str = include_str!("../shaders/tests/rng_bits.wgsl");

// ---------------------------------------------------------------------------------------------------
// Statistics: the chi-square helpers and ALPHA are in tests/common/stats.rs.

/// Pearson's correlation coefficient.
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Chi-square of values in [0, 1) against the uniform law, on `bins` equal bins.
fn uniform_chi2(values: &[f64], bins: usize) -> Chi2 {
    let mut obs = vec![0.0; bins];
    for &v in values {
        obs[((v * bins as f64) as usize).min(bins - 1)] += 1.0;
    }
    let e = values.len() as f64 / bins as f64;
    chi2(&obs, &vec![e; bins])
}

/// Chi-square of pairs in [0, 1)^2 against independence and uniformity, on k x k equal cells.
fn pair_chi2(a: &[f64], b: &[f64], k: usize) -> Chi2 {
    let mut obs = vec![0.0; k * k];
    for (&x, &y) in a.iter().zip(b) {
        let i = ((x * k as f64) as usize).min(k - 1);
        let j = ((y * k as f64) as usize).min(k - 1);
        obs[i * k + j] += 1.0;
    }
    let e = a.len() as f64 / (k * k) as f64;
    chi2(&obs, &vec![e; k * k])
}

/// Chi-square quantiles from tables (Abramowitz & Stegun, Table 26.8), against which Wilson–Hilferty is
/// checked; also the normal quantile itself.
#[test]
fn chi2_quantile_matches_tables() {
    assert!((normal_upper_quantile(0.025) - 1.959_964).abs() < 1e-5);
    assert!((normal_upper_quantile(1e-4) - 3.719_016).abs() < 1e-5);
    for (dof, p, table) in [
        (10, 1e-3, 29.588),
        (30, 0.05, 43.773),
        (100, 1e-3, 149.449),
        (100, 0.01, 135.807),
    ] {
        let c = chi2_critical(dof, p);
        assert!(
            (c / table - 1.0).abs() < 0.01,
            "dof {dof} p {p}: {c} vs table {table}"
        );
    }
}

// ---------------------------------------------------------------------------------------------------
// The CPU twin of rng.wgsl.

fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    let mut v = v.map(|x| x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    let mix = |v: &mut [u32; 4]| {
        v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
        v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
        v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
        v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    };
    mix(&mut v);
    v = v.map(|x| x ^ (x >> 16));
    mix(&mut v);
    v
}

/// k * 2^-24 for the top 24 bits k, computed exactly in f64.
fn unit(x: u32) -> f64 {
    (x >> 8) as f64 / 16_777_216.0
}

/// A query of rng_stream.wgsl: (pixel, sample, seed, dim).
type Query = [u32; 4];

/// The four outputs of rng_stream.wgsl for each query, widened to f64.
fn stream(queries: &[Query]) -> Vec<[f32; 4]> {
    let out =
        testing::run_kernel(&testing::context(), STREAM, queries, queries.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// 2^20 queries over 1024 pixels x 256 samples x 4 dimensions.
fn spread_queries(seed: u32) -> Vec<Query> {
    (0..1u32 << 20)
        .map(|i| [i & 1023, (i >> 10) & 255, seed, i >> 18])
        .collect()
}

// ---------------------------------------------------------------------------------------------------
// Exactness and range.

/// The GPU hash is pcg4d bit for bit (so renders are reproducible across devices), and u32_to_unit_float
/// is exactly (x >> 8) * 2^-24, including at the extremes 0 and 0xffffffff (-> 1 - 2^-24 < 1).
#[test]
fn hash_and_float_conversion_are_exact() {
    let mut queries: Vec<[u32; 4]> = vec![
        [0, 0, 0, 0],
        [u32::MAX; 4],
        [0xffff_ffff, 0xffff_fe00, 0x0000_00ff, 0x0000_0100],
        [0x8000_0000, 0x7fff_ffff, 1, 0xffff_ff00],
    ];
    // And a spread of ordinary inputs.
    let mut s = 0x1234_5678u32;
    for _ in 0..4096 {
        let mut q = [0u32; 4];
        for c in &mut q {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            *c = s;
        }
        queries.push(q);
    }
    let out: Vec<[[u32; 4]; 2]> =
        testing::run_kernel(&testing::context(), BITS, &queries, queries.len()).expect("kernel");
    for (q, [hash, bits]) in queries.iter().zip(&out) {
        assert_eq!(*hash, pcg4d(*q), "pcg4d({q:?})");
        for c in 0..4 {
            let f = f32::from_bits(bits[c]);
            assert_eq!(f as f64, unit(q[c]), "u32_to_unit_float({:#x})", q[c]);
            assert!(
                (0.0..1.0).contains(&f),
                "u32_to_unit_float({:#x}) = {f}",
                q[c]
            );
        }
    }
    // The largest value: 0xffffffff -> 1 - 2^-24, the f32 just below 1, never 1.0.
    let top = f32::from_bits(out[1][1][0]);
    assert_eq!(top, 1.0 - f32::EPSILON / 2.0);
    assert!(top < 1.0);
    assert_eq!(f32::from_bits(out[0][1][0]), 0.0);
}

/// rng_next / rng_next2 on the GPU equal the CPU twin bit for bit, in the documented order (rng_next
/// takes the x word of the hash at the current dimension, then advances the dimension by one;
/// rng_next2 takes x and y of the same hash), and two runs give the same bits.
#[test]
fn deterministic_and_equal_to_cpu_twin() {
    let queries: Vec<Query> = (0..65_536u32)
        .map(|i| [i.wrapping_mul(2_654_435_761), i % 97, i / 7, i % 13])
        .collect();
    let a = stream(&queries);
    let b = stream(&queries);
    let bits = |v: &[[f32; 4]]| {
        v.iter()
            .flat_map(|x| x.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b), "two runs of the same inputs differ");
    for (q, o) in queries.iter().zip(&a) {
        let [pixel, sample, seed, dim] = *q;
        let h = pcg4d([pixel, sample, dim, seed]);
        let h1 = pcg4d([pixel, sample, dim + 1, seed]);
        let expect = [unit(h[0]), unit(h[0]), unit(h[1]), unit(h1[0])];
        assert_eq!(o.map(|x| x as f64), expect, "query {q:?}");
    }
}

/// Every output of 2^20 queries lies in [0, 1) and is a multiple of 2^-24.
#[test]
fn outputs_in_unit_interval() {
    let out = stream(&spread_queries(7));
    let mut max = 0.0f32;
    for o in &out {
        for &u in o {
            assert!((0.0..1.0).contains(&u), "{u}");
            assert_eq!(
                (u as f64 * 16_777_216.0).fract(),
                0.0,
                "{u} is not k * 2^-24"
            );
            max = max.max(u);
        }
    }
    // 2^22 draws of 24-bit numbers come close to the top: the largest is within 1e-5 of 1 (the chance
    // that it is not is (1 - 1e-5)^(2^22) ~ e^-42).
    assert!(max > 1.0 - 1e-5, "max {max}");
}

// ---------------------------------------------------------------------------------------------------
// Uniformity.

/// 256 bins of 2^20 draws of each word: rng_next's (the hash's x) and rng_next2's second (the hash's y).
/// dof = 255; the critical value at ALPHA = 1e-4 is ~340.
#[test]
fn uniform_chi_square() {
    let out = stream(&spread_queries(12_345));
    for (word, c) in [("x", 0), ("y", 2)] {
        let v: Vec<f64> = out.iter().map(|o| o[c] as f64).collect();
        let t = uniform_chi2(&v, 256);
        assert_fits(&format!("word {word}"), &t);
        // Mean and variance of U[0,1): 1/2 and 1/12, within 5 standard errors.
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        assert!(
            (mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n).sqrt(),
            "mean {mean}"
        );
        let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
        // Var of the sample variance of U: (1/80 - 1/144) / n.
        assert!(
            (var - 1.0 / 12.0).abs() < 5.0 * ((1.0 / 80.0 - 1.0 / 144.0) / n).sqrt(),
            "variance {var}"
        );
    }
}

/// The uniformity test has power: the same GPU draws bent by u -> u^1.05 (a 5% skew, what an off-by-a-
/// little warping would do) give a statistic far beyond the critical value.
#[test]
fn uniform_chi_square_rejects_skewed() {
    let out = stream(&spread_queries(12_345));
    let v: Vec<f64> = out.iter().map(|o| (o[0] as f64).powf(1.05)).collect();
    let t = uniform_chi2(&v, 256);
    eprintln!("skewed: chi2 = {:.1} (critical {:.1})", t.stat, t.critical);
    assert!(
        t.stat > 4.0 * t.critical,
        "chi2 {} vs critical {}",
        t.stat,
        t.critical
    );
}

// ---------------------------------------------------------------------------------------------------
// Independence.

const PAIRS: u32 = 1 << 18;

/// The draws of 2^18 base queries and of their neighbours in pixel (right and below), sample, seed
/// (and, from the same run, dimension and the y word).
struct Neighbours {
    base: Vec<f64>,
    pixel: Vec<f64>,
    sample: Vec<f64>,
    seed: Vec<f64>,
    pixel_below: Vec<f64>,
    dim: Vec<f64>,
    word_y: Vec<f64>,
}

fn neighbours() -> Neighbours {
    // Base queries: consecutive pixels of an image, each at sample 5, dimension 3, seed 2024. The pairs
    // overlap (pixel p+1 is also a base): the lag-1 autocorrelation of the stream over pixels.
    let base: Vec<Query> = (0..PAIRS).map(|p| [p, 5, 2024, 3]).collect();
    let mut q = base.clone();
    q.extend(base.iter().map(|&[p, s, k, d]| [p + 1, s, k, d]));
    q.extend(base.iter().map(|&[p, s, k, d]| [p, s + 1, k, d]));
    q.extend(base.iter().map(|&[p, s, k, d]| [p, s, k + 1, d]));
    // The pixel below in a 1024-wide image (the renderer's pixel index is y * width + x).
    q.extend(base.iter().map(|&[p, s, k, d]| [p + 1024, s, k, d]));
    let out = stream(&q);
    let n = PAIRS as usize;
    let col = |range: std::ops::Range<usize>, c: usize| {
        out[range].iter().map(|o| o[c] as f64).collect::<Vec<_>>()
    };
    Neighbours {
        base: col(0..n, 0),
        pixel: col(n..2 * n, 0),
        sample: col(2 * n..3 * n, 0),
        seed: col(3 * n..4 * n, 0),
        pixel_below: col(4 * n..5 * n, 0),
        dim: col(0..n, 3),
        word_y: col(0..n, 2),
    }
}

/// Correlation within 5/sqrt(N) of 0 and a 16 x 16 chi-square (dof 255) for each kind of neighbour.
#[test]
fn neighbouring_streams_are_independent() {
    let nb = neighbours();
    let bound = 5.0 / (PAIRS as f64).sqrt();
    for (what, other) in [
        ("pixel + 1", &nb.pixel),
        ("sample + 1", &nb.sample),
        ("seed + 1", &nb.seed),
        ("pixel + width", &nb.pixel_below),
        ("dim + 1", &nb.dim),
        ("rng_next2 x vs y", &nb.word_y),
    ] {
        let r = correlation(&nb.base, other);
        let t = pair_chi2(&nb.base, other, 16);
        eprintln!(
            "{what}: r = {r:.2e} (bound {bound:.2e}), chi2 = {:.1} (critical {:.1})",
            t.stat, t.critical
        );
        assert!(r.abs() < bound, "{what}: correlation {r} beyond {bound}");
        assert!(
            t.passes(),
            "{what}: 2-D chi2 {} > {} (dof {})",
            t.stat,
            t.critical,
            t.dof
        );
    }
}

/// The independence tests have power. (a) The GPU pairs (u_p, u_p+1) with every 20th partner replaced
/// by u_p itself (5% of pairs fully dependent): correlation ~0.05, five times the bound, and the 2-D
/// chi-square explodes on the diagonal. (b) A plain LCG of the pixel index, the classic mistake of
/// hashing with one multiply-add: it passes the 1-D test (it is even too uniform), but its neighbouring
/// pairs lie on one line, which the 2-D test sees at once.
#[test]
fn independence_tests_reject_dependent_pairs() {
    let nb = neighbours();
    let bound = 5.0 / (PAIRS as f64).sqrt();
    let tainted: Vec<f64> = nb
        .pixel
        .iter()
        .enumerate()
        .map(|(i, &v)| if i % 20 == 0 { nb.base[i] } else { v })
        .collect();
    let r = correlation(&nb.base, &tainted);
    assert!(
        r > 3.0 * bound,
        "correlation {r} not detected (bound {bound})"
    );
    let t = pair_chi2(&nb.base, &tainted, 16);
    assert!(
        t.stat > 10.0 * t.critical,
        "2-D chi2 {} vs critical {}",
        t.stat,
        t.critical
    );

    let lcg = |p: u32| unit(p.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    let a: Vec<f64> = (0..PAIRS).map(lcg).collect();
    let b: Vec<f64> = (1..=PAIRS).map(lcg).collect();
    let t1 = uniform_chi2(&a, 256);
    assert!(
        t1.passes(),
        "the LCG should pass the 1-D test: {} > {}",
        t1.stat,
        t1.critical
    );
    let t2 = pair_chi2(&a, &b, 16);
    assert!(
        t2.stat > 100.0 * t2.critical,
        "2-D chi2 of the LCG {} vs critical {}",
        t2.stat,
        t2.critical
    );
}
