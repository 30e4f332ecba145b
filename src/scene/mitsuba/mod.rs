//! Mitsuba 3 XML scenes, read as vkpath scenes (`vkpath render scene.xml`).
//!
//! As for glTF (super::import), the XML becomes the vkpath TOML text that says what vkpath understood
//! of it, and that text is read by the TOML reader, so every check and default is the TOML reader's and
//! `vkpath convert scene.xml -o scene.toml` writes the same text. Each line of the TOML remembers the XML
//! element it came from, so that an error the TOML reader finds (an albedo above 1, an unreadable mesh)
//! is reported at the XML file, line and element, not at a line of text the user never saw.
//!
//! Two stages, one concept a file:
//!
//! 1. Reading. xml.rs: the parser reads the XML (roxmltree) into a tree of objects and their named
//!    properties, with Mitsuba 3's rules for the file format: `<default>` and `$name` substitution in
//!    attribute values, `<include>`, `id` and `<ref>`, nested `<transform>` operations (each one
//!    left-multiplies the transform so far), the value tags. Anything it does not know is an error (or,
//!    with `lenient`, a warning and the element skipped). objects.rs: that tree, each element with its
//!    file and line.
//! 2. Translation into TOML (toml_out.rs: the text, each line with the element it came from). context.rs:
//!    the translator, its state and the rules every plugin follows. Each plugin reads its parameters
//!    through args.rs, which remembers which ones were used: a parameter no one read is an error that names
//!    it (Mitsuba 3 does the same: "unreferenced property"), so nothing in the file is silently ignored.
//!    translate.rs: the `<scene>` (its objects, the integrator) and the order of the TOML; sensor.rs: one
//!    sensor, its film and sampler; emitters.rs: the lights and the environment; shapes.rs: the shapes;
//!    materials.rs: their BSDFs as materials; colors.rs: colour and texture parameters.
//!
//! docs/scene-format.md, "Mitsuba 3 XML scenes", lists every element, its mapping and what is refused.
//! The maths of each conversion (camera frame, field of view, transforms, the disk) is next to its code.

mod args;
mod colors;
mod context;
mod emitters;
mod materials;
mod objects;
mod sensor;
mod shapes;
mod toml_out;
mod translate;
mod xml;

pub use shapes::DISK_SEGMENTS;
pub use translate::INFINITE_DEPTH_BOUNCES;

use super::toml_text::absolute;
use super::{Scene, SceneError};
use context::Tr;
use objects::Loc;
use std::path::{Path, PathBuf};
use xml::Parser;

/// How to read an XML scene.
#[derive(Clone, Debug, Default)]
pub struct XmlOptions {
    /// The sensor to render from (0-based, in file order); the first when `None`.
    pub camera: Option<usize>,
    /// Skip unknown elements, plugins and parameters with a warning each, instead of refusing the file.
    pub lenient: bool,
    /// Write file paths relative to this directory (absolute); the XML file's own directory when `None`
    /// (the TOML is then read as if it sat beside the XML).
    pub paths_relative_to: Option<PathBuf>,
}

/// What an XML scene becomes: the TOML text, what the reader noticed, and where each TOML line came from.
pub struct Translated {
    pub toml: String,
    pub warnings: Vec<String>,
    origins: Vec<Option<Loc>>,
}

impl Translated {
    /// An error of the TOML reader on this text, placed at the XML element its line came from.
    fn relocate(&self, e: SceneError) -> SceneError {
        let origin = e
            .line()
            .and_then(|l| self.origins.get(l.wrapping_sub(1)))
            .and_then(Option::as_ref);
        match origin {
            Some(loc) => {
                let key = match e.key() {
                    Some(k) => format!("{} (read as vkpath's {k})", loc.element),
                    None => loc.element.clone(),
                };
                e.relocated(loc.file.display().to_string(), Some(loc.line), Some(key))
            }
            None => e,
        }
    }
}

/// Whether a scene file is read as Mitsuba 3 XML (its extension is `.xml`, any case).
pub fn is_xml(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Reads the XML scene at `path` and loads the vkpath scene it becomes.
pub fn load(path: &Path, options: &XmlOptions) -> Result<Scene, SceneError> {
    let t = xml_scene(path, options)?;
    let mut scene = Scene::from_toml_str(&t.toml, Some(path)).map_err(|e| t.relocate(e))?;
    let mut warnings = t.warnings;
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    Ok(scene)
}

/// The vkpath TOML for the XML scene at `path` (see the module comment).
pub fn xml_scene(path: &Path, options: &XmlOptions) -> Result<Translated, SceneError> {
    let main = absolute(path);
    let main_dir = main.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut parser = Parser::new(options.lenient, main_dir.clone());
    let scene = parser.main_file(path)?;
    let refer_dir = options
        .paths_relative_to
        .as_deref()
        .map(absolute)
        .unwrap_or_else(|| main_dir.clone());
    let warnings = std::mem::take(&mut parser.warnings);
    let mut tr = Tr::new(&parser.ids, options.lenient, warnings, main_dir, refer_dir);
    let toml = tr.toml(&scene, path, options.camera)?;
    Ok(Translated {
        toml: toml.text,
        warnings: tr.warnings,
        origins: toml.origins,
    })
}
