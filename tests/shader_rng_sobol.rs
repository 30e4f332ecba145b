//! The Sobol' sampler of shaders/rng.wgsl (`render.sampler = "sobol"`), read back from the GPU.
//!
//! * Exactness: `sobol_dim1` (a loop-free superset transform) equals the textbook construction from
//!   direction numbers, computed on the CPU, for every index tested.
//! * Stratification: any aligned block of 2^m samples of a pixel, in any dimension pair, is a (0,m,2)-net
//!   (exactly one point in every dyadic box of area 2^-m), after scrambling and index shuffling, as
//!   Burley (JCGT 2020) proves; an independent sampler is shown to fail the same check.
//! * Randomisation: across pixels, a given sample is uniform (chi-square), and two dimension pairs of one
//!   pixel are uncorrelated, which is what keeps the estimates unbiased and the pairs independent.

mod common;

use common::stats::{assert_fits, chi2};
use vkpath::gpu::testing;

const KERNEL: &str = include_str!("../shaders/tests/sobol_points.wgsl");

/// (pixel, sample, dim, seed) -> (x, y, unscrambled x, unscrambled y), all 32-bit fractions.
fn points(queries: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let out: Vec<[u32; 4]> =
        testing::run_kernel(&testing::context(), KERNEL, queries, queries.len())
            .expect("kernel runs");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out
}

/// The second Sobol' dimension by its definition: the xor of direction numbers v_k over the set bits k
/// of i, v_0 = 2^31, v_k = v_(k-1) ^ (v_(k-1) >> 1) (primitive polynomial x + 1, m_1 = 1).
fn sobol_dim1_reference(i: u32) -> u32 {
    let (mut v, mut out) = (1u32 << 31, 0u32);
    for k in 0..32 {
        if i >> k & 1 == 1 {
            out ^= v;
        }
        v ^= v >> 1;
    }
    out
}

#[test]
fn sobol_dim1_matches_its_direction_numbers() {
    // Every index below 2^12, then indices with high bits set (a multiplicative sequence).
    let mut indices: Vec<u32> = (0..4096).collect();
    let mut x = 1u32;
    for _ in 0..4096 {
        x = x.wrapping_mul(2_654_435_761).wrapping_add(12345);
        indices.push(x);
    }
    let queries: Vec<[u32; 4]> = indices.iter().map(|&i| [0, i, 0, 0]).collect();
    for (i, p) in indices.iter().zip(points(&queries)) {
        assert_eq!(p[2], i.reverse_bits(), "van der Corput of {i}");
        assert_eq!(p[3], sobol_dim1_reference(*i), "Sobol' dimension 1 of {i}");
    }
    // The first points in natural index order (Gray-code generators list the same points per block of
    // 2^k in another order): 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8.
    let firsts: Vec<f64> = (0..8)
        .map(|i| sobol_dim1_reference(i) as f64 / 2f64.powi(32))
        .collect();
    assert_eq!(firsts, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
}

/// Whether the 2^m points are a (0,m,2)-net: for every split a + b = m, each of the 2^a x 2^b boxes
/// holds exactly one point.
fn is_net(pts: &[(u32, u32)], m: u32) -> bool {
    assert_eq!(pts.len(), 1 << m);
    (0..=m).all(|a| {
        let b = m - a;
        let mut seen = vec![false; 1 << m];
        pts.iter().all(|&(x, y)| {
            let cell = ((x.checked_shr(32 - a).unwrap_or(0)) << b
                | y.checked_shr(32 - b).unwrap_or(0)) as usize;
            !std::mem::replace(&mut seen[cell], true)
        })
    })
}

#[test]
fn aligned_blocks_of_a_pixels_samples_are_nets_in_every_dimension_pair() {
    let m = 8;
    for pixel in [0u32, 17, 123_456] {
        for dim in [0u32, 1, 7] {
            for first in [0u32, 256, 1 << 20] {
                let queries: Vec<[u32; 4]> = (first..first + (1 << m))
                    .map(|s| [pixel, s, dim, 3])
                    .collect();
                let out = points(&queries);
                let scrambled: Vec<(u32, u32)> = out.iter().map(|p| (p[0], p[1])).collect();
                assert!(
                    is_net(&scrambled, m),
                    "pixel {pixel}, dimension pair {dim}, samples {first}..: not a (0,{m},2)-net"
                );
                if first == 0 {
                    let plain: Vec<(u32, u32)> = out.iter().map(|p| (p[2], p[3])).collect();
                    assert!(is_net(&plain, m), "the unscrambled Sobol' points");
                }
            }
        }
    }
    // The check has power: 256 independent uniform points (from a CPU hash) are not a net.
    let mut h = 0x9e37_79b9u64;
    let random: Vec<(u32, u32)> = (0..256)
        .map(|_| {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            ((h >> 32) as u32, h as u32)
        })
        .collect();
    assert!(!is_net(&random, m));
}

#[test]
fn one_sample_is_uniform_across_pixels_and_dimension_pairs_are_uncorrelated() {
    let n = 1u32 << 14;
    // Sample 5 of 2^14 pixels, dimension pair 2: a 16 x 16 chi-square against the uniform law.
    let queries: Vec<[u32; 4]> = (0..n).map(|p| [p, 5, 2, 9]).collect();
    let out = points(&queries);
    let mut counts = vec![0f64; 256];
    for p in &out {
        counts[((p[0] >> 28) * 16 + (p[1] >> 28)) as usize] += 1.0;
    }
    assert_fits(
        "sample 5 across pixels",
        &chi2(&counts, &vec![n as f64 / 256.0; 256]),
    );
    // Within one pixel, the x coordinates of dimension pairs 0 and 1 over 2^14 samples: independent
    // sequences (each index shuffled by its own seed) have correlation ~ N(0, 1/n): within 5 sigma.
    let unit = |v: u32| v as f64 / 2f64.powi(32);
    let pair = |dim: u32| -> Vec<f64> {
        let q: Vec<[u32; 4]> = (0..n).map(|s| [42, s, dim, 9]).collect();
        points(&q).iter().map(|p| unit(p[0])).collect()
    };
    let (a, b) = (pair(0), pair(1));
    let (ma, mb) = (
        a.iter().sum::<f64>() / n as f64,
        b.iter().sum::<f64>() / n as f64,
    );
    let cov: f64 = a.iter().zip(&b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let var_a: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let var_b: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    let r = cov / (var_a * var_b).sqrt();
    assert!(
        r.abs() < 5.0 / (n as f64).sqrt(),
        "dimension pairs 0 and 1 are correlated: r = {r}"
    );
    // A net's mean is far closer to 1/2 than an independent sample's 1/sqrt(12 n) = 0.0023.
    assert!((ma - 0.5).abs() < 1e-3, "mean of pair 0's x: {ma}");
}
