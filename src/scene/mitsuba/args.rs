//! The parameters of one object as a plugin reads them: by name and kind, each read remembered, so that
//! a parameter no plugin read can be named (super::context, `finish`); and references resolved by id.

use super::objects::{Loc, Obj, Prop, SEE_DOCS, Value, Xf};
use crate::scene::SceneError;
use glam::DVec3;
use std::cell::Cell;
use std::collections::HashMap;
use std::rc::Rc;

/// An object's parameters, remembering which were read.
pub(super) struct Args<'o> {
    pub(super) obj: &'o Obj,
    used: Vec<Cell<bool>>,
}

impl<'o> Args<'o> {
    pub(super) fn new(obj: &'o Obj) -> Args<'o> {
        Args {
            obj,
            used: obj.props.iter().map(|_| Cell::new(false)).collect(),
        }
    }

    pub(super) fn prop(&self, name: &str) -> Option<&'o Prop> {
        let i = self.obj.props.iter().position(|p| p.name == name)?;
        self.used[i].set(true);
        Some(&self.obj.props[i])
    }

    pub(super) fn wrong(p: &Prop, expected: &str) -> SceneError {
        p.loc.error(
            format!(
                "\"{}\" is {}, but vkpath reads it as {expected}",
                p.name,
                p.value.kind()
            ),
            SEE_DOCS,
        )
    }

    /// Parameter `name` as `read` takes it from its value, or `None` when the object has none; a value of
    /// another kind is an error that says what vkpath reads it as (`expected`).
    fn typed<T>(
        &self,
        name: &str,
        expected: &str,
        read: impl Fn(&'o Value) -> Option<T>,
    ) -> Result<Option<(T, &'o Loc)>, SceneError> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        match read(&p.value) {
            Some(v) => Ok(Some((v, &p.loc))),
            None => Err(Self::wrong(p, expected)),
        }
    }

    pub(super) fn float(&self, name: &str) -> Result<Option<(f64, &'o Loc)>, SceneError> {
        self.typed(name, "a <float>", |v| match v {
            Value::Float(x) => Some(*x),
            Value::Integer(i) => Some(*i as f64),
            _ => None,
        })
    }

    pub(super) fn float_or(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        Ok(self.float(name)?.map_or(default, |(x, _)| x))
    }

    pub(super) fn int(&self, name: &str) -> Result<Option<(i64, &'o Loc)>, SceneError> {
        self.typed(name, "an <integer>", |v| match v {
            Value::Integer(i) => Some(*i),
            _ => None,
        })
    }

    pub(super) fn boolean(&self, name: &str) -> Result<Option<(bool, &'o Loc)>, SceneError> {
        self.typed(name, "a <boolean>", |v| match v {
            Value::Boolean(b) => Some(*b),
            _ => None,
        })
    }

    pub(super) fn string(&self, name: &str) -> Result<Option<(&'o str, &'o Loc)>, SceneError> {
        self.typed(name, "a <string>", |v| match v {
            Value::Str(s) => Some(s.as_str()),
            _ => None,
        })
    }

    pub(super) fn vector(&self, name: &str) -> Result<Option<(DVec3, &'o Loc)>, SceneError> {
        self.typed(name, "a <point> or <vector>", |v| match v {
            Value::Vector(v) => Some(*v),
            _ => None,
        })
    }

    pub(super) fn transform(&self, name: &str) -> Result<Option<(&'o Xf, &'o Loc)>, SceneError> {
        self.typed(name, "a <transform>", |v| match v {
            Value::Transform(x) => Some(x),
            _ => None,
        })
    }

    /// The properties no one read, in file order.
    pub(super) fn unread(&self) -> impl Iterator<Item = &'o Prop> + '_ {
        self.obj
            .props
            .iter()
            .zip(&self.used)
            .filter(|(_, used)| !used.get())
            .map(|(p, _)| p)
    }

    /// The nested or referenced objects of element `tag` (any name: Mitsuba's shapes find their BSDF by
    /// its kind, not its name).
    pub(super) fn objects(
        &self,
        tag: &str,
        ids: &HashMap<String, Rc<Obj>>,
    ) -> Result<Vec<(Rc<Obj>, &'o Loc)>, SceneError> {
        let mut out = Vec::new();
        for (i, p) in self.obj.props.iter().enumerate() {
            let obj = match &p.value {
                Value::Object(o) => o.clone(),
                Value::Ref(id) => resolve_ref(ids, id, &p.loc)?,
                _ => continue,
            };
            if obj.tag == tag {
                self.used[i].set(true);
                out.push((obj, &p.loc));
            }
        }
        Ok(out)
    }

    /// At most one object of element `tag`.
    pub(super) fn object(
        &self,
        tag: &str,
        ids: &HashMap<String, Rc<Obj>>,
    ) -> Result<Option<(Rc<Obj>, &'o Loc)>, SceneError> {
        let mut all = self.objects(tag, ids)?;
        if all.len() > 1 {
            return Err(all[1].1.error(
                format!("{} has more than one <{tag}>", self.obj.loc.element),
                "Give it one.",
            ));
        }
        Ok(all.pop())
    }
}

pub(super) fn resolve_ref(
    ids: &HashMap<String, Rc<Obj>>,
    id: &str,
    loc: &Loc,
) -> Result<Rc<Obj>, SceneError> {
    ids.get(id).cloned().ok_or_else(|| {
        loc.error(
            format!("no object has the id \"{id}\""),
            "Refer to the id of an object defined in the scene (<bsdf type=\"...\" id=\"...\">).",
        )
    })
}
