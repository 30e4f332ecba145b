//! BSDFs as vkpath materials: each BSDF's keys (diffuse, rough diffuse, conductors, dielectrics, plastics, twosided),
//! its roughness and indices of refraction, and the `[materials]` table, one material per (BSDF,
//! emission) that shapes share.

use super::args::Args;
use super::colors::ColorTex;
use super::context::Tr;
use super::objects::{Loc, Obj, Value};
use super::toml_out::{num, vec3};
use crate::scene::SceneError;
use crate::scene::toml_text::toml_string;
use glam::DVec3;
use std::rc::Rc;

/// A BSDF as vkpath material keys (`key = value` lines), and the element of a bitmap it reads, if any
/// (the shape must then be a mesh, whose uvs it is read at).
#[derive(Clone)]
pub(super) struct MatOut {
    pub(super) lines: Vec<(String, Loc)>,
    pub(super) textured: Option<Loc>,
}

impl Tr<'_> {
    /// An IOR parameter: a number or one of Mitsuba's named media.
    fn ior(&self, args: &Args, name: &str, default: &str) -> Result<f64, SceneError> {
        let Some(p) = args.prop(name) else {
            return Ok(named_ior(default).unwrap_or(1.0));
        };
        match &p.value {
            Value::Float(x) => Ok(*x),
            Value::Integer(i) => Ok(*i as f64),
            Value::Spectrum(x) => Ok(*x),
            Value::Str(s) => named_ior(s).ok_or_else(|| {
                p.loc.error(
                    format!("\"{s}\" is not one of Mitsuba's named indices of refraction"),
                    &format!(
                        "Give a number, or one of: {}.",
                        IOR_TABLE
                            .iter()
                            .map(|(n, _)| *n)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            }),
            _ => Err(Args::wrong(p, "a <float> or a named medium (<string>)")),
        }
    }

    /// A dielectric's (smooth, rough or thin) relative index int_ior / ext_ior (vkpath's ior: the
    /// interior's over the exterior's); a specular_reflectance or specular_transmittance other than 1 is
    /// refused (vkpath's dielectrics have no tint).
    fn untinted_dielectric_ior(&mut self, args: &Args, obj: &Obj) -> Result<f64, SceneError> {
        let ior = self.ior(args, "int_ior", "bk7")? / self.ior(args, "ext_ior", "air")?;
        for name in ["specular_reflectance", "specular_transmittance"] {
            if self.color(args, name, DVec3::ONE)? != DVec3::ONE {
                let p = args.prop(name).map_or(&obj.loc, |p| &p.loc);
                return Err(p.error(
                    format!("{name} other than 1: vkpath's dielectrics have no tint"),
                    "Remove it.",
                ));
            }
        }
        Ok(ior)
    }

    /// A microfacet BSDF's roughness: vkpath's perceptual roughness r has GGX alpha = r^2, so
    /// r = sqrt(alpha). Mitsuba's default distribution is Beckmann, which vkpath does not have.
    /// A rough BSDF's `alpha` as vkpath's roughness sqrt(alpha), and its TOML `distribution` line:
    /// Beckmann (Mitsuba's default) or GGX.
    fn roughness(&mut self, args: &Args, obj: &Obj) -> Result<(f64, String), SceneError> {
        let distribution = match args.string("distribution")? {
            None | Some(("beckmann", _)) => "beckmann",
            Some(("ggx", _)) => "ggx",
            Some((d, l)) => {
                return Err(l.error(
                    format!("unknown microfacet distribution \"{d}\""),
                    "Mitsuba 3 has \"beckmann\" (its default) and \"ggx\".",
                ));
            }
        };
        let line = format!("distribution = \"{distribution}\"");
        let _ = args.boolean("sample_visible")?;
        if let Some(p) = args.prop("alpha_u").or_else(|| args.prop("alpha_v")) {
            return Err(p.loc.error(
                "anisotropic alpha_u / alpha_v: vkpath's tangent frame is not Mitsuba's, so the highlight would stretch along other directions",
                "Give one alpha.",
            ));
        }
        let alpha = args.float("alpha")?;
        let (a, loc) = alpha.map_or((0.1, &obj.loc), |(a, l)| (a, l));
        if !(0.0..=1.0).contains(&a) {
            return Err(loc.error(
                format!("alpha = {a}: vkpath's roughness sqrt(alpha) must be in [0, 1]"),
                "Give alpha in [0, 1].",
            ));
        }
        Ok((a.sqrt(), line))
    }

    /// Whether a BSDF scatters on both faces in Mitsuba: a `twosided`, a dielectric (smooth, rough or
    /// thin: light meets them from either side), or a `mask` around one of those (a mask inside a mask is
    /// refused by bsdf_unwrapped, which has read this one already). Mitsuba's other BSDFs reflect on the
    /// front face only and are black from behind.
    fn two_sided(&self, obj: &Obj) -> bool {
        self.two_sided_within(obj, super::xml::MAX_XML_DEPTH)
    }

    /// [`Tr::two_sided`], looking at most `depth` BSDFs deep: a chain of <ref>s could close on itself
    /// (Tr::bsdf refuses that later). Modifiers (mask, bumpmap, normalmap) are two-sided when what they
    /// hold is; a blendbsdf when both its BSDFs are.
    fn two_sided_within(&self, obj: &Obj, depth: usize) -> bool {
        if depth == 0 {
            return false;
        }
        let nested = || {
            Args::new(obj)
                .objects("bsdf", self.ids)
                .unwrap_or_default()
                .into_iter()
                .map(|(b, _)| b)
        };
        match obj.kind.as_str() {
            "twosided" | "dielectric" | "roughdielectric" | "thindielectric" => true,
            "mask" | "bumpmap" | "normalmap" => nested()
                .next()
                .is_some_and(|b| self.two_sided_within(&b, depth - 1)),
            "blendbsdf" => {
                let all: Vec<_> = nested().collect();
                !all.is_empty() && all.iter().all(|b| self.two_sided_within(b, depth - 1))
            }
            _ => false,
        }
    }

    /// A parameter of `owner` that Mitsuba reads as one number (`eval_1`), default 0.5: a grey colour, or
    /// a bitmap (its luminance; `textured` becomes the bitmap's element). The TOML value, and the number
    /// when it is one; a coloured constant is refused.
    pub(super) fn scalar_tex(
        &mut self,
        args: &Args,
        obj: &Obj,
        name: &str,
        owner: &str,
        textured: &mut Option<Loc>,
    ) -> Result<(String, Option<f64>), SceneError> {
        match self.color_tex(args, name, DVec3::splat(0.5))? {
            ColorTex::Color(c) => {
                if c.x != c.y || c.y != c.z {
                    let p = args.prop(name).map_or(&obj.loc, |p| &p.loc);
                    return Err(p.error(
                        format!(
                            "a coloured {name}: Mitsuba reads a {owner}'s {name} as one number"
                        ),
                        &format!("Give <float name=\"{name}\" value=\"...\"/>."),
                    ));
                }
                Ok((num(c.x), Some(c.x)))
            }
            ColorTex::Bitmap(b) => {
                *textured = Some(b.loc.clone());
                Ok((self.texture_ref(&b, true), None))
            }
        }
    }

    /// Translates a BSDF that nothing uses, for its errors and warnings only.
    pub(super) fn check_bsdf(&mut self, obj: &Obj) -> Result<(), SceneError> {
        self.bsdf(obj).map(drop)
    }

    /// A BSDF as vkpath material keys; refused when it holds itself through `<ref>`s (a cycle, which
    /// Mitsuba would also refuse) or nests more than [`super::xml::MAX_XML_DEPTH`] BSDFs deep through
    /// them (nesting written out is bounded by the reader already).
    fn bsdf(&mut self, obj: &Obj) -> Result<Option<MatOut>, SceneError> {
        let address = obj as *const Obj as usize;
        if self.bsdf_stack.contains(&address) {
            return Err(obj.loc.error(
                "this BSDF holds itself through <ref> (a reference cycle)",
                "A BSDF can nest only other BSDFs: break the cycle of ids.",
            ));
        }
        if self.bsdf_stack.len() >= super::xml::MAX_XML_DEPTH {
            return Err(obj.loc.error(
                format!(
                    "BSDFs nested more than {} deep through <ref>s",
                    super::xml::MAX_XML_DEPTH
                ),
                "Real scenes nest a BSDF or two (twosided around another); this file is damaged or hostile.",
            ));
        }
        self.bsdf_stack.push(address);
        self.translated.insert(address);
        let out = self.bsdf_unwrapped(obj);
        self.bsdf_stack.pop();
        out
    }

    /// [`Tr::bsdf`] once the nesting is checked: each BSDF type by its own method. `twosided` is accepted
    /// and unwrapped: vkpath shades both faces of every surface (Mitsuba's other BSDFs are black from
    /// behind).
    fn bsdf_unwrapped(&mut self, obj: &Obj) -> Result<Option<MatOut>, SceneError> {
        let args = &Args::new(obj);
        let kind = obj.kind.as_str();
        let mut out = MatOut {
            lines: Vec::new(),
            textured: None,
        };
        match kind {
            "twosided" => return self.bsdf_twosided(obj, args),
            "mask" => return self.bsdf_mask(obj, args),
            "blendbsdf" => return self.bsdf_blend(obj, args),
            "bumpmap" | "normalmap" => return self.bsdf_surface_map(obj, args, kind),
            "diffuse" | "roughdiffuse" => self.bsdf_diffuse(obj, args, kind, &mut out)?,
            "conductor" | "roughconductor" => self.bsdf_conductor(obj, args, kind, &mut out)?,
            "thindielectric" => self.bsdf_thin_dielectric(obj, args, &mut out)?,
            "dielectric" | "roughdielectric" => self.bsdf_dielectric(obj, args, kind, &mut out)?,
            "plastic" | "roughplastic" => self.bsdf_plastic(obj, args, kind, &mut out)?,
            "principled" => self.bsdf_principled(obj, args, &mut out)?,
            other if crate::materials::by_mitsuba_type(other).is_some() => {
                let plugin = crate::materials::by_mitsuba_type(other).expect("matched");
                return self.plugin_bsdf(plugin, obj).map(Some);
            }
            _ => {
                let plugins: Vec<&str> = crate::materials::PLUGINS
                    .iter()
                    .flat_map(|p| p.mitsuba.iter().copied())
                    .collect();
                self.unsupported(
                    obj,
                    &format!(
                        "diffuse, roughdiffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, principled, {}, twosided, mask, bumpmap, normalmap and blendbsdf",
                        plugins.join(", ")
                    ),
                )?;
                return Ok(None);
            }
        }
        Ok(Some(out))
    }

    /// `twosided`: one BSDF shows on both faces; two: the front shows the first, the back the second.
    fn bsdf_twosided(&mut self, obj: &Obj, args: &Args) -> Result<Option<MatOut>, SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        // One BSDF: both faces show it. Two: the front shows the first, the back the second
        // (as its own front), vkpath's `back` modifier naming a material of its own.
        let inner = args.objects("bsdf", self.ids)?;
        self.finish(args, &["bsdf"])?;
        match inner.as_slice() {
            [(b, _)] => self.bsdf(b),
            [(front, _), (back, _)] => {
                let Some(mut out) = self.bsdf(front)? else {
                    return Ok(None);
                };
                let (name, textured) =
                    self.material(Some(back), None, "twosided-back", &obj.loc)?;
                out.lines.push(at(format!("back = {}", toml_string(&name))));
                out.textured = out.textured.or(textured);
                Ok(Some(out))
            }
            _ => Err(obj.loc.error(
                "a twosided BSDF with other than one or two nested BSDFs",
                "Nest one BSDF (both faces) or two (front, then back).",
            )),
        }
    }

    /// `mask`: the nested BSDF with an opacity.
    fn bsdf_mask(&mut self, obj: &Obj, args: &Args) -> Result<Option<MatOut>, SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let mut textured = None;
        // Mitsuba's mask: the nested BSDF where a ray stops, with probability `opacity`
        // (default 0.5), else the ray passes on unchanged (a null interaction): vkpath's
        // opacity without alpha_cutoff, the same stochastic transparency.
        let inner = args.objects("bsdf", self.ids)?;
        let [(b, _)] = inner.as_slice() else {
            return Err(obj.loc.error(
                "a mask BSDF with other than one nested BSDF",
                "Nest exactly one BSDF.",
            ));
        };
        let (opacity, _) = self.scalar_tex(args, obj, "opacity", "mask", &mut textured)?;
        self.finish(args, &["opacity", "bsdf"])?;
        let Some(mut out) = self.bsdf(b)? else {
            return Ok(None);
        };
        if out.lines.iter().any(|(l, _)| l.starts_with("opacity")) {
            return Err(obj.loc.error(
                "a mask inside a mask",
                "Give one mask, its opacity the product of the two.",
            ));
        }
        out.lines.push(at(format!("opacity = {opacity}")));
        out.textured = out.textured.or(textured);
        Ok(Some(out))
    }

    /// `blendbsdf`: the first BSDF's material with the second's blended in.
    fn bsdf_blend(&mut self, obj: &Obj, args: &Args) -> Result<Option<MatOut>, SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let mut textured = None;
        // Mitsuba's blendbsdf: (1 - weight) x the first BSDF + weight x the second. vkpath's
        // blend modifier: the first BSDF's material shows the second's at a fraction `weight`
        // of its hits (the same expected BSDF; the choice: scene.wgsl, surface_at).
        let inner = args.objects("bsdf", self.ids)?;
        let [(a, _), (b, _)] = inner.as_slice() else {
            return Err(obj.loc.error(
                "a blendbsdf with other than two nested BSDFs",
                "Nest exactly two BSDFs.",
            ));
        };
        let (weight, constant) =
            self.scalar_tex(args, obj, "weight", "blendbsdf", &mut textured)?;
        if let Some(w) = constant.filter(|w| !(0.0..=1.0).contains(w)) {
            let p = args.prop("weight").map_or(&obj.loc, |p| &p.loc);
            return Err(p.error(
                format!("weight = {w}: a blendbsdf's weight is in [0, 1]"),
                "Give the second BSDF's share, from 0 to 1.",
            ));
        }
        self.finish(args, &["weight", "bsdf"])?;
        if self.two_sided(a) != self.two_sided(b) {
            return Err(obj.loc.error(
                "a blendbsdf of a two-sided and a one-sided BSDF: vkpath's one_sided applies to the \
                 whole blend",
                "Wrap both BSDFs in twosided, or neither.",
            ));
        }
        let Some(mut out) = self.bsdf(a)? else {
            return Ok(None);
        };
        if out.lines.iter().any(|(l, _)| l.starts_with("blend")) {
            return Err(obj.loc.error(
                "a blendbsdf whose first BSDF is a blendbsdf",
                "vkpath blends two materials at a hit: flatten the nested blendbsdfs into one.",
            ));
        }
        let (name, second_textured) = self.material(Some(b), None, "blend", &obj.loc)?;
        out.lines
            .push(at(format!("blend = {}", toml_string(&name))));
        out.lines.push(at(format!("blend_weight = {weight}")));
        out.textured = out.textured.or(textured).or(second_textured);
        Ok(Some(out))
    }

    /// `bumpmap` and `normalmap`: the nested BSDF under a bump or normal map.
    fn bsdf_surface_map(
        &mut self,
        obj: &Obj,
        args: &Args,
        kind: &str,
    ) -> Result<Option<MatOut>, SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        // Mitsuba's bumpmap: the nested BSDF under the shading frame of the surface displaced
        // by `scale` x the texture's value (eval_1: the luminance of a colour texture), whose
        // derivatives in uv it takes; vkpath's bump modifier is the same model (scene.wgsl,
        // bump_mapped). Its normalmap: the frame's normal is 2 x rgb - 1 in the tangent frame
        // along dp/du (the texture as given: Mitsuba's scenes set raw = true), vkpath's
        // normal_map. A texture of any name, as in Mitsuba.
        let bump = kind == "bumpmap";
        let inner = args.objects("bsdf", self.ids)?;
        let maps = args.objects("texture", self.ids)?;
        let ([(b, _)], [(map, _)]) = (inner.as_slice(), maps.as_slice()) else {
            return Err(obj.loc.error(
                format!("a {kind} BSDF with other than one nested BSDF and one texture"),
                "Nest exactly one BSDF and one <texture>.",
            ));
        };
        let scale = if bump {
            args.float_or("scale", 1.0)?
        } else {
            1.0
        };
        self.finish(args, &["bsdf", "texture", "scale"])?;
        let key = if bump { "bump" } else { "normal_map" };
        let texture = match self.texture(map)? {
            // A constant height displaces the surface without tilting it: the nested BSDF as is.
            ColorTex::Color(_) if bump => None,
            ColorTex::Color(_) => {
                return Err(map.loc.error(
                    "a normalmap whose texture is a constant colour",
                    "Give a bitmap texture, or leave the normalmap out.",
                ));
            }
            ColorTex::Bitmap(bitmap) if bitmap.path().is_none() => {
                return Err(bitmap.loc.error(
                    format!("a {kind} of a checkerboard"),
                    "vkpath's bump and normal maps read a bitmap: a checkerboard's steps have no \
                     slope to tilt a normal by.",
                ));
            }
            ColorTex::Bitmap(bitmap) => Some(bitmap),
        };
        let Some(mut out) = self.bsdf(b)? else {
            return Ok(None);
        };
        let Some(bitmap) = texture else {
            return Ok(Some(out));
        };
        if out.lines.iter().any(|(l, _)| l.starts_with(key)) {
            return Err(obj.loc.error(
                format!("a {kind} inside a {kind}"),
                "vkpath applies one map of each kind to a material: keep one.",
            ));
        }
        let mut keys = self.texture_keys(&bitmap, bump, false);
        if bump {
            keys.push(format!("scale = {}", num(scale)));
        }
        out.lines
            .push(at(format!("{key} = {{ {} }}", keys.join(", "))));
        out.textured = out.textured.or(Some(bitmap.loc));
        Ok(Some(out))
    }

    /// `diffuse` and `roughdiffuse`.
    fn bsdf_diffuse(
        &mut self,
        obj: &Obj,
        args: &Args,
        kind: &str,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let rough = kind == "roughdiffuse";
        let vkpath_type = if rough { "rough_diffuse" } else { "diffuse" };
        out.lines.push(at(format!("type = \"{vkpath_type}\"")));
        match self.color_tex(args, "reflectance", DVec3::splat(0.5))? {
            ColorTex::Color(c) => out.lines.push(at(format!("albedo = {}", vec3(c)))),
            ColorTex::Bitmap(b) => {
                out.lines
                    .push(at(format!("albedo = {}", self.texture_ref(&b, false))));
                out.textured = Some(b.loc);
            }
        }
        if rough {
            // Mitsuba's alpha is the RMS slope of the facets (default 0.2); vkpath's roughness
            // r has r^2 = alpha (rough_diffuse.wgsl).
            let (alpha, loc) = args
                .float("alpha")?
                .map_or((0.2, &obj.loc), |(a, l)| (a, l));
            if !(0.0..=1.0).contains(&alpha) {
                return Err(loc.error(
                    format!("alpha = {alpha}: vkpath's roughness sqrt(alpha) must be in [0, 1]"),
                    "Give alpha in [0, 1].",
                ));
            }
            out.lines
                .push(at(format!("roughness = {}", num(alpha.sqrt()))));
            match args.boolean("use_fast_approx")? {
                Some((true, _)) => {}
                _ => self.approximate(
                    &obj.loc,
                    "roughdiffuse without use_fast_approx: Mitsuba's default is Oren and Nayar's full model, vkpath's rough_diffuse their qualitative one".into(),
                    "Add <boolean name=\"use_fast_approx\" value=\"true\"/> to read it as that model.",
                )?,
            }
            self.finish(args, &["reflectance", "alpha", "use_fast_approx"])?;
        } else {
            self.finish(args, &["reflectance"])?;
        }
        Ok(())
    }

    /// `conductor` and `roughconductor`.
    fn bsdf_conductor(
        &mut self,
        obj: &Obj,
        args: &Args,
        kind: &str,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let material = args.string("material")?;
        let eta = args.prop("eta").map(|_| ());
        let k = args.prop("k").map(|_| ());
        let tint = self.color(args, "specular_reflectance", DVec3::ONE)?;
        let rough = if kind == "roughconductor" {
            Some(self.roughness(args, obj)?)
        } else {
            None
        };
        match (material, eta.is_some() || k.is_some()) {
            (Some((_, l)), true) => {
                return Err(l.error("both a material and eta / k are given", "Give one of them."));
            }
            (None, true) => {
                let eta = self.color(args, "eta", DVec3::ZERO)?;
                let k = self.color(args, "k", DVec3::ONE)?;
                out.lines.push(at("type = \"conductor\"".into()));
                out.lines.push(at(format!("eta = {}", vec3(eta))));
                out.lines.push(at(format!("k = {}", vec3(k))));
            }
            (m, false) => {
                let (name, mloc) = m.map_or(("none", &obj.loc), |(n, l)| (n, l));
                let preset = match name {
                    "none" => None,
                    "Au" => Some("gold"),
                    "Ag" => Some("silver"),
                    "Cu" => Some("copper"),
                    "Al" => Some("aluminium"),
                    other => {
                        return Err(mloc.error(
                            format!("the conductor material \"{other}\" is not one vkpath has"),
                            "vkpath has Au, Ag, Cu, Al (its presets gold, silver, copper, aluminium) and none (a perfect mirror); or give eta and k.",
                        ));
                    }
                };
                match preset {
                    Some(p) => {
                        out.lines.push(at("type = \"conductor\"".into()));
                        out.lines.push(at(format!("preset = \"{p}\"")));
                    }
                    None if rough.as_ref().is_none_or(|(r, _)| *r == 0.0) => {
                        // Reflectance 1 times specular_reflectance: vkpath's mirror and its tint.
                        out.lines.push(at("type = \"mirror\"".into()));
                        out.lines.push(at(format!("tint = {}", vec3(tint))));
                    }
                    None => {
                        // Reflectance 1, rough: Schlick's form with f0 = 1 is exactly 1.
                        out.lines.push(at("type = \"conductor\"".into()));
                        out.lines.push(at("base_color = [1.0, 1.0, 1.0]".into()));
                    }
                }
            }
        }
        let is_mirror = out.lines.iter().any(|(l, _)| l == "type = \"mirror\"");
        if !is_mirror && tint != DVec3::ONE {
            // specular_reflectance multiplies the Fresnel reflectance: vkpath's conductor tint.
            out.lines.push(at(format!("tint = {}", vec3(tint))));
        }
        if let Some((r, distribution)) = rough {
            out.lines.push(at(format!("roughness = {}", num(r))));
            out.lines.push(at(distribution));
        }
        let known: &[&str] = if kind == "conductor" {
            &["material", "eta", "k", "specular_reflectance"]
        } else {
            &[
                "material",
                "eta",
                "k",
                "specular_reflectance",
                "distribution",
                "alpha",
                "sample_visible",
            ]
        };
        self.finish(args, known)?;
        Ok(())
    }

    /// `thindielectric`.
    fn bsdf_thin_dielectric(
        &mut self,
        obj: &Obj,
        args: &Args,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        // A thin pane: the same model as Mitsuba's (reflection with the internal reflections
        // summed, 2R / (1 + R), and straight transmission).
        let ior = self.untinted_dielectric_ior(args, obj)?;
        out.lines.push(at("type = \"thin_dielectric\"".into()));
        out.lines.push(at(format!("ior = {}", num(ior))));
        self.finish(
            args,
            &[
                "int_ior",
                "ext_ior",
                "specular_reflectance",
                "specular_transmittance",
            ],
        )?;
        Ok(())
    }

    /// `dielectric` and `roughdielectric`.
    fn bsdf_dielectric(
        &mut self,
        obj: &Obj,
        args: &Args,
        kind: &str,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let ior = self.untinted_dielectric_ior(args, obj)?;
        out.lines.push(at("type = \"dielectric\"".into()));
        out.lines.push(at(format!("ior = {}", num(ior))));
        if kind == "roughdielectric" {
            let (r, distribution) = self.roughness(args, obj)?;
            out.lines.push(at(format!("roughness = {}", num(r))));
            out.lines.push(at(distribution));
        }
        let known: &[&str] = if kind == "dielectric" {
            &[
                "int_ior",
                "ext_ior",
                "specular_reflectance",
                "specular_transmittance",
            ]
        } else {
            &[
                "int_ior",
                "ext_ior",
                "specular_reflectance",
                "specular_transmittance",
                "distribution",
                "alpha",
                "sample_visible",
            ]
        };
        self.finish(args, known)?;
        Ok(())
    }

    /// `plastic` and `roughplastic`.
    fn bsdf_plastic(
        &mut self,
        obj: &Obj,
        args: &Args,
        kind: &str,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        let ior = self.ior(args, "int_ior", "polypropylene")? / self.ior(args, "ext_ior", "air")?;
        if self.color(args, "specular_reflectance", DVec3::ONE)? != DVec3::ONE {
            return Err(obj.loc.error(
                "specular_reflectance other than 1: vkpath's plastic coat has no tint",
                "Remove it.",
            ));
        }
        // Mitsuba's nonlinear (default false): whether the base's internal reflections are
        // tinted by its albedo, a / (1 - a Fdr) rather than a / (1 - Fdr); vkpath's too.
        let nonlinear = args.boolean("nonlinear")?.is_some_and(|(n, _)| n);
        out.lines.push(at("type = \"plastic\"".into()));
        out.lines.push(at(format!("nonlinear = {nonlinear}")));
        match self.color_tex(args, "diffuse_reflectance", DVec3::splat(0.5))? {
            ColorTex::Color(c) => out.lines.push(at(format!("albedo = {}", vec3(c)))),
            ColorTex::Bitmap(b) => {
                out.lines
                    .push(at(format!("albedo = {}", self.texture_ref(&b, false))));
                out.textured = Some(b.loc);
            }
        }
        out.lines.push(at(format!("ior = {}", num(ior))));
        if kind == "roughplastic" {
            let (r, distribution) = self.roughness(args, obj)?;
            out.lines.push(at(format!("roughness = {}", num(r))));
            out.lines.push(at(distribution));
        }
        let known: &[&str] = if kind == "plastic" {
            &[
                "int_ior",
                "ext_ior",
                "diffuse_reflectance",
                "specular_reflectance",
                "nonlinear",
            ]
        } else {
            &[
                "int_ior",
                "ext_ior",
                "diffuse_reflectance",
                "specular_reflectance",
                "nonlinear",
                "distribution",
                "alpha",
                "sample_visible",
            ]
        };
        self.finish(args, known)?;
        Ok(())
    }

    /// `principled`.
    fn bsdf_principled(
        &mut self,
        obj: &Obj,
        args: &Args,
        out: &mut MatOut,
    ) -> Result<(), SceneError> {
        let at = |s: String| (s, obj.loc.clone());
        out.lines.push(at("type = \"principled\"".into()));
        match self.color_tex(args, "base_color", DVec3::splat(0.5))? {
            ColorTex::Color(c) => out.lines.push(at(format!("base_color = {}", vec3(c)))),
            ColorTex::Bitmap(b) => {
                out.lines
                    .push(at(format!("base_color = {}", self.texture_ref(&b, false))));
                out.textured = Some(b.loc);
            }
        }
        // roughness and metallic may be textures (read as Mitsuba's eval_1); the other weights
        // are numbers here.
        for (name, default) in [("roughness", 0.5), ("metallic", 0.0)] {
            if args.prop(name).is_some() {
                let (value, _) =
                    self.scalar_tex(args, obj, name, "principled", &mut out.textured)?;
                out.lines.push(at(format!("{name} = {value}")));
            } else {
                out.lines.push(at(format!("{name} = {}", num(default))));
            }
        }
        if let Some((t, l)) = args.float("spec_trans")?.filter(|(t, _)| *t != 0.0) {
            return Err(l.error(
                format!("spec_trans = {t}: vkpath reads the principled BSDF without its specular transmission"),
                "Give spec_trans 0 (or leave it out), or use a roughdielectric for the glass.",
            ));
        }
        if let Some((a, l)) = args.float("anisotropic")?.filter(|(a, _)| *a != 0.0) {
            return Err(l.error(
                format!("anisotropic = {a}: vkpath's tangent frame is not Mitsuba's, so the anisotropy would run another way"),
                "Give anisotropic 0 (or leave it out).",
            ));
        }
        match (args.float("specular")?, args.float("eta")?) {
            (Some(_), Some((_, l))) => {
                return Err(l.error(
                    "both specular and eta (Mitsuba refuses them together)",
                    "Give one of the two.",
                ));
            }
            (None, Some((eta, _))) => out.lines.push(at(format!("ior = {}", num(eta)))),
            (Some((s, _)), None) => out.lines.push(at(format!("specular = {}", num(s)))),
            (None, None) => {}
        }
        // The weights vkpath's principled takes by the same names.
        const WEIGHTS: [&str; 6] = [
            "spec_tint",
            "sheen",
            "sheen_tint",
            "clearcoat",
            "clearcoat_gloss",
            "flatness",
        ];
        // The sampling rates change how Mitsuba draws directions, not the image it converges to.
        const RATES: [&str; 3] = [
            "diffuse_reflectance_sampling_rate",
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
        ];
        for name in WEIGHTS {
            if let Some((x, _)) = args.float(name)? {
                out.lines.push(at(format!("{name} = {}", num(x))));
            }
        }
        for name in RATES {
            let _ = args.float(name)?;
        }
        let read = [
            "base_color",
            "roughness",
            "metallic",
            "spec_trans",
            "anisotropic",
            "specular",
            "eta",
        ];
        let known: Vec<&str> = read.into_iter().chain(WEIGHTS).chain(RATES).collect();
        self.finish(args, &known)?;
        Ok(())
    }

    /// The material of a shape with `bsdf` (Mitsuba's default: diffuse, reflectance 0.5) and `emission`
    /// (an area emitter's radiance): its name in [materials], written the first time, and the element of
    /// the bitmap it reads, if any.
    pub(super) fn material(
        &mut self,
        bsdf: Option<&Rc<Obj>>,
        emission: Option<(DVec3, &Loc)>,
        shape_name: &str,
        shape_loc: &Loc,
    ) -> Result<(String, Option<Loc>), SceneError> {
        let key = (
            bsdf.map_or(0, |b| Rc::as_ptr(b) as usize),
            emission.map_or([u64::MAX; 3], |(e, _)| e.to_array().map(f64::to_bits)),
        );
        if let Some((name, tex)) = self.materials.get(&key) {
            return Ok((name.clone(), tex.clone()));
        }
        let out = match bsdf {
            Some(b) => self.bsdf(b)?,
            None => None,
        };
        let mut out = out.unwrap_or_else(|| MatOut {
            lines: vec![
                ("type = \"diffuse\"".into(), shape_loc.clone()),
                (
                    "albedo = [0.5, 0.5, 0.5]   # Mitsuba's default BSDF".into(),
                    shape_loc.clone(),
                ),
            ],
            textured: None,
        });
        // Mitsuba's reflecting BSDFs, and its default for a shape without one, scatter on the front face
        // only (black from behind) unless wrapped in twosided: vkpath's one_sided.
        if !bsdf.is_some_and(|b| self.two_sided(b)) {
            let origin = bsdf.map_or(shape_loc, |b| &b.loc).clone();
            out.lines.push(("one_sided = true".into(), origin));
        }
        let id = bsdf.and_then(|b| {
            self.ids
                .iter()
                .find(|(_, o)| Rc::ptr_eq(o, b))
                .map(|(id, _)| id.clone())
        });
        let base = match (&id, emission) {
            (Some(id), None) => id.clone(),
            (Some(id), Some(_)) => format!("{id}+{shape_name}"),
            (None, _) => shape_name.to_string(),
        };
        let mut name = base.clone();
        let mut n = 2;
        while self.material_names.contains(&name) {
            name = format!("{base}#{n}");
            n += 1;
        }
        self.material_names.push(name.clone());
        let o = &mut self.out_materials;
        let origin = bsdf.map_or(shape_loc, |b| &b.loc);
        o.line("", None);
        o.line(format!("[materials.{}]", toml_string(&name)), Some(origin));
        for (l, loc) in &out.lines {
            o.line(l, Some(loc));
        }
        if let Some((e, loc)) = emission {
            // Mitsuba's area emitter emits on the side its shape's normal faces: vkpath's front side.
            o.line(format!("emission = {}", vec3(e)), Some(loc));
        }
        self.materials
            .insert(key, (name.clone(), out.textured.clone()));
        Ok((name, out.textured))
    }
}

/// Mitsuba's named indices of refraction (Hecht, Optics; Mitsuba 3's ior table).
const IOR_TABLE: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

fn named_ior(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    IOR_TABLE.iter().find(|(n, _)| *n == lower).map(|(_, v)| *v)
}
