//! Shapes: spheres (`[[sphere]]`), rectangles, cubes and disks (`[[triangle]]`s) and OBJ or PLY meshes
//! (`[[mesh]]`), placed by their transforms, with their material and an area emitter's emission.

use super::args::Args;
use super::context::{ORTHO_TOL, Tr};
use super::objects::{Loc, Obj};
use super::toml_out::{num, vec3};
use crate::scene::SceneError;
use crate::scene::toml_text::toml_string;
use glam::{DMat3, DMat4, DVec3, DVec4};

/// Segments of the polygon that stands for Mitsuba's `disk` (see [`disk_triangles`]).
pub const DISK_SEGMENTS: usize = 64;

impl Tr<'_> {
    /// A top-level `<shape>`: a shape, a `shapegroup` (a definition, drawn only through instances: its
    /// shapes are checked here), or an `instance` of one, whose shapes are written again, each placed by
    /// the instance's to_world after its own. A mesh of the group is written once, as a named `[[mesh]]`
    /// at its first instance, and as an `[[instance]]` of that at every later one, so that the renderer
    /// keeps one copy of it (`Scene::instanced`); the group's rectangles, cubes, disks and spheres are
    /// written again at each instance. `index` numbers the shapes written so far (for the materials'
    /// names); the count written is returned.
    pub(super) fn top_level_shape(&mut self, obj: &Obj, index: usize) -> Result<usize, SceneError> {
        match obj.kind.as_str() {
            "shapegroup" => {
                self.shapegroup_members(obj)?;
                Ok(0)
            }
            "instance" => {
                let args = Args::new(obj);
                let groups = args.objects("shape", self.ids)?;
                let xf = args.transform("to_world")?;
                self.finish(&args, &["shape", "to_world"])?;
                let [(group, _)] = groups.as_slice() else {
                    return Err(obj.loc.error(
                        "an instance with other than one shapegroup",
                        "Refer to one shapegroup: <ref id=\"...\"/>.",
                    ));
                };
                if group.kind != "shapegroup" {
                    return Err(group.loc.error(
                        format!("an instance of a {} shape, not of a shapegroup", group.kind),
                        "Put the shape in a <shape type=\"shapegroup\" id=\"...\"> and refer to that.",
                    ));
                }
                let parent = xf.map_or(DMat4::IDENTITY, |(x, _)| x.m);
                let members = self.shapegroup_members(group)?;
                for (i, member) in members.iter().enumerate() {
                    self.shape(member, index + i, parent, true)?;
                }
                Ok(members.len())
            }
            _ => {
                self.shape(obj, index, DMat4::IDENTITY, false)?;
                Ok(1)
            }
        }
    }

    /// The shapes of a shapegroup, refused as Mitsuba refuses them: a shapegroup or instance inside
    /// one, or an emitter (Mitsuba does not instance emitters).
    fn shapegroup_members(&mut self, group: &Obj) -> Result<Vec<std::rc::Rc<Obj>>, SceneError> {
        let args = Args::new(group);
        let members = args.objects("shape", self.ids)?;
        self.finish(&args, &["shape"])?;
        let mut out = Vec::new();
        for (m, _) in members {
            if matches!(m.kind.as_str(), "shapegroup" | "instance") {
                return Err(m.loc.error(
                    format!("a {} inside a shapegroup", m.kind),
                    "Mitsuba instances one level: put the shapes themselves in the group.",
                ));
            }
            if !Args::new(&m).objects("emitter", self.ids)?.is_empty() {
                return Err(m.loc.error(
                    "an emitter inside a shapegroup: Mitsuba does not instance emitters",
                    "Place emitting shapes outside the group.",
                ));
            }
            out.push(m);
        }
        Ok(out)
    }

    /// A shape placed by `parent` x its own to_world (`parent` is an instance's, else the identity);
    /// `in_group`: a shapegroup's member, whose mesh is written once and instanced after.
    fn shape(
        &mut self,
        obj: &Obj,
        index: usize,
        parent: DMat4,
        in_group: bool,
    ) -> Result<(), SceneError> {
        let kind = obj.kind.as_str();
        if !matches!(
            kind,
            "sphere" | "rectangle" | "cube" | "disk" | "obj" | "ply" | "serialized"
        ) {
            return self.unsupported(
                obj,
                "sphere, rectangle, cube, disk, obj, ply and serialized shapes, shapegroups and instances",
            );
        }
        let args = Args::new(obj);
        let bsdf = args.object("bsdf", self.ids)?;
        let emitter = args.object("emitter", self.ids)?;
        let emission = match &emitter {
            None => None,
            Some((e, _)) if e.kind == "area" => {
                let eargs = Args::new(e);
                let radiance = self.emitted(&eargs, "radiance")?;
                self.finish(&eargs, &["radiance"])?;
                Some((radiance, &e.loc))
            }
            Some((e, _)) => {
                return Err(e.loc.error(
                    format!(
                        "an emitter \"{}\" inside a shape: a shape emits through an area emitter",
                        e.kind
                    ),
                    "Use <emitter type=\"area\"> inside the shape.",
                ));
            }
        };
        let xf = args.transform("to_world")?;
        let m = parent * xf.map_or(DMat4::IDENTITY, |(x, _)| x.m);
        let xf_loc = xf.map_or(&obj.loc, |(_, l)| l).clone();
        let flip = args.boolean("flip_normals")?;
        let shape_name = format!("shape{index}-{kind}");
        let (material, texture) = self.material(
            bsdf.as_ref().map(|(b, _)| b),
            emission,
            &shape_name,
            &obj.loc,
        )?;
        let material = toml_string(&material);
        let uv_kind = matches!(kind, "obj" | "ply" | "serialized" | "rectangle" | "cube");
        if texture.is_some() && !uv_kind {
            return Err(obj.loc.error(
                format!("a texture on a {kind}: vkpath textures meshes, rectangles and cubes only, at their uvs (a {kind} has none in vkpath)"),
                "Give the shape a plain colour, or make it a mesh with texture coordinates.",
            ));
        }
        let cx = ShapeCx {
            obj,
            kind,
            args: &args,
            m,
            xf_loc,
            flip,
            material,
            textured: texture.is_some(),
            shape_name,
            in_group,
        };
        match kind {
            "sphere" => self.sphere_shape(cx)?,
            "rectangle" | "cube" | "disk" => {
                self.finish(&args, &["to_world", "flip_normals", "bsdf", "emitter"])?;
                self.flat_shape(cx);
            }
            _ => self.mesh_shape(cx)?,
        }
        Ok(())
    }

    /// A `sphere`: Mitsuba's unit sphere placed by to_world x translate(center) x scale(radius), which
    /// must be a similarity.
    fn sphere_shape(&mut self, cx: ShapeCx<'_>) -> Result<(), SceneError> {
        let ShapeCx {
            obj,
            args,
            m,
            xf_loc,
            flip,
            material,
            ..
        } = cx;
        let loc = Some(&obj.loc);
        // Mitsuba places the unit sphere by to_world x translate(center) x scale(radius).
        let center = args.vector("center")?.map_or(DVec3::ZERO, |(c, _)| c);
        let radius = match args.float("radius")? {
            None => 1.0,
            Some((r, _)) if r > 0.0 => r,
            Some((r, l)) => {
                return Err(l.error(
                    format!("radius = {r}: a sphere's radius must be > 0"),
                    "Give a positive radius.",
                ));
            }
        };
        if let Some((true, l)) = flip {
            return Err(l.error(
                "flip_normals on a sphere: vkpath's sphere normals point outwards",
                "Remove flip_normals.",
            ));
        }
        self.finish(
            args,
            &[
                "center",
                "radius",
                "to_world",
                "flip_normals",
                "bsdf",
                "emitter",
            ],
        )?;
        let full = m * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
        let (c, r) = similarity(&full).ok_or_else(|| {
            xf_loc.error(
                "the sphere's to_world scales unevenly or shears it: an ellipsoid, which vkpath's spheres cannot be",
                "Scale spheres uniformly (or give radius).",
            )
        })?;
        let o = &mut self.out_shapes;
        o.line("", None);
        o.line("[[sphere]]", loc);
        o.line(format!("center   = {}", vec3(c)), loc);
        o.line(format!("radius   = {}", num(r)), loc);
        o.line(format!("material = {material}"), loc);
        Ok(())
    }

    /// A `rectangle`, `cube` or `disk`: its triangles placed (with Mitsuba's uvs when textured).
    fn flat_shape(&mut self, cx: ShapeCx<'_>) {
        let ShapeCx {
            obj,
            kind,
            m,
            flip,
            material,
            textured,
            ..
        } = cx;
        let loc = Some(&obj.loc);
        // Textured: Mitsuba's own vertices with their uvs (rectangle: (x + 1, y + 1) / 2; the cube
        // its 24-vertex mesh); else the plain triangles (the same surfaces).
        let (local, uvs) = match (kind, textured) {
            ("rectangle", false) => (rectangle_triangles(), None),
            ("cube", false) => (cube_triangles(), None),
            ("rectangle", true) => {
                let t = rectangle_triangles();
                let uv = t
                    .iter()
                    .map(|f| f.map(|p| [(p.x + 1.0) / 2.0, (p.y + 1.0) / 2.0]))
                    .collect();
                (t, Some(uv))
            }
            ("cube", true) => {
                let (t, uv) = mitsuba_cube();
                (t, Some(uv))
            }
            _ => (disk_triangles(), None),
        };
        // Mitsuba's rectangle and disk take their normal through the inverse transpose, so a
        // mirroring to_world (det < 0) keeps it on the side that +z maps to, while the winding of
        // the mirrored vertices turns to the other side: reverse it to keep the emitting side.
        // (The cube is a mesh there, whose normals follow the winding.)
        let det = DMat3::from_mat4(m).determinant();
        let reverse = (det < 0.0 && kind != "cube") != flip.is_some_and(|(f, _)| f);
        let o = &mut self.out_shapes;
        for (k, [a, b, c]) in local.into_iter().enumerate() {
            let [a, b, c] = [a, b, c].map(|p| m.transform_point3(p));
            let (b, c) = if reverse { (c, b) } else { (b, c) };
            o.line("", None);
            o.line("[[triangle]]", loc);
            o.line(
                format!("vertices = [{}, {}, {}]", vec3(a), vec3(b), vec3(c)),
                loc,
            );
            o.line(format!("material = {material}"), loc);
            if let Some(uvs) = &uvs {
                let [ua, ub, uc]: [[f64; 2]; 3] = uvs[k];
                let (ub, uc) = if reverse { (uc, ub) } else { (ub, uc) };
                let uv = |[u, v]: [f64; 2]| format!("[{}, {}]", num(u), num(v));
                o.line(
                    format!("uv       = [{}, {}, {}]", uv(ua), uv(ub), uv(uc)),
                    loc,
                );
            }
        }
    }

    /// An `obj`, `ply` or `serialized` mesh: a `[[mesh]]` of the file, placed; a shapegroup's mesh
    /// written once and instanced after.
    fn mesh_shape(&mut self, cx: ShapeCx<'_>) -> Result<(), SceneError> {
        let ShapeCx {
            obj,
            kind,
            args,
            m,
            xf_loc,
            flip,
            material,
            textured,
            shape_name,
            in_group,
        } = cx;
        let loc = Some(&obj.loc);
        let Some((name, floc)) = args.string("filename")? else {
            return Err(obj.loc.error(
                format!("a {kind} shape needs a filename"),
                "Give <string name=\"filename\" value=\"mesh.obj\"/>.",
            ));
        };
        let file = self.file(name, floc);
        let face_normals = args.boolean("face_normals")?.is_some_and(|(f, _)| f);
        if let Some((true, l)) = flip {
            return Err(l.error(
                "flip_normals on a mesh: vkpath's [[mesh]] keeps the file's winding",
                "Reverse the faces in the mesh file instead.",
            ));
        }
        let serialized = kind == "serialized";
        let flip_uv = if serialized {
            None
        } else {
            args.boolean("flip_tex_coords")?
        };
        // Which mesh of a .serialized file (Mitsuba's default 0).
        let index_arg = if serialized {
            args.int("shape_index")?
        } else {
            None
        };
        let shape_index = match index_arg {
            None => None,
            Some((i, l)) => Some(u32::try_from(i).map_err(|_| {
                l.error(
                    format!("shape_index = {i}: a mesh's index in the file, from 0"),
                    "Give 0 for the file's first mesh.",
                )
            })?),
        };
        if textured {
            // vkpath's uv (0, 0) is the image's bottom-left corner: Mitsuba's OBJ reader with
            // flip_tex_coords = true (its default). Its PLY reader does not flip; nor does its
            // serialized reader, whose v vkpath's own turns over (super::super::serialized).
            let flipped = serialized || flip_uv.map_or(kind == "obj", |(f, _)| f);
            if !flipped {
                return Err(obj.loc.error(
                    "a texture on a mesh whose texture coordinates Mitsuba does not flip (a PLY, or flip_tex_coords = false): vkpath's uv (0, 0) is the image's bottom-left corner",
                    "Use an OBJ with flip_tex_coords true (the default).",
                ));
            }
        }
        self.finish(
            args,
            &[
                "filename",
                "face_normals",
                if serialized {
                    "shape_index"
                } else {
                    "flip_tex_coords"
                },
                "to_world",
                "flip_normals",
                "bsdf",
                "emitter",
            ],
        )?;
        // A similarity as scale / rotate / translate; any other transform that keeps the
        // handedness as a `matrix`. A mirror is refused: Mitsuba keeps a mesh's face normals on
        // the side its winding gives (so a one-sided emitter turns around), where vkpath's
        // `matrix` keeps the front a face had before (pbrt-v4's convention).
        let srt = placement(&m);
        if srt.is_none() && DMat3::from_mat4(m).determinant() <= 0.0 {
            return Err(xf_loc.error(
                "the mesh's to_world mirrors it (or is singular)",
                "Mitsuba turns a mirrored mesh's faces around and vkpath keeps their fronts: bake the mirror into the mesh file.",
            ));
        }
        // A shapegroup's mesh at its second and later instances: one more placement of the
        // mesh written at the first.
        let key = obj as *const Obj as usize;
        if let Some(mesh) = self.shared_meshes.get(&key).filter(|_| in_group) {
            let mesh = toml_string(mesh);
            let o = &mut self.out_shapes;
            o.line("", None);
            o.line("[[instance]]", loc);
            o.line(format!("mesh      = {mesh}"), loc);
            write_placement(o, srt, &m, &xf_loc);
            return Ok(());
        }
        let file_ref = self.refer(&file);
        let o = &mut self.out_shapes;
        o.line("", None);
        o.line("[[mesh]]", loc);
        if in_group {
            o.line(format!("name      = {}", toml_string(&shape_name)), loc);
            self.shared_meshes.insert(key, shape_name.clone());
        }
        let o = &mut self.out_shapes;
        o.line(format!("obj       = {file_ref}"), Some(floc));
        if let Some(i) = shape_index {
            o.line(format!("shape_index = {i}"), loc);
        }
        o.line(format!("material  = {material}"), loc);
        write_placement(o, srt, &m, &xf_loc);
        o.line(format!("smooth    = {}", !face_normals), loc);
        Ok(())
    }
}

/// What the translation of one shape's kind needs: the shape, its parameters, its placement (to_world
/// after the parent's) and where it was given, `flip_normals`, its material's TOML name, whether the
/// material reads a texture, the shape's name and whether it is a shapegroup's member.
struct ShapeCx<'a> {
    obj: &'a Obj,
    kind: &'a str,
    args: &'a Args<'a>,
    m: DMat4,
    xf_loc: Loc,
    flip: Option<(bool, &'a Loc)>,
    material: String,
    textured: bool,
    shape_name: String,
    in_group: bool,
}

/// A mesh's placement in a `[[mesh]]` or `[[instance]]`: `srt` (scale, rotate, translate) when the
/// transform `m` is a similarity ([`placement`]), else `matrix`, its rows.
fn write_placement(
    o: &mut super::toml_out::TomlOut,
    srt: Option<(f64, DVec3, DVec3)>,
    m: &DMat4,
    loc: &super::objects::Loc,
) {
    let loc = Some(loc);
    match srt {
        Some((scale, rotate, translate)) => {
            o.line(format!("scale     = {}", num(scale)), loc);
            o.line(format!("rotate    = {}", vec3(rotate)), loc);
            o.line(format!("translate = {}", vec3(translate)), loc);
        }
        None => {
            let rows: Vec<String> = (0..4)
                .map(|i| {
                    let r = m.row(i);
                    format!("{}, {}, {}, {}", num(r.x), num(r.y), num(r.z), num(r.w))
                })
                .collect();
            o.line(format!("matrix    = [{}]", rows.join(",  ")), loc);
        }
    }
}

/// A transform's uniform scale as (centre, radius) of the unit sphere it maps: None unless its 3 x 3 part
/// is a rotation (or reflection) times one positive scale.
fn similarity(m: &DMat4) -> Option<(DVec3, f64)> {
    let (x, y, z) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    let s = x.length();
    let ok = s > 0.0
        && s.is_finite()
        && (y.length() - s).abs() <= ORTHO_TOL * s
        && (z.length() - s).abs() <= ORTHO_TOL * s
        && x.dot(y).abs() <= ORTHO_TOL * s * s
        && x.dot(z).abs() <= ORTHO_TOL * s * s
        && y.dot(z).abs() <= ORTHO_TOL * s * s
        && m.row(3).abs_diff_eq(DVec4::W, 1e-9);
    ok.then(|| (m.w_axis.truncate(), s))
}

/// A mesh transform as vkpath's [[mesh]] placement: p -> R (s p) + t with R = Rz(c) Ry(b) Rx(a) (degrees
/// about x, then y, then z). From R = M3 / s (a proper rotation):
/// R = [[cb cc, sa sb cc - ca sc, ca sb cc + sa sc], [cb sc, sa sb sc + ca cc, ca sb sc - sa cc],
///      [-sb, sa cb, ca cb]], so b = asin(-R20), a = atan2(R21, R22), c = atan2(R10, R00); at the gimbal
/// lock (cb = 0) only a - c (or a + c) is defined: a = 0, c = atan2(-R01, R11).
fn placement(m: &DMat4) -> Option<(f64, DVec3, DVec3)> {
    let (_, s) = similarity(m)?;
    let r = DMat3::from_mat4(*m) / s;
    if r.determinant() < 0.0 {
        return None;
    }
    // glam's DMat3 is column-major: r.col(j)[i] is row i, column j.
    let e = |i: usize, j: usize| r.col(j)[i];
    let sb = (-e(2, 0)).clamp(-1.0, 1.0);
    let b = sb.asin();
    let (a, c) = if sb.abs() < 1.0 - 1e-9 {
        (e(2, 1).atan2(e(2, 2)), e(1, 0).atan2(e(0, 0)))
    } else {
        (0.0, (-e(0, 1)).atan2(e(1, 1)))
    };
    Some((
        s,
        DVec3::new(a.to_degrees(), b.to_degrees(), c.to_degrees()),
        m.w_axis.truncate(),
    ))
}

/// Mitsuba's rectangle: [-1, 1]^2 at z = 0, normal +z, as two counter-clockwise triangles.
fn rectangle_triangles() -> Vec<[DVec3; 3]> {
    let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    vec![
        [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
        [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
    ]
}

/// Mitsuba's cube: [-1, 1]^3, 12 triangles wound counter-clockwise seen from outside.
fn cube_triangles() -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    // Each face: its outward axis n and two axes u, v with u x v = n; corners c +- u +- v.
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            let mut u = DVec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let q = |a: f64, b: f64| n + a * u + b * v;
            out.push([q(-1.0, -1.0), q(1.0, -1.0), q(1.0, 1.0)]);
            out.push([q(-1.0, -1.0), q(1.0, 1.0), q(-1.0, 1.0)]);
        }
    }
    out
}

/// Mitsuba 3's cube as its own mesh (cube.cpp): 24 vertices, four per face, each face's uvs running
/// over [0, 1]^2, and 12 counter-clockwise triangles seen from outside, with each triangle's uvs. The
/// faces in Mitsuba's order: -y, +y, +x, +z, -x, -z. (Checked against Mitsuba 3.9.1's
/// `vertex_positions`, `vertex_texcoords` and `faces`.)
fn mitsuba_cube() -> (Vec<[DVec3; 3]>, Vec<[[f64; 2]; 3]>) {
    // Each face: its four corners, in the order of uvs (0, 1), (1, 1), (1, 0), (0, 0); triangles
    // (0, 1, 2) and (3, 0, 2).
    const FACES: [[[f64; 3]; 4]; 6] = [
        [
            [1., -1., -1.],
            [1., -1., 1.],
            [-1., -1., 1.],
            [-1., -1., -1.],
        ],
        [[1., 1., -1.], [-1., 1., -1.], [-1., 1., 1.], [1., 1., 1.]],
        [[1., -1., -1.], [1., 1., -1.], [1., 1., 1.], [1., -1., 1.]],
        [[1., -1., 1.], [1., 1., 1.], [-1., 1., 1.], [-1., -1., 1.]],
        [
            [-1., -1., 1.],
            [-1., 1., 1.],
            [-1., 1., -1.],
            [-1., -1., -1.],
        ],
        [
            [1., 1., -1.],
            [1., -1., -1.],
            [-1., -1., -1.],
            [-1., 1., -1.],
        ],
    ];
    const UV: [[f64; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
    let mut triangles = Vec::new();
    let mut uvs = Vec::new();
    for face in FACES {
        let p = face.map(DVec3::from_array);
        for [i, j, k] in [[0, 1, 2], [3, 0, 2]] {
            triangles.push([p[i], p[j], p[k]]);
            uvs.push([UV[i], UV[j], UV[k]]);
        }
    }
    (triangles, uvs)
}

/// Mitsuba's disk (the unit disk at z = 0, normal +z) as a fan of [`DISK_SEGMENTS`] triangles: a regular
/// N-gon whose area equals the disk's. An N-gon of circumradius R has area (N / 2) R^2 sin(2 pi / N), so
/// R = sqrt(2 pi / (N sin(2 pi / N))) = 1.000803 for N = 64: the emitted power and the area are exact,
/// and the outline stays within 0.08% of the unit circle (vertices 0.08% outside, edge midpoints
/// R cos(pi / N) = 0.99960, 0.04% inside).
fn disk_triangles() -> Vec<[DVec3; 3]> {
    let n = DISK_SEGMENTS as f64;
    let tau = std::f64::consts::TAU;
    let r = (tau / (n * (tau / n).sin())).sqrt();
    let at = |k: usize| {
        let phi = tau * k as f64 / n;
        DVec3::new(r * phi.cos(), r * phi.sin(), 0.0)
    };
    (0..DISK_SEGMENTS)
        .map(|k| [DVec3::ZERO, at(k), at((k + 1) % DISK_SEGMENTS)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placement_recovers_euler_angles() {
        let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
            * DMat4::from_rotation_z(0.3)
            * DMat4::from_rotation_y(-0.4)
            * DMat4::from_rotation_x(1.1)
            * DMat4::from_scale(DVec3::splat(2.0));
        let (s, r, t) = placement(&m).unwrap();
        assert!((s - 2.0).abs() < 1e-12);
        assert!((r - DVec3::new(1.1, -0.4, 0.3) * (180.0 / std::f64::consts::PI)).length() < 1e-9);
        assert!((t - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!(placement(&DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0))).is_none());
        assert!(placement(&DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).is_none());
    }

    #[test]
    fn the_disk_polygon_has_the_disk_area_and_faces_z() {
        let area: f64 = disk_triangles()
            .iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a).z / 2.0)
            .sum();
        assert!((area - std::f64::consts::PI).abs() < 1e-12, "{area}");
        for [a, b, c] in cube_triangles() {
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0) > 0.0, "cube faces point outwards");
        }
    }
}
