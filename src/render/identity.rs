//! What must match for a resume or a merge: the identity of a render ([`Identity`]), and the hash of the
//! scene content it is computed from ([`content_hash`]).
//!
//! The renderer computes both when it is built; checkpoints store the identity in their header and
//! compare it before a state is resumed or parts are merged. Living here, beside the renderer, they let
//! the renderer name its identity without depending on the checkpoint format (which depends on the
//! renderer).

use crate::VKPATH_VERSION;
use crate::kernel::abi::GpuParams;
use crate::kernel::upload::GpuScene;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::fmt;

// ---------------------------------------------------------------------------------------------------
// The scene's content hash
// ---------------------------------------------------------------------------------------------------

/// FNV-1a, 64 bits: small, stable across platforms and Rust versions (std's hasher is neither promised).
/// It detects accidental differences (another scene, another override), not adversarial ones.
struct Fnv64(u64);

impl Fnv64 {
    fn new() -> Fnv64 {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// A labelled, length-prefixed field, so that moving bytes between fields changes the hash.
    fn field(&mut self, label: &str, bytes: &[u8]) {
        self.bytes(label.as_bytes());
        self.bytes(&(bytes.len() as u64).to_le_bytes());
        self.bytes(bytes);
    }
}

impl fmt::Write for Fnv64 {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// The hash of everything that decides the value of every sample: the validated scene (geometry,
/// materials, lights, environment, camera, image size, seed, bounces, filter, with the command-line
/// overrides applied), the uniform parameters and arrays uploaded to the GPU, and the renderer settings
/// that change paths (Russian roulette). It leaves out what does not change the sums: the target sample
/// count, the display transform (exposure, gamma), where the file lives, and the kernel variant
/// (specialised and generic kernels give the same bits, `tests/specialise.rs`).
pub fn content_hash(scene: &Scene, gpu: &GpuScene, params: &GpuParams) -> u64 {
    // Both structs are taken apart field by field, with no `..`: a field added to either is a compile
    // error here until it is hashed (or, like the statistics, deliberately left out). Keep it that way:
    // a field that changes the image but escapes the hash would let a checkpoint of another scene resume.
    let Scene {
        path: _, // where the file lives does not change the image
        camera,
        image,  // only width and height: exposure and gamma are the display's
        render, // all but the target sample count
        materials,
        material_names: _, // objects refer to materials by index
        spheres,
        triangles,
        meshes: _, // geometry, normals, uvs and texels: hashed as uploaded (mesh_* and texels below)
        instanced: _, // hashed as uploaded (triangles, mesh_* and instances below)
        lights,
        environment,
        warnings: _, // what the reader said about the input, not what the image is
    } = scene;
    // The map's texels are hashed as uploaded (env_texels below), not through Debug.
    let crate::scene::Environment {
        radiance: env_radiance,
        map: _,
        rotate_deg: env_rotate,
    } = environment;
    let GpuScene {
        spheres: gpu_spheres,
        triangles: gpu_triangles,
        materials: gpu_materials,
        lights: gpu_lights,
        bvh_nodes,
        sphere_nodes: _, // follows from the spheres (hashed in their uploaded order)
        mesh_faces,
        mesh_vertices,
        meshes,
        texels,
        textures,
        material_textures,
        light_triangles,
        env_texels,
        env_cdf: _,           // follows from env_texels
        environment_light: _, // in params
        triangle_light: _,    // in params
        instances,
        stack_need: _,      // follows from bvh_nodes
        instanced_walk: _,  // follows from bvh_nodes and instances
        world_triangles: _, // follows from instances (the identity placement's tree)
        stats: _,           // build statistics (timings): not content
    } = gpu;
    let mut render = *render;
    render.samples = 0;
    // Whether the render splats is hashed as decided (`params.splat`), not as written: `splat = true`
    // written and left to its default are one render, and scenes from before the key keep their hash.
    render.splat = None;
    // Adaptive sampling decides which samples are taken, not what a pixel converges to: a checkpoint
    // carries its counts (and is refused by a render that does not sample adaptively), and a render may
    // go on with another threshold, as with another sample count.
    render.adaptive = crate::scene::Adaptive::default();
    let mut h = Fnv64::new();
    h.bytes(b"vkpath scene v1");
    // Debug prints every field, floats in their shortest round-trip form: a faithful serialisation.
    let _ = fmt::Write::write_fmt(
        &mut h,
        format_args!(
            "{camera:?}|{}x{}|{render:?}|{materials:?}|{spheres:?}|{triangles:?}|{lights:?}|\
             {env_radiance:?}|{env_rotate:?}",
            image.width, image.height
        ),
    );
    h.field("params", bytemuck::bytes_of(params));
    h.field("spheres", bytemuck::cast_slice(gpu_spheres));
    h.field("triangles", bytemuck::cast_slice(gpu_triangles));
    h.field("materials", bytemuck::cast_slice(gpu_materials));
    h.field("lights", bytemuck::cast_slice(gpu_lights));
    h.field("bvh_nodes", bytemuck::cast_slice(bvh_nodes));
    h.field("mesh_faces", bytemuck::cast_slice(mesh_faces));
    h.field("mesh_vertices", bytemuck::cast_slice(mesh_vertices));
    h.field("meshes", bytemuck::cast_slice(meshes));
    h.field("texels", bytemuck::cast_slice(texels));
    h.field("textures", bytemuck::cast_slice(textures));
    h.field("light_triangles", bytemuck::cast_slice(light_triangles));
    h.field("env_texels", bytemuck::cast_slice(env_texels));
    // (Only when present, so that scenes without them keep the identity they had.)
    if !instances.is_empty() {
        h.field("instances", bytemuck::cast_slice(instances));
    }
    // (Only when present, so that scenes without material textures keep the identity they had.)
    if !material_textures.is_empty() {
        h.field("material_textures", bytemuck::cast_slice(material_textures));
    }
    h.0
}

// ---------------------------------------------------------------------------------------------------
// The identity
// ---------------------------------------------------------------------------------------------------

/// What must be equal for two accumulation states to belong to the same render: a checkpoint is resumed,
/// and partial renders are merged, only when these match.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    pub vkpath_version: String,
    /// [`content_hash`] as 16 hexadecimal digits.
    pub scene_hash: String,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_bounces: u32,
    /// `u32::MAX` when Russian roulette is off.
    pub roulette_depth: u32,
    /// `render.sampler` and `render.light_sampling` by name (also in the content hash; here so that a
    /// refusal can say which differs).
    pub sampler: String,
    pub light_sampling: String,
}

/// The name of a `GpuParams::sampler` value.
fn sampler_name(v: u32) -> String {
    match v {
        crate::kernel::abi::SAMPLER_SOBOL => "sobol".into(),
        _ => "independent".into(),
    }
}

/// The name of a `GpuParams::light_sampling` value (scene::LightSampling::ALL has the names).
fn light_sampling_name(v: u32) -> String {
    use crate::kernel::abi::*;
    let strategy = match v {
        LIGHT_SAMPLING_AREA => crate::scene::LightSampling::Area,
        LIGHT_SAMPLING_NONE => crate::scene::LightSampling::None,
        LIGHT_SAMPLING_MIS => crate::scene::LightSampling::Mis,
        _ => crate::scene::LightSampling::Cone,
    };
    crate::scene::LightSampling::ALL
        .iter()
        .find(|(s, _)| *s == strategy)
        .map_or("cone", |(_, n)| *n)
        .into()
}

impl Identity {
    /// The identity of a render of `scene` with these parameters and content hash.
    pub fn new(params: &GpuParams, content_hash: u64) -> Identity {
        Identity {
            vkpath_version: VKPATH_VERSION.to_string(),
            scene_hash: format!("{content_hash:016x}"),
            width: params.width,
            height: params.height,
            seed: params.seed,
            max_bounces: params.max_bounces,
            roulette_depth: params.roulette_depth,
            sampler: sampler_name(params.sampler),
            light_sampling: light_sampling_name(params.light_sampling),
        }
    }

    /// The differences between `self` (a file's) and `other` (this render's), in words; empty when equal.
    pub fn differences(&self, other: &Identity) -> Vec<String> {
        let mut d = Vec::new();
        if self.vkpath_version != other.vkpath_version {
            d.push(format!(
                "it was written by vkpath {} and this is vkpath {} (only the version that wrote a \
                 state can promise the same bits)",
                self.vkpath_version, other.vkpath_version
            ));
        }
        if (self.width, self.height) != (other.width, other.height) {
            d.push(format!(
                "its image is {}x{}, this one {}x{} (--width/--height)",
                self.width, self.height, other.width, other.height
            ));
        }
        if self.seed != other.seed {
            d.push(format!(
                "its seed is {}, this one {} (--seed)",
                self.seed, other.seed
            ));
        }
        if self.max_bounces != other.max_bounces {
            d.push(format!(
                "its max_bounces is {}, this one {} (--max-bounces)",
                self.max_bounces, other.max_bounces
            ));
        }
        if self.roulette_depth != other.roulette_depth {
            let show = |r: u32| {
                if r == u32::MAX {
                    "off".to_string()
                } else {
                    r.to_string()
                }
            };
            d.push(format!(
                "its Russian roulette depth is {}, this one {} (--roulette-depth)",
                show(self.roulette_depth),
                show(other.roulette_depth)
            ));
        }
        if self.sampler != other.sampler {
            d.push(format!(
                "its sampler is {}, this one {} (--sampler)",
                self.sampler, other.sampler
            ));
        }
        if self.light_sampling != other.light_sampling {
            d.push(format!(
                "its light sampling is {}, this one {} (--light-sampling)",
                self.light_sampling, other.light_sampling
            ));
        }
        if d.is_empty() && self.scene_hash != other.scene_hash {
            d.push(format!(
                "the scene's content differs (geometry, materials, lights, camera or render settings: \
                 content hash {} in the file, {} here)",
                self.scene_hash, other.scene_hash
            ));
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_differences_are_named() {
        let a = Identity {
            vkpath_version: VKPATH_VERSION.into(),
            scene_hash: "0123456789abcdef".into(),
            width: 2,
            height: 1,
            seed: 0,
            max_bounces: 5,
            roulette_depth: 3,
            sampler: "independent".into(),
            light_sampling: "mis".into(),
        };
        let mut b = a.clone();
        b.seed = 9;
        b.roulette_depth = u32::MAX;
        let d = a.differences(&b).join("; ");
        assert!(d.contains("seed is 0, this one 9"), "{d}");
        assert!(d.contains("roulette depth is 3, this one off"), "{d}");
        // Issue 18: a refusal for another sampler or light sampling said only "the scene's content
        // differs".
        let mut e = a.clone();
        (e.sampler, e.light_sampling) = ("sobol".into(), "cone".into());
        let d = a.differences(&e).join("; ");
        assert!(
            d.contains("sampler is independent, this one sobol (--sampler)"),
            "{d}"
        );
        assert!(
            d.contains("light sampling is mis, this one cone (--light-sampling)"),
            "{d}"
        );
        let mut c = a.clone();
        c.scene_hash = "ffffffffffffffff".into();
        assert!(a.differences(&c)[0].contains("content differs"));
    }
}
