//! An environment map for tests, and Mitsuba's envmap lookup written independently of the shader and of
//! src/scene/environment.rs: texture coordinates, cells and bilinear radiance (columns at (k + 1/2) / W
//! wrapping around, rows at j / (H - 1)), and the rotation about +y.
#![allow(dead_code)]

use super::vec::{V3, add, scale};
use std::f64::consts::PI;
use vkpath::scene::EnvironmentMap;

/// A small map with structure: a sky gradient, a bright spot, a dark ground, a black column.
pub fn test_map(spot_radiance: f32) -> EnvironmentMap {
    let (w, h) = (24u32, 13u32);
    let texels = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let v = y as f32 / (h - 1) as f32;
            let base = if v < 0.5 { 0.3 + v } else { 0.05 };
            let spot = if (x, y) == (17, 3) || (x, y) == (18, 3) {
                spot_radiance
            } else {
                0.0
            };
            let dark = if x == 5 { 0.0 } else { 1.0 };
            [
                (base + spot) * dark,
                (0.5 * base + spot) * dark,
                (2.0 * base + 0.5 * spot) * dark,
            ]
        })
        .collect();
    EnvironmentMap {
        path: "test.exr".into(),
        width: w,
        height: h,
        texels,
    }
}

/// Rotation by `deg` about +y: map frame -> world (Mitsuba's to_world = rotate([0, 1, 0], deg)).
pub fn rotate_y(deg: f64, m: V3) -> V3 {
    let (s, c) = deg.to_radians().sin_cos();
    [c * m[0] + s * m[2], m[1], -s * m[0] + c * m[2]]
}

/// Mitsuba's envmap lookup, written independently: texture coordinates of a map-frame direction, and
/// the bilinear radiance there (columns at (k + 1/2) / W wrapping, rows at j / (H - 1)).
pub fn map_uv(m: V3) -> (f64, f64) {
    let u = m[0].atan2(-m[2]) / (2.0 * PI);
    (u - u.floor(), m[1].clamp(-1.0, 1.0).acos() / PI)
}

pub fn texel(map: &EnvironmentMap, k: usize, j: usize) -> V3 {
    let t = map.texels[j * map.width as usize + k % map.width as usize];
    [t[0] as f64, t[1] as f64, t[2] as f64]
}

/// (k, j, fx, fy): the cell of (u, v) and the position in it.
pub fn cell_of(map: &EnvironmentMap, u: f64, v: f64) -> (usize, usize, f64, f64) {
    let (w, h) = (map.width as usize, map.height as usize);
    let x = (u - 0.5 / w as f64).rem_euclid(1.0) * w as f64;
    let y = v * (h - 1) as f64;
    let k = (x.floor() as usize).min(w - 1);
    let j = (y.floor() as usize).min(h - 2);
    (k, j, x - k as f64, y - j as f64)
}

pub fn bilinear(map: &EnvironmentMap, m: V3) -> V3 {
    let (u, v) = map_uv(m);
    let (k, j, fx, fy) = cell_of(map, u, v);
    let lerp = |a: V3, b: V3, t: f64| add(scale(a, 1.0 - t), scale(b, t));
    let top = lerp(texel(map, k, j), texel(map, k + 1, j), fx);
    let bottom = lerp(texel(map, k, j + 1), texel(map, k + 1, j + 1), fx);
    lerp(top, bottom, fy)
}

/// Writes the map as a 32-bit float RGB OpenEXR file.
pub fn write_exr(map: &EnvironmentMap, path: &std::path::Path) {
    let data: Vec<f32> = map.texels.iter().flatten().copied().collect();
    let img = image::Rgb32FImage::from_raw(map.width, map.height, data).expect("texel count");
    image::DynamicImage::ImageRgb32F(img)
        .save_with_format(path, image::ImageFormat::OpenExr)
        .expect("write the map");
}

/// The integral over the sphere of the map's radiance (rotated by `rotate_deg`, times `tint`) weighted by
/// `weight(world direction)`, by a midpoint quadrature with `steps` rows (and 2 steps columns) in (u, v)
/// (solid angle 2 pi^2 sin(theta) du dv).
pub fn integrate(
    map: &EnvironmentMap,
    rotate_deg: f64,
    tint: V3,
    steps: usize,
    weight: impl Fn(V3) -> f64,
) -> V3 {
    let mut sum = [0.0; 3];
    for a in 0..2 * steps {
        for b in 0..steps {
            let (u, v) = (
                (a as f64 + 0.5) / (2 * steps) as f64,
                (b as f64 + 0.5) / steps as f64,
            );
            let (theta, phi) = (PI * v, 2.0 * PI * u);
            let m = [
                theta.sin() * phi.sin(),
                theta.cos(),
                -theta.sin() * phi.cos(),
            ];
            let w = weight(rotate_y(rotate_deg, m));
            if w == 0.0 {
                continue;
            }
            let l = bilinear(map, m);
            let d_omega = 2.0 * PI * PI * theta.sin() / (2 * steps * steps) as f64;
            for ch in 0..3 {
                sum[ch] += tint[ch] * l[ch] * w * d_omega;
            }
        }
    }
    sum
}

/// The radiance a diffuse surface of albedo 1 with unit normal n reflects under the map: (1 / pi) times
/// the integral of L(w) max(0, n.w).
pub fn cosine_convolution(
    map: &EnvironmentMap,
    rotate_deg: f64,
    tint: V3,
    n: V3,
    steps: usize,
) -> V3 {
    integrate(map, rotate_deg, tint, steps, |w| {
        super::vec::dot(n, w).max(0.0) / PI
    })
}
