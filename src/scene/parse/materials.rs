//! `[materials]`: the keys each material type takes and the material it becomes (a material plugin's by
//! `plugins.rs`), a conductor's Fresnel, and the surface modifiers that any material takes.

use super::error::SceneError;
use super::params::in_unit_range;
use super::raw::{RawMaterial, RawParam, RawVec3};
use super::{Checker, Files};
use crate::scene::bsdfs;
use crate::scene::texture::{MaterialTextures, TextureRef};
use crate::scene::{
    Bsdf, CONDUCTOR_PRESETS, ConductorFresnel, Emission, GltfLayers, Material, Roughness,
};
use glam::Vec3;
use toml::Spanned;

/// A plastic's coat when `ior` is not given: near polypropylene's 1.49 (Mitsuba's `plastic` default) and
/// the 1.5 of glTF's dielectrics.
const PLASTIC_DEFAULT_IOR: f32 = 1.5;

/// The keys a material type allows besides the modifiers, and the BSDF it reads.
type Keyed = (Vec<&'static str>, Bsdf);

/// What every type but `emitter` may add: emission.
const EMISSION: [&str; 2] = ["emission", "two_sided_emission"];

/// What every type takes: the surface modifiers.
const MODIFIERS: [&str; 8] = [
    "opacity",
    "alpha_cutoff",
    "bump",
    "normal_map",
    "one_sided",
    "back",
    "blend",
    "blend_weight",
];

impl Checker<'_> {
    /// Material `name` of `[materials]`: its type's BSDF (a built-in type's own reader below, a
    /// plugin's by `plugins.rs`), with the keys it allows checked, its emission and its modifiers.
    pub(super) fn material(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
    ) -> Result<Material, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let kind = m.kind.get_ref().as_str();
        let mut textures = MaterialTextures::default();
        // Each type allows only some of the optional keys; a key for another type is treated like any
        // unknown key rather than silently ignored. Every type but `emitter` may also emit; every type
        // takes the surface modifiers.
        let (allowed, bsdf): (Vec<&str>, _) = match kind {
            "diffuse" => {
                let albedo = self.required(
                    &m.albedo,
                    raw,
                    &key("albedo"),
                    "a diffuse material needs an albedo",
                )?;
                let albedo = self.color_param(
                    albedo,
                    &key("albedo"),
                    |a| !in_unit_range(a),
                    "every albedo component must be in [0, 1]",
                    "Albedo is the fraction of light reflected per channel; energy conservation needs it in [0, 1].",
                    files,
                    &mut textures.albedo,
                )?;
                (
                    vec!["albedo", EMISSION[0], EMISSION[1]],
                    Bsdf::Diffuse { albedo },
                )
            }
            "mirror" => {
                let tint = match &m.tint {
                    None => Vec3::ONE,
                    Some(t) => self.color_param(
                        t,
                        &key("tint"),
                        |t| !in_unit_range(t),
                        "every tint component must be in [0, 1]",
                        "The tint scales reflected light per channel; leave it out for a perfect white mirror.",
                        files,
                        &mut textures.albedo,
                    )?,
                };
                (
                    vec!["tint", EMISSION[0], EMISSION[1]],
                    Bsdf::Mirror { tint },
                )
            }
            "dielectric" => {
                let ior = self.required(
                    &m.ior,
                    raw,
                    &key("ior"),
                    "a dielectric material needs an ior",
                )?;
                let ior = self.ior(ior, &key("ior"))?;
                let roughness =
                    self.microfacet_roughness(name, m, files, &mut textures.roughness)?;
                (
                    vec!["ior", "roughness", "distribution", EMISSION[0], EMISSION[1]],
                    Bsdf::Dielectric { ior, roughness },
                )
            }
            "conductor" => self.conductor_material(name, raw, files, &mut textures)?,
            "plastic" => self.plastic_material(name, raw, files, &mut textures)?,
            "metallic_roughness" => {
                self.metallic_roughness_material(name, raw, files, &mut textures)?
            }
            "principled" => self.principled(name, m, files, &mut textures)?,
            "emitter" => (vec!["radiance", "two_sided"], Bsdf::Black),
            "thin_dielectric" => {
                let ior = match &m.ior {
                    Some(ior) => self.ior(ior, &key("ior"))?,
                    None => 1.5,
                };
                (
                    vec!["ior", EMISSION[0], EMISSION[1]],
                    Bsdf::ThinDielectric { ior },
                )
            }
            other if bsdfs::by_toml_type(other).is_some() => {
                let (kind, plugin) = bsdfs::by_toml_type(other).expect("matched");
                self.plugin_material(kind, plugin, name, raw, files, &mut textures)?
            }
            other => return Err(self.unknown_material_type(name, m, other)),
        };
        self.reject_foreign_material_keys(name, m, &allowed)?;
        let emission = self.material_emission(
            name,
            raw,
            bsdf == Bsdf::Black,
            files,
            &mut textures.emission,
        )?;
        self.modifiers(name, m, files, &mut textures)?;
        Ok(Material {
            bsdf,
            emission,
            textures,
        })
    }

    /// Refuses a key the material's type does not take (`allowed`, and the modifiers), as any unknown
    /// key: a built-in type's key on another type, a plugin's key on another, or a mistake.
    fn reject_foreign_material_keys(
        &self,
        name: &str,
        m: &RawMaterial,
        allowed: &[&str],
    ) -> Result<(), SceneError> {
        let kind = m.kind.get_ref().as_str();
        let present = [
            ("albedo", m.albedo.as_ref().map(Spanned::span)),
            ("tint", m.tint.as_ref().map(Spanned::span)),
            ("ior", m.ior.as_ref().map(Spanned::span)),
            ("nonlinear", m.nonlinear.as_ref().map(Spanned::span)),
            ("distribution", m.distribution.as_ref().map(Spanned::span)),
            ("preset", m.preset.as_ref().map(Spanned::span)),
            ("eta", m.eta.as_ref().map(Spanned::span)),
            ("k", m.k.as_ref().map(Spanned::span)),
            ("base_color", m.base_color.as_ref().map(Spanned::span)),
            ("roughness", m.roughness.as_ref().map(Spanned::span)),
            ("metallic", m.metallic.as_ref().map(Spanned::span)),
            ("specular", m.specular.as_ref().map(Spanned::span)),
            ("spec_tint", m.spec_tint.as_ref().map(Spanned::span)),
            ("anisotropic", m.anisotropic.as_ref().map(Spanned::span)),
            ("sheen", m.sheen.as_ref().map(Spanned::span)),
            ("sheen_tint", m.sheen_tint.as_ref().map(Spanned::span)),
            ("clearcoat", m.clearcoat.as_ref().map(Spanned::span)),
            (
                "clearcoat_gloss",
                m.clearcoat_gloss.as_ref().map(Spanned::span),
            ),
            ("flatness", m.flatness.as_ref().map(Spanned::span)),
            ("radiance", m.radiance.as_ref().map(Spanned::span)),
            ("two_sided", m.two_sided.as_ref().map(Spanned::span)),
            ("emission", m.emission.as_ref().map(Spanned::span)),
            (
                "two_sided_emission",
                m.two_sided_emission.as_ref().map(Spanned::span),
            ),
        ];
        // Keys that are no built-in type's (a plugin's, or a mistake), with their spans from the tree.
        let others = self.material_keys(name);
        let present: Vec<(&str, Option<std::ops::Range<usize>>)> = present
            .into_iter()
            .chain(
                others
                    .iter()
                    .filter(|(k, _)| m.other.contains_key(*k))
                    .map(|(k, v)| (*k, Some(v.span()))),
            )
            .collect();
        let allowed: Vec<&str> = allowed.iter().chain(MODIFIERS.iter()).copied().collect();
        self.reject_foreign_keys(
            &present,
            &allowed,
            &format!("materials.{name}"),
            &format!("a {kind} material"),
        )
    }

    /// What a material emits: an emitter's `radiance` (required), any other's optional `emission`, each
    /// a colour or a texture (recorded in `emission_texture`), and whether both faces emit.
    fn material_emission(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        black: bool,
        files: &mut Files,
        emission_texture: &mut Option<TextureRef>,
    ) -> Result<Option<Emission>, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let radiance = |v: &Spanned<RawParam<RawVec3>>,
                        field: &str,
                        files: &mut Files,
                        slot: &mut Option<TextureRef>| {
            self.color_param(
                v,
                &key(field),
                |r| r.min_element() < 0.0,
                "emitted radiance cannot be negative",
                "Give a linear RGB radiance in W sr^-1 m^-2 with components >= 0.",
                files,
                slot,
            )
        };
        Ok(if black {
            let r = self.required(
                &m.radiance,
                raw,
                &key("radiance"),
                "an emitter material needs a radiance",
            )?;
            Some(Emission {
                radiance: radiance(r, "radiance", files, emission_texture)?,
                two_sided: m.two_sided.as_ref().is_some_and(|t| *t.get_ref()),
            })
        } else {
            match (&m.emission, &m.two_sided_emission) {
                (Some(e), two_sided) => Some(Emission {
                    radiance: radiance(e, "emission", files, emission_texture)?,
                    two_sided: two_sided.as_ref().is_some_and(|t| *t.get_ref()),
                }),
                (None, Some(t)) => {
                    return Err(self.error(
                        t.span(),
                        &key("two_sided_emission"),
                        "two_sided_emission is given but the material has no emission",
                        "Give `emission = [r, g, b]` (its radiance) as well, or remove two_sided_emission.",
                    ));
                }
                (None, None) => None,
            }
        })
    }

    /// A microfacet material's `roughness` (one number, [u, v] or a texture, recorded in `slot`) and
    /// its `distribution` (GGX or Beckmann): dielectric, conductor and plastic.
    fn microfacet_roughness(
        &self,
        name: &str,
        m: &RawMaterial,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Roughness, SceneError> {
        let key = |field: &str| format!("materials.{name}.{field}");
        let r = self.roughness(&m.roughness, &key("roughness"), files, slot)?;
        self.distribution(&m.distribution, &key("distribution"), r)
    }

    /// A `conductor`: its Fresnel (a preset, eta and k, or a base colour), roughness and tint.
    fn conductor_material(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<Keyed, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let fresnel = self.conductor_fresnel(name, raw, files, &mut textures.albedo)?;
        // The tint multiplies the Fresnel reflectance (Mitsuba's specular_reflectance). A
        // textured tint is the albedo slot, which a Schlick conductor's base colour holds.
        let tint = match &m.tint {
            None => Vec3::ONE,
            Some(t) => {
                let schlick = matches!(fresnel, ConductorFresnel::Schlick { .. });
                if schlick && matches!(t.get_ref(), RawParam::Texture(_)) {
                    return Err(self.error(
                        t.span(),
                        &key("tint"),
                        "a conductor with base_color cannot also have a textured tint",
                        "Give the tint as a constant [r, g, b], or texture the base_color instead                                  (the tint multiplies it).",
                    ));
                }
                self.unit_color(t, &key("tint"), files, &mut textures.albedo)?
            }
        };
        Ok((
            vec![
                "preset",
                "eta",
                "k",
                "base_color",
                "roughness",
                "distribution",
                "tint",
                EMISSION[0],
                EMISSION[1],
            ],
            Bsdf::Conductor {
                fresnel,
                roughness: self.microfacet_roughness(name, m, files, &mut textures.roughness)?,
                tint,
            },
        ))
    }

    /// A `plastic`: a diffuse base under a dielectric coat.
    fn plastic_material(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<Keyed, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let albedo = self.required(
            &m.albedo,
            raw,
            &key("albedo"),
            "a plastic material needs an albedo (the colour of its diffuse base)",
        )?;
        let albedo = self.unit_color(albedo, &key("albedo"), files, &mut textures.albedo)?;
        let ior = match &m.ior {
            Some(ior) => self.ior(ior, &key("ior"))?,
            None => PLASTIC_DEFAULT_IOR,
        };
        let roughness = self.microfacet_roughness(name, m, files, &mut textures.roughness)?;
        let nonlinear = m.nonlinear.as_ref().is_none_or(|n| *n.get_ref());
        Ok((
            vec![
                "albedo",
                "ior",
                "roughness",
                "distribution",
                "nonlinear",
                EMISSION[0],
                EMISSION[1],
            ],
            Bsdf::Plastic {
                albedo,
                ior,
                roughness,
                nonlinear,
            },
        ))
    }

    /// glTF's `metallic_roughness`, with the Khronos extensions' layers.
    fn metallic_roughness_material(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<Keyed, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let base_color = match &m.base_color {
            Some(c) => self.unit_color(c, &key("base_color"), files, &mut textures.albedo)?,
            None => Vec3::ONE,
        };
        // glTF's defaults: metallic 1, roughness 1.
        let (metallic, roughness) =
            self.metallic_and_roughness(name, m, files, textures, (1.0, 1.0))?;
        Ok((
            vec![
                "base_color",
                "metallic",
                "roughness",
                "ior",
                "specular",
                "specular_color",
                "transmission",
                "volume",
                "attenuation_color",
                "attenuation_distance",
                "clearcoat",
                "clearcoat_roughness",
                "sheen_color",
                "sheen_roughness",
                EMISSION[0],
                EMISSION[1],
            ],
            Bsdf::MetallicRoughness {
                base_color,
                metallic,
                roughness,
                layers: self.gltf_layers(name, m)?,
            },
        ))
    }

    /// The error for a `type` vkpath does not read, listing those it does.
    fn unknown_material_type(&self, name: &str, m: &RawMaterial, other: &str) -> SceneError {
        let key = |field: &str| format!("materials.{name}.{field}");
        let registered: Vec<String> = crate::materials::PLUGINS
            .iter()
            .map(|p| format!("\"{}\"", p.name))
            .collect();
        self.error(
            m.kind.span(),
            &key("type"),
            format!("unknown material type \"{other}\""),
            format!(
                "Use \"diffuse\" (with albedo), \"mirror\" (optional tint), \"dielectric\" (with ior), \
                 \"thin_dielectric\" (optional ior), \
                 \"conductor\" (with preset, eta and k, or base_color), \"plastic\" (with albedo), \
                 \"metallic_roughness\", \"principled\", \"emitter\" (with radiance), or {} (see docs/scene-format.md).",
                registered.join(", ")
            ),
        )
    }

    /// The surface modifiers any material takes: `opacity` (a number in [0, 1] or a texture),
    /// `alpha_cutoff` (in [0, 1]: a cut-out), `bump` and `normal_map` (texture tables whose `scale` is a
    /// number: height in scene units per unit of texel, and the factor of the normal's x and y).
    fn modifiers(
        &self,
        name: &str,
        m: &RawMaterial,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<(), SceneError> {
        let key = |field: &str| format!("materials.{name}.{field}");
        if let Some(o) = &m.opacity {
            textures.opacity_value = self.scalar_param(
                o,
                &key("opacity"),
                |x| !(0.0..=1.0).contains(&x),
                "opacity must be in [0, 1]",
                "Opacity is the fraction of light the surface stops: 1 is opaque (the default), 0 invisible.",
                files,
                &mut textures.opacity,
            )?;
        }
        textures.one_sided = m.one_sided.as_ref().is_some_and(|o| *o.get_ref());
        if let Some(w) = &m.blend_weight {
            if m.blend.is_none() {
                return Err(self.error(
                    w.span(),
                    &key("blend_weight"),
                    "blend_weight is the weight of a blend material, and the material names none",
                    "Give `blend = \"name\"` too, or remove blend_weight.",
                ));
            }
            textures.blend_weight = self.scalar_param(
                w,
                &key("blend_weight"),
                |x| !(0.0..=1.0).contains(&x),
                "blend_weight must be in [0, 1]",
                "It is the fraction of hits that show the blend material (Mitsuba's blendbsdf weight).",
                files,
                &mut textures.blend_weight_texture,
            )?;
        }
        if let Some(c) = &m.alpha_cutoff {
            textures.alpha_cutoff = Some(self.number_unless(
                c,
                &key("alpha_cutoff"),
                |x| !(0.0..=1.0).contains(&x),
                "alpha_cutoff must be in [0, 1]",
                "Opacity below the cutoff is a hole, at or above it solid (glTF's alphaMode MASK; 0.5 is its default).",
            )?);
        }
        for (field, raw, slot) in [
            ("bump", &m.bump, &mut textures.bump),
            ("normal_map", &m.normal_map, &mut textures.normal_map),
        ] {
            let Some(raw) = raw else { continue };
            let t = &raw.get_ref().0;
            let (mut r, scale) =
                self.texture_ref(t, raw.span(), &key(field), false, true, files)?;
            // A normal map is a vector: all three channels (a height map, like a scalar, reads "r").
            if field == "normal_map" && t.channel.is_none() {
                r.channel = crate::scene::texture::Channel::Rgb;
            }
            *slot = Some((r, scale.unwrap_or(1.0)));
        }
        Ok(())
    }

    /// A conductor's Fresnel: exactly one of `preset`, `eta` with `k`, or `base_color`.
    fn conductor_fresnel(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<ConductorFresnel, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let names: Vec<String> = CONDUCTOR_PRESETS
            .iter()
            .map(|(n, _, _)| format!("\"{n}\""))
            .collect();
        let how = format!(
            "Give `preset` ({}), or `eta = [r, g, b]` with `k = [r, g, b]` (the complex index of \
             refraction), or `base_color = [r, g, b]` (Schlick's reflectance at normal incidence).",
            names.join(", ")
        );
        match (&m.preset, &m.eta, &m.k, &m.base_color) {
            (Some(p), None, None, None) => {
                let wanted = p.get_ref().as_str();
                match CONDUCTOR_PRESETS.iter().find(|(n, _, _)| *n == wanted) {
                    Some((_, eta, k)) => Ok(ConductorFresnel::Complex {
                        eta: Vec3::from_array(*eta),
                        k: Vec3::from_array(*k),
                    }),
                    None => Err(self.error(
                        p.span(),
                        &key("preset"),
                        format!("unknown conductor preset \"{wanted}\""),
                        format!("The presets are {}.", names.join(", ")),
                    )),
                }
            }
            (None, Some(eta), Some(k), None) => {
                let eta = self.vec3_unless(
                    eta,
                    &key("eta"),
                    |e| e.min_element() <= 0.0,
                    "every eta component must be > 0",
                    "eta is the real part of the metal's complex index of refraction (gold: about [0.14, 0.37, 1.44]).",
                )?;
                let k = self.vec3_unless(
                    k,
                    &key("k"),
                    |k| k.min_element() < 0.0,
                    "every k component must be >= 0",
                    "k is the extinction coefficient, the imaginary part of the complex index of refraction (gold: about [3.98, 2.39, 1.60]).",
                )?;
                Ok(ConductorFresnel::Complex { eta, k })
            }
            (None, None, None, Some(c)) => Ok(ConductorFresnel::Schlick {
                f0: self.unit_color(c, &key("base_color"), files, slot)?,
            }),
            (None, Some(_), None, None) => Err(self.error(
                m.eta.as_ref().map_or(0..0, Spanned::span),
                &key("eta"),
                "eta is given without k",
                how,
            )),
            (None, None, Some(_), None) => Err(self.error(
                m.k.as_ref().map_or(0..0, Spanned::span),
                &key("k"),
                "k is given without eta",
                how,
            )),
            (None, None, None, None) => Err(self.error(
                raw.span(),
                &format!("materials.{name}"),
                "a conductor material needs a preset, eta and k, or a base_color",
                how,
            )),
            _ => {
                // Two ways at once: point at the second one given.
                let spans = [
                    ("preset", m.preset.as_ref().map(Spanned::span)),
                    ("eta", m.eta.as_ref().map(Spanned::span)),
                    ("base_color", m.base_color.as_ref().map(Spanned::span)),
                ];
                let mut given = spans.iter().filter_map(|(n, s)| s.clone().map(|s| (*n, s)));
                let first = given.next().map_or("preset", |(n, _)| n);
                let (second, span) = given.next().unwrap_or(("k", raw.span()));
                Err(self.error(
                    span,
                    &key(second),
                    format!("a conductor takes one of preset, eta and k, or base_color, but {first} and {second} are both given"),
                    how,
                ))
            }
        }
    }
}

impl Checker<'_> {
    /// The `metallic` (in [0, 1], or a texture) and the isotropic `roughness` (one number in [0, 1], or
    /// a texture) of a metallic_roughness or principled material, with the type's `defaults`.
    fn metallic_and_roughness(
        &self,
        name: &str,
        m: &RawMaterial,
        files: &mut Files,
        textures: &mut MaterialTextures,
        defaults: (f32, f32),
    ) -> Result<(f32, f32), SceneError> {
        let key = |field: &str| format!("materials.{name}.{field}");
        let metallic = match &m.metallic {
            Some(v) => self.scalar_param(
                v,
                &key("metallic"),
                |x| !(0.0..=1.0).contains(&x),
                "metallic must be in [0, 1]",
                "0 is a dielectric (plastic-like), 1 a metal.",
                files,
                &mut textures.metallic,
            )?,
            None => defaults.0,
        };
        let roughness = match &m.roughness {
            None => defaults.1,
            Some(r) => match self.roughness(
                &m.roughness,
                &key("roughness"),
                files,
                &mut textures.roughness,
            )? {
                Roughness { u, v, .. } if u == v => u,
                _ => {
                    return Err(self.error(
                        r.span(),
                        &key("roughness"),
                        format!("a {} material's roughness is one number", m.kind.get_ref()),
                        "The model is isotropic (principled: its anisotropy is `anisotropic`); give one number in [0, 1].",
                    ));
                }
            },
        };
        Ok((metallic, roughness))
    }

    /// The Khronos PBR extensions' layers of a `metallic_roughness` material (`scene::GltfLayers`), each
    /// key with its extension's default and range: `ior` (> 0, 1.5), `specular` (in [0, 1], 1),
    /// `specular_color` (>= 0, white), `transmission` ([0, 1], 0), `volume` (false: a thin surface),
    /// `attenuation_color` (in (0, 1], white) and `attenuation_distance` (> 0, infinite; both need
    /// `volume`), `clearcoat` and `clearcoat_roughness` ([0, 1], 0), `sheen_color` ([0, 1], black) and
    /// `sheen_roughness` ([0, 1], 0).
    fn gltf_layers(&self, name: &str, m: &RawMaterial) -> Result<GltfLayers, SceneError> {
        let key = |field: &str| format!("materials.{name}.{field}");
        let unit = |v: &Option<Spanned<f32>>, field: &str, default: f32| {
            self.optional_unit(
                v,
                &key(field),
                default,
                "The glTF extensions' factors run from 0 to 1 (docs/scene-format.md, metallic_roughness).",
            )
        };
        let color = |v: &Option<Spanned<RawVec3>>,
                     field: &str,
                     default: Vec3,
                     bad: fn(f32) -> bool,
                     rule: &str| {
            match v {
            None => Ok(default),
            Some(c) => self.vec3_unless(
                c,
                &key(field),
                |c| c.to_array().into_iter().any(bad),
                &format!("every component of {field} must be {rule}"),
                "The glTF extensions' colours are linear RGB (docs/scene-format.md, metallic_roughness).",
            ),
        }
        };
        let mut layers = GltfLayers::NONE;
        if let Some(ior) = &m.ior {
            layers.ior = self.ior(ior, &key("ior"))?;
        }
        layers.specular = unit(&m.specular, "specular", 1.0)?;
        layers.specular_color = color(
            &m.specular_color,
            "specular_color",
            Vec3::ONE,
            |x| x < 0.0,
            ">= 0",
        )?;
        layers.transmission = unit(&m.transmission, "transmission", 0.0)?;
        layers.clearcoat = unit(&m.clearcoat, "clearcoat", 0.0)?;
        layers.clearcoat_roughness = unit(&m.clearcoat_roughness, "clearcoat_roughness", 0.0)?;
        layers.sheen_color = color(
            &m.sheen_color,
            "sheen_color",
            Vec3::ZERO,
            |x| !(0.0..=1.0).contains(&x),
            "in [0, 1]",
        )?;
        layers.sheen_roughness = unit(&m.sheen_roughness, "sheen_roughness", 0.0)?;
        let volume = m.volume.as_ref().is_some_and(|v| *v.get_ref());
        let attenuation = color(
            &m.attenuation_color,
            "attenuation_color",
            Vec3::ONE,
            |x| !(x > 0.0 && x <= 1.0),
            "in (0, 1]",
        )?;
        let distance = match &m.attenuation_distance {
            None => f32::INFINITY,
            Some(d) => self.number_unless(
                d,
                &key("attenuation_distance"),
                |d| d <= 0.0,
                "attenuation_distance must be > 0",
                "The distance, in scene units, over which white light becomes attenuation_color.",
            )?,
        };
        if !volume {
            for (given, field) in [
                (
                    m.attenuation_color.as_ref().map(|c| c.span()),
                    "attenuation_color",
                ),
                (
                    m.attenuation_distance.as_ref().map(|d| d.span()),
                    "attenuation_distance",
                ),
            ] {
                if let Some(span) = given {
                    return Err(self.error(
                        span,
                        &key(field),
                        format!("{field} without `volume = true`"),
                        "Only a surface that bounds a volume (`volume = true`) has a medium to attenuate light; a thin one has none.",
                    ));
                }
            }
        }
        if volume {
            // sigma_a = -ln(attenuationColor) / attenuationDistance (KHR_materials_volume); an infinite
            // distance absorbs nothing.
            layers.volume = Some(if distance.is_finite() {
                -Vec3::new(attenuation.x.ln(), attenuation.y.ln(), attenuation.z.ln()) / distance
            } else {
                Vec3::ZERO
            });
        }
        Ok(layers)
    }

    /// A `principled` material (Mitsuba 3's, bsdfs/principled.wgsl): its keys and the material. The
    /// defaults are Mitsuba's: base_color 0.5, roughness 0.5, specular 0.5 (eta = 2 / (1 - sqrt(0.08
    /// specular)) - 1, Mitsuba's mapping; or `ior`), every other weight 0.
    fn principled(
        &self,
        name: &str,
        m: &RawMaterial,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<(Vec<&'static str>, Bsdf), SceneError> {
        let key = |field: &str| format!("materials.{name}.{field}");
        let base_color = match &m.base_color {
            Some(c) => self.unit_color(c, &key("base_color"), files, &mut textures.albedo)?,
            None => Vec3::splat(0.5),
        };
        // Mitsuba's defaults: metallic 0, roughness 0.5.
        let (metallic, roughness) =
            self.metallic_and_roughness(name, m, files, textures, (0.0, 0.5))?;
        let weight = |v: &Option<Spanned<f32>>, field: &str, default: f32| {
            self.optional_unit(
                v,
                &key(field),
                default,
                "The principled material's weights run from 0 to 1 (Burley 2012; Mitsuba's principled).",
            )
        };
        let eta = match (&m.specular, &m.ior) {
            (Some(s), Some(_)) => {
                return Err(self.error(
                    s.span(),
                    &key("specular"),
                    "both `specular` and `ior`",
                    "`specular` is another way to give the index (eta = 2 / (1 - sqrt(0.08 specular)) - 1): give one.",
                ));
            }
            (None, Some(ior)) => self.ior(ior, &key("ior"))?,
            (s, None) => {
                let specular = weight(s, "specular", 0.5)?;
                2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
            }
        };
        Ok((
            vec![
                "base_color",
                "roughness",
                "metallic",
                "specular",
                "ior",
                "spec_tint",
                "anisotropic",
                "sheen",
                "sheen_tint",
                "clearcoat",
                "clearcoat_gloss",
                "flatness",
                "emission",
                "two_sided_emission",
            ],
            Bsdf::Principled {
                base_color,
                roughness,
                anisotropic: weight(&m.anisotropic, "anisotropic", 0.0)?,
                metallic,
                eta,
                spec_tint: weight(&m.spec_tint, "spec_tint", 0.0)?,
                sheen: weight(&m.sheen, "sheen", 0.0)?,
                sheen_tint: weight(&m.sheen_tint, "sheen_tint", 0.0)?,
                clearcoat: weight(&m.clearcoat, "clearcoat", 0.0)?,
                clearcoat_gloss: weight(&m.clearcoat_gloss, "clearcoat_gloss", 0.0)?,
                flatness: weight(&m.flatness, "flatness", 0.0)?,
            },
        ))
    }
}
