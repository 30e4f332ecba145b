//! Chi-square goodness-of-fit helpers shared by the statistical shader tests (tests/shader_rng.rs,
//! tests/shader_sampling.rs), with no dependency on a statistics crate.

/// Significance level of every chi-square test.
pub const ALPHA: f64 = 1e-4;

/// erfc(x): the library's (Numerical Recipes' Chebyshev fit, fractional error below 1.2e-7).
pub use vkpath::kernel::coat::erfc;

/// The z with P(Z > z) = p for a standard normal Z, by bisection on erfc (p < 0.5).
pub fn normal_upper_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if 0.5 * erfc(mid / std::f64::consts::SQRT_2) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The chi-square value exceeded with probability `p` at `dof` degrees of freedom, by the
/// Wilson–Hilferty approximation (E. B. Wilson and M. M. Hilferty, "The distribution of chi-square",
/// PNAS 17(12), 1931): (X/k)^(1/3) is nearly normal with mean 1 - 2/(9k) and variance 2/(9k). Its
/// relative error is below 1% for k >= 10 at these tail probabilities (checked against tables in tests/shader_rng.rs).
pub fn chi2_critical(dof: usize, p: f64) -> f64 {
    let k = dof as f64;
    let z = normal_upper_quantile(p);
    let v = 2.0 / (9.0 * k);
    k * (1.0 - v + z * v.sqrt()).powi(3)
}

pub struct Chi2 {
    pub stat: f64,
    pub dof: usize,
    pub critical: f64,
}

impl Chi2 {
    pub fn passes(&self) -> bool {
        self.stat <= self.critical
    }

    /// P(X >= stat) for X ~ chi-square(dof), by the same Wilson–Hilferty approximation as the critical
    /// value (so `passes` is `p_value >= ALPHA` up to rounding).
    pub fn p_value(&self) -> f64 {
        let k = self.dof as f64;
        let v = 2.0 / (9.0 * k);
        let z = ((self.stat / k).cbrt() - (1.0 - v)) / v.sqrt();
        0.5 * erfc(z / std::f64::consts::SQRT_2)
    }
}

/// Pearson's chi-square of observed counts against expected counts. Cells expected to hold fewer than 5
/// are pooled, smallest first, until each pool expects at least 5 (the usual validity rule; pbrt-v3's
/// `Chi2Test` does the same), so the statistic is close to its chi-square law.
pub fn chi2(observed: &[f64], expected: &[f64]) -> Chi2 {
    assert_eq!(observed.len(), expected.len());
    let mut cells: Vec<(f64, f64)> = observed
        .iter()
        .copied()
        .zip(expected.iter().copied())
        .collect();
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut pooled: Vec<(f64, f64)> = Vec::new();
    // The open pool: observed, expected, number of cells in it.
    let mut pool = (0.0, 0.0, 0usize);
    for (o, e) in cells {
        if e < 5.0 || pool.2 > 0 {
            pool = (pool.0 + o, pool.1 + e, pool.2 + 1);
            if pool.1 >= 5.0 {
                pooled.push((pool.0, pool.1));
                pool = (0.0, 0.0, 0);
            }
        } else {
            pooled.push((o, e));
        }
    }
    if pool.2 > 0 {
        match pooled.last_mut() {
            Some(last) => {
                last.0 += pool.0;
                last.1 += pool.1;
            }
            None => pooled.push((pool.0, pool.1)),
        }
    }
    let stat = pooled
        .iter()
        .map(|&(o, e)| {
            if e > 0.0 {
                (o - e) * (o - e) / e
            } else if o > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        })
        .sum();
    let dof = pooled.len().saturating_sub(1).max(1);
    Chi2 {
        stat,
        dof,
        critical: chi2_critical(dof, ALPHA),
    }
}

/// Asserts that a chi-square test passes and says so.
pub fn assert_fits(what: &str, t: &Chi2) {
    eprintln!(
        "{what}: chi2 = {:.1} (critical {:.1}, dof {}, p = {:.3})",
        t.stat,
        t.critical,
        t.dof,
        t.p_value()
    );
    assert!(
        t.passes(),
        "{what}: chi2 {} > critical {} (dof {}, ALPHA {ALPHA})",
        t.stat,
        t.critical,
        t.dof
    );
}

/// Asserts that a chi-square test rejects a wrong hypothesis by far: at least `factor` times the
/// critical value, where a correct one would sit near its dof.
pub fn assert_rejects(what: &str, t: &Chi2, factor: f64) {
    eprintln!(
        "{what} (wrong pdf): chi2 = {:.1} (critical {:.1}, dof {})",
        t.stat, t.critical, t.dof
    );
    assert!(
        t.stat > factor * t.critical,
        "{what}: chi2 {} is not > {factor} x critical {}",
        t.stat,
        t.critical
    );
}

/// The 4-point Gauss–Legendre rule on [-1, 1] (nodes, weights): exact for polynomials of degree 7. The
/// chi-square tests integrate a shader's pdf over each bin with it, 4 x 4 nodes per bin.
pub const GAUSS_LEGENDRE_4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
];
