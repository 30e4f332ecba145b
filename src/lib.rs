//! vkpath: a physically based path tracer whose every ray runs in a Vulkan compute shader.
//!
//! Data flows one way:
//! `scene.toml` → [`scene::Scene`] (parse + validate) → [`kernel::upload::GpuScene`] (Pod buffers) →
//! [`render::Renderer`] (WGSL compiled by naga, dispatched through ash, accumulated progressively) →
//! [`film::Film`] (linear f32 means and variances) → PNG / EXR.
//!
//! ```no_run
//! use vkpath::{gpu::{ContextOptions, GpuContext}, render::{Renderer, RenderOptions}, scene::Scene};
//! let scene = Scene::default_scene();
//! let ctx = GpuContext::new(&ContextOptions::default())?;
//! let mut renderer = Renderer::new(&ctx, &scene, &RenderOptions::default())?;
//! renderer.run_pass(16)?;
//! let film = renderer.film()?;
//! film.write(std::path::Path::new("course.png"), &scene.image)?;
//! # Ok::<(), vkpath::Error>(())
//! ```
//!
//! The library never prints; errors are values ([`Error`]).

pub mod accum;
pub mod bench;
pub mod checkpoint;
pub mod compare;
pub mod denoise;
pub mod film;
pub mod fs_atomic;
pub mod gpu;
pub mod kernel;
pub mod materials;
pub mod memory;
pub mod output;
#[cfg(feature = "preview")]
pub mod preview;
pub mod render;
pub mod scene;
pub mod session;

pub use film::Film;
pub use render::{RenderOptions, Renderer};
pub use scene::Scene;

use std::path::PathBuf;

/// The version of vkpath (Cargo's package version): written into every image's metadata and every
/// checkpoint's identity (the only version that resumes it).
pub const VKPATH_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Everything that can go wrong, grouped by who can fix it (see [`Error::exit_code`]).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene file is wrong: the message names the file, line and key.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// The device, driver or shader failed.
    #[error(transparent)]
    Gpu(#[from] gpu::GpuError),
    /// Reading or writing a file failed.
    #[error("could not write {}: {message}. Check that the directory exists and is writable.", path.display())]
    Io { path: PathBuf, message: String },
    /// Bad flags or arguments.
    #[error("{0}")]
    Usage(String),
    /// A checkpoint or partial render that cannot be used: unreadable, damaged, or of another render.
    /// The message says which and what to do.
    #[error("{}: {message}", path.display())]
    Checkpoint { path: PathBuf, message: String },
    /// Denoising was asked for and Intel Open Image Denoise cannot be loaded (or is too old): the
    /// message says what was tried and how to install it.
    #[error("{0}")]
    DenoiserMissing(String),
    /// Open Image Denoise failed while denoising.
    #[error("{0}")]
    Denoise(String),
}

impl Error {
    /// A checkpoint error with what to do in this context appended (resuming and merging want
    /// different advice); any other error unchanged.
    pub fn with_checkpoint_hint(self, hint: &str) -> Error {
        match self {
            Error::Checkpoint { path, message } => Error::Checkpoint {
                path,
                message: format!("{message} {hint}"),
            },
            e => e,
        }
    }

    /// The CLI's exit status: 2 for bad input (scene, flags), 1 for everything else.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene(_)
            | Error::Usage(_)
            | Error::Checkpoint { .. }
            | Error::DenoiserMissing(_) => 2,
            Error::Gpu(_) | Error::Io { .. } | Error::Denoise(_) => 1,
        }
    }
}

impl From<kernel::KernelError> for Error {
    fn from(e: kernel::KernelError) -> Error {
        Error::Gpu(e.into())
    }
}
