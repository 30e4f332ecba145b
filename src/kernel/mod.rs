//! The kernel's contract with the host, and nothing that speaks Vulkan (that is `gpu/`).
//!
//! - [`abi`]: the `#[repr(C)]` Pod structs shared with WGSL and every constant shared with it (each held
//!   against naga's reflection of the WGSL by `tests/layout.rs`).
//! - [`alias`]: alias tables, which pick emissive triangles in proportion to their power.
//! - [`features`]: the feature set of a scene, one table row per specialisation constant.
//! - [`library`]: the WGSL files and the assembly of a kernel from its `requires` lines.
//! - [`specialise`]: naga compilation, override folding and pruning, binding reflection.
//! - [`upload`]: a [`crate::scene::Scene`] flattened into the Pod arrays the kernel reads.

pub mod abi;
pub mod alias;
pub mod coat;
pub mod features;
pub mod library;
pub mod light_kinds;
pub mod sheen;
pub mod specialise;
pub mod upload;

/// A shader that does not compile or specialise: a bug in vkpath's WGSL (the message says where).
#[derive(Debug, thiserror::Error)]
pub enum KernelError {
    #[error("{0}")]
    Shader(String),
}
