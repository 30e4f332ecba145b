//! Buffers: host-visible ones for uploads and readback, device-local ones for the accumulator.

use super::{GpuContext, GpuError};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use std::sync::Arc;

/// A Vulkan buffer with its memory. Freed on drop.
pub struct Buffer {
    ctx: Arc<GpuContext>,
    pub(crate) raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
}

impl Buffer {
    /// A buffer of `size` bytes (at least 4: Vulkan forbids empty buffers, so empty arrays get a dummy).
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer, GpuError> {
        let size = size.max(16);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let device = &ctx.device;
        // SAFETY: valid create info; the buffer is destroyed in Drop or below on failure.
        let raw = unsafe { device.create_buffer(&info, None) }
            .map_err(|e| GpuError::vk("vkCreateBuffer", e))?;
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = {
            let mut guard = ctx.allocator();
            let Some(allocator) = guard.as_mut() else {
                unsafe { device.destroy_buffer(raw, None) };
                return Err(GpuError::Alloc("the allocator is gone".into()));
            };
            allocator.allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
        };
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_buffer(raw, None) };
                return Err(GpuError::Alloc(format!("{name} ({size} bytes): {e}")));
            }
        };
        if let Err(e) =
            unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
        {
            if let Some(a) = ctx.allocator().as_mut() {
                let _ = a.free(allocation);
            }
            unsafe { device.destroy_buffer(raw, None) };
            return Err(GpuError::vk("vkBindBufferMemory", e));
        }
        Ok(Buffer {
            ctx: ctx.clone(),
            raw,
            allocation: Some(allocation),
            size,
        })
    }

    /// A host-visible storage buffer holding `data` (uploaded now).
    pub fn storage_from<T: bytemuck::Pod>(
        ctx: &Arc<GpuContext>,
        name: &str,
        data: &[T],
    ) -> Result<Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut b = Buffer::new(
            ctx,
            name,
            bytes.len() as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        b.write(bytes)?;
        Ok(b)
    }

    /// A host-visible storage buffer of `size` bytes (at least `data`'s) holding `data` at its start and
    /// zeros after it: the source of a copy into a padded buffer or a data image, written once, without a
    /// padded copy of `data` on the host.
    pub fn zero_padded(
        ctx: &Arc<GpuContext>,
        name: &str,
        data: &[u8],
        size: usize,
    ) -> Result<Buffer, GpuError> {
        let mut b = Buffer::new(
            ctx,
            name,
            size as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        b.write(data)?;
        let slice = b
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| GpuError::Usage("write to a buffer that is not host-visible".into()))?;
        slice[data.len()..].fill(0);
        Ok(b)
    }

    /// A host-visible uniform buffer holding `value`.
    pub fn uniform_from<T: bytemuck::Pod>(
        ctx: &Arc<GpuContext>,
        name: &str,
        value: &T,
    ) -> Result<Buffer, GpuError> {
        let mut b = Buffer::new(
            ctx,
            name,
            std::mem::size_of::<T>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        b.write(bytemuck::bytes_of(value))?;
        Ok(b)
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// Copies `bytes` to the start of a host-visible buffer.
    pub fn write(&mut self, bytes: &[u8]) -> Result<(), GpuError> {
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| GpuError::Usage("write to a buffer that is not host-visible".into()))?;
        if bytes.len() > slice.len() {
            return Err(GpuError::Usage(format!(
                "write of {} bytes into a buffer of {}",
                bytes.len(),
                slice.len()
            )));
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// The contents of a host-visible buffer (call after the GPU work writing it has completed).
    pub fn read_bytes(&self) -> Result<&[u8], GpuError> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| &s[..self.size as usize])
            .ok_or_else(|| GpuError::Usage("read of a buffer that is not host-visible".into()))
    }
}

impl Buffer {
    /// A device-local storage buffer the kernel reads and writes and the host fills and reads through
    /// copies (the accumulator strips).
    pub fn device_storage(
        ctx: &Arc<GpuContext>,
        name: &str,
        bytes: u64,
    ) -> Result<Buffer, GpuError> {
        Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )
    }

    /// A host-visible buffer that copies go to and come from (readback and restore).
    pub fn staging(ctx: &Arc<GpuContext>, name: &str, bytes: u64) -> Result<Buffer, GpuError> {
        Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuToCpu,
        )
    }

    /// A device-local uniform buffer updated by copies recorded in the command buffer.
    pub fn device_uniform(
        ctx: &Arc<GpuContext>,
        name: &str,
        bytes: u64,
    ) -> Result<Buffer, GpuError> {
        Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )
    }

    /// A host-visible storage buffer the host writes and the kernel reads (adaptive sampling's list of
    /// pixels): small, rewritten now and then, read once per invocation, so not worth a staging copy.
    pub fn host_storage(ctx: &Arc<GpuContext>, name: &str, bytes: u64) -> Result<Buffer, GpuError> {
        Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )
    }

    /// A small host-visible storage buffer the kernel writes and the host reads directly (test outputs,
    /// counters), zero-filled.
    pub fn readable_storage(
        ctx: &Arc<GpuContext>,
        name: &str,
        bytes: u64,
    ) -> Result<Buffer, GpuError> {
        let mut b = Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        b.write(&vec![0u8; b.size() as usize])?;
        Ok(b)
    }
}

/// A device-local storage buffer holding `data`, filled through a host-visible staging buffer and a copy
/// recorded on `kernel` (the scene's big read-only arrays: on a discrete GPU, host-visible memory would be
/// read across the bus on every access). Refuses an array larger than the device's storage-buffer range.
pub fn upload_device_local<T: bytemuck::Pod>(
    ctx: &Arc<GpuContext>,
    kernel: &mut super::Kernel,
    name: &str,
    data: &[T],
) -> Result<Buffer, GpuError> {
    let bytes = std::mem::size_of_val(data) as u64;
    let range = u64::from(ctx.device_info().max_storage_buffer_range);
    if bytes > range {
        return Err(GpuError::Limit(format!(
            "the scene's {name} take {bytes} bytes, more than the {range} bytes one storage buffer may \
             hold on {}. Use a smaller mesh, or a device with a larger maxStorageBufferRange.",
            ctx.device_info().name
        )));
    }
    let data: &[u8] = bytemuck::cast_slice(data);
    device_local_copy(
        ctx,
        kernel,
        name,
        data,
        data.len(),
        vk::BufferUsageFlags::STORAGE_BUFFER,
    )
}

/// A new device-local buffer of `size` bytes for `usage` holding `data` and zeros after it, copied from a
/// host-visible staging buffer by a copy recorded on `kernel`.
fn device_local_copy(
    ctx: &Arc<GpuContext>,
    kernel: &mut super::Kernel,
    name: &str,
    data: &[u8],
    size: usize,
    usage: vk::BufferUsageFlags,
) -> Result<Buffer, GpuError> {
    let staging = Buffer::zero_padded(ctx, name, data, size)?;
    let buffer = Buffer::new(
        ctx,
        name,
        size as u64,
        usage | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )?;
    if !data.is_empty() {
        kernel.submit(&[super::Command::Copy(&staging, &buffer)])?;
    }
    Ok(buffer)
}

/// A device-local uniform buffer of exactly `bytes` holding `data` at its start and zeros after it (a
/// small scene array's uniform twin, `kernel::abi::UNIFORM_ARRAYS`: the WGSL declares it with a fixed
/// length, and the buffer covers all of it), filled like [`upload_device_local`].
pub fn upload_uniform_padded(
    ctx: &Arc<GpuContext>,
    kernel: &mut super::Kernel,
    name: &str,
    data: &[u8],
    bytes: usize,
) -> Result<Buffer, GpuError> {
    let range = ctx.device_info().max_uniform_buffer_range as usize;
    if data.len() > bytes || bytes > range {
        return Err(GpuError::Usage(format!(
            "the uniform buffer `{name}` would hold {} bytes in {bytes}, and {} allows {range}",
            data.len(),
            ctx.device_info().name
        )));
    }
    device_local_copy(
        ctx,
        kernel,
        name,
        data,
        bytes,
        vk::BufferUsageFlags::UNIFORM_BUFFER,
    )
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the owner waits for GPU work using this buffer before dropping it.
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take()
            && let Some(alloc) = self.ctx.allocator().as_mut()
        {
            let _ = alloc.free(a);
        }
    }
}
