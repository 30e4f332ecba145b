//! A material plugin's material (`crate::materials`): each declared parameter read from its key by its
//! type (a colour or a number, either may be a texture where the type allows; a choice among names; a
//! boolean), checked against its range, defaulted, and packed into the kind's parameter block. The keys
//! are read, with their spans, from the TOML tree, since the plugins' keys are not fields of
//! `RawMaterial`.

use super::error::SceneError;
use super::raw::{RawMaterial, RawParam, RawVec3};
use super::{Checker, Files};
use crate::materials::{MaterialPlugin, Param, ParamType, Value};
use crate::scene::Bsdf;
use crate::scene::texture::{MaterialTextures, TextureRef};
use serde::Deserialize;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

impl<'a> Checker<'a> {
    /// The keys written in material `name`'s table, with their values, in the file's order.
    pub(super) fn material_keys(&self, name: &str) -> Vec<(&'a str, &'a Spanned<DeValue<'a>>)> {
        let table = |v: &'a Spanned<DeValue<'a>>| match v.get_ref() {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
        let entry = |t: &'a DeTable<'a>, key: &str| {
            t.iter()
                .find(|(k, _)| k.get_ref().as_ref() == key)
                .map(|(_, v)| v)
        };
        let Some(material) = self
            .tree
            .and_then(|tree| entry(tree, "materials"))
            .and_then(table)
            .and_then(|ms| entry(ms, name))
            .and_then(table)
        else {
            return Vec::new();
        };
        let mut keys: Vec<_> = material
            .iter()
            .map(|(k, v)| (k.get_ref().as_ref(), v))
            .collect();
        keys.sort_by_key(|(_, v)| v.span().start);
        keys
    }

    /// The material of plugin `plugin` (kind number `kind`) that material `name` gives, its textures
    /// recorded in `textures.block`. Returns the keys the kind allows besides the modifiers (its
    /// parameters and emission) and the material.
    pub(super) fn plugin_material(
        &self,
        kind: u32,
        plugin: &'static MaterialPlugin,
        name: &str,
        raw: &Spanned<RawMaterial>,
        files: &mut Files,
        textures: &mut MaterialTextures,
    ) -> Result<(Vec<&'static str>, Bsdf), SceneError> {
        let given = self.material_keys(name);
        let layout = plugin.layout();
        let mut values = Vec::with_capacity(plugin.params.len());
        for (p, slot) in plugin.params.iter().zip(&layout) {
            let key = format!("materials.{name}.{}", p.key);
            let value = given.iter().find(|(k, _)| *k == p.key).map(|(_, v)| *v);
            let mut texture = None;
            values.push(match value {
                None => self.plugin_default(plugin, p, raw, &key)?,
                Some(v) => self.plugin_value(plugin, p, v, &key, files, &mut texture)?,
            });
            if let Some(t) = texture {
                textures
                    .block
                    .push((slot.texture_word.expect("a textured type"), t));
            }
        }
        if let Some(check) = plugin.check {
            check(&values).map_err(|(blame, problem)| {
                let (_, p) = plugin.param(blame).expect("a check blames a parameter");
                let span = given
                    .iter()
                    .find(|(k, _)| *k == blame)
                    .map_or(raw.span(), |(_, v)| v.span());
                self.error(span, &format!("materials.{name}.{blame}"), problem, p.doc)
            })?;
        }
        let mut allowed: Vec<&'static str> = plugin.params.iter().map(|p| p.key).collect();
        allowed.extend(["emission", "two_sided_emission"]);
        Ok((
            allowed,
            Bsdf::Plugin {
                kind,
                block: plugin.pack(&values),
            },
        ))
    }

    /// A parameter that is not given: its default, or an error if it has none.
    fn plugin_default(
        &self,
        plugin: &MaterialPlugin,
        p: &Param,
        raw: &Spanned<RawMaterial>,
        key: &str,
    ) -> Result<Value, SceneError> {
        let missing = || {
            self.error(
                raw.span(),
                key,
                format!(
                    "a {} material needs {}, but the key is missing",
                    plugin.name, p.key
                ),
                format!("Give {} ({}). {}", p.key, p.ty.describe(), p.doc),
            )
        };
        Ok(match p.ty {
            ParamType::Color { default, .. } => Value::Color(default.ok_or_else(missing)?),
            ParamType::Float { default, .. } => Value::Float(default.ok_or_else(missing)?),
            ParamType::Choice { options, default } => Value::Choice(
                options
                    .iter()
                    .position(|o| *o == default)
                    .expect("a choice's default is an option") as u32,
            ),
            ParamType::Bool { default } => Value::Bool(default),
        })
    }

    /// A given parameter's value, read as its type says; a texture is recorded in `texture`.
    fn plugin_value(
        &self,
        plugin: &MaterialPlugin,
        p: &Param,
        v: &Spanned<DeValue<'_>>,
        key: &str,
        files: &mut Files,
        texture: &mut Option<TextureRef>,
    ) -> Result<Value, SceneError> {
        let wrong = |span: Range<usize>| {
            self.error(
                span,
                key,
                format!(
                    "a {} material's {} is a {}",
                    plugin.name,
                    p.key,
                    p.ty.describe()
                ),
                p.doc,
            )
        };
        Ok(match p.ty {
            ParamType::Color { max, .. } => {
                let c: Spanned<RawParam<RawVec3>> = typed(v).map_err(|_| wrong(v.span()))?;
                let c = self.color_param(
                    &c,
                    key,
                    |c| !(c.min_element() >= 0.0 && c.max_element() <= max),
                    &format!("every component must be in [0, {max}]"),
                    p.doc,
                    files,
                    texture,
                )?;
                Value::Color(c.into())
            }
            ParamType::Float {
                min, max, textured, ..
            } => {
                let x: Spanned<RawParam<f32>> = typed(v).map_err(|_| wrong(v.span()))?;
                if !textured && matches!(x.get_ref(), RawParam::Texture(_)) {
                    return Err(wrong(v.span()));
                }
                Value::Float(self.scalar_param(
                    &x,
                    key,
                    |x| !(min..=max).contains(&x),
                    &format!("it must be in [{min}, {max}]"),
                    p.doc,
                    files,
                    texture,
                )?)
            }
            ParamType::Choice { options, .. } => {
                let s: Spanned<String> = typed(v).map_err(|_| wrong(v.span()))?;
                let Some(i) = options.iter().position(|o| o == s.get_ref()) else {
                    return Err(self.error(
                        s.span(),
                        key,
                        format!("unknown {} \"{}\"", p.key, s.get_ref()),
                        format!("Use {}. {}", p.ty.describe(), p.doc),
                    ));
                };
                Value::Choice(i as u32)
            }
            ParamType::Bool { .. } => {
                let b: Spanned<bool> = typed(v).map_err(|_| wrong(v.span()))?;
                Value::Bool(*b.get_ref())
            }
        })
    }
}

/// `v` as a `T` (with its span), through the same serde forms as the built-in keys.
fn typed<'de, T: Deserialize<'de>>(v: &Spanned<DeValue<'de>>) -> Result<T, toml::de::Error> {
    T::deserialize(toml::de::ValueDeserializer::from(v.clone()))
}
