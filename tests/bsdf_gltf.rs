//! `gltf_pbr` (shaders/bsdfs/gltf_pbr.wgsl): glTF 2.0's metallic-roughness material with the Khronos
//! PBR extensions KHR_materials_ior, _specular, _transmission, _volume, _clearcoat and _sheen, through
//! the shared adapter (tests/common/bsdf.rs) as a scene file gives it (`metallic_roughness` with the
//! extensions' keys): f against an f64 implementation of the specification's formulas written here
//! (glTF 2.0 Appendix B and each extension's "Implementation" section), the sampler against its own pdf
//! (chi-square), sample / eval / pdf consistency, the directional albedo (a furnace) with a clearcoat
//! and with a sheen against an f64 quadrature of the same model, the smooth surfaces' closed forms
//! (Fresnel of a thin sheet; refraction by Snell's law), the keys' checks, and renders of slabs (a thin
//! sheet, a volume with and without absorption) against their closed forms. The glTF reader's side is
//! tests/gltf.rs (`gltf_pbr_extensions_are_read_into_the_materials_layers`).

mod common;

use common::bsdf::*;
use common::vec::{V3, add, dot, from_angles, normalize, scale, sub, xyz};
use std::f64::consts::PI;
use vkpath::kernel::abi::{BSDF_DELTA, BSDF_TRANSMISSION, GpuMaterial};

/// The parameters, as a scene file gives them (the extensions' defaults where a case leaves them).
#[derive(Clone, Copy)]
struct P {
    base: [f64; 3],
    metallic: f64,
    roughness: f64,
    ior: f64,
    specular: f64,
    specular_color: [f64; 3],
    transmission: f64,
    volume: bool,
    clearcoat: f64,
    clearcoat_roughness: f64,
    sheen_color: [f64; 3],
    sheen_roughness: f64,
}

const DEFAULT: P = P {
    base: [0.8, 0.8, 0.8],
    metallic: 0.0,
    roughness: 0.5,
    ior: 1.5,
    specular: 1.0,
    specular_color: [1.0; 3],
    transmission: 0.0,
    volume: false,
    clearcoat: 0.0,
    clearcoat_roughness: 0.0,
    sheen_color: [0.0; 3],
    sheen_roughness: 0.0,
};

fn arr(c: [f64; 3]) -> String {
    format!("[{}, {}, {}]", c[0], c[1], c[2])
}

impl P {
    fn toml(&self) -> String {
        format!(
            "{{ type = \"metallic_roughness\", base_color = {}, metallic = {}, roughness = {}, ior = {}, \
             specular = {}, specular_color = {}, transmission = {}, volume = {}, clearcoat = {}, \
             clearcoat_roughness = {}, sheen_color = {}, sheen_roughness = {} }}",
            arr(self.base),
            self.metallic,
            self.roughness,
            self.ior,
            self.specular,
            arr(self.specular_color),
            self.transmission,
            self.volume,
            self.clearcoat,
            self.clearcoat_roughness,
            arr(self.sheen_color),
            self.sheen_roughness
        )
    }
}

/// The cases: each extension alone, then together.
fn cases() -> Vec<(&'static str, P)> {
    vec![
        (
            "ior and specular colour",
            P {
                base: [0.7, 0.3, 0.2],
                ior: 1.8,
                specular: 0.7,
                specular_color: [1.0, 0.5, 0.25],
                roughness: 0.4,
                ..DEFAULT
            },
        ),
        (
            "clearcoat over a rough red dielectric",
            P {
                base: [0.8, 0.1, 0.1],
                roughness: 0.7,
                clearcoat: 1.0,
                clearcoat_roughness: 0.3,
                ..DEFAULT
            },
        ),
        (
            "sheen over a half metal",
            P {
                base: [0.2, 0.3, 0.6],
                metallic: 0.5,
                roughness: 0.6,
                sheen_color: [1.0, 0.8, 0.6],
                sheen_roughness: 0.4,
                ..DEFAULT
            },
        ),
        (
            "thin rough transmission",
            P {
                base: [0.9, 0.8, 0.5],
                roughness: 0.35,
                transmission: 0.8,
                ..DEFAULT
            },
        ),
        (
            "volumetric rough transmission",
            P {
                base: [0.9, 0.9, 0.7],
                roughness: 0.3,
                transmission: 1.0,
                volume: true,
                ..DEFAULT
            },
        ),
        (
            "everything",
            P {
                base: [0.6, 0.5, 0.4],
                metallic: 0.2,
                roughness: 0.45,
                ior: 1.4,
                specular: 0.8,
                specular_color: [0.9, 1.0, 0.8],
                transmission: 0.5,
                volume: true,
                clearcoat: 0.6,
                clearcoat_roughness: 0.2,
                sheen_color: [0.5, 0.5, 0.7],
                sheen_roughness: 0.5,
            },
        ),
    ]
}

// --- The specification's model, in f64 ---------------------------------------------------------------

fn pow5(c: f64) -> f64 {
    (1.0 - c.clamp(0.0, 1.0)).powi(5)
}

fn max3(c: [f64; 3]) -> f64 {
    c[0].max(c[1]).max(c[2])
}

/// GGX D(h) for cos(theta_h) = `c` (Appendix B).
fn ggx_d(c: f64, a: f64) -> f64 {
    if c <= 0.0 {
        return 0.0;
    }
    let a2 = a * a;
    let q = c * c * (a2 - 1.0) + 1.0;
    a2 / (PI * q * q)
}

/// Smith's Lambda for GGX at cosine `c`.
fn ggx_lambda(c: f64, a: f64) -> f64 {
    let t2 = (1.0 - c * c).max(0.0) / (c * c);
    ((1.0 + a * a * t2).sqrt() - 1.0) / 2.0
}

/// The specification's specular_brdf without Fresnel: D G2 / (4 |cos_o| |cos_i|), height-correlated G2,
/// for the microfacet normal h.
fn spec_brdf(h: V3, ns: V3, wo: V3, wi: V3, a: f64) -> f64 {
    let (co, ci) = (dot(wo, ns).abs(), dot(wi, ns).abs());
    let g2 = 1.0 / (1.0 + ggx_lambda(co, a) + ggx_lambda(ci, a));
    ggx_d(dot(h, ns), a) * g2 / (4.0 * co * ci)
}

/// The Charlie sheen lobe without its colour (KHR_materials_sheen, Implementation Notes).
fn sheen_l(x: f64, a: f64) -> f64 {
    let t = (1.0 - a) * (1.0 - a);
    let m = |p: f64, q: f64| p * (1.0 - t) + q * t;
    m(21.5473, 25.3245) / (1.0 + m(3.82987, 3.32435) * x.powf(m(0.19823, 0.16801)))
        + m(-1.97760, -1.27393) * x
        + m(-4.32054, -4.85967)
}

fn sheen_lambda(c: f64, a: f64) -> f64 {
    if c.abs() < 0.5 {
        sheen_l(c, a).exp()
    } else {
        (2.0 * sheen_l(0.5, a) - sheen_l(1.0 - c, a)).exp()
    }
}

fn sheen_lobe(ns: V3, wo: V3, wi: V3, a: f64) -> f64 {
    let h = normalize(add(wo, wi));
    let c = dot(h, ns);
    let d = (2.0 + 1.0 / a) * (1.0 - c * c).max(0.0).powf(0.5 / a) / (2.0 * PI);
    let (co, ci) = (dot(wo, ns), dot(wi, ns));
    d / ((1.0 + sheen_lambda(co, a) + sheen_lambda(ci, a)) * 4.0 * co * ci)
}

/// E(mu) as the material defines it: the uploaded table (coat[8..16], the lobe's albedo at
/// mu_j = (j / 7)^3, held against a quadrature below), linear in 7 cbrt(mu).
fn sheen_e(mat: &GpuMaterial, mu: f64) -> f64 {
    let x = mu.clamp(0.0, 1.0).cbrt() * 7.0;
    let j = (x as usize).min(6);
    let u = x - j as f64;
    f64::from(mat.block[8 + j]) * (1.0 - u) + f64::from(mat.block[9 + j]) * u
}

/// f(wo, wi) of the whole material; `entering`: wo is on the outer side.
fn model_f(p: &P, mat: &GpuMaterial, ns: V3, wo: V3, wi: V3, entering: bool) -> [f64; 3] {
    let (co, ci) = (dot(wo, ns), dot(wi, ns));
    let a = p.roughness * p.roughness;
    let outside = entering || !p.volume;
    let sheen_a = p.sheen_roughness.max(0.07);
    // The dielectric Fresnel: f0 from the ior and the specular colour; inside a volume at the outer
    // side's cosine (Snell), 1 under total internal reflection.
    let fr = |c: f64, inside: bool| -> [f64; 3] {
        let r = (p.ior - 1.0) / (p.ior + 1.0);
        let c = if inside {
            let s2 = (1.0 - c * c) * p.ior * p.ior;
            if s2 >= 1.0 { 0.0 } else { (1.0 - s2).sqrt() }
        } else {
            c
        };
        std::array::from_fn(|k| {
            let f0 = (r * r * p.specular_color[k]).min(1.0);
            f0 + (1.0 - f0) * pow5(c)
        })
    };
    let fc = if outside {
        p.clearcoat * (0.04 + 0.96 * pow5(co))
    } else {
        0.0
    };
    let sheen_scale = |mu: f64| {
        if outside {
            1.0 - max3(p.sheen_color) * sheen_e(mat, mu)
        } else {
            1.0
        }
    };
    let mut f = [0.0; 3];
    if ci > 0.0 {
        let h = normalize(add(wo, wi));
        let c = dot(wo, h);
        let fr = fr(c, !outside);
        let s = p.specular;
        let spec = spec_brdf(h, ns, wo, wi, a);
        let scale = sheen_scale(co).min(sheen_scale(ci));
        let coat = if p.clearcoat > 0.0 {
            spec_brdf(h, ns, wo, wi, p.clearcoat_roughness * p.clearcoat_roughness)
        } else {
            0.0
        };
        let sheen = if outside && max3(p.sheen_color) > 0.0 {
            sheen_lobe(ns, wo, wi, sheen_a)
        } else {
            0.0
        };
        for k in 0..3 {
            let b = p.base[k];
            let dielectric =
                s * fr[k] * spec + (1.0 - s * max3(fr)) * (1.0 - p.transmission) * b / PI;
            let metal = (b + (1.0 - b) * pow5(c)) * spec;
            let base = dielectric * (1.0 - p.metallic) + metal * p.metallic;
            let sheened = p.sheen_color[k] * sheen + base * scale;
            f[k] = (1.0 - fc) * sheened + fc * coat;
        }
    } else if ci < 0.0 && p.transmission > 0.0 {
        let scale = sheen_scale(co).min(sheen_scale(-ci));
        let (value, c) = if p.volume {
            // Walter et al. 2007: h = -(wo + eta wi) normalised, eta = n_t / n_i.
            let eta = if entering { p.ior } else { 1.0 / p.ior };
            let mut h = normalize(add(wo, scale_v(wi, eta)));
            if dot(h, ns) < 0.0 {
                h = scale_v(h, -1.0);
            }
            let (coh, cih) = (dot(wo, h), dot(wi, h));
            let denom = cih + coh / eta;
            if coh <= 0.0 || cih >= 0.0 {
                return f;
            }
            let g2 = 1.0 / (1.0 + ggx_lambda(co, a) + ggx_lambda(ci.abs(), a));
            let v = ggx_d(dot(h, ns), a) * g2 * cih.abs() * coh / (co * ci.abs() * denom * denom);
            (v, coh)
        } else {
            // Thin: the reflection lobe at wi mirrored through the surface.
            let wm = sub(wi, scale_v(ns, 2.0 * ci));
            let h = normalize(add(wo, wm));
            (spec_brdf(h, ns, wo, wm, a), dot(wo, h))
        };
        let fr = fr(c, !entering && p.volume);
        for (fk, b) in f.iter_mut().zip(p.base) {
            *fk = (1.0 - fc)
                * scale
                * (1.0 - p.metallic)
                * p.transmission
                * b
                * (1.0 - p.specular * max3(fr))
                * value;
        }
    }
    f
}

fn scale_v(v: V3, s: f64) -> V3 {
    scale(v, s)
}

fn material(p: &P) -> GpuMaterial {
    material_from_toml(&p.toml())
}

/// The query directions: a spread over the whole sphere (transmission included).
fn sphere_directions(ns: V3, n: usize) -> Vec<V3> {
    (0..n)
        .map(|i| {
            let c = -1.0 + 2.0 * ((i * 37 % n) as f64 + 0.5) / n as f64;
            from_angles(ns, c, i as f64 * 0.61)
        })
        .collect()
}

/// f against the f64 model at 1024 directions over the sphere per view, entering and (for a volume)
/// leaving: each channel within 2e-3 relative plus 1e-5 (f32 rounding of the half vectors, amplified at
/// a specular peak, and of the Charlie exponent).
#[test]
fn gltf_pbr_matches_the_specifications_model_in_f64() {
    for (name, p) in cases() {
        let mat = material(&p);
        assert_eq!(mat.kind, vkpath::kernel::abi::MAT_GLTF_PBR, "{name}");
        for entering in [true, false] {
            if !entering && !p.volume {
                continue; // a thin surface is the same from both sides
            }
            for cos_o in [0.9, 0.5, 0.2] {
                let mut setup = Setup::new(mat, cos_o);
                setup.entering = entering;
                let qs = sphere_directions(setup.ns, 1024);
                let out = gpu(&qs.iter().map(|&q| setup.case(0, q)).collect::<Vec<_>>());
                for (q, o) in qs.iter().zip(&out) {
                    if dot(*q, setup.ns).abs() < 1e-3 {
                        continue;
                    }
                    let want = model_f(&p, &mat, setup.ns, setup.wo, *q, entering);
                    for (k, want) in want.iter().enumerate() {
                        let got = f64::from(o.aq[k]);
                        assert!(
                            (got - want).abs() <= 2e-3 * want + 1e-5,
                            "{name}, entering {entering}, cos_o {cos_o}, cos_i {}: channel {k}: f = {got}, model {want}",
                            dot(*q, setup.ns)
                        );
                    }
                }
            }
        }
    }
}

/// The sheen's albedo table (coat[8..16], computed by src/kernel/sheen.rs) against this file's own
/// quadrature of the lobe above: E(mu) = the integral of the lobe x cos over the hemisphere (midpoint,
/// 400 x 200 cells over (cos, phi)), within 2e-3 at every node, for three roughnesses.
#[test]
fn the_sheen_albedo_table_is_the_lobes_albedo() {
    for r in [0.1, 0.4, 0.9] {
        let mat = material(&P {
            sheen_color: [1.0; 3],
            sheen_roughness: r,
            ..DEFAULT
        });
        let a: f64 = r.max(0.07);
        let ns = [0.0, 0.0, 1.0];
        for j in 0..8 {
            let mu = (j as f64 / 7.0).powi(3).max(1e-3);
            let wo = from_angles(ns, mu, 0.0);
            let (nc, np) = (400, 200);
            let mut e = 0.0;
            for i in 0..nc {
                let c = (i as f64 + 0.5) / nc as f64;
                for k in 0..np {
                    let wi = from_angles(ns, c, 2.0 * PI * (k as f64 + 0.5) / np as f64);
                    e += sheen_lobe(ns, wo, wi, a) * c;
                }
            }
            e *= 2.0 * PI / (nc * np) as f64;
            let table = f64::from(mat.block[8 + j]);
            assert!(
                (table - e).abs() < 2e-3,
                "sheen roughness {r}, mu {mu}: table {table}, quadrature {e}"
            );
        }
    }
}

/// The sampler against its own pdf (chi-square over the whole sphere), and, for the reciprocal cases
/// (no clearcoat, whose weight depends on wo alone, and no transmission), sample / eval / pdf
/// consistency and reciprocity.
#[test]
fn gltf_pbr_sampler_matches_its_own_pdf() {
    let mut seed = 1300;
    for (name, p) in cases() {
        let mat = material(&p);
        for cos_o in [0.8, 0.3] {
            let setup = Setup::new(mat, cos_o);
            // Rings about the mirror direction as wide as the narrowest lobe (they cover the sphere).
            let mut alpha = p.roughness * p.roughness;
            if p.clearcoat > 0.0 {
                alpha = alpha.min(p.clearcoat_roughness * p.clearcoat_roughness);
            }
            // A refracting lobe stops at cos = -cos_o / eta (microfacets at the horizon): rings that
            // start at that edge (as tests/shader_glossy.rs bins rough glass).
            let bins = if p.volume {
                Bins::transmission(setup.ns, cos_o, p.ior, 128, 256)
            } else {
                reflection_bins(&setup, alpha, cos_o)
            };
            chi2_sampler(&format!("{name}, cos_o {cos_o}"), &setup, &bins, seed);
            seed += 1;
        }
        if p.clearcoat == 0.0 && p.transmission == 0.0 {
            assert_sample_eval_pdf_agree(name, mat);
        }
    }
}

/// For every case, entering and leaving: each sample's weight is f |cos| / pdf and its pdf is the
/// material's pdf(wi) (the consistency the integrator's MIS relies on), without the reciprocity that the
/// specification's clearcoat (its weight is a function of wo) does not have.
#[test]
fn gltf_pbr_samples_agree_with_eval_and_pdf() {
    for (name, p) in cases() {
        let mat = material(&p);
        for entering in [true, false] {
            let mut setup = Setup::new(mat, 0.6);
            setup.entering = entering;
            let out = setup.samples(21, 4096);
            let mut seen = 0;
            for o in &out {
                let flags = o.w[3] as u32;
                if flags == 0 || flags & BSDF_DELTA != 0 {
                    continue;
                }
                seen += 1;
                let cos = dot(xyz(o.s), setup.ns).abs();
                let pdf = f64::from(o.s[3]);
                assert!(
                    (pdf - f64::from(o.at[3])).abs() <= 1e-4 * pdf,
                    "{name}: sampled pdf {pdf} vs pdf(wi) {}",
                    o.at[3]
                );
                for k in 0..3 {
                    let want = f64::from(o.at[k]) * cos / pdf;
                    assert!(
                        (want - f64::from(o.w[k])).abs() <= 1e-3 * want.abs() + 1e-6,
                        "{name}: weight {} vs f cos / pdf {want}",
                        o.w[k]
                    );
                }
            }
            assert!(seen > 1000, "{name}: only {seen} non-delta samples");
        }
    }
}

/// The directional albedo (a white furnace seen from cos_o = 0.6): the mean of the sampler's weights
/// over 2^18 samples against the f64 integral of f |cos| over the sphere (midpoint rule in (cos, phi),
/// 1200 x 480 cells per hemisphere, with the model above), within 5 standard errors plus 3e-3 for the
/// quadrature (the lobes' peaks). A clearcoat over a white base, a sheen over a white base, and all the
/// cases above. (Measured: the white clearcoat furnace reflects 1.0018 both ways, the sampler and the
/// quadrature, its white base alone 1.0024: the specification's core dielectric, whose diffuse lobe is
/// weighted by 1 - F(VdotH), is not exactly energy conserving, and the clearcoat's layering, a convex mix
/// of it and the coat, reflects less; the white sheen furnace 0.9397.)
#[test]
fn gltf_pbr_albedo_matches_the_models_integral() {
    let mut all = cases();
    all.push((
        "white clearcoat furnace",
        P {
            base: [1.0; 3],
            roughness: 0.5,
            clearcoat: 1.0,
            clearcoat_roughness: 0.25,
            ..DEFAULT
        },
    ));
    all.push((
        "white core furnace (the clearcoat's base alone)",
        P {
            base: [1.0; 3],
            roughness: 0.5,
            ..DEFAULT
        },
    ));
    all.push((
        "white sheen furnace",
        P {
            base: [1.0; 3],
            roughness: 0.8,
            sheen_color: [1.0; 3],
            sheen_roughness: 0.3,
            ..DEFAULT
        },
    ));
    let mut furnace = Vec::new();
    for (name, p) in all {
        let mat = material(&p);
        let cos_o = 0.6;
        let setup = Setup::new(mat, cos_o);
        let samples = setup.samples(77, 1 << 18);
        // Smooth lobes (deltas) are not in the quadrature: these cases have none.
        let integral = assert_albedo_matches(
            name,
            &samples,
            setup.ns,
            &[1.0, -1.0],
            (1200, 480),
            3e-3,
            |wi| model_f(&p, &mat, setup.ns, setup.wo, wi, true),
        );
        furnace.push((name, integral[0]));
    }
    // The clearcoat's layering is a convex mix of its base and the coat: it adds no energy to its base,
    // whose own excess over 1 is the specification's (the diffuse weight 1 - F(VdotH)).
    let get = |n: &str| furnace.iter().find(|(k, _)| k.starts_with(n)).unwrap().1;
    let (coat, core) = (get("white clearcoat"), get("white core"));
    assert!(
        coat <= core && core < 1.005,
        "clearcoat {coat}, its base {core}"
    );
}

/// Smooth surfaces, where every lobe is a delta, against the closed forms. A thin sheet (transmission 1,
/// white, ior 1.5): seen at cos_o, light is reflected with fr = 0.04 + 0.96 (1 - cos_o)^5 and passes
/// straight through with 1 - fr (KHR_materials_transmission's fresnel_mix with specular_btdf a delta);
/// the sampled weights' means per lobe times their frequencies give both. A volumetric surface refracts by
/// Snell's law (sin_t = sin_o / 1.5) with the same split.
#[test]
fn smooth_transmission_splits_by_schlicks_fresnel() {
    for volume in [false, true] {
        let p = P {
            base: [1.0; 3],
            roughness: 0.0,
            transmission: 1.0,
            volume,
            ..DEFAULT
        };
        let mat = material(&p);
        for cos_o in [1.0 - 1e-6, 0.7, 0.3] {
            let setup = Setup::new(mat, cos_o);
            let out = setup.samples(5, 1 << 16);
            let n = out.len() as f64;
            let fr = 0.04 + 0.96 * (1.0 - cos_o).powi(5);
            let mut transmitted = 0.0;
            for o in &out {
                let flags = o.w[3] as u32;
                assert!(
                    flags & BSDF_DELTA != 0,
                    "a smooth sheet samples deltas only"
                );
                let wi = xyz(o.s);
                // A delta lobe's weight times the probability of choosing it is its reflectance or
                // transmittance.
                let coefficient = f64::from(o.w[0]) * f64::from(o.s[3]);
                if flags & BSDF_TRANSMISSION != 0 {
                    transmitted += 1.0 / n;
                    let want = if volume {
                        // Snell: the refracted direction, eta = 1.5.
                        let c_t = (1.0 - (1.0 - cos_o * cos_o) / 2.25).sqrt();
                        let wo_t = sub(scale(setup.ns, cos_o), setup.wo);
                        normalize(sub(scale(wo_t, 1.0 / 1.5), scale(setup.ns, c_t)))
                    } else {
                        scale(setup.wo, -1.0)
                    };
                    assert!(
                        dot(wi, want) > 1.0 - 1e-5,
                        "transmitted along {wi:?}, want {want:?}"
                    );
                    assert!(
                        (coefficient - (1.0 - fr)).abs() < 1e-5,
                        "volume {volume}, cos_o {cos_o}: T {coefficient}, 1 - fr {}",
                        1.0 - fr
                    );
                } else {
                    assert!(dot(wi, setup.mirror()) > 1.0 - 1e-5);
                    assert!(
                        (coefficient - fr).abs() < 1e-5,
                        "volume {volume}, cos_o {cos_o}: R {coefficient}, fr {fr}"
                    );
                }
            }
            // Each lobe is chosen with its share: within 5 standard errors of 1 - fr.
            let se = (fr * (1.0 - fr) / n).sqrt();
            assert!(
                (transmitted - (1.0 - fr)).abs() < 5.0 * se,
                "volume {volume}, cos_o {cos_o}: transmitted {transmitted} of the samples, 1 - fr {}",
                1.0 - fr
            );
        }
    }
}

/// The keys: a metallic_roughness without them is the plain kind; each out of range, or attenuation
/// without `volume`, is refused naming the key and the line; absorption is -ln(colour) / distance.
#[test]
fn gltf_pbr_keys_are_checked() {
    let plain = material_from_toml("{ type = \"metallic_roughness\" }");
    assert_eq!(plain.kind, vkpath::kernel::abi::MAT_METALLIC_ROUGHNESS);
    let v = material_from_toml(
        "{ type = \"metallic_roughness\", transmission = 1.0, volume = true, attenuation_color = [0.5, 0.25, 1.0], attenuation_distance = 2.0 }",
    );
    assert_eq!(v.kind, vkpath::kernel::abi::MAT_GLTF_PBR);
    for (k, want) in [0.5f64, 0.25, 1.0].iter().enumerate() {
        let sigma = -want.ln() / 2.0;
        assert!(
            (f64::from(v.block[4 + k]) - sigma).abs() < 1e-6,
            "{k}: {}",
            v.block[4 + k]
        );
    }
    for (spec, key) in [
        (
            "{ type = \"metallic_roughness\", transmission = 1.5 }",
            "materials.m.transmission",
        ),
        (
            "{ type = \"metallic_roughness\", clearcoat = -0.5 }",
            "materials.m.clearcoat",
        ),
        (
            "{ type = \"metallic_roughness\", sheen_color = [1.0, 2.0, 0.0] }",
            "materials.m.sheen_color",
        ),
        (
            "{ type = \"metallic_roughness\", ior = 0.0 }",
            "materials.m.ior",
        ),
        (
            "{ type = \"metallic_roughness\", attenuation_distance = 1.0 }",
            "materials.m.attenuation_distance",
        ),
        (
            "{ type = \"metallic_roughness\", volume = true, attenuation_color = [0.0, 0.5, 0.5] }",
            "materials.m.attenuation_color",
        ),
    ] {
        let e = material_error(spec);
        assert!(e.contains(key) && e.contains("line"), "{spec}: {e}");
    }
}

// --- Renders: a slab's transmittance -------------------------------------------------------------------

/// The TOML of an axis-aligned box [lo, hi] as twelve triangles, wound so that every geometric normal
/// points out of the box (the side a refracting material counts as outside).
fn box_triangles(lo: [f64; 3], hi: [f64; 3], material: &str) -> String {
    let corner = |i: usize| -> [f64; 3] {
        [
            if i & 1 != 0 { hi[0] } else { lo[0] },
            if i & 2 != 0 { hi[1] } else { lo[1] },
            if i & 4 != 0 { hi[2] } else { lo[2] },
        ]
    };
    // Each face as four corners counter-clockwise seen from outside.
    let faces = [
        [0, 2, 3, 1], // z = lo
        [4, 5, 7, 6], // z = hi
        [0, 1, 5, 4], // y = lo
        [2, 6, 7, 3], // y = hi
        [0, 4, 6, 2], // x = lo
        [1, 3, 7, 5], // x = hi
    ];
    let mut out = String::new();
    for f in faces {
        for tri in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let v: Vec<String> = tri.iter().map(|&i| arr(corner(i))).collect();
            out += &format!(
                "[[triangle]]\nvertices = [{}]\nmaterial = \"{material}\"\n",
                v.join(", ")
            );
        }
    }
    out
}

/// A camera on the z axis looking down -z through a narrow field (rays within 0.5 degrees of the axis),
/// a surface `body` between it and a wall at z = -5 that emits radiance 1 towards +z, nothing else (a
/// black sky): each pixel sees the wall through the body. Returns per channel the image mean and its
/// standard error.
fn seen_through(material: &str, body: &str) -> [(f64, f64); 3] {
    let toml = format!(
        "[camera]\nposition = [0.0, 0.0, 10.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 1.0\n\
         [image]\nwidth = 8\nheight = 8\n[render]\nsamples = 2048\nmax_bounces = -1\n\
         [materials]\nbody = {material}\nlamp = {{ type = \"emitter\", radiance = [1.0, 1.0, 1.0] }}\n\
         [[triangle]]\nvertices = [[-100.0, -100.0, -5.0], [100.0, -100.0, -5.0], [100.0, 100.0, -5.0]]\nmaterial = \"lamp\"\n\
         [[triangle]]\nvertices = [[-100.0, -100.0, -5.0], [100.0, 100.0, -5.0], [-100.0, 100.0, -5.0]]\nmaterial = \"lamp\"\n\
         {body}"
    );
    let film = common::render(&common::scene(&toml));
    let n = film.mean.len() as f64;
    std::array::from_fn(|c| {
        let mean = film.mean.iter().map(|p| f64::from(p[c])).sum::<f64>() / n;
        let var = film
            .variance
            .iter()
            .map(|v| f64::from(v[c]).max(0.0))
            .sum::<f64>()
            / (n * n);
        (mean, var.sqrt())
    })
}

/// Transmission through smooth slabs at normal incidence, against the closed forms with the
/// specification's Fresnel F = 0.04 (ior 1.5; Schlick at cos 1):
/// - a thin sheet (KHR_materials_transmission alone: one surface, the light tinted by the base colour
///   b): T = (1 - F) b;
/// - a volumetric slab of thickness d = 1 (KHR_materials_volume) absorbing sigma_a = -ln(c) / D with
///   D = attenuation_distance = 1, so that one crossing keeps e^{-sigma_a d} = c: the light crosses the
///   front (1 - F), the inside (c), the back (1 - F), and reflects back and forth inside (F^2 c^2 per
///   round trip), T = (1 - F)^2 c / (1 - F^2 c^2), the geometric series summed (Beer-Lambert between
///   Fresnel interfaces);
/// - the same slab without absorption (c = 1): (1 - F) / (1 + F).
///
/// Each within 5 standard errors (unbounded paths, Russian roulette).
#[test]
fn slabs_transmit_by_fresnel_and_beer_lambert() {
    let f = 0.04;
    let sheet = "[[triangle]]\nvertices = [[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [50.0, 50.0, 0.0]]\nmaterial = \"body\"\n\
                 [[triangle]]\nvertices = [[-50.0, -50.0, 0.0], [50.0, 50.0, 0.0], [-50.0, 50.0, 0.0]]\nmaterial = \"body\"\n";
    let b = [1.0, 0.5, 0.25];
    let thin = seen_through(
        &format!(
            "{{ type = \"metallic_roughness\", base_color = {}, metallic = 0.0, roughness = 0.0, transmission = 1.0 }}",
            arr(b)
        ),
        sheet,
    );
    let slab = box_triangles([-50.0, -50.0, -0.5], [50.0, 50.0, 0.5], "body");
    let c = [0.5, 0.7, 0.9];
    let absorbing = seen_through(
        &format!(
            "{{ type = \"metallic_roughness\", base_color = [1.0, 1.0, 1.0], metallic = 0.0, roughness = 0.0, \
             transmission = 1.0, volume = true, attenuation_color = {}, attenuation_distance = 1.0 }}",
            arr(c)
        ),
        &slab,
    );
    let clear = seen_through(
        "{ type = \"metallic_roughness\", base_color = [1.0, 1.0, 1.0], metallic = 0.0, roughness = 0.0, \
         transmission = 1.0, volume = true }",
        &slab,
    );
    for k in 0..3 {
        for (what, (mean, se), want) in [
            ("thin sheet", thin[k], (1.0 - f) * b[k]),
            (
                "absorbing slab",
                absorbing[k],
                (1.0 - f) * (1.0 - f) * c[k] / (1.0 - f * f * c[k] * c[k]),
            ),
            ("clear slab", clear[k], (1.0 - f) / (1.0 + f)),
        ] {
            eprintln!("{what}, channel {k}: {mean:.5} +- {se:.5}, closed form {want:.5}");
            assert!(
                (mean - want).abs() < 5.0 * se + 1e-6,
                "{what}, channel {k}: {mean} +- {se}, closed form {want}"
            );
        }
    }
}

/// An emitting glTF volume seen from inside: the camera sits in the middle of an absorbing slab of
/// thickness 1 (sigma_a = -ln c, attenuation_distance 1) whose faces emit Le on both sides, and looks
/// straight at the back of its far face, 0.5 away. With no bounce after the first hit, every sample is
/// that face's emission after half a crossing of the medium: Le c^0.5 (Beer-Lambert), up to the field's
/// 0.5 degrees (a path at most 4e-5 longer). The emission found at the boundary is light that crossed
/// the medium, so the absorption of the segment applies to it too.
#[test]
fn emission_seen_from_inside_a_volume_is_absorbed_on_the_way() {
    let c = [0.5, 0.7, 0.9];
    let le = [2.0, 3.0, 4.0];
    let toml = format!(
        "[camera]\nposition = [0.0, 0.0, 0.0]\nlook_at = [0.0, 0.0, -1.0]\nfov = 1.0\n\
         [image]\nwidth = 4\nheight = 4\n[render]\nsamples = 4\nmax_bounces = 0\n\
         [materials]\nbody = {{ type = \"metallic_roughness\", base_color = [1.0, 1.0, 1.0], metallic = 0.0, \
         roughness = 0.0, transmission = 1.0, volume = true, attenuation_color = {}, attenuation_distance = 1.0, \
         emission = {}, two_sided_emission = true }}\n{}",
        arr(c),
        arr(le),
        box_triangles([-50.0, -50.0, -0.5], [50.0, 50.0, 0.5], "body")
    );
    let film = common::render(&common::scene(&toml));
    for p in &film.mean {
        for k in 0..3 {
            let want = le[k] * c[k].sqrt();
            let got = f64::from(p[k]);
            assert!(
                (got - want).abs() < 1e-4 * want,
                "channel {k}: {got}, want Le c^0.5 = {want} (unattenuated it would be {})",
                le[k]
            );
        }
    }
}
