//! A [`Scene`] flattened into the Pod arrays the shader reads.
//!
//! Every emitting surface is also a light that next-event estimation samples:
//! * a sphere whose material emits (a `[[light]] type = "sphere"` is one: an emitter material and a
//!   sphere) is a sphere light, which records that sphere's index (a BSDF-sampled ray that hits the sphere
//!   finds its light for the MIS weight);
//! * the emitting triangles (of `[[triangle]]`s and meshes) are together one light, `LIGHT_TRIANGLES`,
//!   with a `light_triangles` record each and an alias table that picks one in proportion to its power
//!   (area x mean emitted radiance x faces), so that a mesh of 10^5 emissive triangles costs one table
//!   lookup per light sample;
//! * the environment, when not black, is one light, `LIGHT_ENVIRONMENT`, with its map's texels and
//!   sampling distribution (scene::environment).

use super::abi::*;
use super::alias;
use super::coat::{coat_table, fresnel_diffuse_reflectance};
use super::sheen::{SHEEN_MIN_ALPHA, sheen_albedo_table};
use crate::scene::bvh::{self, Bvh};
use crate::scene::environment::channel_mean;
use crate::scene::mesh::MeshPlacement;
use crate::scene::texture::{Channel, TextureFilter, Wrap};
use crate::scene::{
    Bsdf, ConductorFresnel, Emission, Filter, Light, LightSampling, Material, MaterialTextures,
    Mesh, Projection, Roughness, Sampler, Scene, SpotFalloff, Texture, TextureRef,
};
use glam::{DAffine3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::Arc;

/// Scenes with at most this many triangles test them all in a loop instead of walking a BVH: a walk's
/// fixed costs (the traversal stack, two box tests per node) exceed a few triangle tests. Measured on
/// lavapipe (`bench::mesh::mesh_scaling`, direct lighting in the course's box): with 2 triangles the loop
/// renders 2.2x faster than the walk; with 24 the walk is already 1.9x faster, 59x with 960.
pub const BVH_MIN_TRIANGLES: usize = 16;

/// Scenes with at least this many spheres find them through a BVH of their boxes (`sphere_nodes`)
/// instead of testing every sphere for every ray, whose cost grows with their number. Measured on
/// lavapipe (docs/performance.md, "Many spheres"): at 16 the two cost the same, at 31 the walk is 1.5x
/// faster, at 1001 21x.
pub const SPHERE_BVH_MIN: usize = 16;

/// The scene as GPU arrays (host side; uploaded by the renderer).
///
/// Triangles, from `[[triangle]]` tables and meshes alike, are stored in the BVH's leaf order; `bvh_nodes`
/// indexes them. When some mesh is smooth or textured, `mesh_faces[i]` gives triangle i's shading
/// vertices and mesh (or `NO_MESH`); otherwise `mesh_faces` is empty and the kernel never reads it.
#[derive(Clone, Debug, Default)]
pub struct GpuScene {
    pub spheres: Vec<GpuSphere>,
    pub triangles: Vec<GpuTriangle>,
    pub materials: Vec<GpuMaterial>,
    pub lights: Vec<GpuLight>,
    pub bvh_nodes: Vec<GpuBvhNode>,
    /// The spheres' own BVH (the same node layout; leaves index `spheres`), when there are at least
    /// [`SPHERE_BVH_MIN`] of them: `spheres` is then in its leaf order. Empty otherwise.
    pub sphere_nodes: Vec<GpuBvhNode>,
    pub mesh_faces: Vec<GpuMeshFace>,
    pub mesh_vertices: Vec<GpuMeshVertex>,
    pub meshes: Vec<GpuMeshInfo>,
    /// Every image's texels, RGBA8 or RGBA f16 (a checkerboard: its two colours as six f32), one image
    /// after the other, each uploaded once however many texture references read it.
    pub texels: Vec<u32>,
    /// The texture table (`GpuMaterialTextures`' indices): each texture reference, where its image's
    /// texels are and how it reads them.
    pub textures: Vec<GpuTextureInfo>,
    /// Per material (parallel to `materials`), its textures and surface modifiers; empty when no
    /// material has any (the kernel then never reads it).
    pub material_textures: Vec<GpuMaterialTextures>,
    /// The emitting triangles, with the alias table that picks them (LIGHT_TRIANGLES).
    pub light_triangles: Vec<GpuLightTriangle>,
    /// The environment map's RGB radiance, three floats per pixel, rows from the top.
    pub env_texels: Vec<f32>,
    /// Its sampling distribution (`EnvironmentMap::distribution`).
    pub env_cdf: Vec<f32>,
    /// The environment's index in `lights`, or NO_LIGHT.
    pub environment_light: u32,
    /// The emissive triangles' index in `lights`, or NO_LIGHT.
    pub triangle_light: u32,
    /// In a scene with instanced meshes (`Scene::instanced`), every placement (the top-level tree's
    /// leaves index it); empty otherwise.
    pub instances: Vec<GpuInstance>,
    /// With instances: the most traversal-stack entries a walk can hold (the top-level tree's, one for
    /// the way out of a placement, and the deepest group tree's); the renderer checks it against
    /// `bvh::STACK_SIZE`. 0 without.
    pub stack_need: usize,
    /// With instances: 4 x nodes + triangles + 2 over the top-level tree and every placement's tree, the
    /// walk's bound as if the placements were copies (`render::worst_case_loop_iterations`). 0 without.
    pub instanced_walk: u64,
    /// The triangles in world space: `triangles[..world_triangles]` (all of them in a scene without
    /// instances). Only they can be lights: an instanced mesh's material never emits (`InstancedMesh`).
    pub world_triangles: usize,
    pub stats: SceneStats,
}

impl GpuScene {
    /// The large arrays, by their WGSL names (part 0's, for those split across bindings:
    /// `abi::SPLIT_ARRAYS`), as the bytes the renderer uploads to device-local memory.
    pub fn large_arrays(&self) -> [(&'static str, &[u8]); 8] {
        [
            "triangles",
            "bvh_nodes",
            "mesh_faces",
            "mesh_vertices",
            "texels",
            "light_triangles",
            "env_texels",
            "env_cdf",
        ]
        .map(|name| (name, self.array_bytes(name)))
    }

    /// The bytes of the array named `name` (its WGSL storage binding's name; empty for any other
    /// name): the large arrays and those `abi::UNIFORM_ARRAYS` lists.
    pub fn array_bytes(&self, name: &str) -> &[u8] {
        match name {
            "triangles" => bytemuck::cast_slice(&self.triangles),
            "bvh_nodes" => bytemuck::cast_slice(&self.bvh_nodes),
            "mesh_faces" => bytemuck::cast_slice(&self.mesh_faces),
            "mesh_vertices" => bytemuck::cast_slice(&self.mesh_vertices),
            "texels" => bytemuck::cast_slice(&self.texels),
            "light_triangles" => bytemuck::cast_slice(&self.light_triangles),
            "env_texels" => bytemuck::cast_slice(&self.env_texels),
            "env_cdf" => bytemuck::cast_slice(&self.env_cdf),
            "spheres" => bytemuck::cast_slice(&self.spheres),
            "sphere_nodes" => bytemuck::cast_slice(&self.sphere_nodes),
            "lights" => bytemuck::cast_slice(&self.lights),
            "instances" => bytemuck::cast_slice(&self.instances),
            "materials" => bytemuck::cast_slice(&self.materials),
            "textures" => bytemuck::cast_slice(&self.textures),
            "material_textures" => bytemuck::cast_slice(&self.material_textures),
            _ => &[],
        }
    }

    /// The elements of the split array `name` (0 for any other name).
    pub fn array_len(&self, name: &str) -> usize {
        split_array(name).map_or(0, |a| self.array_bytes(name).len() / a.element_bytes)
    }
}

/// A reference of a group's own tree where it lands in `bvh_nodes` (`add_instanced`): a node index moved
/// by `base`, a leaf's first triangle by `first`; unused slots stay unused.
fn shift_reference(r: u32, base: u32, first: u32) -> u32 {
    if r == bvh::NO_CHILD {
        r
    } else if r & bvh::LEAF != 0 {
        let start = ((r & !bvh::LEAF) >> bvh::LEAF_COUNT_BITS) + first;
        bvh::LEAF | (start << bvh::LEAF_COUNT_BITS) | (r & bvh::LEAF_COUNT_MASK)
    } else {
        r + base
    }
}

/// The placement `p` of the tree at node `root`, for the shader: the rows of both maps (object to world
/// and back) and the material its faces take instead of their own, if any.
fn gpu_instance(p: &MeshPlacement, root: u32) -> GpuInstance {
    let m = &p.to_world;
    let rows = |a: &DAffine3| -> [[f32; 4]; 3] {
        std::array::from_fn(|r| {
            let l = a.matrix3.row(r);
            [l.x as f32, l.y as f32, l.z as f32, a.translation[r] as f32]
        })
    };
    let [to_object_x, to_object_y, to_object_z] = rows(&m.inverse());
    let [to_world_x, to_world_y, to_world_z] = rows(m);
    GpuInstance {
        to_object_x,
        to_object_y,
        to_object_z,
        to_world_x,
        to_world_y,
        to_world_z,
        root,
        flags: if m.matrix3.determinant() < 0.0 {
            INSTANCE_MIRRORS
        } else {
            0
        },
        // (Scene materials are uploaded at their own indices: `materials` starts with them.)
        material: p.material.unwrap_or(NO_MATERIAL),
        _pad: 0,
    }
}

/// Triangles gathered for one BVH: their corners, materials and (when some have shading data) faces.
#[derive(Default)]
struct TriangleGroup {
    corners: Vec<[Vec3; 3]>,
    materials: Vec<u32>,
    faces: Vec<GpuMeshFace>,
}

/// The face of a triangle without shading data.
const NO_FACE: GpuMeshFace = GpuMeshFace {
    vertices: [0; 3],
    mesh: NO_MESH,
};

/// A wide tree's nodes as the kernel reads them: quantised (`bvh::quantise`), in parallel.
fn gpu_nodes(wide: &[bvh::WideNode]) -> Vec<GpuBvhNode> {
    wide.par_iter()
        .map(|n| {
            let q = bvh::quantise(n);
            GpuBvhNode {
                origin: q.origin,
                exponents: q.exponents,
                planes_xy: [q.planes[0], q.planes[1], q.planes[2], q.planes[3]],
                planes_z: [q.planes[4], q.planes[5]],
                child: q.child,
                ..Default::default()
            }
        })
        .collect()
}

/// A material as the shader has it. Glossy materials whose GGX alpha is below [`SMOOTH_ALPHA`] on both
/// axes are uploaded as their smooth forms (a dielectric as MAT_DIELECTRIC, whose code is the course's
/// glass; a conductor with a delta lobe), and so is a dielectric of ior 1 (no interface at all).
pub fn gpu_material(m: &Material) -> GpuMaterial {
    let mut g = GpuMaterial::default();
    let set_alpha = |g: &mut GpuMaterial, r: Roughness| {
        let (ax, ay) = r.alpha();
        let smooth = ax.max(ay) < SMOOTH_ALPHA;
        (g.alpha_x, g.alpha_y) = if smooth { (0.0, 0.0) } else { (ax, ay) };
        if r.beckmann && !smooth {
            g.flags |= MATERIAL_BECKMANN;
        }
        smooth
    };
    match m.bsdf {
        Bsdf::Diffuse { albedo } => (g.kind, g.albedo) = (MAT_DIFFUSE, albedo.into()),
        Bsdf::Mirror { tint } => (g.kind, g.albedo) = (MAT_MIRROR, tint.into()),
        Bsdf::Dielectric { ior, roughness } => {
            let smooth = set_alpha(&mut g, roughness) || ior == 1.0;
            g.kind = if smooth {
                MAT_DIELECTRIC
            } else {
                MAT_ROUGH_DIELECTRIC
            };
            g.ior = ior;
        }
        Bsdf::Conductor {
            fresnel,
            roughness,
            tint,
        } => {
            g.kind = MAT_CONDUCTOR;
            set_alpha(&mut g, roughness);
            // The tint goes where the Fresnel model leaves room: `albedo` beside eta and k, `eta` beside
            // Schlick's f0 (in `albedo`), which has no index of refraction (bsdfs/conductor.wgsl, conductor_fresnel).
            match fresnel {
                ConductorFresnel::Complex { eta, k } => {
                    (g.eta, g.k, g.albedo) = (eta.into(), k.into(), tint.into())
                }
                ConductorFresnel::Schlick { f0 } => {
                    (g.albedo, g.eta) = (f0.into(), tint.into());
                    g.flags |= MATERIAL_SCHLICK;
                }
            }
        }
        Bsdf::Plastic {
            albedo,
            ior,
            roughness,
            nonlinear,
        } => {
            g.kind = MAT_PLASTIC;
            if !nonlinear {
                g.flags |= MATERIAL_LINEAR;
            }
            g.albedo = albedo.into();
            g.ior = ior;
            g.fdr_int = fresnel_diffuse_reflectance(1.0 / ior as f64) as f32;
            let smooth = set_alpha(&mut g, roughness);
            // A rough coat lets light through with its own transmittance (Mitsuba's roughplastic,
            // kernel/coat.rs), tabulated for its one alpha: not for an anisotropic coat, nor for one
            // whose roughness a texture varies, which keep the smooth interface's 1 - F.
            if !smooth && roughness.u == roughness.v && m.textures.roughness.is_none() {
                let alpha = f64::from(g.alpha_x);
                (g.block, g.fdr_int) = coat_table(f64::from(ior), alpha, roughness.beckmann);
                g.flags |= MATERIAL_ROUGH_COAT;
            }
        }
        Bsdf::MetallicRoughness {
            base_color,
            metallic,
            roughness,
            layers,
        } => {
            g.kind = MAT_METALLIC_ROUGHNESS;
            g.albedo = base_color.into();
            g.metallic = metallic;
            set_alpha(&mut g, Roughness::isotropic(roughness));
            if !layers.is_none() {
                // bsdfs/gltf_pbr.wgsl lists the fields.
                g.kind = MAT_GLTF_PBR;
                g.ior = layers.ior;
                g.eta = layers.specular_color.into();
                g.fdr_int = layers.specular;
                g.k = layers.sheen_color.into();
                g.block[0] = layers.transmission;
                g.block[1] = layers.clearcoat;
                g.block[2] = layers.clearcoat_roughness * layers.clearcoat_roughness;
                let sheen_alpha = layers.sheen_roughness.max(SHEEN_MIN_ALPHA);
                g.block[3] = sheen_alpha;
                if let Some(sigma) = layers.volume {
                    g.flags |= MATERIAL_VOLUME;
                    g.block[4..7].copy_from_slice(&sigma.to_array());
                }
                if layers.sheen_color != Vec3::ZERO {
                    g.block[8..16].copy_from_slice(&sheen_albedo_table(f64::from(sheen_alpha)));
                }
            }
        }
        Bsdf::Principled {
            base_color,
            roughness,
            anisotropic,
            metallic,
            eta,
            spec_tint,
            sheen,
            sheen_tint,
            clearcoat,
            clearcoat_gloss,
            flatness,
        } => {
            // bsdfs/principled.wgsl lists the fields. alpha = r^2 / aspect and r^2 aspect with Mitsuba's
            // aspect = sqrt(1 - 0.9 anisotropic), unclamped (the shader takes max(0.001, alpha), as
            // Mitsuba, and the retro-reflection's roughness as (alpha_x alpha_y)^(1/4) = r).
            g.kind = MAT_PRINCIPLED;
            g.albedo = base_color.into();
            g.metallic = metallic;
            g.ior = eta;
            let r2 = roughness * roughness;
            let aspect = (1.0 - 0.9 * anisotropic).sqrt();
            (g.alpha_x, g.alpha_y) = if anisotropic == 0.0 {
                (r2, r2)
            } else {
                (r2 / aspect, r2 * aspect)
            };
            g.eta = [spec_tint, sheen, sheen_tint];
            g.k = [clearcoat, clearcoat_gloss, flatness];
        }
        Bsdf::Black => g.kind = MAT_EMITTER,
        Bsdf::ThinDielectric { ior } => (g.kind, g.ior) = (MAT_THIN_DIELECTRIC, ior),
        // A plugin's parameters are its block, packed by its declaration (`crate::materials`); its
        // textures' words are filled when the textures are uploaded (`GpuScene::build`).
        Bsdf::Plugin { kind, block } => (g.kind, g.block) = (kind, block),
    }
    if m.textures.one_sided {
        g.flags |= MATERIAL_ONE_SIDED;
    }
    g.back = m.textures.back.map_or(0, |b| b + 1);
    if let Some(Emission {
        radiance,
        two_sided,
    }) = m.emission
    {
        g.emission = radiance.into();
        if two_sided {
            g.flags |= MATERIAL_TWO_SIDED_EMISSION;
        }
    }
    g
}

/// The images whose texels are uploaded already, and where they start in `texels`.
#[derive(Default)]
struct ImageTable {
    offsets: Vec<(*const Texture, u32)>,
}

/// A texture reference's `TEXTURE_*` flags.
fn texture_flags(r: &TextureRef) -> u32 {
    let mut flags = match r.channel {
        Channel::Rgb => TEXTURE_CHANNEL_RGB,
        Channel::R => TEXTURE_CHANNEL_R,
        Channel::G => TEXTURE_CHANNEL_G,
        Channel::B => TEXTURE_CHANNEL_B,
        Channel::A => TEXTURE_CHANNEL_A,
        Channel::Luminance => TEXTURE_CHANNEL_LUMINANCE,
    } << TEXTURE_CHANNEL_SHIFT;
    if r.srgb {
        flags |= TEXTURE_SRGB;
    }
    if r.image.half {
        flags |= TEXTURE_HALF;
    }
    if r.image.checkerboard {
        flags |= TEXTURE_CHECKERBOARD;
    }
    if r.filter == TextureFilter::Nearest {
        flags |= TEXTURE_NEAREST;
    }
    flags |= match r.wrap {
        Wrap::Repeat => 0,
        Wrap::Clamp => TEXTURE_CLAMP,
        Wrap::Mirror => TEXTURE_MIRROR,
    };
    flags
}

/// Whether a material emits at all.
fn emits(m: &GpuMaterial) -> bool {
    m.emission.iter().any(|&c| c > 0.0)
}

/// The power of an emitting triangle up to the common factor pi: area x mean radiance x faces. (The
/// shader's `triangle_light_power` computes the same in f32, for the pmf it reports.)
fn triangle_power(t: &GpuLightTriangle) -> f64 {
    let [a, b, c] = [t.v0, t.v1, t.v2].map(|v| Vec3::from(v).as_dvec3());
    let area = 0.5 * (b - a).cross(c - a).length();
    let faces = if t.flags & MATERIAL_TWO_SIDED_EMISSION != 0 {
        2.0
    } else {
        1.0
    };
    area * channel_mean(t.emission) * faces
}

/// What building the GPU scene cost and made (reported by `--json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SceneStats {
    /// Triangles uploaded: `[[triangle]]` tables plus every mesh's (an instanced mesh's once).
    pub triangles: usize,
    /// Interior nodes of the BVH (each holds its two children's boxes: 64 bytes on the GPU).
    pub bvh_nodes: usize,
    pub bvh_leaves: usize,
    /// Levels of interior nodes (the traversal stack needs at most this many entries).
    pub bvh_depth: usize,
    /// Wall time of the BVH build, in milliseconds.
    pub bvh_build_ms: f64,
    /// Bytes of scene data uploaded to the device (all arrays above).
    pub scene_bytes: u64,
    /// Placements of instanced meshes (0 in a scene without).
    pub instances: usize,
}

impl GpuScene {
    pub fn build(scene: &Scene) -> GpuScene {
        let mut g = GpuScene {
            environment_light: NO_LIGHT,
            triangle_light: NO_LIGHT,
            ..Default::default()
        };
        g.materials = scene.materials.iter().map(gpu_material).collect();
        let mut images = ImageTable::default();
        for (i, m) in scene.materials.iter().enumerate() {
            let entry = g.material_entry(&mut images, &m.textures);
            g.material_textures.push(entry);
            // A plugin's textured parameters: the texture's index, as a number, in its block word.
            for (word, r) in &m.textures.block {
                g.materials[i].block[*word] = g.add_texture(&mut images, r) as f32;
            }
        }
        for s in &scene.spheres {
            let material = &g.materials[s.material as usize];
            if emits(material) {
                g.lights.push(GpuLight {
                    position: s.center.into(),
                    radius: s.radius,
                    intensity: material.emission,
                    kind: LIGHT_SPHERE,
                    index: g.spheres.len() as u32,
                    ..Default::default()
                });
            }
            g.spheres.push(GpuSphere {
                center: s.center.into(),
                radius: s.radius,
                material: s.material,
                _pad: [0; 3],
            });
        }
        g.add_triangles(scene, &mut images);
        g.add_triangle_lights();
        for l in &scene.lights {
            match *l {
                Light::Point {
                    position,
                    power,
                    color,
                } => g.lights.push(GpuLight {
                    position: position.into(),
                    // Radiant intensity of an isotropic point source: I = P / (4 pi) W/sr.
                    intensity: (color * (power / (4.0 * PI))).into(),
                    kind: LIGHT_POINT,
                    ..Default::default()
                }),
                Light::Sphere {
                    center,
                    radius,
                    power,
                    color,
                } => {
                    // A sphere of radius r with uniform radiance Le emits P = Le * pi * 4 pi r^2
                    // (pi from the cosine-weighted hemisphere, 4 pi r^2 the area): Le = P / (4 pi^2 r^2).
                    // Both faces emit, so that it looks the same from inside (where it is not sampled).
                    let le = color * (power / (4.0 * PI * PI * radius * radius));
                    let material = g.materials.len() as u32;
                    g.materials.push(GpuMaterial {
                        kind: MAT_EMITTER,
                        emission: le.into(),
                        flags: MATERIAL_TWO_SIDED_EMISSION,
                        ..Default::default()
                    });
                    let sphere_index = g.spheres.len() as u32;
                    g.spheres.push(GpuSphere {
                        center: center.into(),
                        radius,
                        material,
                        _pad: [0; 3],
                    });
                    g.lights.push(GpuLight {
                        position: center.into(),
                        radius,
                        intensity: le.into(),
                        kind: LIGHT_SPHERE,
                        index: sphere_index,
                        ..Default::default()
                    });
                }
                Light::Spot {
                    position,
                    axis,
                    intensity,
                    color,
                    cutoff_deg,
                    beam_deg,
                    falloff,
                } => {
                    // The cone's trigonometry in f64 here: the shader only multiplies and takes one
                    // atan2 of a small angle (lights/spot.wgsl), so the falloff is accurate to its
                    // relative rounding, where the GPU's cos and acos of the angles would not be.
                    let (c, b) = (
                        f64::from(cutoff_deg).to_radians(),
                        f64::from(beam_deg).to_radians(),
                    );
                    // Linear: 1 / (c - b) in radians; smooth: 1 / max(0.001, cos b - cos c), the
                    // extension's guard against a beam as wide as the cone.
                    let inv_width = match falloff {
                        SpotFalloff::Linear if c > b => 1.0 / (c - b),
                        SpotFalloff::Linear => 0.0,
                        SpotFalloff::Smooth => 1.0 / (b.cos() - c.cos()).max(0.001),
                    };
                    g.lights.push(GpuLight {
                        position: position.into(),
                        intensity: (color * intensity).into(),
                        kind: LIGHT_SPOT,
                        spot_falloff: u32::from(falloff == SpotFalloff::Smooth),
                        axis: axis.normalize().into(),
                        spot_inv_width: inv_width as f32,
                        spot_cone: [c.cos(), c.sin(), b.cos(), b.sin()].map(|v| v as f32),
                        ..Default::default()
                    })
                }
                Light::Directional {
                    direction,
                    irradiance,
                    color,
                    angle_deg,
                } => {
                    // `position` holds the unit direction towards the light, `radius` 1 - cos of the
                    // cone's half-angle a (0: a delta light). A disc of uniform radiance Le filling the
                    // cone gives E = Le pi sin^2(a) on a surface facing it (the projected solid angle of
                    // the cap), so Le = E / (pi sin^2 a); a delta light carries E itself.
                    let half = (angle_deg as f64 / 2.0).to_radians();
                    let omc = 2.0 * (half / 2.0).sin().powi(2); // 1 - cos, without cancellation
                    let sin2 = omc * (2.0 - omc);
                    let scale = if omc > 0.0 {
                        irradiance as f64 / (std::f64::consts::PI * sin2)
                    } else {
                        irradiance as f64
                    };
                    g.lights.push(GpuLight {
                        position: (-direction).into(),
                        radius: omc as f32,
                        intensity: (color * scale as f32).into(),
                        kind: LIGHT_DIRECTIONAL,
                        ..Default::default()
                    });
                }
            }
        }
        g.add_environment(scene);
        g.add_sphere_bvh();
        // Material textures are read only when some material has one (or a modifier); the materials
        // added since (sphere lights') have none.
        if g.material_textures
            .iter()
            .all(GpuMaterialTextures::is_plain)
        {
            g.material_textures.clear();
        } else {
            g.material_textures
                .resize(g.materials.len(), GpuMaterialTextures::default());
        }
        g.stats.scene_bytes = g.bytes();
        g
    }

    /// A texture reference's entry in the texture table (an equal entry is shared), its image's texels
    /// uploaded once.
    fn add_texture(&mut self, images: &mut ImageTable, r: &TextureRef) -> u32 {
        let key = Arc::as_ptr(&r.image);
        let offset = match images.offsets.iter().find(|(k, _)| *k == key) {
            Some(&(_, offset)) => offset,
            None => {
                let offset = self.texels.len() as u32;
                self.texels.extend_from_slice(&r.image.texels);
                images.offsets.push((key, offset));
                offset
            }
        };
        let entry = GpuTextureInfo {
            offset,
            width: r.image.width,
            height: r.image.height,
            flags: texture_flags(r),
            uv_matrix: r.uv_matrix(),
            uv_offset: r.offset,
            _pad: [0; 2],
        };
        if let Some(i) = self.textures.iter().position(|t| *t == entry) {
            return i as u32;
        }
        self.textures.push(entry);
        (self.textures.len() - 1) as u32
    }

    /// A material's textures and modifiers as the kernel reads them.
    fn material_entry(
        &mut self,
        images: &mut ImageTable,
        t: &MaterialTextures,
    ) -> GpuMaterialTextures {
        let mut index = |r: &Option<TextureRef>| {
            r.as_ref()
                .map_or(NO_TEXTURE, |r| self.add_texture(images, r))
        };
        let mut e = GpuMaterialTextures {
            albedo_texture: index(&t.albedo),
            roughness_texture: index(&t.roughness),
            metallic_texture: index(&t.metallic),
            emission_texture: index(&t.emission),
            opacity_texture: index(&t.opacity),
            opacity: t.opacity_value,
            ..GpuMaterialTextures::default()
        };
        if let Some(cutoff) = t.alpha_cutoff {
            e.flags |= MATERIAL_CUTOUT;
            e.alpha_cutoff = cutoff;
        }
        if let Some((r, scale)) = &t.bump {
            e.bump_texture = self.add_texture(images, r);
            e.bump_scale = *scale;
        }
        if let Some((r, scale)) = &t.normal_map {
            e.normal_texture = self.add_texture(images, r);
            e.normal_scale = *scale;
        }
        if let Some(b) = t.blend {
            e.blend = b + 1;
            e.blend_weight = t.blend_weight;
            if let Some(r) = &t.blend_weight_texture {
                e.blend_texture = self.add_texture(images, r);
            }
        }
        e
    }

    /// The material a mesh's triangles use: its own, or, when the mesh has texture keys of its own
    /// (`texture`, `emission_texture`, `metallic_roughness_texture`, `normal_map`: docs/scene-format.md,
    /// `[[mesh]]`), a copy of it with those textures bound to its parameters: `texture` is the albedo
    /// (base colour, tint), replacing the constant, or multiplying it for a glTF base colour
    /// (`maps.base_color_factor`), and on an emitting material (TOML, OBJ) it also multiplies the
    /// emission; `emission_texture` multiplies the emission; `metallic_roughness_texture` multiplies
    /// metallic by its B channel and roughness by its G channel (glTF 2.0 §3.9.2); `normal_map` is the
    /// normal map.
    fn mesh_material(&mut self, images: &mut ImageTable, scene: &Scene, m: &Mesh) -> u32 {
        let maps = &m.maps;
        if m.texture.is_none() && maps.change_nothing() {
            return m.material;
        }
        let base = m.material as usize;
        let mut material = self.materials[base];
        let mut entry = self.material_textures[base];
        let mut plain = |g: &mut GpuScene,
                         tex: &Arc<Texture>,
                         colour: bool,
                         channel: Channel,
                         read: &crate::scene::mesh::TextureRead| {
            g.add_texture(
                images,
                &read.apply(TextureRef::plain(tex.clone(), colour).with_channel(channel)),
            )
        };
        // (A conductor given by eta and k has no colour for `texture` to replace: its albedo is its tint,
        // which the texture leaves alone; the texture then only multiplies its emission.)
        let tint_only = matches!(
            scene.materials[base].bsdf,
            Bsdf::Conductor {
                fresnel: ConductorFresnel::Complex { .. },
                ..
            }
        );
        if let (Some(tex), false) = (&m.texture, tint_only) {
            if !maps.base_color_factor {
                material.albedo = [1.0; 3];
            }
            entry.albedo_texture = plain(self, tex, true, Channel::Rgb, &maps.base_color_read);
        }
        let emits = scene.materials[base].emission.is_some();
        let emissive = match (&maps.emissive, &m.texture) {
            (Some(e), _) => Some((e, &maps.emissive_read)),
            (None, Some(t)) if emits && !maps.base_color_factor => Some((t, &maps.base_color_read)),
            _ => None,
        };
        if let Some((tex, read)) = emissive {
            entry.emission_texture = plain(self, tex, true, Channel::Rgb, read);
        }
        if let Some(tex) = &maps.metallic_roughness {
            let read = &maps.metallic_roughness_read;
            entry.metallic_texture = plain(self, tex, false, Channel::B, read);
            entry.roughness_texture = plain(self, tex, false, Channel::G, read);
        }
        if let Some(tex) = &maps.normal {
            entry.normal_texture = plain(self, tex, false, Channel::Rgb, &maps.normal_read);
            entry.normal_scale = maps.normal_scale;
        }
        // glTF's alpha coverage: opacity = the base colour factor's alpha x the texture's (linear).
        if let Some((factor, cutoff)) = maps.alpha {
            entry.opacity = factor;
            if let Some(tex) = &m.texture {
                entry.opacity_texture = plain(self, tex, false, Channel::A, &maps.base_color_read);
            }
            if let Some(c) = cutoff {
                entry.flags |= MATERIAL_CUTOUT;
                entry.alpha_cutoff = c;
            }
        }
        self.materials.push(material);
        self.material_textures.push(entry);
        (self.materials.len() - 1) as u32
    }

    /// The emitting triangles as one light, with their alias table.
    fn add_triangle_lights(&mut self) {
        let mut lit: Vec<GpuLightTriangle> = self.triangles[..self.world_triangles]
            .iter()
            .enumerate()
            .filter(|(_, t)| emits(&self.materials[t.material as usize]))
            .map(|(i, t)| {
                let m = &self.materials[t.material as usize];
                GpuLightTriangle {
                    v0: t.v0,
                    v1: t.v1,
                    v2: t.v2,
                    flags: m.flags & MATERIAL_TWO_SIDED_EMISSION,
                    emission: m.emission,
                    triangle: i as u32,
                    ..Default::default()
                }
            })
            .collect();
        // Zero-area triangles emit nothing and cannot be sampled.
        let power: Vec<f64> = lit.iter().map(triangle_power).collect();
        let keep: Vec<bool> = power.iter().map(|&p| p > 0.0).collect();
        let mut k = keep.iter();
        lit.retain(|_| *k.next().expect("one flag per triangle"));
        let power: Vec<f64> = power.into_iter().filter(|&p| p > 0.0).collect();
        if lit.is_empty() {
            return;
        }
        for (t, column) in lit.iter_mut().zip(alias::build(&power)) {
            t.keep = column.keep;
            t.alias_triangle = column.alias;
        }
        self.triangle_light = self.lights.len() as u32;
        self.lights.push(GpuLight {
            // The total power, which turns a triangle's power into its selection probability.
            radius: power.iter().sum::<f64>() as f32,
            kind: LIGHT_TRIANGLES,
            index: lit.len() as u32,
            ..Default::default()
        });
        self.light_triangles = lit;
    }

    /// The environment as a light, unless it is black.
    fn add_environment(&mut self, scene: &Scene) {
        let env = &scene.environment;
        if env.is_black() {
            return;
        }
        // `position` holds cos and sin of the rotation about +y.
        let (sin, cos) = (env.rotate_deg as f64).to_radians().sin_cos();
        let mut light = GpuLight {
            position: [cos as f32, sin as f32, 0.0],
            intensity: env.radiance.into(),
            kind: LIGHT_ENVIRONMENT,
            ..Default::default()
        };
        if let Some(map) = &env.map {
            light.map_width = map.width;
            light.map_height = map.height;
            self.env_texels = map.texels.iter().flatten().copied().collect();
            self.env_cdf = map.distribution();
        }
        self.environment_light = self.lights.len() as u32;
        self.lights.push(light);
    }

    /// All triangles in BVH order, with the BVH and the meshes' shading data. A scene with instances
    /// gets a two-level BVH instead (`add_instanced`).
    fn add_triangles(&mut self, scene: &Scene, images: &mut ImageTable) {
        let total = scene.triangles.len()
            + scene
                .meshes
                .iter()
                .map(|m| m.triangles.len())
                .sum::<usize>();
        let mut world = TriangleGroup {
            corners: Vec::with_capacity(total),
            materials: Vec::with_capacity(total),
            faces: Vec::new(),
        };
        for t in &scene.triangles {
            world.corners.push(t.vertices);
            world.materials.push(t.material);
        }
        for m in &scene.meshes {
            self.gather_mesh(scene, images, m, &mut world);
        }
        if !scene.instanced.is_empty() {
            self.add_instanced(scene, images, world);
            return;
        }
        let tree: Bvh = if total > BVH_MIN_TRIANGLES {
            bvh::build(&world.corners)
        } else {
            // No BVH: the kernel loops over the triangles in file order (and, being generic, finds the
            // `bvh_nodes` buffer empty and does the same).
            Bvh {
                order: (0..total as u32).collect(),
                ..Default::default()
            }
        };
        self.append_group(&world, &tree.order);
        self.world_triangles = total;
        // The build time reported includes the collapse to the wide tree and the quantisation.
        let started = std::time::Instant::now();
        let wide = tree.wide();
        self.bvh_nodes = gpu_nodes(&wide);
        self.stats = SceneStats {
            triangles: total,
            bvh_nodes: wide.len(),
            bvh_leaves: tree.leaves,
            bvh_depth: tree.depth,
            bvh_build_ms: (tree.build_seconds + started.elapsed().as_secs_f64()) * 1e3,
            ..Default::default()
        };
    }

    /// Adds mesh `m`'s triangles (corners as given: world space, or an instanced mesh's own) to `group`,
    /// and its vertices' shading data to `mesh_vertices` and `meshes`.
    fn gather_mesh(
        &mut self,
        scene: &Scene,
        images: &mut ImageTable,
        m: &Mesh,
        group: &mut TriangleGroup,
    ) {
        let material = self.mesh_material(images, scene, m);
        let shaded = !m.normals.is_empty() || !m.uvs.is_empty();
        if shaded && group.faces.is_empty() {
            group.faces.resize(group.corners.len(), NO_FACE);
        }
        let mesh_index = self.meshes.len() as u32;
        let first_vertex = self.mesh_vertices.len() as u32;
        for t in &m.triangles {
            group.corners.push(t.map(|i| m.positions[i as usize]));
            group.materials.push(material);
            if shaded {
                group.faces.push(GpuMeshFace {
                    vertices: t.map(|i| first_vertex + i),
                    mesh: mesh_index,
                });
            } else if !group.faces.is_empty() {
                group.faces.push(NO_FACE);
            }
        }
        if !shaded {
            return;
        }
        let mut flags = 0;
        if !m.normals.is_empty() {
            flags |= MESH_SMOOTH;
        }
        if !m.uvs.is_empty() {
            flags |= MESH_UV;
        }
        self.meshes.push(GpuMeshInfo {
            flags,
            _pad: [0; 3],
        });
        for k in 0..m.positions.len() {
            let n = m.normals.get(k).copied().unwrap_or(Vec3::ZERO);
            let uv = m.uvs.get(k).copied().unwrap_or([0.0, 0.0]);
            self.mesh_vertices.push(GpuMeshVertex {
                nx: n.x,
                ny: n.y,
                nz: n.z,
                u: uv[0],
                v: uv[1],
                tangent: m.tangents.get(k).map_or(0, |&t| encode_tangent(t)),
            });
        }
    }

    /// Appends `group`'s triangles to `triangles` in `order` (a BVH's leaf order), with their faces
    /// (`mesh_faces` stays empty while no triangle so far has shading data, and is filled in with
    /// [`NO_FACE`] when a later one has).
    fn append_group(&mut self, group: &TriangleGroup, order: &[u32]) {
        let first = self.triangles.len();
        self.triangles.extend(order.iter().map(|&i| {
            let [v0, v1, v2] = group.corners[i as usize];
            GpuTriangle {
                v0: v0.into(),
                v1: v1.into(),
                v2: v2.into(),
                material: group.materials[i as usize],
                ..Default::default()
            }
        }));
        if !group.faces.is_empty() {
            self.mesh_faces.resize(first, NO_FACE);
            self.mesh_faces
                .extend(order.iter().map(|&i| group.faces[i as usize]));
        } else if !self.mesh_faces.is_empty() {
            self.mesh_faces.resize(self.triangles.len(), NO_FACE);
        }
    }

    /// A scene with instances: a two-level BVH (the layout of Wald et al.'s and Embree's instancing,
    /// pbrt-v4 §7.1.4's `TransformedPrimitive`). Each instanced mesh's triangles are uploaded once in
    /// its own space, with a BVH of their own; the scene's other triangles (`world`) are one more such
    /// group, placed by the identity. `instances` lists every placement (`GpuInstance`: its two maps and
    /// the root of its mesh's tree), and the top-level tree over the placements' world boxes has one
    /// placement in each leaf (`bvh::INSTANCE`), but for the identity's, which refers to the world
    /// group's root node instead (its entry in `instances` stays, unused by the walk). `bvh_nodes`
    /// holds the top-level tree first (node 0, where every walk starts), then each group's tree, their
    /// references shifted to where they land; the walk (bvh.wgsl) takes the ray into a placement's
    /// space when it reaches its leaf.
    fn add_instanced(&mut self, scene: &Scene, images: &mut ImageTable, world: TriangleGroup) {
        let started = std::time::Instant::now();
        let mut groups: Vec<(TriangleGroup, Vec<MeshPlacement>)> = Vec::new();
        self.world_triangles = world.corners.len();
        if !world.corners.is_empty() {
            groups.push((world, vec![MeshPlacement::at(DAffine3::IDENTITY)]));
        }
        for inst in &scene.instanced {
            let mut group = TriangleGroup::default();
            for part in &inst.parts {
                self.gather_mesh(scene, images, part, &mut group);
            }
            if !group.corners.is_empty() {
                groups.push((group, inst.placements.clone()));
            }
        }
        // Each group's own tree, over its triangles in its own space.
        let trees: Vec<Bvh> = groups.iter().map(|(g, _)| bvh::build(&g.corners)).collect();
        let mut bottom: Vec<Vec<GpuBvhNode>> = Vec::with_capacity(trees.len());
        let mut first_triangle = Vec::with_capacity(trees.len());
        let mut stack_need = 0;
        for ((group, _), tree) in groups.iter().zip(&trees) {
            first_triangle.push(self.triangles.len() as u32);
            self.append_group(group, &tree.order);
            let wide = tree.wide();
            stack_need = stack_need.max(bvh::wide_stack_need(&wide, 0));
            bottom.push(gpu_nodes(&wide));
        }
        // The placements and their world boxes: the 8 corners of the tree's box mapped in f64, widened
        // by 2^-20 of their magnitude, so that the box holds every point of the mapped triangles the walk
        // can find in f32 (it only culls: a wider box costs a box test, never a hit).
        let mut placements: Vec<(usize, MeshPlacement, bvh::Aabb)> = Vec::new();
        for (g, ((_, maps), tree)) in groups.iter().zip(&trees).enumerate() {
            let root = tree.nodes[0].bounds[0].union(&tree.nodes[0].bounds[1]);
            for placement in maps {
                let m = &placement.to_world;
                let mut b = bvh::Aabb::EMPTY;
                for k in 0..8 {
                    let c = glam::DVec3::new(
                        if k & 1 == 0 { root.lo.x } else { root.hi.x } as f64,
                        if k & 2 == 0 { root.lo.y } else { root.hi.y } as f64,
                        if k & 4 == 0 { root.lo.z } else { root.hi.z } as f64,
                    );
                    let p = m.transform_point3(c);
                    let slack = (p.abs() + m.matrix3.abs() * c.abs()) * (1.0 / 1048576.0);
                    b.grow((p - slack).as_vec3());
                    b.grow((p + slack).as_vec3());
                }
                placements.push((g, *placement, b));
            }
        }
        let boxes: Vec<bvh::Aabb> = placements.iter().map(|p| p.2).collect();
        let top = bvh::build_single_leaves(&boxes);
        let top_wide = top.wide();
        let mut nodes = gpu_nodes(&top_wide);
        for n in &mut nodes {
            for c in &mut n.child {
                if *c != bvh::NO_CHILD && *c & bvh::LEAF != 0 {
                    *c |= bvh::INSTANCE;
                }
            }
        }
        let top_nodes = nodes.len();
        let mut root = Vec::with_capacity(bottom.len());
        for (tree, &first) in bottom.iter().zip(&first_triangle) {
            let base = nodes.len() as u32;
            root.push(base);
            nodes.extend(tree.iter().map(|n| {
                let mut n = *n;
                for c in &mut n.child {
                    *c = shift_reference(*c, base, first);
                }
                n
            }));
        }
        // The scene's own triangles are placed by the identity: their top-level leaf becomes a plain
        // reference to their tree's root, so that a ray walks it in world space, without entering a
        // placement (no mapping of the ray, no exit marker) and its hits carry no placement.
        if self.world_triangles > 0 {
            let identity = top.order.iter().position(|&i| i == 0).expect("placement 0") as u32;
            let leaf = bvh::LEAF | bvh::INSTANCE | (identity << bvh::LEAF_COUNT_BITS);
            for n in &mut nodes[..top_nodes] {
                for c in &mut n.child {
                    if *c == leaf {
                        *c = root[0];
                    }
                }
            }
        }
        self.bvh_nodes = nodes;
        self.instances = top
            .order
            .iter()
            .map(|&i| {
                let (g, m, _) = placements[i as usize];
                gpu_instance(&m, root[g])
            })
            .collect();
        self.stack_need = bvh::wide_stack_need(&top_wide, 0) + 1 + stack_need;
        let mut expanded_walk = 4 * top_wide.len() as u64 + 1;
        for (g, _, _) in &placements {
            expanded_walk += 4 * bottom[*g].len() as u64 + groups[*g].0.corners.len() as u64 + 2;
        }
        self.instanced_walk = expanded_walk;
        self.stats = SceneStats {
            triangles: self.triangles.len(),
            bvh_nodes: self.bvh_nodes.len(),
            bvh_leaves: top.leaves + trees.iter().map(|t| t.leaves).sum::<usize>(),
            bvh_depth: top.depth + trees.iter().map(|t| t.depth).max().unwrap_or(0),
            bvh_build_ms: started.elapsed().as_secs_f64() * 1e3,
            instances: self.instances.len(),
            ..Default::default()
        };
    }

    /// The spheres' BVH, when there are at least [`SPHERE_BVH_MIN`]: built over their boxes, the spheres
    /// put in its leaf order and every sphere index (a sphere light's emitter) renumbered to match. A box
    /// is the sphere's centre +- its radius widened by 2^-20 of |centre| + radius, so that the boxes the
    /// walk tests contain every point intersect_sphere can return (the quantisation only grows them).
    fn add_sphere_bvh(&mut self) {
        if self.spheres.len() < SPHERE_BVH_MIN {
            return;
        }
        let boxes: Vec<bvh::Aabb> = self
            .spheres
            .iter()
            .map(|s| {
                let c = Vec3::from(s.center);
                let r = Vec3::splat(s.radius) + (c.abs() + s.radius) * (1.0 / 1048576.0);
                bvh::Aabb {
                    lo: c - r,
                    hi: c + r,
                }
            })
            .collect();
        let tree = bvh::build_boxes(&boxes);
        let mut renumbered = vec![0u32; self.spheres.len()];
        for (new, &old) in tree.order.iter().enumerate() {
            renumbered[old as usize] = new as u32;
        }
        self.spheres = tree
            .order
            .iter()
            .map(|&i| self.spheres[i as usize])
            .collect();
        for l in &mut self.lights {
            if l.kind == LIGHT_SPHERE {
                l.index = renumbered[l.index as usize];
            }
        }
        self.sphere_nodes = gpu_nodes(&tree.wide());
    }

    /// Bytes of all arrays.
    pub fn bytes(&self) -> u64 {
        fn b<T>(v: &[T]) -> u64 {
            std::mem::size_of_val(v) as u64
        }
        b(&self.spheres)
            + b(&self.triangles)
            + b(&self.materials)
            + b(&self.lights)
            + b(&self.bvh_nodes)
            + b(&self.sphere_nodes)
            + b(&self.mesh_faces)
            + b(&self.mesh_vertices)
            + b(&self.meshes)
            + b(&self.texels)
            + b(&self.textures)
            + b(&self.material_textures)
            + b(&self.light_triangles)
            + b(&self.env_texels)
            + b(&self.env_cdf)
            + b(&self.instances)
    }
}

/// The uniform parameters for a render of `scene` (the primitive counts are filled in by the renderer).
pub fn params_for(scene: &Scene, roulette_depth: u32) -> GpuParams {
    let cam = &scene.camera;
    // Camera frame: forward towards look_at, right = forward x up, up re-orthogonalised.
    let forward = (cam.look_at - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    GpuParams {
        cam_position: cam.position.into(),
        lens_radius: cam.aperture,
        cam_right: right.into(),
        view_half_width: match cam.projection {
            Projection::Perspective => (cam.fov_deg.to_radians() * 0.5).tan(),
            Projection::Orthographic => 0.5 * cam.extent,
        },
        cam_up: up.into(),
        focus_distance: cam.focus_distance,
        cam_forward: forward.into(),
        filter_width: match scene.render.filter {
            Filter::Tent => scene.render.filter_radius,
            _ => scene.render.filter_sigma,
        },
        environment_light: NO_LIGHT,
        triangle_light: NO_LIGHT,
        sample_clamp: scene.render.clamp.unwrap_or(0.0),
        filter_kind: match scene.render.filter {
            Filter::None => FILTER_NONE,
            Filter::Box => FILTER_BOX,
            Filter::Gaussian => FILTER_GAUSSIAN,
            Filter::Tent => FILTER_TENT,
        },
        width: scene.image.width,
        height: scene.image.height,
        // No limit, or more than the cap, is the cap (abi.rs; the kernel counts the paths it ends).
        max_bounces: scene.render.max_bounces.min(crate::kernel::abi::BOUNCE_CAP),
        seed: scene.render.seed,
        sampler: match scene.render.sampler {
            Sampler::Independent => SAMPLER_INDEPENDENT,
            Sampler::Sobol => SAMPLER_SOBOL,
        },
        light_sampling: match scene.render.light_sampling {
            LightSampling::Cone => LIGHT_SAMPLING_CONE,
            LightSampling::Area => LIGHT_SAMPLING_AREA,
            LightSampling::None => LIGHT_SAMPLING_NONE,
            LightSampling::Mis => LIGHT_SAMPLING_MIS,
        },
        num_spheres: 0,
        num_triangles: 0,
        num_lights: 0,
        roulette_depth,
        guard_one: 1.0,
        camera_kind: match cam.projection {
            Projection::Perspective => CAMERA_PERSPECTIVE,
            Projection::Orthographic => CAMERA_ORTHOGRAPHIC,
        },
        aov: AOV_NONE,
        filter_in_image: u32::from(!scene.render.sample_border),
        splat: u32::from(scene.render.splats()),
        _pad: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Roughness 0 (and ior 1) uploads the course's smooth glass; a rough one the rough kind, alpha =
    /// roughness^2; an anisotropic conductor keeps both alphas, an effectively smooth one none.
    #[test]
    fn glossy_materials_upload_their_smooth_forms_below_the_threshold() {
        let glass = |ior, r| {
            gpu_material(&Material::from(Bsdf::Dielectric {
                ior,
                roughness: Roughness::isotropic(r),
            }))
        };
        assert_eq!(glass(1.5, 0.0).kind, MAT_DIELECTRIC);
        assert_eq!(glass(1.5, 0.03).kind, MAT_DIELECTRIC); // alpha 9e-4 < SMOOTH_ALPHA
        assert_eq!(glass(1.0, 0.5).kind, MAT_DIELECTRIC);
        let rough = glass(1.5, 0.5);
        assert_eq!(
            (rough.kind, rough.alpha_x, rough.alpha_y),
            (MAT_ROUGH_DIELECTRIC, 0.25, 0.25)
        );
        let metal = gpu_material(&Material::from(Bsdf::Conductor {
            fresnel: ConductorFresnel::Schlick { f0: Vec3::ONE },
            roughness: Roughness::anisotropic(0.1, 0.5),
            tint: Vec3::ONE,
        }));
        assert_eq!(metal.kind, MAT_CONDUCTOR);
        assert_eq!(metal.flags & MATERIAL_SCHLICK, MATERIAL_SCHLICK);
        assert!((metal.alpha_x - 0.01).abs() < 1e-7 && metal.alpha_y == 0.25);
        let plastic = gpu_material(&Material::from(Bsdf::Plastic {
            albedo: Vec3::splat(0.5),
            ior: 1.5,
            roughness: Roughness::SMOOTH,
            nonlinear: true,
        }));
        assert_eq!((plastic.kind, plastic.alpha_x), (MAT_PLASTIC, 0.0));
        assert!((plastic.fdr_int as f64 - fresnel_diffuse_reflectance(1.0 / 1.5)).abs() < 1e-7);
    }
}
