//! Colour parameters: an `<rgb>`, a uniform `<spectrum>`, a `<float>` (a grey), or a texture: `srgb` (a
//! colour) or `bitmap` (a file, which vkpath applies to a mesh).

use super::args::{Args, resolve_ref};
use super::context::Tr;
use super::objects::{Loc, Prop, Value};
use crate::scene::SceneError;
use glam::DVec3;
use std::path::PathBuf;

/// A colour parameter: a colour, or a bitmap texture's file (which vkpath applies per mesh).
#[derive(Clone, Debug)]
pub(super) enum ColorTex {
    Color(DVec3),
    Bitmap(PathBuf, Loc),
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
            ColorTex::Bitmap(_, loc) => Err(loc.error(
                format!("a bitmap texture as \"{name}\": vkpath textures a diffuse or plastic reflectance only"),
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
        let targs = Args::new(&obj);
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
                if let Some((true, l)) = targs.boolean("raw")? {
                    return Err(l.error(
                        "raw = true: vkpath decodes 8-bit textures as sRGB (and EXR/HDR as linear) always",
                        "Remove raw, or store the texture linear in an EXR file.",
                    ));
                }
                if let Some((f, l)) = targs.string("filter_type")?
                    && f != "bilinear"
                {
                    return Err(l.error(
                        format!("filter_type \"{f}\": vkpath filters textures bilinearly"),
                        "Remove filter_type (bilinear is the default).",
                    ));
                }
                if let Some((w, l)) = targs.string("wrap_mode")?
                    && w != "repeat"
                {
                    return Err(l.error(
                        format!("wrap_mode \"{w}\": vkpath repeats textures"),
                        "Remove wrap_mode (repeat is the default).",
                    ));
                }
                self.finish(&targs, &["filename", "raw", "filter_type", "wrap_mode"])?;
                ColorTex::Bitmap(path, floc.clone())
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
