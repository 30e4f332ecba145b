//! `principled` (shaders/bsdfs/principled.wgsl: Mitsuba 3's principled BSDF without specular
//! transmission), through the shared adapter (tests/common/bsdf.rs) as the scene file gives it: f
//! against an f64 implementation of the model as Mitsuba 3.9.1's principled.cpp computes it (written here
//! from the formulas, with the angles' cosines in f64), the sampler against its own pdf (chi-square),
//! sample / eval / pdf consistency and reciprocity, the directional albedo the sampler's weights give
//! against an f64 quadrature of the model, and the keys' checks. (The render against Mitsuba 3 itself is
//! benches/peers/xml_check.py's: see docs/scene-format.md.)

mod common;

use common::bsdf::*;
use common::vec::{V3, add, dot, normalize};
use std::f64::consts::PI;

/// The parameters, as a scene file gives them.
#[derive(Clone, Copy)]
struct P {
    base: [f64; 3],
    roughness: f64,
    metallic: f64,
    specular: f64,
    spec_tint: f64,
    sheen: f64,
    sheen_tint: f64,
    clearcoat: f64,
    clearcoat_gloss: f64,
    flatness: f64,
}

impl P {
    fn toml(&self) -> String {
        format!(
            "{{ type = \"principled\", base_color = [{}, {}, {}], roughness = {}, metallic = {}, specular = {}, \
             spec_tint = {}, sheen = {}, sheen_tint = {}, clearcoat = {}, clearcoat_gloss = {}, flatness = {} }}",
            self.base[0],
            self.base[1],
            self.base[2],
            self.roughness,
            self.metallic,
            self.specular,
            self.spec_tint,
            self.sheen,
            self.sheen_tint,
            self.clearcoat,
            self.clearcoat_gloss,
            self.flatness
        )
    }

    fn eta(&self) -> f64 {
        2.0 / (1.0 - (0.08 * self.specular).sqrt()) - 1.0
    }
}

const CASES: [P; 4] = [
    // A red plastic-like dielectric.
    P {
        base: [0.8, 0.2, 0.1],
        roughness: 0.3,
        metallic: 0.0,
        specular: 0.5,
        spec_tint: 0.0,
        sheen: 0.0,
        sheen_tint: 0.0,
        clearcoat: 0.0,
        clearcoat_gloss: 0.0,
        flatness: 0.0,
    },
    // Half metal, tinted specular, sheen.
    P {
        base: [0.9, 0.6, 0.2],
        roughness: 0.5,
        metallic: 0.5,
        specular: 0.8,
        spec_tint: 0.6,
        sheen: 1.0,
        sheen_tint: 0.5,
        clearcoat: 0.0,
        clearcoat_gloss: 0.0,
        flatness: 0.0,
    },
    // Clearcoated, flattened diffuse.
    P {
        base: [0.1, 0.3, 0.6],
        roughness: 0.7,
        metallic: 0.0,
        specular: 0.3,
        spec_tint: 0.0,
        sheen: 0.3,
        sheen_tint: 0.0,
        clearcoat: 1.0,
        clearcoat_gloss: 0.4,
        flatness: 0.7,
    },
    // A rough metal.
    P {
        base: [0.95, 0.9, 0.8],
        roughness: 0.6,
        metallic: 1.0,
        specular: 0.5,
        spec_tint: 0.0,
        sheen: 0.0,
        sheen_tint: 0.0,
        clearcoat: 0.0,
        clearcoat_gloss: 0.0,
        flatness: 0.0,
    },
];

fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

fn schlick_weight(c: f64) -> f64 {
    (1.0 - c).clamp(0.0, 1.0).powi(5)
}

/// Mitsuba's calc_schlick for eta > 1 seen from outside: R0 + (1 - R0) SW(cos).
fn schlick(r0: f64, c: f64) -> f64 {
    r0 + (1.0 - r0) * schlick_weight(c)
}

/// Isotropic GGX D(h) and Smith's G1, by the cosines.
fn ggx_d(cos_h: f64, a: f64) -> f64 {
    let c2 = cos_h * cos_h;
    let q = c2 + (1.0 - c2) / (a * a);
    1.0 / (PI * a * a * q * q)
}

fn ggx_g1(cos_v: f64, a: f64) -> f64 {
    let t2 = (1.0 - cos_v * cos_v) / (cos_v * cos_v);
    2.0 / (1.0 + (1.0 + a * a * t2).sqrt())
}

fn gtr1(cos_h: f64, a: f64) -> f64 {
    let a2 = a * a;
    (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * cos_h * cos_h))
}

/// f(wo, wi) per channel, Mitsuba 3's principled (spec_trans 0, front side), in f64.
fn principled_f(p: &P, ns: V3, wo: V3, wi: V3) -> [f64; 3] {
    let (co, ci) = (dot(wo, ns), dot(wi, ns));
    if co <= 0.0 || ci <= 0.0 {
        return [0.0; 3];
    }
    let h = normalize(add(wo, wi));
    let (ch, coh, cd) = (dot(h, ns), dot(wo, h), dot(wi, h));
    let eta = p.eta();
    let a = (p.roughness * p.roughness).max(0.001);
    let lum = 0.212671 * p.base[0] + 0.715160 * p.base[1] + 0.072169 * p.base[2];
    let fd = fresnel_dielectric(coh, eta);
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let spec_dg = ggx_d(ch, a) * ggx_g1(co, a) * ggx_g1(ci, a) / (4.0 * co * ci);
    let acc = 0.1 + (0.001 - 0.1) * p.clearcoat_gloss;
    let gcc = ggx_g1(co, 0.25) * ggx_g1(ci, 0.25);
    let clearcoat = 0.25 * p.clearcoat * schlick(0.04, coh) * gtr1(ch, acc) * gcc;
    let (swo, swi) = (schlick_weight(ci), schlick_weight(co));
    let f_diff = (1.0 - 0.5 * swi) * (1.0 - 0.5 * swo);
    let rr = 2.0 * p.roughness * cd * cd;
    let f_retro = rr * (swo + swi + swo * swi * (rr - 1.0));
    let fss = (1.0 + (rr / 2.0 - 1.0) * swo) * (1.0 + (rr / 2.0 - 1.0) * swi);
    let f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5);
    let diffuse =
        (1.0 - p.metallic) / PI * ((f_diff + f_retro) * (1.0 - p.flatness) + f_ss * p.flatness);
    std::array::from_fn(|k| {
        let tint = if lum > 0.0 { p.base[k] / lum } else { 1.0 };
        let f_p = (1.0 - p.metallic) * (1.0 - p.spec_tint) * fd
            + p.metallic * schlick(p.base[k], coh)
            + (1.0 - p.metallic) * p.spec_tint * schlick(tint * r0, coh);
        let sheen =
            p.sheen * (1.0 - p.metallic) * schlick_weight(cd) * (1.0 + (tint - 1.0) * p.sheen_tint);
        f_p * spec_dg + clearcoat + diffuse * p.base[k] + sheen
    })
}

fn material(p: &P) -> vkpath::kernel::abi::GpuMaterial {
    material_from_toml(&p.toml())
}

/// f against the f64 model at 512 directions per view, each channel within 1e-3 relative (f32 rounding
/// of the half vector, amplified at the specular peak) plus 1e-6.
#[test]
fn principled_matches_mitsubas_model_in_f64() {
    for (n, p) in CASES.iter().enumerate() {
        for cos_o in [0.95, 0.5, 0.15] {
            let setup = Setup::new(material(p), cos_o);
            let what = format!("case {n}, cos_o {cos_o}");
            assert_eval_matches(&what, &setup, 1e-3, |wi| {
                principled_f(p, setup.ns, setup.wo, wi)
            });
        }
    }
}

/// The sampler against its own pdf (chi-square), and sample / eval / pdf consistency and reciprocity.
#[test]
fn principled_sampler_matches_its_own_pdf() {
    let mut seed = 900;
    for (n, p) in CASES.iter().enumerate() {
        for cos_o in [0.8, 0.3] {
            let setup = Setup::new(material(p), cos_o);
            let bins = reflection_bins(&setup, p.roughness * p.roughness, cos_o);
            chi2_sampler(
                &format!("principled case {n}, cos_o {cos_o}"),
                &setup,
                &bins,
                seed,
            );
            seed += 1;
        }
        assert_sample_eval_pdf_agree(&format!("principled case {n}"), material(p));
        assert_reciprocal_and_one_sided_at_the_horizon(
            &format!("principled case {n}"),
            material(p),
        );
    }
}

/// The directional albedo, the mean of the sampler's weights f cos / pdf over 2^18 samples, against the
/// f64 integral of f cos over the hemisphere (midpoint rule in (cos theta, phi), 1500 x 600 cells, with
/// the model above): within 5 standard errors of the samples plus 2e-4 for the quadrature.
#[test]
fn principled_albedo_matches_the_models_integral() {
    for (n, p) in CASES.iter().enumerate() {
        let cos_o = 0.6;
        let setup = Setup::new(material(p), cos_o);
        let samples = setup.samples(77, 1 << 18);
        assert_albedo_matches(
            &format!("case {n}"),
            &samples,
            setup.ns,
            &[1.0],
            (1500, 600),
            2e-4,
            |wi| principled_f(p, setup.ns, setup.wo, wi),
        );
    }
}

/// The keys: Mitsuba's defaults and specular -> eta mapping (specular 0.5 is eta 1.5); `ior` instead;
/// both refused; weights out of [0, 1], a roughness per axis and another type's key refused by name.
#[test]
fn principled_keys_are_checked() {
    let m = material_from_toml("{ type = \"principled\" }");
    assert_eq!(m.albedo, [0.5; 3]);
    assert_eq!((m.alpha_x, m.alpha_y, m.metallic), (0.25, 0.25, 0.0));
    assert!((m.ior - 1.5).abs() < 1e-6, "{}", m.ior);
    assert_eq!(
        material_from_toml("{ type = \"principled\", ior = 1.33 }").ior,
        1.33
    );
    let aniso = material_from_toml("{ type = \"principled\", roughness = 0.5, anisotropic = 0.5 }");
    let aspect = (1.0f32 - 0.45).sqrt();
    assert!(
        (aniso.alpha_x - 0.25 / aspect).abs() < 1e-6
            && (aniso.alpha_y - 0.25 * aspect).abs() < 1e-6
    );
    let load = material_error;
    for (spec, key) in [
        (
            "{ type = \"principled\", specular = 0.5, ior = 1.5 }",
            "materials.m.specular",
        ),
        (
            "{ type = \"principled\", sheen = 1.5 }",
            "materials.m.sheen",
        ),
        (
            "{ type = \"principled\", clearcoat = -0.1 }",
            "materials.m.clearcoat",
        ),
        (
            "{ type = \"principled\", roughness = [0.1, 0.5] }",
            "materials.m.roughness",
        ),
        (
            "{ type = \"principled\", albedo = [0.5, 0.5, 0.5] }",
            "materials.m.albedo",
        ),
        (
            "{ type = \"principled\", base_color = [1.5, 0.5, 0.5] }",
            "materials.m.base_color",
        ),
    ] {
        let e = load(spec);
        assert!(e.contains(key) && e.contains("line"), "{spec}: {e}");
    }
}
