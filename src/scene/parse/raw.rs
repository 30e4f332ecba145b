//! Step 2: the file as serde sees it. The `Raw*` types mirror the file one to one; every value is
//! [`Spanned`], so that the checker still knows where it came from.

use serde::Deserialize;
use serde::de::{Deserializer, Visitor};
use std::collections::BTreeMap;
use std::fmt;
use toml::Spanned;

/// The whole file. Table names are singular (`[[sphere]]`) because each array-of-tables entry is one
/// object.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) camera: Spanned<RawCamera>,
    pub(super) image: Option<RawImage>,
    pub(super) render: Option<RawRender>,
    /// A BTreeMap iterates in name order; the key spans let us restore the order of the file.
    #[serde(default)]
    pub(super) materials: BTreeMap<Spanned<String>, Spanned<RawMaterial>>,
    #[serde(default)]
    pub(super) sphere: Vec<Spanned<RawSphere>>,
    #[serde(default)]
    pub(super) triangle: Vec<Spanned<RawTriangle>>,
    #[serde(default)]
    pub(super) mesh: Vec<Spanned<RawMesh>>,
    #[serde(default)]
    pub(super) instance: Vec<Spanned<RawInstance>>,
    #[serde(default)]
    pub(super) light: Vec<Spanned<RawLight>>,
    pub(super) environment: Option<Spanned<RawEnvironment>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEnvironment {
    pub(super) radiance: Option<Spanned<RawVec3>>,
    pub(super) map: Option<Spanned<String>>,
    pub(super) rotate: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    #[serde(rename = "type")]
    pub(super) kind: Option<Spanned<String>>,
    pub(super) position: Spanned<RawVec3>,
    pub(super) look_at: Spanned<RawVec3>,
    pub(super) up: Option<Spanned<RawVec3>>,
    pub(super) fov: Option<Spanned<f32>>,
    pub(super) extent: Option<Spanned<f32>>,
    pub(super) aperture: Option<Spanned<f32>>,
    pub(super) focus_distance: Option<Spanned<f32>>,
}

/// Integers are read as `i64` (TOML's integer type) so that a negative or huge value gets a message
/// about its allowed range rather than serde's "expected u32".
#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawImage {
    pub(super) width: Option<Spanned<i64>>,
    pub(super) height: Option<Spanned<i64>>,
    pub(super) exposure: Option<Spanned<f32>>,
    pub(super) gamma: Option<Spanned<RawGamma>>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    pub(super) samples: Option<Spanned<i64>>,
    pub(super) max_bounces: Option<Spanned<i64>>,
    pub(super) seed: Option<Spanned<i64>>,
    pub(super) filter: Option<Spanned<String>>,
    pub(super) filter_sigma: Option<Spanned<f32>>,
    pub(super) filter_radius: Option<Spanned<f32>>,
    pub(super) sample_border: Option<Spanned<bool>>,
    pub(super) splat: Option<Spanned<bool>>,
    pub(super) adaptive: Option<Spanned<bool>>,
    pub(super) adaptive_threshold: Option<Spanned<f32>>,
    pub(super) adaptive_min_samples: Option<Spanned<i64>>,
    pub(super) background: Option<Spanned<RawVec3>>,
    pub(super) sampler: Option<Spanned<String>>,
    pub(super) light_sampling: Option<Spanned<String>>,
    pub(super) tonemap: Option<Spanned<String>>,
    pub(super) clamp: Option<Spanned<f32>>,
    pub(super) denoise: Option<Spanned<bool>>,
}

/// One flat struct for every material type rather than a serde-tagged enum (one serde type per kind): a
/// tagged enum buffers its content, which loses the spans (toml's `Spanned` inside an internally tagged
/// enum fails to deserialize at all: toml-rs/toml#535), and its "unknown variant" error would point at
/// the whole material rather than at `type`. Which keys a type allows is checked by hand in
/// `Checker::material`, for every key: the keys of the built-in types are fields here; any other key
/// (a material plugin's, or a mistake) lands in `other`, and the checker reads it, with its span, from
/// the TOML tree (`Checker::material_keys`): serde's `flatten` buffers what it collects, which would lose
/// the spans.
#[derive(Deserialize)]
pub(super) struct RawMaterial {
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) albedo: Option<Spanned<RawParam<RawVec3>>>,
    pub(super) tint: Option<Spanned<RawParam<RawVec3>>>,
    pub(super) ior: Option<Spanned<f32>>,
    /// `plastic`: whether the base's internal reflections are tinted by its albedo (Mitsuba's
    /// `nonlinear`).
    pub(super) nonlinear: Option<Spanned<bool>>,
    /// The microfacet materials: "ggx" (default) or "beckmann".
    pub(super) distribution: Option<Spanned<String>>,
    /// `conductor`: a named metal, or its complex index of refraction, or a base colour (Schlick).
    pub(super) preset: Option<Spanned<String>>,
    pub(super) eta: Option<Spanned<RawVec3>>,
    pub(super) k: Option<Spanned<RawVec3>>,
    pub(super) base_color: Option<Spanned<RawParam<RawVec3>>>,
    /// The glossy types: perceptual roughness, one number or [along u, along v], or a texture.
    pub(super) roughness: Option<Spanned<RawRoughness>>,
    /// `metallic_roughness`, `principled`.
    pub(super) metallic: Option<Spanned<RawParam<f32>>>,
    /// `principled` (Mitsuba 3's): its weights in [0, 1] (`specular` or `ior`, not both).
    pub(super) specular: Option<Spanned<f32>>,
    pub(super) spec_tint: Option<Spanned<f32>>,
    pub(super) anisotropic: Option<Spanned<f32>>,
    pub(super) sheen: Option<Spanned<f32>>,
    pub(super) sheen_tint: Option<Spanned<f32>>,
    pub(super) clearcoat: Option<Spanned<f32>>,
    pub(super) clearcoat_gloss: Option<Spanned<f32>>,
    pub(super) flatness: Option<Spanned<f32>>,
    /// `metallic_roughness`: the Khronos PBR extensions' layers (also `ior`, `specular`, `clearcoat`).
    pub(super) specular_color: Option<Spanned<RawVec3>>,
    pub(super) transmission: Option<Spanned<f32>>,
    pub(super) volume: Option<Spanned<bool>>,
    pub(super) attenuation_color: Option<Spanned<RawVec3>>,
    pub(super) attenuation_distance: Option<Spanned<f32>>,
    pub(super) clearcoat_roughness: Option<Spanned<f32>>,
    pub(super) sheen_color: Option<Spanned<RawVec3>>,
    pub(super) sheen_roughness: Option<Spanned<f32>>,
    /// `emitter`: its radiance, and whether both faces emit.
    pub(super) radiance: Option<Spanned<RawParam<RawVec3>>>,
    pub(super) two_sided: Option<Spanned<bool>>,
    /// Any other type: what it emits besides scattering.
    pub(super) emission: Option<Spanned<RawParam<RawVec3>>>,
    pub(super) two_sided_emission: Option<Spanned<bool>>,
    /// Any type: the surface modifiers.
    pub(super) opacity: Option<Spanned<RawParam<f32>>>,
    pub(super) alpha_cutoff: Option<Spanned<f32>>,
    pub(super) bump: Option<Spanned<RawModifier>>,
    pub(super) normal_map: Option<Spanned<RawModifier>>,
    pub(super) one_sided: Option<Spanned<bool>>,
    /// The name of the material the back face shows.
    pub(super) back: Option<Spanned<String>>,
    /// The name of the material a hit shows instead with probability `blend_weight`.
    pub(super) blend: Option<Spanned<String>>,
    pub(super) blend_weight: Option<Spanned<RawParam<f32>>>,
    /// Every other key (only its name is kept here).
    #[serde(flatten)]
    pub(super) other: BTreeMap<String, serde::de::IgnoredAny>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSphere {
    pub(super) center: Spanned<RawVec3>,
    pub(super) radius: Spanned<f32>,
    pub(super) material: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTriangle {
    pub(super) vertices: Spanned<Vec<Spanned<RawVec3>>>,
    pub(super) material: Spanned<String>,
    /// Optional texture coordinates of the three vertices (a textured material reads them).
    pub(super) uv: Option<Spanned<Vec<RawVec2>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMesh {
    pub(super) obj: Spanned<String>,
    /// Optional: a name `[[instance]]` tables refer to.
    pub(super) name: Option<Spanned<String>>,
    /// A row-major 4 x 4 affine transform, instead of scale / rotate / translate.
    pub(super) matrix: Option<Spanned<RawMatrix>>,
    /// Optional when the OBJ has MTL materials (they are used then).
    pub(super) material: Option<Spanned<String>>,
    pub(super) scale: Option<Spanned<f32>>,
    pub(super) rotate: Option<Spanned<RawVec3>>,
    pub(super) translate: Option<Spanned<RawVec3>>,
    pub(super) smooth: Option<Spanned<bool>>,
    pub(super) texture: Option<Spanned<String>>,
    /// sRGB colour multiplying the material's emission (instead of `texture`).
    pub(super) emission_texture: Option<Spanned<String>>,
    /// Linear data, glTF's layout: B multiplies metallic, G roughness (a metallic_roughness material).
    pub(super) metallic_roughness_texture: Option<Spanned<String>>,
    /// A tangent-space normal map (linear data), and the factor of its x and y (default 1).
    pub(super) normal_map: Option<Spanned<String>>,
    pub(super) normal_scale: Option<Spanned<f32>>,
    /// Which mesh of a Mitsuba `.serialized` file (from 0; default 0).
    pub(super) shape_index: Option<Spanned<u32>>,
}

/// `[[instance]]`: a named `[[mesh]]` placed once more, by its own transform, optionally in another
/// material.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInstance {
    pub(super) mesh: Spanned<String>,
    pub(super) matrix: Option<Spanned<RawMatrix>>,
    pub(super) scale: Option<Spanned<f32>>,
    pub(super) rotate: Option<Spanned<RawVec3>>,
    pub(super) translate: Option<Spanned<RawVec3>>,
    pub(super) material: Option<Spanned<String>>,
}

/// Flat for the same reason as [`RawMaterial`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) position: Option<Spanned<RawVec3>>,
    pub(super) center: Option<Spanned<RawVec3>>,
    pub(super) radius: Option<Spanned<f32>>,
    pub(super) power: Option<Spanned<f32>>,
    pub(super) color: Option<Spanned<RawVec3>>,
    pub(super) direction: Option<Spanned<RawVec3>>,
    pub(super) irradiance: Option<Spanned<f32>>,
    pub(super) angle: Option<Spanned<f32>>,
    pub(super) look_at: Option<Spanned<RawVec3>>,
    pub(super) intensity: Option<Spanned<f32>>,
    pub(super) cutoff_angle: Option<Spanned<f32>>,
    pub(super) beam_width: Option<Spanned<f32>>,
    /// `spot`: "linear" (Mitsuba's, the default) or "smooth" (glTF's).
    pub(super) falloff: Option<Spanned<String>>,
}

/// A TOML array of exactly three numbers (integers accepted). serde's own `[f32; 3]` silently ignores
/// extra elements, so the length is checked here.
#[derive(Clone, Copy)]
pub(super) struct RawVec3(pub(super) [f32; 3]);

impl<'de> Deserialize<'de> for RawVec3 {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let numbers = Vec::<f32>::deserialize(deserializer)?;
        match <[f32; 3]>::try_from(numbers.as_slice()) {
            Ok(xyz) => Ok(RawVec3(xyz)),
            Err(_) => Err(serde::de::Error::invalid_length(
                numbers.len(),
                &"an array of 3 numbers",
            )),
        }
    }
}

/// A TOML array of exactly 16 numbers: a 4 x 4 matrix, row-major (integers accepted).
#[derive(Clone, Copy)]
pub(super) struct RawMatrix(pub(super) [f64; 16]);

impl<'de> Deserialize<'de> for RawMatrix {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let numbers = Vec::<f64>::deserialize(deserializer)?;
        match <[f64; 16]>::try_from(numbers.as_slice()) {
            Ok(m) => Ok(RawMatrix(m)),
            Err(_) => Err(serde::de::Error::invalid_length(
                numbers.len(),
                &"an array of 16 numbers (a 4 x 4 matrix, row by row)",
            )),
        }
    }
}

/// A texture reference (docs/scene-format.md, "Textured parameters"): an inline table in place of a
/// parameter's constant, or a surface modifier (`bump`, `normal_map`, where `scale` is the modifier's
/// number and the uv scale is `uv_scale`).
#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTextureRef {
    /// The image file; or, instead, `checkerboard`.
    pub(super) texture: Option<Spanned<String>>,
    /// Mitsuba's procedural checkerboard: its two colours (each a number or [r, g, b]).
    pub(super) checkerboard: Option<Spanned<Vec<RawFactor>>>,
    pub(super) channel: Option<Spanned<String>>,
    pub(super) color_space: Option<Spanned<String>>,
    pub(super) filter: Option<Spanned<String>>,
    pub(super) wrap: Option<Spanned<String>>,
    /// The uv scale ([su, sv]); in `bump` and `normal_map` the modifier's scale (a number).
    pub(super) scale: Option<Spanned<RawScale>>,
    pub(super) uv_scale: Option<Spanned<RawVec2>>,
    pub(super) offset: Option<Spanned<RawVec2>>,
    pub(super) rotation: Option<Spanned<f32>>,
    pub(super) factor: Option<Spanned<RawFactor>>,
}

/// A texture reference's `scale`: a uv scale [su, sv], or (bump and normal maps) one number.
#[derive(Clone)]
pub(super) enum RawScale {
    Uv(RawVec2),
    Number(f32),
}

/// A texture reference's `factor`: one number, or a colour [r, g, b].
#[derive(Clone)]
pub(super) enum RawFactor {
    Number(f32),
    Color(RawVec3),
}

/// A parameter that is a constant `T` (a number or an array) or a texture reference (a table).
pub(super) enum RawParam<T> {
    Constant(T),
    Texture(Box<RawTextureRef>),
}

/// Numbers, collected from a TOML array.
fn numbers<'de, A: serde::de::SeqAccess<'de>>(mut seq: A) -> Result<Vec<f32>, A::Error> {
    let mut numbers = Vec::new();
    while let Some(x) = seq.next_element::<f32>()? {
        numbers.push(x);
    }
    Ok(numbers)
}

/// What a visitor of a number-or-array-or-table value does with each form; `expecting` names the forms.
trait Forms: Sized {
    const EXPECTING: &'static str;
    fn number<E: serde::de::Error>(_: f32) -> Result<Self, E> {
        Err(E::custom(format!("expected {}", Self::EXPECTING)))
    }
    fn numbers<E: serde::de::Error>(_: Vec<f32>) -> Result<Self, E> {
        Err(E::custom(format!("expected {}", Self::EXPECTING)))
    }
    fn texture<E: serde::de::Error>(_: RawTextureRef) -> Result<Self, E> {
        Err(E::custom(format!("expected {}", Self::EXPECTING)))
    }
}

struct FormsVisitor<T>(std::marker::PhantomData<T>);

impl<'de, T: Forms> Visitor<'de> for FormsVisitor<T> {
    type Value = T;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(T::EXPECTING)
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<T, E> {
        T::number(v as f32)
    }
    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<T, E> {
        T::number(v as f32)
    }
    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<T, E> {
        T::number(v as f32)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<T, A::Error> {
        T::numbers(numbers(seq)?)
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
        let raw = RawTextureRef::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
        T::texture(raw)
    }
}

/// Deserialize through [`Forms`].
macro_rules! deserialize_forms {
    ($t:ty) => {
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                deserializer.deserialize_any(FormsVisitor::<$t>(std::marker::PhantomData))
            }
        }
    };
}

fn length_error<E: serde::de::Error>(n: usize, what: &'static str) -> E {
    E::invalid_length(n, &what)
}

/// Two numbers ([u, v]).
#[derive(Clone, Copy)]
pub(super) struct RawVec2(pub(super) [f32; 2]);

impl Forms for RawVec2 {
    const EXPECTING: &'static str = "an array of 2 numbers";
    fn numbers<E: serde::de::Error>(v: Vec<f32>) -> Result<Self, E> {
        <[f32; 2]>::try_from(v.as_slice())
            .map(RawVec2)
            .map_err(|_| length_error(v.len(), "an array of 2 numbers"))
    }
}
deserialize_forms!(RawVec2);

impl Forms for RawScale {
    const EXPECTING: &'static str = "a uv scale [su, sv] (or, for bump and normal_map, a number)";
    fn number<E: serde::de::Error>(v: f32) -> Result<Self, E> {
        Ok(RawScale::Number(v))
    }
    fn numbers<E: serde::de::Error>(v: Vec<f32>) -> Result<Self, E> {
        RawVec2::numbers(v).map(RawScale::Uv)
    }
}
deserialize_forms!(RawScale);

impl Forms for RawFactor {
    const EXPECTING: &'static str = "a number or an array of 3 numbers [r, g, b]";
    fn number<E: serde::de::Error>(v: f32) -> Result<Self, E> {
        Ok(RawFactor::Number(v))
    }
    fn numbers<E: serde::de::Error>(v: Vec<f32>) -> Result<Self, E> {
        <[f32; 3]>::try_from(v.as_slice())
            .map(|c| RawFactor::Color(RawVec3(c)))
            .map_err(|_| length_error(v.len(), "an array of 3 numbers"))
    }
}
deserialize_forms!(RawFactor);

impl Forms for RawParam<RawVec3> {
    const EXPECTING: &'static str =
        "an array of 3 numbers [r, g, b] or a texture table { texture = \"file\", ... }";
    fn numbers<E: serde::de::Error>(v: Vec<f32>) -> Result<Self, E> {
        <[f32; 3]>::try_from(v.as_slice())
            .map(|c| RawParam::Constant(RawVec3(c)))
            .map_err(|_| length_error(v.len(), "an array of 3 numbers"))
    }
    fn texture<E: serde::de::Error>(t: RawTextureRef) -> Result<Self, E> {
        Ok(RawParam::Texture(Box::new(t)))
    }
}
deserialize_forms!(RawParam<RawVec3>);

impl Forms for RawParam<f32> {
    const EXPECTING: &'static str = "a number or a texture table { texture = \"file\", ... }";
    fn number<E: serde::de::Error>(v: f32) -> Result<Self, E> {
        Ok(RawParam::Constant(v))
    }
    fn texture<E: serde::de::Error>(t: RawTextureRef) -> Result<Self, E> {
        Ok(RawParam::Texture(Box::new(t)))
    }
}
deserialize_forms!(RawParam<f32>);

impl Forms for RawTextureRef {
    const EXPECTING: &'static str = "a texture table { texture = \"file\", ... }";
    fn texture<E: serde::de::Error>(t: RawTextureRef) -> Result<Self, E> {
        Ok(t)
    }
}

/// A surface modifier's table (`bump`, `normal_map`).
pub(super) struct RawModifier(pub(super) RawTextureRef);

impl<'de> Deserialize<'de> for RawModifier {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer
            .deserialize_any(FormsVisitor::<RawTextureRef>(std::marker::PhantomData))
            .map(RawModifier)
    }
}

/// `roughness` is one number (isotropic) or two, [along the tangent, along the bitangent], or a texture
/// (both axes).
pub(super) enum RawRoughness {
    Isotropic(f32),
    Anisotropic(f32, f32),
    Texture(Box<RawTextureRef>),
}

impl Forms for RawRoughness {
    const EXPECTING: &'static str =
        "a number in [0, 1], an array of 2 (along u, along v) or a texture table";
    fn number<E: serde::de::Error>(v: f32) -> Result<Self, E> {
        Ok(RawRoughness::Isotropic(v))
    }
    fn numbers<E: serde::de::Error>(v: Vec<f32>) -> Result<Self, E> {
        match v[..] {
            [u, v] => Ok(RawRoughness::Anisotropic(u, v)),
            _ => Err(length_error(
                v.len(),
                "an array of 2 numbers (along u, along v)",
            )),
        }
    }
    fn texture<E: serde::de::Error>(t: RawTextureRef) -> Result<Self, E> {
        Ok(RawRoughness::Texture(Box::new(t)))
    }
}
deserialize_forms!(RawRoughness);

/// `gamma` is either a number or a name; which names are valid is decided in `Checker::image` so that
/// the error can list them.
pub(super) enum RawGamma {
    Number(f32),
    Name(String),
}

impl<'de> Deserialize<'de> for RawGamma {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct GammaVisitor;

        impl Visitor<'_> for GammaVisitor {
            type Value = RawGamma;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a positive number or the string \"srgb\"")
            }

            // `as f32` saturates out-of-range values to infinity, which the finiteness check reports.
            fn visit_f64<E>(self, v: f64) -> Result<RawGamma, E> {
                Ok(RawGamma::Number(v as f32))
            }

            fn visit_i64<E>(self, v: i64) -> Result<RawGamma, E> {
                Ok(RawGamma::Number(v as f32))
            }

            fn visit_u64<E>(self, v: u64) -> Result<RawGamma, E> {
                Ok(RawGamma::Number(v as f32))
            }

            fn visit_str<E>(self, v: &str) -> Result<RawGamma, E> {
                Ok(RawGamma::Name(v.to_owned()))
            }
        }

        deserializer.deserialize_any(GammaVisitor)
    }
}
