//! A material's parameters: each a constant or a texture reference that stands in for it (colours,
//! scalars, roughness), the texture reference itself, and the index of refraction.

use super::error::SceneError;
use super::raw::{RawFactor, RawParam, RawRoughness, RawScale, RawTextureRef, RawVec2, RawVec3};
use super::{Checker, Files};
use crate::scene::Roughness;
use crate::scene::texture::TextureRef;
use glam::Vec3;
use std::sync::Arc;
use toml::Spanned;

impl Checker<'_> {
    /// A colour parameter: its constant (checked by `bad`), or a texture reference, recorded in `slot`,
    /// whose factor (default white, checked the same way) becomes the constant.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn color_param(
        &self,
        v: &Spanned<RawParam<RawVec3>>,
        key: &str,
        bad: impl Fn(Vec3) -> bool,
        problem: &str,
        hint: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Vec3, SceneError> {
        match v.get_ref() {
            RawParam::Constant(c) => {
                self.vec3_unless(&Spanned::new(v.span(), *c), key, bad, problem, hint)
            }
            RawParam::Texture(t) => {
                let (r, _) = self.texture_ref(t, v.span(), key, true, false, files)?;
                let factor = match &t.factor {
                    None => Vec3::ONE,
                    Some(f) => {
                        let c = match f.get_ref() {
                            RawFactor::Number(x) => RawVec3([*x; 3]),
                            RawFactor::Color(c) => *c,
                        };
                        let fkey = format!("{key}.factor");
                        self.vec3_unless(&Spanned::new(f.span(), c), &fkey, bad, problem, hint)?
                    }
                };
                *slot = Some(r);
                Ok(factor)
            }
        }
    }

    /// A scalar parameter: its constant (checked by `bad`), or a texture reference, recorded in `slot`,
    /// whose factor (a number, default 1, checked the same way) becomes the constant.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn scalar_param(
        &self,
        v: &Spanned<RawParam<f32>>,
        key: &str,
        bad: impl Fn(f32) -> bool,
        problem: &str,
        hint: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<f32, SceneError> {
        match v.get_ref() {
            RawParam::Constant(x) => {
                self.number_unless(&Spanned::new(v.span(), *x), key, bad, problem, hint)
            }
            RawParam::Texture(t) => {
                let (r, _) = self.texture_ref(t, v.span(), key, false, false, files)?;
                let factor = match &t.factor {
                    None => 1.0,
                    Some(f) => match f.get_ref() {
                        RawFactor::Number(x) => {
                            let fkey = format!("{key}.factor");
                            self.number_unless(
                                &Spanned::new(f.span(), *x),
                                &fkey,
                                bad,
                                problem,
                                hint,
                            )?
                        }
                        RawFactor::Color(_) => {
                            return Err(self.error(
                                f.span(),
                                &format!("{key}.factor"),
                                "the factor of a scalar parameter is one number",
                                "Give `factor = 0.5`, say; [r, g, b] factors are for colours.",
                            ));
                        }
                    },
                };
                *slot = Some(r);
                Ok(factor)
            }
        }
    }

    /// A texture reference: the image (relative to the scene file, read once however many references
    /// name it) and how it is read; with `modifier` (bump, normal_map), also the modifier's `scale`.
    pub(super) fn texture_ref(
        &self,
        t: &RawTextureRef,
        span: std::ops::Range<usize>,
        key: &str,
        colour: bool,
        modifier: bool,
        files: &mut Files,
    ) -> Result<(TextureRef, Option<f32>), SceneError> {
        use crate::scene::texture::{Channel, TextureFilter, Wrap};
        let sub = |field: &str| format!("{key}.{field}");
        let image = match (&t.texture, &t.checkerboard) {
            (Some(file), None) => self.mesh_texture(
                file,
                &sub("texture"),
                files.base,
                files.loaded,
                "The path is relative to the scene file; PNG, JPEG, EXR and HDR images are read.",
            )?,
            (None, Some(colors)) if !modifier => {
                Arc::new(self.checkerboard(colors, &sub("checkerboard"))?)
            }
            (None, Some(colors)) => {
                return Err(self.error(
                    colors.span(),
                    &sub("checkerboard"),
                    "a bump or normal map of a checkerboard",
                    "Bump and normal maps read an image (`texture = \"file.png\"`); a checkerboard's \
                     steps have no slope to tilt a normal by.",
                ));
            }
            (Some(file), Some(_)) => {
                return Err(self.error(
                    file.span(),
                    key,
                    "a texture reference with both `texture` and `checkerboard`",
                    "Give the image file (`texture`) or the checkerboard's two colours, not both.",
                ));
            }
            (None, None) => {
                return Err(self.error(
                    span,
                    key,
                    "a texture reference without `texture` (or `checkerboard`)",
                    "Give `texture = \"file.png\"` (relative to the scene file), or                      `checkerboard = [colour0, colour1]`.",
                ));
            }
        };
        let mut r = TextureRef::plain(image, colour);
        if r.image.checkerboard {
            // Its colours are linear values, whatever the parameter; it tiles the plane and has no texels
            // to filter.
            r.srgb = false;
            for (field, v) in [
                ("color_space", &t.color_space),
                ("filter", &t.filter),
                ("wrap", &t.wrap),
            ] {
                if let Some(v) = v {
                    return Err(self.error(
                        v.span(),
                        &sub(field),
                        format!("a checkerboard has no {field}"),
                        "Its colours are linear and exact, its squares tile the plane: leave the key out \
                         (scale, offset, rotation, channel and factor apply).",
                    ));
                }
            }
        }
        if !colour {
            r.channel = Channel::R;
        }
        let choose = |v: &Option<Spanned<String>>, field: &str, names: &[&str]| {
            let Some(v) = v else { return Ok(None) };
            let given = v.get_ref().as_str();
            match names.iter().position(|n| *n == given) {
                Some(i) => Ok(Some(i)),
                None => Err(self.error(
                    v.span(),
                    &sub(field),
                    format!("unknown {field} \"{given}\""),
                    format!(
                        "Use one of {}.",
                        names
                            .iter()
                            .map(|n| format!("\"{n}\""))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )),
            }
        };
        let names: Vec<&str> = Channel::ALL.iter().map(|(_, n)| *n).collect();
        if let Some(i) = choose(&t.channel, "channel", &names)? {
            r.channel = Channel::ALL[i].0;
        }
        if let Some(i) = choose(&t.color_space, "color_space", &["srgb", "linear"])? {
            r.srgb = i == 0;
        }
        if let Some(i) = choose(&t.filter, "filter", &["bilinear", "nearest"])? {
            r.filter = [TextureFilter::Bilinear, TextureFilter::Nearest][i];
        }
        if let Some(i) = choose(&t.wrap, "wrap", &["repeat", "clamp", "mirror"])? {
            r.wrap = [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror][i];
        }
        let vec2 = |v: &Spanned<RawVec2>, field: &str| -> Result<[f32; 2], SceneError> {
            let [a, b] = v.get_ref().0;
            if !(a.is_finite() && b.is_finite()) {
                return Err(self.not_finite(v.span(), &sub(field), &format!("[{a}, {b}]")));
            }
            Ok([a, b])
        };
        let mut modifier_scale = None;
        if let Some(sc) = &t.scale {
            match sc.get_ref() {
                RawScale::Uv(uv) if !modifier => {
                    r.scale = vec2(&Spanned::new(sc.span(), *uv), "scale")?
                }
                RawScale::Number(x) if modifier => {
                    modifier_scale = Some(self.number(&Spanned::new(sc.span(), *x), &sub("scale"))?)
                }
                _ if modifier => {
                    return Err(self.error(
                        sc.span(),
                        &sub("scale"),
                        "a bump or normal map's scale is one number",
                        "`scale` is the bump map's height per unit of texel (scene units), or the normal map's \
                         factor of x and y; the uv scale of a modifier's texture is `uv_scale = [su, sv]`.",
                    ));
                }
                _ => {
                    return Err(self.error(
                        sc.span(),
                        &sub("scale"),
                        "a texture's scale is an array [su, sv]",
                        "uv' = R(rotation) (scale * uv) + offset; give `scale = [4.0, 4.0]` to repeat the image 4 times each way.",
                    ));
                }
            }
        }
        if let Some(uv) = &t.uv_scale {
            if !modifier {
                return Err(self.error(
                    uv.span(),
                    &sub("uv_scale"),
                    "uv_scale is for bump and normal maps, whose `scale` is a number",
                    "A parameter's texture takes its uv scale as `scale = [su, sv]`.",
                ));
            }
            r.scale = vec2(uv, "uv_scale")?;
        }
        if let Some(o) = &t.offset {
            r.offset = vec2(o, "offset")?;
        }
        if let Some(rot) = &t.rotation {
            r.rotation_deg = self.number(rot, &sub("rotation"))?;
        }
        if let (true, Some(f)) = (modifier, &t.factor) {
            return Err(self.error(
                f.span(),
                &sub("factor"),
                "a bump or normal map takes `scale`, not `factor`",
                "Give the bump height per unit of texel (or the normal map's strength) as `scale`.",
            ));
        }
        Ok((r, modifier_scale))
    }

    /// A checkerboard's two colours (`checkerboard = [c0, c1]`, each a number or [r, g, b], finite and
    /// >= 0): Mitsuba's procedural texture (`Texture::checkerboard`).
    fn checkerboard(
        &self,
        colors: &Spanned<Vec<RawFactor>>,
        key: &str,
    ) -> Result<crate::scene::image_texture::Texture, SceneError> {
        let hint = "Give the two colours: `checkerboard = [[0.4, 0.4, 0.4], [0.2, 0.2, 0.2]]` (numbers \
                    for greys), colour 0 on the square at uv (0, 0).";
        let [c0, c1] = colors.get_ref().as_slice() else {
            return Err(self.error(
                colors.span(),
                key,
                format!("{} colours; a checkerboard has two", colors.get_ref().len()),
                hint,
            ));
        };
        let rgb = |c: &RawFactor| match c {
            RawFactor::Number(x) => [*x; 3],
            RawFactor::Color(c) => c.0,
        };
        let pair = [rgb(c0), rgb(c1)];
        if let Some(bad) = pair
            .iter()
            .flatten()
            .find(|x| !(x.is_finite() && **x >= 0.0))
        {
            return Err(self.error(
                colors.span(),
                key,
                format!("a checkerboard colour component {bad}: they must be finite and >= 0"),
                hint,
            ));
        }
        Ok(crate::scene::image_texture::Texture::checkerboard(pair))
    }

    /// An index of refraction: finite and > 0.
    pub(super) fn ior(&self, ior: &Spanned<f32>, key: &str) -> Result<f32, SceneError> {
        self.number_unless(
            ior,
            key,
            |ior| ior <= 0.0,
            "the index of refraction must be > 0",
            "Glass is about 1.5, water 1.33; the outside medium has ior 1.",
        )
    }

    /// A colour whose components are reflectances, in [0, 1] (or a texture, whose factor is).
    pub(super) fn unit_color(
        &self,
        c: &Spanned<RawParam<RawVec3>>,
        key: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Vec3, SceneError> {
        self.color_param(
            c,
            key,
            |a| !in_unit_range(a),
            "every component must be in [0, 1]",
            "A reflectance is the fraction of light reflected per channel; energy conservation needs it in [0, 1].",
            files,
            slot,
        )
    }

    /// `roughness`: absent (smooth), one number or two, each in [0, 1], or a texture (both axes; its
    /// factor, default 1, is the constant).
    /// A microfacet material's `distribution`: "ggx" (the default) or "beckmann", set on `roughness`.
    pub(super) fn distribution(
        &self,
        raw: &Option<Spanned<String>>,
        key: &str,
        roughness: Roughness,
    ) -> Result<Roughness, SceneError> {
        let beckmann = match raw.as_ref().map(|d| (d, d.get_ref().as_str())) {
            None | Some((_, "ggx")) => false,
            Some((_, "beckmann")) => true,
            Some((d, other)) => {
                return Err(self.error(
                    d.span(),
                    key,
                    format!("unknown microfacet distribution \"{other}\""),
                    "Use \"ggx\" (the default) or \"beckmann\".",
                ));
            }
        };
        Ok(Roughness {
            beckmann,
            ..roughness
        })
    }

    pub(super) fn roughness(
        &self,
        raw: &Option<Spanned<RawRoughness>>,
        key: &str,
        files: &mut Files,
        slot: &mut Option<TextureRef>,
    ) -> Result<Roughness, SceneError> {
        let Some(r) = raw else {
            return Ok(Roughness::SMOOTH);
        };
        let (u, v) = match r.get_ref() {
            RawRoughness::Isotropic(x) => (*x, *x),
            RawRoughness::Anisotropic(u, v) => (*u, *v),
            RawRoughness::Texture(t) => {
                let param = Spanned::new(r.span(), RawParam::<f32>::Texture(t.clone()));
                let x = self.scalar_param(
                    &param,
                    key,
                    |x| !(0.0..=1.0).contains(&x),
                    "roughness must be in [0, 1]",
                    "The texture's value times its factor is the roughness: 0 smooth, 1 the roughest.",
                    files,
                    slot,
                )?;
                (x, x)
            }
        };
        for x in [u, v] {
            if !x.is_finite() {
                return Err(self.not_finite(r.span(), key, &x.to_string()));
            }
            self.reject_if(
                r,
                key,
                x,
                |x| !(0.0..=1.0).contains(&x),
                "roughness must be in [0, 1]",
                "0 is a perfectly smooth surface, 1 the roughest (GGX alpha = roughness^2); \
                 [u, v] gives a different roughness along the tangent and the bitangent.",
            )?;
        }
        Ok(Roughness::anisotropic(u, v))
    }
}

pub(super) fn in_unit_range(v: Vec3) -> bool {
    v.min_element() >= 0.0 && v.max_element() <= 1.0
}
