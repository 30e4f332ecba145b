//! The glossy materials of shaders/bsdfs/ (conductor, rough dielectric, plastic, metallic_roughness),
//! read back from the GPU through the BSDF interface the integrator calls (shaders/tests/glossy_sample.wgsl),
//! with materials built by the host's own upload (`upload::gpu_material`).
//!
//! * Chi-square of each sampler against its own pdf: directions binned on the whole sphere around the
//!   lobe's centre (see [`Bins`]); each bin's expected count is the shader's bsdf_pdf integrated over it
//!   on the GPU (4 x 4 Gauss–Legendre nodes per bin); absorbed samples and delta samples have a cell each.
//!   Several roughnesses and incident angles, grazing included (Mitsuba 3's test pattern), entering and
//!   leaving glass.
//! * Every sample consistent with eval and pdf (weight = f cos / pdf, pdf = bsdf_pdf(wi)); reciprocity of
//!   f for the reflection lobes, and f_t(wo, wi) = eta^2 f_t(wi, wo) for transmission (bsdf.wgsl omits the
//!   1/eta^2 radiance scaling).
//! * White furnace: a conductor whose Fresnel is 1 (Schlick from base colour 1) reflects exactly the
//!   single-scattering GGX albedo, which an independent f64 quadrature over microfacet normals gives here
//!   ([`ggx_albedo`]); a smooth white plastic reflects all the light at every angle, a rough one the GGX
//!   coat's albedo plus 1 - F(cos_o); a rough dielectric of ior 1 is invisible.
//! * Fresnel of a complex index against an f64 complex-arithmetic reference.
//! * A sweep of every material over roughness 0..1 and angles down to grazing and below: no NaN or Inf.

mod common;

use common::bsdf::*;
use common::stats::GAUSS_LEGENDRE_4;
use common::vec::{V3, dot, from_angles, normalize};
use glam::Vec3;
use vkpath::kernel::abi::{
    BSDF_DELTA, BSDF_REFLECTION, BSDF_TRANSMISSION, GpuMaterial, MAT_ROUGH_DIELECTRIC,
};
use vkpath::kernel::upload::gpu_material;
use vkpath::scene::{Bsdf, CONDUCTOR_PRESETS, ConductorFresnel, Material, Roughness};

fn material(bsdf: Bsdf) -> GpuMaterial {
    gpu_material(&Material::from(bsdf))
}

fn conductor(preset: &str, roughness: Roughness) -> GpuMaterial {
    let (_, eta, k) = CONDUCTOR_PRESETS
        .iter()
        .find(|(n, _, _)| *n == preset)
        .expect("preset");
    material(Bsdf::Conductor {
        fresnel: ConductorFresnel::Complex {
            eta: Vec3::from_array(*eta),
            k: Vec3::from_array(*k),
        },
        roughness,
        tint: Vec3::ONE,
    })
}

fn diffuse(albedo: f32) -> GpuMaterial {
    material(Bsdf::Diffuse {
        albedo: Vec3::splat(albedo),
    })
}

fn white_conductor(r: f32) -> GpuMaterial {
    material(Bsdf::Conductor {
        fresnel: ConductorFresnel::Schlick { f0: Vec3::ONE },
        roughness: Roughness::isotropic(r),
        tint: Vec3::ONE,
    })
}

fn rough_glass(ior: f32, r: f32) -> GpuMaterial {
    material(Bsdf::Dielectric {
        ior,
        roughness: Roughness::isotropic(r),
    })
}

fn plastic(albedo: f32, r: f32) -> GpuMaterial {
    plastic_of(albedo, r, true)
}

fn plastic_of(albedo: f32, r: f32, nonlinear: bool) -> GpuMaterial {
    material(Bsdf::Plastic {
        albedo: Vec3::splat(albedo),
        ior: 1.5,
        roughness: Roughness::isotropic(r),
        nonlinear,
    })
}

fn gltf(base: [f32; 3], metallic: f32, r: f32) -> GpuMaterial {
    material(Bsdf::MetallicRoughness {
        base_color: Vec3::from_array(base),
        metallic,
        roughness: r,
        layers: vkpath::scene::GltfLayers::NONE,
    })
}

const ANGLES: [f64; 3] = [0.9, 0.4, 0.05]; // cos theta_o: near normal, oblique, grazing (87 degrees)

#[test]
fn conductor_sampler_matches_its_own_pdf() {
    let mut seed = 1;
    for r in [0.1f32, 0.3, 0.6, 1.0] {
        for cos_o in ANGLES {
            if cos_o < 0.1 && r < 0.3 {
                continue; // a lobe this narrow at the horizon: too fine for the polar bins
            }
            let setup = Setup::new(conductor("gold", Roughness::isotropic(r)), cos_o);
            let bins = reflection_bins(&setup, (r * r) as f64, cos_o);
            chi2_sampler(
                &format!("conductor r {r}, cos_o {cos_o}"),
                &setup,
                &bins,
                seed,
            );
            seed += 1;
        }
    }
    // Anisotropic: a different roughness along the tangent and the bitangent.
    for cos_o in [0.7, 0.1] {
        let setup = Setup::new(conductor("copper", Roughness::anisotropic(0.2, 0.7)), cos_o);
        let bins = reflection_bins(&setup, 0.2, cos_o);
        chi2_sampler(
            &format!("conductor r [0.2, 0.7], cos_o {cos_o}"),
            &setup,
            &bins,
            seed,
        );
        seed += 1;
    }
}

fn beckmann(r: f32) -> Roughness {
    Roughness {
        beckmann: true,
        ..Roughness::isotropic(r)
    }
}

/// Beckmann's visible normals (sampled from the slope distribution by erf, erfinv and Newton's method)
/// against the pdf built from D and Smith's Lambda (exp and erfc): independent code that agrees only if
/// both are right, including Lambda's normalisation of the visible normals. Conductors (anisotropic
/// too), a rough glass both ways, and the plastic's coat.
#[test]
fn beckmann_samplers_match_their_own_pdf() {
    let mut seed = 700;
    for r in [0.1f32, 0.3, 0.6, 1.0] {
        for cos_o in ANGLES {
            if cos_o < 0.1 && r < 0.3 {
                continue; // too narrow at the horizon for the polar bins (as for GGX)
            }
            let setup = Setup::new(conductor("gold", beckmann(r)), cos_o);
            let bins = reflection_bins(&setup, (r * r) as f64, cos_o);
            chi2_sampler(
                &format!("beckmann conductor r {r}, cos_o {cos_o}"),
                &setup,
                &bins,
                seed,
            );
            seed += 1;
        }
    }
    for cos_o in [0.7, 0.1] {
        let rough = Roughness {
            beckmann: true,
            ..Roughness::anisotropic(0.2, 0.7)
        };
        let setup = Setup::new(conductor("copper", rough), cos_o);
        let bins = reflection_bins(&setup, 0.2, cos_o);
        chi2_sampler(
            &format!("beckmann conductor r [0.2, 0.7], cos_o {cos_o}"),
            &setup,
            &bins,
            seed,
        );
        seed += 1;
    }
    for entering in [true, false] {
        let mut setup = Setup::new(
            material(Bsdf::Dielectric {
                ior: 1.5,
                roughness: beckmann(0.5),
            }),
            0.6,
        );
        setup.entering = entering;
        let bins = Bins::polar(setup.ns, 64, 64);
        chi2_sampler(
            &format!("beckmann rough glass, entering {entering}"),
            &setup,
            &bins,
            seed,
        );
        seed += 1;
    }
    let coat = material(Bsdf::Plastic {
        albedo: Vec3::splat(0.6),
        ior: 1.5,
        roughness: beckmann(0.3),
        nonlinear: false,
    });
    let setup = Setup::new(coat, 0.8);
    let bins = reflection_bins(&setup, 0.1, 0.8);
    chi2_sampler("beckmann plastic r 0.3, cos_o 0.8", &setup, &bins, seed);
    for (what, mat) in [
        ("beckmann gold r 0.4", conductor("gold", beckmann(0.4))),
        (
            "beckmann glass r 0.5",
            material(Bsdf::Dielectric {
                ior: 1.5,
                roughness: beckmann(0.5),
            }),
        ),
    ] {
        assert_sample_eval_pdf_agree(what, mat);
        assert_reciprocal_and_one_sided_at_the_horizon(what, mat);
    }
}

#[test]
fn rough_dielectric_sampler_matches_its_own_pdf() {
    let mut seed = 100;
    for r in [0.3f32, 0.6, 1.0] {
        for cos_o in ANGLES {
            for entering in [true, false] {
                let mut setup = Setup::new(rough_glass(1.5, r), cos_o);
                setup.entering = entering;
                // Reflection and transmission: polar bins about ns (the horizon a ring boundary).
                let eta = if entering { 1.5 } else { 1.0 / 1.5 };
                let bins = if cos_o < 0.2 {
                    Bins::transmission(setup.ns, cos_o, eta, 128, 256)
                } else {
                    Bins::polar(setup.ns, 64, 64)
                };
                chi2_sampler(
                    &format!("rough dielectric r {r}, cos_o {cos_o}, entering {entering}"),
                    &setup,
                    &bins,
                    seed,
                );
                seed += 1;
            }
        }
    }
}

#[test]
fn two_lobe_samplers_match_their_own_pdf() {
    let mut seed = 200;
    for cos_o in [0.8, 0.1] {
        for (what, mat, alpha) in [
            ("plastic r 0 (delta coat)", plastic(0.6, 0.0), 1.0f64),
            ("plastic r 0.3", plastic(0.6, 0.3), 0.09),
            (
                "metallic_roughness r 0.5 metallic 0.5",
                gltf([0.9, 0.5, 0.2], 0.5, 0.5),
                0.25,
            ),
            (
                "metallic_roughness r 0.2 metallic 0",
                gltf([0.2, 0.5, 0.9], 0.0, 0.2),
                0.04,
            ),
        ] {
            if cos_o < 0.2 && alpha < 0.09 {
                continue; // too narrow at the horizon for the polar bins (as for the conductor)
            }
            let setup = Setup::new(mat, cos_o);
            // Two lobes: rings round the mirror direction wide enough for the specular lobe, which
            // still cover the diffuse lobe's hemisphere; polar bins at grazing incidence.
            let bins = reflection_bins(&setup, alpha.max(0.1), cos_o);
            chi2_sampler(&format!("{what}, cos_o {cos_o}"), &setup, &bins, seed);
            seed += 1;
        }
    }
}

// --- Consistency of sample, eval and pdf ------------------------------------------------------------

/// Every material through the shared adapter's checks (tests/common/bsdf.rs).
#[test]
fn sample_eval_pdf_agree_and_reciprocity() {
    let materials = [
        ("diffuse", diffuse(0.7)),
        ("gold r 0.4", conductor("gold", Roughness::isotropic(0.4))),
        (
            "silver [0.1, 0.5]",
            conductor("silver", Roughness::anisotropic(0.1, 0.5)),
        ),
        ("glass r 0.5", rough_glass(1.5, 0.5)),
        ("plastic r 0.2", plastic(0.7, 0.2)),
        ("plastic r 0", plastic(0.7, 0.0)),
        ("gltf r 0.6", gltf([0.8, 0.3, 0.1], 0.3, 0.6)),
    ];
    for (what, mat) in materials {
        assert_sample_eval_pdf_agree(what, mat);
    }
}

#[test]
fn every_bsdf_is_reciprocal_and_one_sided_at_the_horizon() {
    let materials = [
        ("diffuse", diffuse(0.7)),
        ("gold r 0.4", conductor("gold", Roughness::isotropic(0.4))),
        ("white conductor r 0.3", white_conductor(0.3)),
        ("glass r 0.5", rough_glass(1.5, 0.5)),
        ("plastic r 0.2", plastic(0.7, 0.2)),
        ("plastic r 0", plastic(0.7, 0.0)),
        ("gltf r 0.6", gltf([0.8, 0.3, 0.1], 0.3, 0.6)),
    ];
    for (what, mat) in materials {
        assert_reciprocal_and_one_sided_at_the_horizon(what, mat);
    }
}

// --- White furnace ----------------------------------------------------------------------------------

/// The directional albedo of a GGX reflection lobe with Fresnel factor `fresnel(wo.h)`, isotropic
/// alpha, seen from cos theta_o: E = \int F D G2 / (4 cos_o cos_i) cos_i d omega_i. Independent of the
/// shader's sampling: written over microfacet normals (d omega_i = 4 |wo.h| d omega_h) as
/// E = \int F G2 |wo.h| / (cos_o cos theta_h) dP(h), dP = D cos theta_h d omega_h, and integrated in the
/// coordinates where P is uniform (tan^2 theta_h = alpha^2 t / (1 - t), phi), where the integrand is
/// bounded and continuous: Gauss–Legendre on 256 x 128 panels, f64.
fn ggx_albedo(alpha: f64, cos_o: f64, fresnel: impl Fn(f64) -> f64) -> f64 {
    let wo = [(1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o];
    let lambda = |w: V3| {
        let a = alpha * alpha * (w[0] * w[0] + w[1] * w[1]) / (w[2] * w[2]);
        0.5 * ((1.0 + a).sqrt() - 1.0)
    };
    let (nt, np) = (256, 128);
    let mut sum = 0.0;
    for i in 0..nt {
        for j in 0..np {
            for &(x, wx) in &GAUSS_LEGENDRE_4 {
                for &(y, wy) in &GAUSS_LEGENDRE_4 {
                    let t = (i as f64 + 0.5 * (x + 1.0)) / nt as f64;
                    let phi = (j as f64 + 0.5 * (y + 1.0)) / np as f64 * 2.0 * std::f64::consts::PI;
                    let tan2 = alpha * alpha * t / (1.0 - t);
                    let cos_h = 1.0 / (1.0 + tan2).sqrt();
                    let sin_h = (1.0 - cos_h * cos_h).sqrt();
                    let h = [sin_h * phi.cos(), sin_h * phi.sin(), cos_h];
                    let oh = dot(wo, h);
                    if oh <= 0.0 {
                        continue;
                    }
                    let wi: V3 = std::array::from_fn(|k| 2.0 * oh * h[k] - wo[k]);
                    if wi[2] <= 0.0 {
                        continue;
                    }
                    let g2 = 1.0 / (1.0 + lambda(wo) + lambda(wi));
                    let w = 0.25 * wx * wy / (nt * np) as f64;
                    sum += w * fresnel(oh) * g2 * oh / (cos_o * cos_h);
                }
            }
        }
    }
    sum
}

/// The f64 Fresnel reflectance of a smooth dielectric (relative index eta).
fn fresnel_dielectric(c: f64, eta: f64) -> f64 {
    let s2 = (1.0 - c * c) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2).sqrt();
    let rp = (eta * c - ct) / (eta * c + ct);
    let rs = (c - eta * ct) / (c + eta * ct);
    0.5 * (rp * rp + rs * rs)
}

/// The mean weight of n samples (absorbed samples weigh 0): the material's directional albedo for the
/// first channel, with its standard error.
fn albedo_gpu(setup: &Setup, seed: u32, n: usize) -> (f64, f64) {
    // In batches of 2^18, each with its own seed (one seed draws the same numbers in every batch).
    const BATCH: usize = 1 << 18;
    let w: Vec<f64> = (0..n.div_ceil(BATCH))
        .flat_map(|b| setup.samples(seed * 64 + b as u32, BATCH.min(n - b * BATCH)))
        .map(|o| {
            if o.w[3] as u32 == 0 {
                0.0
            } else {
                o.w[0] as f64
            }
        })
        .collect();
    let mean = w.iter().sum::<f64>() / n as f64;
    let var = w.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, (var / n as f64).sqrt())
}

/// A conductor with F = 1 loses only what single-scattering GGX loses: its albedo matches the f64
/// quadrature of the same model within 5 standard errors plus 2e-4 (f32 rounding of the weights), at
/// every roughness and angle. The losses (1 - E) are printed for the record. glTF's metallic_roughness
/// with metallic 1 and base colour 1 is the same lobe, and loses the same.
#[test]
fn white_furnace_conductor_loses_only_single_scattering_energy() {
    const N: usize = 1 << 20;
    let mut seed = 300;
    for r in [0.1f64, 0.25, 0.5, 0.75, 1.0] {
        let mut line = format!("roughness {r}: loss 1 - E at cos_o");
        for cos_o in [1.0, 0.7, 0.3, 0.1] {
            let want = ggx_albedo(r * r, cos_o, |_| 1.0);
            for (what, mat) in [
                ("conductor", white_conductor(r as f32)),
                ("metallic_roughness", gltf([1.0; 3], 1.0, r as f32)),
            ] {
                let setup = Setup::new(mat, cos_o);
                let (got, se) = albedo_gpu(&setup, seed, N);
                seed += 1;
                assert!(
                    (got - want).abs() <= 5.0 * se + 2e-4,
                    "{what} r {r}, cos_o {cos_o}: albedo {got} +- {se} vs f64 {want}"
                );
            }
            line += &format!(" {cos_o}: {:.4}", 1.0 - want);
        }
        eprintln!("{line}");
    }
}

/// A rough dielectric interface's (reflected, transmitted) fractions of light arriving at cosine `mu`
/// (relative index eta, GGX alpha), with the separable masking-shadowing G1(wi) G1(wo) of Mitsuba's
/// roughplastic tables: R = \int F D G1 G1 (wi.h) / mu d omega_h over half vectors h reflecting wi above
/// the surface, T = \int (1 - F) D G1 G1 (wi.h) / mu d omega_h over those refracting it below. Integrated
/// here over h in spherical coordinates, theta_h = atan(alpha tan(pi s / 2)) (s in [0, 1], which spreads
/// the peak of D), by the midpoint rule on 1600 x 200 cells: independent of the library's quadrature.
fn rough_interface(alpha: f64, mu: f64, eta: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    let wi = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    let lambda = |w: V3| {
        0.5 * ((1.0 + alpha * alpha * (w[0] * w[0] + w[1] * w[1]) / (w[2] * w[2])).sqrt() - 1.0)
    };
    let (ns, np) = (1600, 200);
    let (mut r, mut t) = (0.0, 0.0);
    for i in 0..ns {
        let s = (i as f64 + 0.5) / ns as f64;
        let tan_s = (0.5 * PI * s).tan();
        let theta = (alpha * tan_s).atan();
        let dtheta_ds =
            alpha * 0.5 * PI * (1.0 + tan_s * tan_s) / (1.0 + alpha * alpha * tan_s * tan_s);
        let (sin_h, cos_h) = theta.sin_cos();
        let tan2 = (sin_h / cos_h).powi(2);
        let d = 1.0 / (PI * alpha * alpha * cos_h.powi(4) * (1.0 + tan2 / (alpha * alpha)).powi(2));
        for j in 0..np {
            // phi over [0, pi], doubled: wi lies in the xz plane.
            let phi = (j as f64 + 0.5) / np as f64 * PI;
            let h = [sin_h * phi.cos(), sin_h * phi.sin(), cos_h];
            let ih = dot(wi, h);
            if ih <= 0.0 {
                continue;
            }
            let measure = 2.0 * sin_h * dtheta_ds / ns as f64 * PI / np as f64;
            let common = d * ih / mu * measure / (1.0 + lambda(wi));
            let f = fresnel_dielectric(ih, eta);
            let wo: V3 = std::array::from_fn(|k| 2.0 * ih * h[k] - wi[k]);
            if wo[2] > 0.0 {
                r += common * f / (1.0 + lambda(wo));
            }
            let sin2_t = (1.0 - ih * ih) / (eta * eta);
            if sin2_t < 1.0 {
                let cos_t = (1.0 - sin2_t).sqrt();
                let wt: V3 = std::array::from_fn(|k| -wi[k] / eta + (ih / eta - cos_t) * h[k]);
                if wt[2] < 0.0 {
                    t += common * (1.0 - f) / (1.0 + lambda(wt));
                }
            }
        }
    }
    (r, t)
}

/// A smooth white plastic reflects everything at every angle: the coat's F(cos_o) specularly and the rest
/// diffusely (eta^2 (1 - Fdr_int) = 1 - Fdr_ext makes the diffuse albedo exactly 1 - F(cos_o)). A rough
/// coat (Mitsuba's roughplastic) reflects E_ggx,F(cos_o), the f64 quadrature of its specular lobe, plus
/// T(cos_o) 2 \int_0^1 T(c) c dc / (eta^2 (1 - Fdr_int)) diffusely, with T the coat's rough
/// transmittance and Fdr_int = 2 mean_k R(c_k; 1 / eta) c_k over Mitsuba's 64 cosines c_k = k / 63
/// (rough_interface, f64; the integral by 32-point Gauss-Legendre panels in c).
#[test]
fn white_furnace_plastic() {
    const N: usize = 1 << 20;
    let mut seed = 400;
    for r in [0.0f64, 0.3, 0.7] {
        let alpha = r * r;
        let (transmitted, fdr_int) = if r == 0.0 {
            (0.0, 0.0)
        } else {
            let mut integral = 0.0;
            for p in 0..8 {
                for &(x, w) in &GAUSS_LEGENDRE_4 {
                    let c = (p as f64 + 0.5 * (x + 1.0)) / 8.0;
                    integral += 0.5 * w / 8.0 * rough_interface(alpha, c, 1.5).1 * c;
                }
            }
            let fdr: f64 = (0..64)
                .map(|k| {
                    let c = (k as f64 / 63.0).max(1e-6);
                    rough_interface(alpha, c, 1.0 / 1.5).0 * c
                })
                .sum::<f64>()
                * 2.0
                / 64.0;
            (2.0 * integral, fdr)
        };
        for cos_o in [1.0, 0.6, 0.2, 0.05] {
            let want = if r == 0.0 {
                1.0
            } else {
                let spec = ggx_albedo(alpha, cos_o, |c| fresnel_dielectric(c, 1.5));
                spec + rough_interface(alpha, cos_o, 1.5).1 * transmitted
                    / (1.5 * 1.5 * (1.0 - fdr_int))
            };
            let setup = Setup::new(plastic(1.0, r as f32), cos_o);
            let (got, se) = albedo_gpu(&setup, seed, N);
            seed += 1;
            eprintln!(
                "plastic r {r}, cos_o {cos_o}: albedo {got:.5} +- {se:.5}, expected {want:.5}"
            );
            assert!(
                (got - want).abs() <= 5.0 * se + 5e-4,
                "plastic r {r}, cos_o {cos_o}: albedo {got} +- {se} vs {want}"
            );
        }
    }
}

/// A smooth grey plastic (albedo a = 0.4, ior 1.5): the coat reflects F(cos_o) and the base
/// a (1 - F(cos_o)) (1 - Fdr_int) / (1 - a Fdr_int) when its internal reflections are tinted again at each
/// bounce (nonlinear), a (1 - F(cos_o)) when not (linear: Mitsuba's default), Fdr_int the internal
/// reflectance's cosine-weighted mean 2 int_0^1 F(c, 1/1.5) c dc by quadrature here.
#[test]
fn grey_plastic_linear_and_nonlinear_albedos() {
    const N: usize = 1 << 20;
    let a = 0.4f64;
    let steps = 100_000;
    let fdr_int: f64 = (0..steps)
        .map(|k| {
            let c = (k as f64 + 0.5) / steps as f64;
            2.0 * fresnel_dielectric(c, 1.0 / 1.5) * c / steps as f64
        })
        .sum();
    let mut seed = 450;
    for cos_o in [1.0, 0.5, 0.1] {
        let f = fresnel_dielectric(cos_o, 1.5);
        for nonlinear in [true, false] {
            let diffuse = if nonlinear {
                a * (1.0 - f) * (1.0 - fdr_int) / (1.0 - a * fdr_int)
            } else {
                a * (1.0 - f)
            };
            let want = f + diffuse;
            let setup = Setup::new(plastic_of(a as f32, 0.0, nonlinear), cos_o);
            let (got, se) = albedo_gpu(&setup, seed, N);
            seed += 1;
            assert!(
                (got - want).abs() <= 5.0 * se + 5e-4,
                "nonlinear {nonlinear}, cos_o {cos_o}: albedo {got} +- {se} vs {want}"
            );
        }
    }
}

/// A thin pane (Mitsuba's thindielectric): every sample reflects about ns or passes straight through
/// (wi = -wo exactly), with weight 1, and the fraction reflected is 2R / (1 + R), R the f64 Fresnel
/// reflectance at cos_o (the internal reflections summed), within 5 standard errors.
#[test]
fn thin_dielectric_reflects_two_r_over_one_plus_r_and_passes_straight_through() {
    use vkpath::kernel::abi::{BSDF_REFLECTION, BSDF_TRANSMISSION};
    const N: usize = 1 << 18;
    for (k, cos_o) in [1.0f64, 0.5, 0.1].into_iter().enumerate() {
        let setup = Setup::new(material(Bsdf::ThinDielectric { ior: 1.5 }), cos_o);
        let r = fresnel_dielectric(cos_o, 1.5);
        let want = 2.0 * r / (1.0 + r);
        let mirror = setup.mirror();
        let mut reflected = 0usize;
        for o in setup.samples(900 + k as u32, N) {
            let flags = o.w[3] as u32;
            assert_eq!(&o.w[..3], &[1.0, 1.0, 1.0], "cos_o {cos_o}: weight");
            let wi = [o.s[0] as f64, o.s[1] as f64, o.s[2] as f64];
            if flags & BSDF_REFLECTION != 0 {
                reflected += 1;
                assert!(
                    (0..3).all(|i| (wi[i] - mirror[i]).abs() < 1e-5),
                    "{wi:?} vs {mirror:?}"
                );
            } else {
                assert!(flags & BSDF_TRANSMISSION != 0, "flags {flags}");
                assert!(
                    (0..3).all(|i| (wi[i] + setup.wo[i]).abs() < 1e-6),
                    "{wi:?} vs -{:?}",
                    setup.wo
                );
            }
        }
        let got = reflected as f64 / N as f64;
        let se = (want * (1.0 - want) / N as f64).sqrt();
        assert!(
            (got - want).abs() <= 5.0 * se + 1e-6,
            "cos_o {cos_o}: reflected {got} vs {want} (se {se})"
        );
    }
}

/// A rough dielectric of ior 1 has no interface: every sample passes straight through (wi = -wo) with
/// weight 1, whatever the roughness, in both directions. (The host uploads it as the smooth dielectric;
/// the shader's rough kind, given it directly, must do the same.)
#[test]
fn rough_dielectric_of_ior_one_is_invisible() {
    for r in [0.2f32, 1.0] {
        let mut mat = rough_glass(1.0, r);
        assert_ne!(
            mat.kind, MAT_ROUGH_DIELECTRIC,
            "ior 1 is uploaded as smooth"
        );
        mat.kind = MAT_ROUGH_DIELECTRIC;
        mat.alpha_x = r * r;
        mat.alpha_y = r * r;
        for entering in [true, false] {
            let mut setup = Setup::new(mat, 0.3);
            setup.entering = entering;
            for o in setup.samples(5, 4096) {
                assert_eq!(o.w[3] as u32, BSDF_TRANSMISSION | BSDF_DELTA, "{o:?}");
                assert_eq!(&o.w[..3], &[1.0; 3], "{o:?}");
                let wo = setup.wo.map(|x| -x as f32);
                assert_eq!(&o.s[..3], &wo, "{o:?}");
            }
        }
    }
}

// --- Fresnel of a complex index ----------------------------------------------------------------------

/// F of a conductor (the smooth conductor's sample weight is F(cos_o)) against the complex Fresnel
/// equations in f64: r_s = (c - w) / (c + w), r_p = (n^2 c - w) / (n^2 c + w), w = sqrt(n^2 - sin^2),
/// n = eta + i k, F = (|r_s|^2 + |r_p|^2) / 2. Every preset, normal to grazing incidence, within 2e-5.
#[test]
fn conductor_fresnel_matches_complex_reference() {
    #[derive(Clone, Copy)]
    struct C(f64, f64);
    let mul = |a: C, b: C| C(a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let div = |a: C, b: C| {
        let d = b.0 * b.0 + b.1 * b.1;
        C((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    };
    let sqrt = |a: C| {
        let r = (a.0 * a.0 + a.1 * a.1).sqrt();
        let re = ((r + a.0) / 2.0).sqrt();
        let im = ((r - a.0) / 2.0).sqrt().copysign(a.1);
        C(re, im)
    };
    let norm2 = |a: C| a.0 * a.0 + a.1 * a.1;
    let reference = |c: f64, eta: f64, k: f64| {
        let n2 = mul(C(eta, k), C(eta, k));
        let w = sqrt(C(n2.0 - (1.0 - c * c), n2.1));
        let rs = div(C(c - w.0, -w.1), C(c + w.0, w.1));
        let n2c = C(n2.0 * c, n2.1 * c);
        let rp = div(C(n2c.0 - w.0, n2c.1 - w.1), C(n2c.0 + w.0, n2c.1 + w.1));
        0.5 * (norm2(rs) + norm2(rp))
    };
    for (name, eta, k) in CONDUCTOR_PRESETS {
        let mat = conductor(name, Roughness::SMOOTH);
        let coss = [1.0, 0.9, 0.7, 0.5, 0.3, 0.1, 0.03, 0.01];
        let setups: Vec<Setup> = coss.iter().map(|&c| Setup::new(mat, c)).collect();
        let cases: Vec<Case> = setups.iter().map(|s| s.case(0, s.ns)).collect();
        for ((o, s), c) in gpu(&cases).iter().zip(&setups).zip(coss) {
            assert_eq!(o.w[3] as u32, BSDF_REFLECTION | BSDF_DELTA);
            let cos = dot(s.wo, s.ns);
            for ch in 0..3 {
                let want = reference(cos, eta[ch] as f64, k[ch] as f64);
                assert!(
                    (o.w[ch] as f64 - want).abs() < 2e-5,
                    "{name} channel {ch}, cos {c}: F = {} vs {want}",
                    o.w[ch]
                );
            }
        }
    }
}

// --- No NaN, no Inf --------------------------------------------------------------------------------

/// Every material at roughness 0 to 1 (through the smooth threshold), seen from normal incidence down to
/// grazing and a hair below the surface, queried in every direction (the normal, its opposite, grazing
/// ones): every value read back is finite, weights, f and pdfs are >= 0.
#[test]
fn no_nan_or_inf_at_any_angle_or_roughness() {
    let mut cases = Vec::new();
    let roughnesses = [0.0f32, 1e-4, 0.01, 0.0316, 0.0317, 0.05, 0.1, 0.5, 0.9, 1.0];
    let coss = [1.0f64, 0.999_999, 0.5, 1e-3, 1e-6, 0.0, -1e-6];
    let ns = normalize([0.3, -0.5, 0.81]);
    let queries: Vec<V3> = [1.0, 0.999_999, 0.3, 1e-4, 0.0, -1e-4, -0.3, -1.0]
        .iter()
        .flat_map(|&c| [0.0, 2.0].map(|phi| from_angles(ns, c, phi)))
        .collect();
    for &r in &roughnesses {
        let mats = [
            conductor("aluminium", Roughness::isotropic(r)),
            conductor("gold", Roughness::anisotropic(r, 1.0 - r)),
            white_conductor(r),
            rough_glass(1.5, r),
            rough_glass(1.0001, r),
            plastic(0.8, r),
            plastic(1.0, r),
            gltf([0.5, 0.5, 0.5], 0.0, r),
            gltf([1.0, 0.8, 0.2], 1.0, r),
            gltf([0.0, 0.0, 0.0], 0.5, r),
        ];
        for mat in mats {
            for &cos_o in &coss {
                for entering in [true, false] {
                    for &q in &queries {
                        let mut s = Setup::new(mat, 0.5);
                        s.wo = from_angles(ns, cos_o, 1.0);
                        s.entering = entering;
                        cases.push(s.case(cases.len() as u32 % 4096, q));
                    }
                }
            }
        }
    }
    let out = gpu(&cases);
    for (c, o) in cases.iter().zip(&out) {
        let all = [o.s, o.w, o.at, o.aq, o.r, o.rp].concat();
        assert!(
            all.iter().all(|x| x.is_finite()),
            "not finite: {o:?} for material kind {} alpha {} wo {:?}",
            c.mat.kind,
            c.mat.alpha_x,
            c.wo
        );
        let nonneg = [
            o.w[0], o.w[1], o.w[2], o.s[3], o.at[3], o.aq[0], o.aq[1], o.aq[2], o.aq[3], o.r[0],
        ];
        assert!(
            nonneg.iter().all(|&x| x >= 0.0),
            "negative: {o:?} for material kind {} alpha {}",
            c.mat.kind,
            c.mat.alpha_x
        );
    }
    eprintln!("{} cases, all finite", cases.len());
}
