//! Scenes: the TOML file format (`docs/scene-format.md` is the contract), its validation, and
//! the in-memory [`Scene`] the renderer consumes.
//!
//! Everything here is plain data in `f32`/glam types: it knows nothing of Vulkan. `kernel::upload` turns a
//! [`Scene`] into the Pod buffers the shader reads.

pub mod bsdfs;
pub mod bvh;
pub mod environment;
pub mod gltf;
pub mod gltf_scene;
pub mod image_texture;
pub mod import;
pub mod mesh;
pub mod mesh_file;
pub mod mitsuba;
pub mod obj;
mod parse;
pub mod ply;
pub mod serialized;
pub mod shapes;
pub mod texture;
pub mod toml_text;
pub mod translated;

use glam::Vec3;
use import::Importer;
use std::path::{Path, PathBuf};
use translated::ImportOptions;

pub use environment::{Environment, EnvironmentMap};

/// A scene warning that begins with this is a note: what vkpath does by design with such a file (a glTF
/// file without a camera is framed from its bounds, without lights lit by a uniform sky, its occlusion
/// texture read past: a path tracer computes occlusion), documented in docs/scene-format.md; the command
/// line prints it as `vkpath: note: ...` rather than as a warning.
pub const NOTE: &str = "note: ";

/// A scene warning as the command line prints it: `note: ...` or `warning: ...` (see [`NOTE`]).
pub fn warning_line(w: &str) -> String {
    match w.strip_prefix(NOTE) {
        Some(note) => format!("vkpath: note: {note}"),
        None => format!("vkpath: warning: {w}"),
    }
}
pub use image_texture::Texture;
pub use mesh::Mesh;
pub use parse::{FileCache, SceneError};
pub use texture::{MaterialTextures, TextureRef};

/// The course's box of spheres, embedded so that `vkpath render` works with no file at all.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../../scenes/course.toml");
/// The name the default scene reports (and its default output stem).
pub const DEFAULT_SCENE_NAME: &str = "course";
/// The largest scene file read (32 MiB, about 600 000 inline spheres). Large geometry belongs in OBJ
/// meshes; the limit keeps a huge or endless file from being read into memory.
pub const MAX_SCENE_FILE_BYTES: u64 = 32 << 20;

/// A loaded, validated scene. Every invariant of the contract holds (finite numbers, positive radii,
/// albedos in [0,1], a non-degenerate camera, material indices in range).
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Where the scene came from (`None` for the embedded default); used in messages and for the output stem.
    pub path: Option<PathBuf>,
    pub camera: Camera,
    pub image: ImageSettings,
    pub render: RenderSettings,
    /// Materials in order of first definition in `[materials]`; objects hold indices into this list.
    pub materials: Vec<Material>,
    /// Material names, parallel to `materials`.
    pub material_names: Vec<String>,
    pub spheres: Vec<Sphere>,
    pub triangles: Vec<Triangle>,
    /// `[[mesh]]` tables, loaded and placed in world space.
    pub meshes: Vec<Mesh>,
    /// Meshes drawn more than once (`[[instance]]`s, Mitsuba's `shapegroup`/`instance`): each stored once
    /// in its own space and placed by each of its transforms. The renderer shares one copy of the
    /// triangles and their BVH between the placements (a two-level BVH, `kernel::upload`).
    pub instanced: Vec<mesh::InstancedMesh>,
    pub lights: Vec<Light>,
    /// Light from infinitely far (`[environment]`, or `render.background`): black when not given.
    pub environment: Environment,
    /// What the reader noticed and worked around (an OBJ's MTL file that cannot be read, an MTL value
    /// clipped): one sentence each, for the command line to print. Never silently dropped.
    pub warnings: Vec<String>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub projection: Projection,
    /// Perspective: the horizontal field of view across the image width, in degrees, in (0, 180).
    pub fov_deg: f32,
    /// Orthographic: the width of the view in scene units (> 0); the height follows the image.
    pub extent: f32,
    /// Lens radius in scene units; 0 is a pinhole.
    pub aperture: f32,
    /// Distance along the view axis to the plane in focus (> 0).
    pub focus_distance: f32,
}

/// How the camera maps the film to rays (`camera.type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Projection {
    /// Rays from one point (or a thin lens) through the film: a field of view `fov_deg`.
    #[default]
    Perspective,
    /// Parallel rays along the view direction from a film `extent` wide: no perspective, for technical
    /// renders and tests.
    Orthographic,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gamma {
    /// `clamp(exposure * L, 0, 1)^(1/g)`, the course's transform (g = 2.2 by default).
    Power(f32),
    /// The sRGB transfer curve (IEC 61966-2-1).
    Srgb,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
    pub exposure: f32,
    pub gamma: Gamma,
    /// The tone curve between exposure and gamma in the 8-bit image (`render.tonemap`); EXR stays linear.
    pub tonemap: Tonemap,
    /// `render.denoise`: the final images are denoised (as `--denoise`). Like the display transform, not
    /// part of the render's identity: the samples are the same either way.
    pub denoise: bool,
}

/// A display tone curve, applied to exposure x radiance per channel before the gamma or sRGB encoding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Tonemap {
    /// The course's display: clamp to [0, 1].
    #[default]
    None,
    /// Narkowicz's fit of the ACES filmic reference rendering transform (K. Narkowicz, "ACES Filmic Tone
    /// Mapping Curve", 2016): f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), then clamped to [0, 1].
    /// It compresses highlights smoothly instead of clipping them: f(1) = 2.54 / 3.16 = 0.804, and f reaches
    /// 1 at x = (0.56 + sqrt(0.3584)) / 0.16 = 7.24 (the root of 0.08 x^2 - 0.56 x - 0.14), tending to
    /// 2.51 / 2.43 beyond.
    Aces,
}

impl Tonemap {
    pub fn apply(self, x: f32) -> f32 {
        match self {
            Tonemap::None => x.clamp(0.0, 1.0),
            Tonemap::Aces => {
                let x = x.max(0.0);
                (x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// Gaussian of std-dev `filter_sigma` pixels, sampled by Box–Muller jitter.
    Gaussian,
    /// Uniform over the pixel's square.
    Box,
    /// Every sample through the pixel centre.
    None,
    /// A tent (triangle) of radius `filter_radius` pixels in x times the same in y (Mitsuba's tent),
    /// importance-sampled.
    Tent,
}

/// Where a path's random numbers come from (`render.sampler`). Both are pure functions of (pixel, sample
/// index, dimension, seed), so passes, tiles and sample ranges split either exactly (rng.wgsl).
/// The default is Sobol': on every course scene it reaches a given error sooner than independent numbers
/// at the same speed (docs/speed-vs-accuracy.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampler {
    /// Independent uniform numbers from a hash (PCG4D).
    Independent,
    /// Owen-scrambled Sobol' points, shuffled and padded per pair of dimensions (Burley 2020): the
    /// samples of a pixel stratify each pair of dimensions.
    #[default]
    Sobol,
}

/// How the lights that paths can also hit (sphere lights, emitting surfaces, the environment) are sampled
/// at non-specular vertices (`render.light_sampling`). Point lights and delta suns are always sampled: no
/// path can hit them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampling {
    /// Light sampling only, by solid angle: a sphere uniformly in the cone it subtends, a triangle
    /// uniformly in its solid angle (by area when it subtends less than 3e-4 sr), the environment from
    /// its map.
    Cone,
    /// Light sampling only, by area: a sphere's point on the hemisphere that faces the shaded point,
    /// cosine-distributed about its axis (the course's method); a triangle's point uniform on its area.
    Area,
    /// BSDF sampling only: their emission counts when a path hits them.
    None,
    /// Both: the cone's light sample and the BSDF-sampled ray that hits the light, each weighted by the
    /// power heuristic (Veach 1997), so that whichever strategy has the higher density dominates. The
    /// default: as good as `Cone` at equal time on the course's sphere-lit scenes (the same error per
    /// sample, within the timing noise per second), far better where BSDF sampling is the good strategy
    /// (a large light or the environment seen by a diffuse surface).
    #[default]
    Mis,
}

impl LightSampling {
    /// Every strategy with its name in scene files and on the command line (the one list of names).
    pub const ALL: [(LightSampling, &'static str); 4] = [
        (LightSampling::Cone, "cone"),
        (LightSampling::Area, "area"),
        (LightSampling::None, "none"),
        (LightSampling::Mis, "mis"),
    ];

    pub fn from_name(name: &str) -> Option<LightSampling> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(s, _)| *s)
    }

    /// The names, quoted and listed for an error message: `"cone", "area", "none" or "mis"`.
    pub fn names_listed() -> String {
        let quoted: Vec<String> = Self::ALL.iter().map(|(_, n)| format!("\"{n}\"")).collect();
        let (last, rest) = quoted.split_last().expect("strategies");
        format!("{} or {last}", rest.join(", "))
    }
}

/// `max_bounces = -1` in a scene file or on the command line: no bounce limit.
pub const NO_BOUNCE_LIMIT: u32 = u32::MAX;

/// `max_bounces` as the user writes it: -1 for [`NO_BOUNCE_LIMIT`].
pub fn bounces_as_written(max_bounces: u32) -> i64 {
    if max_bounces == NO_BOUNCE_LIMIT {
        -1
    } else {
        i64::from(max_bounces)
    }
}

impl RenderSettings {
    /// Whether the render splats its samples (`render.splat`). Splatting needs a filter wider than
    /// its pixel (tent, Gaussian) and samples that stay on the image (`sample_border = false`: the
    /// film has no pixels beyond the edges to trace). Not set, it splats wherever it can: at equal
    /// samples the weighted average has less variance than one pixel's own filter-importance-sampled
    /// samples (docs/speed-vs-accuracy.md, "Splatting").
    /// An adaptive render (`render.adaptive`) does not splat unless told to (which the readers refuse).
    pub fn splats(&self) -> bool {
        self.can_splat() && self.splat.unwrap_or(self.adaptive.on != Some(true))
    }

    /// Whether this filter and border can be splatted (see [`RenderSettings::splats`]).
    /// The gather reaches K = ceil(R - 1/2) pixels each way for a filter of radius R
    /// (`render::splat::reach`), and sums a sample's (2K + 1)^2 weights in 32 bits: K <= 7, R <= 7.5.
    pub fn can_splat(&self) -> bool {
        let radius = match self.filter {
            Filter::Tent => self.filter_radius,
            Filter::Gaussian => 4.0 * self.filter_sigma,
            Filter::Box | Filter::None => return false,
        };
        radius <= 7.5 && !self.sample_border
    }

    /// Decides splatting where nothing overrides the scene's `render.splat`: off when denoising (the
    /// denoiser reads each pixel's own estimate, whose noise is independent of its neighbours') and with
    /// adaptive sampling (which keeps each pixel's own samples). False when the scene asks for both
    /// splatting and adaptive sampling, which do not go together (a splatted pixel averages its
    /// neighbours' samples, which adaptive sampling takes in unequal numbers): the caller refuses it.
    pub fn settle_splat(&mut self, denoise: bool) -> bool {
        let adaptive = self.adaptive.on == Some(true);
        match self.splat {
            None if denoise || adaptive => self.splat = Some(false),
            Some(true) if adaptive => return false,
            _ => {}
        }
        true
    }
}

/// Adaptive sampling as the scene file asks for it (`render.adaptive*`; Cycles' names): pixels stop
/// sampling once their estimated error is below the threshold (`vkpath::render::adaptive`). Each is
/// `None` when not written; the command line may override them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Adaptive {
    /// `render.adaptive`: on or off (default off).
    pub on: Option<bool>,
    /// `render.adaptive_threshold`: the error at which a pixel stops (> 0; default 0.01).
    pub threshold: Option<f64>,
    /// `render.adaptive_min_samples`: samples every pixel takes first, and between checks (>= 2;
    /// default 16).
    pub min_samples: Option<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub samples: u32,
    /// Scattering events per path; [`NO_BOUNCE_LIMIT`] (`max_bounces = -1`) for none: paths then end by
    /// Russian roulette, or at `abi::BOUNCE_CAP` (counted and reported).
    pub max_bounces: u32,
    pub seed: u32,
    pub filter: Filter,
    pub filter_sigma: f32,
    /// The tent filter's radius, in pixels (> 0; default 1).
    pub filter_radius: f32,
    /// `render.sample_border` (default true): a pixel's filter reaches past the image's edges, as it
    /// does inside. False: samples stay on the image, an edge pixel's filter is cut off there and
    /// renormalised (Mitsuba 3's hdrfilm with its default `sample_border = false`).
    pub sample_border: bool,
    /// `render.splat`: each radiance sample is splatted into every pixel its filter covers, with the
    /// filter's weight, and a pixel is the weighted average of what it received (Mitsuba 3's film);
    /// else each sample counts for its own pixel only, its position drawn from that pixel's filter.
    /// `None` (not in the file): [`RenderSettings::splats`] decides.
    pub splat: Option<bool>,
    /// `render.adaptive`, `render.adaptive_threshold`, `render.adaptive_min_samples`.
    pub adaptive: Adaptive,
    pub sampler: Sampler,
    pub light_sampling: LightSampling,
    /// `render.clamp`: each sample's radiance is scaled down so that its largest channel is at most this
    /// (a firefly clamp: biased, darkening exactly what is clamped; `None`, the default, leaves the
    /// estimator unbiased).
    pub clamp: Option<f32>,
}

/// A material: how its surface scatters light, and what it emits; its parameters' textures and its
/// surface modifiers (opacity, bump and normal maps).
#[derive(Clone, PartialEq)]
pub struct Material {
    /// The constant parameters (each the factor of its texture, when it has one).
    pub bsdf: Bsdf,
    /// `None`: the surface emits nothing.
    pub emission: Option<Emission>,
    pub textures: MaterialTextures,
}

impl std::fmt::Debug for Material {
    /// As derived, with `textures` only when there are any (so that a material without keeps the
    /// form render::identity hashes).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("Material");
        d.field("bsdf", &self.bsdf)
            .field("emission", &self.emission);
        if !self.textures.is_plain() {
            d.field("textures", &self.textures);
        }
        d.finish()
    }
}

impl From<Bsdf> for Material {
    /// A material that does not emit, without textures.
    fn from(bsdf: Bsdf) -> Material {
        Material {
            bsdf,
            emission: None,
            textures: MaterialTextures::default(),
        }
    }
}

/// How a surface scatters light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse {
        albedo: Vec3,
    },
    Mirror {
        tint: Vec3,
    },
    /// Glass: smooth at roughness 0, else the Walter et al. 2007 rough dielectric.
    Dielectric {
        ior: f32,
        roughness: Roughness,
    },
    /// A metal: GGX reflection (a mirror at roughness 0) with a conductor's Fresnel reflectance, times
    /// `tint` (Mitsuba's specular_reflectance; white by default).
    Conductor {
        fresnel: ConductorFresnel,
        roughness: Roughness,
        tint: Vec3,
    },
    /// A thin pane of a dielectric of index `ior` (shaders/bsdfs/thin_dielectric.wgsl): light reflects
    /// (with the internal reflections summed) or passes straight through.
    ThinDielectric {
        ior: f32,
    },
    /// A diffuse base of `albedo` under a dielectric coat of index `ior` (shaders/bsdfs/plastic.wgsl);
    /// `nonlinear`: the light reflected back and forth between base and coat is tinted by the albedo at
    /// each bounce (Mitsuba's `nonlinear = true`; false is Mitsuba's default, linear in the albedo).
    Plastic {
        albedo: Vec3,
        ior: f32,
        roughness: Roughness,
        nonlinear: bool,
    },
    /// glTF 2.0's metallic-roughness material (the specification's Appendix B), with the layers of the
    /// Khronos PBR extensions ([`GltfLayers`]; none: the plain material).
    MetallicRoughness {
        base_color: Vec3,
        metallic: f32,
        roughness: f32,
        layers: GltfLayers,
    },
    /// Mitsuba 3's `principled` BSDF without specular transmission (shaders/bsdfs/principled.wgsl, which
    /// gives the model): perceptual `roughness`, `eta` the specular's relative index (from Mitsuba's
    /// `specular` or given), the other weights in [0, 1].
    Principled {
        base_color: Vec3,
        roughness: f32,
        anisotropic: f32,
        metallic: f32,
        eta: f32,
        spec_tint: f32,
        sheen: f32,
        sheen_tint: f32,
        clearcoat: f32,
        clearcoat_gloss: f32,
        flatness: f32,
    },
    /// Reflects and transmits nothing (the `emitter` material: a lamp's surface).
    Black,
    /// A material plugin's material (`crate::materials`): the kind's number (its row in
    /// `bsdfs::kinds`) and its parameters as packed into the GPU record's block (the plugin's `layout`;
    /// `unpack` reads them back by name). Its textures are in `MaterialTextures::block`.
    Plugin {
        kind: u32,
        block: [f32; crate::materials::BLOCK_WORDS],
    },
}

/// What the Khronos PBR extensions add to a glTF metallic-roughness material (shaders/bsdfs/gltf_pbr.wgsl
/// gives the model): KHR_materials_ior, _specular, _transmission, _volume, _clearcoat and _sheen, each
/// with the specification's default when absent ([`GltfLayers::NONE`] is the core material).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfLayers {
    /// The dielectric's index of refraction (its Fresnel f0 = ((ior - 1) / (ior + 1))^2; with a volume
    /// also the refraction's).
    pub ior: f32,
    /// The dielectric's specular weight and the colour its f0 is multiplied by.
    pub specular: f32,
    pub specular_color: Vec3,
    /// The share of the light entering the dielectric that is transmitted rather than diffused.
    pub transmission: f32,
    /// KHR_materials_volume with thicknessFactor > 0: the surface bounds a medium that absorbs
    /// sigma_a = -ln(attenuationColor) / attenuationDistance per scene unit; `None`: a thin surface.
    pub volume: Option<Vec3>,
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub sheen_color: Vec3,
    pub sheen_roughness: f32,
}

impl GltfLayers {
    /// The core material: no extension's layer.
    pub const NONE: GltfLayers = GltfLayers {
        ior: 1.5,
        specular: 1.0,
        specular_color: Vec3::ONE,
        transmission: 0.0,
        volume: None,
        clearcoat: 0.0,
        clearcoat_roughness: 0.0,
        sheen_color: Vec3::ZERO,
        sheen_roughness: 0.0,
    };

    /// Whether these are the core material's (uploaded as the plainer `metallic_roughness` kind).
    pub fn is_none(&self) -> bool {
        *self == Self::NONE
    }
}

impl Default for GltfLayers {
    fn default() -> Self {
        Self::NONE
    }
}

/// A microfacet roughness as scenes give it: perceptual, in [0, 1], along the surface's tangent (`u`)
/// and bitangent (`v`); the alpha is its square on each axis. `beckmann`: the microfacet normals follow
/// Beckmann's distribution instead of GGX's (`distribution = "beckmann"`, Mitsuba's default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    pub u: f32,
    pub v: f32,
    pub beckmann: bool,
}

impl Roughness {
    pub const SMOOTH: Roughness = Roughness {
        u: 0.0,
        v: 0.0,
        beckmann: false,
    };

    pub fn isotropic(r: f32) -> Roughness {
        Roughness {
            u: r,
            v: r,
            beckmann: false,
        }
    }

    /// A GGX roughness with a different value along the tangent (`u`) and the bitangent (`v`).
    pub fn anisotropic(u: f32, v: f32) -> Roughness {
        Roughness {
            u,
            v,
            beckmann: false,
        }
    }

    /// The GGX alpha along the tangent and the bitangent: roughness^2.
    pub fn alpha(self) -> (f32, f32) {
        (self.u * self.u, self.v * self.v)
    }
}

/// Where a conductor's Fresnel reflectance comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConductorFresnel {
    /// The exact Fresnel equations of a complex index of refraction eta + i k, per channel.
    Complex { eta: Vec3, k: Vec3 },
    /// Schlick's approximation from the reflectance at normal incidence (a base colour).
    Schlick { f0: Vec3 },
}

/// The named conductors of `preset = "..."`: (name, eta, k), linear sRGB. The values are Mitsuba 3.6.4's
/// for `material = "Au"`, `"Ag"`, `"Cu"` and `"Al"`: its spectral tables (from the luxpop.com database,
/// shipped as mitsuba/data/ior/*.spd) reduced to RGB by its `scalar_rgb` variant, as printed by
/// benches/peers/conductor_presets.py; so a preset is the same metal in both renderers.
pub const CONDUCTOR_PRESETS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "gold",
        [0.143_036, 0.375_307, 1.442_045],
        [3.982_997, 2.385_556, 1.603_359],
    ),
    (
        "silver",
        [0.155_276, 0.116_728, 0.138_388],
        [4.828_354, 3.122_222, 2.146_901],
    ),
    (
        "copper",
        [0.201_005, 0.923_750, 1.102_215],
        [3.913_262, 2.453_045, 2.142_09],
    ),
    (
        "aluminium",
        [1.657_501, 0.880_405, 0.521_244],
        [9.223_811, 6.269_502, 4.837_004],
    ),
];

/// Light a surface emits: uniform radiance (W sr^-1 m^-2) from its front face (the side its geometric
/// normal faces: outward on spheres, (v1 - v0) x (v2 - v0) on triangles), or from both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    pub radiance: Vec3,
    pub two_sided: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Counter-clockwise seen from the front; both faces are shaded.
    pub vertices: [Vec3; 3],
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `power * color / (4 pi)` W/sr in every direction.
    Point {
        position: Vec3,
        power: f32,
        color: Vec3,
    },
    /// A visible sphere of uniform radiance `power * color / (4 pi^2 radius^2)`.
    Sphere {
        center: Vec3,
        radius: f32,
        power: f32,
        color: Vec3,
    },
    /// A sun: light arriving from infinitely far along `direction` (unit, the way the light travels),
    /// giving `irradiance * color` W/m^2 on a surface facing it. With a positive angular diameter
    /// `angle_deg` it is a disc of uniform radiance filling a cone of half-angle `angle_deg / 2` (soft
    /// shadows); with 0, a delta light.
    Directional {
        direction: Vec3,
        irradiance: f32,
        color: Vec3,
        angle_deg: f32,
    },
    /// A spot: a point at `position` radiating `intensity * color` W/sr along its unit `axis`, the
    /// same out to `beam_deg` from the axis, falling to 0 at `cutoff_deg` as `falloff` says (0 <=
    /// beam_deg <= cutoff_deg <= 90; beam_deg > 0 for the linear falloff).
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: f32,
        color: Vec3,
        cutoff_deg: f32,
        beam_deg: f32,
        falloff: SpotFalloff,
    },
}

/// How a spot light's intensity falls from its beam to its cutoff angle (`falloff` in a scene file).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpotFalloff {
    /// Linearly in the angle, (c - theta) / (c - b): Mitsuba 3's `spot` ("linear", the default).
    #[default]
    Linear,
    /// glTF's KHR_lights_punctual: t = clamp((cos theta - cos c) / (cos b - cos c), 0, 1), f = t^2
    /// ("smooth"; the extension's recommended implementation).
    Smooth,
}

/// The solid angle a spot light's falloff covers, Omega = integral of f(theta) over the sphere, so that
/// a spot of on-axis intensity I emits P = I Omega. With f = 1 out to the beam angle b and
/// (c - theta) / (c - b) from there to the cutoff c (radians):
/// Omega = 2 pi [integral_0^b sin t dt + integral_b^c (c - t)/(c - b) sin t dt]
///       = 2 pi [1 - (sin c - sin b) / (c - b)]
/// (the second integral by parts: (c - b) cos b - (sin c - sin b)); as b -> c it tends to the cap's
/// 2 pi (1 - cos c).
///
/// The smooth falloff (glTF's), f = t^2 with t = (cos theta - cos c) / (cos b - cos c) between the
/// angles: with x = cos theta, Omega = 2 pi [integral_{cos b}^1 dx + integral_{cos c}^{cos b} t^2 dx]
/// = 2 pi [(1 - cos b) + (cos b - cos c) / 3].
pub fn spot_cone_solid_angle(cutoff_deg: f64, beam_deg: f64, falloff: SpotFalloff) -> f64 {
    let (c, b) = (cutoff_deg.to_radians(), beam_deg.to_radians());
    let tau = std::f64::consts::TAU;
    if falloff == SpotFalloff::Smooth {
        // 1 - cos b as 2 sin^2(b / 2), without cancellation.
        let one_minus_cos_b = 2.0 * (b / 2.0).sin().powi(2);
        return tau * (one_minus_cos_b + (b.cos() - c.cos()) / 3.0);
    }
    if c - b < 1e-6 {
        // 1 - cos c without cancellation.
        return tau * 2.0 * (c / 2.0).sin().powi(2);
    }
    tau * (1.0 - (c.sin() - b.sin()) / (c - b))
}

impl Scene {
    /// Reads and validates a scene file. Errors name the file, the line and the key.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_with_camera(path, None)
    }

    /// Reads a scene file: TOML, or a glTF 2.0 file (`.gltf`, `.glb`: [`gltf_scene`]) or a Mitsuba 3 XML
    /// file (`.xml`: [`mitsuba`]) read as the TOML scene it becomes, from its first camera or camera
    /// `camera` (which only glTF and Mitsuba XML files take). [`import`] picks the format.
    pub fn load_with_camera(path: &Path, camera: Option<usize>) -> Result<Scene, SceneError> {
        Scene::load_with_options(path, camera, false)
    }

    /// [`Scene::load_with_camera`]; `xml_lenient` reads a Mitsuba XML file skipping what vkpath does
    /// not read (a warning each) instead of refusing it.
    pub fn load_with_options(
        path: &Path,
        camera: Option<usize>,
        xml_lenient: bool,
    ) -> Result<Scene, SceneError> {
        let options = ImportOptions {
            camera,
            xml_lenient,
            ..ImportOptions::default()
        };
        Scene::load_with(path, &options)
    }

    /// Reads a scene file with every import option (see [`ImportOptions`]).
    pub fn load_with(path: &Path, options: &ImportOptions) -> Result<Scene, SceneError> {
        Importer::for_path(path).load(path, options)
    }

    /// Parses and validates scene text. `path` is used for messages and to resolve relative paths.
    pub fn from_toml_str(text: &str, path: Option<&Path>) -> Result<Scene, SceneError> {
        parse::parse_scene(text, path)
    }

    /// [`Scene::from_toml_str`], reading the mesh files, textures and environment map through `cache`:
    /// those it already holds are not read again (the Python module's edits of a loaded scene).
    pub fn from_toml_str_cached(
        text: &str,
        path: Option<&Path>,
        cache: &mut FileCache,
    ) -> Result<Scene, SceneError> {
        parse::parse_scene_cached(text, path, cache)
    }

    /// Whether any light is in the scene: a light, an emitting material, or an environment that is not
    /// black. (An emitting material counts whether or not a shape uses it.)
    pub fn has_light(&self) -> bool {
        !self.lights.is_empty()
            || !self.environment.is_black()
            || self
                .materials
                .iter()
                .any(|m| m.emission.is_some_and(|e| e.radiance.max_element() > 0.0))
    }

    /// The embedded default scene (the course's box of spheres).
    pub fn default_scene() -> Scene {
        Scene::from_toml_str(DEFAULT_SCENE_TOML, None).expect("the embedded default scene is valid")
    }

    /// The stem used for default output names (`course` for the embedded scene).
    pub fn stem(&self) -> String {
        self.path
            .as_ref()
            .and_then(|p| p.file_stem())
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| DEFAULT_SCENE_NAME.to_string())
    }

    /// A short name for reports (`--json`'s "scene").
    pub fn display_name(&self) -> String {
        self.path
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| format!("<default: {DEFAULT_SCENE_NAME}>"))
    }
}

/// A scene file's text (TOML, or an XML scene and its includes). Read at most one byte past the limit: a
/// huge file (10^8 inline spheres would be several GB, and parsing costs ~50 bytes of memory per byte of
/// TOML) or an endless one (/dev/zero, a pipe) is refused without being read into memory. Not
/// read_to_string: its error for a byte that is not UTF-8 names neither line nor byte.
pub(crate) fn read_scene_text(path: &Path) -> Result<String, SceneError> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, &e))?;
    let mut bytes = Vec::new();
    file.take(MAX_SCENE_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| SceneError::io(path, &e))?;
    if bytes.len() as u64 > MAX_SCENE_FILE_BYTES {
        return Err(SceneError::too_large(path, MAX_SCENE_FILE_BYTES));
    }
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        SceneError::not_utf8(path, e.as_bytes(), valid)
    })
}
