//! Everything that speaks Vulkan (ash). Nothing outside this module imports ash.
//!
//! - [`context`]: instance, device choice, queue, allocator, validation messages.
//! - [`buffer`]: storage/uniform buffers and readback.
//! - [`image`]: data images, read-only scene arrays the kernel reads with `textureLoad`.
//! - [`kernel`]: a compute pipeline whose descriptor layout is reflected from the WGSL (compiled by
//!   [`crate::kernel::specialise`]), buffers bound by their WGSL names, and dispatch.
//! - [`present`] (feature `preview`): a window's surface and swapchain, showing 8-bit images.
//! - [`testing`]: run a WGSL test kernel over an input buffer and read the answers back.

pub mod buffer;
pub mod context;
pub mod image;
pub mod kernel;
#[cfg(feature = "preview")]
pub mod present;
pub mod testing;

pub use buffer::{Buffer, upload_device_local, upload_uniform_padded};
pub use context::{ContextOptions, DeviceInfo, GpuContext};
pub use image::DataImage;
pub use kernel::{Command, Kernel};

use ash::vk;

/// Failures of the GPU layer. Each message says what to do.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no Vulkan loader could be loaded ({0}). Install a Vulkan driver: on Debian/Ubuntu run \
         `./ci/setup.sh` (or `sudo apt-get install -y mesa-vulkan-drivers libvulkan1`), which provides \
         Mesa's lavapipe, a Vulkan implementation on the CPU."
    )]
    NoVulkan(String),
    #[error(
        "no Vulkan device with a compute queue was found. Install a Vulkan driver: on Debian/Ubuntu run \
         `./ci/setup.sh` (or `sudo apt-get install -y mesa-vulkan-drivers libvulkan1`) for Mesa's lavapipe \
         (Vulkan on the CPU), or your GPU vendor's driver."
    )]
    NoDevice,
    #[error(
        "no Vulkan device name contains \"{wanted}\" (VKPATH_DEVICE); the devices found are: {}. Unset \
         VKPATH_DEVICE or give a part of one of these names.", available.join(", ")
    )]
    DeviceNotFound {
        wanted: String,
        available: Vec<String>,
    },
    #[error(
        "the Khronos validation layer was requested (VKPATH_VALIDATION) but is not installed. Install it \
         with `sudo apt-get install -y vulkan-validationlayers` (or `./ci/setup.sh --test`), or unset \
         VKPATH_VALIDATION."
    )]
    ValidationUnavailable,
    #[error(
        "the Vulkan device was lost during {0} (a driver crash or a GPU reset, often a dispatch that ran \
         too long for the watchdog). Try a shorter --dispatch-ms (smaller tiles), fewer samples per \
         pass or a smaller image."
    )]
    DeviceLost(&'static str),
    #[error("the Vulkan device ran out of memory during {0}. Try a smaller image or scene.")]
    OutOfMemory(&'static str),
    #[error(
        "Vulkan call {0} failed: {1}. This is likely a driver problem; try another device (VKPATH_DEVICE)."
    )]
    Vulkan(&'static str, vk::Result),
    #[error("GPU memory allocation failed: {0}. Try a smaller image or scene.")]
    Alloc(String),
    #[error(
        "the WGSL shader failed to compile: {0}. This is a bug in vkpath's shaders; please report it."
    )]
    Shader(String),
    /// The scene or image exceeds what this device can do (the message names the limit).
    #[error("{0}")]
    Limit(String),
    /// A misuse of the GPU layer's API (a bug in the caller).
    #[error("{0}")]
    Usage(String),
}

impl From<crate::kernel::KernelError> for GpuError {
    fn from(e: crate::kernel::KernelError) -> GpuError {
        match e {
            crate::kernel::KernelError::Shader(m) => GpuError::Shader(m),
        }
    }
}

impl GpuError {
    pub(crate) fn vk(what: &'static str, r: vk::Result) -> GpuError {
        match r {
            vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(what),
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                GpuError::OutOfMemory(what)
            }
            other => GpuError::Vulkan(what, other),
        }
    }
}
