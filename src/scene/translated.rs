//! What an importer (super::import) is asked and what it answers: the options the command line gives
//! (`--camera`, `--xml-lenient`), and the vkpath TOML text a scene file becomes, with the warnings of
//! reading it and where each of its lines came from, so that an error the TOML reader finds in the text is
//! reported at the file, line and element the user wrote, not at a line of text they never saw.

use super::SceneError;
use std::path::PathBuf;
use std::rc::Rc;

/// How to read a scene file.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// The camera to render from (0-based, in the file's order: a glTF scene's camera nodes in a depth-first
    /// walk, a Mitsuba scene's sensors); the first when `None`. A TOML scene has one and refuses it.
    pub camera: Option<usize>,
    /// `--camera auto`: a glTF scene is framed from its bounds (gltf_scene.rs), whatever cameras it has
    /// (a glTF scene without one is framed anyway). Other formats refuse it.
    pub auto_camera: bool,
    /// Mitsuba XML: skip unknown elements, plugins and parameters with a warning each, instead of refusing
    /// the file.
    pub xml_lenient: bool,
    /// Mitsuba XML: `<default>` parameters set on the command line (`-D name=value`), in the order given.
    /// They win over the file's own `<default>`s, as on Mitsuba's command line; the first of a repeated
    /// name wins.
    pub defines: Vec<(String, String)>,
    /// `--environment MAP`: the command line lights the scene, so a glTF scene without lights gets no
    /// uniform environment of its own (nor the note that says so).
    pub environment_given: bool,
}

/// Where a line of translated TOML came from: the file, its 1-based line (none where lines mean nothing:
/// a glTF file's JSON, often on one line), and the element as written there (`<float name="radius">`,
/// `cameras[0]`), which errors give as their key.
#[derive(Clone, Debug)]
pub struct Origin {
    pub file: Rc<PathBuf>,
    pub line: Option<usize>,
    pub element: String,
}

/// What a scene file becomes: the TOML text, what the reader noticed, and where each TOML line came from
/// (`origins[i]` for line i + 1; shorter, or `None`, where no element of the file is known).
pub struct Translated {
    pub toml: String,
    pub warnings: Vec<String>,
    pub origins: Vec<Option<Origin>>,
    /// Lights a lenient reading skipped (an emitter, or a shape that emits): when the scene is left
    /// without any light, the reader says the image will be black.
    pub skipped_lights: usize,
}

impl Translated {
    /// A translation that skipped no light.
    pub fn new(toml: String, warnings: Vec<String>, origins: Vec<Option<Origin>>) -> Translated {
        Translated {
            toml,
            warnings,
            origins,
            skipped_lights: 0,
        }
    }

    /// Text read as it is: no warnings, no origins.
    pub fn as_written(toml: String) -> Translated {
        Translated {
            toml,
            warnings: Vec::new(),
            origins: Vec::new(),
            skipped_lights: 0,
        }
    }

    /// An error of the TOML reader on this text, placed at the element its line came from.
    pub fn relocate(&self, e: SceneError) -> SceneError {
        let origin = e
            .line()
            .and_then(|l| self.origins.get(l.wrapping_sub(1)))
            .and_then(Option::as_ref);
        match origin {
            Some(o) => {
                // The TOML key helps where the user can see the translation line by line (`vkpath
                // convert` of an XML file); a glTF element without a line is named alone.
                let key = match e.key() {
                    Some(k) if o.line.is_some() => format!("{} (read as vkpath's {k})", o.element),
                    _ => o.element.clone(),
                };
                e.relocated(o.file.display().to_string(), o.line, Some(key))
            }
            None => e,
        }
    }
}
