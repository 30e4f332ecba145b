//! Triangle meshes: a mesh file as read, in its own coordinates ([`ObjMesh`], whatever the format:
//! `obj`, `ply` and `gltf` read one, `mesh_file` picks the reader), the materials it brings and what is
//! wrong with it, and the [`Mesh`] it becomes once placed in the scene by an affine transform ([`Placement`]), with
//! per-vertex shading normals and optional textures.
//!
//! Everything here is host data in `f32`/glam types; `kernel::upload` flattens it into the triangle, BVH and
//! shading buffers. Errors are [`ObjError`]s that carry the file's own line number: the scene parser wraps
//! them into a `SceneError` that also names the scene file, its line and the `[[mesh]]` key.

use super::image_texture::Texture;
use super::texture::{TextureFilter, TextureRef, Wrap};
use glam::{DAffine3, DMat3, DVec3, Vec3};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// The most triangles one scene may hold: the BVH's leaf references keep a triangle index in 29 bits
/// (see `bvh.rs`), and a triangle buffer this large is already 25 GB.
pub const MAX_TRIANGLES: usize = 1 << 29;

/// A mesh in world space, ready for the BVH. Vertices are "corners": a position with the normal and uv it
/// has in the faces that use it (the OBJ may give one position several normals or uvs, e.g. along a uv
/// seam; `tobj` splits such positions into several vertices).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// The OBJ file, as resolved against the scene file's directory (for messages).
    pub obj: PathBuf,
    pub positions: Vec<Vec3>,
    /// Unit shading normals per vertex, in world space, when the mesh is smooth; empty when it is flat.
    /// A vertex whose normal is undefined (all its faces have zero area) holds zero, and the shader then
    /// falls back to the geometric normal.
    pub normals: Vec<Vec3>,
    /// Texture coordinates per vertex when the mesh has a texture; empty otherwise.
    pub uvs: Vec<[f32; 2]>,
    /// Tangents per vertex (world space; see [`ObjMesh::tangents`]) when the mesh has a normal map and
    /// its file gives or generates them; empty otherwise (the shader then orients the normal map by each
    /// triangle's dp/du).
    pub tangents: Vec<[f32; 4]>,
    /// Vertex indices, counter-clockwise seen from the front (the OBJ's winding).
    pub triangles: Vec<[u32; 3]>,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// The base colour texture: it replaces the material's albedo (or tint), or multiplies it when
    /// `maps.base_color_factor`.
    pub texture: Option<Arc<Texture>>,
    /// The textures glTF materials bring besides it.
    pub maps: MeshMaps,
}

/// A mesh drawn several times: its parts (one per material) in the mesh's own space, and the affine
/// transforms that place each copy in the world. The renderer uploads the parts once, with one BVH over
/// them, and a top-level BVH over the copies' boxes (a two-level BVH: `kernel::upload`, bvh.wgsl).
///
/// A copy is the parts mapped by its transform as [`place`] would map them: positions and tangents by
/// the transform, normals by its inverse transpose, and, where it mirrors, the faces' fronts kept (the
/// shader flips the winding's normal; `INSTANCE_MIRRORS`). Smooth normals a file does not give are
/// computed once, in the mesh's own space, and mapped: under a non-uniform scale they can differ
/// slightly from the normals of the placed mesh (which [`place`] computes after placing).
#[derive(Clone, Debug, PartialEq)]
pub struct InstancedMesh {
    pub parts: Vec<Mesh>,
    /// One per copy.
    pub placements: Vec<MeshPlacement>,
}

/// Where one copy of an [`InstancedMesh`] lies, and in what material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshPlacement {
    /// Object to world.
    pub to_world: DAffine3,
    /// The material every face of this copy takes instead of its part's (an `[[instance]]`'s own
    /// `material`), an index into `Scene::materials`; `None` keeps the parts' own. Only a material that
    /// one index can stand for is given here: the parts have no textures or maps of their own, and
    /// neither they nor it emit (`parse::geometry`, `shares_material`); the copy keeps its texture
    /// coordinates where such a material reads them.
    pub material: Option<u32>,
}

impl MeshPlacement {
    /// A copy in the parts' own materials.
    pub fn at(to_world: DAffine3) -> Self {
        Self {
            to_world,
            material: None,
        }
    }
}

/// A mesh's textures besides its base colour texture, and how that one combines with the material
/// (docs/scene-format.md, "glTF meshes"). The default is a TOML or OBJ mesh's: the texture replaces the
/// albedo and, on an emitting material, multiplies the emission.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshMaps {
    /// The base colour texture multiplies the material's albedo (glTF: base colour = baseColorFactor x
    /// texel) instead of replacing it, and leaves the emission alone (only `emissive` changes that).
    pub base_color_factor: bool,
    /// sRGB colour multiplying the emission (glTF: emissive = emissiveFactor x texel).
    pub emissive: Option<Arc<Texture>>,
    /// Linear data (glTF's metallicRoughnessTexture): B multiplies metallic, G roughness.
    pub metallic_roughness: Option<Arc<Texture>>,
    /// A tangent-space normal map (glTF's normalTexture, linear data), and the factor of its x and y
    /// (normalTexture.scale; read only with a map, so the default's 0 never applies).
    pub normal: Option<Arc<Texture>>,
    pub normal_scale: f32,
    /// glTF's alphaMode MASK or BLEND (OPAQUE: `None`): the surface's opacity is the base colour factor's
    /// alpha (the first number) times the base colour texture's alpha, where the mesh has that texture;
    /// with MASK's alphaCutoff (the second) a cut-out, with BLEND (`None`) stochastic transparency
    /// (glTF 2.0 §3.9.4, "Alpha Coverage").
    pub alpha: Option<(f32, Option<f32>)>,
    /// How each of the textures above is read (glTF: its sampler and KHR_texture_transform): the base
    /// colour texture's (the mesh's `texture`; also the alpha's), the emissive, the metallic-roughness and
    /// the normal texture's.
    pub base_color_read: TextureRead,
    pub emissive_read: TextureRead,
    pub metallic_roughness_read: TextureRead,
    pub normal_read: TextureRead,
}

impl MeshMaps {
    /// Whether these maps change nothing of the material they go with (no emissive, metallic-roughness
    /// or normal texture, no alpha coverage): with no base colour texture either, a mesh part is drawn
    /// in its material as it is (`kernel::upload`, `mesh_material`).
    pub fn change_nothing(&self) -> bool {
        self.emissive.is_none()
            && self.metallic_roughness.is_none()
            && self.normal.is_none()
            && self.alpha.is_none()
    }
}

/// How a mesh's texture is read besides its image: the filter, the wrap mode and the uv transform of a
/// texture reference (glTF: its sampler and KHR_texture_transform, already in vkpath's uv convention).
/// The default reads it plainly: bilinear, repeated, untransformed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRead {
    pub nearest: bool,
    pub wrap: Wrap,
    pub scale: [f32; 2],
    pub rotation_deg: f32,
    pub offset: [f32; 2],
}

impl Default for TextureRead {
    fn default() -> TextureRead {
        TextureRead {
            nearest: false,
            wrap: Wrap::Repeat,
            scale: [1.0, 1.0],
            rotation_deg: 0.0,
            offset: [0.0, 0.0],
        }
    }
}

impl TextureRead {
    /// `r` read this way.
    pub fn apply(&self, mut r: TextureRef) -> TextureRef {
        r.filter = if self.nearest {
            TextureFilter::Nearest
        } else {
            TextureFilter::Bilinear
        };
        r.wrap = self.wrap;
        (r.scale, r.rotation_deg, r.offset) = (self.scale, self.rotation_deg, self.offset);
        r
    }
}

/// A mesh as the OBJ file gives it, in the file's own coordinates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjMesh {
    pub positions: Vec<Vec3>,
    /// Per vertex, when every vertex of every face has a `vn`.
    pub normals: Option<Vec<Vec3>>,
    /// Per vertex, when every vertex of every face has a `vt`.
    pub uvs: Option<Vec<[f32; 2]>>,
    pub triangles: Vec<[u32; 3]>,
    /// The materials of the OBJ's MTL files (`mtllib`), in the order read; empty when it names none or
    /// none could be read.
    pub materials: Vec<FileMaterial>,
    /// Per triangle, its `usemtl` material (an index into `materials`), or `None`: empty when
    /// `materials` is.
    pub face_materials: Vec<Option<u32>>,
    /// An MTL file the OBJ names that could not be read, and why (a warning: the mesh is still usable).
    pub mtl_problem: Option<String>,
    /// What else the reader could not use (glTF: unsupported textures, primitives): warnings.
    pub notes: Vec<String>,
    /// Per vertex, tangents for a normal map (glTF's TANGENT, or MikkTSpace's): xyz the direction of
    /// increasing u, w = +-1 the sign of the bitangent B = w cross(N, T) (towards increasing v); zero
    /// where a vertex has none.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// The file asks for face normals (a `.serialized` mesh's flag 0x0010): shaded flat whatever the
    /// `[[mesh]]`'s `smooth` says, as Mitsuba does.
    pub face_normals: bool,
    /// Meshes the file places more than once (glTF nodes sharing a mesh), each kept once in its own
    /// space with the transforms that place it into the file's; the fields above hold everything else.
    /// Their `face_materials` index `materials` above; they have no materials, notes or shared meshes
    /// of their own.
    pub shared: Vec<SharedMesh>,
}

/// A mesh the file places several times: in its own space, and one affine map (its own space to the
/// file's) per placement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SharedMesh {
    pub mesh: ObjMesh,
    pub nodes: Vec<DAffine3>,
}

/// Whether a linear map flattens space (its determinant is zero relative to the size of its entries),
/// so that it has no inverse for normals or for mapping rays back.
pub fn singular(m: &DMat3) -> bool {
    let det = m.determinant();
    let size = m.to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    det.abs() <= 1e-12 * size.powi(3) || !det.is_finite()
}

impl ObjMesh {
    /// Whether every position, normal and texture coordinate is finite (`f32::from_str` and binary
    /// files give NaN and infinities as readily as numbers).
    pub fn is_finite(&self) -> bool {
        self.positions.iter().all(|p| p.is_finite())
            && self.normals.iter().flatten().all(|n| n.is_finite())
            && self
                .uvs
                .iter()
                .flatten()
                .all(|t| t[0].is_finite() && t[1].is_finite())
            && self
                .tangents
                .iter()
                .flatten()
                .all(|t| t.iter().all(|c| c.is_finite()))
    }

    /// The triangles whose `usemtl` material is `material`, with only the vertices they use (renumbered
    /// in order of first use), and no materials.
    pub fn subset(&self, material: Option<u32>) -> ObjMesh {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let mut out = ObjMesh::default();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut tangents = Vec::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            if self.face_materials.get(t).copied().flatten() != material {
                continue;
            }
            out.triangles.push(tri.map(|v| {
                let v = v as usize;
                if remap[v] == u32::MAX {
                    remap[v] = out.positions.len() as u32;
                    out.positions.push(self.positions[v]);
                    if let Some(n) = &self.normals {
                        normals.push(n[v]);
                    }
                    if let Some(uv) = &self.uvs {
                        uvs.push(uv[v]);
                    }
                    if let Some(t) = &self.tangents {
                        tangents.push(t[v]);
                    }
                }
                remap[v]
            }));
        }
        out.normals = self.normals.as_ref().map(|_| normals);
        out.uvs = self.uvs.as_ref().map(|_| uvs);
        out.tangents = self.tangents.as_ref().map(|_| tangents);
        out
    }
}

/// One material a mesh file brings (an MTL file's, or a glTF material), with what vkpath maps
/// (docs/scene-format.md, "OBJ materials" and "glTF meshes").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FileMaterial {
    pub name: String,
    /// Kd, Ks, Ke (linear RGB).
    pub diffuse: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub emission: Option<[f32; 3]>,
    /// Ni.
    pub ior: Option<f32>,
    /// illum.
    pub illum: Option<u8>,
    /// map_Kd, as written (relative to the MTL file's directory).
    pub diffuse_texture: Option<String>,
    /// Pr and Pm, the PBR extension's roughness and metallic.
    pub roughness: Option<f32>,
    pub metallic: Option<f32>,
    /// A texture already decoded (a glTF image); it takes the place of `diffuse_texture`.
    pub texture: Option<Arc<Texture>>,
    /// glTF's other textures, and that its base colour factor multiplies `texture` (set for every glTF
    /// material; MTL ones keep the default).
    pub maps: MeshMaps,
    /// A glTF material's Khronos PBR extension layers (none for MTL materials).
    pub layers: crate::scene::GltfLayers,
}

/// What is wrong with an OBJ file, and on which of its lines (1-based) when that is known.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjError {
    pub line: Option<usize>,
    /// What is wrong, without the file name or a final full stop.
    pub message: String,
}

impl ObjError {
    pub(crate) fn at(line: usize, message: impl Into<String>) -> ObjError {
        ObjError {
            line: Some(line),
            message: message.into(),
        }
    }

    pub(crate) fn whole_file(message: impl Into<String>) -> ObjError {
        ObjError {
            line: None,
            message: message.into(),
        }
    }
}

/// Where a mesh goes. `Srt`: scaled uniformly about the OBJ's origin, rotated about x, then y, then z
/// (degrees, right-handed), then translated: a point p becomes `Rz Ry Rx (scale p) + translate`.
/// `Matrix`: any invertible affine map (`matrix` in a `[[mesh]]` or `[[instance]]`, Mitsuba's `to_world`),
/// non-uniform scales, shears and mirrors included.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    Srt {
        scale: f32,
        rotate_deg: Vec3,
        translate: Vec3,
    },
    Matrix(DAffine3),
}

impl Default for Placement {
    fn default() -> Self {
        Placement::Srt {
            scale: 1.0,
            rotate_deg: Vec3::ZERO,
            translate: Vec3::ZERO,
        }
    }
}

impl Placement {
    /// Where a point of the file goes, in f64 so that composing the transform rounds once.
    fn point(&self, p: DVec3) -> DVec3 {
        match self {
            Placement::Srt {
                scale,
                rotate_deg,
                translate,
            } => srt_rotation(*rotate_deg) * (p * f64::from(*scale)) + translate.as_dvec3(),
            Placement::Matrix(m) => m.transform_point3(p),
        }
    }

    /// The linear part, which maps directions in the surface (edges, tangents): the rotation and the
    /// scale, or the matrix's upper 3 x 3.
    fn linear(&self) -> DMat3 {
        match self {
            Placement::Srt {
                scale, rotate_deg, ..
            } => srt_rotation(*rotate_deg) * f64::from(*scale),
            Placement::Matrix(m) => m.matrix3,
        }
    }

    /// The map of normals: the rotation (a uniform scale changes no direction), or the inverse
    /// transpose of the matrix's linear part, which keeps a normal perpendicular to the transformed
    /// surface under non-uniform scales and shears (pbrt-v4 §3.10.3).
    fn normal_map(&self) -> DMat3 {
        match self {
            Placement::Srt { rotate_deg, .. } => srt_rotation(*rotate_deg),
            Placement::Matrix(m) => m.matrix3.inverse().transpose(),
        }
    }

    /// The transform as an affine map (object to world).
    pub fn affine(&self) -> DAffine3 {
        match self {
            Placement::Srt { translate, .. } => {
                DAffine3::from_mat3_translation(self.linear(), translate.as_dvec3())
            }
            Placement::Matrix(m) => *m,
        }
    }

    /// Whether the transform mirrors (its determinant is negative): the triangles' winding is then
    /// reversed, so that the side a face's counter-clockwise winding called its front stays its front
    /// (pbrt-v4's `transformSwapsHandedness`); vertex normals, mapped by the inverse transpose, agree.
    pub fn mirrors(&self) -> bool {
        matches!(self, Placement::Matrix(m) if m.matrix3.determinant() < 0.0)
    }
}

/// The rotation of an `Srt` placement, in f64.
fn srt_rotation(rotate_deg: Vec3) -> DMat3 {
    let r = rotate_deg.as_dvec3() * (std::f64::consts::PI / 180.0);
    DMat3::from_rotation_z(r.z) * DMat3::from_rotation_y(r.y) * DMat3::from_rotation_x(r.x)
}

/// The mesh file placed in the world: positions, shading normals, uvs and triangles. With `smooth`,
/// shading normals are the file's (mapped by [`Placement::normal_map`]) when it gives one for every
/// vertex, else computed (see [`vertex_normals`]). `keep_uvs` keeps the texture coordinates (the caller
/// has checked they exist). A mirroring placement reverses each triangle's winding.
pub fn place(
    obj: &ObjMesh,
    placement: &Placement,
    smooth: bool,
    keep_uvs: bool,
    keep_tangents: bool,
) -> PlacedMesh {
    let positions: Vec<Vec3> = obj
        .positions
        .iter()
        .map(|p| placement.point(p.as_dvec3()).as_vec3())
        .collect();
    let triangles: Vec<[u32; 3]> = if placement.mirrors() {
        obj.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect()
    } else {
        obj.triangles.clone()
    };
    let normals = if !smooth {
        Vec::new()
    } else {
        match &obj.normals {
            Some(given) => {
                let m = placement.normal_map();
                given
                    .iter()
                    .map(|n| unit_or_zero(m * n.as_dvec3()))
                    .collect()
            }
            None => vertex_normals(&positions, &triangles),
        }
    };
    let uvs = match (&obj.uvs, keep_uvs) {
        (Some(uvs), true) => uvs.clone(),
        _ => Vec::new(),
    };
    // Tangents lie in the surface: mapped by the linear part, as edges are; a mirroring placement
    // reverses cross(N, T), so the bitangent's sign flips with it.
    let tangents = match (&obj.tangents, keep_tangents) {
        (Some(t), true) => {
            let m = placement.linear();
            let flip = if placement.mirrors() { -1.0 } else { 1.0 };
            t.iter()
                .map(|&[x, y, z, w]| {
                    let d = unit_or_zero(m * DVec3::new(x.into(), y.into(), z.into()));
                    [d.x, d.y, d.z, w * flip]
                })
                .collect()
        }
        _ => Vec::new(),
    };
    PlacedMesh {
        positions,
        normals,
        uvs,
        tangents,
        triangles,
    }
}

/// What [`place`] makes of a mesh file.
pub struct PlacedMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<[f32; 2]>,
    pub tangents: Vec<[f32; 4]>,
    pub triangles: Vec<[u32; 3]>,
}

fn unit_or_zero(v: DVec3) -> Vec3 {
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        (v / len).as_vec3()
    } else {
        Vec3::ZERO
    }
}

/// Smooth vertex normals for a mesh without its own, as Mitsuba 3 computes them
/// (`Mesh::recompute_vertex_normals`; Thürmer and Wüthrich, "Computing vertex normals from polygonal
/// facets", 1998): at each vertex, the sum of the unit normals of the faces around it, each weighted by
/// the face's interior angle at that vertex, then normalised. Weighting by angle makes the normal a
/// property of the surface, not of how it was cut into triangles (an area weighting leans towards the
/// larger faces: up to 38 degrees off on a PLY teapot). Degenerate faces add nothing. Vertices at the
/// same position are welded first (OBJ exporters split a position where the uv or normal changes, and
/// those splits must not crease the surface). Sums run in f64.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut weld: HashMap<[u32; 3], usize> = HashMap::with_capacity(positions.len());
    let welded: Vec<usize> = positions
        .iter()
        .map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let next = weld.len();
            *weld.entry(key).or_insert(next)
        })
        .collect();
    let mut sums = vec![DVec3::ZERO; weld.len()];
    for t in triangles {
        let v = t.map(|i| positions[i as usize].as_dvec3());
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let len = n.length();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        for k in 0..3 {
            // The interior angle at corner k, between the edges to the other two corners:
            // atan2(|e1 x e2|, e1 . e2), accurate for small and obtuse angles alike.
            let (e1, e2) = (v[(k + 1) % 3] - v[k], v[(k + 2) % 3] - v[k]);
            let angle = e1.cross(e2).length().atan2(e1.dot(e2));
            sums[welded[t[k] as usize]] += n * (angle / len);
        }
    }
    welded.iter().map(|&w| unit_or_zero(sums[w])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn computed_normals_weld_split_vertices() {
        // Two triangles of a tent sharing an edge, whose shared positions are duplicated.
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(-1.0, 1.0, 0.5),
        ];
        let tris = [[0, 1, 2], [3, 5, 4]];
        let n = vertex_normals(&positions, &tris);
        assert_eq!(n[0], n[3]);
        assert_eq!(n[1], n[4]);
        assert!((n[0] - Vec3::Y).length() < 1e-6, "{:?}", n[0]);
    }

    /// The angle weighting against a hand computation: a vertex shared by a fan of two faces, one a
    /// long thin sliver, the other a right angle. The corner angles at the apex are 90 and 45 degrees
    /// with unit normals +z and +x: the normal is (45 x + 90 z) / |...| = (1, 0, 2) / sqrt 5, whatever
    /// the faces' areas (an area weighting would give another direction).
    #[test]
    fn computed_normals_weight_faces_by_their_angle_at_the_vertex() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0), // the shared vertex
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0), // face 0: right angle at the origin, normal +z
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0), // face 1: 45 degrees at the origin, normal +x
        ];
        let tris = [[0, 1, 2], [0, 3, 4]];
        let n = vertex_normals(&positions, &tris)[0];
        let want = Vec3::new(1.0, 0.0, 2.0) / 5f32.sqrt();
        assert!((n - want).length() < 1e-6, "{n:?} vs {want:?}");
        // Area-weighted, face 0 (area 50) would swamp face 1 (area 0.5).
        let area = (Vec3::Z * 100.0 + Vec3::X * 1.0).normalize();
        assert!((n - area).length() > 0.3);
    }

    #[test]
    fn placement_scales_then_rotates_x_y_z_then_translates() {
        let obj = ObjMesh {
            positions: vec![Vec3::X],
            normals: Some(vec![Vec3::X]),
            uvs: None,
            triangles: vec![[0, 0, 0]],
            ..ObjMesh::default()
        };
        let p = Placement::Srt {
            scale: 2.0,
            rotate_deg: Vec3::new(90.0, 0.0, 90.0),
            translate: Vec3::new(0.0, 0.0, 5.0),
        };
        let placed = place(&obj, &p, true, false, false);
        let (pos, nrm) = (placed.positions, placed.normals);
        // Rx(90) leaves x alone, Rz(90) turns x into y: 2 x -> 2 y, then + 5 z.
        assert!(
            (pos[0] - Vec3::new(0.0, 2.0, 5.0)).length() < 1e-6,
            "{:?}",
            pos[0]
        );
        assert!((nrm[0] - Vec3::Y).length() < 1e-6);
        let p = Placement::Srt {
            scale: 1.0,
            rotate_deg: Vec3::new(90.0, 90.0, 0.0),
            translate: Vec3::ZERO,
        };
        let obj_y = ObjMesh {
            positions: vec![Vec3::Y],
            ..obj
        };
        // Rx(90): y -> z; then Ry(90): z -> x.
        let pos = place(&obj_y, &p, false, false, false).positions;
        assert!((pos[0] - Vec3::X).length() < 1e-6, "{:?}", pos[0]);
    }

    /// A matrix placement: a non-uniform scale maps normals by the inverse transpose (a 45-degree
    /// face of a mesh stretched 2x along x gets the normal of the stretched face), and a mirror keeps
    /// each face's front outward by reversing its winding.
    #[test]
    fn matrix_placement_maps_normals_by_the_inverse_transpose_and_mirrors_keep_fronts() {
        // The triangle x + y = 1 in the z = 0.. plane, normal (1, 1, 0)/sqrt 2, wound counter-clockwise
        // seen from that side.
        let obj = ObjMesh {
            positions: vec![Vec3::X, Vec3::Y, Vec3::new(1.0, 0.0, 1.0)],
            normals: Some(vec![Vec3::new(1.0, 1.0, 0.0).normalize(); 3]),
            uvs: None,
            triangles: vec![[0, 1, 2]],
            ..ObjMesh::default()
        };
        let face_normal = |m: &PlacedMesh| {
            let [a, b, c] = m.triangles[0].map(|i| m.positions[i as usize]);
            (b - a).cross(c - a).normalize()
        };
        assert!(
            (face_normal(&place(&obj, &Placement::default(), true, false, false))
                - obj.normals.as_ref().unwrap()[0])
                .length()
                < 1e-6
        );
        let stretch = Placement::Matrix(DAffine3::from_scale(DVec3::new(2.0, 1.0, 1.0)));
        let placed = place(&obj, &stretch, true, false, false);
        // The stretched face is x/2 + y = 1: normal (1/2, 1, 0) normalised.
        let expected = Vec3::new(0.5, 1.0, 0.0).normalize();
        assert!(
            (placed.normals[0] - expected).length() < 1e-6,
            "{:?}",
            placed.normals[0]
        );
        assert!((face_normal(&placed) - expected).length() < 1e-6);
        let mirror = Placement::Matrix(DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0)));
        assert!(mirror.mirrors() && !stretch.mirrors());
        let placed = place(&obj, &mirror, true, false, false);
        let expected = Vec3::new(-1.0, 1.0, 0.0).normalize();
        assert!((placed.normals[0] - expected).length() < 1e-6);
        assert!(
            (face_normal(&placed) - expected).length() < 1e-6,
            "the mirrored face's front turned inward"
        );
    }

    /// Tangents follow the surface (the linear part, renormalised) and a mirroring placement flips
    /// their bitangent's sign: B = w N x T must stay the mapped bitangent. Kept only when asked.
    #[test]
    fn tangents_are_mapped_with_the_surface_and_flip_sign_in_a_mirror() {
        let obj = ObjMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![Vec3::Z; 3]),
            tangents: Some(vec![[1.0, 0.0, 0.0, 1.0]; 3]),
            triangles: vec![[0, 1, 2]],
            ..ObjMesh::default()
        };
        let stretch = Placement::Matrix(DAffine3::from_cols_array(&[
            2.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        ]));
        let t = place(&obj, &stretch, true, false, true).tangents[0];
        let want = Vec3::new(2.0, 1.0, 0.0).normalize();
        assert!((Vec3::new(t[0], t[1], t[2]) - want).length() < 1e-6 && t[3] == 1.0);
        let mirror = Placement::Matrix(DAffine3::from_scale(DVec3::new(1.0, -1.0, 1.0)));
        let placed = place(&obj, &mirror, true, false, true);
        let t = placed.tangents[0];
        assert_eq!(t, [1.0, 0.0, 0.0, -1.0]);
        // The bitangent, mapped: +y -> -y; and w N' x T' with N' = +z (the mirror keeps z): -(z x x) = -y.
        let n = placed.normals[0];
        let b = n.cross(Vec3::new(t[0], t[1], t[2])) * t[3];
        assert!((b - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6, "{b}");
        assert!(place(&obj, &mirror, true, false, false).tangents.is_empty());
    }
}
