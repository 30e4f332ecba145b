//! Data images: a read-only scene array stored as the texels of a 2D `rgba32uint` image, 16 bytes a texel,
//! [`DATA_IMAGE_WIDTH`] texels a row, and read by the kernel with `textureLoad` (a `texture_2d<u32>`
//! binding: `kernel::abi::IMAGE_ARRAYS` lists the arrays, scene_data.wgsl reads them).
//!
//! Why an image and not a storage buffer: Mesa 25's lavapipe compiles each storage-buffer read whose
//! index differs between the lanes of its 8-wide SIMD vectors into branches for every lane and word
//! (`emit_load_mem`, gallivm/lp_bld_nir_soa.c), and the compile time of LLVM's coroutine split and register
//! allocator grows faster than the branches; a texel fetch is one call per vector to a fetch function
//! llvmpipe compiles once per format (lp_texture_handle.c). docs/performance.md, "What the first sample
//! waits for", has the measurements.

use super::buffer::Buffer;
use super::{GpuContext, GpuError};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use std::sync::Arc;

/// log2 of a data image's texels per row (4096: 64 KiB a row), the WGSL's DATA_IMAGE_WIDTH_BITS
/// (scene_data.wgsl; `tests/layout.rs` holds the two equal). Defined here rather than in `kernel::abi`,
/// so that the GPU layer imports nothing from the kernel's data model.
pub const DATA_IMAGE_WIDTH_BITS: u32 = 12;

/// Texels per row of a data image. A power of two, so that the kernel finds element i's texel with a
/// mask and a shift.
pub const DATA_IMAGE_WIDTH: u32 = 1 << DATA_IMAGE_WIDTH_BITS;

/// Bytes of one texel (`rgba32uint`).
pub const DATA_TEXEL_BYTES: usize = 16;

/// The image format of every data image.
const FORMAT: vk::Format = vk::Format::R32G32B32A32_UINT;

/// A device-local 2D image holding a byte array, with its view. Freed on drop.
pub struct DataImage {
    ctx: Arc<GpuContext>,
    pub(crate) raw: vk::Image,
    pub(crate) view: vk::ImageView,
    allocation: Option<Allocation>,
    rows: u32,
}

/// The rows a data image of `bytes` needs: room for one texel past the data (an element that ends
/// inside a texel may be read with the texel after it: a mesh vertex, scene_data.wgsl), so at least one.
pub fn data_image_rows(bytes: usize) -> u64 {
    let texels = bytes.div_ceil(DATA_TEXEL_BYTES) as u64 + 1;
    texels.div_ceil(u64::from(DATA_IMAGE_WIDTH)).max(1)
}

/// Whether `bytes` fit one data image on a device whose 2D images have at most `max_dimension` rows.
pub fn data_image_fits(bytes: usize, max_dimension: u32) -> bool {
    DATA_IMAGE_WIDTH <= max_dimension && data_image_rows(bytes) <= u64::from(max_dimension)
}

impl DataImage {
    /// A data image holding `data` (zero-padded to whole rows), copied from a staging buffer by a command
    /// recorded on `kernel`; the image is then in SHADER_READ_ONLY_OPTIMAL layout.
    pub fn upload(
        ctx: &Arc<GpuContext>,
        kernel: &mut super::Kernel,
        name: &str,
        data: &[u8],
    ) -> Result<DataImage, GpuError> {
        let max = ctx.device_info().max_image_dimension_2d;
        if !data_image_fits(data.len(), max) {
            return Err(GpuError::Limit(format!(
                "the scene's {name} take {} bytes, more than one {DATA_IMAGE_WIDTH}-wide image of at most \
                 {max} rows holds on {}. Use a smaller scene.",
                data.len(),
                ctx.device_info().name
            )));
        }
        let rows = data_image_rows(data.len()) as u32;
        let bytes = rows as usize * DATA_IMAGE_WIDTH as usize * DATA_TEXEL_BYTES;
        let staging = Buffer::zero_padded(ctx, name, data, bytes)?;
        let mut image = DataImage {
            ctx: ctx.clone(),
            raw: vk::Image::null(),
            view: vk::ImageView::null(),
            allocation: None,
            rows,
        };
        image.create(name)?;
        kernel.submit(&[super::Command::CopyToImage(&staging, &image)])?;
        Ok(image)
    }

    /// Creates the image, its memory and its view into `self` (Drop frees whatever was made).
    fn create(&mut self, name: &str) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(FORMAT)
            .extent(vk::Extent3D {
                width: DATA_IMAGE_WIDTH,
                height: self.rows,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY (whole block): valid create infos; every handle made is destroyed in Drop.
        unsafe {
            self.raw = device
                .create_image(&info, None)
                .map_err(|e| GpuError::vk("vkCreateImage", e))?;
            let requirements = device.get_image_memory_requirements(self.raw);
            let allocation = {
                let mut guard = self.ctx.allocator();
                let Some(allocator) = guard.as_mut() else {
                    return Err(GpuError::Alloc("the allocator is gone".into()));
                };
                allocator
                    .allocate(&AllocationCreateDesc {
                        name,
                        requirements,
                        location: MemoryLocation::GpuOnly,
                        linear: false,
                        allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                    })
                    .map_err(|e| GpuError::Alloc(format!("{name} (image): {e}")))?
            };
            let (memory, offset) = (allocation.memory(), allocation.offset());
            self.allocation = Some(allocation);
            device
                .bind_image_memory(self.raw, memory, offset)
                .map_err(|e| GpuError::vk("vkBindImageMemory", e))?;
            self.view = device
                .create_image_view(
                    &vk::ImageViewCreateInfo::default()
                        .image(self.raw)
                        .view_type(vk::ImageViewType::TYPE_2D)
                        .format(FORMAT)
                        .subresource_range(Self::range()),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateImageView", e))?;
        }
        Ok(())
    }

    /// The whole image: one mip level, one layer.
    pub(crate) fn range() -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        }
    }

    /// Rows of texels.
    pub fn rows(&self) -> u32 {
        self.rows
    }
}

impl Drop for DataImage {
    fn drop(&mut self) {
        // SAFETY: the owner waits for GPU work using this image before dropping it; null handles are
        // ignored.
        unsafe {
            self.ctx.device.destroy_image_view(self.view, None);
            self.ctx.device.destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take()
            && let Some(alloc) = self.ctx.allocator().as_mut()
        {
            let _ = alloc.free(a);
        }
    }
}
