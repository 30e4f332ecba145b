//! Alias tables: O(1) sampling of a discrete distribution (Walker 1977), built in O(n) by Vose's method
//! (Vose 1991, "A linear algorithm for generating random numbers with a given distribution").
//!
//! Column j of n keeps item j with probability `keep[j]` and otherwise gives `alias[j]`: drawing a
//! column uniformly and then keep-or-alias picks item i with probability
//! (keep[i] + sum over columns j with alias[j] = i of (1 - keep[j])) / n = w_i / sum(w). The shader does
//! it with one uniform number (lights/triangles.wgsl, `triangle_light_pick`).

/// One column of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AliasColumn {
    pub keep: f32,
    pub alias: u32,
}

/// The alias table of `weights` (non-negative, not all zero; the caller drops zero-power items).
pub fn build(weights: &[f64]) -> Vec<AliasColumn> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    assert!(n > 0 && total > 0.0, "an alias table needs positive weight");
    // Scaled so that the mean is 1: columns below 1 ("small") are topped up from ones above ("large").
    let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
    let mut columns = vec![
        AliasColumn {
            keep: 1.0,
            alias: 0
        };
        n
    ];
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        columns[s] = AliasColumn {
            keep: scaled[s] as f32,
            alias: l as u32,
        };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left is 1 up to rounding: those columns keep their own item.
    for i in small.into_iter().chain(large) {
        columns[i] = AliasColumn {
            keep: 1.0,
            alias: i as u32,
        };
    }
    columns
}

/// The probability the table gives each item (the inverse of [`build`], for tests and reports).
pub fn probabilities(columns: &[AliasColumn]) -> Vec<f64> {
    let n = columns.len() as f64;
    let mut p = vec![0.0; columns.len()];
    for (j, c) in columns.iter().enumerate() {
        p[j] += c.keep as f64 / n;
        p[c.alias as usize] += (1.0 - c.keep as f64) / n;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_reproduces_its_weights() {
        let weights = [1.0, 0.0, 7.5, 2.0, 0.25, 3.0, 1e-6];
        let total: f64 = weights.iter().sum();
        let p = probabilities(&build(&weights));
        for (w, p) in weights.iter().zip(&p) {
            assert!((p - w / total).abs() < 1e-7, "{p} vs {}", w / total);
        }
    }

    #[test]
    fn equal_weights_keep_every_column() {
        let t = build(&[2.0; 5]);
        assert!(
            t.iter()
                .enumerate()
                .all(|(i, c)| c.keep == 1.0 && c.alias == i as u32)
        );
    }

    #[test]
    fn a_skewed_distribution_of_many_items() {
        // 10^5 items with weights spanning 12 orders of magnitude.
        let weights: Vec<f64> = (0..100_000)
            .map(|i| 10f64.powf((i % 13) as f64 - 6.0))
            .collect();
        let total: f64 = weights.iter().sum();
        let p = probabilities(&build(&weights));
        let worst = weights
            .iter()
            .zip(&p)
            .map(|(w, p)| (p - w / total).abs() / (w / total))
            .fold(0.0, f64::max);
        // keep is stored in f32: relative error ~1e-7 per column, amplified for the tiniest weights by
        // the n / total scaling, still far below any sampling noise.
        assert!(worst < 1e-2, "worst relative error {worst}");
    }
}
