//! `[[sphere]]`, `[[triangle]]` and `[[mesh]]`: the objects, placed in world space, and the scene
//! materials that a mesh's own (MTL or glTF) materials become.

use super::error::SceneError;
use super::raw::{RawInstance, RawMatrix, RawMesh, RawSphere, RawTriangle, RawVec3};
use super::{Checker, FileCache};
use crate::scene::image_texture::{Texture, load_texture};
use crate::scene::mesh::{self, Mesh, MeshMaps, ObjMesh, Placement};
use crate::scene::mesh_file;
use crate::scene::texture::MaterialTextures;
use crate::scene::{Bsdf, ConductorFresnel, Emission, Material, Roughness, Sphere, Triangle};
use glam::{DAffine3, DMat4, DVec3, Vec3};
use std::cell::OnceCell;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

/// What one `[[mesh]]` table becomes: its meshes (one per MTL material when the OBJ's materials are used),
/// the materials it adds to the scene (named `mesh[i]/<MTL name>`), and what the reader noticed.
#[derive(Default)]
pub(super) struct MeshTable {
    pub(super) meshes: Vec<Mesh>,
    pub(super) materials: Vec<(String, Material)>,
    pub(super) warnings: Vec<String>,
    /// What `[[instance]]`s of this mesh place again: the file, its parts and their materials.
    pub(super) source: MeshSource,
    /// The file's shared meshes (`source.shared[g]`, by `g`) that this table placed as one copy each,
    /// with the placements it gave them.
    pub(super) instanced: Vec<(usize, mesh::InstancedMesh)>,
}

/// A `[[mesh]]` before placement: its file's parts (one per material) and how they are shaded, which an
/// `[[instance]]` places again with its own transform.
#[derive(Default)]
pub(super) struct MeshSource {
    pub(super) obj_path: PathBuf,
    pub(super) smooth: bool,
    /// The parts in the file's own space.
    pub(super) parts: Vec<MeshPart>,
    /// The meshes the file places several times (glTF nodes sharing a mesh: [`ObjMesh::shared`]).
    pub(super) shared: Vec<SharedParts>,
    /// The box around `parts`, found when first needed.
    bounds: OnceCell<Bounds>,
}

/// The parts of one mesh a file places several times, in the mesh's own space, and the maps from it
/// to the file's space.
pub(super) struct SharedParts {
    pub(super) parts: Vec<MeshPart>,
    pub(super) nodes: Vec<DAffine3>,
    /// The box around `parts`, found when first needed.
    bounds: OnceCell<Bounds>,
}

impl MeshSource {
    /// Whether any part emits light (a material with emission, or an emission texture): an emitting
    /// triangle is a light, sampled in world space, so it is never shared.
    fn emits(parts: &[MeshPart], materials: &[Material]) -> bool {
        parts.iter().any(|part| {
            part.maps.emissive.is_some()
                || materials
                    .get(part.material as usize)
                    .is_some_and(|m| m.emission.is_some())
        })
    }

    /// Every vertex of the source, placed by `affine` (each shared mesh's through its nodes as well):
    /// the first that leaves the f32 range, if any.
    fn overflows(&self, affine: &DAffine3) -> Option<DVec3> {
        first_overflow(&self.parts, &self.bounds, std::iter::once(*affine)).or_else(|| {
            self.shared.iter().find_map(|g| {
                first_overflow(&g.parts, &g.bounds, g.nodes.iter().map(|n| *affine * *n))
            })
        })
    }
}

/// One material's faces of a mesh file.
pub(super) struct MeshPart {
    obj: Arc<ObjMesh>,
    material: u32,
    texture: Option<Arc<Texture>>,
    maps: MeshMaps,
}

/// What the readers of one `[[mesh]]`'s keys share: its index and keys, its `material` (an index into
/// the scene's materials so far), the file read.
struct MeshContext<'a> {
    i: usize,
    raw: &'a RawMesh,
    material: Option<u32>,
    names: &'a [String],
    materials: &'a [Material],
    base: &'a Path,
    obj_path: PathBuf,
    obj: Arc<ObjMesh>,
}

impl MeshContext<'_> {
    /// The dotted key of `field` in this mesh's table.
    fn key(&self, field: &str) -> String {
        format!("mesh[{}].{field}", self.i)
    }
}

/// A group of a mesh's faces by their file material: its id in the file, the scene material's index,
/// its texture and maps.
type MtlGroup = (Option<u32>, u32, Option<Arc<Texture>>, MeshMaps);

/// An axis-aligned box, its least and greatest corners (empty: +inf and -inf).
type Bounds = [DVec3; 2];

/// The first vertex of `parts` that one of `placements` takes out of the f32 range, where it lands.
/// `bounds` caches the box around the parts' vertices: a vertex is a convex combination of the box's
/// eight corners and an affine map keeps the combination, so where every mapped corner lies within
/// half the f32 range (a margin far above f64's rounding of the map, 2^-52 relative) no vertex can
/// leave it, and only placements that fail this test map every vertex. Checking a shared mesh's
/// placements costs O(1) each instead of O(vertices), with the same refusals.
fn first_overflow(
    parts: &[MeshPart],
    bounds: &OnceCell<Bounds>,
    mut placements: impl Iterator<Item = DAffine3>,
) -> Option<DVec3> {
    let vertices = || parts.iter().flat_map(|part| part.obj.positions.iter());
    let [lo, hi] = *bounds.get_or_init(|| {
        vertices().fold([DVec3::INFINITY, DVec3::NEG_INFINITY], |[lo, hi], p| {
            [lo.min(p.as_dvec3()), hi.max(p.as_dvec3())]
        })
    });
    let safe = 0.5 * f64::from(f32::MAX);
    placements.find_map(|a| {
        let corners_safe = (0..8).all(|k| {
            let corner = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            a.transform_point3(corner).abs().max_element() <= safe
        });
        if corners_safe {
            return None;
        }
        vertices()
            .map(|p| a.transform_point3(p.as_dvec3()))
            .find(|p| !p.as_vec3().is_finite())
    })
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
            layers: m.layers,
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

impl Checker<'_> {
    pub(super) fn sphere(
        &self,
        i: usize,
        raw: &RawSphere,
        names: &[String],
    ) -> Result<Sphere, SceneError> {
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

    pub(super) fn triangle(
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

    /// A `[[triangle]]`'s texture coordinates (`uv`, one [u, v] per vertex), when it gives them: the
    /// triangle is then a one-triangle mesh, whose uvs a textured material reads (without them a
    /// triangle's uv is its barycentrics).
    pub(super) fn triangle_uv(
        &self,
        i: usize,
        raw: &RawTriangle,
    ) -> Result<Option<[[f32; 2]; 3]>, SceneError> {
        let Some(uv) = &raw.uv else { return Ok(None) };
        let key = format!("triangle[{i}].uv");
        let given = uv.get_ref();
        if given.len() != 3 {
            return Err(self.error(
                uv.span(),
                &key,
                format!(
                    "a triangle's uv has one [u, v] per vertex, 3; got {}",
                    given.len()
                ),
                "Give uv = [[u, v], [u, v], [u, v]], in the order of `vertices`.",
            ));
        }
        let mut out = [[0.0; 2]; 3];
        for (slot, [u, v]) in out.iter_mut().zip(given.iter().map(|p| p.0)) {
            if !(u.is_finite() && v.is_finite()) {
                return Err(self.not_finite(uv.span(), &key, &format!("[{u}, {v}]")));
            }
            *slot = [u, v];
        }
        Ok(Some(out))
    }

    /// A `[[mesh]]`: the OBJ read and placed, its normals and texture resolved. OBJ problems are reported
    /// at the `obj` key, with the OBJ's own file and line in the message.
    pub(super) fn mesh(
        &self,
        i: usize,
        raw: &Spanned<RawMesh>,
        names: &[String],
        materials: &[Material],
        base: &Path,
        files: &mut FileCache,
    ) -> Result<MeshTable, SceneError> {
        let m = raw.get_ref();
        let key = |field: &str| format!("mesh[{i}].{field}");
        let material = match &m.material {
            Some(name) => Some(self.material_index(name, &key("material"), names)?),
            None => None,
        };
        let placement = self.placement(
            &format!("mesh[{i}]"),
            m.matrix.as_ref(),
            m.scale.as_ref(),
            m.rotate.as_ref(),
            m.translate.as_ref(),
        )?;
        let smooth = m.smooth.as_ref().is_none_or(|s| *s.get_ref());

        let (obj_path, obj) = self.mesh_file(i, m, base, files)?;
        let cx = MeshContext {
            i,
            raw: m,
            material,
            names,
            materials,
            base,
            obj_path,
            obj,
        };
        let texture = self.mesh_texture_key(&cx, files)?;
        let maps = self.mesh_maps(&cx, files)?;
        let (obj_path, obj) = (&cx.obj_path, cx.obj.clone());

        let mut table = MeshTable {
            source: MeshSource {
                obj_path: obj_path.clone(),
                smooth: smooth && !obj.face_normals,
                parts: Vec::new(),
                shared: Vec::new(),
                bounds: OnceCell::new(),
            },
            ..MeshTable::default()
        };
        table.warnings.extend(
            obj.notes
                .iter()
                .map(|n| match n.strip_prefix(crate::scene::NOTE) {
                    Some(note) => format!(
                        "{}mesh[{i}]: {}: {note}",
                        crate::scene::NOTE,
                        obj_path.display()
                    ),
                    None => format!("mesh[{i}]: {}: {n}", obj_path.display()),
                }),
        );
        if let Some(material) = material {
            // The scene's material applies to every face, whatever the OBJ's MTL says.
            let part = |obj: Arc<ObjMesh>| MeshPart {
                obj,
                material,
                texture: texture.clone(),
                maps: maps.clone(),
            };
            table.source.shared = obj
                .shared
                .iter()
                .map(|g| SharedParts {
                    parts: vec![part(Arc::new(g.mesh.clone()))],
                    nodes: g.nodes.clone(),
                    bounds: OnceCell::new(),
                })
                .collect();
            if !obj.triangles.is_empty() {
                table.source.parts.push(part(obj));
            }
            return self.place_table(
                table,
                &placement,
                materials,
                raw.span(),
                &format!("mesh[{i}]"),
            );
        }
        // A glTF primitive without a material has the file's default (glTF 2.0 §3.9.6), even when the
        // file has no materials at all: vkpath's, diffuse Kd 0.8, as for the primitives that name none
        // in a file that has some (docs/scene-format.md, "glTF meshes").
        if obj.materials.is_empty() && !mesh_file::is_gltf(obj_path) {
            let Some(problem) = &obj.mtl_problem else {
                return Err(self.error(
                    raw.span(),
                    &format!("mesh[{i}]"),
                    format!(
                        "mesh[{i}] needs a material: {} has no materials of its own",
                        obj_path.display()
                    ),
                    "Give the mesh `material = \"name\"`, one of the names in [materials].",
                ));
            };
            table.warnings.push(format!(
                "mesh[{i}]: {problem}; its faces are diffuse grey (albedo 0.8, MTL's default Kd). Give the mesh a `material` to choose one."
            ));
        }
        let made = self.mtl_materials(&cx, &mut table, files);
        let parts_of = |m: &ObjMesh| -> Vec<MeshPart> {
            made.iter()
                .map(|(id, index, texture, maps)| MeshPart {
                    obj: Arc::new(m.subset(*id)),
                    material: *index,
                    texture: texture.clone(),
                    maps: maps.clone(),
                })
                .filter(|part| !part.obj.triangles.is_empty())
                .collect()
        };
        table.source.parts = parts_of(&obj);
        table.source.shared = obj
            .shared
            .iter()
            .map(|g| SharedParts {
                parts: parts_of(&g.mesh),
                nodes: g.nodes.clone(),
                bounds: OnceCell::new(),
            })
            .collect();
        // (The MTL materials are not in `materials` yet: the parts look theirs up in the table.)
        let mut all = materials.to_vec();
        all.extend(table.materials.iter().map(|(_, m)| m.clone()));
        self.place_table(table, &placement, &all, raw.span(), &format!("mesh[{i}]"))
    }

    /// A `[[mesh]]`'s file (`obj`, and `shape_index` for a Mitsuba .serialized file), read once however
    /// many meshes name it; a problem reading it is reported at the `obj` key, with the file's own line.
    fn mesh_file(
        &self,
        i: usize,
        m: &RawMesh,
        base: &Path,
        files: &mut FileCache,
    ) -> Result<(PathBuf, Arc<ObjMesh>), SceneError> {
        let key = |field: &str| format!("mesh[{i}].{field}");
        let obj_path = base.join(m.obj.get_ref());
        let shape_index = match &m.shape_index {
            None => 0,
            Some(s) if mesh_file::is_serialized(&obj_path) => *s.get_ref(),
            Some(s) => {
                return Err(self.error(
                    s.span(),
                    &key("shape_index"),
                    "shape_index picks one of the meshes of a Mitsuba .serialized file, and this mesh is \
                     not one",
                    "Remove shape_index.",
                ));
            }
        };
        let cached = (obj_path.clone(), shape_index);
        let obj = match files.objs.get(&cached) {
            Some(obj) => obj.clone(),
            None => {
                let loaded = mesh_file::load_mesh_file(&obj_path, shape_index).map_err(|e| {
                    let at = e.line.map_or(String::new(), |l| format!(", line {l}"));
                    let hint = if mesh_file::is_gltf(&obj_path) {
                        "The path is relative to the scene file. A glTF 2.0 file (.gltf with its buffers, or .glb) \
                         needs a scene with at least one mesh of TRIANGLES primitives."
                    } else if mesh_file::is_serialized(&obj_path) {
                        "The path is relative to the scene file. A Mitsuba .serialized file (versions 3 and 4) \
                         holds one or more meshes; shape_index picks one (from 0)."
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
                files.objs.insert(cached, loaded.clone());
                loaded
            }
        };
        Ok((obj_path, obj))
    }

    /// A `[[mesh]]`'s `texture`: the albedo (tint, base colour) of its material, or the factor of its
    /// emission; it needs a material with one of those and the file's texture coordinates.
    fn mesh_texture_key(
        &self,
        cx: &MeshContext<'_>,
        files: &mut FileCache,
    ) -> Result<Option<Arc<Texture>>, SceneError> {
        Ok(match (&cx.raw.texture, cx.material) {
            (None, _) => None,
            (Some(t), None) => {
                return Err(self.error(
                    t.span(),
                    &cx.key("texture"),
                    "a texture is given but no material for it to apply to",
                    "Give the mesh a `material` as well; without one, the OBJ's MTL materials are used, with \
                     their own map_Kd textures.",
                ));
            }
            (Some(t), Some(material)) => {
                let tkey = cx.key("texture");
                // The texture replaces the albedo (or tint) and multiplies the emission: a material with
                // neither has nothing for it to change.
                let untexturable = match cx.materials.get(material as usize) {
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
                    Some(Material {
                        bsdf: Bsdf::Plugin { .. },
                        emission: None,
                        ..
                    }) => Some(
                        "a plugin material that does not emit (its parameters take their textures in its own table)",
                    ),
                    _ => None,
                };
                if let Some(what) = untexturable {
                    return Err(self.error(
                        t.span(),
                        &tkey,
                        format!(
                            "material \"{}\" is {what}: it has no albedo for a texture to replace and no emission for it to multiply",
                            cx.names[material as usize]
                        ),
                        "Give textured meshes a diffuse or plastic material (the texture is the albedo), a mirror (the tint), a metallic_roughness material or a conductor with base_color (the texture is the base colour) or an emitting material (the texture multiplies the emission).",
                    ));
                }
                if cx.obj.uvs.is_none() {
                    return Err(self.error(
                        t.span(),
                        &tkey,
                        format!(
                            "{} has no texture coordinates (`vt`) for every face corner, so the texture cannot be mapped",
                            cx.obj_path.display()
                        ),
                        "Export the OBJ with uvs (faces written `v/vt` or `v/vt/vn`), or remove `texture`.",
                    ));
                }
                Some(self.mesh_texture(
                    t,
                    &tkey,
                    cx.base,
                    files,
                    "The path is relative to the scene file; the texture must be a PNG image (sRGB).",
                )?)
            }
        })
    }

    /// A `[[mesh]]`'s glTF-style maps (docs/scene-format.md, "[[mesh]]"): each needs the mesh's
    /// `material`, a material it can change, and the file's texture coordinates.
    fn mesh_maps(
        &self,
        cx: &MeshContext<'_>,
        files: &mut FileCache,
    ) -> Result<MeshMaps, SceneError> {
        let mut maps = MeshMaps {
            normal_scale: 1.0,
            ..MeshMaps::default()
        };
        let given = [
            ("emission_texture", &cx.raw.emission_texture),
            (
                "metallic_roughness_texture",
                &cx.raw.metallic_roughness_texture,
            ),
            ("normal_map", &cx.raw.normal_map),
        ];
        for (field, t) in given {
            let Some(t) = t else { continue };
            let tkey = cx.key(field);
            let Some(material) = cx.material else {
                return Err(self.error(
                    t.span(),
                    &tkey,
                    format!("`{field}` is given but no material for it to apply to"),
                    "Give the mesh a `material` as well.",
                ));
            };
            let mat = cx.materials.get(material as usize);
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
                    format!("material \"{}\" {why}", cx.names[material as usize]),
                    "emission_texture needs an emitting material (an `emission`, or an emitter), metallic_roughness_texture a metallic_roughness material.",
                ));
            }
            if cx.obj.uvs.is_none() {
                return Err(self.error(
                    t.span(),
                    &tkey,
                    format!(
                        "{} has no texture coordinates (`vt`) for every face corner, so `{field}` cannot be mapped",
                        cx.obj_path.display()
                    ),
                    "Export the OBJ with uvs (faces written `v/vt` or `v/vt/vn`), or remove the key.",
                ));
            }
            let tex = self.mesh_texture(
                t,
                &tkey,
                cx.base,
                files,
                "The path is relative to the scene file; data maps (metallic_roughness_texture, normal_map) are read as stored, so give them as PNG (8-bit, not sRGB-decoded).",
            )?;
            match field {
                "emission_texture" => maps.emissive = Some(tex),
                "metallic_roughness_texture" => maps.metallic_roughness = Some(tex),
                _ => maps.normal = Some(tex),
            }
        }
        if let Some(s) = &cx.raw.normal_scale {
            if cx.raw.normal_map.is_none() {
                return Err(self.error(
                    s.span(),
                    &cx.key("normal_scale"),
                    "normal_scale is given without a normal_map",
                    "Give the mesh a `normal_map`, or remove `normal_scale`.",
                ));
            }
            maps.normal_scale = self.number(s, &cx.key("normal_scale"))?;
        }
        Ok(maps)
    }

    /// The scene materials of a `[[mesh]]` without a `material`: one per MTL (or glTF) material its
    /// faces use, in the order they first use them, with its texture and maps (added to `table`, with
    /// what could not be used as warnings). Returns, per group: the file's material id, the scene
    /// material's index, its texture and maps.
    fn mtl_materials(
        &self,
        cx: &MeshContext<'_>,
        table: &mut MeshTable,
        files: &mut FileCache,
    ) -> Vec<MtlGroup> {
        let i = cx.i;
        // One mesh per MTL material, in the order the faces first use them (faces with none, or when no
        // MTL file could be read, get MTL's default: diffuse, Kd 0.8); the file's own space first, then
        // its shared meshes, whose parts use the same scene materials.
        let mut groups: Vec<Option<u32>> = Vec::new();
        for m in std::iter::once(&*cx.obj).chain(cx.obj.shared.iter().map(|g| &g.mesh)) {
            for t in 0..m.triangles.len() {
                let id = m.face_materials.get(t).copied().flatten();
                if !groups.contains(&id) {
                    groups.push(id);
                }
            }
        }
        // Per material of the file: its scene material, texture and maps.
        let mut made = Vec::new();
        let obj_dir = cx.obj_path.parent().unwrap_or(Path::new("."));
        for id in groups {
            let index = (cx.names.len() + table.materials.len()) as u32;
            let (name, material, texture, maps) = match id.map(|k| &cx.obj.materials[k as usize]) {
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
                            cx.obj_path.display(),
                            mtl.name
                        ));
                    }
                    let texture = match &mtl.diffuse_texture {
                        _ if mtl.texture.is_some() && cx.obj.uvs.is_some() => mtl.texture.clone(),
                        None if mtl.texture.is_some() => {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: material \"{}\" has a texture but the file has no texture coordinates for every vertex; the texture is not used",
                                cx.obj_path.display(),
                                mtl.name
                            ));
                            None
                        }
                        None => None,
                        Some(_) if cx.obj.uvs.is_none() => {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: MTL material \"{}\" has a map_Kd but the OBJ has no texture coordinates; the texture is not used",
                                cx.obj_path.display(),
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
                    if cx.obj.uvs.is_none() {
                        if maps.emissive.is_some()
                            || maps.metallic_roughness.is_some()
                            || maps.normal.is_some()
                        {
                            table.warnings.push(format!(
                                "mesh[{i}]: {}: material \"{}\" has an emissive, metallic-roughness or normal texture but the file has no texture coordinates for every vertex; it is not used",
                                cx.obj_path.display(),
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
            made.push((id, index, texture, maps));
            table.materials.push((name, material));
        }
        made
    }

    /// Places every part of `table.source` by `placement` into `table.meshes`; each of the file's
    /// shared meshes once, in its own space, into `table.instanced` with one placement per node
    /// (copies into `table.meshes` when it emits).
    fn place_table(
        &self,
        mut table: MeshTable,
        placement: &Placement,
        materials: &[Material],
        span: std::ops::Range<usize>,
        label: &str,
    ) -> Result<MeshTable, SceneError> {
        let source = &table.source;
        let emits = |g: &SharedParts| MeshSource::emits(&g.parts, materials);
        let meshes = self.place_parts(
            source,
            None,
            placement,
            materials,
            span.clone(),
            label,
            &emits,
        )?;
        let affine = placement.affine();
        let mut instanced = Vec::new();
        for (g, group) in source.shared.iter().enumerate() {
            if emits(group) {
                continue;
            }
            let placements: Vec<DAffine3> = group.nodes.iter().map(|n| affine * *n).collect();
            if let Some(p) = first_overflow(&group.parts, &group.bounds, placements.iter().copied())
            {
                return Err(self.overflow(span, label, source, p));
            }
            let parts = self.place_each(
                source,
                &group.parts,
                None,
                &Placement::default(),
                materials,
                span.clone(),
                label,
                false,
            )?;
            let placements = placements
                .into_iter()
                .map(mesh::MeshPlacement::at)
                .collect();
            instanced.push((g, mesh::InstancedMesh { parts, placements }));
        }
        table.meshes = meshes;
        table.instanced = instanced;
        Ok(table)
    }

    /// One part of a mesh placed by `placement`, in its own material or in `material` instead; with
    /// `keep_uvs`, its texture coordinates kept even where neither the part nor its material reads them
    /// (a shared copy that placements draw in textured materials of their own).
    #[allow(clippy::too_many_arguments)]
    fn place_part(
        &self,
        source: &MeshSource,
        part: &MeshPart,
        material: Option<u32>,
        placement: &Placement,
        materials: &[Material],
        span: std::ops::Range<usize>,
        label: &str,
        keep_uvs: bool,
    ) -> Result<Mesh, SceneError> {
        let material = material.unwrap_or(part.material);
        // (Texture coordinates are kept for the material's own textures too.)
        let textured = keep_uvs
            || part.texture.is_some()
            || !materials
                .get(material as usize)
                .is_none_or(|m| m.textures.is_plain())
            || part.maps.emissive.is_some()
            || part.maps.metallic_roughness.is_some()
            || part.maps.normal.is_some();
        // (Tangents exist only where the file gave or generated them for its normal map.)
        let placed = mesh::place(&part.obj, placement, source.smooth, textured, textured);
        if let Some(p) = placed.positions.iter().find(|p| !p.is_finite()) {
            return Err(self.overflow(span, label, source, p));
        }
        Ok(Mesh {
            obj: source.obj_path.clone(),
            positions: placed.positions,
            normals: placed.normals,
            uvs: placed.uvs,
            tangents: placed.tangents,
            triangles: placed.triangles,
            material,
            texture: part.texture.clone(),
            maps: part.maps.clone(),
        })
    }

    /// A `[[mesh]]`'s or `[[instance]]`'s transform: `matrix` (row-major, affine, invertible), or
    /// `scale` (uniform, > 0), `rotate` (degrees about x, then y, then z) and `translate`; not both.
    pub(super) fn placement(
        &self,
        table: &str,
        matrix: Option<&Spanned<RawMatrix>>,
        scale: Option<&Spanned<f32>>,
        rotate: Option<&Spanned<RawVec3>>,
        translate: Option<&Spanned<RawVec3>>,
    ) -> Result<Placement, SceneError> {
        let key = |field: &str| format!("{table}.{field}");
        if let Some(m) = matrix {
            if scale.is_some() || rotate.is_some() || translate.is_some() {
                return Err(self.error(
                    m.span(),
                    &key("matrix"),
                    "matrix is given together with scale, rotate or translate",
                    "Give either a matrix (the whole transform) or scale / rotate / translate, not both.",
                ));
            }
            let RawMatrix(rows) = *m.get_ref();
            let bad = |problem: &str| {
                Err(self.error(
                    m.span(),
                    &key("matrix"),
                    problem.to_string(),
                    "matrix is 16 numbers, a 4 x 4 affine transform row by row: the last row is [0, 0, 0, 1], \
                     the translation is the last column, and the 3 x 3 part must be invertible (mirrors and \
                     non-uniform scales are fine).",
                ))
            };
            if rows.iter().any(|v| !v.is_finite()) {
                return bad("the matrix has a number that is not finite");
            }
            if rows[12..] != [0.0, 0.0, 0.0, 1.0] {
                return bad("the matrix's last row is not [0, 0, 0, 1] (a projective matrix)");
            }
            // glam's matrices are column-major: the file's rows are the transpose's columns.
            let affine = DAffine3::from_mat4(DMat4::from_cols_array(&rows).transpose());
            if mesh::singular(&affine.matrix3) {
                return bad("the matrix is singular (it flattens the mesh)");
            }
            return Ok(Placement::Matrix(affine));
        }
        let scale = scale.map_or(Ok(1.0), |s| {
            self.number_unless(
                s,
                &key("scale"),
                |s| s <= 0.0,
                "the scale must be > 0",
                "scale is a uniform factor applied to the OBJ's coordinates; 1 keeps them.",
            )
        })?;
        let rotate_deg = rotate.map_or(Ok(Vec3::ZERO), |r| self.vec3(r, &key("rotate")))?;
        let translate = translate.map_or(Ok(Vec3::ZERO), |t| self.vec3(t, &key("translate")))?;
        Ok(Placement::Srt {
            scale,
            rotate_deg,
            translate,
        })
    }

    /// An `[[instance]]`: the named mesh's parts placed again by the instance's transform, in the
    /// instance's material when it gives one. Shared (one copy of the mesh, drawn through the two-level
    /// BVH: [`mesh::InstancedMesh`]), in the instance's material where it gives one that one index can
    /// stand for ([`shares_material`]); otherwise (the mesh or the material emits light, or the mesh's
    /// parts have textures or maps) copies of the parts, placed as a `[[mesh]]` is: an emitting
    /// triangle must be in the light list in world space, and a part's textures and maps combine with
    /// its material into a material of its own (`kernel::upload`, `mesh_material`), so such a copy is a
    /// material per part.
    pub(super) fn instance(
        &self,
        i: usize,
        raw: &Spanned<RawInstance>,
        sources: &[(String, MeshSource)],
        names: &[String],
        materials: &[Material],
    ) -> Result<Placed, SceneError> {
        let r = raw.get_ref();
        let label = format!("instance[{i}]");
        let wanted = r.mesh.get_ref();
        let Some(source_index) = sources.iter().position(|(name, _)| name == wanted) else {
            let known: Vec<&str> = sources.iter().map(|(n, _)| n.as_str()).collect();
            return Err(self.error(
                r.mesh.span(),
                &format!("{label}.mesh"),
                format!("no [[mesh]] is named \"{wanted}\""),
                if known.is_empty() {
                    "Give the [[mesh]] to instance a `name = \"...\"`.".to_string()
                } else {
                    format!("The named meshes are: {}.", known.join(", "))
                },
            ));
        };
        let source = &sources[source_index].1;
        let material = match &r.material {
            Some(name) => Some(self.material_index(name, &format!("{label}.material"), names)?),
            None => None,
        };
        let placement = self.placement(
            &label,
            r.matrix.as_ref(),
            r.scale.as_ref(),
            r.rotate.as_ref(),
            r.translate.as_ref(),
        )?;
        let emits = MeshSource::emits(&source.parts, materials)
            || source
                .shared
                .iter()
                .any(|g| MeshSource::emits(&g.parts, materials));
        if !emits && material.is_none_or(|m| shares_material(source, &materials[m as usize])) {
            // The placement must map the mesh's own space to floats, as placing a copy would.
            let affine = placement.affine();
            if let Some(p) = source.overflows(&affine) {
                return Err(self.overflow(raw.span(), &label, source, p));
            }
            return Ok(Placed::Shared {
                source: source_index,
                placement: mesh::MeshPlacement {
                    to_world: affine,
                    material,
                },
            });
        }
        let copies = self.place_parts(
            source,
            material,
            &placement,
            materials,
            raw.span(),
            &label,
            &|_| true,
        )?;
        Ok(Placed::Copies(copies))
    }

    /// Every part of `source` placed by `placement`, and copies of the shared meshes that `copy`
    /// picks through each of their nodes, in `material` when one is given.
    #[allow(clippy::too_many_arguments)]
    fn place_parts(
        &self,
        source: &MeshSource,
        material: Option<u32>,
        placement: &Placement,
        materials: &[Material],
        span: std::ops::Range<usize>,
        label: &str,
        copy: &dyn Fn(&SharedParts) -> bool,
    ) -> Result<Vec<Mesh>, SceneError> {
        let mut out = self.place_each(
            source,
            &source.parts,
            material,
            placement,
            materials,
            span.clone(),
            label,
            false,
        )?;
        let affine = placement.affine();
        for group in source.shared.iter().filter(|g| copy(g)) {
            for n in &group.nodes {
                out.extend(self.place_each(
                    source,
                    &group.parts,
                    material,
                    &Placement::Matrix(affine * *n),
                    materials,
                    span.clone(),
                    label,
                    false,
                )?);
            }
        }
        Ok(out)
    }

    /// `parts` (of `source`) placed by `placement`, in `material` when one is given, each keeping its
    /// texture coordinates with `keep_uvs` ([`Self::place_part`]).
    #[allow(clippy::too_many_arguments)]
    fn place_each(
        &self,
        source: &MeshSource,
        parts: &[MeshPart],
        material: Option<u32>,
        placement: &Placement,
        materials: &[Material],
        span: std::ops::Range<usize>,
        label: &str,
        keep_uvs: bool,
    ) -> Result<Vec<Mesh>, SceneError> {
        parts
            .iter()
            .map(|part| {
                self.place_part(
                    source,
                    part,
                    material,
                    placement,
                    materials,
                    span.clone(),
                    label,
                    keep_uvs,
                )
            })
            .collect()
    }

    /// A placement that takes a vertex of `source` (landing at `p`) out of the f32 range.
    fn overflow(
        &self,
        span: std::ops::Range<usize>,
        label: &str,
        source: &MeshSource,
        p: impl std::fmt::Display,
    ) -> SceneError {
        self.error(
            span,
            label,
            format!(
                "placing {} overflows 32-bit floats (a vertex lands at {p})",
                source.obj_path.display()
            ),
            "Use a smaller scale or translation.",
        )
    }

    /// The parts of a named mesh in its file's own space, for the placements that share it
    /// ([`Placed::Shared`]); `keep_uvs` when some of them draw it in a textured material of their own.
    pub(super) fn instanced_parts(
        &self,
        source: &MeshSource,
        materials: &[Material],
        span: std::ops::Range<usize>,
        label: &str,
        keep_uvs: bool,
    ) -> Result<Vec<Mesh>, SceneError> {
        self.place_each(
            source,
            &source.parts,
            None,
            &Placement::default(),
            materials,
            span,
            label,
            keep_uvs,
        )
    }
}

/// What an `[[instance]]` becomes.
pub(super) enum Placed {
    /// Copies of the named mesh's parts, placed in world space.
    Copies(Vec<Mesh>),
    /// One more placement of the mesh `sources[source]`, shared with the others.
    Shared {
        source: usize,
        placement: mesh::MeshPlacement,
    },
}

/// Whether an `[[instance]]` of `source` in `material` can share the mesh's one copy, each face drawn in
/// `material` through the placement ([`mesh::MeshPlacement::material`]): when one material index stands
/// for every face. That holds when no part of the mesh (nor of the file's shared meshes) has a texture
/// or maps of its own, which would combine with the material into one material per part, and when the
/// material does not emit (an emitting triangle is a light, sampled in world space). A material with
/// textures or modifiers reads the texture coordinates, which the named mesh's shared copy then keeps
/// (`instanced_parts`); a glTF file's shared meshes are read before any instance of the file, with only
/// what their own materials read, so such a material shares a file without them only.
fn shares_material(source: &MeshSource, material: &Material) -> bool {
    material.emission.is_none()
        && (material.textures.is_plain() || source.shared.is_empty())
        && source
            .parts
            .iter()
            .chain(source.shared.iter().flat_map(|g| g.parts.iter()))
            .all(|p| p.texture.is_none() && p.maps.change_nothing())
}

#[cfg(test)]
mod tests {
    use crate::scene::parse::tests::{MINIMAL, parse};

    #[test]
    fn zero_area_triangles_are_allowed() {
        let text = format!(
            "{MINIMAL}\n[materials]\nw = {{ type = \"diffuse\", albedo = [1, 1, 1] }}\n[[triangle]]\n\
             vertices = [[1, 1, 1], [1, 1, 1], [2, 2, 2]]\nmaterial = \"w\"\n"
        );
        assert_eq!(parse(&text).triangles.len(), 1);
    }
}
