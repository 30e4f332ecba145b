//! The Charlie sheen of KHR_materials_sheen (Conty Estevez & Kulla, "Production Friendly Microfacet Sheen
//! BRDF", SIGGRAPH 2017): its directional albedo, tabulated on the host for bsdfs/gltf_pbr.wgsl.
//!
//! The sheen lobe (without its colour) is f_s(wo, wi) = D(h) / ((1 + Lambda(mu_o) + Lambda(mu_i)) 4 mu_o mu_i)
//! with D(h) = (2 + 1/a) sin(theta_h)^(1/a) / (2 pi) and Lambda the paper's fitted
//! exp(l(mu)) (l(x) = p / (1 + q x^r) + s x + u, its coefficients interpolated in (1 - a)^2; for mu >= 1/2,
//! exp(2 l(1/2) - l(1 - mu))). The specification scales the base under the sheen by
//! min(1 - max(sheenColor) E(mu_o), 1 - max(sheenColor) E(mu_i)) with the lobe's directional albedo
//!
//!   E(mu) = \int_{H^2} f_s(wo, wi) mu_i d wi,   mu_o = mu,
//!
//! here by the midpoint rule in (mu_i, phi) (256 x 128 cells over the half circle, the other half by
//! symmetry), at [`SHEEN_NODES`] cosines mu_j = (j / 7)^3 (the first at 1e-3), dense towards grazing
//! where E changes fastest; the shader interpolates linearly in cbrt(mu): within 0.015 of E for
//! mu >= 0.03 and 0.05 below (the fitted Lambda makes E erratic at grazing: 0.94 at mu = 1e-3, 0.99 at
//! 4e-3, 0.90 at 0.02 for alpha 0.07), where squares (mu_j = (j / 7)^2) were 0.07 off.

use std::f64::consts::PI;

/// Entries of a sheen's albedo table (`GpuMaterial::coat[8..16]`; `SHEEN_NODES` in gltf_pbr.wgsl).
pub const SHEEN_NODES: usize = 8;

/// The smallest sheen alpha the shader uses: below it the distribution's exponent 1 / a overflows f32 at
/// the peak (the Imageworks paper clamps the same way).
pub const SHEEN_MIN_ALPHA: f32 = 0.07;

fn l(x: f64, a: f64) -> f64 {
    let t = (1.0 - a) * (1.0 - a);
    let mix = |p: f64, q: f64| p + (q - p) * t;
    mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
        + mix(-1.97760, -1.27393) * x
        + mix(-4.32054, -4.85967)
}

/// The Charlie visibility's Lambda at cosine `mu`.
pub fn sheen_lambda(mu: f64, a: f64) -> f64 {
    if mu < 0.5 {
        l(mu, a).exp()
    } else {
        (2.0 * l(0.5, a) - l(1.0 - mu, a)).exp()
    }
}

/// The sheen lobe without its colour at cosines and azimuth difference: f_s for wo at `mu_o`, wi at
/// `mu_i` and `phi` apart.
pub fn sheen_lobe(mu_o: f64, mu_i: f64, phi: f64, a: f64) -> f64 {
    let so = (1.0 - mu_o * mu_o).max(0.0).sqrt();
    let si = (1.0 - mu_i * mu_i).max(0.0).sqrt();
    let h = [so + si * phi.cos(), si * phi.sin(), mu_o + mu_i];
    let len2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    let cos2 = h[2] * h[2] / len2;
    let d = (2.0 + 1.0 / a) * (1.0 - cos2).max(0.0).powf(0.5 / a) / (2.0 * PI);
    d / ((1.0 + sheen_lambda(mu_o, a) + sheen_lambda(mu_i, a)) * 4.0 * mu_o * mu_i)
}

/// E(mu): the sheen lobe's directional albedo (colour 1) seen from cosine `mu`.
pub fn sheen_albedo(mu: f64, a: f64) -> f64 {
    let (nc, np) = (256, 128);
    let mut sum = 0.0;
    for i in 0..nc {
        let mu_i = (i as f64 + 0.5) / nc as f64;
        for j in 0..np {
            let phi = PI * (j as f64 + 0.5) / np as f64;
            sum += sheen_lobe(mu, mu_i, phi, a) * mu_i;
        }
    }
    sum * 2.0 * PI / (nc * np) as f64
}

/// The cosine of node `j` of the table: (j / 7)^3, the first at 1e-3.
pub fn sheen_node(j: usize) -> f64 {
    (j as f64 / (SHEEN_NODES - 1) as f64).powi(3).max(1e-3)
}

/// The table the shader reads: E at the nodes.
pub fn sheen_albedo_table(a: f64) -> [f32; SHEEN_NODES] {
    std::array::from_fn(|j| sheen_albedo(sheen_node(j), a) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lobe reflects less than it receives at every node and roughness (E in (0, 1)), and the
    /// table's linear interpolation in cbrt(mu) stays within 0.015 of E between its nodes for
    /// mu >= 0.03, 0.05 from 1e-3 to there.
    #[test]
    fn the_sheen_albedo_is_below_one_and_its_table_interpolates_it() {
        for a in [0.07, 0.3, 0.6, 1.0] {
            let table = sheen_albedo_table(a);
            for (j, e) in table.iter().enumerate() {
                assert!(*e > 0.0 && *e < 1.0, "a {a}, node {j}: E = {e}");
            }
            for k in 1..56 {
                let x = k as f64 / 8.0; // in 7 cbrt(mu), off the nodes
                let mu = (x / 7.0).powi(3);
                if mu < 1e-3 {
                    continue;
                }
                let j = (x as usize).min(SHEEN_NODES - 2);
                let u = x - j as f64;
                let lerp = f64::from(table[j]) * (1.0 - u) + f64::from(table[j + 1]) * u;
                let e = sheen_albedo(mu, a);
                let tolerance = if mu >= 0.03 { 0.015 } else { 0.05 };
                assert!(
                    (lerp - e).abs() < tolerance,
                    "a {a}, mu {mu}: table {lerp}, E {e}"
                );
            }
        }
    }
}
