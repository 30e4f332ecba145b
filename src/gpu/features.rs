//! The feature set of a scene: which parts of the kernel it needs. The renderer specialises the kernel
//! for it (see `shaders/scene.wgsl`, "Specialisation"), so that a scene pays only for what it uses.

use super::scene::GpuScene;
use super::types::{
    GpuParams, LIGHT_POINT, LIGHT_SPHERE, MAT_DIELECTRIC, MAT_DIFFUSE, MAT_EMITTER, MAT_MIRROR,
    MESH_SMOOTH, MESH_TEXTURED,
};

/// One flag per overridable feature of the kernel; `filter` is the pixel filter as a constant, or `None`
/// to read it from the parameters at run time (the generic kernel).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct FeatureSet {
    pub spheres: bool,
    pub triangles: bool,
    /// Triangles are found through the BVH (scenes of more than `scene::BVH_MIN_TRIANGLES` triangles);
    /// otherwise by a loop over every triangle, which is also the reference that tests and the scaling
    /// benchmark compare the BVH against.
    pub bvh: bool,
    /// The loop over every triangle (scenes without a BVH; the generic kernel has both).
    pub triangle_loop: bool,
    /// Some mesh interpolates vertex normals (`smooth`).
    pub smooth_normals: bool,
    /// Some mesh has a texture.
    pub textures: bool,
    pub diffuse: bool,
    pub mirror: bool,
    pub dielectric: bool,
    pub emitters: bool,
    pub point_lights: bool,
    pub sphere_lights: bool,
    pub lens: bool,
    pub roulette: bool,
    pub background: bool,
    pub filter: Option<u32>,
    /// The sampler (`GpuParams::sampler`) as a constant, or `None` to read it at run time.
    pub sampler: Option<u32>,
    /// The sphere-light strategy (`GpuParams::light_sampling`) as a constant, or `None` to read it.
    pub light_sampling: Option<u32>,
}

impl FeatureSet {
    /// Exactly one material kind is used (emitters included), so the kernel need not test the kind.
    pub fn single_material_kind(&self) -> bool {
        [self.diffuse, self.mirror, self.dielectric, self.emitters]
            .iter()
            .filter(|&&b| b)
            .count()
            == 1
    }

    /// Exactly one light kind is present.
    pub fn single_light_kind(&self) -> bool {
        self.point_lights != self.sphere_lights
    }
}

impl FeatureSet {
    /// Everything on: the one kernel that renders any scene.
    pub fn generic() -> FeatureSet {
        FeatureSet {
            spheres: true,
            triangles: true,
            bvh: true,
            triangle_loop: true,
            smooth_normals: true,
            textures: true,
            diffuse: true,
            mirror: true,
            dielectric: true,
            emitters: true,
            point_lights: true,
            sphere_lights: true,
            lens: true,
            roulette: true,
            background: true,
            filter: None,
            sampler: None,
            light_sampling: None,
        }
    }

    /// What `scene` (as uploaded, with its parameters) needs. Materials count only when an object uses
    /// them; a light kind only when present.
    pub fn of(scene: &GpuScene, params: &GpuParams) -> FeatureSet {
        let used_kinds: Vec<u32> = scene
            .spheres
            .iter()
            .map(|s| s.material)
            .chain(scene.triangles.iter().map(|t| t.material))
            .filter_map(|m| scene.materials.get(m as usize).map(|m| m.kind))
            .collect();
        let uses = |kind| used_kinds.contains(&kind);
        let mesh_flag = |flag| scene.meshes.iter().any(|m| m.flags & flag != 0);
        FeatureSet {
            spheres: !scene.spheres.is_empty(),
            triangles: !scene.triangles.is_empty(),
            bvh: !scene.bvh_nodes.is_empty(),
            triangle_loop: !scene.triangles.is_empty() && scene.bvh_nodes.is_empty(),
            smooth_normals: mesh_flag(MESH_SMOOTH),
            textures: mesh_flag(MESH_TEXTURED),
            diffuse: uses(MAT_DIFFUSE),
            mirror: uses(MAT_MIRROR),
            dielectric: uses(MAT_DIELECTRIC),
            emitters: uses(MAT_EMITTER),
            point_lights: scene.lights.iter().any(|l| l.kind == LIGHT_POINT),
            sphere_lights: scene.lights.iter().any(|l| l.kind == LIGHT_SPHERE),
            lens: params.lens_radius > 0.0,
            // The roulette test runs after scattering event `bounces` (1..=max_bounces).
            roulette: params.roulette_depth <= params.max_bounces,
            background: params.background.iter().any(|&c| c != 0.0),
            filter: Some(params.filter_kind),
            sampler: Some(params.sampler),
            light_sampling: Some(params.light_sampling),
        }
    }

    /// The values of the kernel's `override` constants (naga takes them as f64).
    pub fn pipeline_constants(&self) -> Vec<(&'static str, f64)> {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        vec![
            ("HAS_SPHERES", b(self.spheres)),
            ("HAS_TRIANGLES", b(self.triangles)),
            ("HAS_BVH", b(self.bvh)),
            ("HAS_TRIANGLE_LOOP", b(self.triangle_loop)),
            ("HAS_SMOOTH_NORMALS", b(self.smooth_normals)),
            ("HAS_TEXTURES", b(self.textures)),
            ("HAS_MESH_SHADING", b(self.smooth_normals || self.textures)),
            ("HAS_DIFFUSE", b(self.diffuse)),
            ("HAS_MIRROR", b(self.mirror)),
            ("HAS_DIELECTRIC", b(self.dielectric)),
            ("HAS_EMITTERS", b(self.emitters)),
            ("HAS_POINT_LIGHTS", b(self.point_lights)),
            ("HAS_SPHERE_LIGHTS", b(self.sphere_lights)),
            ("HAS_LENS", b(self.lens)),
            ("HAS_ROULETTE", b(self.roulette)),
            ("HAS_BACKGROUND", b(self.background)),
            ("SINGLE_MATERIAL_KIND", b(self.single_material_kind())),
            ("SINGLE_LIGHT_KIND", b(self.single_light_kind())),
            ("FILTER_FROM_PARAMS", b(self.filter.is_none())),
            ("FILTER_KIND", self.filter.unwrap_or(0) as f64),
            // rng.wgsl: 1 = Sobol'.
            ("SAMPLER_FROM_RNG", b(self.sampler.is_none())),
            ("SAMPLER_IS_SOBOL", b(self.sampler == Some(1))),
            // scene.wgsl: 1 = area, 2 = none.
            (
                "LIGHT_SAMPLING_FROM_PARAMS",
                b(self.light_sampling.is_none()),
            ),
            ("LIGHT_SAMPLING_IS_AREA", b(self.light_sampling == Some(1))),
            ("LIGHT_SAMPLING_IS_NONE", b(self.light_sampling == Some(2))),
        ]
    }

    /// Switches the feature named as in [`FeatureSet::absent`] on (its code back in the kernel).
    pub fn enable(&mut self, name: &str) {
        match name {
            "spheres" => self.spheres = true,
            "triangles" => {
                self.triangles = true;
                self.bvh = true;
                self.triangle_loop = true;
            }
            "smooth_normals" => self.smooth_normals = true,
            "textures" => self.textures = true,
            "diffuse" => self.diffuse = true,
            "mirror" => self.mirror = true,
            "dielectric" => self.dielectric = true,
            "emitters" => self.emitters = true,
            "point_lights" => self.point_lights = true,
            "sphere_lights" => self.sphere_lights = true,
            "lens" => self.lens = true,
            "roulette" => self.roulette = true,
            "background" => self.background = true,
            _ => {}
        }
    }

    /// The features this set leaves out, by name (for reports).
    pub fn absent(&self) -> Vec<&'static str> {
        let flags = [
            ("spheres", self.spheres),
            ("triangles", self.triangles),
            ("smooth_normals", self.smooth_normals),
            ("textures", self.textures),
            ("diffuse", self.diffuse),
            ("mirror", self.mirror),
            ("dielectric", self.dielectric),
            ("emitters", self.emitters),
            ("point_lights", self.point_lights),
            ("sphere_lights", self.sphere_lights),
            ("lens", self.lens),
            ("roulette", self.roulette),
            ("background", self.background),
        ];
        flags
            .iter()
            .filter(|(_, on)| !on)
            .map(|(n, _)| *n)
            .collect()
    }
}
