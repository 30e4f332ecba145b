//! Running the `vkpath` binary and writing its input files, for the tests that drive the command line
//! as a child process. One copy here, so that every such test runs the binary the same way: in a
//! directory of its own, with the Khronos validation layer on, and blind to the scheduler variables of
//! the machine the tests run on.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The variables `--part env` reads to pick a part of the render.
const SCHEDULER_VARIABLES: [&str; 5] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_COUNT",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "JOB_COMPLETION_INDEX",
];

/// The `vkpath` binary Cargo built for these tests, run in `dir` (relative paths in the arguments are
/// the test's own temporary files) with the validation layer on (`VKPATH_VALIDATION=1`), so that a
/// Vulkan usage error fails the run.
pub fn vkpath(dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_vkpath"));
    c.env("VKPATH_VALIDATION", "1").current_dir(dir);
    // `--part env` reads these: a test run inside a Slurm or Kubernetes job must not see its own.
    for v in SCHEDULER_VARIABLES {
        c.env_remove(v);
    }
    c
}

/// Runs `vkpath args` in `dir` to the end and returns its exit status, stdout and stderr; the caller
/// checks them.
#[track_caller]
pub fn run(dir: &Path, args: &[&str]) -> Output {
    vkpath(dir).args(args).output().expect("run vkpath")
}

/// Runs `vkpath args` in `dir` and asserts that it exited 0, showing its stderr (the reason) if not.
#[track_caller]
pub fn run_ok(dir: &Path, args: &[&str]) -> Output {
    let out = run(dir, args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "vkpath {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Writes `text` to `dir/name` (a scene, a model, a material library) and returns the path, for a test
/// that loads the file or passes it to the binary.
#[track_caller]
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap_or_else(|e| panic!("write {}: {e}", path.display()));
    path
}
