//! Scene files: TOML text -> validated [`Scene`], or a [`SceneError`] that names the file, the line and
//! the key.
//!
//! The work happens in three steps:
//!
//! 1. `toml` parses the text into its syntax tree (`DeTable`), keeping the byte span of every key and
//!    value. Invalid TOML stops here.
//! 2. serde (`deny_unknown_fields`) turns that tree into the `Raw*` structs (`raw.rs`), which mirror the
//!    file one to one. Every value is wrapped in [`Spanned`] so that step 3 still knows where it came
//!    from. Unknown keys, missing required keys and wrong types stop here; their errors carry only a
//!    byte span and a message, so we find the dotted key path by looking that span up in the tree from
//!    step 1.
//! 3. `Checker` applies the contract's rules (finite numbers, positive radii, a usable camera, ...) and
//!    builds the renderer's types, filling in defaults.
//!
//! The contract is `docs/scene-format.md`. Nothing here may panic on any input: user numbers are
//! compared, never unwrapped, and integer arithmetic on them is done in a type wide enough not to
//! overflow.
//!
//! The files, one concern each:
//!
//! - `mod.rs`: the entry point; the `Checker` (the file name and text), which turns a byte span into an
//!   error at its line and key, and assembles the [`Scene`] from its sections; the files a scene reads
//!   besides itself (OBJ meshes, images), each read once.
//! - `error.rs`: [`SceneError`], and the dotted key path of a span, found in the TOML tree (or guessed
//!   from the line when the text is not TOML).
//! - `raw.rs`: step 2's schema, the `Raw*` types and their serde visitors.
//! - `checks.rs`: the small checks that every section shares (finite numbers, ranges, keys that only
//!   some types need or allow, material names).
//! - `settings.rs`: `[camera]`, `[image]` and `[render]`.
//! - `materials.rs`: `[materials]`: each type's keys, the registry's generic reader, a conductor's
//!   Fresnel, the surface modifiers.
//! - `params.rs`: a material's parameters, each a constant or a texture reference (colours, scalars,
//!   roughness), the texture reference itself, the index of refraction.
//! - `geometry.rs`: `[[sphere]]`, `[[triangle]]` and `[[mesh]]`, with the mapping of MTL materials.
//! - `lights.rs`: `[[light]]` and `[environment]`.

mod checks;
mod error;
mod geometry;
mod lights;
mod materials;
mod params;
mod plugins;
mod raw;
mod settings;

pub use error::SceneError;

use super::image_texture::{Texture, load_texture};
use super::mesh::{self, ObjMesh};
use super::{Material, Scene, Triangle};
use error::{SEE_CONTRACT, backticked_after, find_key_path, guess_key_at, join_key, plain_words};
use raw::RawScene;
use serde::Deserialize;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;
use toml::de::DeTable;

/// A scene's meshes, its instanced meshes, and the warnings reading them gave.
type MeshTables = (Vec<mesh::Mesh>, Vec<mesh::InstancedMesh>, Vec<String>);

/// The file name errors report for the embedded default scene, which has no path.
const DEFAULT_SCENE_FILE: &str = "<default scene>";

// ---------------------------------------------------------------------------------------------------
// Entry point
// ---------------------------------------------------------------------------------------------------

/// Parses and validates a scene. `path` is only used for messages and stored in the result.
pub(crate) fn parse_scene(text: &str, path: Option<&Path>) -> Result<Scene, SceneError> {
    parse_scene_cached(text, path, &mut FileCache::default())
}

/// [`parse_scene`], reading the files it names through `cache` (see [`FileCache`]).
pub(crate) fn parse_scene_cached(
    text: &str,
    path: Option<&Path>,
    cache: &mut FileCache,
) -> Result<Scene, SceneError> {
    let file = match path {
        Some(p) => p.display().to_string(),
        None => DEFAULT_SCENE_FILE.to_string(),
    };
    let checker = Checker {
        file,
        text,
        tree: None,
    };

    // Step 1: syntax. The tree is kept so that step 2's errors can be located in it.
    let tree = DeTable::parse(text).map_err(|e| checker.syntax_error(&e))?;
    // Step 2: shape. Scene files are small, so cloning the tree costs nothing worth avoiding.
    let raw = RawScene::deserialize(toml::de::Deserializer::from(tree.clone()))
        .map_err(|e| checker.shape_error(&e, tree.get_ref()))?;
    // Step 3: meaning, with the tree at hand for the keys step 2 does not type (material plugins').
    let checker = Checker {
        tree: Some(tree.get_ref()),
        ..checker
    };
    checker.scene(&raw, path, cache)
}

// ---------------------------------------------------------------------------------------------------
// Step 3: the contract's rules
// ---------------------------------------------------------------------------------------------------

/// Validates the raw file and builds the [`Scene`]; knows the file name and text to phrase errors.
struct Checker<'a> {
    file: String,
    text: &'a str,
    /// The file's syntax tree (from step 3 on).
    tree: Option<&'a DeTable<'a>>,
}
impl Checker<'_> {
    fn scene(
        &self,
        raw: &RawScene,
        path: Option<&Path>,
        cache: &mut FileCache,
    ) -> Result<Scene, SceneError> {
        let camera = self.camera(&raw.camera)?;
        let mut image = self.image(raw.image.as_ref())?;
        let (render, background) = self.render(raw.render.as_ref())?;
        image.tonemap = self.tonemap(raw.render.as_ref())?;
        image.denoise = raw
            .render
            .as_ref()
            .and_then(|r| r.denoise.as_ref())
            .is_some_and(|d| *d.get_ref());
        let base = path.and_then(Path::parent).unwrap_or(Path::new(""));
        let environment = self.environment(raw, background, base, cache)?;

        // Relative model and image paths are relative to the scene file (to the working directory for the
        // embedded scene). A file used by several meshes or materials is read once.
        let mut files = Files {
            base,
            loaded: cache,
        };
        let (mut materials, mut material_names) = self.scene_materials(raw, &mut files)?;
        let mut spheres = Vec::with_capacity(raw.sphere.len());
        for (i, sphere) in raw.sphere.iter().enumerate() {
            spheres.push(self.sphere(i, sphere.get_ref(), &material_names)?);
        }
        let (triangles, meshes) = self.scene_triangles(raw, &material_names)?;
        let (meshes, instanced, warnings) = self.scene_meshes(
            raw,
            (&mut materials, &mut material_names),
            meshes,
            triangles.len(),
            &mut files,
        )?;
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
            instanced,
            lights,
            environment,
            warnings,
        })
    }

    /// `[materials]`, in the file's order, with their names; then their `back` and `blend` links, once
    /// every name is known.
    fn scene_materials(
        &self,
        raw: &RawScene,
        files: &mut Files,
    ) -> Result<(Vec<Material>, Vec<String>), SceneError> {
        // TOML has already rejected duplicate names, so sorting by position is a total order.
        let mut named: Vec<_> = raw.materials.iter().collect();
        named.sort_by_key(|(name, _)| name.span().start);
        let mut materials = Vec::with_capacity(named.len());
        let mut material_names = Vec::with_capacity(named.len());
        for (name, material) in &named {
            materials.push(self.material(name.get_ref(), material, files)?);
            material_names.push(name.get_ref().clone());
        }
        // Back and blend materials, once every name is known (a material may name one defined after
        // it); one level each (a back has no back of its own, a blend's material no blend).
        let backs = self.material_links(
            &named,
            &material_names,
            "back",
            |m| m.back.as_ref(),
            [
                "a material cannot be its own back",
                "the back material has a back of its own: the back face shows one material",
                "Name a material of its own for the back face, one without a back.",
            ],
        )?;
        let blends = self.material_links(
            &named,
            &material_names,
            "blend",
            |m| m.blend.as_ref(),
            [
                "a material cannot blend with itself",
                "the blend material has a blend of its own: a hit shows one of two materials",
                "Name another material, one without a blend of its own.",
            ],
        )?;
        for ((m, back), blend) in materials.iter_mut().zip(backs).zip(blends) {
            (m.textures.back, m.textures.blend) = (back, blend);
        }

        Ok((materials, material_names))
    }

    /// `[[triangle]]`s: plain ones, and those with texture coordinates as one-triangle meshes.
    fn scene_triangles(
        &self,
        raw: &RawScene,
        material_names: &[String],
    ) -> Result<(Vec<Triangle>, Vec<mesh::Mesh>), SceneError> {
        let mut triangles = Vec::with_capacity(raw.triangle.len());
        let mut meshes = Vec::with_capacity(raw.mesh.len());
        for (i, triangle) in raw.triangle.iter().enumerate() {
            let t = self.triangle(i, triangle.get_ref(), material_names)?;
            match self.triangle_uv(i, triangle.get_ref())? {
                None => triangles.push(t),
                Some(uv) => meshes.push(mesh::Mesh {
                    obj: PathBuf::from(format!("triangle[{i}]")),
                    positions: t.vertices.to_vec(),
                    normals: Vec::new(),
                    uvs: uv.to_vec(),
                    tangents: Vec::new(),
                    triangles: vec![[0, 1, 2]],
                    material: t.material,
                    texture: None,
                    maps: mesh::MeshMaps::default(),
                }),
            }
        }
        Ok((triangles, meshes))
    }

    /// `[[mesh]]`es and `[[instance]]`s after `meshes` (the textured triangles, `triangles` more
    /// counted): each mesh's file read and placed (its MTL materials appended to `materials` and
    /// `material_names`), each instance a copy or one more placement of a named mesh's shared copy.
    /// Returns the meshes, the instanced meshes and the warnings.
    fn scene_meshes(
        &self,
        raw: &RawScene,
        scene_materials: (&mut Vec<Material>, &mut Vec<String>),
        mut meshes: Vec<mesh::Mesh>,
        triangles: usize,
        files: &mut Files,
    ) -> Result<MeshTables, SceneError> {
        let (materials, material_names) = scene_materials;
        let base = files.base;
        let mut total = triangles + meshes.len(); // (a textured [[triangle]] is a one-triangle mesh)
        let mut warnings = Vec::new();
        // Named meshes, for [[instance]]s.
        let mut sources: Vec<(String, geometry::MeshSource)> = Vec::new();
        // Meshes stored once and placed by the two-level BVH (`Scene::instanced`), and per named mesh
        // which of them hold its file's shared meshes: (`source.shared` index, `instanced` index).
        let mut instanced: Vec<mesh::InstancedMesh> = Vec::new();
        let mut nested_of: Vec<Vec<(usize, usize)>> = Vec::new();
        let too_many = |span: Range<usize>, table: &str| {
            self.error(
                span,
                table,
                format!("the scene has more than {} triangles", mesh::MAX_TRIANGLES),
                "Use fewer or simpler meshes (or fewer instances).",
            )
        };
        for (i, mesh) in raw.mesh.iter().enumerate() {
            let table = self.mesh(i, mesh, material_names, materials, base, files.loaded)?;
            total += table
                .meshes
                .iter()
                .chain(table.instanced.iter().flat_map(|(_, m)| m.parts.iter()))
                .map(|m| m.triangles.len())
                .sum::<usize>();
            if total > mesh::MAX_TRIANGLES {
                return Err(too_many(mesh.span(), &format!("mesh[{i}]")));
            }
            meshes.extend(table.meshes);
            let mut nested = Vec::new();
            for (g, shared) in table.instanced {
                nested.push((g, instanced.len()));
                instanced.push(shared);
            }
            for (name, material) in table.materials {
                material_names.push(name);
                materials.push(material);
            }
            warnings.extend(table.warnings);
            if let Some(name) = &mesh.get_ref().name {
                if sources.iter().any(|(n, _)| n == name.get_ref()) {
                    return Err(self.error(
                        name.span(),
                        &format!("mesh[{i}].name"),
                        format!("two [[mesh]] tables are named \"{}\"", name.get_ref()),
                        "Give each [[mesh]] its own name: an [[instance]] names the one it places again.",
                    ));
                }
                sources.push((name.get_ref().clone(), table.source));
                nested_of.push(nested);
            }
        }
        // Instances: shared placements of a named mesh, or copies (geometry::Checker::instance).
        // The placements of each named mesh by the [[instance]]s that share it, gathered first (by mesh,
        // in the order of the first such instance, which names the errors of making the copy): the
        // mesh's shared copy keeps its texture coordinates when some placement's own material reads them.
        let mut shared_of: Vec<Option<usize>> = vec![None; sources.len()];
        let mut pending: Vec<(usize, Range<usize>, String, Vec<mesh::MeshPlacement>)> = Vec::new();
        for (i, instance) in raw.instance.iter().enumerate() {
            let label = format!("instance[{i}]");
            match self.instance(i, instance, &sources, material_names, materials)? {
                geometry::Placed::Copies(placed) => {
                    total += placed.iter().map(|m| m.triangles.len()).sum::<usize>();
                    if total > mesh::MAX_TRIANGLES {
                        return Err(too_many(instance.span(), &label));
                    }
                    meshes.extend(placed);
                }
                geometry::Placed::Shared { source, placement } => {
                    // The file's shared meshes: one more placement for each of their nodes.
                    for &(g, k) in &nested_of[source] {
                        let nodes = &sources[source].1.shared[g].nodes;
                        instanced[k]
                            .placements
                            .extend(nodes.iter().map(|n| mesh::MeshPlacement {
                                to_world: placement.to_world * *n,
                                material: placement.material,
                            }));
                    }
                    if sources[source].1.parts.is_empty() {
                        continue;
                    }
                    let k = *shared_of[source].get_or_insert_with(|| {
                        pending.push((source, instance.span(), label, Vec::new()));
                        pending.len() - 1
                    });
                    pending[k].3.push(placement);
                }
            }
        }
        for (source, span, label, placements) in pending {
            // The mesh's own copy, stored once (its triangles counted once).
            let keep_uvs = placements.iter().any(|p| {
                p.material
                    .is_some_and(|m| !materials[m as usize].textures.is_plain())
            });
            let parts = self.instanced_parts(
                &sources[source].1,
                materials,
                span.clone(),
                &label,
                keep_uvs,
            )?;
            total += parts.iter().map(|m| m.triangles.len()).sum::<usize>();
            if total > mesh::MAX_TRIANGLES {
                return Err(too_many(span, &label));
            }
            instanced.push(mesh::InstancedMesh { parts, placements });
        }
        Ok((meshes, instanced, warnings))
    }

    /// The image file `t` names (relative to the scene file), read once however many keys name it.
    fn mesh_texture(
        &self,
        t: &Spanned<String>,
        key: &str,
        base: &Path,
        files: &mut FileCache,
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

/// The files a scene reads besides itself (mesh files, textures, the environment map), by resolved
/// path, each read once however many keys name it. A scene read again with the same cache (the Python
/// module's edits: `Scene::from_toml_str_cached`) reads none of them again: a file changed on disk since
/// is seen only by a fresh load.
#[derive(Default)]
pub struct FileCache {
    /// Mesh files read, by path and `shape_index`.
    objs: HashMap<(PathBuf, u32), Arc<ObjMesh>>,
    textures: HashMap<PathBuf, Arc<Texture>>,
    environments: HashMap<PathBuf, Arc<super::EnvironmentMap>>,
}

/// The files a scene reads besides itself, relative to `base` (the scene file's directory).
struct Files<'a> {
    base: &'a Path,
    loaded: &'a mut FileCache,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{
        Bsdf, Camera, Filter, Gamma, ImageSettings, Light, LightSampling, Projection,
        RenderSettings, Roughness, Sampler, Sphere, Tonemap, Triangle,
    };
    use glam::Vec3;

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

    pub(super) const MINIMAL: &str = r#"
[camera]
position = [0, 0, 10]
look_at  = [0, 0, 0]
fov      = 45
"#;

    pub(super) fn parse(text: &str) -> Scene {
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
                denoise: false,
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
                filter_radius: 1.0,
                sample_border: true,
                splat: None,
                adaptive: crate::scene::Adaptive::default(),
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
                denoise: false,
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
                filter_radius: 1.0,
                sample_border: true,
                splat: None,
                adaptive: crate::scene::Adaptive::default(),
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
}
