//! Host memory: what the machine has available, so that a render too large for the machine is refused
//! before anything is allocated instead of being killed by the kernel's out-of-memory killer part-way
//! (11586 x 11586 at 1 spp used to be), and so that a file that claims a size (a checkpoint's header, a
//! mesh's counts) is checked against memory before it is decoded; and reading a whole file with a bound.
//!
//! What a render holds per pixel is the render's to say (`render::host_use`): this module depends on
//! nothing of vkpath's, so that every reader (the scene's files, images, checkpoints) can use it.

/// The test hook that stands for the machine's available memory, in bytes (so that the refusal can be
/// tested without a render as large as the machine).
pub const AVAILABLE_OVERRIDE: &str = "VKPATH_HOST_MEMORY_AVAILABLE";

/// The memory the machine can give a new allocation without swapping, in bytes: `MemAvailable` of
/// /proc/meminfo (Linux's own estimate: free memory plus the caches it can drop), or
/// [`AVAILABLE_OVERRIDE`]. `None` where neither is known (another system): nothing is refused then.
pub fn available_bytes() -> Option<u64> {
    if let Some(v) = std::env::var_os(AVAILABLE_OVERRIDE) {
        return v.to_str().and_then(|v| v.trim().parse().ok());
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_mem_available(&text)
}

/// `MemAvailable:  24131164 kB` -> bytes.
fn parse_mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => value.checked_mul(1024),
        None => Some(value),
        Some(_) => None,
    }
}

/// The largest input file read whole (a mesh, a texture, a glTF buffer, an MTL library): 2^32 bytes, a
/// GLB's own limit.
pub const MAX_FILE_BYTES: u64 = 1 << 32;

/// Reads an input file whole: a regular file (a pipe or a device such as /dev/zero may never end) of at
/// most [`MAX_FILE_BYTES`] that fits the memory available. The error is the reason alone (the caller
/// names the file and what it is for).
pub fn read_file(path: &std::path::Path) -> Result<Vec<u8>, String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("it is not a regular file".into());
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(format!(
            "it is {} bytes, more than the {MAX_FILE_BYTES} vkpath reads",
            meta.len()
        ));
    }
    check_available(meta.len(), "reading it")?;
    std::fs::read(path).map_err(|e| e.to_string())
}

/// MiB, for messages.
pub fn mib(bytes: u64) -> f64 {
    bytes as f64 / f64::from(1 << 20)
}

/// Refuses (the message, without the file or flag it is about) an allocation of `bytes` for `what`
/// that the machine does not have available.
pub fn check_available(bytes: u64, what: &str) -> Result<(), String> {
    match available_bytes() {
        Some(available) if bytes > available => Err(format!(
            "{what} would take {:.0} MiB of host memory, and the machine has {:.0} MiB available",
            mib(bytes),
            mib(available)
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let text = "MemTotal:       24596060 kB\nMemFree:         1000000 kB\nMemAvailable:   24131164 kB\n";
        assert_eq!(parse_mem_available(text), Some(24131164 * 1024));
        assert_eq!(parse_mem_available("MemFree: 3 kB\n"), None);
        assert_eq!(parse_mem_available("MemAvailable: x kB\n"), None);
    }

    #[test]
    fn only_regular_files_are_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f.bin");
        std::fs::write(&file, b"abc").unwrap();
        assert_eq!(read_file(&file).unwrap(), b"abc");
        assert!(
            read_file(dir.path())
                .unwrap_err()
                .contains("not a regular file")
        );
        if cfg!(unix) {
            let e = read_file(std::path::Path::new("/dev/zero")).unwrap_err();
            assert!(e.contains("not a regular file"), "{e}");
        }
        assert!(read_file(&dir.path().join("absent")).is_err());
    }
}
