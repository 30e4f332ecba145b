//! Colour and scalar parameters: an `<rgb>`, a `<spectrum>`, a `<float>` (a grey), or a texture: `srgb`
//! (a colour) or `bitmap` (a file: a texture reference of vkpath's material, read at the mesh's uv).

use super::args::{Args, resolve_ref};
use super::context::Tr;
use super::objects::{Loc, Obj, Prop, Value};
use crate::scene::SceneError;
use glam::DVec3;
use std::path::PathBuf;

/// A colour parameter: a colour, or a bitmap texture.
#[derive(Clone, Debug)]
pub(super) enum ColorTex {
    Color(DVec3),
    Bitmap(Bitmap),
}

/// A `bitmap` texture as Mitsuba 3 reads it: the file, its `filter_type` (bilinear or nearest), its
/// `wrap_mode` (repeat, mirror or clamp: vkpath's names too) and `raw` (8-bit texels not decoded from
/// sRGB), and the element naming the file.
#[derive(Clone, Debug)]
pub(super) struct Bitmap {
    pub(super) path: PathBuf,
    pub(super) loc: Loc,
    nearest: bool,
    wrap: String,
    raw: bool,
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
                self.finish(&targs, &["filename", "raw", "filter_type", "wrap_mode"])?;
                ColorTex::Bitmap(Bitmap {
                    path,
                    loc: floc.clone(),
                    nearest,
                    wrap: wrap.to_string(),
                    raw,
                })
            }
            _ => {
                return Err(obj.loc.error(
                    format!("vkpath does not read Mitsuba's texture \"{}\"", obj.kind),
                    "Use a bitmap texture (a file) or an <rgb>.",
                ));
            }
        };
        Ok(out)
    }
}

impl Tr<'_> {
    /// A bitmap as a vkpath texture reference (an inline TOML table) with Mitsuba's meaning: 8-bit
    /// texels are sRGB-decoded unless `raw`, floating-point files (EXR, HDR) are linear; a `scalar`
    /// parameter reads the luminance of the decoded colour (Mitsuba's `eval_1`; an image's alpha is not
    /// read, as Mitsuba does not).
    pub(super) fn texture_ref(&self, b: &Bitmap, scalar: bool) -> String {
        format!("{{ {} }}", self.texture_keys(b, scalar, !scalar).join(", "))
    }

    /// The keys of [`Tr::texture_ref`] for a parameter whose 8-bit texels vkpath reads as sRGB by
    /// default when `srgb_default` (colours), else as linear data (scalars, normal and bump maps).
    pub(super) fn texture_keys(&self, b: &Bitmap, scalar: bool, srgb_default: bool) -> Vec<String> {
        let mut keys = vec![format!("texture = {}", self.refer(&b.path))];
        let float_file = b
            .path
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
