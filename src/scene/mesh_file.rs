//! The mesh file of a `[[mesh]]`, read by its extension: PLY (`ply`), glTF (`gltf`), OBJ (`obj`)
//! otherwise.

use super::mesh::{ObjError, ObjMesh};
use std::path::Path;

/// Whether a mesh file is read as PLY (its extension is `.ply`, any case); anything else is read as OBJ.
pub fn is_ply(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"))
}

/// The extensions of glTF 2.0 files: JSON with its buffers, or binary.
pub const GLTF_EXTENSIONS: &[&str] = &["gltf", "glb"];

/// Whether a mesh file is read as glTF 2.0 (its extension is `.gltf` or `.glb`, any case).
pub fn is_gltf(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| GLTF_EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Host bytes a mesh file may take per byte of file on the way to the device, with a margin over the
/// 10 measured (see [`load_mesh_file`]).
pub const MEMORY_PER_FILE_BYTE: u64 = 16;

/// Whether a mesh file is read as a Mitsuba `.serialized` file (by its extension, any case).
pub fn is_serialized(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("serialized"))
}

/// Reads the mesh file of a `[[mesh]]` by its extension: PLY (super::ply), glTF (super::gltf), Mitsuba's
/// serialized meshes (super::serialized: mesh `shape_index` of the file; the others read mesh 0 only),
/// OBJ (super::obj) otherwise.
pub fn load_mesh_file(path: &Path, shape_index: u32) -> Result<ObjMesh, ObjError> {
    // A mesh file becomes about 10 times its size in memory by the time its triangles are on the device
    // (a 1-million-triangle OBJ of 34 MB: 330 MB on lavapipe, parse, BVH and device arrays together):
    // a file the machine cannot hold that way is refused before it is read. A file that is not a regular
    // file (a pipe, a device) has no size to check, and is not a mesh.
    if let Ok(meta) = std::fs::metadata(path) {
        if !meta.is_file() {
            return Err(ObjError::whole_file("it is not a regular file"));
        }
        crate::memory::check_available(
            meta.len().saturating_mul(MEMORY_PER_FILE_BYTE),
            &format!("reading this mesh file of {} bytes", meta.len()),
        )
        .map_err(ObjError::whole_file)?;
    }
    if is_gltf(path) {
        return super::gltf::load_gltf(path);
    }
    if is_serialized(path) {
        return super::serialized::load_serialized(path, shape_index);
    }
    if !is_ply(path) {
        return super::obj::load_obj(path);
    }
    let bytes = crate::memory::read_file(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the PLY file: {e}")))?;
    super::ply::parse_ply(&bytes)
}
