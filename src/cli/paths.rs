//! The files a render will write, checked before it starts: a mistake found after an hour of rendering
//! loses the hour, and a path that names one of the render's inputs would overwrite what the user gave.
//!
//! Checked: every output image and the checkpoint are distinct files; none of them is an input (the
//! scene file, its meshes, textures and environment map, or a checkpoint being resumed, except that a
//! resumed checkpoint may be saved back into itself); and each one's directory exists and takes a new
//! file (a probe file is created and removed there). Each refusal is a usage error (exit 2) that names
//! the path, before the device is even opened.

use std::path::{Path, PathBuf};
use vkpath::fs_atomic::directory_of;
use vkpath::{Error, Scene};

/// A path made comparable: its directory resolved (symbolic links, `..`) when it exists, then its file
/// name; the path itself when its directory does not exist (the writability check reports that).
fn comparable(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    match (directory_of(path).canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// The files a render of `scene` reads, as the scene names them, each with what it is.
pub fn scene_inputs(scene: &Scene) -> Vec<(PathBuf, &'static str)> {
    let mut v = Vec::new();
    if let Some(p) = &scene.path {
        v.push((p.clone(), "the scene file"));
    }
    for m in &scene.meshes {
        v.push((m.obj.clone(), "a mesh of the scene"));
        for t in [
            &m.texture,
            &m.maps.emissive,
            &m.maps.metallic_roughness,
            &m.maps.normal,
        ]
        .into_iter()
        .flatten()
        {
            v.push((t.path.clone(), "a texture of the scene"));
        }
    }
    if let Some(map) = &scene.environment.map {
        v.push((map.path.clone(), "the scene's environment map"));
    }
    v
}

/// What the resumed checkpoint is called among the inputs (the one input the checkpoint may overwrite).
const RESUMED: &str = "the checkpoint resumed";

fn usage(message: String) -> Error {
    Error::Usage(message)
}

/// Refuses, before any device work, outputs and a checkpoint that collide with each other or with an
/// input (`inputs`: path and what it is), or that cannot be written. `resumed`, a checkpoint being
/// resumed, is an input too, but the checkpoint may be saved back into it.
pub fn check_outputs(
    outputs: &[PathBuf],
    checkpoint: Option<&Path>,
    mut inputs: Vec<(PathBuf, &'static str)>,
    resumed: Option<&Path>,
) -> Result<(), Error> {
    let mut written: Vec<(&Path, String)> = outputs
        .iter()
        .map(|o| (o.as_path(), format!("the output {}", o.display())))
        .collect();
    if let Some(c) = checkpoint {
        written.push((c, format!("the checkpoint {}", c.display())));
    }
    for (i, (a, what_a)) in written.iter().enumerate() {
        for (b, what_b) in &written[..i] {
            if comparable(a) == comparable(b) {
                return Err(usage(format!(
                    "{what_a} and {what_b} are the same file: each would overwrite the other. Give \
                     each output and the checkpoint its own path."
                )));
            }
        }
    }
    if let Some(r) = resumed {
        inputs.push((r.to_path_buf(), RESUMED));
    }
    for (path, what) in &written {
        for (input, kind) in &inputs {
            let resumed_into_itself = *kind == RESUMED && Some(*path) == checkpoint;
            if !resumed_into_itself && comparable(path) == comparable(input) {
                return Err(usage(format!(
                    "{what} is {kind} ({}): vkpath never overwrites what it reads. Write to another path.",
                    input.display()
                )));
            }
        }
    }
    for (path, what) in &written {
        check_writable(path, what)?;
    }
    Ok(())
}

/// The file's directory exists and takes a new file: a uniquely named probe is created and removed.
fn check_writable(path: &Path, what: &str) -> Result<(), Error> {
    let dir = directory_of(path);
    if !dir.is_dir() {
        return Err(usage(format!(
            "cannot write {what}: its directory {} does not exist. Create it, or choose another path \
             (nothing was rendered).",
            dir.display()
        )));
    }
    if path.is_dir() {
        return Err(usage(format!(
            "cannot write {what}: it is a directory. Name a file (nothing was rendered)."
        )));
    }
    let probe = dir.join(format!(".vkpath-probe-{}", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        // A probe left by a killed run of the same process id: the directory took a file then.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(usage(format!(
            "cannot write {what} in {}: {e}. Choose a writable directory (nothing was rendered).",
            dir.display()
        ))),
    }
}
