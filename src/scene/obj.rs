//! Wavefront OBJ files, and the MTL files they name, read with `tobj` into an [`ObjMesh`]. Errors name
//! the OBJ's line.

use super::mesh::{FileMaterial, MAX_TRIANGLES, MeshMaps, ObjError, ObjMesh};
use glam::Vec3;
use std::io::{BufRead, Read};
use std::path::Path;

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
            layers: crate::scene::GltfLayers::NONE,
        }
    }
}

/// Reads an OBJ file and the MTL files it names, beside it (see [`parse_obj_in`]).
pub fn load_obj(path: &Path) -> Result<ObjMesh, ObjError> {
    let bytes = crate::memory::read_file(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the OBJ file: {e}")))?;
    parse_obj_in(&bytes, Some(path.parent().unwrap_or(Path::new("."))))
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
        let read = crate::memory::read_file(&path).and_then(|b| {
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
                    // `//1` (a normal without its vertex) was refused as "a missing vertex" with no
                    // line: tobj reads the empty index as none.
                    if corner.split('/').next().is_none_or(str::is_empty) {
                        return Some(ObjError::at(
                            line,
                            format!(
                                "the face corner `{corner}` has no vertex index (a corner is v, v/vt, v//vn or v/vt/vn)"
                            ),
                        ));
                    }
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
