//! Mitsuba 3 XML scenes, read as vkpath scenes (`vkpath render scene.xml`).
//!
//! As for glTF (super::gltf_scene), the XML becomes the vkpath TOML text that says what vkpath
//! understood of it, and that text is read by the TOML reader, so every check and default is the TOML
//! reader's and `vkpath convert scene.xml -o scene.toml` writes the same text. Each line of the TOML
//! remembers the XML element it came from, so that an error the TOML reader finds (an albedo above 1, an
//! unreadable mesh) is reported at the XML file, line and element, not at a line of text the user never
//! saw. [`to_toml`] is this format's entry in super::import.
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
mod plugins;
mod sensor;
mod shapes;
mod spectra;
mod toml_out;
mod translate;
mod xml;

pub use shapes::DISK_SEGMENTS;

use super::SceneError;
use super::toml_text::absolute;
use super::translated::{ImportOptions, Translated};
use context::Tr;
use std::path::Path;
use xml::Parser;

/// The vkpath TOML for the XML scene at `path` (see the module comment), its file paths relative to
/// `toml_dir` (absolute), or to the XML file's own folder when `None` (the TOML is then read as if it sat
/// beside the XML).
pub fn to_toml(
    path: &Path,
    options: &ImportOptions,
    toml_dir: Option<&Path>,
) -> Result<Translated, SceneError> {
    let main = absolute(path);
    let main_dir = main.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut parser = Parser::new(options.xml_lenient, main_dir.clone(), &options.defines);
    let scene = parser.main_file(path)?;
    let refer_dir = toml_dir.map(absolute).unwrap_or_else(|| main_dir.clone());
    let warnings = std::mem::take(&mut parser.warnings);
    let search_dirs = parser.search_dirs();
    let mut tr = Tr::new(
        &parser.ids,
        options.xml_lenient,
        warnings,
        search_dirs,
        refer_dir,
    );
    tr.parameters = parser.parameters().to_vec();
    if options.auto_camera {
        return Err(SceneError::import(
            path,
            Some("--camera".into()),
            "--camera auto frames a glTF scene from its bounds; a Mitsuba XML scene is rendered from one of its sensors",
            "Give --camera N (the sensor, from 0) or leave --camera out for the first.",
        ));
    }
    let toml = tr.toml(&scene, path, options.camera)?;
    Ok(Translated {
        toml: toml.text,
        warnings: tr.warnings,
        origins: toml.origins,
        skipped_lights: tr.skipped_lights,
    })
}
