//! Triangle meshes: Wavefront OBJ files read with `tobj`, placed in the scene by a similarity transform,
//! with per-vertex shading normals and an optional sRGB albedo texture.
//!
//! Everything here is host data in `f32`/glam types; `kernel::upload` flattens it into the triangle, BVH and
//! shading buffers. Errors are [`ObjError`]s that carry the OBJ's own line number: the scene parser wraps
//! them into a `SceneError` that also names the scene file, its line and the `[[mesh]]` key.

use glam::{DMat3, DVec3, Vec3};
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The most triangles one scene may hold: the BVH's leaf references keep a triangle index in 29 bits
/// (see `bvh.rs`), and a triangle buffer this large is already 25 GB.
pub const MAX_TRIANGLES: usize = 1 << 29;
/// The most texels one texture may have (2^28: 1 GiB of RGBA8 on the device), checked from the file's
/// header before it is decoded.
pub const MAX_TEXTURE_TEXELS: u64 = 1 << 28;

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
}

/// An RGBA image, rows from the top, as the shader samples it (texture.wgsl): 8 bits per channel
/// (PNG, JPEG: sRGB-encoded colour or linear data, as a texture reference says), or f16 (EXR, HDR:
/// linear values).
#[derive(Clone, PartialEq)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left texel. 8-bit: one word per texel, `r | g << 8 | b << 16 | a << 24`
    /// (WGSL's `unpack4x8unorm` order). `half`: two words per texel, `r | g << 16` and `b | a << 16`, each
    /// an IEEE binary16 (WGSL's `unpack2x16float` order).
    pub texels: Vec<u32>,
    pub half: bool,
}

impl std::fmt::Debug for Texture {
    /// The file, size and format; not the texels (millions of them).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Texture")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("half", &self.half)
            .finish_non_exhaustive()
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
    }

    /// The triangles whose `usemtl` material is `material`, with only the vertices they use (renumbered
    /// in order of first use), and no materials.
    pub fn subset(&self, material: Option<u32>) -> ObjMesh {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let mut out = ObjMesh::default();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
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
                }
                remap[v]
            }));
        }
        out.normals = self.normals.as_ref().map(|_| normals);
        out.uvs = self.uvs.as_ref().map(|_| uvs);
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
}

impl FileMaterial {
    fn from_tobj(m: &tobj::Material) -> FileMaterial {
        let number = |key: &str| {
            m.unknown_param
                .get(key)
                .and_then(|v| v.trim().parse::<f32>().ok())
        };
        FileMaterial {
            name: m.name.clone(),
            diffuse: m.diffuse,
            specular: m.specular,
            emission: m.emissive,
            ior: m.optical_density,
            illum: m.illumination_model,
            diffuse_texture: m.diffuse_texture.clone(),
            roughness: number("Pr"),
            metallic: number("Pm"),
            texture: None,
            maps: MeshMaps::default(),
        }
    }
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

/// Reads an OBJ file and the MTL files it names, beside it (see [`parse_obj_in`]).
pub fn load_obj(path: &Path) -> Result<ObjMesh, ObjError> {
    let bytes = std::fs::read(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the OBJ file: {e}")))?;
    parse_obj_in(&bytes, Some(path.parent().unwrap_or(Path::new("."))))
}

/// Whether a mesh file is read as PLY (its extension is `.ply`, any case); anything else is read as OBJ.
pub fn is_ply(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"))
}

/// Whether a mesh file is read as glTF 2.0 (its extension is `.gltf` or `.glb`, any case).
pub fn is_gltf(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Reads the mesh file of a `[[mesh]]` by its extension: PLY (super::ply), glTF (super::gltf), OBJ
/// otherwise.
pub fn load_mesh_file(path: &Path) -> Result<ObjMesh, ObjError> {
    if is_gltf(path) {
        return super::gltf::load_gltf(path);
    }
    if !is_ply(path) {
        return load_obj(path);
    }
    let bytes = std::fs::read(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the PLY file: {e}")))?;
    super::ply::parse_ply(&bytes)
}

/// A byte slice as a `BufRead` that remembers how far `tobj` has read: `tobj` reads line by line
/// (`BufRead::lines`) and stops at the first bad line, so when it fails the line it failed on is the
/// last one consumed. (Its errors carry no position of their own.)
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Read for Cursor<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = buf.len().min(self.bytes.len() - self.pos);
        buf[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl BufRead for Cursor<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.bytes[self.pos..])
    }

    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.bytes.len());
    }
}

/// The 1-based line that ends at byte `pos` (the byte after its newline, or the end of the text).
fn line_ending_at(bytes: &[u8], pos: usize) -> usize {
    let end = pos.saturating_sub(1).min(bytes.len());
    1 + bytes[..end].iter().filter(|&&b| b == b'\n').count()
}

/// Parses OBJ text without its MTL files (see [`parse_obj_in`]).
pub fn parse_obj(bytes: &[u8]) -> Result<ObjMesh, ObjError> {
    parse_obj_in(bytes, None)
}

/// Parses OBJ text: `v`, `vt`, `vn` and `f` (polygons are triangulated as fans, points and lines
/// ignored, `\r\n` line ends accepted), and `mtllib` / `usemtl`: the MTL files are read from `dir`
/// (none when `dir` is `None`), and each triangle keeps its material. Errors name the line: a malformed
/// number or face, an index out of range, a non-finite coordinate, no faces. An MTL file that cannot be
/// read is not an error (`mtl_problem`).
pub fn parse_obj_in(bytes: &[u8], dir: Option<&Path>) -> Result<ObjMesh, ObjError> {
    let options = tobj::LoadOptions {
        // One index per corner: a position used with two normals or uvs becomes two vertices.
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // tobj 4.0.5 computes `index * 2 + 1` and `index * 3 + 2` on face indices without overflow checks
    // (lib.rs:852, 860): an index such as `-2147483649` panics in debug builds and wraps in release
    // ones (found by tests/fuzz_scene.rs). Every out-of-range index is refused before tobj sees it.
    if let Some(e) = locate_bad_index(bytes) {
        return Err(e);
    }
    let mut cursor = Cursor { bytes, pos: 0 };
    let mtl_problem = std::cell::RefCell::new(None);
    let loaded = tobj::load_obj_buf(&mut cursor, &options, |name| {
        let Some(dir) = dir else {
            return Ok((Vec::new(), Default::default()));
        };
        let path = dir.join(name);
        let read = std::fs::read(&path)
            .map_err(|e| e.to_string())
            .and_then(|b| {
                tobj::load_mtl_buf(&mut std::io::BufReader::new(&b[..]))
                    .map_err(|e| format!("not a valid MTL file ({e})"))
            });
        read.map_err(|why| {
            *mtl_problem.borrow_mut() = Some(format!(
                "the OBJ's material library {} cannot be read: {why}",
                path.display()
            ));
            tobj::LoadError::OpenFileFailed
        })
    });
    let (models, materials) = match loaded {
        Ok((models, materials)) => (models, materials.unwrap_or_default()),
        Err(e) => return Err(explain_tobj_error(bytes, e, cursor.pos)),
    };

    let mut mesh = ObjMesh {
        materials: materials.iter().map(FileMaterial::from_tobj).collect(),
        mtl_problem: mtl_problem.into_inner(),
        ..ObjMesh::default()
    };
    let mut all_normals = true;
    let mut all_uvs = true;
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len();
        let count = m.positions.len() / 3;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        // tobj stores a normal (uv) per vertex only for the vertices whose face corners have one.
        if m.normals.len() == 3 * count {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        } else {
            all_normals = false;
        }
        if m.texcoords.len() == 2 * count {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| [t[0], t[1]]));
        } else {
            all_uvs = false;
        }
        if base + count > MAX_TRIANGLES
            || mesh.triangles.len() + m.indices.len() / 3 > MAX_TRIANGLES
        {
            return Err(ObjError::whole_file(format!(
                "the mesh is too large: more than {MAX_TRIANGLES} vertices or triangles"
            )));
        }
        mesh.triangles.extend(
            m.indices
                .chunks_exact(3)
                .map(|t| [t[0] + base as u32, t[1] + base as u32, t[2] + base as u32]),
        );
        if !mesh.materials.is_empty() {
            let id = m
                .material_id
                .filter(|&id| id < mesh.materials.len())
                .map(|id| id as u32);
            mesh.face_materials.resize(mesh.triangles.len(), id);
        }
    }
    if mesh.triangles.is_empty() {
        return Err(ObjError::whole_file(
            "the file has no faces (`f` lines with at least 3 vertices)",
        ));
    }
    mesh.normals = all_normals.then_some(normals);
    mesh.uvs = all_uvs.then_some(uvs);

    // `f32::from_str` accepts "nan" and "inf": a coordinate must be finite to be placed in the scene.
    if !mesh.is_finite() {
        return Err(locate_non_finite(bytes));
    }
    Ok(mesh)
}

/// Turns a `tobj` error into a message with a line. Parse errors happen on the line `tobj` stopped at;
/// index errors are found only when a group of faces is assembled (at the next `o`/`g` or at the end),
/// so their line is found by checking every face ourselves.
fn explain_tobj_error(bytes: &[u8], e: tobj::LoadError, pos: usize) -> ObjError {
    use tobj::LoadError as E;
    match e {
        E::FaceVertexOutOfBounds
        | E::FaceTexCoordOutOfBounds
        | E::FaceNormalOutOfBounds
        | E::FaceColorOutOfBounds => locate_bad_index(bytes).unwrap_or_else(|| {
            ObjError::whole_file(format!("a face refers to a missing vertex ({e})"))
        }),
        E::ReadError => ObjError::at(
            line_ending_at(bytes, pos),
            "this line is not valid UTF-8 text",
        ),
        _ => {
            let line = line_ending_at(bytes, pos);
            let what = match e {
                E::PositionParseError => "a vertex (`v`) needs three numbers",
                E::NormalParseError => "a normal (`vn`) needs three numbers",
                E::TexcoordParseError => "a texture coordinate (`vt`) needs two numbers",
                E::FaceParseError => {
                    "a face (`f`) must list vertex references `v`, `v/vt`, `v//vn` or `v/vt/vn`, \
                     each an integer"
                }
                E::ScalingByZeroError => "a vertex has a w coordinate of 0",
                E::ColorParseError => "a vertex has the wrong number of colour components",
                _ => "",
            };
            if what.is_empty() {
                ObjError::at(line, format!("the OBJ reader failed here: {e}"))
            } else {
                ObjError::at(line, what)
            }
        }
    }
}

/// The lines of an OBJ as (1-based line number, first word, rest of the words).
fn obj_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &str, std::str::SplitWhitespace<'_>)> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .filter_map(|(i, raw)| {
            let text = std::str::from_utf8(raw).ok()?;
            let mut words = text.split_whitespace();
            let first = words.next()?;
            Some((i + 1, first, words))
        })
}

/// Finds the first face with fewer than 3 corners, or corner whose position, uv or normal index is out
/// of range. OBJ indices are 1-based; a negative index counts back from the last element defined before
/// the face.
fn locate_bad_index(bytes: &[u8]) -> Option<ObjError> {
    let mut totals = [0usize; 3];
    for (_, first, _) in obj_lines(bytes) {
        match first {
            "v" => totals[0] += 1,
            "vt" => totals[1] += 1,
            "vn" => totals[2] += 1,
            _ => {}
        }
    }
    let names = ["vertex", "texture coordinate", "normal"];
    let keys = ["v", "vt", "vn"];
    let mut so_far = [0usize; 3];
    for (line, first, words) in obj_lines(bytes) {
        match first {
            "v" => so_far[0] += 1,
            "vt" => so_far[1] += 1,
            "vn" => so_far[2] += 1,
            "f" => {
                // A face of fewer than 3 corners was dropped without a word (tobj skips it), and a
                // file of only such faces said "no faces" without a line.
                let corners: Vec<&str> = words.into_iter().collect();
                if corners.len() < 3 {
                    return Some(ObjError::at(
                        line,
                        format!(
                            "a face (`f`) needs at least 3 vertex references, this one has {}",
                            corners.len()
                        ),
                    ));
                }
                for corner in corners {
                    for (k, part) in corner.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(index) = part.parse::<i64>() else {
                            continue;
                        };
                        let ok = if index > 0 {
                            index as u64 <= totals[k] as u64
                        } else if index < 0 {
                            index.unsigned_abs() <= so_far[k] as u64
                        } else {
                            false
                        };
                        if !ok {
                            let range = if totals[k] == 0 {
                                format!("the file defines no {} (`{}` lines)", names[k], keys[k])
                            } else {
                                format!(
                                    "the file defines {} of them, numbered from 1 (or -1 for the last one before the face)",
                                    totals[k]
                                )
                            };
                            return Some(ObjError::at(
                                line,
                                format!(
                                    "face corner `{corner}` refers to {} {index}, which does not exist: {range}",
                                    names[k]
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// Finds the first `v`, `vn` or `vt` line with a NaN or infinite number.
fn locate_non_finite(bytes: &[u8]) -> ObjError {
    for (line, first, words) in obj_lines(bytes) {
        if matches!(first, "v" | "vn" | "vt") {
            for w in words {
                if let Ok(x) = w.parse::<f32>()
                    && !x.is_finite()
                {
                    return ObjError::at(
                        line,
                        format!(
                            "`{first}` has a non-finite number ({w}): every coordinate must be finite"
                        ),
                    );
                }
            }
        }
    }
    ObjError::whole_file("a coordinate is not finite")
}

/// Where a mesh goes: scaled uniformly about the OBJ's origin, rotated about x, then y, then z (degrees,
/// right-handed), then translated. A point p becomes `Rz Ry Rx (scale p) + translate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub scale: f32,
    pub rotate_deg: Vec3,
    pub translate: Vec3,
}

impl Default for Placement {
    fn default() -> Self {
        Placement {
            scale: 1.0,
            rotate_deg: Vec3::ZERO,
            translate: Vec3::ZERO,
        }
    }
}

impl Placement {
    /// The rotation, in f64 so that composing it rounds once.
    fn rotation(&self) -> DMat3 {
        let r = self.rotate_deg.as_dvec3() * (std::f64::consts::PI / 180.0);
        DMat3::from_rotation_z(r.z) * DMat3::from_rotation_y(r.y) * DMat3::from_rotation_x(r.x)
    }
}

/// The OBJ mesh placed in the world. With `smooth`, shading normals are the OBJ's (rotated: a uniform
/// scale does not change directions) when it gives one for every vertex, else computed (see
/// [`vertex_normals`]). `keep_uvs` keeps the texture coordinates (the caller has checked they exist).
pub fn place(
    obj: &ObjMesh,
    placement: &Placement,
    smooth: bool,
    keep_uvs: bool,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<[f32; 2]>) {
    let rotation = placement.rotation();
    let scale = f64::from(placement.scale);
    let translate = placement.translate.as_dvec3();
    let positions: Vec<Vec3> = obj
        .positions
        .iter()
        .map(|p| (rotation * (p.as_dvec3() * scale) + translate).as_vec3())
        .collect();
    let normals = if !smooth {
        Vec::new()
    } else {
        match &obj.normals {
            Some(given) => given
                .iter()
                .map(|n| unit_or_zero(rotation * n.as_dvec3()))
                .collect(),
            None => vertex_normals(&positions, &obj.triangles),
        }
    };
    let uvs = match (&obj.uvs, keep_uvs) {
        (Some(uvs), true) => uvs.clone(),
        _ => Vec::new(),
    };
    (positions, normals, uvs)
}

fn unit_or_zero(v: DVec3) -> Vec3 {
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        (v / len).as_vec3()
    } else {
        Vec3::ZERO
    }
}

/// Smooth vertex normals for a mesh without its own: at each vertex, the sum of the unnormalised face
/// normals (v1 - v0) x (v2 - v0) of the faces around it, i.e. the area-weighted mean face normal, then
/// normalised. Vertices at the same position are welded first (OBJ exporters split a position where the
/// uv or normal changes, and those splits must not crease the surface). Sums run in f64.
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
        let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[welded[i as usize]] += n;
        }
    }
    welded.iter().map(|&w| unit_or_zero(sums[w])).collect()
}

/// Reads an image file as an sRGB RGBA8 texture (PNG, JPEG, EXR, HDR).
pub fn load_texture(path: &Path) -> Result<Texture, String> {
    let bytes = std::fs::read(path)
        .map_err(|e| format!("cannot read the texture {}: {e}", path.display()))?;
    decode_texture(&bytes, path)
}

/// Decodes an image held in memory (a glTF buffer's), `what` naming it in messages.
pub fn load_texture_bytes(bytes: &[u8], what: &str) -> Result<Texture, String> {
    decode_texture(bytes, Path::new(what))
}

fn decode_texture(bytes: &[u8], path: &Path) -> Result<Texture, String> {
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("cannot read the texture {}: {e}", path.display()))
    };
    // The size comes from the header, before any texel is decoded: a small file declaring a huge image
    // (a decompression bomb) is refused without the memory it would take.
    let (width, height) = reader()?
        .into_dimensions()
        .map_err(|e| format!("cannot decode the texture {}: {e}", path.display()))?;
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_TEXTURE_TEXELS {
        return Err(format!(
            "the texture {} is {width} x {height} texels; it must have between 1 and 2^28 texels",
            path.display()
        ));
    }
    let decoded = reader()?
        .decode()
        .map_err(|e| format!("cannot decode the texture {}: {e}", path.display()))?;
    // PNG and JPEG hold 8 bits per channel, RGBA8 on the device. EXR and HDR decode to floats (linear
    // radiance, reflectance or heights): kept as RGBA f16 (two words per texel), unclipped, so that an
    // emission or height map keeps its range. (Non-finite values become 0; f16 saturates at 65504.)
    let (texels, half) = match decoded {
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_) => {
            let linear = decoded.to_rgba32f();
            let h = |v: f32| {
                let v = if v.is_finite() { v } else { 0.0 };
                u32::from(half::f16::from_f32(v).to_bits())
            };
            let texels = linear
                .pixels()
                .flat_map(|p| {
                    let [r, g, b, a] = p.0;
                    [h(r) | h(g) << 16, h(b) | h(a) << 16]
                })
                .collect();
            (texels, true)
        }
        other => {
            let rgba = other.to_rgba8();
            (
                rgba.pixels().map(|p| u32::from_le_bytes(p.0)).collect(),
                false,
            )
        }
    };
    Ok(Texture {
        path: path.to_path_buf(),
        width,
        height,
        texels,
        half,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// JPEG textures are read as 8-bit texels like PNG; EXR and HDR ones keep their linear values as
    /// f16, unclipped (1.5 stays 1.5).
    #[test]
    fn jpeg_textures_load_as_8_bit_and_exr_and_hdr_as_half_floats() {
        let dir = tempfile::tempdir().unwrap();
        // (Values HDR's shared-exponent RGBE and f16 both hold exactly: multiples of 2^-7 below 2.)
        let linear = [0.5f32, 0.0625, 1.5];
        let float = image::Rgb32FImage::from_fn(4, 2, |_, _| image::Rgb(linear));
        for ext in ["exr", "hdr"] {
            let path = dir.path().join(format!("t.{ext}"));
            float.save(&path).unwrap();
            let t = load_texture(&path).unwrap_or_else(|e| panic!("{ext}: {e}"));
            assert_eq!((t.width, t.height, t.half), (4, 2, true));
            assert_eq!(t.texels.len(), 16);
            let f = |bits: u32| half::f16::from_bits(bits as u16).to_f32();
            let (rg, ba) = (t.texels[10], t.texels[11]); // texel 5
            let got = [f(rg & 0xffff), f(rg >> 16), f(ba & 0xffff), f(ba >> 16)];
            assert_eq!(got, [linear[0], linear[1], linear[2], 1.0], "{ext}");
        }
        let srgb = image::RgbImage::from_fn(8, 8, |_, _| image::Rgb([200, 100, 50]));
        let path = dir.path().join("t.jpg");
        srgb.save(&path).unwrap();
        let t = load_texture(&path).expect("jpeg");
        let [r, g, b, _] = t.texels[27].to_le_bytes();
        // (JPEG is lossy: a flat colour comes back within a few levels.)
        assert!(
            r.abs_diff(200) <= 3 && g.abs_diff(100) <= 3 && b.abs_diff(50) <= 3,
            "{r} {g} {b}"
        );
    }

    /// Issue 18, failure 5: a 62 kB PNG declaring 23000 x 23000 was refused only after it was decoded
    /// (7.9 s, 2.5 GB). The size now comes from the header: a PNG whose header declares that size and
    /// which holds almost no image data is refused for its size (decoding it would fail otherwise).
    #[test]
    fn a_huge_texture_is_refused_from_its_header() {
        fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
            let mut crc = crc32fast::Hasher::new();
            crc.update(kind);
            crc.update(data);
            [
                &(data.len() as u32).to_be_bytes()[..],
                kind,
                data,
                &crc.finalize().to_be_bytes(),
            ]
            .concat()
        }
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&23000u32.to_be_bytes());
        ihdr.extend_from_slice(&23000u32.to_be_bytes());
        ihdr.extend_from_slice(&[8, 6, 0, 0, 0]); // 8-bit RGBA, no interlace
        let png = [
            &b"\x89PNG\r\n\x1a\n"[..],
            &chunk(b"IHDR", &ihdr),
            // A zlib stream of nothing: the 2 GB of texels it declares are not there.
            &chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]),
            &chunk(b"IEND", &[]),
        ]
        .concat();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bomb.png");
        std::fs::write(&path, png).unwrap();
        let e = load_texture(&path).unwrap_err();
        assert!(e.contains("23000 x 23000") && e.contains("2^28"), "{e}");
    }

    #[test]
    fn quads_and_polygons_are_triangulated_and_crlf_is_accepted() {
        let text =
            "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nv 0.5 1.5 0\r\nf 1 2 3 4\r\nf 4 3 5\r\n";
        let m = parse_obj(text.as_bytes()).unwrap();
        assert_eq!(m.triangles.len(), 3);
        assert_eq!(m.positions.len(), 5);
        assert!(m.normals.is_none() && m.uvs.is_none());
        let pentagon = "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\nf 1 2 3 4 5\n";
        assert_eq!(parse_obj(pentagon.as_bytes()).unwrap().triangles.len(), 3);
    }

    #[test]
    fn normals_and_uvs_are_kept_per_corner() {
        let text =
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n";
        let m = parse_obj(text.as_bytes()).unwrap();
        assert_eq!(m.normals.unwrap(), vec![Vec3::Z; 3]);
        assert_eq!(m.uvs.unwrap(), vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    }

    fn error(text: &str) -> ObjError {
        parse_obj(text.as_bytes()).expect_err("should fail")
    }

    #[test]
    fn errors_name_the_line() {
        let e = error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
        assert_eq!(e.line, Some(4), "{e:?}");
        assert!(e.message.contains("vertex 4"), "{e:?}");
        let e = error("v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n");
        assert_eq!(e.line, Some(2), "{e:?}");
        let e = error("v 0 0 0\r\nv 1 0 0\r\nv 0 nan 0\r\nf 1 2 3\r\n");
        assert_eq!(e.line, Some(3), "{e:?}");
        assert!(e.message.contains("non-finite"), "{e:?}");
        let e = error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n");
        assert_eq!(e.line, Some(4), "{e:?}");
        let e = error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n");
        assert_eq!(e.line, Some(4), "{e:?}");
        let e = error("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\no next\n");
        assert_eq!(e.line, Some(5), "{e:?}");
        assert!(e.message.contains("normal 2"), "{e:?}");
        let e = error("v 0 0 0\nv 1 0 0\nf 1/a 2 3\n");
        assert_eq!(e.line, Some(3), "{e:?}");
        let e = error("# nothing\nv 0 0 0\n");
        assert_eq!(e.line, None);
        assert!(e.message.contains("no faces"));
        // Issue 18: a face of two corners was dropped silently (and alone gave "no faces", no line).
        let e = error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
        assert_eq!(e.line, Some(5), "{e:?}");
        assert!(
            e.message.contains("at least 3") && e.message.contains("has 2"),
            "{e:?}"
        );
    }

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

    #[test]
    fn placement_scales_then_rotates_x_y_z_then_translates() {
        let obj = ObjMesh {
            positions: vec![Vec3::X],
            normals: Some(vec![Vec3::X]),
            uvs: None,
            triangles: vec![[0, 0, 0]],
            ..ObjMesh::default()
        };
        let p = Placement {
            scale: 2.0,
            rotate_deg: Vec3::new(90.0, 0.0, 90.0),
            translate: Vec3::new(0.0, 0.0, 5.0),
        };
        let (pos, nrm, _) = place(&obj, &p, true, false);
        // Rx(90) leaves x alone, Rz(90) turns x into y: 2 x -> 2 y, then + 5 z.
        assert!(
            (pos[0] - Vec3::new(0.0, 2.0, 5.0)).length() < 1e-6,
            "{:?}",
            pos[0]
        );
        assert!((nrm[0] - Vec3::Y).length() < 1e-6);
        let p = Placement {
            scale: 1.0,
            rotate_deg: Vec3::new(90.0, 90.0, 0.0),
            translate: Vec3::ZERO,
        };
        let obj_y = ObjMesh {
            positions: vec![Vec3::Y],
            ..obj
        };
        // Rx(90): y -> z; then Ry(90): z -> x.
        let (pos, _, _) = place(&obj_y, &p, false, false);
        assert!((pos[0] - Vec3::X).length() < 1e-6, "{:?}", pos[0]);
    }
}
