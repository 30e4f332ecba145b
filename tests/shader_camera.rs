//! Primary rays (shaders/camera.wgsl), read back from the GPU and compared with an f64 reference of the
//! documented convention: horizontal field of view across the image width, film position (0, 0) at the
//! top-left corner, x to the right, y down, the camera's up vector up on the image, square pixels; a thin
//! lens focuses every ray of a film position on the point where its pinhole ray meets the plane at
//! `focus_distance` along the view axis.
//!
//! Tolerances. The camera's inputs (frame, tan(fov/2)) are f32; the reference uses the same f32 values,
//! widened. u = 2^-24 is the f32 unit roundoff. The pinhole direction is normalize(F + sx R + sy U) with
//! sx, sy each from a subtraction (exact), a division (<= 2.5 ulps) and a product; each component of the
//! sum carries <= 2u of the largest term, which is at most the length of the sum, so the direction is off
//! by <= 2u sqrt(3) rad, plus u for the rounding of sx, sy and 2u for the normalisation: ~8u. We allow
//! ANGLE_TOL = 16u ~ 9.5e-7 rad (a factor 2).

mod common;

use common::vec::{V3, add, cross, dot, length, normalize, scale, sub, widen};
use vkpath::gpu::testing;

const KERNEL: &str = include_str!("../shaders/tests/camera_rays.wgsl");

const U: f64 = f32::EPSILON as f64 / 2.0;
const ANGLE_TOL: f64 = 16.0 * U;

/// The angle between two directions, accurate for tiny angles (atan2 of |a x b| and a . b).
fn angle(a: V3, b: V3) -> f64 {
    length(cross(a, b)).atan2(dot(a, b))
}

/// A camera as the renderer passes it to the shader (src/kernel/upload.rs): an f32 frame built from position,
/// look_at and the world up (forward towards look_at, right = forward x up, up = right x forward).
#[derive(Clone, Copy, Debug)]
struct Camera {
    position: [f32; 3],
    right: [f32; 3],
    up: [f32; 3],
    forward: [f32; 3],
    tan_half_fov: f32,
    width: u32,
    height: u32,
    lens_radius: f32,
    focus_distance: f32,
}

impl Camera {
    fn new(position: V3, look_at: V3, fov_deg: f64, width: u32, height: u32) -> Camera {
        let forward = normalize(sub(look_at, position));
        let right = normalize(cross(forward, [0.0, 1.0, 0.0]));
        let up = cross(right, forward);
        let f32s = |v: V3| v.map(|x| x as f32);
        Camera {
            position: f32s(position),
            right: f32s(right),
            up: f32s(up),
            forward: f32s(forward),
            tan_half_fov: (fov_deg.to_radians() / 2.0).tan() as f32,
            width,
            height,
            lens_radius: 0.0,
            focus_distance: 1.0,
        }
    }

    fn lens(self, lens_radius: f32, focus_distance: f32) -> Camera {
        Camera {
            lens_radius,
            focus_distance,
            ..self
        }
    }

    /// The f64 reference pinhole direction through film position (fx, fy), from the convention: the
    /// image plane at distance 1 along forward spans [-t, t] across the width (t = tan(fov/2)), so the
    /// film position maps to x = (2 fx / w - 1) t to the right and y = (1 - 2 fy / h) t (h / w) up.
    fn reference_dir(&self, film: [f64; 2]) -> V3 {
        let (w, h, t) = (
            self.width as f64,
            self.height as f64,
            self.tan_half_fov as f64,
        );
        let x = (2.0 * film[0] / w - 1.0) * t;
        let y = (1.0 - 2.0 * film[1] / h) * t * (h / w);
        normalize(add(
            widen(self.forward),
            add(scale(widen(self.right), x), scale(widen(self.up), y)),
        ))
    }
}

/// A GPU ray: origin and direction.
#[derive(Clone, Copy, Debug)]
struct Ray {
    o: V3,
    d: V3,
    o32: [f32; 3],
    d32: [f32; 3],
}

/// camera_ray on the GPU for each (film, lens) pair.
fn rays(cam: &Camera, queries: &[([f32; 2], [f32; 2])]) -> Vec<Ray> {
    let p = cam.position;
    let mut input = vec![
        [p[0], p[1], p[2], cam.tan_half_fov],
        [cam.right[0], cam.right[1], cam.right[2], cam.lens_radius],
        [cam.up[0], cam.up[1], cam.up[2], cam.focus_distance],
        [cam.forward[0], cam.forward[1], cam.forward[2], 0.0],
        [cam.width as f32, cam.height as f32, 0.0, 0.0],
    ];
    assert_eq!(input[4][0] as u32, cam.width);
    input.extend(queries.iter().map(|(f, l)| [f[0], f[1], l[0], l[1]]));
    let out: Vec<[[f32; 4]; 2]> =
        testing::run_kernel(&testing::context(), KERNEL, &input, queries.len()).expect("kernel");
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
    out.iter()
        .map(|[o, d]| Ray {
            o: [o[0] as f64, o[1] as f64, o[2] as f64],
            d: [d[0] as f64, d[1] as f64, d[2] as f64],
            o32: [o[0], o[1], o[2]],
            d32: [d[0], d[1], d[2]],
        })
        .collect()
}

fn pinhole(cam: &Camera, films: &[[f32; 2]]) -> Vec<Ray> {
    let q: Vec<_> = films.iter().map(|&f| (f, [0.0, 0.0])).collect();
    rays(cam, &q)
}

/// Corners, edge midpoints, the centre and the extreme pixel centres of the film.
fn film_landmarks(w: u32, h: u32) -> Vec<[f32; 2]> {
    let (w, h) = (w as f32, h as f32);
    vec![
        [0.0, 0.0],
        [w, 0.0],
        [0.0, h],
        [w, h],
        [w / 2.0, h / 2.0],
        [0.0, h / 2.0],
        [w, h / 2.0],
        [w / 2.0, 0.0],
        [w / 2.0, h],
        [0.5, 0.5],
        [w - 0.5, 0.5],
        [0.5, h - 0.5],
        [w - 0.5, h - 0.5],
        [(w / 2.0).floor() + 0.5, (h / 2.0).floor() + 0.5],
    ]
}

/// Asserts that each GPU direction is finite, unit (to 4u: normalize's rounding) and within ANGLE_TOL of
/// the reference.
fn assert_pinhole(cam: &Camera, films: &[[f32; 2]], out: &[Ray], what: &str) -> f64 {
    let mut worst: f64 = 0.0;
    for (f, r) in films.iter().zip(out) {
        assert!(
            r.d.iter().chain(&r.o).all(|x| x.is_finite()),
            "{what} film {f:?}: {r:?}"
        );
        assert!(
            (length(r.d) - 1.0).abs() <= 4.0 * U,
            "{what} film {f:?}: |d| = {}",
            length(r.d)
        );
        assert_eq!(
            r.o32, cam.position,
            "{what}: a pinhole ray starts at the camera"
        );
        let want = cam.reference_dir([f[0] as f64, f[1] as f64]);
        let a = angle(r.d, want);
        worst = worst.max(a);
        assert!(
            a <= ANGLE_TOL,
            "{what} film {f:?}: {:?} vs {want:?}, {a:.2e} rad",
            r.d
        );
    }
    worst
}

/// A camera looking along a generic direction from a point away from the origin.
fn generic(fov: f64, w: u32, h: u32) -> Camera {
    Camera::new([1.5, -2.0, 7.25], [-3.0, 0.5, -4.0], fov, w, h)
}

/// The convention itself, independently of the formula: at 60 degrees on 640 x 480, the top-left film
/// corner is left (negative along right) and up, the centre is the view axis, the left and right edges
/// at mid-height are exactly fov/2 off the axis horizontally, the top edge at mid-width is
/// atan(tan(fov/2) h / w) off vertically (square pixels).
#[test]
fn convention_horizontal_fov_y_down() {
    let (w, h) = (640u32, 480u32);
    let fov = 60.0f64;
    let cam = generic(fov, w, h);
    let (wf, hf) = (w as f32, h as f32);
    let films = [
        [0.0, 0.0],
        [wf / 2.0, hf / 2.0],
        [0.0, hf / 2.0],
        [wf, hf / 2.0],
        [wf / 2.0, 0.0],
        [0.5, 0.5],
    ];
    let out = pinhole(&cam, &films);
    let (r, u, f) = (widen(cam.right), widen(cam.up), widen(cam.forward));
    let half = (cam.tan_half_fov as f64).atan(); // fov / 2 up to the f32 rounding of tan
    assert!((half - fov.to_radians() / 2.0).abs() < 1e-7);
    let top_left = out[0].d;
    assert!(
        dot(top_left, r) < 0.0 && dot(top_left, u) > 0.0,
        "top-left corner: {top_left:?}"
    );
    assert!(angle(out[1].d, f) <= ANGLE_TOL, "centre: {:?}", out[1].d);
    let horiz = |d: V3| dot(d, r).atan2(dot(d, f));
    let vert = |d: V3| dot(d, u).atan2(dot(d, f));
    assert!(
        (horiz(out[2].d) + half).abs() <= ANGLE_TOL,
        "left edge: {}",
        horiz(out[2].d)
    );
    assert!(
        (horiz(out[3].d) - half).abs() <= ANGLE_TOL,
        "right edge: {}",
        horiz(out[3].d)
    );
    assert!(vert(out[2].d).abs() <= ANGLE_TOL);
    let top = (half.tan() * h as f64 / w as f64).atan();
    assert!(
        (vert(out[4].d) - top).abs() <= ANGLE_TOL,
        "top edge: {} vs {top}",
        vert(out[4].d)
    );
    assert!(
        dot(out[5].d, r) < 0.0 && dot(out[5].d, u) > 0.0,
        "pixel (0, 0) is top-left"
    );
    assert_pinhole(&cam, &films, &out, "60 deg");
}

/// Fields of view from 0.01 to 179.9 degrees, image sizes 1 x 1, 4096 x 16, 16 x 4096 and 640 x 480: the
/// landmarks of the film (corners, edges, centre, extreme pixel centres) against the reference.
#[test]
fn pinhole_matches_reference_at_extreme_fov_and_sizes() {
    for fov in [0.01, 1.0, 60.0, 120.0, 179.0, 179.9] {
        for (w, h) in [(1u32, 1u32), (4096, 16), (16, 4096), (640, 480)] {
            let cam = generic(fov, w, h);
            let films = film_landmarks(w, h);
            let out = pinhole(&cam, &films);
            let worst = assert_pinhole(&cam, &films, &out, &format!("fov {fov} {w}x{h}"));
            if w == 4096 || w == 1 {
                eprintln!("fov {fov}, {w}x{h}: worst angle {worst:.1e} rad");
            }
            // The film centre is the view axis; for 1 x 1 the pixel centre is the film centre.
            let centre = &out[4];
            assert!(
                angle(centre.d, widen(cam.forward)) <= ANGLE_TOL,
                "fov {fov} {w}x{h}: centre {centre:?}"
            );
            // The left edge at mid-height is fov/2 off the axis: at 179.9 deg, 89.95 deg.
            let (r, f) = (widen(cam.right), widen(cam.forward));
            let horiz = dot(out[5].d, r).atan2(dot(out[5].d, f));
            let half = (cam.tan_half_fov as f64).atan();
            assert!(
                (horiz + half).abs() <= ANGLE_TOL,
                "fov {fov} {w}x{h}: left edge {horiz} vs {}",
                -half
            );
        }
    }
}

/// At 0.01 degrees on a 4096-wide film, neighbouring pixel centres are 4.3e-8 rad apart. For a camera
/// along a coordinate axis the direction's small components carry that exactly and every pixel of a row
/// gets a distinct direction, in order, with the angle off the axis accurate to 16u relative. For a
/// generic orientation the step is below the spacing of f32 unit vectors (~6e-8 per component near 0.6),
/// so only the absolute ANGLE_TOL is asserted; the distinct directions, order inversions and error in
/// pixel steps are printed as evidence for docs/robustness.md (lavapipe: 4096 distinct, 0 inversions,
/// 0.71 pixel steps at worst).
#[test]
fn tiny_fov_resolves_every_pixel_on_axis() {
    let (w, h) = (4096u32, 16u32);
    let cam = Camera::new([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.01, w, h);
    assert_eq!(cam.right, [1.0, 0.0, 0.0]);
    let films: Vec<[f32; 2]> = (0..w).map(|i| [i as f32 + 0.5, 7.5]).collect();
    let out = pinhole(&cam, &films);
    assert_pinhole(&cam, &films, &out, "fov 0.01 on axis");
    for (i, pair) in out.windows(2).enumerate() {
        assert!(
            pair[1].d32[0] > pair[0].d32[0],
            "pixels {i} and {} share a direction",
            i + 1
        );
    }
    for (f, r) in films.iter().zip(&out) {
        let want = cam.reference_dir([f[0] as f64, f[1] as f64]);
        let (got_a, want_a) = (
            angle(r.d, widen(cam.forward)),
            angle(want, widen(cam.forward)),
        );
        assert!(
            (got_a - want_a).abs() <= 16.0 * U * want_a,
            "film {f:?}: off-axis angle {got_a} vs {want_a}"
        );
    }
    // The same row for a generic orientation: count distinct directions (evidence for the docs).
    let cam = generic(0.01, w, h);
    let out = pinhole(&cam, &films);
    assert_pinhole(&cam, &films, &out, "fov 0.01 generic");
    let distinct = out.windows(2).filter(|p| p[0].d32 != p[1].d32).count() + 1;
    let r = widen(cam.right);
    let inversions = out
        .windows(2)
        .filter(|p| dot(p[1].d, r) <= dot(p[0].d, r))
        .count();
    // The error in units of the angle between neighbouring pixels.
    let step = 2.0 * cam.tan_half_fov as f64 / w as f64;
    let worst_px = films
        .iter()
        .zip(&out)
        .map(|(f, ray)| angle(ray.d, cam.reference_dir([f[0] as f64, f[1] as f64])) / step)
        .fold(0.0f64, f64::max);
    eprintln!("generic: {inversions} order inversions, worst error {worst_px:.2} pixel steps");
    eprintln!("fov 0.01, 4096 wide, generic orientation: {distinct} distinct directions of {w}");
    assert!(
        distinct > w as usize / 2,
        "{distinct} distinct directions of {w}"
    );
}

/// Every pixel centre of a 64 x 48 image at three fields of view: finite, unit, within ANGLE_TOL.
#[test]
fn pinhole_all_pixels() {
    for fov in [0.01, 45.0, 179.9] {
        let (w, h) = (64u32, 48u32);
        let cam = generic(fov, w, h);
        let films: Vec<[f32; 2]> = (0..w * h)
            .map(|k| [(k % w) as f32 + 0.5, (k / w) as f32 + 0.5])
            .collect();
        let out = pinhole(&cam, &films);
        assert_pinhole(&cam, &films, &out, &format!("fov {fov} all pixels"));
    }
}

/// Lens samples covering the unit disk, its centre and its rim.
fn lens_samples() -> Vec<[f32; 2]> {
    let mut l = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [0.0, 1.0],
        [-1.0, 0.0],
        [0.0, -1.0],
        [0.6, -0.8],
    ];
    for k in 0..24 {
        let (r, phi) = (((k % 4) as f32 + 1.0) / 4.0, k as f32 * 0.9);
        l.push([r * phi.cos(), r * phi.sin()]);
    }
    l
}

/// Aperture 0 is the pinhole exactly: the ray does not depend on the lens sample or on the focus
/// distance (not even 0, where the thin-lens construction would divide nothing by nothing), bit for bit;
/// the origin is the camera position. A vanishing aperture (1e-30) takes the thin-lens path and stays
/// within ANGLE_TOL of the pinhole ray (no discontinuity at 0).
#[test]
fn aperture_zero_is_pinhole() {
    let cam = generic(50.0, 320, 200);
    let films = film_landmarks(320, 200);
    let base = pinhole(&cam, &films);
    assert_pinhole(&cam, &films, &base, "50 deg");
    for lens in lens_samples() {
        let q: Vec<_> = films.iter().map(|&f| (f, lens)).collect();
        for focus in [0.0f32, 1e-30, 3.0, 1e30] {
            let out = rays(&cam.lens(0.0, focus), &q);
            for (a, b) in out.iter().zip(&base) {
                assert_eq!(a.o32, cam.position);
                assert_eq!(
                    a.d32.map(f32::to_bits),
                    b.d32.map(f32::to_bits),
                    "lens {lens:?} focus {focus}"
                );
            }
        }
        let tiny = rays(&cam.lens(1e-30, 10.0), &q);
        for (a, b) in tiny.iter().zip(&base) {
            assert_eq!(
                a.o32, cam.position,
                "a 1e-30 lens offset vanishes in the position"
            );
            assert!(
                angle(a.d, b.d) <= ANGLE_TOL,
                "lens {lens:?}: {:?} vs {:?}",
                a.d,
                b.d
            );
        }
    }
}

/// Thin lens: every ray of a film position, whatever its lens sample, starts on the lens (position +
/// radius (lens.x right + lens.y up)) and crosses the plane at focus_distance along the view axis at the
/// reference focus point P (where the f64 pinhole ray meets that plane). Focus distances 0.5 to 1e6,
/// apertures 1e-3 to 2.
///
/// Tolerance: P is computed by the shader in f32 as position + dir (focus / dot(dir, forward)), with the
/// direction within ANGLE_TOL, so its error is ~ANGLE_TOL |P - position| + a few u (|position| + |P|);
/// the ray to it from the lens point adds a few u of |P - origin|. We allow 32u (|P - position| +
/// |position| + |P|), relative to the scale of the scene.
#[test]
fn thin_lens_focuses_on_the_plane() {
    let (w, h) = (300u32, 200u32);
    let films = film_landmarks(w, h);
    let lenses = lens_samples();
    for (aperture, focus) in [
        (0.05f32, 0.5f32),
        (0.1, 7.0),
        (2.0, 25.0),
        (1e-3, 1e3),
        (0.05, 1e6),
    ] {
        for fov in [10.0, 60.0, 150.0] {
            let cam = generic(fov, w, h).lens(aperture, focus);
            let (pos, r, u, f) = (
                widen(cam.position),
                widen(cam.right),
                widen(cam.up),
                widen(cam.forward),
            );
            let q: Vec<_> = films
                .iter()
                .flat_map(|&fl| lenses.iter().map(move |&l| (fl, l)))
                .collect();
            let out = rays(&cam, &q);
            let mut worst: f64 = 0.0;
            for ((film, lens), ray) in q.iter().zip(&out) {
                let what = format!(
                    "aperture {aperture} focus {focus} fov {fov} film {film:?} lens {lens:?}"
                );
                assert!(
                    ray.d.iter().chain(&ray.o).all(|x| x.is_finite()),
                    "{what}: {ray:?}"
                );
                assert!(
                    (length(ray.d) - 1.0).abs() <= 4.0 * U,
                    "{what}: |d| = {}",
                    length(ray.d)
                );
                // On the lens.
                let lens_pt = add(
                    pos,
                    scale(
                        add(scale(r, lens[0] as f64), scale(u, lens[1] as f64)),
                        aperture as f64,
                    ),
                );
                let o_err = length(sub(ray.o, lens_pt));
                assert!(
                    o_err <= 4.0 * U * (length(pos) + aperture as f64),
                    "{what}: origin off by {o_err}"
                );
                // Through the reference focus point.
                let dir = cam.reference_dir([film[0] as f64, film[1] as f64]);
                let p = add(pos, scale(dir, focus as f64 / dot(dir, f)));
                let t = (focus as f64 - dot(sub(ray.o, pos), f)) / dot(ray.d, f);
                assert!(t > 0.0, "{what}: the focus plane is behind the ray");
                let x = add(ray.o, scale(ray.d, t));
                let scale_len = length(sub(p, pos)) + length(pos) + length(p);
                let rel = length(sub(x, p)) / scale_len;
                worst = worst.max(rel);
                assert!(
                    rel <= 32.0 * U,
                    "{what}: crosses the focus plane {} away from P ({rel:.2e} rel)",
                    length(sub(x, p))
                );
            }
            eprintln!(
                "aperture {aperture} focus {focus} fov {fov}: worst relative miss {worst:.1e}"
            );
        }
    }
}

/// Defect 4: a thin lens focused at 1e30 gave a zero ray direction (the focus point, 1e30 away, has a
/// squared length that overflows f32 inside normalize). The direction is now computed divided by the
/// distance to the focus point, with no overflow: for every focus distance up to f32::MAX the rays are
/// finite and unit, and they approach the pinhole direction as the focus goes to infinity (every lens
/// point then looks along it), within aperture / focus plus the pinhole tolerance. The old formula,
/// replayed on the CPU in f32, breaks there (asserted, so that the case keeps testing something).
#[test]
fn thin_lens_with_huge_focus_distances() {
    let (w, h) = (64u32, 48u32);
    let films = film_landmarks(w, h);
    let lenses = lens_samples();
    let mut old_formula_failed = false;
    for focus in [1e10f32, 1e19, 1e20, 1e30, f32::MAX] {
        let aperture = 0.5f32;
        let cam = generic(60.0, w, h).lens(aperture, focus);
        let q: Vec<_> = films
            .iter()
            .flat_map(|&fl| lenses.iter().map(move |&l| (fl, l)))
            .collect();
        let out = rays(&cam, &q);
        for ((film, lens), ray) in q.iter().zip(&out) {
            let what = format!("focus {focus:e} film {film:?} lens {lens:?}");
            assert!(ray.d.iter().all(|x| x.is_finite()), "{what}: {ray:?}");
            assert!(
                (length(ray.d) - 1.0).abs() <= 4.0 * U,
                "{what}: |d| = {}",
                length(ray.d)
            );
            let want = cam.reference_dir([film[0] as f64, film[1] as f64]);
            let a = angle(ray.d, want);
            assert!(
                a <= 2.0 * ANGLE_TOL + 2.0 * aperture as f64 / focus as f64,
                "{what}: {a:e} rad from the pinhole direction"
            );
            // The previous formula: normalize(position + dir k - origin), k = focus / dot(dir, forward).
            let f32v = |v: V3| glam::Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
            let (pos, r, u, fw) = (
                glam::Vec3::from(cam.position),
                glam::Vec3::from(cam.right),
                glam::Vec3::from(cam.up),
                glam::Vec3::from(cam.forward),
            );
            let dir = f32v(want);
            let focus_point = pos + dir * (focus / dir.dot(fw));
            let origin = pos + aperture * (lens[0] * r + lens[1] * u);
            let old = (focus_point - origin).normalize();
            if !old.is_finite() || old.length() < 0.5 {
                old_formula_failed = true;
            }
        }
    }
    assert!(
        old_formula_failed,
        "the old formula was expected to fail at 1e30"
    );
}

/// The orthographic camera: every ray has the view direction, and starts on the film plane through the
/// camera position at the point the film position maps to: x = (2 fx / w - 1) e/2 along right and
/// y = (1 - 2 fy / h) (e/2) (h / w) along up, for an extent (view width) e; square pixels. Checked at the
/// film's landmarks for a generic camera and extents from 1e-3 to 1e4, against f64.
#[test]
fn orthographic_rays_are_parallel_and_tile_the_film() {
    for (w, h) in [(64u32, 48u32), (1, 1), (300, 20)] {
        for extent in [1e-3f32, 2.0, 1e4] {
            let mut cam = generic(60.0, w, h);
            cam.tan_half_fov = 0.5 * extent; // the kernel's view_half_width
            let films = film_landmarks(w, h);
            let p = cam.position;
            let mut input = vec![
                [p[0], p[1], p[2], cam.tan_half_fov],
                [cam.right[0], cam.right[1], cam.right[2], 0.0],
                [cam.up[0], cam.up[1], cam.up[2], 1.0],
                [cam.forward[0], cam.forward[1], cam.forward[2], 0.0],
                [w as f32, h as f32, 1.0, 0.0],
            ];
            input.extend(films.iter().map(|f| [f[0], f[1], 0.3, -0.2]));
            let out: Vec<[[f32; 4]; 2]> =
                testing::run_kernel(&testing::context(), KERNEL, &input, films.len())
                    .expect("kernel");
            let (pos, r, u, fw) = (
                widen(cam.position),
                widen(cam.right),
                widen(cam.up),
                widen(cam.forward),
            );
            let half = 0.5 * extent as f64;
            for (f, [o, d]) in films.iter().zip(&out) {
                let what = format!("{w}x{h} extent {extent} film {f:?}");
                assert_eq!(&d[..3], &cam.forward, "{what}: the view direction, exactly");
                let x = (2.0 * f[0] as f64 / w as f64 - 1.0) * half;
                let y = (1.0 - 2.0 * f[1] as f64 / h as f64) * half * (h as f64 / w as f64);
                let want = add(pos, add(scale(r, x), scale(u, y)));
                let got = [o[0] as f64, o[1] as f64, o[2] as f64];
                let err = length(sub(got, want));
                assert!(
                    err <= 8.0 * U * (length(pos) + half),
                    "{what}: origin off by {err}"
                );
                // On the film plane through the camera position.
                assert!(dot(sub(got, pos), fw).abs() <= 8.0 * U * (length(pos) + half));
            }
        }
    }
}
