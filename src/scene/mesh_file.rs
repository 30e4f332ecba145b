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

/// Reads the mesh file of a `[[mesh]]` by its extension: PLY (super::ply), glTF (super::gltf), OBJ
/// (super::obj) otherwise.
pub fn load_mesh_file(path: &Path) -> Result<ObjMesh, ObjError> {
    if is_gltf(path) {
        return super::gltf::load_gltf(path);
    }
    if !is_ply(path) {
        return super::obj::load_obj(path);
    }
    let bytes = std::fs::read(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the PLY file: {e}")))?;
    super::ply::parse_ply(&bytes)
}
