//! Stanford PLY meshes (Turk, "The PLY Polygon File Format", 1994; the format as Paul Bourke documents
//! it): `ascii`, `binary_little_endian` and `binary_big_endian`, version 1.0.
//!
//! Read: the `vertex` element's `x`, `y`, `z` (required), `nx`, `ny`, `nz` (the normal, all three or
//! none) and texture coordinates under any of the usual names (`u`/`v`, `s`/`t`, `texture_u`/`texture_v`,
//! `texture_s`/`texture_t`); the `face` element's index list (`vertex_indices` or `vertex_index`), each
//! polygon split into a fan of triangles. Every other element and property is read past (its values are
//! parsed, so a binary file stays in step) and ignored. Any scalar type of the format is accepted for any
//! property; indices must be integers.
//!
//! Errors name the header line (1-based) for header problems, and the element and its index for body
//! problems (a binary body has no lines); counts are checked against the file's size before anything is
//! allocated, so a small file that declares 10^12 vertices is refused at once.

use super::mesh::{MAX_TRIANGLES, ObjError, ObjMesh};
use glam::Vec3;

/// A scalar type of the format.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Debug)]
enum Property {
    Scalar(String, Scalar),
    /// A list: the type of its count, the type of its items.
    List(String, Scalar, Scalar),
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar(n, _) | Property::List(n, _, _) => n,
        }
    }
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    /// The header line that declared it.
    line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Reads the values of a body, in order, whatever the encoding.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    /// The next value as f64 (every PLY scalar fits exactly, but 64-bit integers, which the format lacks).
    fn next(&mut self, t: Scalar) -> Option<f64> {
        if self.format == Format::Ascii {
            while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let start = self.pos;
            while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let word = std::str::from_utf8(&self.bytes[start..self.pos]).ok()?;
            let v: f64 = word.parse().ok()?;
            return (!t.is_integer() || v.fract() == 0.0).then_some(v);
        }
        let n = t.size();
        let raw = self.bytes.get(self.pos..self.pos + n)?;
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(raw);
        if self.format == Format::Big {
            b[..n].reverse();
        }
        Some(match t {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// The names texture coordinates go by, in the order they are looked for.
const UV_NAMES: [(&str, &str); 4] = [
    ("u", "v"),
    ("s", "t"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// Parses a PLY file's bytes into a mesh in the file's coordinates.
pub fn parse_ply(bytes: &[u8]) -> Result<ObjMesh, ObjError> {
    let (format, elements, body_start) = parse_header(bytes)?;
    let vertex = elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or_else(|| ObjError::whole_file("the PLY header declares no `element vertex`"))?;
    let face = elements
        .iter()
        .find(|e| e.name == "face")
        .ok_or_else(|| ObjError::whole_file("the PLY header declares no `element face`"))?;
    let find = |e: &Element, name: &str| e.properties.iter().position(|p| p.name() == name);
    let xyz = ["x", "y", "z"].map(|n| find(vertex, n));
    let [Some(px), Some(py), Some(pz)] = xyz else {
        return Err(ObjError::at(
            vertex.line,
            "the vertex element needs properties x, y and z",
        ));
    };
    let normal = match ["nx", "ny", "nz"].map(|n| find(vertex, n)) {
        [Some(a), Some(b), Some(c)] => Some([a, b, c]),
        [None, None, None] => None,
        _ => {
            return Err(ObjError::at(
                vertex.line,
                "the vertex element has some of nx, ny, nz but not all three",
            ));
        }
    };
    let uv = UV_NAMES
        .iter()
        .find_map(|(u, v)| Some([find(vertex, u)?, find(vertex, v)?]));
    let indices = find(face, "vertex_indices")
        .or_else(|| find(face, "vertex_index"))
        .ok_or_else(|| {
            ObjError::at(
                face.line,
                "the face element has no `vertex_indices` (or `vertex_index`) list",
            )
        })?;
    match &face.properties[indices] {
        Property::List(_, count, item) if count.is_integer() && item.is_integer() => {}
        _ => {
            return Err(ObjError::at(
                face.line,
                "the face element's vertex_indices must be a list of integers",
            ));
        }
    }
    for p in &vertex.properties {
        let wanted = [Some(px), Some(py), Some(pz)]
            .into_iter()
            .chain(normal.into_iter().flatten().map(Some))
            .chain(uv.into_iter().flatten().map(Some))
            .any(|i| i.is_some_and(|i| vertex.properties[i].name() == p.name()));
        if wanted && matches!(p, Property::List(..)) {
            return Err(ObjError::at(
                vertex.line,
                format!(
                    "the vertex property {} must be a scalar, not a list",
                    p.name()
                ),
            ));
        }
    }

    let mut body = Body {
        bytes,
        pos: body_start,
        format,
    };
    let mut mesh = ObjMesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for e in &elements {
        let is_vertex = std::ptr::eq(e, vertex);
        let is_face = std::ptr::eq(e, face);
        if is_vertex {
            mesh.positions.reserve(e.count);
        }
        let mut values = vec![0.0f64; e.properties.len()];
        let mut list: Vec<f64> = Vec::new();
        for k in 0..e.count {
            let truncated = || {
                ObjError::whole_file(format!(
                    "{} {k} of {} (declared at line {}) is truncated or not a number of its type",
                    e.name, e.count, e.line
                ))
            };
            for (i, p) in e.properties.iter().enumerate() {
                match p {
                    Property::Scalar(_, t) => values[i] = body.next(*t).ok_or_else(truncated)?,
                    Property::List(_, ct, it) => {
                        let n = body.next(*ct).ok_or_else(truncated)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(ObjError::whole_file(format!(
                                "{} {k}: a list of {n} items",
                                e.name
                            )));
                        }
                        let keep = is_face && i == indices;
                        if keep {
                            list.clear();
                        }
                        for _ in 0..n as usize {
                            let v = body.next(*it).ok_or_else(truncated)?;
                            if keep {
                                list.push(v);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                let at = |i: usize| values[i] as f32;
                mesh.positions.push(Vec3::new(at(px), at(py), at(pz)));
                if let Some([a, b, c]) = normal {
                    normals.push(Vec3::new(at(a), at(b), at(c)));
                }
                if let Some([u, v]) = uv {
                    uvs.push([at(u), at(v)]);
                }
            } else if is_face {
                if list.len() < 3 {
                    return Err(ObjError::whole_file(format!(
                        "face {k} has {} vertices; a face needs at least 3",
                        list.len()
                    )));
                }
                let n = vertex.count as f64;
                if let Some(bad) = list.iter().find(|&&i| i < 0.0 || i >= n) {
                    return Err(ObjError::whole_file(format!(
                        "face {k} refers to vertex {bad}, but the file has {} vertices (0 to {})",
                        vertex.count,
                        vertex.count.saturating_sub(1)
                    )));
                }
                for j in 1..list.len() - 1 {
                    if mesh.triangles.len() >= MAX_TRIANGLES {
                        return Err(ObjError::whole_file(format!(
                            "the mesh is too large: more than {MAX_TRIANGLES} triangles"
                        )));
                    }
                    mesh.triangles
                        .push([list[0] as u32, list[j] as u32, list[j + 1] as u32]);
                }
            }
        }
    }
    if mesh.triangles.is_empty() {
        return Err(ObjError::whole_file("the file has no faces"));
    }
    mesh.normals = normal.map(|_| normals);
    mesh.uvs = uv.map(|_| uvs);
    if !mesh.is_finite() {
        return Err(ObjError::whole_file(
            "a vertex position, normal or texture coordinate is not a finite number",
        ));
    }
    Ok(mesh)
}

/// The header: the body's encoding, its elements in order, and where the body starts.
fn parse_header(bytes: &[u8]) -> Result<(Format, Vec<Element>, usize), ObjError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(ObjError::whole_file(
                "the PLY header has no `end_header` line",
            ));
        };
        line_no += 1;
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        let text = std::str::from_utf8(raw)
            .map_err(|_| ObjError::at(line_no, "the PLY header is not ASCII text"))?
            .trim_end_matches('\r');
        let words: Vec<&str> = text.split_whitespace().collect();
        let bad = |what: &str| ObjError::at(line_no, format!("{what}: `{text}`"));
        match words.as_slice() {
            ["ply"] if line_no == 1 => {}
            _ if line_no == 1 => {
                return Err(ObjError::at(
                    1,
                    "not a PLY file: the first line is not `ply`",
                ));
            }
            ["format", f, "1.0"] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(bad("unknown PLY format")),
                });
            }
            ["format", ..] => return Err(bad("unsupported PLY format line (version 1.0 only)")),
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count: usize = count.parse().map_err(|_| bad("bad element count"))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line: line_no,
                });
            }
            ["property", "list", ct, it, name] => {
                let (Some(ct), Some(it)) = (Scalar::parse(ct), Scalar::parse(it)) else {
                    return Err(bad("unknown property type"));
                };
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad("a property before any element"))?;
                e.properties.push(Property::List(name.to_string(), ct, it));
            }
            ["property", t, name] => {
                let t = Scalar::parse(t).ok_or_else(|| bad("unknown property type"))?;
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad("a property before any element"))?;
                e.properties.push(Property::Scalar(name.to_string(), t));
            }
            ["end_header"] => break,
            _ => return Err(bad("unknown PLY header line")),
        }
    }
    let format =
        format.ok_or_else(|| ObjError::whole_file("the PLY header has no `format` line"))?;
    // Each item takes at least one byte of the body (two in ASCII: a digit and a separator), so a count
    // beyond the body's size is refused before anything is allocated.
    let body = bytes.len() - pos;
    for e in &elements {
        let min_item = if format == Format::Ascii { 2 } else { 1 };
        let per_item = e.properties.len().max(1) * min_item;
        if e.count > MAX_TRIANGLES || e.count.saturating_mul(per_item) > body {
            return Err(ObjError::at(
                e.line,
                format!(
                    "element {} declares {} items, more than the file's {body} bytes of data can hold",
                    e.name, e.count
                ),
            ));
        }
    }
    Ok((format, elements, pos))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE_FACE_ASCII: &str = "ply\nformat ascii 1.0\ncomment a unit square as a quad\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n";

    /// The same square, binary, with a colour property to skip and an extra element after the faces.
    fn binary(big: bool) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nproperty uchar red\nproperty double u\nproperty double v\n\
             element face 1\nproperty list uchar uint vertex_indices\n\
             element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
            if big {
                "binary_big_endian"
            } else {
                "binary_little_endian"
            }
        )
        .into_bytes();
        let f32b = |x: f32| {
            if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            }
        };
        let f64b = |x: f64| {
            if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            }
        };
        let u32b = |x: u32| {
            if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            }
        };
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            out.extend(f32b(x));
            out.extend(f32b(y));
            out.extend(f32b(0.0));
            out.push(200);
            out.extend(f64b(x as f64));
            out.extend(f64b(y as f64));
        }
        out.push(4);
        for i in 0..4 {
            out.extend(u32b(i));
        }
        out.extend(u32b(0));
        out.extend(u32b(1));
        out
    }

    fn check_square(m: &ObjMesh) {
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs.as_ref().expect("uvs")[2], [1.0, 1.0]);
    }

    #[test]
    fn ascii_with_normals_and_st() {
        let m = parse_ply(CUBE_FACE_ASCII.as_bytes()).expect("parses");
        check_square(&m);
        assert_eq!(m.normals.expect("normals")[0], Vec3::Z);
    }

    #[test]
    fn binary_both_endians_skip_unknown_properties_and_elements() {
        for big in [false, true] {
            let m = parse_ply(&binary(big)).expect("parses");
            check_square(&m);
            assert!(m.normals.is_none());
        }
    }

    #[test]
    fn errors_name_the_line_or_the_item() {
        let bad_index = CUBE_FACE_ASCII.replace("4 0 1 2 3", "4 0 1 2 7");
        let e = parse_ply(bad_index.as_bytes()).unwrap_err();
        assert!(e.message.contains("vertex 7"), "{e:?}");
        let no_x = CUBE_FACE_ASCII.replace("property float x\n", "property float w\n");
        let e = parse_ply(no_x.as_bytes()).unwrap_err();
        assert_eq!(e.line, Some(4), "{e:?}");
        let huge = CUBE_FACE_ASCII.replace("element vertex 4", "element vertex 1000000000000");
        let e = parse_ply(huge.as_bytes()).unwrap_err();
        assert_eq!(e.line, Some(4), "{e:?}");
        let truncated = &binary(false)[..binary(false).len() - 3];
        let e = parse_ply(truncated).unwrap_err();
        assert!(e.message.contains("edge 0"), "{e:?}");
        let e = parse_ply(b"ply\nformat ascii 2.0\nend_header\n").unwrap_err();
        assert_eq!(e.line, Some(2), "{e:?}");
        let e = parse_ply(b"OFF\n").unwrap_err();
        assert_eq!(e.line, Some(1), "{e:?}");
        let nan = CUBE_FACE_ASCII.replace("1 1 0 0 0 1 1 1", "1 nan 0 0 0 1 1 1");
        assert!(parse_ply(nan.as_bytes()).is_err());
    }
}
