//! The XML as objects: what the reader (super::xml) makes of the files and the translation reads. An
//! object ([`Obj`]: `<bsdf type="diffuse" id="...">`) holds its named properties ([`Prop`]), whose values
//! ([`Value`]) are numbers, strings, colours, transforms ([`Xf`]), nested objects or references by id.
//! Each remembers where it was written ([`Loc`]), which every error and warning names.

use crate::scene::SceneError;
use crate::scene::translated::Origin;
use glam::{DMat4, DVec3};
use std::path::PathBuf;
use std::rc::Rc;

/// The hint of a refusal: where the elements vkpath reads, and how, are documented.
pub(super) const SEE_DOCS: &str =
    "See docs/scene-format.md, \"Mitsuba 3 XML scenes\", for the elements vkpath reads and how.";

/// Where an element is: its file, its 1-based line, and the element as written (`<float name="radius">`),
/// which errors give as their key.
#[derive(Clone, Debug)]
pub(super) struct Loc {
    pub(super) file: Rc<PathBuf>,
    pub(super) line: usize,
    pub(super) element: String,
}

impl Loc {
    pub(super) fn error(&self, problem: impl Into<String>, hint: &str) -> SceneError {
        SceneError::at(
            &self.file,
            Some(self.line),
            Some(self.element.clone()),
            problem,
            hint,
        )
    }

    /// Where a line of TOML written for this element came from.
    pub(super) fn origin(&self) -> Origin {
        Origin {
            file: self.file.clone(),
            line: Some(self.line),
            element: self.element.clone(),
        }
    }

    /// `file, line N, <element>: ` before a warning.
    pub(super) fn warning(&self, what: impl std::fmt::Display) -> String {
        format!(
            "{}, line {}, {}: {what}",
            self.file.display(),
            self.line,
            self.element
        )
    }
}

/// A transform, and the lookat it is when it is exactly one `<lookat>` (the camera is then written with
/// that origin, target and up, as a user would write it).
#[derive(Clone, Debug)]
pub(super) struct Xf {
    pub(super) m: DMat4,
    pub(super) lookat: Option<(DVec3, DVec3, Option<DVec3>)>,
}

#[derive(Clone, Debug)]
pub(super) enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    Str(String),
    /// `<point>` or `<vector>`.
    Vector(DVec3),
    Rgb(DVec3),
    /// A uniform `<spectrum value="x">`.
    Spectrum(f64),
    Transform(Xf),
    Object(Rc<Obj>),
    /// `<ref id="...">`, resolved when used (Mitsuba allows references to objects defined later).
    Ref(String),
}

impl Value {
    pub(super) fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "<float>",
            Value::Integer(_) => "<integer>",
            Value::Boolean(_) => "<boolean>",
            Value::Str(_) => "<string>",
            Value::Vector(_) => "<point> or <vector>",
            Value::Rgb(_) => "<rgb>",
            Value::Spectrum(_) => "<spectrum>",
            Value::Transform(_) => "<transform>",
            Value::Object(_) => "a nested object",
            Value::Ref(_) => "<ref>",
        }
    }
}

/// A property of an object: its `name` ("" for an unnamed nested object or reference).
#[derive(Clone, Debug)]
pub(super) struct Prop {
    pub(super) name: String,
    pub(super) value: Value,
    pub(super) loc: Loc,
}

/// A Mitsuba object: `<bsdf type="diffuse" id="...">` with its properties (`tag` "bsdf", `kind` "diffuse").
#[derive(Debug)]
pub(super) struct Obj {
    pub(super) tag: String,
    pub(super) kind: String,
    pub(super) loc: Loc,
    pub(super) props: Vec<Prop>,
    /// Written for Mitsuba below 2.0 (its file's `version`): the parameters Mitsuba 0.5/0.6 accepted
    /// and Mitsuba 3 dropped (a film's `banner`) are read too.
    pub(super) legacy: bool,
}

/// Names quoted and listed for a message: `"a", "b" and "c"` (`none` for no name).
pub(super) fn listed(names: &[&str]) -> String {
    match names {
        [] => "none".into(),
        [one] => format!("\"{one}\""),
        [rest @ .., last] => format!(
            "{} and \"{last}\"",
            rest.iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}
