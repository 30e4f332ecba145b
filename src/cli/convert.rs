//! `vkpath convert SCENE -o OUT.toml`: any scene vkpath can read, written as the vkpath TOML it
//! understood, so that a user can see and edit it. The scene's importer (src/scene/import.rs, the one
//! `render` reads it with) writes the TOML with its file paths relative to OUT's directory when it can be
//! (else absolute): a glTF file becomes the scene src/scene/gltf_scene.rs makes of it (the file as a mesh,
//! its camera and lights), a Mitsuba 3 XML file the scene src/scene/mitsuba/ makes of it; a TOML scene is
//! checked and written as it is.

use super::{load_scene_with, usage};
use clap::Args;
use std::path::{Path, PathBuf};
use vkpath::Error;
use vkpath::scene::import::Importer;
use vkpath::scene::toml_text::absolute;
use vkpath::scene::translated::ImportOptions;

#[derive(Args)]
pub struct ConvertArgs {
    /// Scene to read: TOML, glTF 2.0 (.gltf, .glb) or Mitsuba 3 XML (.xml).
    scene: PathBuf,
    /// The TOML file to write.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// A glTF scene's camera (or `auto`), or a Mitsuba XML scene's sensor (as `render --camera`).
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_camera)]
    camera: Option<super::CameraArg>,
    /// A Mitsuba XML scene: skip what vkpath does not read, with a warning each (as `render`).
    #[arg(long = "xml-lenient")]
    xml_lenient: bool,
    /// A Mitsuba XML scene's `<default>` parameter (as `render -D`); repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = super::parse_define)]
    defines: Vec<(String, String)>,
}

pub fn run_convert(a: ConvertArgs) -> Result<i32, Error> {
    let is_toml = a
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if !is_toml {
        return Err(usage(format!(
            "-o {}: convert writes vkpath TOML; give an output ending in .toml.",
            a.output.display()
        )));
    }
    let same = |p: &Path, q: &Path| match (p.canonicalize(), q.canonicalize()) {
        (Ok(p), Ok(q)) => p == q,
        _ => false,
    };
    if same(&a.scene, &a.output) {
        return Err(usage(format!(
            "-o {} is the scene being read; convert never overwrites its input.",
            a.output.display()
        )));
    }
    // Read (and check) the scene as render would, warnings included.
    let options = ImportOptions {
        xml_lenient: a.xml_lenient,
        defines: a.defines.clone(),
        ..super::CameraArg::options(a.camera)
    };
    load_scene_with(Some(&a.scene), &options)?;
    // File paths relative to the output's folder, so that the TOML reads them from where it is. The
    // warnings were printed by load_scene_with.
    let out_dir = absolute(a.output.parent().unwrap_or(Path::new("")));
    let importer = Importer::for_path(&a.scene);
    let text = (importer.to_toml)(&a.scene, &options, Some(&out_dir))?.toml;
    vkpath::fs_atomic::write_atomically(&a.output, text.as_bytes())?;
    eprintln!("vkpath: wrote {}", a.output.display());
    Ok(0)
}
