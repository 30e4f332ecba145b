//! The small checks that the sections' rules share: finite numbers and vectors, integers and values in
//! range, keys that only some types need or allow, material names.

use super::Checker;
use super::error::{SEE_CONTRACT, SceneError};
use super::raw::{RawMaterial, RawVec3};
use glam::Vec3;
use std::fmt;
use std::ops::Range;
use toml::Spanned;

impl Checker<'_> {
    /// A number that must be finite: TOML allows `nan` and `inf`, and a value beyond f32's range
    /// (about 3.4e38) has already become infinite by the time we see it.
    pub(super) fn number(&self, v: &Spanned<f32>, key: &str) -> Result<f32, SceneError> {
        let value = *v.get_ref();
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.not_finite(v.span(), key, &value.to_string()))
        }
    }

    /// Three finite numbers.
    pub(super) fn vec3(&self, v: &Spanned<RawVec3>, key: &str) -> Result<Vec3, SceneError> {
        let RawVec3(xyz) = *v.get_ref();
        if xyz.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from_array(xyz))
        } else {
            let shown = format!("[{}, {}, {}]", xyz[0], xyz[1], xyz[2]);
            Err(self.not_finite(v.span(), key, &shown))
        }
    }

    pub(super) fn not_finite(&self, span: Range<usize>, key: &str, shown: &str) -> SceneError {
        self.error(
            span,
            key,
            format!("every number must be finite, got {shown}"),
            "TOML allows nan and inf, but a scene needs finite numbers within the 32-bit float range (about ±3.4e38).",
        )
    }

    /// An integer in `min..=max`, checked in i64 so that no value can overflow on the way.
    pub(super) fn integer(
        &self,
        v: &Spanned<i64>,
        key: &str,
        min: u32,
        max: u32,
        hint: &str,
    ) -> Result<u32, SceneError> {
        let value = *v.get_ref();
        let name = key.rsplit('.').next().unwrap_or(key);
        let out_of_range = || {
            self.error(
                v.span(),
                key,
                format!("{name} must be an integer from {min} to {max}, got {value}"),
                hint,
            )
        };
        if value < i64::from(min) || value > i64::from(max) {
            return Err(out_of_range());
        }
        // In range, so the conversion cannot fail; the impossible case still gets the same error.
        u32::try_from(value).map_err(|_| out_of_range())
    }

    pub(super) fn positive_radius(
        &self,
        v: &Spanned<f32>,
        key: &str,
        what: &str,
    ) -> Result<f32, SceneError> {
        self.number_unless(
            v,
            key,
            |r| r <= 0.0,
            "the radius must be > 0",
            &format!("Give every {what} a positive radius in scene units."),
        )
    }

    /// A finite number that `bad` does not reject (see [`Checker::reject_if`]).
    pub(super) fn number_unless(
        &self,
        v: &Spanned<f32>,
        key: &str,
        bad: impl FnOnce(f32) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<f32, SceneError> {
        let value = self.number(v, key)?;
        self.reject_if(v, key, value, bad, problem, hint)
    }

    /// An optional weight in [0, 1] at `key` (its last part names it in the message): `default` when
    /// absent.
    pub(super) fn optional_unit(
        &self,
        v: &Option<Spanned<f32>>,
        key: &str,
        default: f32,
        hint: &str,
    ) -> Result<f32, SceneError> {
        let field = key.rsplit('.').next().unwrap_or(key);
        match v {
            None => Ok(default),
            Some(x) => self.number_unless(
                x,
                key,
                |x| !(0.0..=1.0).contains(&x),
                &format!("{field} must be in [0, 1]"),
                hint,
            ),
        }
    }

    /// Three finite numbers that `bad` does not reject (see [`Checker::reject_if`]).
    pub(super) fn vec3_unless(
        &self,
        v: &Spanned<RawVec3>,
        key: &str,
        bad: impl FnOnce(Vec3) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<Vec3, SceneError> {
        let value = self.vec3(v, key)?;
        self.reject_if(v, key, value, bad, problem, hint)
    }

    /// `value`, read from `v`, unless `bad(value)`: then an error at `v` saying `{problem}, got {value}`.
    pub(super) fn reject_if<T: Copy + fmt::Display, S>(
        &self,
        v: &Spanned<S>,
        key: &str,
        value: T,
        bad: impl FnOnce(T) -> bool,
        problem: &str,
        hint: &str,
    ) -> Result<T, SceneError> {
        if bad(value) {
            Err(self.error(v.span(), key, format!("{problem}, got {value}"), hint))
        } else {
            Ok(value)
        }
    }

    /// A key that serde treats as optional because only some `type`s need it. Reported like serde's
    /// missing keys: at the line of the table that lacks it.
    pub(super) fn required<'v, T>(
        &self,
        value: &'v Option<Spanned<T>>,
        table: &Spanned<impl Sized>,
        key: &str,
        problem: &str,
    ) -> Result<&'v Spanned<T>, SceneError> {
        value.as_ref().ok_or_else(|| {
            self.error(
                table.span(),
                key,
                format!("{problem}, but the key is missing"),
                format!(
                    "Add `{}`. {SEE_CONTRACT}",
                    key.rsplit('.').next().unwrap_or(key)
                ),
            )
        })
    }

    /// Errors on the first present key (in file order) that `allowed` does not list.
    pub(super) fn reject_foreign_keys(
        &self,
        present: &[(&str, Option<Range<usize>>)],
        allowed: &[&str],
        table_key: &str,
        what: &str,
    ) -> Result<(), SceneError> {
        let first_foreign = present
            .iter()
            .filter(|(name, _)| !allowed.contains(name))
            .filter_map(|(name, span)| span.clone().map(|span| (*name, span)))
            .min_by_key(|(_, span)| span.start);
        match first_foreign {
            None => Ok(()),
            Some((name, span)) => Err(self.error(
                span,
                &format!("{table_key}.{name}"),
                format!("{what} has no `{name}`"),
                format!("Remove `{name}`, or change the type. {SEE_CONTRACT}"),
            )),
        }
    }

    /// The material each of `named` links to through its key `field` (`back`, `blend`: `link` reads
    /// it), resolved to indices in `names`, one level deep: a material linking to itself, or to one
    /// that links on in turn, is refused with `messages` (itself, a chain, the hint).
    pub(super) fn material_links(
        &self,
        named: &[(&Spanned<String>, &Spanned<RawMaterial>)],
        names: &[String],
        field: &str,
        link: impl Fn(&RawMaterial) -> Option<&Spanned<String>>,
        messages: [&str; 3],
    ) -> Result<Vec<Option<u32>>, SceneError> {
        let [itself, chain, hint] = messages;
        let mut out = Vec::with_capacity(named.len());
        for (i, (name, material)) in named.iter().enumerate() {
            let Some(target) = link(material.get_ref()) else {
                out.push(None);
                continue;
            };
            let key = format!("materials.{}.{field}", name.get_ref());
            let j = self.material_index(target, &key, names)?;
            let refuse =
                |problem: &str| Err(self.error(target.span(), &key, problem.to_string(), hint));
            if j as usize == i {
                return refuse(itself);
            }
            if link(named[j as usize].1.get_ref()).is_some() {
                return refuse(chain);
            }
            out.push(Some(j));
        }
        Ok(out)
    }

    /// Resolves a material name to its index in `names` (file order).
    pub(super) fn material_index(
        &self,
        name: &Spanned<String>,
        key: &str,
        names: &[String],
    ) -> Result<u32, SceneError> {
        let wanted = name.get_ref();
        let Some(index) = names.iter().position(|n| n == wanted) else {
            let defined = if names.is_empty() {
                "no materials are defined".to_string()
            } else {
                let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
                format!("the defined materials are {}", quoted.join(", "))
            };
            return Err(self.error(
                name.span(),
                key,
                format!("material \"{wanted}\" is not defined ({defined})"),
                "Use one of the names in [materials], or define this one there.",
            ));
        };
        u32::try_from(index).map_err(|_| {
            self.error(
                name.span(),
                key,
                "too many materials for a 32-bit index",
                "Use fewer materials.",
            )
        })
    }
}
