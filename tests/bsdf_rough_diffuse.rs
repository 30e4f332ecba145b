//! `rough_diffuse` (src/materials/rough_diffuse, Oren & Nayar's qualitative model), a material plugin,
//! tested through the shared adapter (tests/common/bsdf.rs) as the scene file gives it.

mod common;

use common::bsdf::*;
use common::vec::{V3, basis, dot};
use vkpath::kernel::abi::GpuMaterial;

fn rough_diffuse(albedo: f32, roughness: f32) -> GpuMaterial {
    material_from_toml(&format!(
        "{{ type = \"rough_diffuse\", albedo = [{albedo}, {albedo}, {albedo}], roughness = {roughness} }}"
    ))
}

/// Oren & Nayar 1994, eq. 30, in f64 with the angles themselves (theta, phi; not the shader's
/// trigonometry-free form): f = albedo / pi (A + B max(0, cos(phi_i - phi_o)) sin(a) tan(b)),
/// sigma^2 = alpha^2 / 2, alpha = roughness^2.
fn oren_nayar(albedo: f64, roughness: f64, ns: V3, wo: V3, wi: V3) -> f64 {
    let (t, b) = basis(ns);
    let angles = |w: V3| {
        (
            dot(w, ns).clamp(-1.0, 1.0).acos(),
            dot(w, b).atan2(dot(w, t)),
        )
    };
    let ((theta_o, phi_o), (theta_i, phi_i)) = (angles(wo), angles(wi));
    if dot(wo, ns) <= 0.0 || dot(wi, ns) <= 0.0 {
        return 0.0;
    }
    let alpha = roughness * roughness;
    let s2 = alpha * alpha / 2.0;
    let a = 1.0 - s2 / (2.0 * (s2 + 0.33));
    let bb = 0.45 * s2 / (s2 + 0.09);
    let (big, small) = (theta_i.max(theta_o), theta_i.min(theta_o));
    albedo / std::f64::consts::PI
        * (a + bb * (phi_i - phi_o).cos().max(0.0) * big.sin() * small.tan())
}

#[test]
fn rough_diffuse_sampler_matches_its_own_pdf() {
    let mut seed = 300;
    for r in [0.3f32, 1.0] {
        for cos_o in [0.9, 0.3, 0.05] {
            let setup = Setup::new(rough_diffuse(0.8, r), cos_o);
            let bins = Bins::polar(setup.ns, 32, 32);
            chi2_sampler(
                &format!("rough_diffuse r {r}, cos_o {cos_o}"),
                &setup,
                &bins,
                seed,
            );
            seed += 1;
        }
    }
}

#[test]
fn rough_diffuse_is_consistent_reciprocal_and_one_sided() {
    for r in [0.0f32, 0.5, 1.0] {
        let what = format!("rough_diffuse r {r}");
        assert_sample_eval_pdf_agree(&what, rough_diffuse(0.7, r));
        assert_reciprocal_and_one_sided_at_the_horizon(&what, rough_diffuse(0.7, r));
    }
}

/// f against the f64 reference over a spread of directions, within 1e-4 relative (f32 rounding); at
/// roughness 0 the reference is Lambert's albedo / pi.
#[test]
fn rough_diffuse_matches_oren_nayar_in_f64() {
    for r in [0.0f64, 0.4, 0.8, 1.0] {
        for cos_o in [0.95, 0.5, 0.1] {
            let setup = Setup::new(rough_diffuse(0.6, r as f32), cos_o);
            let what = format!("r {r}, cos_o {cos_o}");
            assert_eval_matches(&what, &setup, 1e-4, |wi| {
                [oren_nayar(0.6, r, setup.ns, setup.wo, wi); 3]
            });
        }
    }
}

/// The generic reader's checks name the file's key: a missing albedo, an albedo out of range, and a
/// roughness given per axis.
#[test]
fn rough_diffuse_keys_are_checked() {
    let load = material_error;
    let missing = load("{ type = \"rough_diffuse\", roughness = 0.5 }");
    assert!(
        missing.contains("materials.m.albedo") && missing.contains("missing"),
        "{missing}"
    );
    let bright = load("{ type = \"rough_diffuse\", albedo = [1.2, 0.5, 0.5] }");
    assert!(
        bright.contains("materials.m.albedo") && bright.contains("[0, 1]"),
        "{bright}"
    );
    let anisotropic =
        load("{ type = \"rough_diffuse\", albedo = [0.5, 0.5, 0.5], roughness = [0.1, 0.5] }");
    assert!(
        anisotropic.contains("materials.m.roughness") && anisotropic.contains("number in [0, 1]"),
        "{anisotropic}"
    );
    let foreign = load("{ type = \"rough_diffuse\", albedo = [0.5, 0.5, 0.5], ior = 1.5 }");
    assert!(foreign.contains("materials.m.ior"), "{foreign}");
    // The default roughness, 0.5, is in the block (the shader squares it).
    let m = material_from_toml("{ type = \"rough_diffuse\", albedo = [0.5, 0.5, 0.5] }");
    let plugin = vkpath::materials::by_name("rough_diffuse").unwrap();
    assert_eq!(
        plugin.unpack(&m.block),
        [
            vkpath::materials::Value::Color([0.5; 3]),
            vkpath::materials::Value::Float(0.5)
        ]
    );
}
