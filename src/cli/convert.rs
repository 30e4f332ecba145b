//! `vkpath convert SCENE -o OUT.toml`: any scene vkpath can read, written as the vkpath TOML it
//! understood, so that a user can see and edit it. A glTF file becomes the scene src/scene/import.rs
//! makes of it (the file as a mesh, its camera and lights), its mesh path written relative to OUT's
//! directory when it can be (else absolute); a Mitsuba 3 XML file the scene src/scene/mitsuba/ makes
//! of it, its file paths likewise; a TOML scene is checked and written as it is.

use super::{load_scene_with, usage};
use clap::Args;
use std::path::{Path, PathBuf};
use vkpath::Error;
use vkpath::scene::toml_text::{absolute, relative_to};
use vkpath::scene::{import, mesh_file, mitsuba};

#[derive(Args)]
pub struct ConvertArgs {
    /// Scene to read: TOML, glTF 2.0 (.gltf, .glb) or Mitsuba 3 XML (.xml).
    scene: PathBuf,
    /// The TOML file to write.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// A glTF scene's camera, or a Mitsuba XML scene's sensor (as `render --camera`).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32))]
    camera: Option<u32>,
    /// A Mitsuba XML scene: skip what vkpath does not read, with a warning each (as `render`).
    #[arg(long = "xml-lenient")]
    xml_lenient: bool,
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
    let camera = a.camera.map(|c| c as usize);
    load_scene_with(Some(&a.scene), camera, a.xml_lenient)?;
    let text = if mitsuba::is_xml(&a.scene) {
        // File paths relative to the output's folder, so that the TOML reads them from where it is.
        let options = mitsuba::XmlOptions {
            camera,
            lenient: a.xml_lenient,
            paths_relative_to: Some(absolute(a.output.parent().unwrap_or(Path::new("")))),
        };
        let translated = mitsuba::xml_scene(&a.scene, &options)?;
        // The warnings were printed by load_scene_with.
        translated.toml
    } else if mesh_file::is_gltf(&a.scene) {
        let out_dir = absolute(a.output.parent().unwrap_or(Path::new("")));
        let input = absolute(&a.scene);
        let mesh_ref = relative_to(&input, &out_dir).unwrap_or_else(|| input.clone());
        import::gltf_scene_referring(&a.scene, camera, &mesh_ref.to_string_lossy())?.toml
    } else {
        std::fs::read_to_string(&a.scene).map_err(|e| Error::Io {
            path: a.scene.clone(),
            message: e.to_string(),
        })?
    };
    vkpath::fs_atomic::write_atomically(&a.output, text.as_bytes())?;
    eprintln!("vkpath: wrote {}", a.output.display());
    Ok(0)
}
