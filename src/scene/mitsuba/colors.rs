//! Colour and scalar parameters: an `<rgb>`, a `<spectrum>`, a `<float>` (a grey), or a texture: `srgb`
//! (a colour), `bitmap` (a file) or `checkerboard` (both a texture reference of vkpath's material, read
//! at the mesh's uv through the texture's `to_uv`).

use super::args::{Args, resolve_ref};
use super::context::Tr;
use super::objects::{Loc, Obj, Prop, Value};
use super::toml_out::{num, vec3};
use crate::scene::SceneError;
use glam::DVec3;
use std::path::{Path, PathBuf};

/// A colour parameter: a colour, or a texture (a bitmap or a checkerboard).
#[derive(Clone, Debug)]
pub(super) enum ColorTex {
    Color(DVec3),
    Bitmap(Bitmap),
}

/// A texture vkpath reads through a texture reference: a `bitmap` as Mitsuba 3 reads it (the file, its
/// `filter_type`, bilinear or nearest, its `wrap_mode`, repeat, mirror or clamp: vkpath's names too, and
/// `raw`: 8-bit texels not decoded from sRGB), or a `checkerboard`; with its `to_uv` transform, and the
/// element naming the file (the texture's, for a checkerboard).
#[derive(Clone, Debug)]
pub(super) struct Bitmap {
    pub(super) source: Source,
    pub(super) loc: Loc,
    nearest: bool,
    wrap: String,
    raw: bool,
    /// `to_uv` as vkpath's uv transform; `None`: the identity.
    to_uv: Option<UvTransform>,
}

/// A uv transform as vkpath's texture references write it: uv' = R(rotation) diag(scale) uv + offset
/// (scale, rotation in degrees, offset).
type UvTransform = ([f64; 2], f64, [f64; 2]);

/// What a [`Bitmap`] reads.
#[derive(Clone, Debug)]
pub(super) enum Source {
    File(PathBuf),
    /// Mitsuba's procedural checkerboard: `color0`, `color1` (defaults 0.4, 0.2).
    Checkerboard([DVec3; 2]),
}

impl Bitmap {
    /// The file it reads, if it is a bitmap.
    pub(super) fn path(&self) -> Option<&PathBuf> {
        match &self.source {
            Source::File(p) => Some(p),
            Source::Checkerboard(_) => None,
        }
    }
}

impl Tr<'_> {
    /// A colour parameter that may not be a texture.
    pub(super) fn color(
        &mut self,
        args: &Args,
        name: &str,
        default: DVec3,
    ) -> Result<DVec3, SceneError> {
        match self.color_tex(args, name, default)? {
            ColorTex::Color(c) => Ok(c),
            ColorTex::Bitmap(b) => Err(b.loc.error(
                format!("a bitmap texture as \"{name}\": vkpath reads textures for reflectances, a mask's opacity and a bump map's height only"),
                "Give a colour (<rgb>) here.",
            )),
        }
    }

    /// A colour parameter: `<rgb>`, a uniform `<spectrum>`, a `<float>` (grey), or a texture: `bitmap`
    /// (a file) or `srgb` (a colour).
    pub(super) fn color_tex(
        &mut self,
        args: &Args,
        name: &str,
        default: DVec3,
    ) -> Result<ColorTex, SceneError> {
        let Some(p) = args.prop(name) else {
            return Ok(ColorTex::Color(default));
        };
        let obj = match &p.value {
            Value::Rgb(c) => return Ok(ColorTex::Color(*c)),
            Value::Spectrum(x) | Value::Float(x) => return Ok(ColorTex::Color(DVec3::splat(*x))),
            Value::Integer(i) => return Ok(ColorTex::Color(DVec3::splat(*i as f64))),
            Value::Object(o) => o.clone(),
            Value::Ref(id) => resolve_ref(self.ids, id, &p.loc)?,
            _ => return Err(Args::wrong(p, "a colour (<rgb>, <spectrum> or a texture)")),
        };
        if obj.tag != "texture" {
            return Err(obj.loc.error(
                format!("\"{name}\" is a <{}>, not a colour or texture", obj.tag),
                "Give an <rgb> or a <texture type=\"bitmap\">.",
            ));
        }
        self.texture(&obj)
    }

    /// A `<texture>` object: `bitmap` (a file) or `srgb` (a colour).
    pub(super) fn texture(&mut self, obj: &Obj) -> Result<ColorTex, SceneError> {
        self.translated.insert(obj as *const Obj as usize);
        let targs = Args::new(obj);
        let out = match obj.kind.as_str() {
            "srgb" => {
                let c = match targs.prop("color") {
                    Some(Prop {
                        value: Value::Rgb(c) | Value::Vector(c),
                        ..
                    }) => *c,
                    Some(q) => return Err(Args::wrong(q, "an <rgb>")),
                    None => {
                        return Err(obj.loc.error(
                            "an srgb texture needs a color",
                            "Give <rgb name=\"color\" .../>.",
                        ));
                    }
                };
                let _ = targs.boolean("unbounded")?;
                self.finish(&targs, &["color", "unbounded"])?;
                ColorTex::Color(c)
            }
            "bitmap" => {
                let Some((file, floc)) = targs.string("filename")? else {
                    return Err(obj.loc.error(
                        "a bitmap texture needs a filename (vkpath does not read in-memory bitmaps)",
                        "Give <string name=\"filename\" value=\"texture.png\"/>.",
                    ));
                };
                let path = self.file(file, floc);
                let raw = targs.boolean("raw")?.is_some_and(|(r, _)| r);
                let nearest = match targs.string("filter_type")? {
                    None | Some(("bilinear", _)) => false,
                    Some(("nearest", _)) => true,
                    Some((f, l)) => {
                        return Err(l.error(
                            format!("filter_type \"{f}\" is not one of Mitsuba's"),
                            "Give \"bilinear\" (the default) or \"nearest\".",
                        ));
                    }
                };
                let wrap = match targs.string("wrap_mode")? {
                    None => "repeat",
                    Some((w @ ("repeat" | "mirror" | "clamp"), _)) => w,
                    Some((w, l)) => {
                        return Err(l.error(
                            format!("wrap_mode \"{w}\" is not one of Mitsuba's"),
                            "Give \"repeat\" (the default), \"mirror\" or \"clamp\".",
                        ));
                    }
                };
                let to_uv = self.to_uv(&targs)?;
                self.finish(
                    &targs,
                    &["filename", "raw", "filter_type", "wrap_mode", "to_uv"],
                )?;
                ColorTex::Bitmap(Bitmap {
                    source: Source::File(path),
                    loc: floc.clone(),
                    nearest,
                    wrap: wrap.to_string(),
                    raw,
                    to_uv,
                })
            }
            "checkerboard" => {
                // Mitsuba 3 (3.9.1 checked): colour 0 where frac(u) > 1/2 and frac(v) > 1/2 agree.
                let c0 = self.color(&targs, "color0", DVec3::splat(0.4))?;
                let c1 = self.color(&targs, "color1", DVec3::splat(0.2))?;
                let to_uv = self.to_uv(&targs)?;
                self.finish(&targs, &["color0", "color1", "to_uv"])?;
                ColorTex::Bitmap(Bitmap {
                    source: Source::Checkerboard([c0, c1]),
                    loc: obj.loc.clone(),
                    nearest: false,
                    wrap: "repeat".into(),
                    raw: true,
                    to_uv,
                })
            }
            _ => {
                return Err(obj.loc.error(
                    format!("vkpath does not read Mitsuba's texture \"{}\"", obj.kind),
                    "Use a bitmap texture (a file), a checkerboard or an <rgb>.",
                ));
            }
        };
        Ok(out)
    }
}

impl Tr<'_> {
    /// A texture's `to_uv` (a <transform>) as vkpath's uv transform: Mitsuba applies the 4x4 matrix's
    /// x-y block and its translation to (u, v) (uv' = M uv + t); vkpath's texture reference writes M as
    /// R(rotation) diag(scale), which holds every M whose columns are orthogonal (scales, rotations,
    /// mirrors and their products); a shear is refused. The identity is `None`.
    fn to_uv(&self, targs: &Args) -> Result<Option<UvTransform>, SceneError> {
        let Some((xf, loc)) = targs.transform("to_uv")? else {
            return Ok(None);
        };
        let m = xf.m;
        // Columns of the x-y block: M e_u = su (cos t, sin t), M e_v = sv (-sin t, cos t).
        let (cu, cv) = (m.x_axis, m.y_axis);
        let offset = [m.w_axis.x, m.w_axis.y];
        let su = (cu.x * cu.x + cu.y * cu.y).sqrt();
        let theta = cu.y.atan2(cu.x);
        let (sin, cos) = theta.sin_cos();
        let sv = -sin * cv.x + cos * cv.y;
        let shear = cos * cv.x + sin * cv.y;
        let size = su.max(sv.abs());
        let plane = su > 0.0 && sv != 0.0 && su.is_finite() && sv.is_finite();
        if !(plane && shear.abs() <= 1e-9 * size) {
            return Err(loc.error(
                "a to_uv that shears or collapses the uv plane",
                "vkpath's textures take a uv transform of scales, a rotation and a translation (their \
                 products); give to_uv as <scale>, <rotate z=\"1\">, <translate> elements.",
            ));
        }
        if (su, sv, theta, offset) == (1.0, 1.0, 0.0, [0.0, 0.0]) {
            return Ok(None);
        }
        Ok(Some(([su, sv], theta.to_degrees(), offset)))
    }

    /// A texture as a vkpath texture reference (an inline TOML table) with Mitsuba's meaning: 8-bit
    /// texels are sRGB-decoded unless `raw`, floating-point files (EXR, HDR) are linear; a `scalar`
    /// parameter reads a bitmap's luminance of the decoded colour (Mitsuba's `eval_1`; an image's alpha is
    /// not read, as Mitsuba does not), a checkerboard's mean of each colour's channels (what Mitsuba 3's
    /// `eval_1` gives for an <rgb>), with the two colours swapped: its `eval_1` tests the opposite
    /// squares to its `eval` (3.9.1 checked), so a scalar parameter reads colour 1 where a colour
    /// parameter reads colour 0.
    pub(super) fn texture_ref(&self, b: &Bitmap, scalar: bool) -> String {
        format!("{{ {} }}", self.texture_keys(b, scalar, !scalar).join(", "))
    }

    /// The keys of [`Tr::texture_ref`] for a parameter whose 8-bit texels vkpath reads as sRGB by
    /// default when `srgb_default` (colours), else as linear data (scalars, normal and bump maps).
    pub(super) fn texture_keys(&self, b: &Bitmap, scalar: bool, srgb_default: bool) -> Vec<String> {
        let mut keys = match &b.source {
            Source::File(path) => self.file_keys(b, path, scalar, srgb_default),
            Source::Checkerboard([c0, c1]) if scalar => {
                let mean = |c: &DVec3| num((c.x + c.y + c.z) / 3.0);
                vec![format!("checkerboard = [{}, {}]", mean(c1), mean(c0))]
            }
            Source::Checkerboard([c0, c1]) => {
                vec![format!("checkerboard = [{}, {}]", vec3(*c0), vec3(*c1))]
            }
        };
        if let Some(([su, sv], rotation, [ou, ov])) = b.to_uv {
            keys.push(format!("scale = [{}, {}]", num(su), num(sv)));
            keys.push(format!("rotation = {}", num(rotation)));
            keys.push(format!("offset = [{}, {}]", num(ou), num(ov)));
        }
        keys
    }

    /// [`Tr::texture_keys`] of a bitmap file.
    fn file_keys(&self, b: &Bitmap, path: &Path, scalar: bool, srgb_default: bool) -> Vec<String> {
        let mut keys = vec![format!("texture = {}", self.refer(path))];
        let float_file = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("hdr"));
        if scalar {
            keys.push("channel = \"luminance\"".into());
        }
        if !float_file && b.raw == srgb_default {
            keys.push(format!(
                "color_space = \"{}\"",
                if b.raw { "linear" } else { "srgb" }
            ));
        }
        if b.nearest {
            keys.push("filter = \"nearest\"".into());
        }
        if b.wrap != "repeat" {
            keys.push(format!("wrap = \"{}\"", b.wrap));
        }
        keys
    }
}
