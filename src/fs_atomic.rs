//! Atomic file writing: a file is written to a temporary file beside its target, flushed and synced,
//! then renamed over the target, so that a crash never leaves a partial file.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The directory a file `path` is (or would be) in: its parent, or `.` for a bare file name.
pub fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The temporary file a write of `path` goes through: hidden, beside it, named by this process.
pub(crate) fn temp_path_for(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `bytes` to `path` through a temporary file and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), crate::Error> {
    write_atomically_with(path, |f| f.write_all(bytes))
}

/// Writes a file atomically: `fill` writes the content into a temporary file in the same directory,
/// which is then flushed, synced to disk and renamed over `path` (and the directory synced, so that the
/// rename itself survives a power cut). A crash or a kill at any point leaves either the old file or the
/// new one under `path`, never a partial one; at worst a hidden `.NAME.PID.tmp` file stays behind.
pub fn write_atomically_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), crate::Error> {
    let io_err = |e: std::io::Error| crate::Error::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let tmp = temp_path_for(path);
    let result = (|| {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        fill(&mut f)?;
        let f = f.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io_err)?;
    sync_parent_dir(path);
    Ok(())
}

/// Best effort: make a rename in `path`'s directory durable (a no-op where directories cannot be opened).
pub(crate) fn sync_parent_dir(path: &Path) {
    if let Ok(d) = std::fs::File::open(directory_of(path)) {
        let _ = d.sync_all();
    }
}
