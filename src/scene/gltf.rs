//! glTF 2.0 geometry and materials for `[[mesh]] obj = "*.gltf" | "*.glb"`, read with the `gltf` crate
//! (Khronos, "glTF 2.0 Specification", 2021).
//!
//! What is read: the default scene (else the first), its node hierarchy with each node's transform
//! (matrix or translation-rotation-scale, composed from the root: world = parent x local, glTF's
//! column-vector convention), and every triangle primitive of every mesh a node instances: positions,
//! normals (transformed by the inverse transpose), the texture coordinate set the material's textures read
//! (`uv_set`), indices. A node that mirrors re-winds its triangles (glTF 2.0 §3.7.2.1). A mesh that two
//! or more nodes place is read once in its own space, with the nodes' transforms (`ObjMesh::shared`: the
//! scene shares it through the two-level BVH); every other node's primitives are flattened into the
//! file's space. Materials are glTF's
//! metallic-roughness ones (Appendix B), which vkpath's `metallic_roughness` implements: baseColorFactor
//! (its alpha the MASK/BLEND opacity), metallicFactor, roughnessFactor, emissiveFactor x KHR_materials_emissive_strength,
//! and the textures each factor multiplies (glTF 2.0 §3.9): baseColorTexture and emissiveTexture (sRGB
//! colour: base colour = baseColorFactor x texel, emission = emissive factor x texel) and
//! metallicRoughnessTexture (linear: metallic = metallicFactor x B, roughness = roughnessFactor x G), and
//! normalTexture (linear: a tangent-space normal map, its x and y times normalTexture.scale, in the frame
//! of the primitive's TANGENT, or of MikkTSpace's tangents where it has none: `mikktspace_tangents`),
//! each a file beside the glTF or an
//! image in a buffer (PNG, JPEG), decoded once however many use it.
//!
//! What is not, each said in a note (a warning of the scene, never silent): non-triangle primitives
//! (points, lines, strips and fans are skipped), occlusionTexture, a material's textures on different
//! texture coordinate sets (all read at TEXCOORD_0), cameras and lights (a mesh file brings geometry and materials only). Each
//! texture is read with its sampler's filter and wrap mode and its KHR_texture_transform
//! (`texture_read`); images may be files, buffer views or data URIs. Alpha modes: MASK and BLEND through
//! the opacity modifier. The Khronos PBR extensions KHR_materials_ior, _specular, _transmission, _volume,
//! _clearcoat and _sheen: their factors, as the material's layers (`layers`; bsdfs/gltf_pbr.wgsl); their
//! textures are warnings. Any other extension the file uses is a warning naming it.

use super::GltfLayers;
use super::image_texture::{Texture, load_texture, load_texture_bytes};
use super::mesh::SharedMesh;
use super::mesh::{FileMaterial, MAX_TRIANGLES, ObjError, ObjMesh};
use glam::{DAffine3, DMat3, Mat3, Mat4, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Reads a `.gltf` (with its buffers, beside it or in data URIs) or a `.glb`.
/// The nodes of `scene` with their world transforms, parents before children, depth first: in the
/// file's order, or with `mirrored` in the mirror order (the last root first, and at each node its last
/// child first: the order the mesh reader has always appended triangles in, which every render's bits
/// depend on through the BVH and the emitters' alias table). glTF requires the node hierarchy to be a strict tree (glTF 2.0 §3.5.3: no node is the child of
/// two nodes, or twice of one, and none is an ancestor of itself); a file whose nodes are not is refused,
/// naming a node, rather than walked: 64 nodes each listing the next one twice make 2^64 paths, and a
/// cycle never ends. The walk visits each node once. The error is the message alone (the callers add the
/// file).
pub fn scene_nodes<'a>(
    doc: &'a gltf::Document,
    scene: &gltf::Scene<'a>,
    mirrored: bool,
) -> Result<Vec<(gltf::Node<'a>, Mat4)>, String> {
    let mut parent: Vec<Option<usize>> = vec![None; doc.nodes().len()];
    for node in doc.nodes() {
        for child in node.children() {
            if let Some(first) = parent[child.index()].replace(node.index()) {
                return Err(format!(
                    "node {} is a child of node {first} and of node {} (or twice of one): glTF's                      node hierarchy must be a tree",
                    child.index(),
                    node.index()
                ));
            }
        }
    }
    let mut visited = vec![false; parent.len()];
    let mut out = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    if !mirrored {
        stack.reverse();
    }
    while let Some((node, parent_world)) = stack.pop() {
        // With one parent each, a node reached twice is a root listed twice or a cycle.
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(format!(
                "node {} is reached twice from the scene's root nodes (a cycle, or a root listed                  twice): glTF's node hierarchy must be a tree",
                node.index()
            ));
        }
        let world = parent_world * Mat4::from_cols_array_2d(&node.transform().matrix());
        let mut children: Vec<_> = node.children().map(|c| (c, world)).collect();
        if !mirrored {
            children.reverse();
        }
        stack.extend(children);
        out.push((node, world));
    }
    Ok(out)
}

/// Every glTF extension vkpath reads (a file using another gets a warning naming it).
const READ_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
];

/// The glTF extensions vkpath implements beyond those the `gltf` crate's features validate.
const VKPATH_EXTENSIONS: &[&str] = &["KHR_mesh_quantization", "KHR_texture_transform"];

/// Parses and validates a glTF file's bytes (JSON or GLB) as the `gltf` crate does, with the checks
/// the crate (1.4) leaves to a panic, found by the fuzzer: its validation of a primitive reads
/// `accessors[i]` for the POSITION index `i` before that index is checked, `Image::source` unwraps an
/// image's `mimeType` (required with a `bufferView`) and its `uri` (required without one), and the GLB
/// reader subtracts 12 from the header's length unchecked. The error is
/// the message alone (the callers add the file).
pub fn read_gltf(bytes: &[u8]) -> Result<gltf::Gltf, String> {
    let invalid = |e: gltf::Error| format!("not a valid glTF 2.0 file: {e}");
    // A GLB's header gives the file's length, which the crate reduces by the header's 12 bytes
    // unchecked (an overflow in a debug build).
    if let Some(length) = bytes
        .strip_prefix(b"glTF")
        .and_then(|rest| rest.get(4..8))
        .map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]))
        && length < 12
    {
        return Err(format!(
            "not a valid glTF 2.0 file: its GLB header gives a length of {length} bytes, less than the \
             header's own 12"
        ));
    }
    let unchecked = gltf::Gltf::from_slice_without_validation(bytes).map_err(invalid)?;
    let mut json = unchecked.document.into_json();
    // Extensions vkpath reads itself (the crate's validation refuses a required extension it does not
    // know): KHR_mesh_quantization (read_attribute) and KHR_texture_transform (texture_read).
    json.extensions_required
        .retain(|e| !VKPATH_EXTENSIONS.contains(&e.as_str()));
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &primitive.attributes {
                if index.value() >= json.accessors.len() {
                    let name = match semantic {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "?".into(),
                    };
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.{name} refers to accessors[{}], and the \
                         file has {} accessors",
                        index.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    for (i, image) in json.images.iter().enumerate() {
        let problem = match (&image.buffer_view, &image.mime_type, &image.uri) {
            (Some(_), None, _) => "has a bufferView and no mimeType",
            (None, _, None) => "has neither a uri nor a bufferView",
            _ => continue,
        };
        return Err(format!(
            "images[{i}] {problem} (glTF 2.0 requires one, §5.18)"
        ));
    }
    check_extension_values(&json)?;
    Ok(gltf::Gltf {
        document: gltf::Document::from_json(json).map_err(invalid)?,
        blob: unchecked.blob,
    })
}

/// The extension values whose specifications require them to be finite and (for a distance) positive,
/// refused naming their element when they are not, as other invalid glTF is: every KHR_texture_transform's
/// `offset`, `scale` (two numbers each) and `rotation` (one), within f32 (a value beyond it would become
/// an infinity in the renderer's f32 and NaN samples), and KHR_materials_volume's `attenuationDistance`
/// (> 0; absent is infinity).
fn check_extension_values(json: &gltf::json::Root) -> Result<(), String> {
    // The materials only (a file's buffers may be data URIs of megabytes).
    let value = serde_json::to_value(&json.materials)
        .map_err(|e| format!("not a valid glTF 2.0 file: {e}"))?;
    let Some(materials) = value.as_array() else {
        return Ok(());
    };
    let finite = |v: &serde_json::Value| v.as_f64().is_some_and(|x| x.abs() <= f64::from(f32::MAX));
    fn walk(
        v: &serde_json::Value,
        path: &str,
        check: &mut dyn FnMut(&str, &str, &serde_json::Value) -> Result<(), String>,
    ) -> Result<(), String> {
        if let Some(obj) = v.as_object() {
            for (key, child) in obj {
                check(path, key, child)?;
                walk(child, &format!("{path}.{key}"), check)?;
            }
        } else if let Some(items) = v.as_array() {
            for (i, child) in items.iter().enumerate() {
                walk(child, &format!("{path}[{i}]"), check)?;
            }
        }
        Ok(())
    }
    let mut check = |path: &str, key: &str, v: &serde_json::Value| -> Result<(), String> {
        let at = format!("{path}.{key}");
        match key {
            "KHR_texture_transform" => {
                for (field, count) in [("offset", 2), ("scale", 2), ("rotation", 1)] {
                    let Some(x) = v.get(field) else { continue };
                    let ok = match (x.as_array(), count) {
                        (Some(a), 2) => a.len() == 2 && a.iter().all(finite),
                        (None, 1) => finite(x),
                        _ => false,
                    };
                    if !ok {
                        return Err(format!(
                            "{at}.{field} = {x} is not {} (KHR_texture_transform requires them, within                              32-bit floats)",
                            if count == 2 {
                                "two finite numbers"
                            } else {
                                "a finite number"
                            }
                        ));
                    }
                }
                Ok(())
            }
            "KHR_materials_volume" => match v.get("attenuationDistance") {
                Some(d) if !(finite(d) && d.as_f64().is_some_and(|x| x > 0.0)) => Err(format!(
                    "{at}.attenuationDistance = {d} is not a positive number (KHR_materials_volume                      requires it; leave it out for no attenuation)"
                )),
                _ => Ok(()),
            },
            _ => Ok(()),
        }
    };
    for (i, m) in materials.iter().enumerate() {
        walk(m, &format!("materials[{i}]"), &mut check)?;
    }
    Ok(())
}

pub fn load_gltf(path: &Path) -> Result<ObjMesh, ObjError> {
    let bytes = crate::memory::read_file(path)
        .map_err(|e| ObjError::whole_file(format!("cannot read the glTF file: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse_gltf(&bytes, dir)
}

/// Parses glTF (JSON or binary) whose external files live in `dir`.
pub fn parse_gltf(bytes: &[u8], dir: &Path) -> Result<ObjMesh, ObjError> {
    let gltf = read_gltf(bytes).map_err(ObjError::whole_file)?;
    let buffers =
        load_buffers(&gltf.document, dir, gltf.blob.clone()).map_err(ObjError::whole_file)?;
    let doc = &gltf.document;
    let mut notes = Notes::default();
    let mut images = Images {
        buffers: &buffers,
        dir,
        loaded: Vec::new(),
    };
    let materials: Vec<FileMaterial> = doc
        .materials()
        .map(|m| material(m, &mut images, &mut notes))
        .collect();
    // An extension the file uses that vkpath does not read is said, never skipped silently (cameras and
    // lights are the scene reader's: gltf_scene.rs).
    for e in doc.extensions_used() {
        if !READ_EXTENSIONS.contains(&e) {
            notes.add(format!(
                "the file uses the extension {e}, which vkpath does not read"
            ));
        }
    }

    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| ObjError::whole_file("the glTF file has no scene"))?;
    let nodes = scene_nodes(doc, &scene, true).map_err(ObjError::whole_file)?;
    // KHR_mesh_quantization: attributes may be 8- and 16-bit integers (read_attribute dequantizes them).
    let quantized = doc.extensions_used().any(|e| e == "KHR_mesh_quantization");
    let read = Read {
        buffers: &buffers,
        quantized,
    };
    // A mesh that two or more nodes place (each by an invertible transform: the renderer maps rays
    // back through its inverse) is read once, in its own space, with the nodes' world transforms
    // (`ObjMesh::shared`); every other node's primitives are flattened into the file's space.
    let mut users = vec![0usize; doc.meshes().len()];
    for (node, world) in &nodes {
        if let Some(m) = node.mesh()
            && invertible(world)
        {
            users[m.index()] += 1;
        }
    }
    let mut flat = Gather::new();
    let mut group_of: Vec<Option<usize>> = vec![None; users.len()];
    let mut groups: Vec<(Gather, Vec<DAffine3>)> = Vec::new();
    for (node, world) in nodes {
        let Some(m) = node.mesh() else { continue };
        if users[m.index()] < 2 || !invertible(&world) {
            flat.add(&m, world, &read, &mut notes)?;
            continue;
        }
        let g = match group_of[m.index()] {
            Some(g) => g,
            None => {
                let mut own = Gather::new();
                own.add(&m, Mat4::IDENTITY, &read, &mut notes)?;
                groups.push((own, Vec::new()));
                group_of[m.index()] = Some(groups.len() - 1);
                groups.len() - 1
            }
        };
        groups[g].1.push(DAffine3::from_mat4(world.as_dmat4()));
    }
    // A primitive without TEXCOORD_0 gets (0, 0) at its vertices when any primitive of the file has
    // them (a valid file textures only primitives that have them), so that the others keep theirs.
    let uvs = flat.any_uvs || groups.iter().any(|(g, _)| g.any_uvs);
    let mut mesh = flat.finish(uvs, &mut notes);
    mesh.materials = materials;
    mesh.shared = groups
        .into_iter()
        .filter(|(g, _)| !g.mesh.triangles.is_empty())
        .map(|(g, nodes)| SharedMesh {
            mesh: g.finish(uvs, &mut notes),
            nodes,
        })
        .collect();
    if mesh.triangles.is_empty() && mesh.shared.is_empty() {
        return Err(ObjError::whole_file(
            "the glTF scene has no triangles (no mesh with a TRIANGLES primitive)",
        ));
    }
    if mesh.materials.is_empty() {
        mesh.face_materials.clear();
        for s in &mut mesh.shared {
            s.mesh.face_materials.clear();
        }
    }
    if !mesh.is_finite() || mesh.shared.iter().any(|s| !s.mesh.is_finite()) {
        return Err(ObjError::whole_file(
            "a vertex position, normal or texture coordinate is not a finite number (after the node transforms)",
        ));
    }
    mesh.notes = notes.0;
    Ok(mesh)
}

/// Whether a node's world transform can be inverted (a node scaled by 0 cannot: its mesh is
/// flattened, to a plane or a point, rather than shared).
fn invertible(world: &Mat4) -> bool {
    !super::mesh::singular(&DMat3::from_mat4(world.as_dmat4()))
}

/// What every primitive is read with: the file's buffers, and whether it may quantize attributes.
struct Read<'a> {
    buffers: &'a [Vec<u8>],
    quantized: bool,
}

/// One mesh being read primitive by primitive: the file's flattened nodes (in the file's space), or one
/// shared mesh (in its own).
struct Gather {
    mesh: ObjMesh,
    /// Every primitive so far had NORMAL.
    all_normals: bool,
    /// Some primitive had the texture coordinates its material reads.
    any_uvs: bool,
    normals: Vec<Vec3>,
    uvs: Vec<[f32; 2]>,
    tangents: Vec<[f32; 4]>,
}

impl Gather {
    fn new() -> Gather {
        Gather {
            mesh: ObjMesh::default(),
            all_normals: true,
            any_uvs: false,
            normals: Vec::new(),
            uvs: Vec::new(),
            tangents: Vec::new(),
        }
    }

    /// Appends the triangle primitives of `m`, placed by `world`.
    fn add(
        &mut self,
        m: &gltf::Mesh,
        world: Mat4,
        read: &Read,
        notes: &mut Notes,
    ) -> Result<(), ObjError> {
        let buffers = read.buffers;
        let mesh = &mut self.mesh;
        // Normals go by the inverse transpose of the upper 3x3 (a non-uniform scale bends them).
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        // glTF 2.0 §3.7.2.1: a node whose world transform has a negative determinant turns its
        // triangles' winding clockwise; written out in world space, they are re-wound so that the
        // front (counter-clockwise) side stays the side the file's normals face.
        let mirrors = Mat3::from_mat4(world).determinant() < 0.0;
        for p in m.primitives() {
            let at = format!("meshes[{}].primitives[{}]", m.index(), p.index());
            if p.mode() != gltf::mesh::Mode::Triangles {
                notes.add(format!(
                    "{at} is {:?}, not triangles: it is skipped",
                    p.mode()
                ));
                continue;
            }
            check_accessors(&p, buffers, &at, read.quantized).map_err(ObjError::whole_file)?;
            let reader = p.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
            let attribute =
                |s: gltf::Semantic| p.get(&s).and_then(|a| read_attribute::<3>(&a, buffers));
            let Some(positions) = attribute(gltf::Semantic::Positions) else {
                notes.add(format!("{at} has no POSITION: it is skipped"));
                continue;
            };
            let positions: Vec<Vec3> = positions
                .into_iter()
                .map(|p| world.transform_point3(Vec3::from_array(p)))
                .collect();
            let count = positions.len();
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..count as u32).collect(),
            };
            if !indices.len().is_multiple_of(3) {
                return Err(ObjError::whole_file(format!(
                    "{at} is TRIANGLES with {} {}, not a multiple of 3",
                    indices.len(),
                    if p.indices().is_some() {
                        "indices"
                    } else {
                        "vertices (no indices)"
                    }
                )));
            }
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= count) {
                return Err(ObjError::whole_file(format!(
                    "{at}.indices refers to vertex {bad} of {count}"
                )));
            }
            let prim_normals: Option<Vec<Vec3>> = attribute(gltf::Semantic::Normals).map(|n| {
                n.into_iter()
                    .map(|n| (normal_matrix * Vec3::from_array(n)).normalize_or_zero())
                    .collect()
            });
            // The texture coordinate set the material's textures read (`uv_set`).
            let set = uv_set(&p.material());
            let tex_coords = p
                .get(&gltf::Semantic::TexCoords(set))
                .and_then(|a| read_attribute::<2>(&a, buffers));
            let normal_mapped = p.material().normal_texture().is_some();
            // Tangents where the material has a normal map: the file's TANGENT (its xyz mapped by the
            // node's linear part, like a direction on the surface; its w, the bitangent's sign,
            // flipped by a mirroring transform, which reverses cross(N, T)), else MikkTSpace's.
            let mut prim_tangents: Option<Vec<[f32; 4]>> = None;
            let mut vertices: Option<Vec<u32>> = None; // the source vertex of each vertex, when split
            let mut indices = indices;
            if normal_mapped {
                let linear = Mat3::from_mat4(world);
                let flip = if linear.determinant() < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                if let Some(t) = p
                    .get(&gltf::Semantic::Tangents)
                    .and_then(|a| read_attribute::<4>(&a, buffers))
                {
                    prim_tangents = Some(
                        t.into_iter()
                            .map(|[x, y, z, w]| {
                                let d = (linear * Vec3::new(x, y, z)).normalize_or_zero();
                                [d.x, d.y, d.z, if w < 0.0 { -flip } else { flip }]
                            })
                            .collect(),
                    );
                } else if let Some(t) = &tex_coords {
                    // MikkTSpace runs on vkpath's uvs (v up, as the image's +Y that glTF's normal
                    // maps take as up) and on the file's normals, or the triangles' own.
                    let uv_up: Vec<[f32; 2]> = t.iter().map(|&[u, v]| [u, 1.0 - v]).collect();
                    let tris: Vec<[u32; 3]> = indices
                        .chunks_exact(3)
                        .map(|c| [c[0], c[1], c[2]])
                        .collect();
                    let n = prim_normals
                        .clone()
                        .unwrap_or_else(|| super::mesh::vertex_normals(&positions, &tris));
                    let split = mikktspace_tangents(&positions, &n, &uv_up, &indices);
                    indices = split.indices;
                    prim_tangents = Some(split.tangents);
                    vertices = Some(split.vertices);
                }
            }
            // A split (MikkTSpace gives a vertex different tangents on different faces at uv seams)
            // copies the vertex's attributes.
            let gather = |v: Vec<[f32; 2]>| match &vertices {
                Some(src) => src.iter().map(|&i| v[i as usize]).collect(),
                None => v,
            };
            let (positions, prim_normals, tex_coords) = match &vertices {
                Some(src) => (
                    src.iter().map(|&i| positions[i as usize]).collect(),
                    prim_normals.map(|n| src.iter().map(|&i| n[i as usize]).collect()),
                    tex_coords.map(gather),
                ),
                None => (positions, prim_normals, tex_coords),
            };
            let count = positions.len();
            let base = mesh.positions.len();
            if base + count > MAX_TRIANGLES
                || mesh.triangles.len() + indices.len() / 3 > MAX_TRIANGLES
            {
                return Err(ObjError::whole_file(format!(
                    "the mesh is too large: more than {MAX_TRIANGLES} vertices or triangles"
                )));
            }
            mesh.positions.extend(positions);
            match prim_normals {
                Some(n) if self.all_normals => self.normals.extend(n),
                _ => self.all_normals = false,
            }
            match prim_tangents {
                Some(t) => {
                    // Zero (no tangent: the shader's per-triangle frame) for the earlier vertices.
                    self.tangents.resize(base, [0.0; 4]);
                    self.tangents.extend(t);
                }
                None if !self.tangents.is_empty() => self.tangents.resize(base + count, [0.0; 4]),
                None => {}
            }
            match tex_coords {
                Some(t) => {
                    self.uvs.extend(t);
                    self.any_uvs = true;
                }
                None => {
                    self.uvs.extend(std::iter::repeat_n([0.0, 0.0], count));
                    let m = p.material();
                    let pbr = m.pbr_metallic_roughness();
                    if pbr.base_color_texture().is_some()
                        || pbr.metallic_roughness_texture().is_some()
                        || m.emissive_texture().is_some()
                        || m.normal_texture().is_some()
                    {
                        notes.add(format!(
                            "{at} has no TEXCOORD_{set} but its material has textures: they are read at uv (0, 0) there"
                        ));
                    }
                }
            }
            let material = p.material().index().map(|k| k as u32);
            let before = mesh.triangles.len();
            mesh.triangles.extend(indices.chunks_exact(3).map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|v| v + base as u32);
                if mirrors { [a, c, b] } else { [a, b, c] }
            }));
            mesh.face_materials
                .extend(std::iter::repeat_n(material, mesh.triangles.len() - before));
        }
        Ok(())
    }

    /// The mesh gathered: its normals where every primitive had them, its texture coordinates where
    /// `uvs` (some primitive of the file had them), its tangents where a primitive had them.
    fn finish(mut self, uvs: bool, notes: &mut Notes) -> ObjMesh {
        let mut mesh = std::mem::take(&mut self.mesh);
        if !self.all_normals && !self.normals.is_empty() {
            notes.add(
                "some primitives have NORMAL and some do not: the file's normals are not used (vkpath \
                 computes normals from the triangles instead)"
                    .into(),
            );
        }
        mesh.normals = (self.all_normals && self.normals.len() == mesh.positions.len())
            .then_some(self.normals);
        if !self.tangents.is_empty() {
            self.tangents.resize(mesh.positions.len(), [0.0; 4]);
            mesh.tangents = Some(self.tangents);
        }
        // glTF's texture v runs down from the top of the image; the OBJ convention (and vkpath's
        // sampling) has v up from the bottom.
        mesh.uvs = (uvs && self.uvs.len() == mesh.positions.len())
            .then(|| self.uvs.into_iter().map(|[u, v]| [u, 1.0 - v]).collect());
        mesh
    }
}

/// The glTF file's buffers: the GLB's BIN chunk, data URIs (base64) and files beside the glTF. Instead of
/// the `gltf` crate's `import_buffers`, which reads whatever a URI names to its end (`/dev/zero` never
/// ends) and panics on a percent-escape that is not UTF-8: a file is read by [`crate::memory::read_file`]
/// (a regular file the machine's memory can hold), and must hold at least the buffer's byteLength.
fn load_buffers(
    doc: &gltf::Document,
    dir: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let what = format!("buffers[{}]", buffer.index());
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| format!("{what} is the GLB's BIN chunk, and the file has none"))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                let encoded = uri.split_once(";base64,").map(|(_, d)| d).ok_or_else(|| {
                    format!("{what} is a data URI that is not base64 (\"data:...;base64,...\")")
                })?;
                base64::Engine::decode(&base64::engine::general_purpose::STANDARD, encoded)
                    .map_err(|e| format!("{what} is a data URI whose base64 is not valid: {e}"))?
            }
            gltf::buffer::Source::Uri(uri) => {
                let name = uri
                    .strip_prefix("file://")
                    .or_else(|| uri.strip_prefix("file:"))
                    .unwrap_or(uri);
                if name.contains(':') && !uri.starts_with("file:") {
                    return Err(format!("{what}'s uri \"{uri}\" is not a file or data URI"));
                }
                let path = dir.join(percent_decode(name));
                crate::memory::read_file(&path)
                    .map_err(|e| format!("{what}: cannot read {}: {e}", path.display()))?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "{what} holds {} bytes, less than its byteLength {}",
                data.len(),
                buffer.length()
            ));
        }
        // The reader reads 4-byte components: glTF aligns buffers to 4 bytes.
        data.resize(data.len().next_multiple_of(4), 0);
        out.push(data);
    }
    Ok(out)
}

/// A primitive re-indexed with MikkTSpace tangents: its vertices (each the index of its source vertex:
/// a source vertex whose corners got different tangents is split, one vertex per tangent), their
/// tangents (xyz, and w = +-1, the bitangent's sign: B = w cross(N, T)), and the triangles' new indices.
struct SplitTangents {
    vertices: Vec<u32>,
    tangents: Vec<[f32; 4]>,
    indices: Vec<u32>,
}

/// Tangents by MikkTSpace (Mikkelsen, "Simulation of Wrinkled Surfaces Revisited", 2008: the algorithm
/// glTF 2.0 §3.7.2.1 asks clients to use when TANGENT is absent, and that the sample models' normal maps
/// are baked against), through `bevy_mikktspace`, a port that gives the reference implementation's bits.
/// It yields a tangent per triangle corner; corners of one vertex that disagree (uv seams, mirrored uvs)
/// split it. A corner it leaves without one (a degenerate triangle with no neighbour) gets zero: the
/// shader's per-triangle frame there.
fn mikktspace_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[[f32; 2]],
    indices: &[u32],
) -> SplitTangents {
    struct Geometry<'a> {
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        uvs: &'a [[f32; 2]],
        indices: &'a [u32],
        corners: Vec<[f32; 4]>,
    }
    impl bevy_mikktspace::Geometry for Geometry<'_> {
        fn num_faces(&self) -> usize {
            self.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.indices[face * 3 + vert] as usize].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.normals[self.indices[face * 3 + vert] as usize].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.indices[face * 3 + vert] as usize]
        }
        fn set_tangent(
            &mut self,
            tangent: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            self.corners[face * 3 + vert] = tangent.map_or([0.0; 4], |t| t.tangent_encoded());
        }
    }
    let mut g = Geometry {
        positions,
        normals,
        uvs,
        indices,
        corners: vec![[0.0; 4]; indices.len()],
    };
    // (The crate's error type has no values: generation cannot fail.)
    let _ = bevy_mikktspace::generate_tangents(&mut g);
    let mut out = SplitTangents {
        vertices: Vec::with_capacity(positions.len()),
        tangents: Vec::with_capacity(positions.len()),
        indices: Vec::with_capacity(indices.len()),
    };
    let mut seen: std::collections::HashMap<(u32, [u32; 4]), u32> =
        std::collections::HashMap::with_capacity(positions.len());
    for (&source, tangent) in indices.iter().zip(&g.corners) {
        let key = (source, tangent.map(f32::to_bits));
        let next = out.vertices.len() as u32;
        let index = *seen.entry(key).or_insert(next);
        if index == next {
            out.vertices.push(source);
            out.tangents.push(*tangent);
        }
        out.indices.push(index);
    }
    out
}

/// An attribute's elements as f32 (the accessor checked by `check_accessors`; sparse accessors
/// included, through the gltf crate's iterator): floats as they are; KHR_mesh_quantization's integers
/// as their values, or normalized (glTF 2.0 §3.11: c / 255, c / 65535 unsigned, max(c / 127, -1),
/// max(c / 32767, -1) signed). The node's transform, which the extension relies on to scale them back,
/// applies afterwards. `None` for another component type.
fn read_attribute<const N: usize>(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Option<Vec<[f32; N]>>
where
    [f32; N]: gltf::accessor::Item,
    [i8; N]: gltf::accessor::Item,
    [u8; N]: gltf::accessor::Item,
    [i16; N]: gltf::accessor::Item,
    [u16; N]: gltf::accessor::Item,
{
    use gltf::accessor::{DataType, Iter};
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d[..]);
    let normalized = a.normalized();
    fn convert<T: Copy, const N: usize>(
        it: impl Iterator<Item = [T; N]>,
        to_f32: impl Fn(T) -> f32,
        normalized: bool,
        scale: f32,
        min: f32,
    ) -> Vec<[f32; N]> {
        it.map(|v| {
            v.map(|c| {
                let x = to_f32(c);
                if normalized { (x / scale).max(min) } else { x }
            })
        })
        .collect()
    }
    Some(match a.data_type() {
        DataType::F32 => Iter::<[f32; N]>::new(a.clone(), get)?.collect(),
        DataType::I8 => convert(
            Iter::<[i8; N]>::new(a.clone(), get)?,
            f32::from,
            normalized,
            127.0,
            -1.0,
        ),
        DataType::U8 => convert(
            Iter::<[u8; N]>::new(a.clone(), get)?,
            f32::from,
            normalized,
            255.0,
            0.0,
        ),
        DataType::I16 => convert(
            Iter::<[i16; N]>::new(a.clone(), get)?,
            f32::from,
            normalized,
            32767.0,
            -1.0,
        ),
        DataType::U16 => convert(
            Iter::<[u16; N]>::new(a.clone(), get)?,
            f32::from,
            normalized,
            65535.0,
            0.0,
        ),
        DataType::U32 => return None,
    })
}

/// Checks every accessor primitive `p` is read through (POSITION, NORMAL, TANGENT, TEXCOORD_n, indices) before
/// the gltf crate's reader touches it: the component type and shape the reader assumes, a stride at least
/// an element, and every element inside its buffer view, every view inside its buffer (glTF 2.0 §3.6.2).
/// The reader itself stops early at a view that is too short, which used to render a mesh with faces
/// missing and no word (7 indices in a 12-byte view). `at` names the primitive (`meshes[0].primitives[0]`).
fn check_accessors(
    p: &gltf::Primitive,
    buffers: &[Vec<u8>],
    at: &str,
    quantized: bool,
) -> Result<(), String> {
    use DataType::{F32, I8, I16, U8, U16, U32};
    use gltf::Semantic;
    use gltf::accessor::{DataType, Dimensions};
    // glTF 2.0 §3.7.2.1, and with KHR_mesh_quantization its integer forms (normals normalized).
    let (position, normal, uv): (&[DataType], &[DataType], &[DataType]) = if quantized {
        (
            &[F32, I8, U8, I16, U16],
            &[F32, I8, I16],
            &[F32, I8, U8, I16, U16],
        )
    } else {
        (&[F32], &[F32], &[F32, U8, U16])
    };
    let index = &[U8, U16, U32][..];
    let mut read: Vec<(String, gltf::Accessor, Dimensions, &[DataType])> = Vec::new();
    for (semantic, a) in p.attributes() {
        let (dims, types) = match semantic {
            Semantic::Positions => (Dimensions::Vec3, position),
            Semantic::Normals => (Dimensions::Vec3, normal),
            Semantic::TexCoords(_) => (Dimensions::Vec2, uv),
            Semantic::Tangents => (Dimensions::Vec4, normal),
            _ => continue,
        };
        read.push((
            format!("{at}.attributes.{}", semantic.to_string()),
            a,
            dims,
            types,
        ));
    }
    // glTF 2.0 §3.7.2.1: a primitive's attributes all have the same count (one element per vertex).
    if let Some((first, first_a, ..)) = read.first()
        && let Some((other, a, ..)) = read.iter().find(|(_, a, ..)| a.count() != first_a.count())
    {
        return Err(format!(
            "{other} (accessors[{}]) has {} elements and {first} (accessors[{}]) {}: a primitive's \
             attributes must have one element per vertex each",
            a.index(),
            a.count(),
            first_a.index(),
            first_a.count()
        ));
    }
    if let Some(a) = p.indices() {
        read.push((format!("{at}.indices"), a, Dimensions::Scalar, index));
    }
    for (what, a, dims, types) in read {
        let what = format!("{what} (accessors[{}])", a.index());
        if a.dimensions() != dims || !types.contains(&a.data_type()) {
            return Err(format!(
                "{what} is {:?} of {:?}, where glTF requires {dims:?} of {}",
                a.dimensions(),
                a.data_type(),
                types
                    .iter()
                    .map(|t| format!("{t:?}"))
                    .collect::<Vec<_>>()
                    .join(" or ")
            ));
        }
        if a.count() == 0 {
            return Err(format!("{what} has a count of 0 (glTF's minimum is 1)"));
        }
        let size = a.size();
        let mut spans = Vec::new();
        if let Some(view) = a.view() {
            spans.push(("", view, a.offset(), a.count(), size));
        }
        if let Some(sparse) = a.sparse() {
            let (i, v) = (sparse.indices(), sparse.values());
            let n = sparse.count();
            spans.push((
                " sparse indices",
                i.view(),
                i.offset(),
                n,
                i.index_type().size(),
            ));
            spans.push((" sparse values", v.view(), v.offset(), n, size));
        }
        for (part, view, offset, count, size) in spans {
            if count == 0 {
                return Err(format!("{what}{part}: a count of 0 (glTF's minimum is 1)"));
            }
            let stride = view.stride().unwrap_or(size);
            let buffer = buffers.get(view.buffer().index()).map_or(0, |d| d.len());
            let view_end = view.offset().checked_add(view.length());
            if view_end.is_none_or(|e| e > buffer) {
                return Err(format!(
                    "{what}{part}: bufferViews[{}] (bytes {} to {}) runs past the end of buffers[{}] ({buffer} bytes)",
                    view.index(),
                    view.offset(),
                    view.offset() as u128 + view.length() as u128,
                    view.buffer().index()
                ));
            }
            if stride < size {
                return Err(format!(
                    "{what}{part}: bufferViews[{}]'s byteStride {stride} is less than an element ({size} bytes)",
                    view.index()
                ));
            }
            // The last element ends at offset + stride x (count - 1) + size.
            let needed = (count as u128 - 1) * stride as u128 + size as u128 + offset as u128;
            if needed > view.length() as u128 {
                return Err(format!(
                    "{what}{part}: {count} elements of {size} bytes (stride {stride}) from byte {offset} need \
                     {needed} bytes of bufferViews[{}], which holds {}",
                    view.index(),
                    view.length()
                ));
            }
        }
    }
    Ok(())
}

/// What the reader could not use, each said once.
#[derive(Default)]
struct Notes(Vec<String>);

impl Notes {
    fn add(&mut self, note: String) {
        if !self.0.contains(&note) {
            self.0.push(note);
        }
    }
}

/// A glTF material as vkpath maps it (the PBR fields of [`FileMaterial`] and its textures).
fn material(m: gltf::Material, images: &mut Images, notes: &mut Notes) -> FileMaterial {
    let name = m.name().map_or_else(
        || format!("material{}", m.index().unwrap_or(0)),
        str::to_owned,
    );
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let mut out = FileMaterial {
        name: name.clone(),
        diffuse: Some([r, g, b]),
        emission: Some(m.emissive_factor().map(|e| e * strength)),
        roughness: Some(pbr.roughness_factor()),
        metallic: Some(pbr.metallic_factor()),
        ..FileMaterial::default()
    };
    out.layers = layers(&m, &name, notes);
    // glTF multiplies each texture by its factor (base colour, emissive, metallic and roughness); the
    // material holds the factors and the shader multiplies.
    out.maps.base_color_factor = true;
    // Occlusion is what a path tracer computes: its texture is read past, with a note.
    if m.occlusion_texture().is_some() {
        notes.add(format!(
            "{}material \"{name}\": occlusionTexture is read past (a path tracer computes occlusion)",
            super::NOTE
        ));
    }
    // Alpha coverage (§3.9.4): MASK cuts out where factor x texel alpha is below alphaCutoff (default
    // 0.5); BLEND lets light through with probability 1 - alpha (stochastic transparency: the expected
    // image of alpha blending, in any order of surfaces).
    let alpha = pbr.base_color_factor()[3];
    out.maps.alpha = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => None,
        gltf::material::AlphaMode::Mask => Some((alpha, Some(m.alpha_cutoff().unwrap_or(0.5)))),
        gltf::material::AlphaMode::Blend => Some((alpha, None)),
    };
    let set = uv_set(&m);
    let mut texture = |what: &str,
                       tex: gltf::Texture,
                       tex_coord: u32,
                       transform: Option<&gltf::json::Value>| {
        let (read, tex_coord) = texture_read(&tex, transform, tex_coord, &mut |n| {
            notes.add(format!("material \"{name}\": its {what} texture: {n}"))
        });
        if tex_coord != set {
            notes.add(format!(
                "material \"{name}\": its {what} texture uses TEXCOORD_{tex_coord}, the others \
                 TEXCOORD_{set}: it is read at TEXCOORD_{set} (a mesh carries one set of texture coordinates)"
            ));
        }
        let image = images
            .get(tex.source())
            .map_err(|e| {
                notes.add(format!(
                    "material \"{name}\": its {what} texture: {e}; it is not used"
                ))
            })
            .ok();
        (image, read)
    };
    const TRANSFORM: &str = "KHR_texture_transform";
    if let Some(info) = pbr.base_color_texture() {
        let t = info.extension_value(TRANSFORM);
        (out.texture, out.maps.base_color_read) =
            texture("base colour", info.texture(), info.tex_coord(), t);
    }
    if let Some(info) = m.emissive_texture() {
        let t = info.extension_value(TRANSFORM);
        (out.maps.emissive, out.maps.emissive_read) =
            texture("emissive", info.texture(), info.tex_coord(), t);
    }
    if let Some(info) = pbr.metallic_roughness_texture() {
        let t = info.extension_value(TRANSFORM);
        (
            out.maps.metallic_roughness,
            out.maps.metallic_roughness_read,
        ) = texture("metallic-roughness", info.texture(), info.tex_coord(), t);
    }
    if let Some(info) = m.normal_texture() {
        let t = info.extension_value(TRANSFORM);
        (out.maps.normal, out.maps.normal_read) =
            texture("normal", info.texture(), info.tex_coord(), t);
        out.maps.normal_scale = info.scale();
    }
    out
}

/// The Khronos PBR extensions of material `m` (`name`) as vkpath's layers (bsdfs/gltf_pbr.wgsl has the
/// model): each factor with its extension's default, a value that is not a number or out of its range
/// replaced by the default or clamped, with a warning. Their textures are not read (a warning each: the
/// factor is used alone), except KHR_materials_volume's thicknessTexture, which the extension tells path
/// tracers to ignore (they measure the thickness along the ray): a note. attenuationDistance is a
/// world-space distance (the extension says so, unlike thicknessFactor's mesh space): node scales leave it
/// alone.
fn layers(m: &gltf::Material, name: &str, notes: &mut Notes) -> GltfLayers {
    let mut out = GltfLayers::NONE;
    let extension = |ext: &str, notes: &mut Notes| {
        let value = m.extension_value(ext)?.as_object()?.clone();
        for (key, v) in &value {
            if key.ends_with("Texture") && v.is_object() {
                let message = if key == "thicknessTexture" {
                    format!(
                        "{}material \"{name}\": {ext}'s thicknessTexture is read past (a path tracer \
                         measures the thickness along each ray)",
                        super::NOTE
                    )
                } else {
                    format!(
                        "material \"{name}\": {ext}'s {key} is not read; its factor is used alone"
                    )
                };
                notes.add(message);
            }
        }
        Some(value)
    };
    let number = |obj: &gltf::json::Value,
                  ext: &str,
                  key: &str,
                  range: (f32, f32),
                  notes: &mut Notes| {
        let default = match (ext, key) {
            (_, "ior") => 1.5,
            (_, "specularFactor") => 1.0,
            (_, "attenuationDistance") => f32::INFINITY,
            _ => 0.0,
        };
        let Some(v) = obj.get(key) else {
            return default;
        };
        match v.as_f64().map(|x| x as f32) {
            Some(x) if x.is_nan() => default,
            Some(x) if x >= range.0 && x <= range.1 => x,
            Some(x) => {
                notes.add(format!(
                    "material \"{name}\": {ext}.{key} = {x} is outside [{}, {}]; clamped",
                    range.0, range.1
                ));
                x.clamp(range.0, range.1)
            }
            None => {
                notes.add(format!(
                    "material \"{name}\": {ext}.{key} is not a number; its default {default} is used"
                ));
                default
            }
        }
    };
    let color = |obj: &gltf::json::Value,
                 ext: &str,
                 key: &str,
                 default: Vec3,
                 max: f32,
                 notes: &mut Notes| {
        let Some(v) = obj.get(key) else {
            return default;
        };
        let values: Option<Vec<f32>> = v
            .as_array()
            .filter(|a| a.len() == 3)
            .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect());
        match values {
            Some(c) if c.iter().all(|x| x.is_finite()) => {
                let clamped = Vec3::from_slice(&c).clamp(Vec3::ZERO, Vec3::splat(max));
                if clamped != Vec3::from_slice(&c) {
                    notes.add(format!(
                        "material \"{name}\": {ext}.{key} has components outside [0, {max}]; clamped"
                    ));
                }
                clamped
            }
            _ => {
                notes.add(format!(
                    "material \"{name}\": {ext}.{key} is not three numbers; its default is used"
                ));
                default
            }
        }
    };
    let object = |v: serde_json::Map<String, gltf::json::Value>| gltf::json::Value::Object(v);
    const IOR: &str = "KHR_materials_ior";
    if let Some(v) = extension(IOR, notes).map(object) {
        // ior 0 is the specification's way to give f0 = 1 (a specular-glossiness conversion).
        out.ior = number(&v, IOR, "ior", (0.0, f32::MAX), notes);
    }
    const SPECULAR: &str = "KHR_materials_specular";
    if let Some(v) = extension(SPECULAR, notes).map(object) {
        out.specular = number(&v, SPECULAR, "specularFactor", (0.0, 1.0), notes);
        out.specular_color = color(
            &v,
            SPECULAR,
            "specularColorFactor",
            Vec3::ONE,
            f32::MAX,
            notes,
        );
    }
    const TRANSMISSION: &str = "KHR_materials_transmission";
    if let Some(v) = extension(TRANSMISSION, notes).map(object) {
        out.transmission = number(&v, TRANSMISSION, "transmissionFactor", (0.0, 1.0), notes);
    }
    const VOLUME: &str = "KHR_materials_volume";
    if let Some(v) = extension(VOLUME, notes).map(object) {
        // thicknessFactor 0 (the default) is a thin surface: the extension has no effect.
        if number(&v, VOLUME, "thicknessFactor", (0.0, f32::MAX), notes) > 0.0 {
            let distance = number(
                &v,
                VOLUME,
                "attenuationDistance",
                (f32::MIN_POSITIVE, f32::INFINITY),
                notes,
            );
            let c =
                color(&v, VOLUME, "attenuationColor", Vec3::ONE, 1.0, notes).max(Vec3::splat(1e-6));
            out.volume = Some(if distance.is_finite() {
                -Vec3::new(c.x.ln(), c.y.ln(), c.z.ln()) / distance
            } else {
                Vec3::ZERO
            });
        }
    }
    const CLEARCOAT: &str = "KHR_materials_clearcoat";
    if let Some(v) = extension(CLEARCOAT, notes).map(object) {
        out.clearcoat = number(&v, CLEARCOAT, "clearcoatFactor", (0.0, 1.0), notes);
        out.clearcoat_roughness =
            number(&v, CLEARCOAT, "clearcoatRoughnessFactor", (0.0, 1.0), notes);
    }
    const SHEEN: &str = "KHR_materials_sheen";
    if let Some(v) = extension(SHEEN, notes).map(object) {
        out.sheen_color = color(&v, SHEEN, "sheenColorFactor", Vec3::ZERO, 1.0, notes);
        out.sheen_roughness = number(&v, SHEEN, "sheenRoughnessFactor", (0.0, 1.0), notes);
    }
    out
}

/// The texture coordinate set (TEXCOORD_n) material `m`'s textures read, each textureInfo's texCoord or
/// its KHR_texture_transform's: the one they share, TEXCOORD_0 when they have none or read different
/// sets (vkpath's meshes carry one set: the others are then read at TEXCOORD_0, with a note each in
/// `material`). The occlusion texture is read past and does not count.
fn uv_set(m: &gltf::Material) -> u32 {
    const TRANSFORM: &str = "KHR_texture_transform";
    // A textureInfo's set: its texCoord, unless its transform gives another.
    fn set(k: u32, transform: Option<&gltf::json::Value>) -> u32 {
        transform
            .and_then(|t| t.get("texCoord"))
            .and_then(|v| v.as_u64())
            .map_or(k, |k| k as u32)
    }
    let pbr = m.pbr_metallic_roughness();
    let sets: Vec<u32> = [
        pbr.base_color_texture()
            .map(|i| set(i.tex_coord(), i.extension_value(TRANSFORM))),
        pbr.metallic_roughness_texture()
            .map(|i| set(i.tex_coord(), i.extension_value(TRANSFORM))),
        m.emissive_texture()
            .map(|i| set(i.tex_coord(), i.extension_value(TRANSFORM))),
        m.normal_texture()
            .map(|i| set(i.tex_coord(), i.extension_value(TRANSFORM))),
    ]
    .into_iter()
    .flatten()
    .collect();
    match sets.first() {
        Some(&first) if sets.iter().all(|&k| k == first) => first,
        _ => 0,
    }
}

/// How a glTF texture is read (a `mesh::TextureRead`), and the texture coordinate set it reads: its
/// sampler's magnification filter (NEAREST, else bilinear: vkpath has no mip levels, so the minification
/// filter does not apply) and wrap mode (wrapS; a different wrapT is a note), and its KHR_texture_transform
/// (`transform`, the extension's JSON; its texCoord overrides the textureInfo's).
///
/// The extension's transform is uv' = T R S uv in glTF's uv space, whose v runs down the image, with
/// S = diag(sx, sy), T the offset (tx, ty) and R = [[cos r, sin r], [-sin r, cos r]]: the rotation as
/// every implementation reads it (three.js, Babylon.js, Blender's importer and the Khronos
/// TextureTransformTest model, whose arrows point at their labels only so), the transpose of the matrix
/// the extension's text prints (KhronosGroup/glTF issue 1563). vkpath's uv has v up, v_vk = 1 - v_gl
/// (F = diag(1, -1) plus (0, 1)), so in vkpath's space the same lookup is F T R S F: its linear part is
/// diag(1, -1) R S diag(1, -1) = R' S with R' = [[cos r, -sin r], [sin r, cos r]], a rotation by +r,
/// and its offset F(T R S (0, 1)) = (tx + sin r sy, 1 - ty - cos r sy). Written as the texture
/// reference's scale (sx, sy), rotation r and that offset.
fn texture_read(
    tex: &gltf::Texture,
    transform: Option<&gltf::json::Value>,
    tex_coord: u32,
    note: &mut dyn FnMut(String),
) -> (super::mesh::TextureRead, u32) {
    use gltf::texture::{MagFilter, WrappingMode};
    let sampler = tex.sampler();
    let wrap = |w: WrappingMode| match w {
        WrappingMode::ClampToEdge => super::texture::Wrap::Clamp,
        WrappingMode::MirroredRepeat => super::texture::Wrap::Mirror,
        WrappingMode::Repeat => super::texture::Wrap::Repeat,
    };
    if sampler.wrap_s() != sampler.wrap_t() {
        note(format!(
            "its sampler wraps s and t differently ({:?}, {:?}); vkpath wraps both as s",
            sampler.wrap_s(),
            sampler.wrap_t()
        ));
    }
    let mut read = super::mesh::TextureRead {
        nearest: sampler.mag_filter() == Some(MagFilter::Nearest),
        wrap: wrap(sampler.wrap_s()),
        ..Default::default()
    };
    let mut tex_coord = tex_coord;
    if let Some(t) = transform {
        let number = |v: Option<&gltf::json::Value>| v.and_then(|x| x.as_f64());
        let pair = |key: &str, default: [f64; 2]| -> [f64; 2] {
            match t.get(key).and_then(|v| v.as_array()) {
                Some(a) if a.len() == 2 => [
                    number(a.first()).unwrap_or(default[0]),
                    number(a.get(1)).unwrap_or(default[1]),
                ],
                _ => default,
            }
        };
        let [tx, ty] = pair("offset", [0.0, 0.0]);
        let [sx, sy] = pair("scale", [1.0, 1.0]);
        let r = number(t.get("rotation")).unwrap_or(0.0);
        if let Some(k) = t.get("texCoord").and_then(|v| v.as_u64()) {
            tex_coord = k as u32;
        }
        let (sin, cos) = r.sin_cos();
        let finite = [tx, ty, sx, sy, r].iter().all(|x| x.is_finite());
        if finite {
            read.scale = [sx as f32, sy as f32];
            read.rotation_deg = r.to_degrees() as f32;
            read.offset = [(tx + sin * sy) as f32, (1.0 - ty - cos * sy) as f32];
        } else {
            note("its KHR_texture_transform is not finite; not applied".into());
        }
    }
    (read, tex_coord)
}

/// The glTF file's images, each decoded once however many textures use it (and so uploaded once).
struct Images<'a> {
    buffers: &'a [Vec<u8>],
    dir: &'a Path,
    loaded: Vec<Option<Result<Arc<Texture>, String>>>,
}

impl Images<'_> {
    /// Image `image` decoded (PNG, JPEG), or why it cannot be used.
    fn get(&mut self, image: gltf::Image) -> Result<Arc<Texture>, String> {
        let k = image.index();
        if self.loaded.len() <= k {
            self.loaded.resize(k + 1, None);
        }
        if let Some(done) = &self.loaded[k] {
            return done.clone();
        }
        let result = match image.source() {
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                match uri.split_once(";base64,") {
                    None => Err("the image is a data URI that is not base64".to_owned()),
                    Some((_, encoded)) => {
                        base64::Engine::decode(&base64::engine::general_purpose::STANDARD, encoded)
                            .map_err(|e| format!("the image's data URI is not valid base64: {e}"))
                            .and_then(|b| {
                                load_texture_bytes(&b, &format!("image {k} (a data URI)"))
                            })
                    }
                }
            }
            gltf::image::Source::Uri { uri, .. } => {
                load_texture(&self.dir.join(percent_decode(uri)))
            }
            gltf::image::Source::View { view, .. } => {
                let data = self.buffers.get(view.buffer().index()).map(|d| &d[..]);
                let range = view.offset()..view.offset().saturating_add(view.length());
                let bytes = data.and_then(|d| d.get(range));
                match bytes {
                    Some(b) => load_texture_bytes(b, &format!("image {}", view.index())),
                    None => Err("its image's buffer view is out of range".to_owned()),
                }
            }
        }
        .map(Arc::new);
        self.loaded[k] = Some(result.clone());
        result
    }
}

/// A URI's %XX escapes decoded (glTF URIs are RFC 3986 references: a space in a file name is `%20`).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::percent_decode;

    #[test]
    fn uris_are_percent_decoded() {
        assert_eq!(percent_decode("my%20texture.png"), "my texture.png");
        assert_eq!(percent_decode("a%2Fb%zz%4"), "a/b%zz%4");
        assert_eq!(percent_decode("%E2%82%AC.png"), "\u{20ac}.png");
    }
}
