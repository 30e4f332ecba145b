//! A BSDF that a material plugin reads (`crate::materials`, `MaterialPlugin::mitsuba`): `type` is the
//! plugin's kind and each parameter is read from the property of its key (the plugin's keys are
//! Mitsuba's, snake_case as Mitsuba 3 upgrades 0.x files), as its type says. A property that is not
//! given is left out: the plugin's default is Mitsuba's.

use super::args::Args;
use super::colors::ColorTex;
use super::context::Tr;
use super::materials::MatOut;
use super::objects::Obj;
use super::toml_out::{num, vec3};
use crate::materials::{MaterialPlugin, ParamType};
use crate::scene::SceneError;
use crate::scene::toml_text::toml_string;
use glam::DVec3;

impl Tr<'_> {
    /// The material keys of `obj`, a BSDF of `plugin`, and the element of a bitmap it reads, if any.
    pub(super) fn plugin_bsdf(
        &mut self,
        plugin: &MaterialPlugin,
        obj: &Obj,
    ) -> Result<MatOut, SceneError> {
        let args = Args::new(obj);
        let mut lines = vec![(
            format!("type = {}", toml_string(plugin.name)),
            obj.loc.clone(),
        )];
        let mut textured = None;
        for p in plugin.params {
            let Some(loc) = args.prop(p.key).map(|prop| prop.loc.clone()) else {
                continue;
            };
            let value = match p.ty {
                ParamType::Color { .. } => match self.color_tex(&args, p.key, DVec3::ZERO)? {
                    ColorTex::Color(c) => vec3(c),
                    ColorTex::Bitmap(b) => {
                        textured = Some(b.loc.clone());
                        self.texture_ref(&b, false)
                    }
                },
                ParamType::Float { textured: true, .. } => {
                    self.scalar_tex(&args, obj, p.key, plugin.name, &mut textured)?
                        .0
                }
                ParamType::Float { .. } => num(args.float(p.key)?.map_or(0.0, |(x, _)| x)),
                ParamType::Choice { .. } => toml_string(args.string(p.key)?.map_or("", |(s, _)| s)),
                ParamType::Bool { .. } => args.boolean(p.key)?.is_some_and(|(b, _)| b).to_string(),
            };
            lines.push((format!("{} = {value}", p.key), loc));
        }
        let keys: Vec<&str> = plugin.params.iter().map(|p| p.key).collect();
        self.finish(&args, &keys)?;
        Ok(MatOut { lines, textured })
    }
}
