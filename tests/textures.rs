//! Textured material parameters and surface modifiers (docs/scene-format.md, "Textured parameters"),
//! rendered and held against independent expectations: texture lookups against an f64 CPU
//! implementation of the filter, wrap modes, uv transform and sRGB decoding; a constant texture against
//! the constant; a roughness checkerboard against the mix of its two constant furnaces; a bump map of
//! constant slope against the analytic shading of the tilted plane; cut-outs and stochastic opacity
//! against the fractions of light they let through, for camera and shadow rays.
//!
//! The lookups are seen directly: an emitter whose radiance is the texture, under an orthographic camera
//! without a pixel filter (every sample through the pixel centre), so that each pixel is one lookup at a
//! known uv.

mod common;

use common::{mean_and_se, render_passes};
use std::path::{Path, PathBuf};
use vkpath::Scene;
use vkpath::render::RenderOptions;

/// A scene's TOML in `dir` (so that its texture paths are relative to it).
fn scene_in(dir: &Path, toml: &str) -> Scene {
    Scene::from_toml_str(toml, Some(&dir.join("scene.toml")))
        .unwrap_or_else(|e| panic!("test scene is invalid: {e}"))
}

fn render(scene: &Scene, generic: bool) -> vkpath::Film {
    let options = RenderOptions {
        generic,
        ..RenderOptions::default()
    };
    render_passes(scene, &options, 1, scene.render.samples)
}

/// The unit square z = 0 as an OBJ whose uvs are its (x, y), front face +z.
fn write_square(dir: &Path) -> PathBuf {
    let path = dir.join("square.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    path
}

/// An orthographic view of the unit square from +z, `n` x `n` pixels exactly covering it, pixel centres
/// only: pixel (i, j) sees (x, y) = ((i + 1/2) / n, 1 - (j + 1/2) / n).
fn square_view(n: u32, spp: u32, bounces: u32) -> String {
    format!(
        "[camera]\ntype = \"orthographic\"\nposition = [0.5, 0.5, 1.0]\nlook_at = [0.5, 0.5, 0.0]\nextent = 1.0\n\
         [image]\nwidth = {n}\nheight = {n}\n\
         [render]\nsamples = {spp}\nmax_bounces = {bounces}\nfilter = \"none\"\n"
    )
}

fn srgb_decode(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An f64 texture lookup: the image `texels` (w x h RGBA8, rows from the top) at uv, after the uv
/// transform, wrapped and filtered as texture.wgsl documents.
struct CpuTexture {
    w: usize,
    h: usize,
    texels: Vec<[u8; 4]>,
    srgb: bool,
}

impl CpuTexture {
    fn texel(&self, x: usize, y: usize) -> [f64; 3] {
        let t = self.texels[y * self.w + x];
        [0, 1, 2].map(|k| {
            let c = f64::from(t[k]) / 255.0;
            if self.srgb { srgb_decode(c) } else { c }
        })
    }

    fn wrap(u: f64, wrap: &str) -> f64 {
        match wrap {
            "clamp" => u.clamp(0.0, 1.0),
            "mirror" => {
                let t = u.rem_euclid(2.0);
                if t > 1.0 { 2.0 - t } else { t }
            }
            _ => u.rem_euclid(1.0),
        }
    }

    fn index(i: i64, n: usize, wrap: &str) -> usize {
        match wrap {
            "repeat" => i.rem_euclid(n as i64) as usize,
            _ => i.clamp(0, n as i64 - 1) as usize,
        }
    }

    fn lookup(&self, uv: [f64; 2], wrap: &str, nearest: bool) -> [f64; 3] {
        let (u, v) = (Self::wrap(uv[0], wrap), Self::wrap(uv[1], wrap));
        if nearest {
            let x = ((u * self.w as f64) as usize).min(self.w - 1);
            let y = (((1.0 - v) * self.h as f64) as usize).min(self.h - 1);
            return self.texel(x, y);
        }
        let x = u * self.w as f64 - 0.5;
        let y = (1.0 - v) * self.h as f64 - 0.5;
        let (xf, yf) = (x.floor(), y.floor());
        let (fx, fy) = (x - xf, y - yf);
        let (x0, x1) = (
            Self::index(xf as i64, self.w, wrap),
            Self::index(xf as i64 + 1, self.w, wrap),
        );
        let (y0, y1) = (
            Self::index(yf as i64, self.h, wrap),
            Self::index(yf as i64 + 1, self.h, wrap),
        );
        let (a, b, c, d) = (
            self.texel(x0, y0),
            self.texel(x1, y0),
            self.texel(x0, y1),
            self.texel(x1, y1),
        );
        [0, 1, 2].map(|k| {
            (1.0 - fx) * (1.0 - fy) * a[k]
                + fx * (1.0 - fy) * b[k]
                + (1.0 - fx) * fy * c[k]
                + fx * fy * d[k]
        })
    }
}

/// A 5 x 3 image of fixed pseudo-random texels, saved as PNG.
fn test_image(dir: &Path) -> CpuTexture {
    let (w, h) = (5usize, 3usize);
    let mut state = 12345u32;
    let texels: Vec<[u8; 4]> = (0..w * h)
        .map(|_| {
            [0; 4].map(|_| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (state >> 24) as u8
            })
        })
        .collect();
    let img = image::RgbaImage::from_fn(w as u32, h as u32, |x, y| {
        image::Rgba(texels[y as usize * w + x as usize])
    });
    img.save(dir.join("t.png")).unwrap();
    CpuTexture {
        w,
        h,
        texels,
        srgb: true,
    }
}

/// Every pixel of an emitter whose radiance is the texture equals the f64 lookup at the pixel's uv:
/// bilinear with each wrap mode (the uv transform maps the square to [-0.7, 1.7]^2 rotated, so that
/// every wrap is exercised), nearest, sRGB and linear decoding, a factor. Tolerance: f32 rounding of
/// the transform, weights and decoding (relative 2e-5, plus the 8-bit texel's 1e-6 absolute).
#[test]
fn texture_lookups_match_an_f64_reference() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let mut tex = test_image(dir.path());
    let n = 24u32;
    let rot = 30.0f64;
    let (s, c) = rot.to_radians().sin_cos();
    let (scale, offset) = ([2.4f64, 1.7f64], [-0.7f64, 0.3f64]);
    for (wrap, filter, space, factor) in [
        ("repeat", "bilinear", "srgb", 1.0),
        ("clamp", "bilinear", "srgb", 1.0),
        ("mirror", "bilinear", "linear", 0.5),
        ("repeat", "nearest", "srgb", 2.0),
    ] {
        let toml = format!(
            "{}[materials]\nlamp = {{ type = \"emitter\", radiance = {{ texture = \"t.png\", wrap = \"{wrap}\", \
             filter = \"{filter}\", color_space = \"{space}\", factor = {factor}, scale = [{}, {}], \
             offset = [{}, {}], rotation = {rot} }} }}\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"lamp\"\n",
            square_view(n, 1, 0),
            scale[0],
            scale[1],
            offset[0],
            offset[1]
        );
        let scene = scene_in(dir.path(), &toml);
        let film = render(&scene, false);
        tex.srgb = space == "srgb";
        let mut worst = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (
                    (f64::from(i) + 0.5) / f64::from(n),
                    1.0 - (f64::from(j) + 0.5) / f64::from(n),
                );
                let (su, sv) = (scale[0] * x, scale[1] * y);
                let uv = [c * su - s * sv + offset[0], s * su + c * sv + offset[1]];
                let want = tex.lookup(uv, wrap, filter == "nearest");
                let got = film.pixel(i, j);
                for k in 0..3 {
                    let w = factor * want[k];
                    let err = (f64::from(got[k]) - w).abs();
                    worst = worst.max(err / (w.abs() + 1e-3));
                    assert!(
                        err <= 2e-5 * w.abs() + 1e-6,
                        "{wrap}/{filter}/{space}: pixel ({i}, {j}) channel {k}: {} vs {w}",
                        got[k]
                    );
                }
            }
        }
        eprintln!("{wrap}/{filter}/{space}: worst relative error {worst:.2e}");
    }
}

/// Mitsuba 3's procedural checkerboard (`checkerboard = [c0, c1]`): every pixel of an emitter whose
/// radiance is one is, bit for bit, the f32 product factor x colour of the square its uv falls in, where
/// colour 0 is where frac(u) > 1/2 and frac(v) > 1/2 agree (what Mitsuba 3.9.1's `eval` gives), through
/// the uv transform (scale, rotation, offset); a channel spreads one component (here b). Pixels whose
/// uv lies within 1e-4 of a square's edge are skipped (f32 and f64 may put them on either side). Same
/// bits from the generic kernel.
#[test]
fn a_checkerboard_gives_its_exact_colours_on_mitsubas_squares() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let n = 24u32;
    let colours = [[0.9f32, 0.5, 0.1], [0.1, 0.2, 0.7]];
    let (scale, rot, offset) = ([2.6f64, 1.7f64], 25.0f64, [-0.3f64, 0.45f64]);
    let (sin, cos) = rot.to_radians().sin_cos();
    for (channel, factor) in [("rgb", 2.0f32), ("b", 1.0)] {
        let toml = format!(
            "{}[materials]\nlamp = {{ type = \"emitter\", radiance = {{ checkerboard = [[0.9, 0.5, 0.1], [0.1, 0.2, 0.7]], \
             channel = \"{channel}\", factor = {factor:?}, scale = [{}, {}], rotation = {rot}, offset = [{}, {}] }} }}\n\
             [[mesh]]\nobj = \"square.obj\"\nmaterial = \"lamp\"\n",
            square_view(n, 1, 0),
            scale[0],
            scale[1],
            offset[0],
            offset[1]
        );
        let scene = scene_in(dir.path(), &toml);
        let film = render(&scene, false);
        assert_eq!(film.mean, render(&scene, true).mean, "{channel}: generic");
        let (mut checked, mut seen) = (0, [false; 2]);
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (
                    (f64::from(i) + 0.5) / f64::from(n),
                    1.0 - (f64::from(j) + 0.5) / f64::from(n),
                );
                let (su, sv) = (scale[0] * x, scale[1] * y);
                let uv = [
                    cos * su - sin * sv + offset[0],
                    sin * su + cos * sv + offset[1],
                ];
                let f = uv.map(|t| t - t.floor());
                if f.iter()
                    .any(|&t| [0.0, 0.5, 1.0].iter().any(|e| (t - e).abs() < 1e-4))
                {
                    continue;
                }
                let square = usize::from((f[0] > 0.5) != (f[1] > 0.5));
                seen[square] = true;
                let c = colours[square];
                let want = if channel == "b" { [c[2]; 3] } else { c };
                let got = film.pixel(i, j);
                for k in 0..3 {
                    assert_eq!(
                        got[k].to_bits(),
                        (factor * want[k]).to_bits(),
                        "{channel}: pixel ({i}, {j}) channel {k}: {} vs {}",
                        got[k],
                        factor * want[k]
                    );
                }
                checked += 1;
            }
        }
        assert!(
            checked > 400 && seen == [true; 2],
            "{checked} pixels checked, {seen:?}"
        );
    }
}

/// A `[[triangle]]` with `uv` is textured at those coordinates: the unit square as two such triangles
/// renders the bits of the same square as an OBJ mesh with the same uvs (a checkerboard's squares
/// crossing the diagonal), and without `uv` a triangle's uv is its barycentrics, another image.
#[test]
fn triangles_with_uvs_are_textured_like_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let head = format!(
        "{}[materials]\nlamp = {{ type = \"emitter\", radiance = {{ checkerboard = [[1, 0.5, 0.25], [0.125, 0.25, 1]], scale = [3, 3] }} }}\n",
        square_view(16, 1, 0)
    );
    let mesh = format!("{head}[[mesh]]\nobj = \"square.obj\"\nmaterial = \"lamp\"\n");
    let triangles = |uv: bool| {
        let uvs = |a: &str| {
            if uv {
                format!("uv = {a}\n")
            } else {
                String::new()
            }
        };
        format!(
            "{head}[[triangle]]\nvertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]\nmaterial = \"lamp\"\n{}\
             [[triangle]]\nvertices = [[0, 0, 0], [1, 1, 0], [0, 1, 0]]\nmaterial = \"lamp\"\n{}",
            uvs("[[0, 0], [1, 0], [1, 1]]"),
            uvs("[[0, 0], [1, 1], [0, 1]]")
        )
    };
    let want = render(&scene_in(dir.path(), &mesh), false).mean;
    assert!(want.iter().any(|p| p[0] != want[0][0]), "the pattern shows");
    assert_eq!(
        render(&scene_in(dir.path(), &triangles(true)), false).mean,
        want
    );
    assert_ne!(
        render(&scene_in(dir.path(), &triangles(false)), false).mean,
        want
    );
}

/// A one-texel texture of value c renders the same bits as the constant c, specialised and generic, on a
/// glTF metallic-roughness surface lit by a sun (base colour, roughness and metallic all from it): an f16
/// texel (EXR) holds c = 0.625 exactly, and the nearest filter returns it unweighted. (Bilinear weights
/// of one texel sum to 1 only up to rounding. Not a rough plastic: its coat's transmittance is tabulated
/// for a constant roughness, and a textured one keeps the smooth coat's.)
#[test]
fn a_constant_texture_renders_the_constant() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let value = 0.625f32;
    image::Rgba32FImage::from_pixel(1, 1, image::Rgba([value, value, value, 1.0]))
        .save(dir.path().join("c.exr"))
        .unwrap();
    let light =
        "[[light]]\ntype = \"directional\"\ndirection = [-0.3, -0.2, -1.0]\nirradiance = 3.0\n";
    let mesh = "[[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n";
    let constant = format!(
        "{}[materials]\nm = {{ type = \"metallic_roughness\", base_color = [{value:?}, {value:?}, {value:?}], roughness = {value:?}, metallic = {value:?} }}\n{mesh}{light}",
        square_view(16, 4, 2)
    );
    let textured = format!(
        "{}[materials]\nm = {{ type = \"metallic_roughness\", base_color = {{ texture = \"c.exr\", filter = \"nearest\" }}, \
         roughness = {{ texture = \"c.exr\", filter = \"nearest\" }}, metallic = {{ texture = \"c.exr\", filter = \"nearest\" }} }}\n{mesh}{light}",
        square_view(16, 4, 2)
    );
    for generic in [false, true] {
        let a = render(&scene_in(dir.path(), &constant), generic);
        let b = render(&scene_in(dir.path(), &textured), generic);
        assert!(a.mean.iter().any(|p| p[1] > 0.01), "the plane is lit");
        assert_eq!(a.mean, b.mean, "generic {generic}");
    }
}

/// Roughness from a texture: a furnace (a white Schlick conductor, f0 = 1, under a uniform environment
/// of radiance 1, one bounce) whose roughness is a 2 x 2 checkerboard of r1 and r2 (nearest filter, the
/// texel edges on pixel edges) renders, pixel for pixel, either the r1 furnace or the r2 one, and its
/// image mean is the area-weighted mix of the two (half each). Tolerance 1e-4 relative: the same random
/// numbers give the same paths, but the textured image's mean sits 2e-5 above the mix (measured, the
/// same in the generic and specialised kernels; its cause is not yet traced).
#[test]
fn a_roughness_checkerboard_mixes_the_two_constant_furnaces() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    // (f16 texels, exact: the textured alpha 1 x r^2 is then the constant's r^2 to the bit.)
    let (r1, r2) = (0.25f32, 0.875f32);
    let img = image::Rgba32FImage::from_fn(2, 2, |x, y| {
        let r = if (x + y) % 2 == 0 { r1 } else { r2 };
        image::Rgba([r, r, r, 1.0])
    });
    img.save(dir.path().join("checker.exr")).unwrap();
    let base = |roughness: &str| {
        format!(
            "{}[environment]\nradiance = [1.0, 1.0, 1.0]\n[materials]\nm = {{ type = \"conductor\", base_color = [1.0, 1.0, 1.0], \
             roughness = {roughness} }}\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n",
            square_view(16, 16, 1)
        )
    };
    // All three in the generic kernel: one program, so the same arithmetic for every pixel (kernels
    // specialised differently may contract multiply-adds differently and round apart by an ulp).
    let f1 = render(&scene_in(dir.path(), &base(&format!("{r1:?}"))), true);
    let f2 = render(&scene_in(dir.path(), &base(&format!("{r2:?}"))), true);
    let ft = render(
        &scene_in(
            dir.path(),
            &base("{ texture = \"checker.exr\", filter = \"nearest\" }"),
        ),
        true,
    );
    let (m1, m2, mt) = (f1.average(), f2.average(), ft.average());
    assert!(
        (m1 - m2).abs() > 0.01,
        "the two roughnesses differ: {m1} {m2}"
    );
    for j in 0..16u32 {
        for i in 0..16u32 {
            // Texel (x, y) of the 2 x 2 image covers pixels [8x, 8x + 8) x [8y, 8y + 8) (rows from the top).
            let want = if (i / 8 + j / 8) % 2 == 0 { &f1 } else { &f2 };
            let (got, want) = (ft.pixel(i, j), want.pixel(i, j));
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() <= 1e-4 * want[k],
                    "pixel ({i}, {j}): {got:?} vs {want:?}"
                );
            }
        }
    }
    let mix = 0.5 * (m1 + m2);
    assert!((mt - mix).abs() <= 1e-4 * mix, "{mt} vs {mix}");
}

/// Bump: a height texture of constant slope on the plane z = 0 (a ramp across u: texel k of 256 holds
/// k / 255, so between texel centres h(u) = scale (256 u - 1/2) / 255, clamped at the edges) shades like
/// the plane tilted by that slope: the shading normal is (-g, 0, 1) / |(-g, 0, 1)|, g = dh/du =
/// scale 256 / 255, and a diffuse surface of albedo a under a sun of irradiance E along l reflects
/// a E max(0, n.l) / pi (the course's formula with the tilted normal), computed here in f64.
#[test]
fn a_bump_map_of_constant_slope_shades_like_the_tilted_plane() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let img = image::RgbaImage::from_fn(256, 4, |x, _| {
        let k = x as u8;
        image::Rgba([k, k, k, 255])
    });
    img.save(dir.path().join("ramp.png")).unwrap();
    let (a, e) = (0.6f64, 2.0f64);
    let l = common::vec::normalize([0.5, 0.1, 1.0]);
    let n = 32u32;
    for scale in [0.25f64, -0.6] {
        let toml = format!(
            "{}[materials]\nm = {{ type = \"diffuse\", albedo = [{a}, {a}, {a}], bump = {{ texture = \"ramp.png\", \
             scale = {scale}, wrap = \"clamp\" }} }}\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n\
             [[light]]\ntype = \"directional\"\ndirection = [{}, {}, {}]\nirradiance = {e}\n",
            square_view(n, 1, 1),
            -l[0],
            -l[1],
            -l[2]
        );
        let film = render(&scene_in(dir.path(), &toml), false);
        let g = scale * 256.0 / 255.0;
        let normal = common::vec::normalize([-g, 0.0, 1.0]);
        let want = a * e * common::vec::dot(normal, l).max(0.0) / std::f64::consts::PI;
        // Pixels whose central differences stay inside the ramp (u in [1.5/256, 1 - 1.5/256]).
        for j in 0..n {
            for i in 1..n - 1 {
                let got = f64::from(film.pixel(i, j)[0]);
                assert!(
                    (got - want).abs() <= 2e-4 * want,
                    "scale {scale}, pixel ({i}, {j}): {got} vs {want}"
                );
            }
        }
        // And not the flat plane's shading.
        let flat = a * e * l[2] / std::f64::consts::PI;
        assert!((want - flat).abs() > 0.02 * flat);
    }
}

/// A cut-out: an occluder of albedo 0 in front of an emitter of radiance 1, cut out by a 2 x 2 checker
/// mask (opacity 0 and 1, nearest, alpha_cutoff 0.5) whose texel edges fall on pixel edges, lets
/// through exactly half the light (the area fraction of the holes); the holes are where the mask's
/// zeros are.
#[test]
fn a_cut_out_transmits_its_area_fraction() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let img = image::RgbaImage::from_fn(2, 2, |x, y| {
        let a = if (x + y) % 2 == 0 { 0 } else { 255 };
        image::Rgba([255, 255, 255, a])
    });
    img.save(dir.path().join("mask.png")).unwrap();
    // The emitter: a large triangle behind the square, facing +z.
    let toml = format!(
        "{}[materials]\nblack = {{ type = \"diffuse\", albedo = [0.0, 0.0, 0.0], opacity = {{ texture = \"mask.png\", \
         channel = \"a\", filter = \"nearest\" }}, alpha_cutoff = 0.5 }}\nlamp = {{ type = \"emitter\", radiance = [1.0, 1.0, 1.0] }}\n\
         [[mesh]]\nobj = \"square.obj\"\nmaterial = \"black\"\n\
         [[triangle]]\nvertices = [[-5.0, -5.0, -1.0], [5.0, -5.0, -1.0], [0.0, 5.0, -1.0]]\nmaterial = \"lamp\"\n",
        square_view(16, 2, 1)
    );
    let film = render(&scene_in(dir.path(), &toml), false);
    assert_eq!(film.average(), 0.5);
    assert_eq!(film.pixel(0, 0), [1.0; 3], "texel (0, 0) is a hole");
    assert_eq!(film.pixel(15, 0), [0.0; 3]);
}

/// Stochastic transparency (no alpha_cutoff): an occluder of opacity 0.3 lets 0.7 of the light through,
/// within the noise of the Bernoulli choices: for camera rays (an emitter seen through it) and for
/// shadow rays (a floor under a sun, seen from above past the occluder's edge: the occluder covers the
/// floor's lit half from the sun only). 4 standard errors.
#[test]
fn stochastic_opacity_transmits_one_minus_opacity() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    // Camera rays.
    let toml = format!(
        "{}[materials]\nveil = {{ type = \"diffuse\", albedo = [0.0, 0.0, 0.0], opacity = 0.3 }}\n\
         lamp = {{ type = \"emitter\", radiance = [1.0, 1.0, 1.0] }}\n\
         [[mesh]]\nobj = \"square.obj\"\nmaterial = \"veil\"\n\
         [[triangle]]\nvertices = [[-5.0, -5.0, -1.0], [5.0, -5.0, -1.0], [0.0, 5.0, -1.0]]\nmaterial = \"lamp\"\n",
        square_view(32, 16, 1)
    );
    let film = render(&scene_in(dir.path(), &toml), false);
    let (mean, se) = mean_and_se(&film);
    assert!(se > 0.0 && se < 0.01, "se {se}");
    assert!((mean - 0.7).abs() < 4.0 * se, "camera rays: {mean} +- {se}");

    // Shadow rays: the floor z = 0 lit by a sun straight down (-z), under a veil at z = 0.5 that the
    // camera, looking straight down too, sees through... so the camera sees the veil as well: give the
    // veil a camera-invisible place instead. The sun comes in along (1, 0, -1) / sqrt 2; the veil is the
    // square x in [-1, 0] lifted to z = 0.5... whose shadow falls on x in [-0.5, 0.5]: the camera sees
    // the floor's x in [0, 1] half, of which [0, 0.5] is in the veil's shadow.
    let veil = dir.path().join("veil.obj");
    std::fs::write(
        &veil,
        "v -1 -1 0.5\nv 0 -1 0.5\nv 0 2 0.5\nv -1 2 0.5\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let n = 32u32;
    let toml = format!(
        "{}[materials]\nveil = {{ type = \"diffuse\", albedo = [0.0, 0.0, 0.0], opacity = 0.3 }}\n\
         floor = {{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }}\n\
         [[mesh]]\nobj = \"square.obj\"\nmaterial = \"floor\"\n[[mesh]]\nobj = \"veil.obj\"\nmaterial = \"veil\"\n\
         [[light]]\ntype = \"directional\"\ndirection = [1.0, 0.0, -1.0]\nirradiance = 2.0\n",
        square_view(n, 16, 1)
    );
    let film = render(&scene_in(dir.path(), &toml), false);
    let lit = 0.5 * 2.0 * std::f64::consts::FRAC_1_SQRT_2 / std::f64::consts::PI;
    let (mut shadow_sum, mut shadow_var, mut count) = (0.0, 0.0, 0.0);
    for j in 0..n {
        for i in 0..n {
            let x = (f64::from(i) + 0.5) / f64::from(n);
            let p = f64::from(film.pixel(i, j)[1]);
            if x < 0.5 - 1e-9 {
                shadow_sum += p;
                shadow_var += f64::from(film.variance[(j * n + i) as usize][1]);
                count += 1.0;
            } else {
                assert!(
                    (p - lit).abs() < 1e-5 * lit,
                    "unshadowed pixel ({i}, {j}): {p} vs {lit}"
                );
            }
        }
    }
    let mean = shadow_sum / count;
    let se = shadow_var.sqrt() / count;
    assert!(se > 0.0, "the veil's shadow is noisy");
    assert!(
        (mean - 0.7 * lit).abs() < 4.0 * se,
        "shadow rays: {mean} +- {se} vs {}",
        0.7 * lit
    );
}

/// Texture keys are checked like every other key: each bad value names its key and line.
#[test]
fn bad_texture_references_are_refused_by_key() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    image::RgbaImage::from_pixel(1, 1, image::Rgba([1, 2, 3, 4]))
        .save(dir.path().join("c.png"))
        .unwrap();
    let cases = [
        (
            "albedo = { texture = \"c.png\", wrap = \"tile\" }",
            "materials.m.albedo.wrap",
        ),
        (
            "albedo = { texture = \"c.png\", channel = \"x\" }",
            "materials.m.albedo.channel",
        ),
        (
            "albedo = { texture = \"missing.png\" }",
            "materials.m.albedo.texture",
        ),
        (
            "albedo = { texture = \"c.png\", factor = 1.5 }",
            "materials.m.albedo.factor",
        ),
        (
            "albedo = { texture = \"c.png\", scale = 2.0 }",
            "materials.m.albedo.scale",
        ),
        ("albedo = { texture = \"c.png\", bogus = 1 }", "bogus"),
        (
            "albedo = [0.5, 0.5, 0.5], opacity = 1.5",
            "materials.m.opacity",
        ),
        (
            "albedo = [0.5, 0.5, 0.5], alpha_cutoff = -0.1",
            "materials.m.alpha_cutoff",
        ),
        (
            "albedo = [0.5, 0.5, 0.5], bump = { texture = \"c.png\", scale = [1.0, 1.0] }",
            "materials.m.bump.scale",
        ),
        (
            "albedo = [0.5, 0.5, 0.5], bump = { texture = \"c.png\", factor = 2.0 }",
            "materials.m.bump.factor",
        ),
        (
            "albedo = { texture = \"c.png\", checkerboard = [0.1, 0.2] }",
            "materials.m.albedo",
        ),
        ("albedo = { factor = 0.5 }", "materials.m.albedo"),
        (
            "albedo = { checkerboard = [0.1, 0.2, 0.3] }",
            "materials.m.albedo.checkerboard",
        ),
        (
            "albedo = { checkerboard = [0.1, -0.2] }",
            "materials.m.albedo.checkerboard",
        ),
        (
            "albedo = { checkerboard = [0.1, 0.2], wrap = \"clamp\" }",
            "materials.m.albedo.wrap",
        ),
        (
            "albedo = [0.5, 0.5, 0.5], bump = { checkerboard = [0.1, 0.2] }",
            "materials.m.bump.checkerboard",
        ),
    ];
    for (material, key) in cases {
        let toml = format!(
            "{}[materials]\nm = {{ type = \"diffuse\", {material} }}\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n",
            square_view(4, 1, 1)
        );
        let e = Scene::from_toml_str(&toml, Some(&dir.path().join("scene.toml")))
            .err()
            .unwrap_or_else(|| panic!("{material}: accepted"));
        let msg = e.to_string();
        assert!(msg.contains(key), "{material}: {msg}");
        assert!(msg.contains("line"), "{material}: {msg}");
    }
}

/// A conductor's tint multiplies its Fresnel reflectance (Mitsuba's specular_reflectance): with a
/// tint of powers of two every sample is scaled exactly, so the tinted image is the untinted one times
/// the tint, bit for bit, per channel; for a conductor given by a preset (the tint in `albedo`), by
/// Schlick's base colour (the tint in `eta`), and with the tint as a texture (an f16 texel of 0.5,
/// nearest) on the preset. A rough metal square under a uniform environment, two bounces.
#[test]
fn a_conductor_tint_scales_its_reflectance_exactly() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    image::Rgba32FImage::from_pixel(1, 1, image::Rgba([0.5, 0.25, 1.0, 1.0]))
        .save(dir.path().join("tint.exr"))
        .unwrap();
    let scene = |material: &str| {
        format!(
            "{}[environment]\nradiance = [1.0, 1.0, 1.0]\n[materials]\nm = {{ type = \"conductor\", roughness = 0.4, {material} }}\n\
             [[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n",
            square_view(8, 8, 2)
        )
    };
    let tint = [0.5f32, 0.25, 1.0];
    for (fresnel, tinted) in [
        ("preset = \"gold\"", "tint = [0.5, 0.25, 1.0]"),
        ("base_color = [0.9, 0.6, 0.3]", "tint = [0.5, 0.25, 1.0]"),
        (
            "preset = \"gold\"",
            "tint = { texture = \"tint.exr\", filter = \"nearest\" }",
        ),
    ] {
        let plain = render(&scene_in(dir.path(), &scene(fresnel)), false);
        let with = render(
            &scene_in(dir.path(), &scene(&format!("{fresnel}, {tinted}"))),
            false,
        );
        assert!(plain.average() > 0.05, "{fresnel}: the metal reflects");
        for (p, w) in plain.mean.iter().zip(&with.mean) {
            for c in 0..3 {
                assert_eq!(w[c], p[c] * tint[c], "{fresnel}, {tinted}: {w:?} vs {p:?}");
            }
        }
    }
    // A textured tint beside base_color (whose slot it would share) is refused by key.
    let e = Scene::from_toml_str(
        &scene("base_color = [0.9, 0.6, 0.3], tint = { texture = \"tint.exr\" }"),
        Some(&dir.path().join("scene.toml")),
    )
    .expect_err("refused");
    assert!(e.to_string().contains("materials.m.tint"), "{e}");
}

/// A normal map and its equivalent bump map agree: the ramp of
/// `a_bump_map_of_constant_slope_shades_like_the_tilted_plane` (slope g = scale 256 / 255) and a constant
/// tangent-space normal map holding that bumped normal, (-g, 0, 1) / |(-g, 0, 1)| (tangent +x = dp/du,
/// bitangent +y = dp/dv), encoded (m + 1) / 2 in f16 (a precision of about 2^-11), shade the square alike
/// under a sun: within 2e-3 relative, the f16 encoding's error.
#[test]
fn a_normal_map_and_its_equivalent_bump_map_agree() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    image::RgbaImage::from_fn(256, 4, |x, _| {
        let k = x as u8;
        image::Rgba([k, k, k, 255])
    })
    .save(dir.path().join("ramp.png"))
    .unwrap();
    let scale = 0.25f64;
    let g = scale * 256.0 / 255.0;
    let m = common::vec::normalize([-g, 0.0, 1.0]);
    let enc = |c: f64| (0.5 * (c + 1.0)) as f32;
    image::Rgba32FImage::from_pixel(1, 1, image::Rgba([enc(m[0]), enc(m[1]), enc(m[2]), 1.0]))
        .save(dir.path().join("normal.exr"))
        .unwrap();
    let n = 16u32;
    let toml = |modifier: &str| {
        format!(
            "{}[materials]\nm = {{ type = \"diffuse\", albedo = [0.6, 0.6, 0.6], {modifier} }}\n\
             [[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n\
             [[light]]\ntype = \"directional\"\ndirection = [-0.5, -0.1, -1.0]\nirradiance = 2.0\n",
            square_view(n, 1, 1)
        )
    };
    let bump = render(
        &scene_in(
            dir.path(),
            &toml(&format!(
                "bump = {{ texture = \"ramp.png\", scale = {scale}, wrap = \"clamp\" }}"
            )),
        ),
        false,
    );
    let normal = render(
        &scene_in(
            dir.path(),
            &toml("normal_map = { texture = \"normal.exr\", filter = \"nearest\" }"),
        ),
        false,
    );
    // (The bump map's edge columns, whose central differences reach the clamped ends, are left out.)
    for j in 0..n {
        for i in 1..n - 1 {
            let (b, nm) = (bump.pixel(i, j)[0], normal.pixel(i, j)[0]);
            assert!(b > 0.1, "lit");
            assert!(
                (b - nm).abs() <= 2e-3 * b,
                "pixel ({i}, {j}): bump {b}, normal map {nm}"
            );
        }
    }
}

/// one_sided (Mitsuba's BSDFs without twosided): a diffuse square under a uniform sky is black seen from
/// behind, exactly, and seen from the front renders the same bits as the two-sided square; two-sided, its
/// back reflects a E / pi = a (albedo 0.5 under radiance 1, the sky unoccluded), within 5 standard errors.
#[test]
fn a_one_sided_material_is_black_from_behind() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let n = 8;
    let view = |z: f32| {
        format!(
            "[camera]\ntype = \"orthographic\"\nposition = [0.5, 0.5, {z}]\nlook_at = [0.5, 0.5, 0.0]\nextent = 1.0\n\
             [image]\nwidth = {n}\nheight = {n}\n[render]\nsamples = 256\nmax_bounces = 1\nfilter = \"none\"\n\
             [environment]\nradiance = [1.0, 1.0, 1.0]\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"m\"\n"
        )
    };
    let scene = |z: f32, one_sided: bool| {
        let toml = format!(
            "{}[materials]\nm = {{ type = \"diffuse\", albedo = [0.5, 0.5, 0.5], one_sided = {one_sided} }}\n",
            view(z)
        );
        render(&scene_in(dir.path(), &toml), false)
    };
    let back = scene(-1.0, true);
    assert!(
        back.mean.iter().all(|p| p[..3] == [0.0; 3]),
        "{:?}",
        &back.mean[..4]
    );
    assert_eq!(scene(1.0, true).mean, scene(1.0, false).mean);
    let lit = scene(-1.0, false);
    let values: Vec<f64> = lit.mean.iter().map(|p| f64::from(p[1])).collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let sd =
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (values.len() - 1) as f64).sqrt();
    let se = sd / (values.len() as f64).sqrt();
    assert!((mean - 0.5).abs() < 5.0 * se + 1e-3, "{mean} +- {se}");
}

/// back (Mitsuba's twosided with two BSDFs): a square whose front is red and whose back material is
/// blue, under a uniform sky of radiance 1, reflects a E / pi = a from each face: the red albedo seen
/// from the front, the blue one from behind, each within 5 standard errors per channel; seen from the
/// front it renders the same bits as the red material alone (the specialised kernel against the generic
/// one: scenes/spot-instances.toml, in tests/specialise.rs). A material that is its own back, or a back
/// with a back, is refused.
#[test]
fn a_back_material_shows_on_the_back_face() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    let n = 8;
    let toml = |z: f32, materials: &str| {
        format!(
            "[camera]\ntype = \"orthographic\"\nposition = [0.5, 0.5, {z}]\nlook_at = [0.5, 0.5, 0.0]\nextent = 1.0\n\
             [image]\nwidth = {n}\nheight = {n}\n[render]\nsamples = 256\nmax_bounces = 1\nfilter = \"none\"\n\
             [environment]\nradiance = [1.0, 1.0, 1.0]\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"front\"\n\
             [materials]\n{materials}"
        )
    };
    let pair = "front = { type = \"diffuse\", albedo = [0.8, 0.1, 0.1], back = \"blue\" }\n\
                blue = { type = \"diffuse\", albedo = [0.1, 0.2, 0.7] }\n";
    let mean_within = |film: &vkpath::Film, albedo: [f64; 3]| {
        for (c, &a) in albedo.iter().enumerate() {
            let values: Vec<f64> = film.mean.iter().map(|p| f64::from(p[c])).collect();
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / (values.len() - 1) as f64)
                .sqrt();
            let se = sd / (values.len() as f64).sqrt();
            assert!(
                (mean - a).abs() < 5.0 * se + 1e-3,
                "channel {c}: {mean} +- {se} against {a}"
            );
        }
    };
    let back = render(&scene_in(dir.path(), &toml(-1.0, pair)), false);
    mean_within(&back, [0.1, 0.2, 0.7]);
    let front = render(&scene_in(dir.path(), &toml(1.0, pair)), false);
    mean_within(&front, [0.8, 0.1, 0.1]);
    let red_alone = render(
        &scene_in(
            dir.path(),
            &toml(
                1.0,
                "front = { type = \"diffuse\", albedo = [0.8, 0.1, 0.1] }\n",
            ),
        ),
        false,
    );
    assert_eq!(front.mean, red_alone.mean);
    for (materials, want) in [
        (
            "front = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], back = \"front\" }\n",
            "its own back",
        ),
        (
            "front = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], back = \"b\" }\n\
             b = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], back = \"front\" }\n",
            "a back of its own",
        ),
        (
            "front = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], back = \"nowhere\" }\n",
            "nowhere",
        ),
    ] {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, toml(1.0, materials)).unwrap();
        let e = vkpath::Scene::load(&path).unwrap_err();
        assert!(
            e.to_string().contains(want) && e.key().is_some_and(|k| k.ends_with(".back")),
            "{e}"
        );
    }
}

/// blend (Mitsuba's blendbsdf): a square of albedo a blended with one of albedo b at weight w reflects
/// (1 - w) a + w b under a uniform sky (each hit shaded by one of the two), within 5 standard errors per
/// channel, for a constant weight and for a texture of one texel (linear data: 64/255). A blend of a blend,
/// a blend with itself and a weight without a blend are refused.
#[test]
fn a_blend_material_mixes_in_expectation() {
    let dir = tempfile::tempdir().unwrap();
    write_square(dir.path());
    image::GrayImage::from_pixel(1, 1, image::Luma([64]))
        .save(dir.path().join("w.png"))
        .unwrap();
    let n = 8;
    let toml = |materials: &str| {
        format!(
            "[camera]\ntype = \"orthographic\"\nposition = [0.5, 0.5, 1.0]\nlook_at = [0.5, 0.5, 0.0]\nextent = 1.0\n\
             [image]\nwidth = {n}\nheight = {n}\n[render]\nsamples = 512\nmax_bounces = 1\nfilter = \"none\"\n\
             [environment]\nradiance = [1.0, 1.0, 1.0]\n[[mesh]]\nobj = \"square.obj\"\nmaterial = \"a\"\n\
             [materials]\n{materials}b = {{ type = \"diffuse\", albedo = [0.1, 0.2, 0.9] }}\n"
        )
    };
    let (a, b) = ([0.8, 0.6, 0.1], [0.1, 0.2, 0.9]);
    for (weight, w) in [("0.25", 0.25), ("{ texture = \"w.png\" }", 64.0 / 255.0)] {
        let scene = scene_in(
            dir.path(),
            &toml(&format!(
                "a = {{ type = \"diffuse\", albedo = [0.8, 0.6, 0.1], blend = \"b\", blend_weight = {weight} }}\n"
            )),
        );
        let film = render(&scene, false);
        for c in 0..3 {
            let values: Vec<f64> = film.mean.iter().map(|p| f64::from(p[c])).collect();
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / (values.len() - 1) as f64)
                .sqrt();
            let se = sd / (values.len() as f64).sqrt();
            let want = (1.0 - w) * a[c] + w * b[c];
            assert!(
                (mean - want).abs() < 5.0 * se + 2e-3,
                "weight {weight}, channel {c}: {mean} +- {se} against {want}"
            );
        }
    }
    for (materials, key, want) in [
        (
            "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], blend = \"a\" }\n",
            "materials.a.blend",
            "itself",
        ),
        (
            "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], blend = \"c\" }\n\
             c = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], blend = \"b\" }\n",
            "materials.a.blend",
            "a blend of its own",
        ),
        (
            "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], blend_weight = 0.5 }\n",
            "materials.a.blend_weight",
            "names none",
        ),
    ] {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, toml(materials)).unwrap();
        let e = vkpath::Scene::load(&path).unwrap_err();
        assert!(e.to_string().contains(want) && e.key() == Some(key), "{e}");
    }
}
