//! The feature set of a scene: which parts of the kernel it needs. The renderer specialises the kernel
//! for it (shaders/features.wgsl), so that a scene pays only for what it uses.
//!
//! One table, [`features()`], has a row per feature: its name (in reports and `vkpath bench
//! specialisation`), the WGSL `override` constant it sets, and whether a scene needs it. Everything else
//! follows from the table: [`FeatureSet::generic`], [`FeatureSet::of`], the pipeline constants,
//! [`FeatureSet::absent`], [`FeatureSet::enable`] and the kernel's name. The three run-time knobs (pixel
//! filter, sampler, light-sampling strategy) are in [`KNOBS`], a row each: a constant value when
//! specialised, read from `Params` by the generic kernel. `tests/layout.rs` holds both tables against
//! the overrides the WGSL declares, both ways.
//!
//! Adding a feature: a row here and its `override` in features.wgsl (the test fails until both exist).
//! The material and light kinds' rows are not written here: each row of the material registry
//! (`scene::bsdfs`) and of the light registry (`kernel::light_kinds`) is one, with its override
//! generated beside the kind's constant (bsdf_kinds.wgsl, light_kinds.wgsl).

use super::abi::*;
use super::light_kinds;
use super::upload::GpuScene;
use crate::materials;
use crate::scene::bsdfs;
use std::sync::LazyLock;

/// A feature of the kernel: a row of [`features()`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    Spheres,
    Triangles,
    Bvh,
    SphereBvh,
    TriangleLoop,
    Instances,
    InstanceMaterials,
    SmoothNormals,
    Textures,
    EmissiveTextures,
    MetallicRoughnessTextures,
    /// Some material plugin's parameter is a texture (`crate::materials`).
    PluginTextures,
    NormalMaps,
    BumpMaps,
    BackMaterials,
    BlendMaterials,
    Opacity,
    Checkerboard,
    Anisotropy,
    Beckmann,
    Emission,
    EnvironmentMap,
    Lens,
    Orthographic,
    Roulette,
    SplitArrays,
    /// The large read-only arrays are read from data images (`gpu::image`): like
    /// [`Feature::SplitArrays`], how arrays are laid out across bindings; the renderer decides it per
    /// device (`render::data_images_help`).
    DataImages,
    /// A material kind (`MAT_*`), a row of the registry (`scene::bsdfs`).
    Material(u32),
    /// A light kind (`LIGHT_*`), a row of the light registry (`kernel::light_kinds`).
    Light(u32),
    /// `abi::UNIFORM_ARRAYS[i]` is read from its uniform twin: like [`Feature::SplitArrays`], how an
    /// array is laid out across bindings, not something the scene's light transport uses.
    UniformArray(u32),
}

/// What decides whether a scene needs a feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// Geometry, camera and render settings.
    Other,
    /// A material kind (`MAT_*`): counted by `SINGLE_MATERIAL_KIND`.
    Material(u32),
    /// A light kind (`LIGHT_*`): counted by `SINGLE_LIGHT_KIND`.
    Light(u32),
    /// `abi::UNIFORM_ARRAYS[i]`: on when the scene's array fits the twin (`UniformArray::fits`).
    UniformArray(u32),
}

/// One row of the feature table.
pub struct FeatureRow {
    pub feature: Feature,
    /// The name in reports (`features_absent`) and `vkpath bench specialisation`.
    pub name: &'static str,
    /// The WGSL `override` constant (features.wgsl).
    pub constant: &'static str,
    pub group: Group,
    /// Whether the scene, as uploaded with its parameters, needs it (material and light rows are
    /// decided by their group: a kind some object uses, a kind of light present).
    pub needed: fn(&GpuScene, &GpuParams) -> bool,
    /// Whether the row is listed by [`FeatureSet::absent`] (rows that only refine another, such as the
    /// BVH and the triangle loop under `triangles`, are not: they follow from it and the scene).
    pub reported: bool,
}

fn by_group(_: &GpuScene, _: &GpuParams) -> bool {
    false // decided by FeatureSet::of from the group
}

fn mesh_flag(g: &GpuScene, flag: u32) -> bool {
    g.meshes.iter().any(|m| m.flags & flag != 0)
}

/// Whether `m` is a material plugin's with a textured parameter (a texture word set: materials::Slot).
fn plugin_textured(m: &GpuMaterial) -> bool {
    bsdfs::plugin_of(m.kind).is_some_and(|p| {
        p.layout()
            .iter()
            .filter_map(|s| s.texture_word)
            .any(|t| m.block[t] != materials::NO_TEXTURE_WORD)
    })
}

/// Whether `m` is an anisotropic material plugin's (`MaterialPlugin::anisotropy`).
fn plugin_anisotropic(m: &GpuMaterial) -> bool {
    bsdfs::plugin_of(m.kind).is_some_and(|p| p.is_anisotropic(&m.block))
}

/// The textures and modifiers of the materials some sphere or triangle uses.
fn used_material_textures(g: &GpuScene) -> impl Iterator<Item = &GpuMaterialTextures> {
    used_material_indices(g).filter_map(|m| g.material_textures.get(m as usize))
}

/// The materials some sphere or triangle uses.
fn used_materials(g: &GpuScene) -> impl Iterator<Item = &GpuMaterial> {
    used_material_indices(g).filter_map(|m| g.materials.get(m as usize))
}

/// The indices of the materials some sphere or triangle uses (its own, or a placement's instead:
/// `GpuInstance::material`), and of the materials their back faces show (`GpuMaterial::back`), which
/// are used as much.
fn used_material_indices(g: &GpuScene) -> impl Iterator<Item = u32> + '_ {
    let used = g.spheres.iter().map(|s| s.material);
    let used = used.chain(g.triangles.iter().map(|t| t.material));
    let used = used.chain(
        g.instances
            .iter()
            .map(|i| i.material)
            .filter(|&m| m != NO_MATERIAL),
    );
    // A back material's blend, or a blend's back, is not read (neither chains: the parser refuses it).
    used.flat_map(|m| {
        let back = g.materials.get(m as usize).map_or(0, |mat| mat.back);
        let blend = g.material_textures.get(m as usize).map_or(0, |t| t.blend);
        std::iter::once(m)
            .chain((back != 0).then(|| back - 1))
            .chain((blend != 0).then(|| blend - 1))
    })
}

/// The rows before the material kinds'.
const BEFORE_MATERIALS: &[FeatureRow] = &[
    FeatureRow {
        feature: Feature::Spheres,
        name: "spheres",
        constant: "HAS_SPHERES",
        group: Group::Other,
        needed: |g, _| !g.spheres.is_empty(),
        reported: true,
    },
    FeatureRow {
        feature: Feature::Triangles,
        name: "triangles",
        constant: "HAS_TRIANGLES",
        group: Group::Other,
        needed: |g, _| !g.triangles.is_empty(),
        reported: true,
    },
    FeatureRow {
        // Triangles are found through the BVH (scenes of more than `upload::BVH_MIN_TRIANGLES`);
        // otherwise by a loop over every triangle, which is also the reference that tests and the
        // scaling benchmark compare the BVH against.
        feature: Feature::Bvh,
        name: "bvh",
        constant: "HAS_BVH",
        group: Group::Other,
        needed: |g, _| !g.bvh_nodes.is_empty(),
        reported: false,
    },
    FeatureRow {
        // Spheres are found through their own BVH (scenes of at least `upload::SPHERE_BVH_MIN`);
        // otherwise by a loop over every sphere.
        feature: Feature::SphereBvh,
        name: "sphere_bvh",
        constant: "HAS_SPHERE_BVH",
        group: Group::Other,
        needed: |g, _| !g.sphere_nodes.is_empty(),
        reported: false,
    },
    FeatureRow {
        feature: Feature::TriangleLoop,
        name: "triangle_loop",
        constant: "HAS_TRIANGLE_LOOP",
        group: Group::Other,
        needed: |g, _| !g.triangles.is_empty() && g.bvh_nodes.is_empty(),
        reported: false,
    },
    FeatureRow {
        // Instanced meshes: the BVH is two-level, and a leaf of the top-level tree takes the walk into a
        // placement's tree (bvh.wgsl); hits on them are mapped to the world (scene.wgsl, hit_triangle).
        feature: Feature::Instances,
        name: "instances",
        constant: "HAS_INSTANCES",
        group: Group::Other,
        needed: |g, _| !g.instances.is_empty(),
        reported: true,
    },
    FeatureRow {
        // Some placement draws its faces in a material of its own (`GpuInstance::material`:
        // scene_data.wgsl, placed_material); without one, a hit on an instance reads no more than its
        // triangle's material.
        feature: Feature::InstanceMaterials,
        name: "instance_materials",
        constant: "HAS_INSTANCE_MATERIALS",
        group: Group::Other,
        needed: |g, _| g.instances.iter().any(|i| i.material != NO_MATERIAL),
        reported: true,
    },
    FeatureRow {
        feature: Feature::SmoothNormals,
        name: "smooth_normals",
        constant: "HAS_SMOOTH_NORMALS",
        group: Group::Other,
        needed: |g, _| mesh_flag(g, MESH_SMOOTH),
        reported: true,
    },
    FeatureRow {
        // Some material's albedo (base colour, tint) is a texture.
        feature: Feature::Textures,
        name: "textures",
        constant: "HAS_TEXTURES",
        group: Group::Other,
        needed: |g, _| used_material_textures(g).any(|t| t.albedo_texture != NO_TEXTURE),
        reported: true,
    },
    FeatureRow {
        feature: Feature::EmissiveTextures,
        name: "emissive_textures",
        constant: "HAS_EMISSIVE_TEXTURES",
        group: Group::Other,
        needed: |g, _| used_material_textures(g).any(|t| t.emission_texture != NO_TEXTURE),
        reported: true,
    },
    FeatureRow {
        // Some material's metallic or roughness is a texture.
        feature: Feature::MetallicRoughnessTextures,
        name: "metallic_roughness_textures",
        constant: "HAS_METALLIC_ROUGHNESS_TEXTURES",
        group: Group::Other,
        needed: |g, _| {
            used_material_textures(g)
                .any(|t| t.metallic_texture != NO_TEXTURE || t.roughness_texture != NO_TEXTURE)
        },
        reported: true,
    },
    FeatureRow {
        feature: Feature::PluginTextures,
        name: "plugin_textures",
        constant: "HAS_PLUGIN_TEXTURES",
        group: Group::Other,
        needed: |g, _| used_materials(g).any(plugin_textured),
        reported: true,
    },
    FeatureRow {
        feature: Feature::NormalMaps,
        name: "normal_maps",
        constant: "HAS_NORMAL_MAPS",
        group: Group::Other,
        needed: |g, _| used_material_textures(g).any(|t| t.normal_texture != NO_TEXTURE),
        reported: true,
    },
    FeatureRow {
        // Some material shows another on its back face (the `back` modifier: Mitsuba's twosided with two
        // BSDFs): surface_at picks it there.
        feature: Feature::BackMaterials,
        name: "back_materials",
        constant: "HAS_BACK_MATERIALS",
        group: Group::Other,
        needed: |g, _| used_materials(g).any(|m| m.back != 0),
        reported: true,
    },
    FeatureRow {
        // Some material shows another at a fraction of its hits (the `blend` modifier: Mitsuba's
        // blendbsdf): surface_at picks one.
        feature: Feature::BlendMaterials,
        name: "blend_materials",
        constant: "HAS_BLEND_MATERIALS",
        group: Group::Other,
        needed: |g, _| used_material_textures(g).any(|t| t.blend != 0),
        reported: true,
    },
    FeatureRow {
        feature: Feature::BumpMaps,
        name: "bump_maps",
        constant: "HAS_BUMP_MAPS",
        group: Group::Other,
        needed: |g, _| used_material_textures(g).any(|t| t.bump_texture != NO_TEXTURE),
        reported: true,
    },
    FeatureRow {
        // Some surface lets light through: an opacity below 1, a texture, or a cut-out (opacity.wgsl).
        // Without it no hit is tested for opacity during traversal.
        feature: Feature::Opacity,
        name: "opacity",
        constant: "HAS_OPACITY",
        group: Group::Other,
        needed: |g, _| {
            used_material_textures(g).any(|t| {
                t.opacity < 1.0 || t.opacity_texture != NO_TEXTURE || t.flags & MATERIAL_CUTOUT != 0
            })
        },
        reported: true,
    },
    FeatureRow {
        // Some texture is Mitsuba's procedural checkerboard (texture.wgsl, texture_checkerboard).
        feature: Feature::Checkerboard,
        name: "checkerboard",
        constant: "HAS_CHECKERBOARD",
        group: Group::Other,
        needed: |g, _| {
            g.textures
                .iter()
                .any(|t| t.flags & TEXTURE_CHECKERBOARD != 0)
        },
        reported: true,
    },
];

/// The rows after the material kinds'.
const AFTER_MATERIALS: &[FeatureRow] = &[
    FeatureRow {
        // A material some object uses has a different roughness along the tangent and the bitangent.
        feature: Feature::Anisotropy,
        name: "anisotropy",
        constant: "HAS_ANISOTROPY",
        group: Group::Other,
        needed: |g, _| used_materials(g).any(|m| m.alpha_x != m.alpha_y || plugin_anisotropic(m)),
        reported: true,
    },
    FeatureRow {
        // Some glossy material's microfacets are Beckmann's (microfacet.wgsl), not GGX's.
        feature: Feature::Beckmann,
        name: "beckmann",
        constant: "HAS_BECKMANN",
        group: Group::Other,
        needed: |g, _| used_materials(g).any(|m| m.flags & MATERIAL_BECKMANN != 0),
        reported: true,
    },
    FeatureRow {
        // Some surface emits (an emitter material, or another with `emission`): rays that hit it see it.
        feature: Feature::Emission,
        name: "emission",
        constant: "HAS_EMISSION",
        group: Group::Other,
        needed: |g, _| used_materials(g).any(|m| m.emission.iter().any(|&c| c > 0.0)),
        reported: true,
    },
];

/// The rows after the light kinds'.
const AFTER_LIGHTS: &[FeatureRow] = &[
    FeatureRow {
        feature: Feature::EnvironmentMap,
        name: "environment_map",
        constant: "HAS_ENVIRONMENT_MAP",
        group: Group::Other,
        needed: |g, _| !g.env_texels.is_empty(),
        reported: true,
    },
    FeatureRow {
        feature: Feature::Lens,
        name: "lens",
        constant: "HAS_LENS",
        group: Group::Other,
        needed: |_, p| p.lens_radius > 0.0,
        reported: true,
    },
    FeatureRow {
        feature: Feature::Orthographic,
        name: "orthographic",
        constant: "HAS_ORTHOGRAPHIC",
        group: Group::Other,
        needed: |_, p| p.camera_kind == CAMERA_ORTHOGRAPHIC,
        reported: true,
    },
    FeatureRow {
        // The roulette test runs after scattering event `bounces` (1..=max_bounces).
        feature: Feature::Roulette,
        name: "roulette",
        constant: "HAS_ROULETTE",
        group: Group::Other,
        needed: |_, p| p.roulette_depth <= p.max_bounces,
        reported: true,
    },
    FeatureRow {
        // The large arrays read from data images (gpu::image, render::DATA_IMAGE_ARRAYS); set by the
        // renderer per device.
        feature: Feature::DataImages,
        name: "data_images",
        constant: "DATA_IMAGES",
        group: Group::Other,
        needed: |_, _| false,
        reported: false,
    },
    FeatureRow {
        // Some array is larger than its first binding (abi::SPLIT_ARRAYS): every access picks a part.
        feature: Feature::SplitArrays,
        name: "split_arrays",
        constant: "HAS_SPLIT_ARRAYS",
        group: Group::Other,
        needed: |g, _| {
            SPLIT_ARRAYS
                .iter()
                .any(|a| a.needs_split(g.array_len(a.name)))
        },
        reported: false,
    },
];

/// The feature table: the rows above, with a row per material kind of the material registry
/// (`scene::bsdfs`) and a row per light kind of the light registry (`kernel::light_kinds`) between them.
/// A feature's bit in a [`FeatureSet`] is its row's index.
pub fn features() -> &'static [FeatureRow] {
    static ROWS: LazyLock<Vec<FeatureRow>> = LazyLock::new(|| {
        let materials = bsdfs::kinds().iter().enumerate().map(|(i, k)| FeatureRow {
            feature: Feature::Material(i as u32),
            name: k.feature,
            // Leaked once: the table lives as long as the program.
            constant: k.feature_constant().leak(),
            group: Group::Material(i as u32),
            needed: by_group,
            reported: true,
        });
        let lights = light_kinds::LIGHTS
            .iter()
            .enumerate()
            .map(|(i, k)| FeatureRow {
                feature: Feature::Light(i as u32),
                name: k.feature,
                constant: k.feature_constant().leak(),
                group: Group::Light(i as u32),
                needed: by_group,
                reported: true,
            });
        let uniform = UNIFORM_ARRAYS.iter().enumerate().map(|(i, a)| FeatureRow {
            feature: Feature::UniformArray(i as u32),
            name: a.uniform,
            constant: a.constant,
            group: Group::UniformArray(i as u32),
            needed: by_group,
            reported: false,
        });
        let rows: Vec<FeatureRow> = BEFORE_MATERIALS
            .iter()
            .map(FeatureRow::copy)
            .chain(materials)
            .chain(AFTER_MATERIALS.iter().map(FeatureRow::copy))
            .chain(lights)
            .chain(AFTER_LIGHTS.iter().map(FeatureRow::copy))
            .chain(uniform)
            .collect();
        assert!(rows.len() <= 64, "a FeatureSet holds 64 features");
        rows
    });
    &ROWS
}

impl FeatureRow {
    fn copy(&self) -> FeatureRow {
        FeatureRow { ..*self }
    }

    /// The row's bit in a [`FeatureSet`].
    fn bit(f: Feature) -> u64 {
        let i = features().iter().position(|r| r.feature == f);
        1 << i.expect("every feature has a row")
    }
}

/// The constants derived from the rows rather than set by one: a single material kind, a single light
/// kind, any material texture or modifier (the hit's texture coordinates, the `material_textures`
/// buffer), and the per-triangle shading data that smooth normals and texture coordinates read.
pub const SINGLE_MATERIAL_KIND: &str = "SINGLE_MATERIAL_KIND";
pub const SINGLE_LIGHT_KIND: &str = "SINGLE_LIGHT_KIND";
pub const HAS_MATERIAL_TEXTURES: &str = "HAS_MATERIAL_TEXTURES";
pub const HAS_MESH_SHADING: &str = "HAS_MESH_SHADING";

/// A run-time choice (a `Params` field) that a specialised kernel has as a constant.
pub struct KnobRow {
    pub name: &'static str,
    /// The `bool` override that makes the kernel read the value from `Params` (the generic kernel).
    pub from_params: &'static str,
    /// The overrides that fix the value when specialised: `(constant, value)`, for `u32` constants the
    /// value itself (`value == u32::MAX`), for `bool` ones whether the knob has that value.
    pub values: &'static [(&'static str, u32)],
    /// The knob's value for the scene as uploaded: a `Params` field, or (for the scene's sizes) the
    /// length of the array the kernel loops over.
    pub read: fn(&GpuScene, &GpuParams) -> u32,
}

/// `KnobRow::values` entry of a `u32` override that takes the knob's value itself.
pub const KNOB_VALUE: u32 = u32::MAX;

/// The index of the `aov` knob in [`KNOBS`] (what the samples are), which every kernel fixes.
const AOV_KNOB: usize = KNOBS.len() - 1;

/// The knob table.
pub const KNOBS: &[KnobRow] = &[
    KnobRow {
        name: "filter",
        from_params: "FILTER_FROM_PARAMS",
        values: &[("FILTER_KIND", KNOB_VALUE)],
        read: |_, p| p.filter_kind,
    },
    KnobRow {
        // render.sample_border = false (trace.wgsl, film_position): the filter cut off at the edges.
        name: "filter_in_image",
        from_params: "FILTER_IN_IMAGE_FROM_PARAMS",
        values: &[("FILTER_IN_IMAGE", 1)],
        read: |_, p| p.filter_in_image,
    },
    KnobRow {
        name: "sampler",
        from_params: "SAMPLER_FROM_RNG",
        values: &[("SAMPLER_IS_SOBOL", SAMPLER_SOBOL)],
        read: |_, p| p.sampler,
    },
    KnobRow {
        name: "light_sampling",
        from_params: "LIGHT_SAMPLING_FROM_PARAMS",
        values: &[
            ("LIGHT_SAMPLING_IS_CONE", LIGHT_SAMPLING_CONE),
            ("LIGHT_SAMPLING_IS_AREA", LIGHT_SAMPLING_AREA),
            ("LIGHT_SAMPLING_IS_NONE", LIGHT_SAMPLING_NONE),
            ("LIGHT_SAMPLING_IS_MIS", LIGHT_SAMPLING_MIS),
        ],
        read: |_, p| p.light_sampling,
    },
    // Scene sizes (scene.wgsl, sphere_count): constant loop bounds that the compiler can unroll. The
    // triangle count matters only to scenes without a BVH (the loop over every triangle).
    KnobRow {
        name: "sphere_count",
        from_params: "SPHERE_COUNT_FROM_PARAMS",
        values: &[("SPHERE_COUNT", KNOB_VALUE)],
        read: |g, _| g.spheres.len() as u32,
    },
    KnobRow {
        name: "triangle_count",
        from_params: "TRIANGLE_COUNT_FROM_PARAMS",
        values: &[("TRIANGLE_COUNT", KNOB_VALUE)],
        read: |g, _| g.triangles.len() as u32,
    },
    KnobRow {
        name: "light_count",
        from_params: "LIGHT_COUNT_FROM_PARAMS",
        values: &[("LIGHT_COUNT", KNOB_VALUE)],
        read: |g, _| g.lights.len() as u32,
    },
    KnobRow {
        // render.splat (trace.wgsl, splat_record): samples drawn over the pixel and recorded for the
        // gather (splat.wgsl).
        name: "splat",
        from_params: "SPLAT_FROM_PARAMS",
        values: &[("SPLAT", 1)],
        read: |_, p| p.splat,
    },
    KnobRow {
        // Radiance, or an `--aov` layer (trace.wgsl, trace_aov): a render's kernel has no AOV code.
        name: "aov",
        from_params: "AOV_FROM_PARAMS",
        values: &[("AOV_KIND", KNOB_VALUE)],
        read: |_, p| p.aov,
    },
];

/// The features a kernel keeps (a bit per [`features()`] row), and the knobs it has as constants
/// (`None`: read at run time, as the generic kernel does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FeatureSet {
    on: u64,
    knobs: [Option<u32>; KNOBS.len()],
}

impl FeatureSet {
    /// Everything on, every knob read at run time but what the samples are: the one kernel that renders
    /// any scene.
    ///
    /// What it renders is fixed, like a specialised kernel's: radiance here, an `--aov` layer in
    /// [`FeatureSet::generic_for`] a layer's render. A kernel that read it at run time would hold the
    /// layers' own path loop (`aov_step`, trace.wgsl: a second inlined copy of the scene walk, the
    /// surface, the textures and the BSDF sampling) beside the radiance's, for nothing a scene needs; on
    /// lavapipe it tripled the all-features kernel's compile (measured: 387 s with it, 124 s without).
    ///
    /// Every feature but the arrays' layout: [`Feature::SplitArrays`] and the
    /// [`Feature::UniformArray`]s are how the scene's arrays are laid out across bindings, not something
    /// the scene's light transport uses. Reading every array through its part switch multiplies the
    /// driver's compile time of the all-features kernel (on lavapipe, from seconds to over ten minutes:
    /// every inlined texel and vertex fetch becomes a switch over bindings), and the uniform twins hold
    /// only small scenes' arrays. So the generic kernel reads each array from its one storage binding,
    /// like the WGSL default, and [`FeatureSet::generic_for`] adds the split for a scene that needs it.
    pub fn generic() -> FeatureSet {
        let mut set = FeatureSet {
            on: u64::MAX >> (64 - features().len()),
            knobs: [None; KNOBS.len()],
        };
        set.set(Feature::SplitArrays, false);
        set.set(Feature::DataImages, false);
        set.without_uniform_arrays();
        set.knobs[AOV_KNOB] = Some(AOV_NONE);
        set
    }

    /// Whether this is the generic kernel (for `scene`: whatever its arrays' layout and its output).
    pub fn is_generic(&self) -> bool {
        let mut set = *self;
        set.set(Feature::SplitArrays, false);
        set.set(Feature::DataImages, false);
        set.without_uniform_arrays();
        set.knobs[AOV_KNOB] = Some(AOV_NONE);
        set == FeatureSet::generic()
    }

    /// Reads every array from its storage binding (the generic kernel's way; a GPU's, see
    /// `abi::UniformArray`).
    pub fn without_uniform_arrays(&mut self) {
        for i in 0..UNIFORM_ARRAYS.len() {
            self.set(Feature::UniformArray(i as u32), false);
        }
    }

    /// Whether some array is read from its uniform twin.
    pub fn has_uniform_arrays(&self) -> bool {
        (0..UNIFORM_ARRAYS.len()).any(|i| self.has(Feature::UniformArray(i as u32)))
    }

    /// The generic kernel for `scene`: [`FeatureSet::generic`], with the split arrays where the scene's
    /// arrays need them, rendering what `params` asks (radiance or an `--aov` layer).
    pub fn generic_for(scene: &GpuScene, params: &GpuParams) -> FeatureSet {
        let mut set = FeatureSet::generic();
        let split = FeatureSet::of(scene, params).has(Feature::SplitArrays);
        set.set(Feature::SplitArrays, split);
        set.knobs[AOV_KNOB] = Some(params.aov);
        set
    }

    /// What `scene` (as uploaded, with its parameters) needs. Material kinds count only when an object
    /// uses them; a light kind only when present.
    pub fn of(scene: &GpuScene, params: &GpuParams) -> FeatureSet {
        let used_kinds: Vec<u32> = used_materials(scene).map(|m| m.kind).collect();
        let mut set = FeatureSet {
            on: 0,
            knobs: [None; KNOBS.len()],
        };
        for row in features() {
            let needed = match row.group {
                Group::Other => (row.needed)(scene, params),
                Group::Material(kind) => used_kinds.contains(&kind),
                Group::Light(kind) => scene.lights.iter().any(|l| l.kind == kind),
                Group::UniformArray(i) => {
                    let a = &UNIFORM_ARRAYS[i as usize];
                    a.fits(scene.array_bytes(a.name).len() / a.element_bytes)
                }
            };
            set.set(row.feature, needed);
        }
        for (k, knob) in KNOBS.iter().enumerate() {
            set.knobs[k] = Some((knob.read)(scene, params));
        }
        set
    }

    pub fn has(&self, f: Feature) -> bool {
        self.on & FeatureRow::bit(f) != 0
    }

    pub fn set(&mut self, f: Feature, on: bool) {
        if on {
            self.on |= FeatureRow::bit(f);
        } else {
            self.on &= !FeatureRow::bit(f);
        }
    }

    /// The knob's constant value, or `None` when the kernel reads it at run time.
    pub fn knob(&self, name: &str) -> Option<u32> {
        KNOBS
            .iter()
            .position(|k| k.name == name)
            .and_then(|i| self.knobs[i])
    }

    fn count_group(&self, material: bool) -> usize {
        features()
            .iter()
            .filter(|r| match r.group {
                Group::Material(_) => material,
                Group::Light(_) => !material,
                Group::Other | Group::UniformArray(_) => false,
            })
            .filter(|r| self.has(r.feature))
            .count()
    }

    /// Exactly one material kind is used (emitters included), so the kernel need not test the kind.
    pub fn single_material_kind(&self) -> bool {
        self.count_group(true) == 1
    }

    /// Exactly one light kind is present.
    pub fn single_light_kind(&self) -> bool {
        self.count_group(false) == 1
    }

    /// The values of the kernel's `override` constants (naga takes them as f64).
    pub fn pipeline_constants(&self) -> Vec<(&'static str, f64)> {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        let mut out: Vec<(&'static str, f64)> = features()
            .iter()
            .map(|r| (r.constant, b(self.has(r.feature))))
            .collect();
        out.push((SINGLE_MATERIAL_KIND, b(self.single_material_kind())));
        out.push((SINGLE_LIGHT_KIND, b(self.single_light_kind())));
        let textured = [
            Feature::Textures,
            Feature::EmissiveTextures,
            Feature::MetallicRoughnessTextures,
            Feature::PluginTextures,
            Feature::NormalMaps,
            Feature::BumpMaps,
            Feature::Opacity,
        ]
        .into_iter()
        .any(|f| self.has(f));
        out.push((HAS_MATERIAL_TEXTURES, b(textured)));
        out.push((
            HAS_MESH_SHADING,
            b(textured || self.has(Feature::SmoothNormals)),
        ));
        for (k, knob) in KNOBS.iter().enumerate() {
            let value = self.knobs[k];
            out.push((knob.from_params, b(value.is_none())));
            for &(constant, when) in knob.values {
                out.push(match when {
                    KNOB_VALUE => (constant, value.unwrap_or(0) as f64),
                    _ => (constant, b(value == Some(when))),
                });
            }
        }
        out
    }

    /// Switches the feature named as in [`FeatureSet::absent`] on (its code back in the kernel). Naming
    /// `triangles` brings back both ways of finding them (BVH and loop), as in the generic kernel, and
    /// `spheres` the sphere BVH beside their loop.
    pub fn enable(&mut self, name: &str) {
        if let Some(row) = features().iter().find(|r| r.name == name) {
            self.set(row.feature, true);
            if row.feature == Feature::Triangles {
                self.set(Feature::Bvh, true);
                self.set(Feature::TriangleLoop, true);
            }
            if row.feature == Feature::Spheres {
                self.set(Feature::SphereBvh, true);
            }
        }
    }

    /// The reported features this set leaves out, by name.
    pub fn absent(&self) -> Vec<&'static str> {
        features()
            .iter()
            .filter(|r| r.reported && !self.has(r.feature))
            .map(|r| r.name)
            .collect()
    }

    /// A short name of the kernel for reports: `generic`, or the features it keeps and the knobs it
    /// fixes, e.g. `spheres+diffuse+point_lights+roulette/filter=2,sampler=0,light_sampling=0`.
    pub fn kernel_name(&self) -> String {
        if self.is_generic() {
            return if self.has(Feature::SplitArrays) {
                "generic+split_arrays".into()
            } else {
                "generic".into()
            };
        }
        let on: Vec<&str> = features()
            .iter()
            .filter(|r| self.has(r.feature))
            .map(|r| r.name)
            .collect();
        let knobs: Vec<String> = KNOBS
            .iter()
            .zip(self.knobs)
            .filter_map(|(k, v)| v.map(|v| format!("{}={v}", k.name)))
            .collect();
        format!("{}/{}", on.join("+"), knobs.join(","))
    }
}

/// Serialised as the feature names it keeps and its knobs (for `--json` reports).
impl serde::Serialize for FeatureSet {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(None)?;
        for r in features() {
            map.serialize_entry(r.name, &self.has(r.feature))?;
        }
        for (k, v) in KNOBS.iter().zip(self.knobs) {
            map.serialize_entry(k.name, &v)?;
        }
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_constants_are_unique() {
        let mut names: Vec<&str> = features().iter().map(|r| r.name).collect();
        let mut constants: Vec<&str> = features().iter().map(|r| r.constant).collect();
        names.extend(KNOBS.iter().map(|k| k.name));
        constants.extend(
            KNOBS
                .iter()
                .flat_map(|k| std::iter::once(k.from_params).chain(k.values.iter().map(|v| v.0))),
        );
        let (n, c) = (names.len(), constants.len());
        names.sort();
        names.dedup();
        constants.sort();
        constants.dedup();
        assert_eq!((names.len(), constants.len()), (n, c));
    }

    #[test]
    fn generic_has_everything_and_reads_every_knob_but_the_output() {
        assert_eq!(KNOBS[AOV_KNOB].name, "aov");
        let g = FeatureSet::generic();
        assert!(features().iter().all(|r| g.has(r.feature)
            == !matches!(
                r.feature,
                Feature::SplitArrays | Feature::DataImages | Feature::UniformArray(_)
            )));
        assert!(g.absent().is_empty());
        assert_eq!(g.kernel_name(), "generic");
        let consts = g.pipeline_constants();
        assert!(consts.contains(&("LIGHT_SAMPLING_FROM_PARAMS", 1.0)));
        assert!(consts.contains(&("SINGLE_MATERIAL_KIND", 0.0)));
        assert!(consts.contains(&("AOV_FROM_PARAMS", 0.0)));
        assert!(consts.contains(&("AOV_KIND", f64::from(AOV_NONE))));
        // A layer's generic kernel is still the generic kernel.
        let mut layer = g;
        layer.knobs[AOV_KNOB] = Some(AOV_ALBEDO);
        assert!(layer.is_generic() && layer != g);
    }

    /// A glossy material switches on its own row only, and anisotropy only when its roughness differs
    /// between the axes; a scene without glossy materials keeps none of their code.
    #[test]
    fn glossy_rows_follow_the_materials_used() {
        use super::super::upload::{GpuScene, params_for};
        let scene_with = |material: &str| {
            let text = format!(
                "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[materials]\nm = {material}\n\
                 [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n[[light]]\ntype = \"point\"\n\
                 position = [0, 5, 5]\npower = 100\n"
            );
            let scene = crate::scene::Scene::from_toml_str(&text, None).expect("scene");
            FeatureSet::of(&GpuScene::build(&scene), &params_for(&scene, 3))
        };
        let glossy = [
            Feature::Material(MAT_CONDUCTOR),
            Feature::Material(MAT_ROUGH_DIELECTRIC),
            Feature::Material(MAT_PLASTIC),
            Feature::Material(MAT_METALLIC_ROUGHNESS),
            Feature::Anisotropy,
        ];
        let on =
            |f: &FeatureSet| -> Vec<Feature> { glossy.into_iter().filter(|&g| f.has(g)).collect() };
        let diffuse = scene_with("{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }");
        assert_eq!(on(&diffuse), vec![]);
        let gold = scene_with("{ type = \"conductor\", preset = \"gold\", roughness = 0.3 }");
        assert_eq!(on(&gold), vec![Feature::Material(MAT_CONDUCTOR)]);
        assert!(gold.single_material_kind());
        let brushed =
            scene_with("{ type = \"conductor\", preset = \"gold\", roughness = [0.1, 0.4] }");
        assert_eq!(
            on(&brushed),
            vec![Feature::Material(MAT_CONDUCTOR), Feature::Anisotropy]
        );
        let smooth_glass = scene_with("{ type = \"dielectric\", ior = 1.5, roughness = 0 }");
        assert_eq!(on(&smooth_glass), vec![]);
        assert!(smooth_glass.has(Feature::Material(MAT_DIELECTRIC)));
        let frosted = scene_with("{ type = \"dielectric\", ior = 1.5, roughness = 0.5 }");
        assert_eq!(on(&frosted), vec![Feature::Material(MAT_ROUGH_DIELECTRIC)]);
        assert!(!frosted.has(Feature::Material(MAT_DIELECTRIC)));
        let plastic = scene_with("{ type = \"plastic\", albedo = [0.5, 0.5, 0.5] }");
        assert_eq!(on(&plastic), vec![Feature::Material(MAT_PLASTIC)]);
        let pbr = scene_with("{ type = \"metallic_roughness\" }");
        assert_eq!(on(&pbr), vec![Feature::Material(MAT_METALLIC_ROUGHNESS)]);
    }

    /// A specialised kernel has the scene's sizes as loop bounds: 12-triangle lists 9 spheres, a sphere
    /// light (one more sphere, its emitting surface) and 2 triangles (too few for a BVH, so the loop
    /// finds them); the generic kernel reads all three from `params`.
    #[test]
    fn scene_sizes_are_constants_of_a_specialised_kernel() {
        use super::super::upload::{GpuScene, params_for};
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/12-triangle.toml"
        ))
        .expect("scene file");
        let scene = crate::scene::Scene::from_toml_str(&text, None).expect("scene");
        let f = FeatureSet::of(&GpuScene::build(&scene), &params_for(&scene, 3));
        assert_eq!(f.knob("sphere_count"), Some(10));
        assert_eq!(f.knob("triangle_count"), Some(2));
        assert_eq!(f.knob("light_count"), Some(1));
        assert!(f.has(Feature::TriangleLoop) && !f.has(Feature::Bvh));
        let consts = f.pipeline_constants();
        for c in [
            ("SPHERE_COUNT_FROM_PARAMS", 0.0),
            ("SPHERE_COUNT", 10.0),
            ("TRIANGLE_COUNT", 2.0),
        ] {
            assert!(consts.contains(&c), "{c:?}");
        }
        let generic = FeatureSet::generic().pipeline_constants();
        assert!(generic.contains(&("SPHERE_COUNT_FROM_PARAMS", 1.0)));
        assert!(generic.contains(&("LIGHT_COUNT_FROM_PARAMS", 1.0)));
    }

    #[test]
    fn enable_and_set() {
        let mut f = FeatureSet::generic();
        f.set(Feature::Triangles, false);
        f.set(Feature::Bvh, false);
        assert_eq!(f.absent(), vec!["triangles"]);
        f.enable("triangles");
        assert!(f.has(Feature::Bvh) && f.has(Feature::TriangleLoop));
    }
}
