//! The scene files vkpath reads, one [`Importer`] a format, picked by the file's extension; `Scene::load`
//! (`vkpath render`) and `vkpath convert` both go through this table, so a new format is one entry.
//!
//! Every importer turns a file into vkpath TOML text (super::translated): a glTF 2.0 scene
//! (super::gltf_scene), a Mitsuba 3 XML scene (super::mitsuba), or a TOML scene, which is its own text.
//! `render` reads that text like any scene file at the file's path; `convert` writes it out, its file
//! paths relative to the output's folder.

use super::mesh_file::GLTF_EXTENSIONS;
use super::translated::{ImportOptions, Translated};
use super::{FileCache, Scene, SceneError, gltf_scene, mitsuba, read_scene_text};
use std::path::Path;

/// A scene file format.
pub struct Importer {
    /// The format's name.
    pub name: &'static str,
    /// The extensions of the files it reads, lower case (a file's is matched in any case).
    pub extensions: &'static [&'static str],
    /// Whether its files have parameters that `-D name=value` sets (Mitsuba XML's `<default>`s).
    pub takes_defines: bool,
    /// The TOML text of the file at `path`, its file paths relative to a folder (absolute), or to the
    /// file's own folder when `None` (the text is then read as if it sat beside the file).
    pub to_toml: fn(
        path: &Path,
        options: &ImportOptions,
        toml_dir: Option<&Path>,
    ) -> Result<Translated, SceneError>,
}

/// vkpath's own format: read as it is written. It is the importer of every file that no other claims.
const TOML: Importer = Importer {
    name: "vkpath TOML",
    extensions: &["toml"],
    takes_defines: false,
    to_toml: toml_as_written,
};

/// Every format, in the order a file's extension is tried against them; vkpath TOML, last, also reads the
/// files that no other claims.
pub const IMPORTERS: &[Importer] = &[
    Importer {
        name: "glTF 2.0",
        extensions: GLTF_EXTENSIONS,
        takes_defines: false,
        to_toml: gltf_scene::to_toml,
    },
    Importer {
        name: "Mitsuba 3 XML",
        extensions: &["xml"],
        takes_defines: true,
        to_toml: mitsuba::to_toml,
    },
    TOML,
];

impl Importer {
    /// The importer of the scene file at `path`: the first that claims its extension, else vkpath TOML.
    pub fn for_path(path: &Path) -> &'static Importer {
        IMPORTERS.iter().find(|i| i.claims(path)).unwrap_or(&TOML)
    }

    /// Whether the file at `path` has one of this format's extensions (in any case).
    pub fn claims(&self, path: &Path) -> bool {
        path.extension()
            .is_some_and(|e| self.extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
    }

    /// The scene the file at `path` becomes: its TOML read like a scene file at `path` (relative paths
    /// from the file's folder), an error of the TOML reader reported where its line came from, and the
    /// warnings of the translation before the TOML reader's.
    pub fn load(&self, path: &Path, options: &ImportOptions) -> Result<Scene, SceneError> {
        self.load_cached(path, options, &mut FileCache::default())
            .map(|(scene, _)| scene)
    }

    /// [`Importer::load`] with the files the scene names read through `cache`, and the TOML text the
    /// scene was read from (the Python module edits that text and reads it again with the same cache).
    pub fn load_cached(
        &self,
        path: &Path,
        options: &ImportOptions,
        cache: &mut FileCache,
    ) -> Result<(Scene, String), SceneError> {
        let t = (self.to_toml)(path, options, None)?;
        let mut scene =
            Scene::from_toml_str_cached(&t.toml, Some(path), cache).map_err(|e| t.relocate(e))?;
        let mut warnings = t.warnings;
        // Lenient reading never hides an empty result: when what it skipped leaves the scene without
        // any light, the image would be black, which the warnings above do not say.
        if t.skipped_lights > 0 && !scene.has_light() {
            warnings.push(format!(
                "{}: no light is left once what --xml-lenient skipped is gone (see the warnings above): \
                 the image will be black",
                path.display()
            ));
        }
        warnings.append(&mut scene.warnings);
        scene.warnings = warnings;
        Ok((scene, t.toml))
    }
}

/// A TOML scene's text, as written (its paths stay as they are). It has one `[camera]`: `--camera` is
/// refused before the file is read.
fn toml_as_written(
    path: &Path,
    options: &ImportOptions,
    _toml_dir: Option<&Path>,
) -> Result<Translated, SceneError> {
    if options.camera.is_some() || options.auto_camera {
        return Err(SceneError::import(
            path,
            Some("--camera".into()),
            "--camera picks a camera of a glTF or Mitsuba XML scene, but this scene is a TOML file with one [camera]",
            "Leave --camera out, or render the glTF or XML file itself.",
        ));
    }
    Ok(Translated::as_written(read_scene_text(path)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_extension_has_one_importer_and_toml_reads_the_rest() {
        let name = |p: &str| Importer::for_path(Path::new(p)).name;
        assert_eq!(name("a/scene.gltf"), "glTF 2.0");
        assert_eq!(name("scene.GLB"), "glTF 2.0");
        assert_eq!(name("scene.Xml"), "Mitsuba 3 XML");
        assert_eq!(name("scene.toml"), "vkpath TOML");
        assert_eq!(name("scene.txt"), "vkpath TOML");
        assert_eq!(name("scene"), "vkpath TOML");
        for (i, a) in IMPORTERS.iter().enumerate() {
            for b in &IMPORTERS[i + 1..] {
                assert!(a.extensions.iter().all(|e| !b.extensions.contains(e)));
            }
        }
    }
}
