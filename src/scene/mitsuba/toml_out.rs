//! The TOML being written, each line with the XML element it came from (so that an error the TOML reader
//! finds is reported at that element), and numbers and vectors as it writes them.

use super::objects::Loc;
use crate::scene::toml_text;
use crate::scene::translated::Origin;
use glam::DVec3;

/// TOML text being written, with the XML element each line came from.
#[derive(Default)]
pub(super) struct TomlOut {
    pub(super) text: String,
    pub(super) origins: Vec<Option<Origin>>,
}

impl TomlOut {
    pub(super) fn line(&mut self, s: impl AsRef<str>, origin: Option<&Loc>) {
        for l in s.as_ref().split('\n') {
            self.text += l;
            self.text.push('\n');
            self.origins.push(origin.map(Loc::origin));
        }
    }

    pub(super) fn append(&mut self, other: TomlOut) {
        self.text += &other.text;
        self.origins.extend(other.origins);
    }
}

/// A number as TOML writes it, rounded to the f32 the scene stores.
pub(super) fn num(x: f64) -> String {
    toml_text::num(x as f32)
}

pub(super) fn vec3(v: DVec3) -> String {
    toml_text::vec3(v.as_vec3().to_array())
}
