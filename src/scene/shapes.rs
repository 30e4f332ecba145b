//! Generated meshes, so that tests, benchmarks and the example scene need no model file from elsewhere:
//! icospheres (closed, nearly uniform triangles), latitude–longitude spheres (with uvs), and OBJ text for
//! any of them.

use glam::Vec3;
use std::collections::HashMap;
use std::fmt::Write;

/// A generated mesh: positions, optional per-vertex normals and uvs, counter-clockwise triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

/// The unit icosphere: a regular icosahedron whose faces are split `subdivisions` times into four, new
/// vertices pushed onto the sphere. 20 * 4^s triangles, 10 * 4^s + 2 vertices, every edge shared by
/// exactly two triangles (closed and watertight as an index structure), outward counter-clockwise.
pub fn icosphere(subdivisions: u32) -> Shape {
    let (positions, triangles) = icosphere_f64(subdivisions);
    let positions: Vec<Vec3> = positions.iter().map(|p| p.as_vec3()).collect();
    Shape {
        normals: positions.iter().map(|p| p.normalize()).collect(),
        positions,
        uvs: Vec::new(),
        triangles,
    }
}

/// The same icosphere with its vertices in f64 (for tests that place it at extreme scales and offsets
/// before rounding to f32 once).
pub fn icosphere_f64(subdivisions: u32) -> (Vec<glam::DVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5.0f64.sqrt()) / 2.0;
    let raw = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut positions: Vec<glam::DVec3> = raw
        .iter()
        .map(|p| glam::DVec3::from_array(*p).normalize())
        .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<glam::DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(m);
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (positions, triangles)
}

/// The unit sphere as a latitude–longitude grid of `segments` x `rings` quads (split into triangles),
/// with uvs (u around the y axis from the -z side, v from the south pole up) and exact normals. The seam
/// at u = 0 / 1 duplicates its vertices, as a textured OBJ does.
pub fn uv_sphere(segments: u32, rings: u32) -> Shape {
    let mut s = Shape::default();
    for j in 0..=rings {
        let v = j as f64 / rings as f64;
        let theta = std::f64::consts::PI * (1.0 - v); // from the south pole (theta = pi) up
        for i in 0..=segments {
            let u = i as f64 / segments as f64;
            let phi = 2.0 * std::f64::consts::PI * u;
            let p = glam::DVec3::new(
                -theta.sin() * phi.sin(),
                theta.cos(),
                -theta.sin() * phi.cos(),
            );
            s.positions.push(p.as_vec3());
            s.normals.push(p.normalize().as_vec3());
            s.uvs.push([u as f32, v as f32]);
        }
    }
    let row = segments + 1;
    for j in 0..rings {
        for i in 0..segments {
            let a = j * row + i;
            let b = a + 1;
            let c = a + row;
            let d = c + 1;
            // Counter-clockwise seen from outside; the pole rows would give zero-area triangles.
            if j != 0 {
                s.triangles.push([a, b, d]);
            }
            if j != rings - 1 {
                s.triangles.push([a, d, c]);
            }
        }
    }
    s
}

impl Shape {
    /// Scales and moves the shape (normals are unchanged by a positive uniform scale).
    pub fn transformed(mut self, scale: f32, offset: Vec3) -> Shape {
        for p in &mut self.positions {
            *p = *p * scale + offset;
        }
        self
    }

    /// The shape as Wavefront OBJ text, with `vn` and `vt` lines when it has normals and uvs. Numbers are
    /// written with Rust's shortest round-trip formatting, so the file reads back to the same f32s.
    pub fn to_obj(&self) -> String {
        let mut out = String::with_capacity(self.positions.len() * 40 + self.triangles.len() * 30);
        out.push_str("# generated by vkpath\n");
        for p in &self.positions {
            let _ = writeln!(out, "v {} {} {}", p.x, p.y, p.z);
        }
        for n in &self.normals {
            let _ = writeln!(out, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in &self.uvs {
            let _ = writeln!(out, "vt {} {}", t[0], t[1]);
        }
        let has_n = !self.normals.is_empty();
        let has_t = !self.uvs.is_empty();
        for t in &self.triangles {
            out.push('f');
            for &i in t {
                let i = i + 1;
                let _ = match (has_t, has_n) {
                    (true, true) => write!(out, " {i}/{i}/{i}"),
                    (true, false) => write!(out, " {i}/{i}"),
                    (false, true) => write!(out, " {i}//{i}"),
                    (false, false) => write!(out, " {i}"),
                };
            }
            out.push('\n');
        }
        out
    }
}
