//! The kernel's ABI: the `#[repr(C)]` Pod structs shared with the WGSL (scene_data.wgsl,
//! bsdfs/common.wgsl, lights/*.wgsl, accumulate.wgsl) and every constant the host and the shader must agree on.
//!
//! WGSL's layout rules put a `vec3<f32>` at 16-byte alignment with size 12, so every `vec3` here is
//! followed by a 4-byte scalar that fills its slot, and structs are padded to a multiple of 16 bytes.
//! The compile-time asserts below pin the sizes; `tests/layout.rs` holds every field offset against the
//! layout naga reflects from the WGSL.

use super::coat::COAT_NODES;
use super::light_kinds;
use crate::materials::BLOCK_WORDS;
use crate::scene::bsdfs;
use bytemuck::{Pod, Zeroable};

/// Per-render constants (uniform buffer `params`). Mirrors `Params` in scene_data.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuParams {
    pub cam_position: [f32; 3],
    pub lens_radius: f32,
    pub cam_right: [f32; 3],
    /// Half the width of the view: of the image plane at distance 1, tan(fov / 2), for a perspective
    /// camera; of the film itself, extent / 2, for an orthographic one.
    pub view_half_width: f32,
    pub cam_up: [f32; 3],
    pub focus_distance: f32,
    pub cam_forward: [f32; 3],
    /// The Gaussian's standard deviation or the tent's radius, in pixels.
    pub filter_width: f32,
    /// The index in `lights` of the environment light ([`NO_LIGHT`]: none), which rays that leave the
    /// scene see.
    pub environment_light: u32,
    /// The index in `lights` of the emissive triangles' light ([`NO_LIGHT`]: none), for the MIS weight
    /// of a BSDF-sampled ray that hits one.
    pub triangle_light: u32,
    /// `render.clamp`: the largest channel a sample may have (it is scaled down to it); 0: no clamp.
    pub sample_clamp: f32,
    pub filter_kind: u32,
    pub width: u32,
    pub height: u32,
    pub max_bounces: u32,
    pub seed: u32,
    /// `scene::Sampler`: [`SAMPLER_INDEPENDENT`] or [`SAMPLER_SOBOL`].
    pub sampler: u32,
    /// `scene::LightSampling`: one of the `LIGHT_SAMPLING_*` constants.
    pub light_sampling: u32,
    pub num_spheres: u32,
    pub num_triangles: u32,
    pub num_lights: u32,
    pub roulette_depth: u32,
    pub guard_one: f32,
    /// [`CAMERA_PERSPECTIVE`] or [`CAMERA_ORTHOGRAPHIC`].
    pub camera_kind: u32,
    /// What a sample is: [`AOV_NONE`], radiance (the render); else one of the `AOV_*` layers of
    /// `--aov`, traced by the same kernel through the same camera rays (trace.wgsl, `trace_aov`).
    pub aov: u32,
    /// 1: a pixel's filter is cut off at the image's edges (`render.sample_border = false`); 0: not.
    pub filter_in_image: u32,
    /// 1: the radiance samples are splatted (`render.splat`): each is drawn uniformly in its pixel and
    /// also written to `splat_samples` for the film-side gather (shaders/splat.wgsl); 0: each sample
    /// counts for its own pixel only, its position drawn from the pixel filter.
    pub splat: u32,
    pub _pad: u32,
}

/// Mirrors `PassConstants` in scene_data.wgsl: which samples the next dispatch traces (`sample_count`
/// of them from `sample_index` on, in each pixel), over which tile, into which accumulator strip (updated
/// in the command buffer before each dispatch).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPassConstants {
    pub sample_index: u32,
    /// The pixel index (row-major over the whole image) of the bound accumulator's first entry.
    pub accum_base: u32,
    /// The tile: the pixels from (tile_x0, tile_y0) (included) to (tile_x1, tile_y1) (excluded).
    pub tile_x0: u32,
    pub tile_y0: u32,
    pub tile_x1: u32,
    pub tile_y1: u32,
    pub sample_count: u32,
    /// Path continuation (trace.wgsl, `main`): 0 for a dispatch that begins the tile's paths (one
    /// invocation per pixel), else the number of paths it continues (one invocation each), whose
    /// `path_state` slots are listed from `path_queue[queue_in]` on.
    pub queued: u32,
    pub queue_in: u32,
    /// Where the dispatch lists the paths still going after `casts` ray casts (their count in
    /// `path_count`).
    pub queue_out: u32,
    /// The most ray casts one invocation makes in this dispatch ([`crate::render::casts_per_dispatch`]).
    pub casts: u32,
    /// The first sample index of the pass: sample s of a pixel is splat record s - pass_start
    /// (`splat_samples`, trace.wgsl).
    pub pass_start: u32,
    /// Adaptive sampling (`crate::render::adaptive`): when `list_len > 0`, the dispatch that begins
    /// paths traces the pixels `active_pixels[list_start..list_start + list_len]` (row-major indices,
    /// one invocation each, in rows `tile_x1 - tile_x0` wide) instead of the tile's rectangle.
    pub list_start: u32,
    pub list_len: u32,
}

/// Mirrors `Sphere` in scene_data.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSphere {
    pub center: [f32; 3],
    pub radius: f32,
    pub material: u32,
    pub _pad: [u32; 3],
}

/// Mirrors `Triangle` in scene_data.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    pub _pad0: u32,
    pub v2: [f32; 3],
    pub _pad1: u32,
}

/// The material kinds the host uploads by name (`GpuMaterial::kind`): their rows' indices in the registry
/// (`scene::bsdfs`), which also numbers the generated WGSL constants.
pub const MAT_DIFFUSE: u32 = bsdfs::kind("diffuse");
pub const MAT_MIRROR: u32 = bsdfs::kind("mirror");
pub const MAT_DIELECTRIC: u32 = bsdfs::kind("dielectric");
pub const MAT_EMITTER: u32 = bsdfs::kind("emitter");
pub const MAT_CONDUCTOR: u32 = bsdfs::kind("conductor");
pub const MAT_ROUGH_DIELECTRIC: u32 = bsdfs::kind("rough_dielectric");
pub const MAT_PLASTIC: u32 = bsdfs::kind("plastic");
pub const MAT_METALLIC_ROUGHNESS: u32 = bsdfs::kind("metallic_roughness");
pub const MAT_THIN_DIELECTRIC: u32 = bsdfs::kind("thin_dielectric");
pub const MAT_PRINCIPLED: u32 = bsdfs::kind("principled");
pub const MAT_GLTF_PBR: u32 = bsdfs::kind("gltf_pbr");

/// `GpuMaterial::flags`: the material emits from both faces (else only from the front: the side its
/// geometric normal faces).
pub const MATERIAL_TWO_SIDED_EMISSION: u32 = 1;
/// `GpuMaterial::flags`: a conductor's Fresnel is Schlick's, from `albedo` as the reflectance at normal
/// incidence.
pub const MATERIAL_SCHLICK: u32 = 2;
/// GpuMaterial::flags: a plastic whose base's internal reflections are not tinted by its albedo
/// (Mitsuba's `nonlinear = false`; bsdfs/coated.wgsl).
pub const MATERIAL_LINEAR: u32 = 4;
/// GpuMaterial::flags: the microfacet normals follow Beckmann's distribution, not GGX's
/// (microfacet.wgsl).
pub const MATERIAL_BECKMANN: u32 = 8;
/// GpuMaterial::flags: a rough plastic whose light crosses its coat with the rough interface's own
/// transmittance, tabulated in `coat` (Mitsuba's roughplastic; bsdfs/coated.wgsl), not the smooth 1 - F.
pub const MATERIAL_ROUGH_COAT: u32 = 16;
/// GpuMaterial::flags: only the front face scatters; a path reaching the back ends there (trace.wgsl,
/// path_step; Mitsuba's BSDFs without `twosided`).
pub const MATERIAL_ONE_SIDED: u32 = 32;
/// GpuMaterial::flags: a gltf_pbr material's transmission bounds an absorbing medium
/// (KHR_materials_volume; bsdfs/gltf_pbr.wgsl, and trace.wgsl's path_step, which absorbs).
pub const MATERIAL_VOLUME: u32 = 64;

/// GGX alpha below which a glossy surface is uploaded (and shaded) as smooth: a delta lobe
/// (`SMOOTH_ALPHA` in microfacet.wgsl, which says why).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// `BsdfSample::flags` (bsdf.wgsl): the lobe a sampled direction came from.
pub const BSDF_REFLECTION: u32 = 1;
pub const BSDF_TRANSMISSION: u32 = 2;
pub const BSDF_DELTA: u32 = 4;

/// Mirrors `Material` in bsdfs/common.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Diffuse albedo, mirror tint, plastic base, glTF base colour or a Schlick conductor's f0; a
    /// conductor's tint beside eta and k.
    pub albedo: [f32; 3],
    pub kind: u32,
    /// Emitted radiance (W sr^-1 m^-2), zero for a material that does not emit.
    pub emission: [f32; 3],
    /// Dielectrics and plastic: index of refraction inside over outside.
    pub ior: f32,
    /// Conductors: the complex index of refraction eta + i k, per channel; a Schlick conductor's tint.
    pub eta: [f32; 3],
    /// GGX alpha (= roughness^2) along the tangent.
    pub alpha_x: f32,
    pub k: [f32; 3],
    /// GGX alpha along the bitangent.
    pub alpha_y: f32,
    /// [`MATERIAL_TWO_SIDED_EMISSION`] | [`MATERIAL_SCHLICK`].
    pub flags: u32,
    /// metallic_roughness: the metal's weight.
    pub metallic: f32,
    /// Plastic: the coat's internal diffuse reflectance, 2 \int_0^1 F(c, 1/ior) c dc (a rough coat's:
    /// `coat::coat_table`).
    pub fdr_int: f32,
    /// 1 + the index of the material the back face shows (the `back` modifier: Mitsuba's twosided
    /// with two BSDFs); 0: the back shows this material (zero, as every unused field, by default).
    pub back: u32,
    /// The kind's own parameters (`Material::block` in bsdfs/common.wgsl): a material plugin's, laid
    /// out by its declaration (`crate::materials`); a plastic with [`MATERIAL_ROUGH_COAT`]: its rough
    /// coat's transmittance T(mu) at mu_j = (j / 15)^2 (`coat::coat_table`; bsdfs/coated.wgsl,
    /// coat_transmittance); gltf_pbr: its layers' weights and tables (bsdfs/gltf_pbr.wgsl).
    pub block: [f32; BLOCK_WORDS],
}

/// Light kinds: the rows of the light registry (`kernel::light_kinds`; `LIGHT_*` in the generated
/// light_kinds.wgsl).
pub const LIGHT_POINT: u32 = light_kinds::kind("point");
pub const LIGHT_SPHERE: u32 = light_kinds::kind("sphere");
pub const LIGHT_DIRECTIONAL: u32 = light_kinds::kind("directional");
pub const LIGHT_TRIANGLES: u32 = light_kinds::kind("triangles");
pub const LIGHT_ENVIRONMENT: u32 = light_kinds::kind("environment");
pub const LIGHT_SPOT: u32 = light_kinds::kind("spot");
/// No light: `GpuParams::environment_light` of a scene without an environment.
pub const NO_LIGHT: u32 = u32::MAX;

/// Mirrors `Light` in lights/common.wgsl. What each field holds depends on the kind (see there).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub radius: f32,
    pub intensity: [f32; 3],
    pub kind: u32,
    /// Sphere light: its emitter sphere in `spheres`; triangle lights: the number of emissive triangles.
    pub index: u32,
    /// Environment light: the map's size in pixels (0 x 0: no map, a uniform radiance).
    pub map_width: u32,
    pub map_height: u32,
    /// Spot light: 0 the linear falloff (in the angle), 1 the smooth one (glTF's; `SpotFalloff`).
    pub spot_falloff: u32,
    /// Spot light: the unit axis of its cone, 1 / (cutoff - beam) (radians; smooth: 1 / max(0.001,
    /// cos beam - cos cutoff)), and (cos, sin) of the cutoff and the beam half-angles.
    pub axis: [f32; 3],
    pub spot_inv_width: f32,
    pub spot_cone: [f32; 4],
}

/// Mirrors `LightTriangle` in lights/triangles.wgsl: one emissive triangle (its vertices as in `triangles`, its
/// material's emission) and its column of the alias table that picks triangles in proportion to their
/// power (Walker 1977; Vose 1991): column j keeps triangle j with probability `keep`, else gives `alias_triangle`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLightTriangle {
    pub v0: [f32; 3],
    pub alias_triangle: u32,
    pub v1: [f32; 3],
    pub keep: f32,
    pub v2: [f32; 3],
    /// [`MATERIAL_TWO_SIDED_EMISSION`] when it emits from both faces.
    pub flags: u32,
    pub emission: [f32; 3],
    /// Its index in `triangles` (whose mesh may texture the emission).
    pub triangle: u32,
}

/// Limbs (u32) of one channel's exact sum: a 192-bit fixed-point integer in units of 2^-96.
pub const ACCUM_LIMBS: usize = 6;

/// Mirrors `Accum` in accumulate.wgsl: per channel, the exact sum of the samples as a long accumulator
/// (`sum[c * ACCUM_LIMBS + k]` is limb k of channel c, little-endian, unit 2^-96), and the Kahan-compensated
/// f32 sum of their squares. See `crate::accum` for reading and adding them on the host.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAccum {
    pub sum: [u32; 3 * ACCUM_LIMBS],
    pub sum_sq: [f32; 3],
    pub sum_sq_c: [f32; 3],
}

/// Mirrors `SplatAccum` in accumulate.wgsl: a pixel's splatted sums (`render.splat`, shaders/splat.wgsl).
/// `sum` is, per channel, the exact sum of w L over the samples whose filter footprint covers the pixel
/// (laid out as [`GpuAccum::sum`]); `weight` the exact sum of their weights w, a 64-bit integer in units
/// of 2^-[`SPLAT_WEIGHT_BITS`] (`weight[0]` the low word). The pixel's value is sum / weight (Mitsuba 3's
/// film: the filter-weighted average of the samples).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSplatAccum {
    pub sum: [u32; 3 * ACCUM_LIMBS],
    pub weight: [u32; 2],
}

/// A splat weight w in [0, 1] is rounded to a multiple of 2^-SPLAT_WEIGHT_BITS before use, so that its
/// sum over any number of samples is an exact integer (and w L is computed from the rounded w).
pub const SPLAT_WEIGHT_BITS: u32 = 24;

/// Bytes of one splat record (`splat_samples`, trace.wgsl): the sample's radiance and its position in
/// its pixel, packed as two 16-bit fixed-point fractions.
pub const SPLAT_RECORD_BYTES: u64 = 16;

/// Mirrors `SplatConstants` in splat.wgsl: one gather dispatch adds records `first..first + count` of
/// every pixel to the splatted sums of the rows `row0..row1` (the bound strip, whose entry 0 is pixel
/// `accum_base`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSplatConstants {
    pub width: u32,
    pub height: u32,
    pub accum_base: u32,
    pub row0: u32,
    pub row1: u32,
    pub first: u32,
    pub count: u32,
    /// [`FILTER_TENT`] or [`FILTER_GAUSSIAN`].
    pub filter_kind: u32,
    /// The tent's radius or the Gaussian's standard deviation, in pixels.
    pub filter_width: f32,
    /// K: the pixels within K of a pixel on each axis are those whose samples can reach its centre
    /// (`render::splat::reach`).
    pub reach: u32,
    pub _pad: [u32; 2],
}

/// Mirrors `BvhNode` in scene_data.wgsl: an interior node of the 4-wide triangle BVH with its children's
/// boxes quantised (`scene::bvh::QuantisedNode`: plane = origin + q 2^(e - 127), q one byte per child and
/// plane), so that the walk fetches 14 words a node instead of 28 and tests the four boxes with vector
/// arithmetic. `child[k]` is a node index, a leaf reference with `scene::bvh::LEAF` set, or
/// `scene::bvh::NO_CHILD` for an unused slot.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBvhNode {
    pub origin: [f32; 3],
    /// Biased exponents of the x, y, z scales in bits 0-7, 8-15, 16-23.
    pub exponents: u32,
    /// Child k's planes in byte k of: lo_x, hi_x, lo_y, hi_y.
    pub planes_xy: [u32; 4],
    /// ... and of lo_z, hi_z.
    pub planes_z: [u32; 2],
    pub _pad: [u32; 2],
    pub child: [u32; 4],
}

/// No mesh: `GpuMeshFace::mesh` of a triangle that has no shading data (a `[[triangle]]` or a flat,
/// untextured mesh).
pub const NO_MESH: u32 = u32::MAX;
/// `GpuMeshInfo::flags`: interpolate the vertex normals.
pub const MESH_SMOOTH: u32 = 1;
/// `GpuMeshInfo::flags`: the mesh's vertices have texture coordinates (a triangle without has its
/// barycentrics (b1, b2) as uv).
pub const MESH_UV: u32 = 2;
/// No texture: a `GpuMaterialTextures` texture index that is unused.
pub const NO_TEXTURE: u32 = u32::MAX;
/// `GpuTextureInfo::flags` (texture.wgsl): the texels hold sRGB-encoded colour, decoded before
/// filtering. Without it they are linear data (roughness, normal and bump maps), read as they are.
pub const TEXTURE_SRGB: u32 = 1;
/// `GpuTextureInfo::flags`: two words per texel, RGBA as four f16 (EXR and HDR images); else one, RGBA8.
pub const TEXTURE_HALF: u32 = 2;
/// `GpuTextureInfo::flags`: the nearest texel; else bilinear filtering.
pub const TEXTURE_NEAREST: u32 = 4;
/// `GpuTextureInfo::flags`: uv outside [0, 1] clamps to the edge texels; else it repeats.
pub const TEXTURE_CLAMP: u32 = 8;
/// `GpuTextureInfo::flags`: uv outside [0, 1] repeats mirrored.
pub const TEXTURE_MIRROR: u32 = 16;
/// `GpuTextureInfo::flags`: not an image but Mitsuba's checkerboard of two colours, stored as six f32
/// at `offset` (`Texture::checkerboard`).
pub const TEXTURE_CHECKERBOARD: u32 = 32;
/// `GpuTextureInfo::flags` bits 8-10: the channel(s) the texture gives (`TEXTURE_CHANNEL_*`).
pub const TEXTURE_CHANNEL_SHIFT: u32 = 8;
pub const TEXTURE_CHANNEL_RGB: u32 = 0;
pub const TEXTURE_CHANNEL_R: u32 = 1;
pub const TEXTURE_CHANNEL_G: u32 = 2;
pub const TEXTURE_CHANNEL_B: u32 = 3;
pub const TEXTURE_CHANNEL_A: u32 = 4;
pub const TEXTURE_CHANNEL_LUMINANCE: u32 = 5;
/// `GpuMaterialTextures::flags`: opacity below `alpha_cutoff` is a hole (a cut-out); without it,
/// opacity is stochastic transparency.
pub const MATERIAL_CUTOUT: u32 = 1;

/// Mirrors `MeshFace` in scene_data.wgsl: the shading vertices of triangle i (same index as in
/// `triangles`) and the mesh it belongs to.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMeshFace {
    pub vertices: [u32; 3],
    pub mesh: u32,
}

/// Mirrors `MeshVertex` in scene_data.wgsl: a shading normal (world space, unit, or zero for "use the
/// geometric normal"), texture coordinates, and a normal map's tangent ([`encode_tangent`]; 0: none).
/// Scalars only, so 24 bytes with no padding.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMeshVertex {
    pub nx: f32,
    pub ny: f32,
    pub nz: f32,
    pub u: f32,
    pub v: f32,
    pub tangent: u32,
}

/// `GpuMeshVertex::tangent`: bit 31 set when the vertex has a tangent, bit 30 set when its bitangent
/// sign w is negative, and the unit direction in bits 0-29 as its octahedral map (Cigolle et al.,
/// "A Survey of Efficient Representations for Independent Unit Vectors", JCGT 2014): p = (x, y) /
/// (|x| + |y| + |z|), folded over the diagonals when z < 0 ((1 - |p.yx|) sign(p)), each coordinate in
/// [-1, 1] stored in 15 bits (an angular error below 1e-4 rad). Decoded by `mesh_tangent` in
/// scene_data.wgsl. A zero or non-finite direction is no tangent (0).
pub fn encode_tangent(t: [f32; 4]) -> u32 {
    let [x, y, z, w] = t;
    let l1 = x.abs() + y.abs() + z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return 0;
    }
    let (mut px, mut py) = (x / l1, y / l1);
    if z < 0.0 {
        let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
        (px, py) = ((1.0 - py.abs()) * sign(px), (1.0 - px.abs()) * sign(py));
    }
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 32767.0).round() as u32;
    (1 << 31) | (u32::from(w < 0.0) << 30) | (q(py) << 15) | q(px)
}

/// Mirrors `MeshInfo` in scene_data.wgsl: per mesh, its `MESH_*` flags. (A mesh's textures belong to
/// its material: [`GpuMaterialTextures`].)
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMeshInfo {
    pub flags: u32,
    pub _pad: [u32; 3],
}

/// Mirrors `Instance` in scene_data.wgsl: one placement of an instanced mesh (`scene::mesh::InstancedMesh`)
/// or, with the identity, the scene's other triangles, in a scene with instances. The rows of the
/// world-to-object map (the walk takes rays into the mesh's space: x' = dot(row.xyz, x) + row.w) and of
/// the object-to-world map (hit points, vertex tangents; its inverse transpose, the transpose of the
/// first, maps normals); `root` is the node of `bvh_nodes` where the mesh's own tree starts.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    pub to_object_x: [f32; 4],
    pub to_object_y: [f32; 4],
    pub to_object_z: [f32; 4],
    pub to_world_x: [f32; 4],
    pub to_world_y: [f32; 4],
    pub to_world_z: [f32; 4],
    pub root: u32,
    /// `INSTANCE_*` flags.
    pub flags: u32,
    /// The material every face of this placement takes instead of its own (an `[[instance]]` in a
    /// material of its own: `scene::mesh::MeshPlacement::material`), or [`NO_MATERIAL`].
    pub material: u32,
    pub _pad: u32,
}

/// `GpuInstance::flags`: the placement mirrors (negative determinant): the triangles' winding normal
/// is flipped, so that a face's front stays the side its counter-clockwise winding calls the front
/// (as `scene::mesh::place` reverses the winding of a mirrored mesh).
pub const INSTANCE_MIRRORS: u32 = 1;
/// A hit on a triangle in world space (scene_data.wgsl, `Hit::instance`).
pub const NO_INSTANCE: u32 = u32::MAX;
/// `GpuInstance::material`: the placement's faces keep their own materials.
pub const NO_MATERIAL: u32 = u32::MAX;

/// Mirrors `TextureInfo` in scene_data.wgsl: one texture reference of the texture table: its image's
/// texels in `texels` from `offset` on, row-major from the top-left, `width` x `height` (one word per
/// texel, two with [`TEXTURE_HALF`]), read at uv' = M uv + `uv_offset` with M = [[m0, m1], [m2, m3]]
/// (`uv_matrix`), and the `TEXTURE_*` flags' wrap mode, filter, channel and colour space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub flags: u32,
    pub uv_matrix: [f32; 4],
    pub uv_offset: [f32; 2],
    pub _pad: [u32; 2],
}

/// Mirrors `MaterialTextures` in scene_data.wgsl: material i's textures (each an index into `textures`
/// or [`NO_TEXTURE`]) and surface modifiers, parallel to `materials`. A textured parameter is the
/// material's constant (the reference's factor) times the texture's value.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterialTextures {
    pub albedo_texture: u32,
    pub roughness_texture: u32,
    pub metallic_texture: u32,
    pub emission_texture: u32,
    pub opacity_texture: u32,
    pub bump_texture: u32,
    pub normal_texture: u32,
    /// [`MATERIAL_CUTOUT`] or 0.
    pub flags: u32,
    /// The fraction of light the surface stops, in [0, 1] (times the opacity texture).
    pub opacity: f32,
    pub alpha_cutoff: f32,
    /// Scene units of height per unit of the bump texture's value.
    pub bump_scale: f32,
    /// The factor of the normal map's x and y.
    pub normal_scale: f32,
    /// 1 + the index of the material a hit shows instead with probability `blend_weight` (times the
    /// blend texture): the `blend` modifier, Mitsuba's blendbsdf; 0: none.
    pub blend: u32,
    pub blend_weight: f32,
    pub blend_texture: u32,
    pub _pad0: u32,
}

impl Default for GpuMaterialTextures {
    /// No texture, fully opaque.
    fn default() -> Self {
        GpuMaterialTextures {
            albedo_texture: NO_TEXTURE,
            roughness_texture: NO_TEXTURE,
            metallic_texture: NO_TEXTURE,
            emission_texture: NO_TEXTURE,
            opacity_texture: NO_TEXTURE,
            bump_texture: NO_TEXTURE,
            normal_texture: NO_TEXTURE,
            flags: 0,
            opacity: 1.0,
            alpha_cutoff: 0.0,
            bump_scale: 1.0,
            normal_scale: 1.0,
            blend: 0,
            blend_weight: 0.0,
            blend_texture: NO_TEXTURE,
            _pad0: 0,
        }
    }
}

impl GpuMaterialTextures {
    /// Every texture index, for checks that go over all of them.
    pub fn texture_indices(&self) -> [u32; 8] {
        [
            self.albedo_texture,
            self.roughness_texture,
            self.metallic_texture,
            self.emission_texture,
            self.opacity_texture,
            self.bump_texture,
            self.normal_texture,
            self.blend_texture,
        ]
    }

    /// Whether the material has any texture or modifier (else the kernel need not read the entry).
    pub fn is_plain(&self) -> bool {
        *self == GpuMaterialTextures::default()
    }
}

/// Projections (`GpuParams::camera_kind`, `CAMERA_*` in camera.wgsl).
pub const CAMERA_PERSPECTIVE: u32 = 0;
pub const CAMERA_ORTHOGRAPHIC: u32 = 1;

/// Pixel filters (`GpuParams::filter_kind`, `FILTER_*` in trace.wgsl).
pub const FILTER_NONE: u32 = 0;
pub const FILTER_BOX: u32 = 1;
pub const FILTER_GAUSSIAN: u32 = 2;
pub const FILTER_TENT: u32 = 3;

/// Samplers (`GpuParams::sampler`, `SAMPLER_*` in rng.wgsl).
pub const SAMPLER_INDEPENDENT: u32 = 0;
pub const SAMPLER_SOBOL: u32 = 1;

/// Sphere-light strategies (`GpuParams::light_sampling`, `LIGHT_SAMPLING_*` in lights/common.wgsl).
pub const LIGHT_SAMPLING_CONE: u32 = 0;
pub const LIGHT_SAMPLING_AREA: u32 = 1;
pub const LIGHT_SAMPLING_NONE: u32 = 2;
pub const LIGHT_SAMPLING_MIS: u32 = 3;

/// What the kernel's samples are (`GpuParams::aov`, `AOV_*` in trace.wgsl): radiance, or one of the
/// layers `--aov` adds to the EXR (the variance layer comes from the render's own sums instead).
pub const AOV_NONE: u32 = 0;
pub const AOV_ALBEDO: u32 = 1;
pub const AOV_NORMAL: u32 = 2;
pub const AOV_DEPTH: u32 = 3;

/// The counters of `sample_faults` (scene_data.wgsl): samples clamped below 2^64 by the accumulator, and
/// samples dropped as not finite (see accumulate.wgsl).
pub const SAMPLE_FAULT_COUNTERS: usize = 3;
/// The third counter of `sample_faults`: paths ended by [`BOUNCE_CAP`] (trace.wgsl, path_step).
pub const FAULT_BOUNCE_CAP: u32 = 2;

/// `max_bounces` in the scene means this many at most on the device. A scene without a bounce limit
/// (`max_bounces = -1`, Mitsuba's `max_depth = -1`) ends its paths by Russian roulette only, and with
/// roulette a path survives each bounce with probability at most 0.95, so it reaches 1024 bounces with
/// probability below 0.95^1020 ~ 2e-23. The cap is there for what cannot end by roulette (roulette
/// turned off in a closed scene): every path it ends is counted (`FAULT_BOUNCE_CAP`) and reported, never
/// dropped silently. Paths of any length cost nothing more than their ray casts: the kernel carries a
/// path across dispatches (trace.wgsl, `main`), so no loop of one invocation grows with it.
pub const BOUNCE_CAP: u32 = 1024;

/// Bytes of one path's state between dispatches (`PathState` in trace.wgsl; `tests/layout.rs` checks it
/// against naga's layout).
pub const PATH_STATE_BYTES: u64 = 96;

/// Arrays split across bindings (`SPLIT_ARRAYS`): each part holds 2^bits elements.
pub const TRIANGLE_PART_BITS: u32 = 21;
pub const BVH_NODE_PART_BITS: u32 = 21;
pub const MESH_FACE_PART_BITS: u32 = 23;
pub const MESH_VERTEX_PART_BITS: u32 = 22;
pub const TEXEL_PART_BITS: u32 = 25;

/// A scene array the kernel reads through several storage bindings, because a large scene's array can
/// exceed what one binding may hold: Vulkan guarantees only `maxStorageBufferRange` >= 2^27 bytes (128
/// MiB), which is exactly lavapipe's limit, and 10^7 triangles take 457 MiB. Part k holds elements
/// [k 2^part_bits, (k + 1) 2^part_bits) under the WGSL name `parts[k]`, and every part is at most 2^27
/// bytes, so the split fits any Vulkan device. The shader reads the array through one accessor
/// (`triangle_at`, ... in scene_data.wgsl) that picks the part by the index's high bits, a switch the
/// specialised kernel of a scene whose arrays fit one part does not have (`HAS_SPLIT_ARRAYS`). The part
/// counts bound the scene: 8 x 2^21 = 16.8 M triangles, with room for their nodes, faces, vertices (when
/// shared by about two triangles each, as in closed meshes) and 512 MiB of texels.
pub struct SplitArray {
    /// The array's name (`GpuScene`'s field, and the WGSL name of part 0).
    pub name: &'static str,
    pub element_bytes: usize,
    pub part_bits: u32,
    /// The WGSL binding name of each part.
    pub parts: &'static [&'static str],
}

impl SplitArray {
    pub const fn part_elements(&self) -> usize {
        1 << self.part_bits
    }

    /// The most elements the parts hold.
    pub const fn max_elements(&self) -> usize {
        self.parts.len() << self.part_bits
    }

    /// The bytes of part `k` of the array whose bytes are `bytes` (empty past its end).
    pub fn part<'a>(&self, bytes: &'a [u8], k: usize) -> &'a [u8] {
        let n = self.part_elements() * self.element_bytes;
        &bytes[(k * n).min(bytes.len())..((k + 1) * n).min(bytes.len())]
    }

    /// Whether `elements` need more than the first part.
    pub const fn needs_split(&self, elements: usize) -> bool {
        elements > self.part_elements()
    }
}

pub const SPLIT_ARRAYS: [SplitArray; 5] = [
    SplitArray {
        name: "triangles",
        element_bytes: std::mem::size_of::<GpuTriangle>(),
        part_bits: TRIANGLE_PART_BITS,
        parts: &[
            "triangles",
            "triangles_1",
            "triangles_2",
            "triangles_3",
            "triangles_4",
            "triangles_5",
            "triangles_6",
            "triangles_7",
        ],
    },
    SplitArray {
        name: "bvh_nodes",
        element_bytes: std::mem::size_of::<GpuBvhNode>(),
        part_bits: BVH_NODE_PART_BITS,
        parts: &["bvh_nodes", "bvh_nodes_1", "bvh_nodes_2", "bvh_nodes_3"],
    },
    SplitArray {
        name: "mesh_faces",
        element_bytes: std::mem::size_of::<GpuMeshFace>(),
        part_bits: MESH_FACE_PART_BITS,
        parts: &["mesh_faces", "mesh_faces_1"],
    },
    SplitArray {
        name: "mesh_vertices",
        element_bytes: std::mem::size_of::<GpuMeshVertex>(),
        part_bits: MESH_VERTEX_PART_BITS,
        parts: &[
            "mesh_vertices",
            "mesh_vertices_1",
            "mesh_vertices_2",
            "mesh_vertices_3",
        ],
    },
    SplitArray {
        name: "texels",
        element_bytes: std::mem::size_of::<u32>(),
        part_bits: TEXEL_PART_BITS,
        parts: &["texels", "texels_1", "texels_2", "texels_3"],
    },
];

/// The split array named `name`, if it is one.
pub fn split_array(name: &str) -> Option<&'static SplitArray> {
    SPLIT_ARRAYS.iter().find(|a| a.name == name)
}

/// The bytes one uniform twin (`UNIFORM_ARRAYS`) holds: lavapipe's `maxUniformBufferRange`, and the
/// size of each WGSL twin's fixed-length array. A device with a smaller range reads every array from its
/// storage binding (`render::uniform_arrays_help`).
pub const UNIFORM_ARRAY_BYTES: usize = 65536;

/// A scene array that a small scene's kernel reads from a uniform buffer (its "uniform twin") instead of
/// its storage binding, on a CPU device. Why: Mesa 25's llvmpipe reads a storage-buffer word whose index
/// differs between the lanes of a SIMD vector one lane at a time, each behind a branch on the lane's
/// execution mask and another on the buffer's bounds (`emit_load_mem`, gallivm/lp_bld_nir_soa.c: about a
/// dozen instructions and two branches per lane and word), while a uniform-buffer read with such an
/// index is a branchless loop of scalar loads (`emit_load_ubo` and `build_gather`, the out-of-range lanes
/// redirected to element 0). The BVH walk, the shading and the light sampling index their arrays per
/// lane, so a scene whose arrays fit the twins traces up to 1.4x more samples per CPU second on Mesa
/// 25's lavapipe (docs/performance.md, "Small scenes through uniform buffers"; Mesa 26 gathers both
/// kinds of read alike and gains nothing, so `render::uniform_arrays_help` leaves it out). A GPU's
/// constant caches serialise reads whose addresses differ between the threads of a warp, so GPUs keep
/// the storage bindings.
/// `tests/layout.rs` holds the table against the WGSL: each twin a uniform binding of
/// `UNIFORM_ARRAY_BYTES / element_bytes` elements of the array's element type.
pub struct UniformArray {
    /// The array's name (`GpuScene::array_bytes`, and its storage binding's WGSL name).
    pub name: &'static str,
    /// The uniform twin's WGSL name.
    pub uniform: &'static str,
    /// The WGSL `override` that makes the kernel read the twin (features.wgsl).
    pub constant: &'static str,
    pub element_bytes: usize,
}

impl UniformArray {
    /// The most elements the twin holds.
    pub const fn max_elements(&self) -> usize {
        UNIFORM_ARRAY_BYTES / self.element_bytes
    }

    /// Whether an array of `elements` is read through the twin: not empty (the kernel tests an empty
    /// tree's storage binding for its length), and not longer than the twin.
    pub const fn fits(&self, elements: usize) -> bool {
        elements > 0 && elements <= self.max_elements()
    }
}

/// The arrays the BVH walk, the shading and the light sampling read at indices that differ between
/// lanes.
pub const UNIFORM_ARRAYS: [UniformArray; 10] = [
    UniformArray {
        name: "triangles",
        uniform: "triangles_uniform",
        constant: "UNIFORM_TRIANGLES",
        element_bytes: std::mem::size_of::<GpuTriangle>(),
    },
    UniformArray {
        name: "bvh_nodes",
        uniform: "bvh_nodes_uniform",
        constant: "UNIFORM_BVH_NODES",
        element_bytes: std::mem::size_of::<GpuBvhNode>(),
    },
    UniformArray {
        name: "spheres",
        uniform: "spheres_uniform",
        constant: "UNIFORM_SPHERES",
        element_bytes: std::mem::size_of::<GpuSphere>(),
    },
    UniformArray {
        name: "sphere_nodes",
        uniform: "sphere_nodes_uniform",
        constant: "UNIFORM_SPHERE_NODES",
        element_bytes: std::mem::size_of::<GpuBvhNode>(),
    },
    UniformArray {
        name: "lights",
        uniform: "lights_uniform",
        constant: "UNIFORM_LIGHTS",
        element_bytes: std::mem::size_of::<GpuLight>(),
    },
    UniformArray {
        name: "light_triangles",
        uniform: "light_triangles_uniform",
        constant: "UNIFORM_LIGHT_TRIANGLES",
        element_bytes: std::mem::size_of::<GpuLightTriangle>(),
    },
    UniformArray {
        name: "materials",
        uniform: "materials_uniform",
        constant: "UNIFORM_MATERIALS",
        element_bytes: std::mem::size_of::<GpuMaterial>(),
    },
    UniformArray {
        name: "instances",
        uniform: "instances_uniform",
        constant: "UNIFORM_INSTANCES",
        element_bytes: std::mem::size_of::<GpuInstance>(),
    },
    UniformArray {
        name: "textures",
        uniform: "textures_uniform",
        constant: "UNIFORM_TEXTURES",
        element_bytes: std::mem::size_of::<GpuTextureInfo>(),
    },
    UniformArray {
        name: "material_textures",
        uniform: "material_textures_uniform",
        constant: "UNIFORM_MATERIAL_TEXTURES",
        element_bytes: std::mem::size_of::<GpuMaterialTextures>(),
    },
];

/// Every integer constant the host and the WGSL share, by its name in both: `tests/layout.rs` checks each
/// against the value naga parses from the production kernel. (The `MAT_*` kinds are generated into the
/// WGSL from the registry, `scene::bsdfs`, and checked against it there.)
pub const SHARED_CONSTANTS: &[(&str, u32)] = &[
    ("TRIANGLE_PART_BITS", TRIANGLE_PART_BITS),
    ("BVH_NODE_PART_BITS", BVH_NODE_PART_BITS),
    ("MESH_FACE_PART_BITS", MESH_FACE_PART_BITS),
    ("MESH_VERTEX_PART_BITS", MESH_VERTEX_PART_BITS),
    ("TEXEL_PART_BITS", TEXEL_PART_BITS),
    ("MATERIAL_TWO_SIDED_EMISSION", MATERIAL_TWO_SIDED_EMISSION),
    ("MATERIAL_SCHLICK", MATERIAL_SCHLICK),
    ("MATERIAL_LINEAR", MATERIAL_LINEAR),
    ("MATERIAL_BECKMANN", MATERIAL_BECKMANN),
    ("MATERIAL_ROUGH_COAT", MATERIAL_ROUGH_COAT),
    ("MATERIAL_ONE_SIDED", MATERIAL_ONE_SIDED),
    ("MATERIAL_VOLUME", MATERIAL_VOLUME),
    ("COAT_NODES", COAT_NODES as u32),
    ("BSDF_REFLECTION", BSDF_REFLECTION),
    ("BSDF_TRANSMISSION", BSDF_TRANSMISSION),
    ("BSDF_DELTA", BSDF_DELTA),
    ("LIGHT_POINT", LIGHT_POINT),
    ("LIGHT_SPHERE", LIGHT_SPHERE),
    ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
    ("LIGHT_TRIANGLES", LIGHT_TRIANGLES),
    ("LIGHT_ENVIRONMENT", LIGHT_ENVIRONMENT),
    ("LIGHT_SPOT", LIGHT_SPOT),
    ("NO_LIGHT", NO_LIGHT),
    ("CAMERA_PERSPECTIVE", CAMERA_PERSPECTIVE),
    ("CAMERA_ORTHOGRAPHIC", CAMERA_ORTHOGRAPHIC),
    ("FILTER_NONE", FILTER_NONE),
    ("FILTER_BOX", FILTER_BOX),
    ("FILTER_GAUSSIAN", FILTER_GAUSSIAN),
    ("FILTER_TENT", FILTER_TENT),
    ("SAMPLER_INDEPENDENT", SAMPLER_INDEPENDENT),
    ("SAMPLER_SOBOL", SAMPLER_SOBOL),
    ("LIGHT_SAMPLING_CONE", LIGHT_SAMPLING_CONE),
    ("LIGHT_SAMPLING_AREA", LIGHT_SAMPLING_AREA),
    ("LIGHT_SAMPLING_NONE", LIGHT_SAMPLING_NONE),
    ("LIGHT_SAMPLING_MIS", LIGHT_SAMPLING_MIS),
    ("AOV_NONE", AOV_NONE),
    ("AOV_ALBEDO", AOV_ALBEDO),
    ("AOV_NORMAL", AOV_NORMAL),
    ("AOV_DEPTH", AOV_DEPTH),
    ("NO_MESH", NO_MESH),
    ("MESH_SMOOTH", MESH_SMOOTH),
    ("MESH_UV", MESH_UV),
    ("NO_TEXTURE", NO_TEXTURE),
    ("TEXTURE_SRGB", TEXTURE_SRGB),
    ("TEXTURE_HALF", TEXTURE_HALF),
    ("TEXTURE_NEAREST", TEXTURE_NEAREST),
    ("TEXTURE_CLAMP", TEXTURE_CLAMP),
    ("TEXTURE_MIRROR", TEXTURE_MIRROR),
    ("TEXTURE_CHECKERBOARD", TEXTURE_CHECKERBOARD),
    ("TEXTURE_CHANNEL_SHIFT", TEXTURE_CHANNEL_SHIFT),
    ("TEXTURE_CHANNEL_RGB", TEXTURE_CHANNEL_RGB),
    ("TEXTURE_CHANNEL_R", TEXTURE_CHANNEL_R),
    ("TEXTURE_CHANNEL_G", TEXTURE_CHANNEL_G),
    ("TEXTURE_CHANNEL_B", TEXTURE_CHANNEL_B),
    ("TEXTURE_CHANNEL_A", TEXTURE_CHANNEL_A),
    ("TEXTURE_CHANNEL_LUMINANCE", TEXTURE_CHANNEL_LUMINANCE),
    ("MATERIAL_CUTOUT", MATERIAL_CUTOUT),
    ("ACCUM_LIMBS", ACCUM_LIMBS as u32),
    ("BVH_LEAF", crate::scene::bvh::LEAF),
    ("BVH_INSTANCE", crate::scene::bvh::INSTANCE),
    ("INSTANCE_MIRRORS", INSTANCE_MIRRORS),
    ("NO_INSTANCE", NO_INSTANCE),
    ("NO_MATERIAL", NO_MATERIAL),
    ("BVH_LEAF_COUNT_BITS", crate::scene::bvh::LEAF_COUNT_BITS),
    ("BVH_LEAF_COUNT_MASK", crate::scene::bvh::LEAF_COUNT_MASK),
    ("BVH_STACK_SIZE", crate::scene::bvh::STACK_SIZE as u32),
    ("BVH_MAX_STEPS", crate::scene::bvh::MAX_STEPS),
    ("FAULT_BOUNCE_CAP", FAULT_BOUNCE_CAP),
    ("BOUNCE_CAP", BOUNCE_CAP),
];

const _: () = assert!(std::mem::size_of::<GpuParams>() == 144);
const _: () = assert!(std::mem::size_of::<GpuBvhNode>() == 64);
const _: () = assert!(std::mem::size_of::<GpuMeshFace>() == 16);
const _: () = assert!(std::mem::size_of::<GpuMeshVertex>() == 24);
const _: () = assert!(std::mem::size_of::<GpuMeshInfo>() == 16);
const _: () = assert!(std::mem::size_of::<GpuInstance>() == 112);
const _: () = assert!(std::mem::size_of::<GpuTextureInfo>() == 48);
const _: () = assert!(std::mem::size_of::<GpuMaterialTextures>() == 64);
const _: () = assert!(std::mem::size_of::<GpuSphere>() == 32);
const _: () = assert!(std::mem::size_of::<GpuTriangle>() == 48);
const _: () = assert!(std::mem::size_of::<GpuMaterial>() == 144);
const _: () = assert!(std::mem::size_of::<GpuLightTriangle>() == 64);
const _: () = assert!(std::mem::size_of::<GpuLight>() == 80);
const _: () = assert!(std::mem::size_of::<GpuAccum>() == 96);
const _: () = assert!(std::mem::size_of::<GpuSplatAccum>() == 80);
const _: () = assert!(std::mem::size_of::<GpuSplatConstants>() == 48);
