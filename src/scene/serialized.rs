//! Mitsuba's `.serialized` meshes (`[[mesh]] obj = "*.serialized"`, `shape_index` picking one of the
//! file's meshes): the format of Mitsuba 0.4 to 3's `serialized` shape plugin, read from its
//! documentation (Mitsuba 3, mitsuba3/src/shapes/serialized.cpp; the layout is described there, the code here is
//! vkpath's own).
//!
//! Little-endian throughout. Each mesh is a 4-byte header (u16 0x041C, u16 version 3 or 4) followed by a
//! zlib stream holding: u32 flags (0x0001 vertex normals, 0x0002 texture coordinates, 0x0008 vertex
//! colours, 0x0010 face normals, 0x2000 double precision, else single), in version 4 the mesh's name
//! (UTF-8, NUL-terminated), u64 vertex count, u64 triangle count, then the positions, normals, texture
//! coordinates and colours present (3, 3, 2 and 3 numbers a vertex), and the triangles (3 u32 each).
//! Meshes follow one another; the file ends with the offset of each (u64 in version 4, u32 in version 3)
//! and the number of meshes (u32).
//!
//! Texture coordinates: Mitsuba samples a bitmap with v = 0 at the image's top row and does not flip a
//! serialized mesh's v (unlike its OBJ reader); vkpath's v = 0 is the bottom row, so v becomes 1 - v,
//! and a textured .serialized mesh looks as it does in Mitsuba. Vertex colours are read past (vkpath
//! does not use them); the face-normals flag is [`ObjMesh::face_normals`].

use super::mesh::{MAX_TRIANGLES, ObjError, ObjMesh};
use glam::Vec3;
use std::io::Read;
use std::path::Path;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const DOUBLE_PRECISION: u32 = 0x2000;

/// The longest mesh name read (the names are identifiers a few bytes long).
const MAX_NAME_BYTES: usize = 1 << 16;

/// Reads mesh `shape_index` (from 0) of the `.serialized` file at `path`.
pub fn load_serialized(path: &Path, shape_index: u32) -> Result<ObjMesh, ObjError> {
    let bytes = crate::memory::read_file(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the serialized file: {e}")))?;
    parse_serialized(&bytes, shape_index).map_err(ObjError::whole_file)
}

/// Mesh `shape_index` of a `.serialized` file's bytes; the error is the message alone.
pub fn parse_serialized(bytes: &[u8], shape_index: u32) -> Result<ObjMesh, String> {
    let u16_at = |at: usize| {
        bytes
            .get(at..at + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    };
    let header = |at: usize| -> Result<u16, String> {
        match (u16_at(at), u16_at(at + 2)) {
            (Some(MAGIC), Some(v @ (3 | 4))) => Ok(v),
            (Some(MAGIC), Some(v)) => Err(format!(
                "mesh {shape_index}'s version is {v}; Mitsuba's serialized meshes are versions 3 and 4"
            )),
            _ => Err(format!(
                "no serialized mesh starts at byte {at} (the header 0x041C is missing)"
            )),
        }
    };
    let version = header(0)?;
    let offset = if shape_index == 0 {
        0
    } else {
        mesh_offset(bytes, version, shape_index)?
    };
    let version = header(offset)?;
    let mut z = flate2::read::ZlibDecoder::new(&bytes[offset + 4..]);
    let ends = |what: &str, e: std::io::Error| {
        format!("mesh {shape_index} ends inside its {what} (a truncated or damaged file: {e})")
    };
    let mut word = [0u8; 4];
    z.read_exact(&mut word).map_err(|e| ends("flags", e))?;
    let flags = u32::from_le_bytes(word);
    if version == 4 {
        // The name: read up to its NUL, bounded.
        let mut byte = [0u8; 1];
        let mut length = 0;
        loop {
            z.read_exact(&mut byte).map_err(|e| ends("name", e))?;
            if byte[0] == 0 {
                break;
            }
            length += 1;
            if length > MAX_NAME_BYTES {
                return Err(format!(
                    "mesh {shape_index}'s name runs past {MAX_NAME_BYTES} bytes (a damaged file)"
                ));
            }
        }
    }
    let mut long = [0u8; 8];
    z.read_exact(&mut long)
        .map_err(|e| ends("vertex count", e))?;
    let vertices = u64::from_le_bytes(long);
    z.read_exact(&mut long)
        .map_err(|e| ends("triangle count", e))?;
    let triangles = u64::from_le_bytes(long);
    let max = MAX_TRIANGLES as u64;
    if vertices > 3 * max || triangles > max || vertices == 0 || triangles == 0 {
        return Err(format!(
            "mesh {shape_index} has {vertices} vertices and {triangles} triangles: vkpath reads 1 to \
             {max} triangles and at most 3 vertices each"
        ));
    }
    let real = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let per_vertex = 3
        + 3 * u64::from(flags & HAS_NORMALS != 0)
        + 2 * u64::from(flags & HAS_TEXCOORDS != 0)
        + 3 * u64::from(flags & HAS_COLORS != 0);
    // What the counts ask to decode, checked before it is: the stream itself may be a few bytes.
    crate::memory::check_available(
        vertices * per_vertex * (real + 4) + triangles * 12,
        &format!("decoding mesh {shape_index} ({vertices} vertices, {triangles} triangles)"),
    )?;
    let n = vertices as usize;
    let mut reals = |count: usize, what: &str| -> Result<Vec<f32>, String> {
        let mut raw = vec![0u8; count * real as usize];
        z.read_exact(&mut raw).map_err(|e| ends(what, e))?;
        Ok(if real == 8 {
            raw.chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap_or_default()) as f32)
                .collect()
        } else {
            raw.chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap_or_default()))
                .collect()
        })
    };
    let vec3s = |v: Vec<f32>| -> Vec<Vec3> { v.chunks_exact(3).map(Vec3::from_slice).collect() };
    let positions = vec3s(reals(3 * n, "positions")?);
    let normals = (flags & HAS_NORMALS != 0)
        .then(|| reals(3 * n, "normals"))
        .transpose()?
        .map(vec3s);
    let uvs = (flags & HAS_TEXCOORDS != 0)
        .then(|| reals(2 * n, "texture coordinates"))
        .transpose()?
        .map(|t| t.chunks_exact(2).map(|uv| [uv[0], 1.0 - uv[1]]).collect());
    if flags & HAS_COLORS != 0 {
        reals(3 * n, "vertex colours")?;
    }
    let mut raw = vec![0u8; triangles as usize * 12];
    z.read_exact(&mut raw).map_err(|e| ends("triangles", e))?;
    let indices: Vec<u32> = raw
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(format!(
            "mesh {shape_index} refers to vertex {bad} of {vertices}"
        ));
    }
    let mesh = ObjMesh {
        positions,
        normals,
        uvs,
        triangles: indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        face_normals: flags & FACE_NORMALS != 0,
        ..ObjMesh::default()
    };
    if !mesh.is_finite() {
        return Err(format!(
            "mesh {shape_index} has a position, normal or texture coordinate that is not a finite number"
        ));
    }
    Ok(mesh)
}

/// Where mesh `shape_index` starts, from the dictionary at the end of the file.
fn mesh_offset(bytes: &[u8], version: u16, shape_index: u32) -> Result<usize, String> {
    let len = bytes.len();
    let damaged = || "its end-of-file dictionary of meshes is damaged".to_string();
    let count = bytes
        .get(len.checked_sub(4).ok_or_else(damaged)?..)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(damaged)?;
    if shape_index >= count {
        return Err(format!(
            "shape_index {shape_index} asks for mesh {shape_index}, and the file has {count} (0 to {})",
            count.saturating_sub(1)
        ));
    }
    let back = u64::from(count - shape_index);
    let (at, width) = if version == 4 {
        (back * 8 + 4, 8)
    } else {
        ((back + 1) * 4, 4)
    };
    let start = (len as u64).checked_sub(at).ok_or_else(damaged)? as usize;
    let field = bytes.get(start..start + width).ok_or_else(damaged)?;
    let offset = if width == 8 {
        u64::from_le_bytes(field.try_into().map_err(|_| damaged())?)
    } else {
        u64::from(u32::from_le_bytes(field.try_into().map_err(|_| damaged())?))
    };
    if offset.checked_add(4).is_none_or(|end| end > len as u64) {
        return Err(damaged());
    }
    Ok(offset as usize)
}
