//! Scene files: TOML text -> validated [`Scene`], or a [`SceneError`] that names the file, the line and
//! the key.
//!
//! The work happens in three steps:
//!
//! 1. `toml` parses the text into its syntax tree (`DeTable`), keeping the byte span of every key and
//!    value. Invalid TOML stops here.
//! 2. serde (`deny_unknown_fields`) turns that tree into the `Raw*` structs below, which mirror the file
//!    one to one. Every value is wrapped in [`Spanned`] so that step 3 still knows where it came from.
//!    Unknown keys, missing required keys and wrong types stop here; their errors carry only a byte span
//!    and a message, so we find the dotted key path by looking that span up in the tree from step 1.
//! 3. `Checker` applies the contract's rules (finite numbers, positive radii, a usable camera, ...) and
//!    builds the renderer's types, filling in defaults.
//!
//! The contract is `shared/docs/scene-format.md`. Nothing here may panic on any input: user numbers are
//! compared, never unwrapped, and integer arithmetic on them is done in a type wide enough not to
//! overflow.

use super::bsdfs;
use super::environment::{self, Environment};
use super::image_texture::{Texture, load_texture};
use super::mesh::{self, Mesh, MeshMaps, ObjMesh, Placement};
use super::mesh_file;
use super::texture::{MaterialTextures, TextureRef};
use super::{
    Bsdf, CONDUCTOR_PRESETS, Camera, ConductorFresnel, Emission, Filter, Gamma, ImageSettings,
    Light, LightSampling, Material, Projection, RenderSettings, Roughness, Sampler, Scene, Sphere,
    Tonemap, Triangle,
};
use glam::Vec3;
use serde::Deserialize;
use serde::de::{Deserializer, Visitor};
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The file name errors report for the embedded default scene, which has no path.
const DEFAULT_SCENE_FILE: &str = "<default scene>";

/// Hint appended to errors whose fix is "make the file match the format".
const SEE_CONTRACT: &str =
    "See the scene-format contract (scene-format.md) for every key, its unit and its default.";

// ---------------------------------------------------------------------------------------------------
// The error type
// ---------------------------------------------------------------------------------------------------

/// Why a scene could not be loaded. Its `Display` is one paragraph (no newline) of the form
/// `FILE, line N, key KEY: what is wrong. What to do.`, ready to print before exiting with status 2.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    file: String,
    line: Option<usize>,
    key: Option<String>,
    /// What is wrong, without a final full stop.
    problem: String,
    /// What to do about it, a full sentence.
    hint: String,
}

impl SceneError {
    /// A scene from another tool (super::import) that cannot be read as one: no line, the element or
    /// flag in `key` when there is one.
    pub(crate) fn import(
        path: &Path,
        key: Option<String>,
        problem: impl Into<String>,
        hint: &str,
    ) -> SceneError {
        SceneError::new(path.display().to_string(), None, key, problem, hint)
    }

    /// A problem at a line of a file of another format (super::mitsuba): `key` names the element.
    pub(crate) fn at(
        path: &Path,
        line: Option<usize>,
        key: Option<String>,
        problem: impl Into<String>,
        hint: &str,
    ) -> SceneError {
        SceneError::new(path.display().to_string(), line, key, problem, hint)
    }

    /// The same problem reported at another file, line and key (a scene translated from another format
    /// reports where its source said what the TOML reader refused).
    pub(crate) fn relocated(
        self,
        file: String,
        line: Option<usize>,
        key: Option<String>,
    ) -> SceneError {
        SceneError {
            file,
            line,
            key,
            ..self
        }
    }

    /// The scene file could not be read at all.
    pub fn io(path: &Path, e: &std::io::Error) -> SceneError {
        SceneError::new(
            path.display().to_string(),
            None,
            None,
            format!("cannot read the scene file: {e}"),
            "Check that the path is right and that the file is readable.",
        )
    }

    /// The scene file is not UTF-8 text: the line and column of the first byte that is not.
    pub fn not_utf8(path: &Path, bytes: &[u8], valid_up_to: usize) -> SceneError {
        let before = &bytes[..valid_up_to];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let column = String::from_utf8_lossy(&before[line_start..])
            .chars()
            .count()
            + 1;
        SceneError::new(
            path.display().to_string(),
            Some(line),
            None,
            format!(
                "the file is not UTF-8 text: the byte 0x{:02x} at column {column} is not valid UTF-8",
                bytes[valid_up_to]
            ),
            "TOML files are UTF-8: save the scene file in that encoding.",
        )
    }

    /// The scene file is larger than `limit` bytes (refused before it is read).
    pub fn too_large(path: &Path, limit: u64) -> SceneError {
        SceneError::new(
            path.display().to_string(),
            None,
            None,
            format!(
                "the scene file is larger than the limit of {} MiB for a scene file",
                limit >> 20
            ),
            "Put large geometry in [[mesh]] tables (Wavefront OBJ files) instead of inline [[sphere]] and [[triangle]] tables.",
        )
    }

    /// The file as given by the user, or `<default scene>` for the embedded scene.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The 1-based line the problem is on, when it is known.
    pub fn line(&self) -> Option<usize> {
        self.line
    }

    /// The dotted key path of the offending value, e.g. `sphere[2].radius` or `materials.glass.ior`.
    /// Array-of-tables indices are 0-based, in file order.
    pub fn key(&self) -> Option<&str> {
        self.key.as_deref()
    }

    fn new(
        file: String,
        line: Option<usize>,
        key: Option<String>,
        problem: impl Into<String>,
        hint: impl Into<String>,
    ) -> SceneError {
        // Messages can quote user text (a bad material name, a TOML parser message); the one-paragraph
        // promise must hold whatever they contain.
        let one_line = |s: String| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let problem = one_line(problem.into());
        SceneError {
            file,
            line,
            key,
            problem: problem.trim_end_matches('.').to_string(),
            hint: one_line(hint.into()),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.file)?;
        if let Some(line) = self.line {
            write!(f, ", line {line}")?;
        }
        if let Some(key) = &self.key {
            write!(f, ", key {key}")?;
        }
        write!(f, ": {}. {}", self.problem, self.hint)
    }
}

impl std::error::Error for SceneError {}

// ---------------------------------------------------------------------------------------------------
// The file as serde sees it
// ---------------------------------------------------------------------------------------------------

/// The whole file. Table names are singular (`[[sphere]]`) because each array-of-tables entry is one
/// object.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    camera: Spanned<RawCamera>,
    image: Option<RawImage>,
    render: Option<RawRender>,
    /// A BTreeMap iterates in name order; the key spans let us restore the order of the file.
    #[serde(default)]
    materials: BTreeMap<Spanned<String>, Spanned<RawMaterial>>,
    #[serde(default)]
    sphere: Vec<Spanned<RawSphere>>,
    #[serde(default)]
    triangle: Vec<Spanned<RawTriangle>>,
    #[serde(default)]
    mesh: Vec<Spanned<RawMesh>>,
    #[serde(default)]
    light: Vec<Spanned<RawLight>>,
    environment: Option<Spanned<RawEnvironment>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    radiance: Option<Spanned<RawVec3>>,
    map: Option<Spanned<String>>,
    rotate: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    #[serde(rename = "type")]
    kind: Option<Spanned<String>>,
    position: Spanned<RawVec3>,
    look_at: Spanned<RawVec3>,
    up: Option<Spanned<RawVec3>>,
    fov: Option<Spanned<f32>>,
    extent: Option<Spanned<f32>>,
    aperture: Option<Spanned<f32>>,
    focus_distance: Option<Spanned<f32>>,
}

/// Integers are read as `i64` (TOML's integer type) so that a negative or huge value gets a message
/// about its allowed range rather than serde's "expected u32".
#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawImage {
    width: Option<Spanned<i64>>,
    height: Option<Spanned<i64>>,
    exposure: Option<Spanned<f32>>,
    gamma: Option<Spanned<RawGamma>>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRender {
    samples: Option<Spanned<i64>>,
    max_bounces: Option<Spanned<i64>>,
    seed: Option<Spanned<i64>>,
    filter: Option<Spanned<String>>,
    filter_sigma: Option<Spanned<f32>>,
    background: Option<Spanned<RawVec3>>,
    sampler: Option<Spanned<String>>,
    light_sampling: Option<Spanned<String>>,
    tonemap: Option<Spanned<String>>,
    clamp: Option<Spanned<f32>>,
}

/// A plastic's coat when `ior` is not given: near polypropylene's 1.49 (Mitsuba's `plastic` default) and
/// the 1.5 of glTF's dielectrics.
const PLASTIC_DEFAULT_IOR: f32 = 1.5;

/// What one `[[mesh]]` table becomes: its meshes (one per MTL material when the OBJ's materials are used),
/// the materials it adds to the scene (named `mesh[i]/<MTL name>`), and what the reader noticed.
#[derive(Default)]
struct MeshTable {
    meshes: Vec<Mesh>,
    materials: Vec<(String, Material)>,
    warnings: Vec<String>,
}

/// The scene material for an MTL material, and whether a value had to be clipped (colours to [0, 1],
/// non-finite numbers to their defaults). The mapping (docs/scene-format.md, "OBJ materials"):
/// Pr or Pm given (the PBR extension): metallic_roughness (base colour Kd, metallic Pm, roughness Pr);
/// otherwise by `illum`: 3 or 5 (reflection) a mirror tinted Ks; 4, 6, 7 or 9 (refraction) a smooth
/// dielectric of index Ni (1.5 without one); anything else, or none, diffuse Kd (MTL's default 0.8). Ke
/// above 0 is the front side's emission.
fn mtl_material(m: &mesh::FileMaterial) -> (Material, bool) {
    let mut clipped = false;
    let mut color = |c: Option<[f32; 3]>, default: f32| {
        let c = c.unwrap_or([default; 3]);
        let v = Vec3::from_array(c.map(|x| if x.is_finite() { x } else { default }));
        let out = v.clamp(Vec3::ZERO, Vec3::ONE);
        clipped |= out != Vec3::from_array(c);
        out
    };
    let unit = |x: Option<f32>, default: f32| {
        x.filter(|x| x.is_finite())
            .unwrap_or(default)
            .clamp(0.0, 1.0)
    };
    let bsdf = if m.roughness.is_some() || m.metallic.is_some() {
        Bsdf::MetallicRoughness {
            base_color: color(m.diffuse, 0.8),
            metallic: unit(m.metallic, 0.0),
            roughness: unit(m.roughness, 1.0),
        }
    } else {
        match m.illum {
            Some(3 | 5) => Bsdf::Mirror {
                tint: color(m.specular, 1.0),
            },
            Some(4 | 6 | 7 | 9) => Bsdf::Dielectric {
                ior: m.ior.filter(|n| n.is_finite() && *n > 0.0).unwrap_or(1.5),
                roughness: Roughness::SMOOTH,
            },
            _ => Bsdf::Diffuse {
                albedo: color(m.diffuse, 0.8),
            },
        }
    };
    let emission = m
        .emission
        .map(|e| Vec3::from_array(e.map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 })))
        .filter(|e| e.max_element() > 0.0)
        .map(|radiance| Emission {
            radiance,
            two_sided: false,
        });
    (
        Material {
            bsdf,
            emission,
            textures: MaterialTextures::default(),
        },
        clipped,
    )
}

/// One flat struct for every material type rather than a serde-tagged enum: a tagged enum buffers its
/// content, which loses the spans, and its "unknown variant" error would point at the whole material
/// rather than at `type`. Which keys a type allows is checked by hand in `Checker::material`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    albedo: Option<Spanned<RawParam<RawVec3>>>,
    tint: Option<Spanned<RawParam<RawVec3>>>,
    ior: Option<Spanned<f32>>,
    /// `conductor`: a named metal, or its complex index of refraction, or a base colour (Schlick).
    preset: Option<Spanned<String>>,
    eta: Option<Spanned<RawVec3>>,
    k: Option<Spanned<RawVec3>>,
    base_color: Option<Spanned<RawParam<RawVec3>>>,
    /// The glossy types: perceptual roughness, one number or [along u, along v], or a texture.
    roughness: Option<Spanned<RawRoughness>>,
    /// `metallic_roughness`.
    metallic: Option<Spanned<RawParam<f32>>>,
    /// `emitter`: its radiance, and whether both faces emit.
    radiance: Option<Spanned<RawParam<RawVec3>>>,
    two_sided: Option<Spanned<bool>>,
    /// Any other type: what it emits besides scattering.
    emission: Option<Spanned<RawParam<RawVec3>>>,
    two_sided_emission: Option<Spanned<bool>>,
    /// Any type: the surface modifiers.
    opacity: Option<Spanned<RawParam<f32>>>,
    alpha_cutoff: Option<Spanned<f32>>,
    bump: Option<Spanned<RawModifier>>,
    normal_map: Option<Spanned<RawModifier>>,
}

impl RawMaterial {
    /// The colour key named `key`, for the registry's generic reader (a parameter's key must be one of
    /// these: tests hold every row against them).
    fn color_key(&self, key: &str) -> Option<&Spanned<RawParam<RawVec3>>> {
        match key {
            "albedo" => self.albedo.as_ref(),
            "tint" => self.tint.as_ref(),
            "base_color" => self.base_color.as_ref(),
            _ => panic!("the material registry names colour key `{key}`, which RawMaterial lacks"),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    center: Spanned<RawVec3>,
    radius: Spanned<f32>,
    material: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTriangle {
    vertices: Spanned<Vec<Spanned<RawVec3>>>,
    material: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    obj: Spanned<String>,
    /// Optional when the OBJ has MTL materials (they are used then).
    material: Option<Spanned<String>>,
    scale: Option<Spanned<f32>>,
    rotate: Option<Spanned<RawVec3>>,
    translate: Option<Spanned<RawVec3>>,
    smooth: Option<Spanned<bool>>,
    texture: Option<Spanned<String>>,
    /// sRGB colour multiplying the material's emission (instead of `texture`).
    emission_texture: Option<Spanned<String>>,
    /// Linear data, glTF's layout: B multiplies metallic, G roughness (a metallic_roughness material).
    metallic_roughness_texture: Option<Spanned<String>>,
    /// A tangent-space normal map (linear data), and the factor of its x and y (default 1).
    normal_map: Option<Spanned<String>>,
    normal_scale: Option<Spanned<f32>>,
}

/// Flat for the same reason as [`RawMaterial`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    position: Option<Spanned<RawVec3>>,
    center: Option<Spanned<RawVec3>>,
    radius: Option<Spanned<f32>>,
    power: Option<Spanned<f32>>,
    color: Option<Spanned<RawVec3>>,
    direction: Option<Spanned<RawVec3>>,
    irradiance: Option<Spanned<f32>>,
    angle: Option<Spanned<f32>>,
}

/// A TOML array of exactly three numbers (integers accepted). serde's own `[f32; 3]` silently ignores
/// extra elements, so the length is checked here.
#[derive(Clone, Copy)]
struct RawVec3([f32; 3]);

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

/// A texture reference (docs/scene-format.md, "Textured parameters"): an inline table in place of a
/// parameter's constant, or a surface modifier (`bump`, `normal_map`, where `scale` is the modifier's
/// number and the uv scale is `uv_scale`).
#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTextureRef {
    texture: Spanned<String>,
    channel: Option<Spanned<String>>,
    color_space: Option<Spanned<String>>,
    filter: Option<Spanned<String>>,
    wrap: Option<Spanned<String>>,
    /// The uv scale ([su, sv]); in `bump` and `normal_map` the modifier's scale (a number).
    scale: Option<Spanned<RawScale>>,
    uv_scale: Option<Spanned<RawVec2>>,
    offset: Option<Spanned<RawVec2>>,
    rotation: Option<Spanned<f32>>,
    factor: Option<Spanned<RawFactor>>,
}

/// A texture reference's `scale`: a uv scale [su, sv], or (bump and normal maps) one number.
#[derive(Clone)]
enum RawScale {
    Uv(RawVec2),
    Number(f32),
}

/// A texture reference's `factor`: one number, or a colour [r, g, b].
#[derive(Clone)]
enum RawFactor {
    Number(f32),
    Color(RawVec3),
}

/// A parameter that is a constant `T` (a number or an array) or a texture reference (a table).
enum RawParam<T> {
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
struct RawVec2([f32; 2]);

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
struct RawModifier(RawTextureRef);

impl<'de> Deserialize<'de> for RawModifier {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer
            .deserialize_any(FormsVisitor::<RawTextureRef>(std::marker::PhantomData))
            .map(RawModifier)
    }
}

/// `roughness` is one number (isotropic) or two, [along the tangent, along the bitangent], or a texture
/// (both axes).
enum RawRoughness {
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
enum RawGamma {
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

// ---------------------------------------------------------------------------------------------------
// Entry point
// ---------------------------------------------------------------------------------------------------

/// Parses and validates a scene. `path` is only used for messages and stored in the result.
pub(crate) fn parse_scene(text: &str, path: Option<&Path>) -> Result<Scene, SceneError> {
    let file = match path {
        Some(p) => p.display().to_string(),
        None => DEFAULT_SCENE_FILE.to_string(),
    };
    let checker = Checker { file, text };

    // Step 1: syntax. The tree is kept so that step 2's errors can be located in it.
    let tree = DeTable::parse(text).map_err(|e| checker.syntax_error(&e))?;
    // Step 2: shape. Scene files are small, so cloning the tree costs nothing worth avoiding.
    let raw = RawScene::deserialize(toml::de::Deserializer::from(tree.clone()))
        .map_err(|e| checker.shape_error(&e, tree.get_ref()))?;
    // Step 3: meaning.
    checker.scene(&raw, path)
}

// ---------------------------------------------------------------------------------------------------
// Step 3: the contract's rules
// ---------------------------------------------------------------------------------------------------

/// Validates the raw file and builds the [`Scene`]; knows the file name and text to phrase errors.
struct Checker<'a> {
    file: String,
    text: &'a str,
}

impl Checker<'_> {
    fn scene(&self, raw: &RawScene, path: Option<&Path>) -> Result<Scene, SceneError> {
        let camera = self.camera(&raw.camera)?;
        let mut image = self.image(raw.image.as_ref())?;
        let (render, background) = self.render(raw.render.as_ref())?;
        image.tonemap = self.tonemap(raw.render.as_ref())?;
        let base = path.and_then(Path::parent).unwrap_or(Path::new(""));
        let environment = self.environment(raw, background, base)?;

        // TOML has already rejected duplicate names, so sorting by position is a total order.
        let mut named: Vec<_> = raw.materials.iter().collect();
        named.sort_by_key(|(name, _)| name.span().start);
        // Relative model and image paths are relative to the scene file (to the working directory for the
        // embedded scene). A file used by several meshes or materials is read once.
        let mut files = Files {
            base,
            loaded: LoadedFiles::default(),
        };
        let mut materials = Vec::with_capacity(named.len());
        let mut material_names = Vec::with_capacity(named.len());
        for (name, material) in named {
            materials.push(self.material(name.get_ref(), material, &mut files)?);
            material_names.push(name.get_ref().clone());
        }

        let mut spheres = Vec::with_capacity(raw.sphere.len());
        for (i, sphere) in raw.sphere.iter().enumerate() {
            spheres.push(self.sphere(i, sphere.get_ref(), &material_names)?);
        }
        let mut triangles = Vec::with_capacity(raw.triangle.len());
        for (i, triangle) in raw.triangle.iter().enumerate() {
            triangles.push(self.triangle(i, triangle.get_ref(), &material_names)?);
        }
        let mut meshes = Vec::with_capacity(raw.mesh.len());
        let mut total = triangles.len();
        let mut warnings = Vec::new();
        for (i, mesh) in raw.mesh.iter().enumerate() {
            let table = self.mesh(
                i,
                mesh,
                &material_names,
                &materials,
                base,
                &mut files.loaded,
            )?;
            total += table
                .meshes
                .iter()
                .map(|m| m.triangles.len())
                .sum::<usize>();
            if total > mesh::MAX_TRIANGLES {
                return Err(self.error(
                    mesh.span(),
                    &format!("mesh[{i}]"),
                    format!("the scene has more than {} triangles", mesh::MAX_TRIANGLES),
                    "Use fewer or simpler meshes.",
                ));
            }
            meshes.extend(table.meshes);
            for (name, material) in table.materials {
                material_names.push(name);
                materials.push(material);
            }
            warnings.extend(table.warnings);
        }
        let mut lights = Vec::with_capacity(raw.light.len());
        for (i, light) in raw.light.iter().enumerate() {
            lights.push(self.light(i, light)?);
        }

        Ok(Scene {
            path: path.map(Path::to_path_buf),
            camera,
            image,
            render,
            materials,
            material_names,
            spheres,
            triangles,
            meshes,
            lights,
            environment,
            warnings,
        })
    }

    /// `[environment]`, or the uniform `render.background` it replaces (giving both is an error: which
    /// one is meant?).
    fn environment(
        &self,
        raw: &RawScene,
        background: Vec3,
        base: &Path,
    ) -> Result<Environment, SceneError> {
        let Some(env) = &raw.environment else {
            return Ok(Environment {
                radiance: background,
                ..Default::default()
            });
        };
        let background_key = raw.render.as_ref().and_then(|r| r.background.as_ref());
        if let Some(b) = background_key {
            return Err(self.error(
                b.span(),
                "render.background",
                "the scene has both render.background and an [environment] table",
                "[environment] replaces render.background: give its uniform radiance as environment.radiance.",
            ));
        }
        let e = env.get_ref();
        let map = match &e.map {
            None => None,
            Some(m) => {
                let path = base.join(m.get_ref());
                let loaded = environment::load_map(&path).map_err(|problem| {
                    self.error(
                        m.span(),
                        "environment.map",
                        problem,
                        "The path is relative to the scene file; the map must be an equirectangular .exr or .hdr \
                         image of linear radiance.",
                    )
                })?;
                Some(Arc::new(loaded))
            }
        };
        let default = if map.is_some() { Vec3::ONE } else { Vec3::ZERO };
        let radiance = e.radiance.as_ref().map_or(Ok(default), |r| {
            self.vec3_unless(
                r,
                "environment.radiance",
                |r| r.min_element() < 0.0,
                "environment radiance cannot be negative",
                "Give a linear RGB radiance (W sr^-1 m^-2) with components >= 0; with a map it multiplies the map.",
            )
        })?;
        let rotate_deg = e
            .rotate
            .as_ref()
            .map_or(Ok(0.0), |r| self.number(r, "environment.rotate"))?;
        Ok(Environment {
            radiance,
            map,
            rotate_deg,
        })
    }

    fn camera(&self, raw: &Spanned<RawCamera>) -> Result<Camera, SceneError> {
        let c = raw.get_ref();
        let position = self.vec3(&c.position, "camera.position")?;
        let look_at = self.vec3(&c.look_at, "camera.look_at")?;
        let projection = match &c.kind {
            None => Projection::Perspective,
            Some(k) => match k.get_ref().as_str() {
                "perspective" => Projection::Perspective,
                "orthographic" => Projection::Orthographic,
                other => {
                    return Err(self.error(
                        k.span(),
                        "camera.type",
                        format!("unknown camera type \"{other}\""),
                        "Use \"perspective\" (the default, with fov) or \"orthographic\" (with extent).",
                    ));
                }
            },
        };
        // Each projection has its own key for the size of the view, and refuses the other's.
        let (fov_deg, extent) = match projection {
            Projection::Perspective => {
                if let Some(e) = &c.extent {
                    return Err(self.error(
                        e.span(),
                        "camera.extent",
                        "a perspective camera has no `extent`",
                        "Remove `extent`, or set `type = \"orthographic\"` for a parallel projection.",
                    ));
                }
                let fov = self.required(
                    &c.fov,
                    raw,
                    "camera.fov",
                    "a perspective camera needs a fov",
                )?;
                let fov_deg = self.number_unless(
                    fov,
                    "camera.fov",
                    |fov| !(fov > 0.0 && fov < 180.0),
                    "the field of view must be strictly between 0 and 180 degrees",
                    "fov is the horizontal angle across the image width in degrees; 60 is a typical value.",
                )?;
                (fov_deg, 0.0)
            }
            Projection::Orthographic => {
                if let Some(f) = &c.fov {
                    return Err(self.error(
                        f.span(),
                        "camera.fov",
                        "an orthographic camera has no `fov`",
                        "Remove `fov`: `extent` gives the width of the view in scene units.",
                    ));
                }
                let extent = self.required(
                    &c.extent,
                    raw,
                    "camera.extent",
                    "an orthographic camera needs an extent",
                )?;
                let extent = self.number_unless(
                    extent,
                    "camera.extent",
                    |e| e <= 0.0,
                    "the extent must be > 0",
                    "extent is the width of the view in scene units (the height follows the image's aspect).",
                )?;
                (0.0, extent)
            }
        };
        if look_at == position {
            return Err(self.error(
                c.look_at.span(),
                "camera.look_at",
                format!(
                    "look_at equals position ({position}), so the camera has no view direction"
                ),
                "Move look_at to the point the camera should aim at.",
            ));
        }

        // The geometry checks run in f64: the difference or squared length of two finite f32 vectors
        // can overflow f32, but not f64.
        let view = sub64(look_at, position);
        let view_length = length64(view);

        // A defaulted `up` has no span of its own; the [camera] header is the nearest place to point.
        let (up, up_span) = match &c.up {
            Some(up) => (self.vec3(up, "camera.up")?, up.span()),
            None => (Vec3::Y, raw.span()),
        };
        let up64 = [f64::from(up.x), f64::from(up.y), f64::from(up.z)];
        let up_length = length64(up64);
        if up_length == 0.0 {
            return Err(self.error(
                up_span,
                "camera.up",
                "the up vector is zero",
                "Set camera.up to the direction that should point up in the image, e.g. [0, 1, 0].",
            ));
        }
        let view_dir = scale64(view, 1.0 / view_length);
        let up_dir = scale64(up64, 1.0 / up_length);
        if length64(cross64(up_dir, view_dir)) < 1e-6 {
            let which = if c.up.is_some() {
                "the up vector"
            } else {
                "the default up vector [0, 1, 0]"
            };
            return Err(self.error(
                up_span,
                "camera.up",
                format!("{which} is parallel to the view direction (look_at - position), so the image has no defined up"),
                "Set camera.up to a direction that is not along the line of sight.",
            ));
        }

        let aperture = c.aperture.as_ref().map_or(Ok(0.0), |a| {
            self.number_unless(
                a,
                "camera.aperture",
                |a| a < 0.0,
                "the aperture (lens radius) must be >= 0",
                "Use 0 for a pinhole camera, or a positive lens radius in scene units for depth of field.",
            )
        })?;
        if let (Projection::Orthographic, Some(a)) = (projection, &c.aperture)
            && aperture > 0.0
        {
            return Err(self.error(
                a.span(),
                "camera.aperture",
                "an orthographic camera has no lens: depth of field needs a perspective camera",
                "Remove `aperture` (or set it to 0), or use `type = \"perspective\"`.",
            ));
        }

        let focus_distance = match &c.focus_distance {
            Some(d) => self.number_unless(
                d,
                "camera.focus_distance",
                |d| d <= 0.0,
                "the focus distance must be > 0",
                "Give the distance along the view axis to the plane in focus, in scene units, or leave it out to focus on look_at.",
            )?,
            None => {
                // The default, |look_at - position|, can exceed f32's range for extreme coordinates.
                let d = view_length as f32;
                if !d.is_finite() {
                    return Err(self.error(
                        c.look_at.span(),
                        "camera.look_at",
                        "look_at is so far from position that the distance between them overflows a 32-bit float",
                        "Bring the scene's coordinates into a smaller range.",
                    ));
                }
                d
            }
        };

        Ok(Camera {
            position,
            look_at,
            up,
            projection,
            fov_deg,
            extent,
            aperture,
            focus_distance,
        })
    }

    fn image(&self, raw: Option<&RawImage>) -> Result<ImageSettings, SceneError> {
        // A missing [image] table is an empty one: every key takes its default below.
        let empty = RawImage::default();
        let raw = raw.unwrap_or(&empty);
        const MAX_SIDE: u32 = 65536;
        const MAX_PIXELS: u64 = 1 << 28;
        let side_hint = "Image sides are in pixels, between 1 and 65536.";
        let width = raw.width.as_ref().map_or(Ok(512), |w| {
            self.integer(w, "image.width", 1, MAX_SIDE, side_hint)
        })?;
        let height = raw.height.as_ref().map_or(Ok(512), |h| {
            self.integer(h, "image.height", 1, MAX_SIDE, side_hint)
        })?;
        let pixels = u64::from(width) * u64::from(height);
        if pixels > MAX_PIXELS {
            // Both defaults are small, so at least one side was given; point at it.
            let (span, key) = match (&raw.width, &raw.height) {
                (Some(w), _) => (w.span(), "image.width"),
                (None, Some(h)) => (h.span(), "image.height"),
                (None, None) => (0..0, "image.width"),
            };
            return Err(self.error(
                span,
                key,
                format!("{width} x {height} is {pixels} pixels, more than the limit of {MAX_PIXELS} (2^28)"),
                "Render a smaller image, e.g. 16384 x 16384 at most.",
            ));
        }

        let exposure = raw.exposure.as_ref().map_or(Ok(1.0), |e| {
            self.number_unless(
                e,
                "image.exposure",
                |e| e < 0.0,
                "the exposure must be >= 0",
                "Exposure is a linear multiplier on radiance before the display transform; 1 leaves it unchanged.",
            )
        })?;

        let gamma = match &raw.gamma {
            None => Gamma::Power(2.2),
            Some(g) => match g.get_ref() {
                RawGamma::Number(value) => Gamma::Power(self.number_unless(
                    &Spanned::new(g.span(), *value),
                    "image.gamma",
                    |gamma| gamma <= 0.0,
                    "a numeric gamma must be > 0",
                    "Use 2.2 (the default) or the string \"srgb\".",
                )?),
                RawGamma::Name(name) if name == "srgb" => Gamma::Srgb,
                RawGamma::Name(name) => {
                    return Err(self.error(
                        g.span(),
                        "image.gamma",
                        format!("unknown gamma \"{name}\""),
                        "Use a positive number such as 2.2, or the string \"srgb\" for the sRGB transfer curve.",
                    ));
                }
            },
        };

        Ok(ImageSettings {
            width,
            height,
            exposure,
            gamma,
            tonemap: Tonemap::None, // render.tonemap, set by `scene`
        })
    }

    /// `render.tonemap`: "none" (default) or "aces".
    fn tonemap(&self, raw: Option<&RawRender>) -> Result<Tonemap, SceneError> {
        match raw.and_then(|r| r.tonemap.as_ref()) {
            None => Ok(Tonemap::None),
            Some(t) => match t.get_ref().as_str() {
                "none" => Ok(Tonemap::None),
                "aces" => Ok(Tonemap::Aces),
                other => Err(self.error(
                    t.span(),
                    "render.tonemap",
                    format!("unknown tonemap \"{other}\""),
                    "Use \"none\" (the course's clamp, the default) or \"aces\" (Narkowicz's ACES filmic fit).",
                )),
            },
        }
    }

    /// The `[render]` settings, and `render.background` (which `environment` turns into the light).
    fn render(&self, raw: Option<&RawRender>) -> Result<(RenderSettings, Vec3), SceneError> {
        // A missing [render] table is an empty one: every key takes its default below.
        let empty = RawRender::default();
        let raw = raw.unwrap_or(&empty);
        let samples = raw.samples.as_ref().map_or(Ok(64), |s| {
            self.integer(
                s,
                "render.samples",
                1,
                u32::MAX,
                "samples is the number of paths per pixel; it must be at least 1.",
            )
        })?;
        let max_bounces = raw.max_bounces.as_ref().map_or(Ok(5), |b| {
            self.integer(
                b,
                "render.max_bounces",
                0,
                u32::MAX,
                "max_bounces counts scattering events per path; 0 shows lights and the background only.",
            )
        })?;
        let seed = raw.seed.as_ref().map_or(Ok(0), |s| {
            self.integer(
                s,
                "render.seed",
                0,
                u32::MAX,
                "The seed is a 32-bit unsigned integer.",
            )
        })?;
        let filter = match &raw.filter {
            None => Filter::Gaussian,
            Some(f) => match f.get_ref().as_str() {
                "gaussian" => Filter::Gaussian,
                "box" => Filter::Box,
                "none" => Filter::None,
                other => {
                    return Err(self.error(
                        f.span(),
                        "render.filter",
                        format!("unknown pixel filter \"{other}\""),
                        "Use \"gaussian\" (the default), \"box\" or \"none\".",
                    ));
                }
            },
        };
        let filter_sigma = raw.filter_sigma.as_ref().map_or(Ok(0.5), |s| {
            self.number_unless(
                s,
                "render.filter_sigma",
                |sigma| sigma <= 0.0,
                "the filter's standard deviation must be > 0",
                "filter_sigma is in pixels; 0.5 is the default. Use filter = \"none\" for no filtering.",
            )
        })?;
        let background = raw.background.as_ref().map_or(Ok(Vec3::ZERO), |b| {
            self.vec3_unless(
                b,
                "render.background",
                |b| b.min_element() < 0.0,
                "background radiance cannot be negative",
                "Give a linear RGB radiance with components >= 0; [0, 0, 0] is black.",
            )
        })?;
        let sampler = match &raw.sampler {
            None => Sampler::Sobol,
            Some(s) => match s.get_ref().as_str() {
                "independent" => Sampler::Independent,
                "sobol" => Sampler::Sobol,
                other => {
                    return Err(self.error(
                        s.span(),
                        "render.sampler",
                        format!("unknown sampler \"{other}\""),
                        "Use \"sobol\" (the default) or \"independent\".",
                    ));
                }
            },
        };
        let light_sampling = match &raw.light_sampling {
            None => LightSampling::Mis,
            Some(s) => match LightSampling::from_name(s.get_ref()) {
                Some(l) => l,
                None => {
                    return Err(self.error(
                        s.span(),
                        "render.light_sampling",
                        format!("unknown light sampling strategy \"{}\"", s.get_ref()),
                        format!(
                            "Use {} (\"mis\" is the default).",
                            LightSampling::names_listed()
                        ),
                    ));
                }
            },
        };
        let clamp = match &raw.clamp {
            None => None,
            Some(c) => Some(self.number_unless(
                c,
                "render.clamp",
                |c| c <= 0.0,
                "the firefly clamp must be > 0",
                "clamp is the largest radiance a sample may carry in any channel (biased: leave it out for an unbiased image).",
            )?),
        };
        let settings = RenderSettings {
            samples,
            max_bounces,
            seed,
            filter,
            filter_sigma,
            sampler,
            light_sampling,
            clamp,
        };
        Ok((settings, background))
    }

    fn material(
        &self,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
    ) -> Result<Material, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("materials.{name}.{field}");
        let kind = m.kind.get_ref().as_str();
        let mut textures = MaterialTextures::default();
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
        // Each type allows only some of the optional keys; a key for another type is treated like any
        // unknown key rather than silently ignored. Every type but `emitter` may also emit; every type
        // takes the surface modifiers.
        const EMISSION: [&str; 2] = ["emission", "two_sided_emission"];
        const MODIFIERS: [&str; 4] = ["opacity", "alpha_cutoff", "bump", "normal_map"];
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
                let roughness = self.roughness(
                    &m.roughness,
                    &key("roughness"),
                    files,
                    &mut textures.roughness,
                )?;
                (
                    vec!["ior", "roughness", EMISSION[0], EMISSION[1]],
                    Bsdf::Dielectric { ior, roughness },
                )
            }
            "conductor" => {
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
                (
                    vec![
                        "preset",
                        "eta",
                        "k",
                        "base_color",
                        "roughness",
                        "tint",
                        EMISSION[0],
                        EMISSION[1],
                    ],
                    Bsdf::Conductor {
                        fresnel,
                        roughness: self.roughness(
                            &m.roughness,
                            &key("roughness"),
                            files,
                            &mut textures.roughness,
                        )?,
                        tint,
                    },
                )
            }
            "plastic" => {
                let albedo = self.required(
                    &m.albedo,
                    raw,
                    &key("albedo"),
                    "a plastic material needs an albedo (the colour of its diffuse base)",
                )?;
                let albedo =
                    self.unit_color(albedo, &key("albedo"), files, &mut textures.albedo)?;
                let ior = match &m.ior {
                    Some(ior) => self.ior(ior, &key("ior"))?,
                    None => PLASTIC_DEFAULT_IOR,
                };
                let roughness = self.roughness(
                    &m.roughness,
                    &key("roughness"),
                    files,
                    &mut textures.roughness,
                )?;
                (
                    vec!["albedo", "ior", "roughness", EMISSION[0], EMISSION[1]],
                    Bsdf::Plastic {
                        albedo,
                        ior,
                        roughness,
                    },
                )
            }
            "metallic_roughness" => {
                let base_color = match &m.base_color {
                    Some(c) => {
                        self.unit_color(c, &key("base_color"), files, &mut textures.albedo)?
                    }
                    None => Vec3::ONE,
                };
                let metallic = match &m.metallic {
                    Some(v) => self.scalar_param(
                        v,
                        &key("metallic"),
                        |x| !(0.0..=1.0).contains(&x),
                        "metallic must be in [0, 1]",
                        "0 is a dielectric (plastic-like), 1 a metal; glTF's default is 1.",
                        files,
                        &mut textures.metallic,
                    )?,
                    None => 1.0,
                };
                // glTF's default roughness is 1.
                let roughness = match &m.roughness {
                    None => 1.0,
                    Some(r) => match self.roughness(
                        &m.roughness,
                        &key("roughness"),
                        files,
                        &mut textures.roughness,
                    )? {
                        Roughness { u, v } if u == v => u,
                        _ => {
                            return Err(self.error(
                                r.span(),
                                &key("roughness"),
                                "a metallic_roughness material's roughness is one number",
                                "glTF 2.0's metallic-roughness model is isotropic; give one number in [0, 1].",
                            ));
                        }
                    },
                };
                (
                    vec![
                        "base_color",
                        "metallic",
                        "roughness",
                        EMISSION[0],
                        EMISSION[1],
                    ],
                    Bsdf::MetallicRoughness {
                        base_color,
                        metallic,
                        roughness,
                    },
                )
            }
            "emitter" => (vec!["radiance", "two_sided"], Bsdf::Black),
            other if bsdfs::by_toml_type(other).is_some() => {
                let (kind, row) = bsdfs::by_toml_type(other).expect("matched");
                self.registered_material(kind, row, name, raw, files, &mut textures)?
            }
            other => {
                let registered: Vec<String> = bsdfs::BSDFS
                    .iter()
                    .filter_map(|k| match k.keys {
                        bsdfs::Keys::Params { toml_type, .. } => Some(format!("\"{toml_type}\"")),
                        bsdfs::Keys::Builtin => None,
                    })
                    .collect();
                return Err(self.error(
                    m.kind.span(),
                    &key("type"),
                    format!("unknown material type \"{other}\""),
                    format!(
                        "Use \"diffuse\" (with albedo), \"mirror\" (optional tint), \"dielectric\" (with ior), \
                         \"conductor\" (with preset, eta and k, or base_color), \"plastic\" (with albedo), \
                         \"metallic_roughness\", \"emitter\" (with radiance), or {} (see docs/scene-format.md).",
                        registered.join(", ")
                    ),
                ));
            }
        };
        let present = [
            ("albedo", m.albedo.as_ref().map(Spanned::span)),
            ("tint", m.tint.as_ref().map(Spanned::span)),
            ("ior", m.ior.as_ref().map(Spanned::span)),
            ("preset", m.preset.as_ref().map(Spanned::span)),
            ("eta", m.eta.as_ref().map(Spanned::span)),
            ("k", m.k.as_ref().map(Spanned::span)),
            ("base_color", m.base_color.as_ref().map(Spanned::span)),
            ("roughness", m.roughness.as_ref().map(Spanned::span)),
            ("metallic", m.metallic.as_ref().map(Spanned::span)),
            ("radiance", m.radiance.as_ref().map(Spanned::span)),
            ("two_sided", m.two_sided.as_ref().map(Spanned::span)),
            ("emission", m.emission.as_ref().map(Spanned::span)),
            (
                "two_sided_emission",
                m.two_sided_emission.as_ref().map(Spanned::span),
            ),
        ];
        let allowed: Vec<&str> = allowed.iter().chain(MODIFIERS.iter()).copied().collect();
        self.reject_foreign_keys(
            &present,
            &allowed,
            &format!("materials.{name}"),
            &format!("a {kind} material"),
        )?;
        let emission = if bsdf == Bsdf::Black {
            let r = self.required(
                &m.radiance,
                raw,
                &key("radiance"),
                "an emitter material needs a radiance",
            )?;
            Some(Emission {
                radiance: radiance(r, "radiance", files, &mut textures.emission)?,
                two_sided: m.two_sided.as_ref().is_some_and(|t| *t.get_ref()),
            })
        } else {
            match (&m.emission, &m.two_sided_emission) {
                (Some(e), two_sided) => Some(Emission {
                    radiance: radiance(e, "emission", files, &mut textures.emission)?,
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
        };
        self.modifiers(name, m, files, &mut textures)?;
        Ok(Material {
            bsdf,
            emission,
            textures,
        })
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
            let (mut r, scale) = self.texture_ref(t, &key(field), false, true, files)?;
            // A normal map is a vector: all three channels (a height map, like a scalar, reads "r").
            if field == "normal_map" && t.channel.is_none() {
                r.channel = super::texture::Channel::Rgb;
            }
            *slot = Some((r, scale.unwrap_or(1.0)));
        }
        Ok(())
    }

    /// A colour parameter: its constant (checked by `bad`), or a texture reference, recorded in `slot`,
    /// whose factor (default white, checked the same way) becomes the constant.
    /// A material of a kind the registry's generic reader reads (`scene::bsdfs`, `Keys::Params`): each
    /// of the row's parameters read from its key, checked, defaulted and textured by its value kind.
    /// Returns the keys the kind allows (its parameters and emission) and the material.
    fn registered_material(
        &self,
        kind: u32,
        row: &'static bsdfs::BsdfKind,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<(Vec<&'static str>, Bsdf), SceneError> {
        let m = raw.get_ref();
        let bsdfs::Keys::Params { toml_type, params } = row.keys else {
            unreachable!("by_toml_type finds rows with parameters only")
        };
        let (mut albedo, mut roughness) = (Vec3::ZERO, Roughness::SMOOTH);
        for p in params {
            let key = format!("materials.{name}.{}", p.key);
            match p.value {
                bsdfs::ParamValue::Albedo { default } => {
                    albedo = match (m.color_key(p.key), default) {
                        (Some(v), _) => self.color_param(
                            v,
                            &key,
                            |a| !in_unit_range(a),
                            "every component must be in [0, 1]",
                            p.hint,
                            files,
                            &mut textures.albedo,
                        )?,
                        (None, Some(d)) => Vec3::from(d),
                        (None, None) => {
                            let problem = format!("a {toml_type} material needs {}", p.key);
                            self.required(&None::<Spanned<()>>, raw, &key, &problem)?;
                            unreachable!("required refuses a missing key")
                        }
                    };
                }
                bsdfs::ParamValue::Roughness { default } => {
                    roughness = match &m.roughness {
                        None => Roughness::isotropic(default),
                        Some(r) => match self.roughness(
                            &m.roughness,
                            &key,
                            files,
                            &mut textures.roughness,
                        )? {
                            iso @ Roughness { u, v } if u == v => iso,
                            _ => {
                                return Err(self.error(
                                    r.span(),
                                    &key,
                                    format!("a {toml_type} material's roughness is one number"),
                                    p.hint,
                                ));
                            }
                        },
                    };
                }
            }
        }
        let mut allowed: Vec<&'static str> = params.iter().map(|p| p.key).collect();
        allowed.extend(["emission", "two_sided_emission"]);
        Ok((
            allowed,
            Bsdf::Registered {
                kind,
                albedo,
                roughness,
            },
        ))
    }

    #[allow(clippy::too_many_arguments)]
    fn color_param(
        &self,
        v: &Spanned<RawParam<RawVec3>>,
        key: &str,
        bad: impl Fn(Vec3) -> bool,
        problem: &str,
        hint: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Vec3, SceneError> {
        match v.get_ref() {
            RawParam::Constant(c) => {
                self.vec3_unless(&Spanned::new(v.span(), *c), key, bad, problem, hint)
            }
            RawParam::Texture(t) => {
                let (r, _) = self.texture_ref(t, key, true, false, files)?;
                let factor = match &t.factor {
                    None => Vec3::ONE,
                    Some(f) => {
                        let c = match f.get_ref() {
                            RawFactor::Number(x) => RawVec3([*x; 3]),
                            RawFactor::Color(c) => *c,
                        };
                        let fkey = format!("{key}.factor");
                        self.vec3_unless(&Spanned::new(f.span(), c), &fkey, bad, problem, hint)?
                    }
                };
                *slot = Some(r);
                Ok(factor)
            }
        }
    }

    /// A scalar parameter: its constant (checked by `bad`), or a texture reference, recorded in `slot`,
    /// whose factor (a number, default 1, checked the same way) becomes the constant.
    #[allow(clippy::too_many_arguments)]
    fn scalar_param(
        &self,
        v: &Spanned<RawParam<f32>>,
        key: &str,
        bad: impl Fn(f32) -> bool,
        problem: &str,
        hint: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<f32, SceneError> {
        match v.get_ref() {
            RawParam::Constant(x) => {
                self.number_unless(&Spanned::new(v.span(), *x), key, bad, problem, hint)
            }
            RawParam::Texture(t) => {
                let (r, _) = self.texture_ref(t, key, false, false, files)?;
                let factor = match &t.factor {
                    None => 1.0,
                    Some(f) => match f.get_ref() {
                        RawFactor::Number(x) => {
                            let fkey = format!("{key}.factor");
                            self.number_unless(
                                &Spanned::new(f.span(), *x),
                                &fkey,
                                bad,
                                problem,
                                hint,
                            )?
                        }
                        RawFactor::Color(_) => {
                            return Err(self.error(
                                f.span(),
                                &format!("{key}.factor"),
                                "the factor of a scalar parameter is one number",
                                "Give `factor = 0.5`, say; [r, g, b] factors are for colours.",
                            ));
                        }
                    },
                };
                *slot = Some(r);
                Ok(factor)
            }
        }
    }

    /// A texture reference: the image (relative to the scene file, read once however many references
    /// name it) and how it is read; with `modifier` (bump, normal_map), also the modifier's `scale`.
    fn texture_ref(
        &self,
        t: &RawTextureRef,
        key: &str,
        colour: bool,
        modifier: bool,
        files: &mut Files,
    ) -> Result<(TextureRef, Option<f32>), SceneError> {
        use super::texture::{Channel, TextureFilter, Wrap};
        let sub = |field: &str| format!("{key}.{field}");
        let image = self.mesh_texture(
            &t.texture,
            &sub("texture"),
            files.base,
            &mut files.loaded,
            "The path is relative to the scene file; PNG, JPEG, EXR and HDR images are read.",
        )?;
        let mut r = TextureRef::plain(image, colour);
        if !colour {
            r.channel = Channel::R;
        }
        let choose = |v: &Option<Spanned<String>>, field: &str, names: &[&str]| {
            let Some(v) = v else { return Ok(None) };
            let given = v.get_ref().as_str();
            match names.iter().position(|n| *n == given) {
                Some(i) => Ok(Some(i)),
                None => Err(self.error(
                    v.span(),
                    &sub(field),
                    format!("unknown {field} \"{given}\""),
                    format!(
                        "Use one of {}.",
                        names
                            .iter()
                            .map(|n| format!("\"{n}\""))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )),
            }
        };
        let names: Vec<&str> = Channel::ALL.iter().map(|(_, n)| *n).collect();
        if let Some(i) = choose(&t.channel, "channel", &names)? {
            r.channel = Channel::ALL[i].0;
        }
        if let Some(i) = choose(&t.color_space, "color_space", &["srgb", "linear"])? {
            r.srgb = i == 0;
        }
        if let Some(i) = choose(&t.filter, "filter", &["bilinear", "nearest"])? {
            r.filter = [TextureFilter::Bilinear, TextureFilter::Nearest][i];
        }
        if let Some(i) = choose(&t.wrap, "wrap", &["repeat", "clamp", "mirror"])? {
            r.wrap = [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror][i];
        }
        let vec2 = |v: &Spanned<RawVec2>, field: &str| -> Result<[f32; 2], SceneError> {
            let [a, b] = v.get_ref().0;
            if !(a.is_finite() && b.is_finite()) {
                return Err(self.not_finite(v.span(), &sub(field), &format!("[{a}, {b}]")));
            }
            Ok([a, b])
        };
        let mut modifier_scale = None;
        if let Some(sc) = &t.scale {
            match sc.get_ref() {
                RawScale::Uv(uv) if !modifier => {
                    r.scale = vec2(&Spanned::new(sc.span(), *uv), "scale")?
                }
                RawScale::Number(x) if modifier => {
                    modifier_scale = Some(self.number(&Spanned::new(sc.span(), *x), &sub("scale"))?)
                }
                _ if modifier => {
                    return Err(self.error(
                        sc.span(),
                        &sub("scale"),
                        "a bump or normal map's scale is one number",
                        "`scale` is the bump map's height per unit of texel (scene units), or the normal map's \
                         factor of x and y; the uv scale of a modifier's texture is `uv_scale = [su, sv]`.",
                    ));
                }
                _ => {
                    return Err(self.error(
                        sc.span(),
                        &sub("scale"),
                        "a texture's scale is an array [su, sv]",
                        "uv' = R(rotation) (scale * uv) + offset; give `scale = [4.0, 4.0]` to repeat the image 4 times each way.",
                    ));
                }
            }
        }
        if let Some(uv) = &t.uv_scale {
            if !modifier {
                return Err(self.error(
                    uv.span(),
                    &sub("uv_scale"),
                    "uv_scale is for bump and normal maps, whose `scale` is a number",
                    "A parameter's texture takes its uv scale as `scale = [su, sv]`.",
                ));
            }
            r.scale = vec2(uv, "uv_scale")?;
        }
        if let Some(o) = &t.offset {
            r.offset = vec2(o, "offset")?;
        }
        if let Some(rot) = &t.rotation {
            r.rotation_deg = self.number(rot, &sub("rotation"))?;
        }
        if let (true, Some(f)) = (modifier, &t.factor) {
            return Err(self.error(
                f.span(),
                &sub("factor"),
                "a bump or normal map takes `scale`, not `factor`",
                "Give the bump height per unit of texel (or the normal map's strength) as `scale`.",
            ));
        }
        Ok((r, modifier_scale))
    }

    /// An index of refraction: finite and > 0.
    fn ior(&self, ior: &Spanned<f32>, key: &str) -> Result<f32, SceneError> {
        self.number_unless(
            ior,
            key,
            |ior| ior <= 0.0,
            "the index of refraction must be > 0",
            "Glass is about 1.5, water 1.33; the outside medium has ior 1.",
        )
    }

    /// A colour whose components are reflectances, in [0, 1] (or a texture, whose factor is).
    fn unit_color(
        &self,
        c: &Spanned<RawParam<RawVec3>>,
        key: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Vec3, SceneError> {
        self.color_param(
            c,
            key,
            |a| !in_unit_range(a),
            "every component must be in [0, 1]",
            "A reflectance is the fraction of light reflected per channel; energy conservation needs it in [0, 1].",
            files,
            slot,
        )
    }

    /// `roughness`: absent (smooth), one number or two, each in [0, 1], or a texture (both axes; its
    /// factor, default 1, is the constant).
    fn roughness(
        &self,
        raw: &Option<Spanned<RawRoughness>>,
        key: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Roughness, SceneError> {
        let Some(r) = raw else {
            return Ok(Roughness::SMOOTH);
        };
        let (u, v) = match r.get_ref() {
            RawRoughness::Isotropic(x) => (*x, *x),
            RawRoughness::Anisotropic(u, v) => (*u, *v),
            RawRoughness::Texture(t) => {
                let param = Spanned::new(r.span(), RawParam::<f32>::Texture(t.clone()));
                let x = self.scalar_param(
                    &param,
                    key,
                    |x| !(0.0..=1.0).contains(&x),
                    "roughness must be in [0, 1]",
                    "The texture's value times its factor is the roughness: 0 smooth, 1 the roughest.",
                    files,
                    slot,
                )?;
                (x, x)
            }
        };
        for x in [u, v] {
            if !x.is_finite() {
                return Err(self.not_finite(r.span(), key, &x.to_string()));
            }
            self.reject_if(
                r,
                key,
                x,
                |x| !(0.0..=1.0).contains(&x),
                "roughness must be in [0, 1]",
                "0 is a perfectly smooth surface, 1 the roughest (GGX alpha = roughness^2); \
                 [u, v] gives a different roughness along the tangent and the bitangent.",
            )?;
        }
        Ok(Roughness { u, v })
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

    fn sphere(&self, i: usize, raw: &RawSphere, names: &[String]) -> Result<Sphere, SceneError> {
        let center = self.vec3(&raw.center, &format!("sphere[{i}].center"))?;
        let radius = self.positive_radius(&raw.radius, &format!("sphere[{i}].radius"), "sphere")?;
        let material =
            self.material_index(&raw.material, &format!("sphere[{i}].material"), names)?;
        Ok(Sphere {
            center,
            radius,
            material,
        })
    }

    fn triangle(
        &self,
        i: usize,
        raw: &RawTriangle,
        names: &[String],
    ) -> Result<Triangle, SceneError> {
        let given = raw.vertices.get_ref();
        if given.len() != 3 {
            return Err(self.error(
                raw.vertices.span(),
                &format!("triangle[{i}].vertices"),
                format!("a triangle needs exactly 3 vertices, got {}", given.len()),
                "Give vertices as [[x, y, z], [x, y, z], [x, y, z]], counter-clockwise seen from the front.",
            ));
        }
        let mut vertices = [Vec3::ZERO; 3];
        for (j, (slot, vertex)) in vertices.iter_mut().zip(given).enumerate() {
            *slot = self.vec3(vertex, &format!("triangle[{i}].vertices[{j}]"))?;
        }
        // A zero-area triangle is allowed: rays never hit it, so it is harmless.
        let material =
            self.material_index(&raw.material, &format!("triangle[{i}].material"), names)?;
        Ok(Triangle { vertices, material })
    }

    /// A `[[mesh]]`: the OBJ read and placed, its normals and texture resolved. OBJ problems are reported
    /// at the `obj` key, with the OBJ's own file and line in the message.
    fn mesh(
        &self,
        i: usize,
        raw: &Spanned<RawMesh>,
        names: &[String],
        materials: &[Material],
        base: &Path,
        files: &mut LoadedFiles,
    ) -> Result<MeshTable, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("mesh[{i}].{field}");
        let material = match &m.material {
            Some(name) => Some(self.material_index(name, &key("material"), names)?),
            None => None,
        };
        let scale = m.scale.as_ref().map_or(Ok(1.0), |s| {
            self.number_unless(
                s,
                &key("scale"),
                |s| s <= 0.0,
                "the scale must be > 0",
                "scale is a uniform factor applied to the OBJ's coordinates; 1 keeps them.",
            )
        })?;
        let rotate_deg = m
            .rotate
            .as_ref()
            .map_or(Ok(glam::Vec3::ZERO), |r| self.vec3(r, &key("rotate")))?;
        let translate = m
            .translate
            .as_ref()
            .map_or(Ok(glam::Vec3::ZERO), |t| self.vec3(t, &key("translate")))?;
        let smooth = m.smooth.as_ref().is_none_or(|s| *s.get_ref());

        let obj_path = base.join(m.obj.get_ref());
        let obj = match files.objs.get(&obj_path) {
            Some(obj) => obj.clone(),
            None => {
                let loaded = mesh_file::load_mesh_file(&obj_path).map_err(|e| {
                    let at = e.line.map_or(String::new(), |l| format!(", line {l}"));
                    let hint = if mesh_file::is_gltf(&obj_path) {
                        "The path is relative to the scene file. A glTF 2.0 file (.gltf with its buffers, or .glb) \
                         needs a scene with at least one mesh of TRIANGLES primitives."
                    } else if mesh_file::is_ply(&obj_path) {
                        "The path is relative to the scene file. A PLY mesh (ascii or binary, version 1.0) needs \
                         `element vertex` with x, y, z (nx, ny, nz and u, v optional) and `element face` with a \
                         `vertex_indices` list, all numbers finite."
                    } else {
                        "The path is relative to the scene file. The OBJ must have `v x y z` vertices and `f` faces \
                         with 1-based indices (`vt u v` and `vn x y z` optional), all numbers finite."
                    };
                    self.error(
                        m.obj.span(),
                        &key("obj"),
                        format!("{}{at}: {}", obj_path.display(), e.message),
                        hint,
                    )
                })?;
                let loaded = Arc::new(loaded);
                files.objs.insert(obj_path.clone(), loaded.clone());
                loaded
            }
        };

        let texture = match (&m.texture, material) {
            (None, _) => None,
            (Some(t), None) => {
                return Err(self.error(
                    t.span(),
                    &key("texture"),
                    "a texture is given but no material for it to apply to",
                    "Give the mesh a `material` as well; without one, the OBJ's MTL materials are used, with \
                     their own map_Kd textures.",
                ));
            }
            (Some(t), Some(material)) => {
                let tkey = key("texture");
                // The texture replaces the albedo (or tint) and multiplies the emission: a material with
                // neither has nothing for it to change.
                let untexturable = match materials.get(material as usize) {
                    Some(Material {
                        bsdf: Bsdf::Dielectric { .. },
                        emission: None,
                        ..
                    }) => Some("a dielectric that does not emit"),
                    Some(Material {
                        bsdf:
                            Bsdf::Conductor {
                                fresnel: ConductorFresnel::Complex { .. },
                                ..
                            },
                        emission: None,
                        ..
                    }) => Some("a conductor given by its index of refraction that does not emit"),
                    _ => None,
                };
                if let Some(what) = untexturable {
                    return Err(self.error(
                        t.span(),
                        &tkey,
                        format!(
                            "material \"{}\" is {what}: it has no albedo for a texture to replace and no emission for it to multiply",
                            names[material as usize]
                        ),
                        "Give textured meshes a diffuse or plastic material (the texture is the albedo), a mirror (the tint), a metallic_roughness material or a conductor with base_color (the texture is the base colour) or an emitting material (the texture multiplies the emission).",
                    ));
                }
                if obj.uvs.is_none() {
                    return Err(self.error(
                        t.span(),
                        &tkey,
                        format!(
                            "{} has no texture coordinates (`vt`) for every face corner, so the texture cannot be mapped",
                            obj_path.display()
                        ),
                        "Export the OBJ with uvs (faces written `v/vt` or `v/vt/vn`), or remove `texture`.",
                    ));
                }
                Some(self.mesh_texture(
                    t,
                    &tkey,
                    base,
                    files,
                    "The path is relative to the scene file; the texture must be a PNG image (sRGB).",
                )?)
            }
        };

        // The glTF-style maps (docs/scene-format.md, "[[mesh]]"): each needs the mesh's `material`, a
        // material it can change, and the mesh's uvs.
        let mut maps = MeshMaps {
            normal_scale: 1.0,
            ..MeshMaps::default()
        };
        let given = [
            ("emission_texture", &m.emission_texture),
            ("metallic_roughness_texture", &m.metallic_roughness_texture),
            ("normal_map", &m.normal_map),
        ];
        for (field, t) in given {
            let Some(t) = t else { continue };
            let tkey = key(field);
            let Some(material) = material else {
                return Err(self.error(
                    t.span(),
                    &tkey,
                    format!("`{field}` is given but no material for it to apply to"),
                    "Give the mesh a `material` as well.",
                ));
            };
            let mat = materials.get(material as usize);
            let unfit = match field {
                "emission_texture" if mat.is_some_and(|m| m.emission.is_none()) => {
                    Some("does not emit: there is no emission for the texture to multiply")
                }
                "metallic_roughness_texture"
                    if !mat.is_some_and(|m| matches!(m.bsdf, Bsdf::MetallicRoughness { .. })) =>
                {
                    Some(
                        "is not a metallic_roughness material: it has no metallic and roughness for the texture to scale",
                    )
                }
                _ => None,
            };
            if let Some(why) = unfit {
                return Err(self.error(
                    t.span(),
                    &tkey,
                    format!("material \"{}\" {why}", names[material as usize]),
                    "emission_texture needs an emitting material (an `emission`, or an emitter), metallic_roughness_texture a metallic_roughness material.",
                ));
            }
            if obj.uvs.is_none() {
                return Err(self.error(
                    t.span(),
                    &tkey,
                    format!(
                        "{} has no texture coordinates (`vt`) for every face corner, so `{field}` cannot be mapped",
                        obj_path.display()
                    ),
                    "Export the OBJ with uvs (faces written `v/vt` or `v/vt/vn`), or remove the key.",
                ));
            }
            let tex = self.mesh_texture(
                t,
                &tkey,
                base,
                files,
                "The path is relative to the scene file; data maps (metallic_roughness_texture, normal_map) are read as stored, so give them as PNG (8-bit, not sRGB-decoded).",
            )?;
            match field {
                "emission_texture" => maps.emissive = Some(tex),
                "metallic_roughness_texture" => maps.metallic_roughness = Some(tex),
                _ => maps.normal = Some(tex),
            }
        }
        if let Some(s) = &m.normal_scale {
            if m.normal_map.is_none() {
                return Err(self.error(
                    s.span(),
                    &key("normal_scale"),
                    "normal_scale is given without a normal_map",
                    "Give the mesh a `normal_map`, or remove `normal_scale`.",
                ));
            }
            maps.normal_scale = self.number(s, &key("normal_scale"))?;
        }

        let placement = Placement {
            scale,
            rotate_deg,
            translate,
        };
        let place =
            |obj: &ObjMesh, material: u32, texture: Option<Arc<Texture>>, maps: MeshMaps| {
                // (Texture coordinates are kept for the material's own textures too.)
                let textured = texture.is_some()
                    || !materials
                        .get(material as usize)
                        .is_none_or(|m| m.textures.is_plain())
                    || maps.emissive.is_some()
                    || maps.metallic_roughness.is_some()
                    || maps.normal.is_some();
                let (positions, normals, uvs) = mesh::place(obj, &placement, smooth, textured);
                if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
                    return Err(self.error(
                        raw.span(),
                        &format!("mesh[{i}]"),
                        format!(
                            "placing {} overflows 32-bit floats (a vertex lands at {p})",
                            obj_path.display()
                        ),
                        "Use a smaller scale or translation.",
                    ));
                }
                Ok(Mesh {
                    obj: obj_path.clone(),
                    positions,
                    normals,
                    uvs,
                    triangles: obj.triangles.clone(),
                    material,
                    texture,
                    maps,
                })
            };
        let mut table = MeshTable::default();
        table.warnings.extend(
            obj.notes
                .iter()
                .map(|n| format!("mesh[{i}]: {}: {n}", obj_path.display())),
        );
        if let Some(material) = material {
            // The scene's material applies to every face, whatever the OBJ's MTL says.
            table.meshes.push(place(&obj, material, texture, maps)?);
            return Ok(table);
        }
        if obj.materials.is_empty() {
            let Some(problem) = &obj.mtl_problem else {
                return Err(self.error(
                    raw.span(),
                    &format!("mesh[{i}]"),
                    format!(
                        "mesh[{i}] needs a material: {} has no materials of its own (MTL or glTF)",
                        obj_path.display()
                    ),
                    "Give the mesh `material = \"name\"`, one of the names in [materials].",
                ));
            };
            table.warnings.push(format!(
                "mesh[{i}]: {problem}; its faces are diffuse grey (albedo 0.8, MTL's default Kd). Give the mesh a `material` to choose one."
            ));
        }
        // One mesh per MTL material, in the order the faces first use them (faces with none, or when no
        // MTL file could be read, get MTL's default: diffuse, Kd 0.8).
        let mut groups: Vec<Option<u32>> = Vec::new();
        for t in 0..obj.triangles.len() {
            let id = obj.face_materials.get(t).copied().flatten();
            if !groups.contains(&id) {
                groups.push(id);
            }
        }
        let obj_dir = obj_path.parent().unwrap_or(Path::new("."));
        for id in groups {
            let index = (names.len() + table.materials.len()) as u32;
            let (name, material, texture, maps) = match id.map(|k| &obj.materials[k as usize]) {
                None => (
                    format!("mesh[{i}]/default"),
                    Material::from(Bsdf::Diffuse {
                        albedo: Vec3::splat(0.8),
                    }),
                    None,
                    MeshMaps::default(),
                ),
                Some(mtl) => {
                    let (material, clipped) = mtl_material(mtl);
                    if clipped {
                        table.warnings.push(format!(
                            "mesh[{i}]: {}: MTL material \"{}\" has colours outside [0, 1] or non-finite values; they were clipped",
                            obj_path.display(),
                            mtl.name
                        ));
                    }
                    let texture = match &mtl.diffuse_texture {
                        _ if mtl.texture.is_some() && obj.uvs.is_some() => mtl.texture.clone(),
                        None if mtl.texture.is_some() => {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: material \"{}\" has a texture but the file has no texture coordinates for every vertex; the texture is not used",
                                obj_path.display(),
                                mtl.name
                            ));
                            None
                        }
                        None => None,
                        Some(_) if obj.uvs.is_none() => {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: MTL material \"{}\" has a map_Kd but the OBJ has no texture coordinates; the texture is not used",
                                obj_path.display(),
                                mtl.name
                            ));
                            None
                        }
                        Some(file) => {
                            let texture_path = obj_dir.join(file.trim());
                            match files.textures.get(&texture_path) {
                                Some(tex) => Some(tex.clone()),
                                None => match load_texture(&texture_path) {
                                    Ok(tex) => {
                                        let tex = Arc::new(tex);
                                        files.textures.insert(texture_path, tex.clone());
                                        Some(tex)
                                    }
                                    Err(e) => {
                                        table.warnings.push(format!(
                                            "mesh[{i}]: MTL material \"{}\": {e}; the texture is not used",
                                            mtl.name
                                        ));
                                        None
                                    }
                                },
                            }
                        }
                    };
                    // glTF's other textures need the texture coordinates too.
                    let mut maps = mtl.maps.clone();
                    if obj.uvs.is_none() {
                        if maps.emissive.is_some()
                            || maps.metallic_roughness.is_some()
                            || maps.normal.is_some()
                        {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: material \"{}\" has an emissive, metallic-roughness or normal texture but the file has no texture coordinates for every vertex; it is not used",
                                obj_path.display(),
                                mtl.name
                            ));
                        }
                        maps.emissive = None;
                        maps.metallic_roughness = None;
                        maps.normal = None;
                    }
                    (format!("mesh[{i}]/{}", mtl.name), material, texture, maps)
                }
            };
            // A texture replaces the albedo; a glass has none: the map is not used.
            let texture = match (&material.bsdf, texture) {
                (Bsdf::Dielectric { .. }, Some(_)) if material.emission.is_none() => None,
                (_, t) => t,
            };
            let sub = obj.subset(id);
            table.meshes.push(place(&sub, index, texture, maps)?);
            table.materials.push((name, material));
        }
        Ok(table)
    }

    /// The image file `t` names (relative to the scene file), read once however many keys name it.
    fn mesh_texture(
        &self,
        t: &Spanned<String>,
        key: &str,
        base: &Path,
        files: &mut LoadedFiles,
        hint: &str,
    ) -> Result<Arc<Texture>, SceneError> {
        let path = base.join(t.get_ref());
        if let Some(tex) = files.textures.get(&path) {
            return Ok(tex.clone());
        }
        let tex = load_texture(&path).map_err(|e| self.error(t.span(), key, e, hint))?;
        let tex = Arc::new(tex);
        files.textures.insert(path, tex.clone());
        Ok(tex)
    }

    fn light(&self, i: usize, raw: &Spanned<RawLight>) -> Result<Light, SceneError> {
        let l = raw.get_ref();
        let key = |field: &str| format!("light[{i}].{field}");
        let kind = l.kind.get_ref().as_str();
        // Point and sphere lights are given by their power; a sun by its irradiance.
        let power = || -> Result<f32, SceneError> {
            let power = self.required(
                &l.power,
                raw,
                &key("power"),
                &format!("a {kind} light needs a power"),
            )?;
            self.number_unless(
                power,
                &key("power"),
                |p| p <= 0.0,
                "a light's power must be > 0",
                "power is the light's total emitted flux in watts; remove the light rather than giving it no power.",
            )
        };
        let color = l.color.as_ref().map_or(Ok(Vec3::ONE), |c| {
            self.vec3_unless(
                c,
                &key("color"),
                |c| c.min_element() < 0.0,
                "light color components cannot be negative",
                "color multiplies power per channel; use components >= 0 ([1, 1, 1] is white).",
            )
        })?;
        let (allowed, light): (&[&str], _) = match kind {
            "point" => {
                let power = power()?;
                let position = self.required(
                    &l.position,
                    raw,
                    &key("position"),
                    "a point light needs a position",
                )?;
                let position = self.vec3(position, &key("position"))?;
                (
                    &["position", "power"],
                    Light::Point {
                        position,
                        power,
                        color,
                    },
                )
            }
            "sphere" => {
                let power = power()?;
                let center = self.required(
                    &l.center,
                    raw,
                    &key("center"),
                    "a sphere light needs a center",
                )?;
                let center = self.vec3(center, &key("center"))?;
                let radius = self.required(
                    &l.radius,
                    raw,
                    &key("radius"),
                    "a sphere light needs a radius",
                )?;
                let radius_span = radius.span();
                let radius = self.positive_radius(radius, &key("radius"), "sphere light")?;
                // The shader works with the light's radiance P / (4 pi^2 r^2) in f32: a radius so small
                // that it overflows (r below ~1e-18) cannot be rendered as a sphere.
                let radiance =
                    power as f64 / (4.0 * std::f64::consts::PI.powi(2) * (radius as f64).powi(2));
                if radiance > f32::MAX as f64 / 16.0
                    || (radius as f64).powi(2) < f32::MIN_POSITIVE as f64
                {
                    return Err(self.error(
                        radius_span,
                        &key("radius"),
                        format!(
                            "a sphere light of radius {radius} and power {power} W has a radiance of {radiance:e}, \
                             beyond what 32-bit floats hold"
                        ),
                        "Use a point light for a source this small (it is the same light as the radius goes to 0).",
                    ));
                }
                (
                    &["center", "radius", "power"],
                    Light::Sphere {
                        center,
                        radius,
                        power,
                        color,
                    },
                )
            }
            "directional" => (
                &["direction", "irradiance", "angle"],
                self.directional_light(raw, &key, color)?,
            ),
            other => {
                return Err(self.error(
                    l.kind.span(),
                    &key("type"),
                    format!("unknown light type \"{other}\""),
                    "Use \"point\" (with position), \"sphere\" (with center and radius) or \"directional\" \
                     (with direction and irradiance).",
                ));
            }
        };
        let present = [
            ("position", l.position.as_ref().map(Spanned::span)),
            ("center", l.center.as_ref().map(Spanned::span)),
            ("radius", l.radius.as_ref().map(Spanned::span)),
            ("power", l.power.as_ref().map(Spanned::span)),
            ("direction", l.direction.as_ref().map(Spanned::span)),
            ("irradiance", l.irradiance.as_ref().map(Spanned::span)),
            ("angle", l.angle.as_ref().map(Spanned::span)),
        ];
        self.reject_foreign_keys(
            &present,
            allowed,
            &format!("light[{i}]"),
            &format!("a {kind} light"),
        )?;
        Ok(light)
    }

    /// `type = "directional"`: a sun (see [`Light::Directional`]).
    fn directional_light(
        &self,
        raw: &Spanned<RawLight>,
        key: &dyn Fn(&str) -> String,
        color: Vec3,
    ) -> Result<Light, SceneError> {
        let l = raw.get_ref();
        let direction = self.required(
            &l.direction,
            raw,
            &key("direction"),
            "a directional light needs a direction",
        )?;
        let d = self.vec3(direction, &key("direction"))?;
        let length = d.as_dvec3().length();
        if !(length > 0.0 && length.is_finite() && (d.as_dvec3() / length).as_vec3().is_finite()) {
            return Err(self.error(
                direction.span(),
                &key("direction"),
                format!("the direction [{}, {}, {}] has no length", d.x, d.y, d.z),
                "Give the direction the light travels in, e.g. [0, -1, 0] for light from straight above.",
            ));
        }
        let irradiance = self.required(
            &l.irradiance,
            raw,
            &key("irradiance"),
            "a directional light needs an irradiance",
        )?;
        let irradiance = self.number_unless(
            irradiance,
            &key("irradiance"),
            |e| e <= 0.0,
            "a directional light's irradiance must be > 0",
            "irradiance is in W/m^2 on a surface facing the light (the sun gives about 1000).",
        )?;
        let angle_deg = match &l.angle {
            None => 0.0,
            Some(a) => self.number_unless(
                a,
                &key("angle"),
                |a| !(0.0..180.0).contains(&a),
                "the angular diameter must be in [0, 180) degrees",
                "Use 0 for a delta light (sharp shadows) or the source's angular diameter (the sun: 0.53).",
            )?,
        };
        Ok(Light::Directional {
            direction: (d.as_dvec3() / length).as_vec3(),
            irradiance,
            color,
            angle_deg,
        })
    }

    // ----- small checks shared by the rules above -----

    /// A number that must be finite: TOML allows `nan` and `inf`, and a value beyond f32's range
    /// (about 3.4e38) has already become infinite by the time we see it.
    fn number(&self, v: &Spanned<f32>, key: &str) -> Result<f32, SceneError> {
        let value = *v.get_ref();
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.not_finite(v.span(), key, &value.to_string()))
        }
    }

    /// Three finite numbers.
    fn vec3(&self, v: &Spanned<RawVec3>, key: &str) -> Result<Vec3, SceneError> {
        let RawVec3(xyz) = *v.get_ref();
        if xyz.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from_array(xyz))
        } else {
            let shown = format!("[{}, {}, {}]", xyz[0], xyz[1], xyz[2]);
            Err(self.not_finite(v.span(), key, &shown))
        }
    }

    fn not_finite(&self, span: Range<usize>, key: &str, shown: &str) -> SceneError {
        self.error(
            span,
            key,
            format!("every number must be finite, got {shown}"),
            "TOML allows nan and inf, but a scene needs finite numbers within the 32-bit float range (about ±3.4e38).",
        )
    }

    /// An integer in `min..=max`, checked in i64 so that no value can overflow on the way.
    fn integer(
        &self,
        v: &Spanned<i64>,
        key: &str,
        min: u32,
        max: u32,
        hint: &str,
    ) -> Result<u32, SceneError> {
        let value = *v.get_ref();
        let name = key.rsplit('.').next().unwrap_or(key);
        let out_of_range = || {
            self.error(
                v.span(),
                key,
                format!("{name} must be an integer from {min} to {max}, got {value}"),
                hint,
            )
        };
        if value < i64::from(min) || value > i64::from(max) {
            return Err(out_of_range());
        }
        // In range, so the conversion cannot fail; the impossible case still gets the same error.
        u32::try_from(value).map_err(|_| out_of_range())
    }

    fn positive_radius(&self, v: &Spanned<f32>, key: &str, what: &str) -> Result<f32, SceneError> {
        self.number_unless(
            v,
            key,
            |r| r <= 0.0,
            "the radius must be > 0",
            &format!("Give every {what} a positive radius in scene units."),
        )
    }

    /// A finite number that `bad` does not reject (see [`Checker::reject_if`]).
    fn number_unless(
        &self,
        v: &Spanned<f32>,
        key: &str,
        bad: impl FnOnce(f32) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<f32, SceneError> {
        let value = self.number(v, key)?;
        self.reject_if(v, key, value, bad, problem, hint)
    }

    /// Three finite numbers that `bad` does not reject (see [`Checker::reject_if`]).
    fn vec3_unless(
        &self,
        v: &Spanned<RawVec3>,
        key: &str,
        bad: impl FnOnce(Vec3) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<Vec3, SceneError> {
        let value = self.vec3(v, key)?;
        self.reject_if(v, key, value, bad, problem, hint)
    }

    /// `value`, read from `v`, unless `bad(value)`: then an error at `v` saying `{problem}, got {value}`.
    fn reject_if<T: Copy + fmt::Display, S>(
        &self,
        v: &Spanned<S>,
        key: &str,
        value: T,
        bad: impl FnOnce(T) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<T, SceneError> {
        if bad(value) {
            Err(self.error(v.span(), key, format!("{problem}, got {value}"), hint))
        } else {
            Ok(value)
        }
    }

    /// A key that serde treats as optional because only some `type`s need it. Reported like serde's
    /// missing keys: at the line of the table that lacks it.
    fn required<'v, T>(
        &self,
        value: &'v Option<Spanned<T>>,
        table: &Spanned<impl Sized>,
        key: &str,
        problem: &str,
    ) -> Result<&'v Spanned<T>, SceneError> {
        value.as_ref().ok_or_else(|| {
            self.error(
                table.span(),
                key,
                format!("{problem}, but the key is missing"),
                format!(
                    "Add `{}`. {SEE_CONTRACT}",
                    key.rsplit('.').next().unwrap_or(key)
                ),
            )
        })
    }

    /// Errors on the first present key (in file order) that `allowed` does not list.
    fn reject_foreign_keys(
        &self,
        present: &[(&str, Option<Range<usize>>)],
        allowed: &[&str],
        table_key: &str,
        what: &str,
    ) -> Result<(), SceneError> {
        let first_foreign = present
            .iter()
            .filter(|(name, _)| !allowed.contains(name))
            .filter_map(|(name, span)| span.clone().map(|span| (*name, span)))
            .min_by_key(|(_, span)| span.start);
        match first_foreign {
            None => Ok(()),
            Some((name, span)) => Err(self.error(
                span,
                &format!("{table_key}.{name}"),
                format!("{what} has no `{name}`"),
                format!("Remove `{name}`, or change the type. {SEE_CONTRACT}"),
            )),
        }
    }

    /// Resolves a material name to its index in `names` (file order).
    fn material_index(
        &self,
        name: &Spanned<String>,
        key: &str,
        names: &[String],
    ) -> Result<u32, SceneError> {
        let wanted = name.get_ref();
        let Some(index) = names.iter().position(|n| n == wanted) else {
            let defined = if names.is_empty() {
                "no materials are defined".to_string()
            } else {
                let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
                format!("the defined materials are {}", quoted.join(", "))
            };
            return Err(self.error(
                name.span(),
                key,
                format!("material \"{wanted}\" is not defined ({defined})"),
                "Use one of the names in [materials], or define this one there.",
            ));
        };
        u32::try_from(index).map_err(|_| {
            self.error(
                name.span(),
                key,
                "too many materials for a 32-bit index",
                "Use fewer materials.",
            )
        })
    }

    // ----- turning positions into errors -----

    /// The 1-based line of a byte offset.
    fn line_of(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        1 + self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    }

    fn error(
        &self,
        span: Range<usize>,
        key: &str,
        problem: impl Into<String>,
        hint: impl Into<String>,
    ) -> SceneError {
        SceneError::new(
            self.file.clone(),
            Some(self.line_of(span.start)),
            Some(key.to_string()),
            problem,
            hint,
        )
    }

    /// Step 1 failed: the text is not TOML. There is no tree to look the key up in, so the key is read
    /// off the offending line when it looks like `key = ...`.
    fn syntax_error(&self, e: &toml::de::Error) -> SceneError {
        let offset = e.span().map_or(0, |s| s.start);
        SceneError::new(
            self.file.clone(),
            Some(self.line_of(offset)),
            guess_key_at(self.text, offset),
            format!("this is not valid TOML: {}", e.message()),
            "Fix the TOML syntax at this line (https://toml.io).",
        )
    }

    /// Step 2 failed: the TOML does not have the scene's shape. serde's message names the key for
    /// unknown and missing keys; otherwise the span points at the offending value.
    fn shape_error(&self, e: &toml::de::Error, tree: &DeTable<'_>) -> SceneError {
        let message = e.message();
        let span = e.span().unwrap_or(0..0);
        let line = Some(self.line_of(span.start));
        let exact = find_key_path(tree, "", &|s: &Range<usize>| *s == span);

        if let Some(field) = backticked_after(message, "missing field `") {
            // The span is the table that lacks the key (the document root has the empty span 0..0,
            // which matches nothing, so it falls back to the empty path).
            let key = join_key(exact.as_deref().unwrap_or(""), field);
            let problem = format!("the required key `{field}` is missing");
            return SceneError::new(
                self.file.clone(),
                line,
                Some(key),
                problem,
                format!("Add `{field}`. {SEE_CONTRACT}"),
            );
        }
        if let Some(field) = backticked_after(message, "unknown field `") {
            // The span is the unknown key itself; serde lists the keys allowed there.
            let key = exact.unwrap_or_else(|| field.to_string());
            let allowed = message
                .split_once(", expected ")
                .map_or(String::new(), |(_, list)| {
                    format!(" (allowed here: {list})")
                });
            let problem = format!("unknown key `{field}`{allowed}");
            let hint = format!("Remove it or fix its spelling. {SEE_CONTRACT}");
            return SceneError::new(self.file.clone(), line, Some(key), problem, hint);
        }

        // A wrong type or length: the span is the value. Prefer the node with exactly that span, else
        // the innermost node containing its start.
        let key =
            exact.or_else(|| find_key_path(tree, "", &|s: &Range<usize>| s.contains(&span.start)));
        SceneError::new(
            self.file.clone(),
            line,
            key,
            plain_words(message),
            SEE_CONTRACT,
        )
    }
}

/// OBJ files and textures already read while checking this scene, by resolved path.
#[derive(Default)]
struct LoadedFiles {
    objs: HashMap<PathBuf, Arc<ObjMesh>>,
    textures: HashMap<PathBuf, Arc<Texture>>,
}

/// The files a scene reads besides itself (meshes, images), relative to `base` (the scene file's
/// directory), each read once however many keys name it.
struct Files<'a> {
    base: &'a Path,
    loaded: LoadedFiles,
}

fn in_unit_range(v: Vec3) -> bool {
    v.min_element() >= 0.0 && v.max_element() <= 1.0
}

// f64 helpers for the camera checks (glam's DVec3 would do too; these keep the f32 -> f64 step visible).

fn sub64(a: Vec3, b: Vec3) -> [f64; 3] {
    [
        f64::from(a.x) - f64::from(b.x),
        f64::from(a.y) - f64::from(b.y),
        f64::from(a.z) - f64::from(b.z),
    ]
}

fn length64(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn scale64(v: [f64; 3], s: f64) -> [f64; 3] {
    [v[0] * s, v[1] * s, v[2] * s]
}

fn cross64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

// ---------------------------------------------------------------------------------------------------
// Locating keys
// ---------------------------------------------------------------------------------------------------

fn join_key(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// The dotted path (`sphere[1].center`) of the innermost key or value in `table` whose span satisfies
/// `hit`. Children are searched before their parent so that the most specific key wins; this matters
/// because a `[table]`'s span is only its header, and an array of tables shares its span with its first
/// element.
fn find_key_path(
    table: &DeTable<'_>,
    path: &str,
    hit: &dyn Fn(&Range<usize>) -> bool,
) -> Option<String> {
    table.iter().find_map(|(key, value)| {
        let key_path = join_key(path, key.get_ref());
        find_in_value(value, &key_path, hit).or_else(|| hit(&key.span()).then_some(key_path))
    })
}

fn find_in_value(
    value: &Spanned<DeValue<'_>>,
    path: &str,
    hit: &dyn Fn(&Range<usize>) -> bool,
) -> Option<String> {
    let inside = match value.get_ref() {
        DeValue::Table(table) => find_key_path(table, path, hit),
        DeValue::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, item)| find_in_value(item, &format!("{path}[{i}]"), hit)),
        _ => None,
    };
    inside.or_else(|| hit(&value.span()).then(|| path.to_string()))
}

/// For text that is not valid TOML: the key assigned on the line holding `offset`, prefixed by the
/// table header above it (`camera.fov`, `sphere[1].radius`). Best effort: `None` when the line is not
/// a plain `key = value`.
fn guess_key_at(text: &str, offset: usize) -> Option<String> {
    let bytes = text.as_bytes();
    let offset = offset.min(bytes.len());
    // Newlines are ASCII, so slicing at them always lands on a char boundary.
    let start = bytes[..offset]
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let end = bytes[start..]
        .iter()
        .position(|&b| b == b'\n')
        .map_or(bytes.len(), |i| start + i);
    let line = text[start..end].split('#').next().unwrap_or("").trim();
    let is_bare_key = |s: &str| {
        !s.is_empty()
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    };
    // A broken or duplicated `[table]` header names the table itself.
    if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
        let name = name.trim_matches(['[', ']']).trim();
        return is_bare_key(name).then(|| name.to_string());
    }
    let (lhs, _) = line.split_once('=')?;
    let key = lhs.trim();
    if !is_bare_key(key) {
        return None;
    }

    // The last header before this line decides the prefix; `[[name]]` headers are counted so that the
    // index matches the one the other errors use.
    let mut header: Option<String> = None;
    let mut array_counts: BTreeMap<&str, usize> = BTreeMap::new();
    for line in text[..start].lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if let Some(name) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
            let name = name.trim();
            let count = array_counts.entry(name).or_insert(0);
            header = Some(format!("{name}[{count}]"));
            *count += 1;
        } else if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            header = Some(name.trim().to_string());
        }
    }
    if header
        .as_deref()
        .is_some_and(|h| !is_bare_key(&h.replace(['[', ']'], "")))
    {
        return Some(key.to_string());
    }
    Some(match header {
        Some(h) => join_key(&h, key),
        None => key.to_string(),
    })
}

/// The text between `prefix` and the next backtick, e.g. the field name in "missing field `radius`".
fn backticked_after<'m>(message: &'m str, prefix: &str) -> Option<&'m str> {
    let rest = message.strip_prefix(prefix)?;
    rest.split_once('`').map(|(name, _)| name)
}

/// serde names Rust types in its messages; say what they mean in TOML terms.
fn plain_words(message: &str) -> String {
    // An integer that does not fit the type serde was asked for (i64 for integer keys, and anything
    // beyond i64 for float keys) comes out as "integer `N` as i128, expected f32" and the like.
    let integer = backticked_after(message, "invalid value: integer `")
        .or_else(|| backticked_after(message, "invalid type: integer `"));
    if let Some(digits) = integer
        && (message.contains("` as i128")
            || message.contains("` as u128")
            || message.ends_with("expected i64"))
    {
        return format!("the integer {digits} is out of range");
    }

    let mut words = message
        .replace("invalid type: map", "invalid type: table")
        .replace("expected f32", "expected a number")
        .replace("expected i64", "expected an integer")
        .replace("a sequence", "an array")
        .replace("expected a string", "expected a string in quotes");
    // "expected struct RawCamera" -> "expected a table": the Raw* names mean nothing to a user.
    if let Some(at) = words.find("struct Raw") {
        let rest = &words[at + "struct Raw".len()..];
        let name_len = rest
            .find(|c: char| !c.is_ascii_alphanumeric())
            .unwrap_or(rest.len());
        words.replace_range(at..at + "struct Raw".len() + name_len, "a table");
    }
    words
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The contract's example, minus the `[[mesh]]` table (its OBJ file does not exist here; tests/mesh.rs
    /// loads meshes from real files).
    const CONTRACT_EXAMPLE: &str = r#"
[camera]
position       = [0.0, 0.0, 55.0]
look_at        = [0.0, 0.0, 0.0]
up             = [0.0, 1.0, 0.0]
fov            = 60.0
aperture       = 0.0
focus_distance = 55.0

[image]
width    = 512
height   = 512
exposure = 1.0
gamma    = 2.2

[render]
samples      = 64
max_bounces  = 5
seed         = 0
filter       = "gaussian"
filter_sigma = 0.5
background   = [0.0, 0.0, 0.0]

[materials]
white  = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
mirror = { type = "mirror", tint = [1.0, 1.0, 1.0] }
glass  = { type = "dielectric", ior = 1.5 }

[[sphere]]
center   = [0.0, 0.0, 0.0]
radius   = 10.0
material = "white"

[[triangle]]
vertices = [[-5.0, -5.0, -20.0], [5.0, -5.0, -20.0], [0.0, 5.0, -20.0]]
material = "white"

[[light]]
type     = "point"
position = [-10.0, 20.0, 40.0]
power    = 37699.1
color    = [1.0, 1.0, 1.0]

[[light]]
type   = "sphere"
center = [-10.0, 20.0, 40.0]
radius = 5.0
power  = 37699.1
color  = [1.0, 1.0, 1.0]
"#;

    const MINIMAL: &str = r#"
[camera]
position = [0, 0, 10]
look_at  = [0, 0, 0]
fov      = 45
"#;

    fn parse(text: &str) -> Scene {
        match parse_scene(text, Some(Path::new("test.toml"))) {
            Ok(scene) => scene,
            Err(e) => panic!("scene should parse: {e}"),
        }
    }

    #[test]
    fn contract_example_parses_to_the_written_values() {
        let scene = parse(CONTRACT_EXAMPLE);
        assert_eq!(scene.path.as_deref(), Some(Path::new("test.toml")));
        assert_eq!(
            scene.camera,
            Camera {
                position: Vec3::new(0.0, 0.0, 55.0),
                look_at: Vec3::ZERO,
                up: Vec3::Y,
                projection: Projection::Perspective,
                fov_deg: 60.0,
                extent: 0.0,
                aperture: 0.0,
                focus_distance: 55.0,
            }
        );
        assert_eq!(
            scene.image,
            ImageSettings {
                width: 512,
                height: 512,
                exposure: 1.0,
                gamma: Gamma::Power(2.2),
                tonemap: Tonemap::None,
            }
        );
        assert_eq!(
            scene.render,
            RenderSettings {
                samples: 64,
                max_bounces: 5,
                seed: 0,
                filter: Filter::Gaussian,
                filter_sigma: 0.5,
                sampler: Sampler::Sobol,
                light_sampling: LightSampling::Mis,
                clamp: None,
            }
        );
        assert_eq!(scene.material_names, ["white", "mirror", "glass"]);
        assert_eq!(
            scene.materials,
            [
                Bsdf::Diffuse {
                    albedo: Vec3::splat(0.8)
                }
                .into(),
                Bsdf::Mirror { tint: Vec3::ONE }.into(),
                Bsdf::Dielectric {
                    ior: 1.5,
                    roughness: Roughness::SMOOTH
                }
                .into(),
            ]
        );
        assert_eq!(
            scene.spheres,
            [Sphere {
                center: Vec3::ZERO,
                radius: 10.0,
                material: 0
            }]
        );
        assert_eq!(
            scene.triangles,
            [Triangle {
                vertices: [
                    Vec3::new(-5.0, -5.0, -20.0),
                    Vec3::new(5.0, -5.0, -20.0),
                    Vec3::new(0.0, 5.0, -20.0),
                ],
                material: 0,
            }]
        );
        assert_eq!(
            scene.lights,
            [
                Light::Point {
                    position: Vec3::new(-10.0, 20.0, 40.0),
                    power: 37699.1,
                    color: Vec3::ONE
                },
                Light::Sphere {
                    center: Vec3::new(-10.0, 20.0, 40.0),
                    radius: 5.0,
                    power: 37699.1,
                    color: Vec3::ONE,
                },
            ]
        );
    }

    #[test]
    fn minimal_scene_gets_every_default() {
        let scene = parse(MINIMAL);
        assert_eq!(scene.camera.up, Vec3::Y);
        assert_eq!(scene.camera.aperture, 0.0);
        // The default focus distance is |look_at - position|.
        assert_eq!(scene.camera.focus_distance, 10.0);
        assert_eq!(
            scene.image,
            ImageSettings {
                width: 512,
                height: 512,
                exposure: 1.0,
                gamma: Gamma::Power(2.2),
                tonemap: Tonemap::None,
            }
        );
        assert_eq!(
            scene.render,
            RenderSettings {
                samples: 64,
                max_bounces: 5,
                seed: 0,
                filter: Filter::Gaussian,
                filter_sigma: 0.5,
                sampler: Sampler::Sobol,
                light_sampling: LightSampling::Mis,
                clamp: None,
            }
        );
        assert!(scene.materials.is_empty() && scene.material_names.is_empty());
        assert!(scene.spheres.is_empty() && scene.triangles.is_empty() && scene.lights.is_empty());
    }

    #[test]
    fn partial_tables_default_the_missing_keys() {
        let text = format!(
            "{MINIMAL}\n[image]\nwidth = 320\n[render]\nsamples = 16\n\n[materials]\nm = {{ type = \"mirror\" }}\n\
             [[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = 100\n"
        );
        let scene = parse(&text);
        assert_eq!((scene.image.width, scene.image.height), (320, 512));
        assert_eq!(scene.image.gamma, Gamma::Power(2.2));
        assert_eq!((scene.render.samples, scene.render.max_bounces), (16, 5));
        assert_eq!(scene.materials, [Bsdf::Mirror { tint: Vec3::ONE }.into()]);
        assert_eq!(
            scene.lights,
            [Light::Point {
                position: Vec3::new(0.0, 5.0, 0.0),
                power: 100.0,
                color: Vec3::ONE
            }]
        );
    }

    #[test]
    fn material_indices_follow_file_order_not_name_order() {
        // Names deliberately out of alphabetical order, and objects refer to them out of order too.
        let text = format!(
            r#"{MINIMAL}
[materials]
zinc  = {{ type = "mirror", tint = [0.9, 0.9, 0.9] }}
amber = {{ type = "diffuse", albedo = [0.8, 0.5, 0.1] }}
moss  = {{ type = "dielectric", ior = 1.3 }}

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "moss"

[[sphere]]
center = [3, 0, 0]
radius = 1
material = "zinc"

[[triangle]]
vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
material = "amber"
"#
        );
        let scene = parse(&text);
        assert_eq!(scene.material_names, ["zinc", "amber", "moss"]);
        let name_of = |i: u32| scene.material_names[i as usize].as_str();
        assert_eq!(name_of(scene.spheres[0].material), "moss");
        assert_eq!(name_of(scene.spheres[1].material), "zinc");
        assert_eq!(name_of(scene.triangles[0].material), "amber");
        assert_eq!(
            scene.materials[2],
            Bsdf::Dielectric {
                ior: 1.3,
                roughness: Roughness::SMOOTH
            }
            .into()
        );
    }

    #[test]
    fn materials_may_be_written_as_subtables() {
        let text = format!(
            "{MINIMAL}\n[materials.b]\ntype = \"dielectric\"\nior = 2\n\n[materials.a]\ntype = \"mirror\"\n"
        );
        let scene = parse(&text);
        assert_eq!(scene.material_names, ["b", "a"]);
    }

    #[test]
    fn gamma_srgb_selects_the_srgb_curve() {
        let scene = parse(&format!("{MINIMAL}\n[image]\ngamma = \"srgb\"\n"));
        assert_eq!(scene.image.gamma, Gamma::Srgb);
        let scene = parse(&format!("{MINIMAL}\n[image]\ngamma = 1.8\n"));
        assert_eq!(scene.image.gamma, Gamma::Power(1.8));
    }

    #[test]
    fn integers_are_accepted_where_floats_are_expected() {
        let text = format!(
            r#"{MINIMAL}
[image]
exposure = 2
gamma = 2
[render]
filter = "box"
filter_sigma = 1
background = [1, 0, 0]
[materials]
glass = {{ type = "dielectric", ior = 2 }}
[[sphere]]
center = [1, 2, 3]
radius = 10
material = "glass"
[[light]]
type = "sphere"
center = [0, 10, 0]
radius = 2
power = 500
"#
        );
        let scene = parse(&text);
        assert_eq!(scene.camera.fov_deg, 45.0);
        assert_eq!(scene.image.exposure, 2.0);
        assert_eq!(scene.image.gamma, Gamma::Power(2.0));
        assert_eq!(scene.render.filter, Filter::Box);
        assert_eq!(scene.render.filter_sigma, 1.0);
        assert_eq!(scene.environment.radiance, Vec3::X);
        assert_eq!(
            scene.materials,
            [Bsdf::Dielectric {
                ior: 2.0,
                roughness: Roughness::SMOOTH
            }
            .into()]
        );
        assert_eq!(
            scene.spheres,
            [Sphere {
                center: Vec3::new(1.0, 2.0, 3.0),
                radius: 10.0,
                material: 0
            }]
        );
        assert_eq!(
            scene.lights,
            [Light::Sphere {
                center: Vec3::new(0.0, 10.0, 0.0),
                radius: 2.0,
                power: 500.0,
                color: Vec3::ONE
            }]
        );
    }

    #[test]
    fn limits_are_inclusive() {
        let text = format!(
            "{MINIMAL}\n[image]\nwidth = 65536\nheight = 4096\nexposure = 0\n[render]\nmax_bounces = 0\nseed = 4294967295\nfilter = \"none\"\n\
             [materials]\nblack = {{ type = \"diffuse\", albedo = [0, 0, 1] }}\n"
        );
        let scene = parse(&text);
        assert_eq!((scene.image.width, scene.image.height), (65536, 4096));
        assert_eq!(scene.render.seed, u32::MAX);
        assert_eq!(scene.render.max_bounces, 0);
        assert_eq!(scene.render.filter, Filter::None);
    }

    #[test]
    fn zero_area_triangles_are_allowed() {
        let text = format!(
            "{MINIMAL}\n[materials]\nw = {{ type = \"diffuse\", albedo = [1, 1, 1] }}\n[[triangle]]\n\
             vertices = [[1, 1, 1], [1, 1, 1], [2, 2, 2]]\nmaterial = \"w\"\n"
        );
        assert_eq!(parse(&text).triangles.len(), 1);
    }

    #[test]
    fn default_scene_errors_name_the_default_scene() {
        let err = parse_scene("[camera]\nfov = 60\n", None).expect_err("position is missing");
        assert_eq!(err.file(), DEFAULT_SCENE_FILE);
        assert!(
            err.to_string()
                .starts_with("<default scene>, line 1, key camera.position: "),
            "{err}"
        );
    }

    #[test]
    fn the_embedded_default_scene_is_valid() {
        if let Err(e) = parse_scene(crate::scene::DEFAULT_SCENE_TOML, None) {
            panic!("{e}");
        }
    }

    #[test]
    fn syntax_errors_guess_the_key_from_the_line() {
        let text = "[camera]\nposition = [0, 0, 1]\n\n[[sphere]]\nradius = 1\n[[sphere]]\nradius = 1.2.3\n";
        let err = parse_scene(text, None).expect_err("not TOML");
        assert_eq!(err.line(), Some(7));
        assert_eq!(err.key(), Some("sphere[1].radius"));
    }

    #[test]
    fn messages_quoting_user_text_stay_on_one_line() {
        let text = format!(
            "{MINIMAL}\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"two\\nlines\"\n"
        );
        let err = parse_scene(&text, None).expect_err("undefined material");
        assert!(!err.to_string().contains('\n'), "{err}");
    }
}
