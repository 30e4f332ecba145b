//! Showing 8-bit images in a window (feature `preview`): the window's surface, a swapchain, and a
//! present that uploads an RGBA8 image (already display-encoded by [`crate::Film::to_rgb8`]) and blits
//! it into the next swapchain image, scaled to fit the window with its aspect ratio kept.
//!
//! The bytes are shown as they are: the swapchain is a UNORM format when the surface offers one, so
//! that nothing encodes them a second time; if it only offers sRGB formats, the uploaded image is sRGB
//! too and the blit decodes and re-encodes (an identity up to rounding).
//!
//! One present in flight: each present waits for the previous one's fence before it reuses the command
//! buffer and the staging buffer. The queue is shared with the renderer (through the context's queue
//! mutex, held only while submitting), so a present waits at most for the compute submit ahead of it.

use super::{Buffer, GpuContext, GpuError};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};
use std::ffi::c_char;
use std::sync::Arc;

/// The raw handles of a window (from winit), for [`super::ContextOptions::window`].
#[derive(Clone, Copy, Debug)]
pub struct WindowHandles {
    pub display: RawDisplayHandle,
    pub window: RawWindowHandle,
}

/// The instance extensions a surface on this display needs (`VK_KHR_surface` and the platform's).
pub(crate) fn instance_extensions(w: &WindowHandles) -> Result<Vec<*const c_char>, GpuError> {
    ash_window::enumerate_required_extensions(w.display)
        .map(|e| e.to_vec())
        .map_err(|e| GpuError::vk("ash_window::enumerate_required_extensions", e))
}

/// A window's `VkSurfaceKHR` with its loader. Owned by the context, destroyed before the instance.
pub(crate) struct Surface {
    loader: ash::khr::surface::Instance,
    raw: vk::SurfaceKHR,
}

impl Surface {
    pub(crate) fn new(
        entry: &ash::Entry,
        instance: &ash::Instance,
        w: &WindowHandles,
    ) -> Result<Surface, GpuError> {
        // SAFETY: the handles come from a live window that outlives the context (ContextOptions::window).
        let raw = unsafe { ash_window::create_surface(entry, instance, w.display, w.window, None) }
            .map_err(|e| GpuError::vk("vkCreate*SurfaceKHR", e))?;
        Ok(Surface {
            loader: ash::khr::surface::Instance::new(entry, instance),
            raw,
        })
    }

    /// A queue family of `pd` that has compute and can present to this surface.
    pub(crate) fn compute_present_family(
        &self,
        pd: vk::PhysicalDevice,
        families: &[vk::QueueFamilyProperties],
    ) -> Option<u32> {
        (0..families.len() as u32).find(|&i| {
            families[i as usize]
                .queue_flags
                .contains(vk::QueueFlags::COMPUTE)
                // SAFETY: pd and the surface belong to the same instance.
                && unsafe {
                    self.loader
                        .get_physical_device_surface_support(pd, i, self.raw)
                }
                .unwrap_or(false)
        })
    }

    pub(crate) fn destroy(&self) {
        // SAFETY: called once, after every swapchain of this surface is destroyed.
        unsafe { self.loader.destroy_surface(self.raw, None) };
    }
}

/// The image being shown, at its own size, in device memory: the blit's source.
struct Source {
    image: vk::Image,
    allocation: Option<Allocation>,
    size: [u32; 2],
    /// False until the first upload has moved it out of `UNDEFINED`.
    initialised: bool,
}

/// A swapchain on the context's surface and what it takes to show an image in it.
pub struct Presenter {
    ctx: Arc<GpuContext>,
    loader: ash::khr::swapchain::Device,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    format: vk::Format,
    extent: vk::Extent2D,
    /// Signalled by acquire, waited by the copy. One suffices: the previous copy waited on it and
    /// completed (its fence) before the next acquire.
    acquired: vk::Semaphore,
    /// One per swapchain image: signalled by the copy, waited by the present of that image (a present
    /// may still hold its semaphore when another image is acquired).
    copied: Vec<vk::Semaphore>,
    pool: vk::CommandPool,
    cb: vk::CommandBuffer,
    /// Signalled when the last present's copy is done (created signalled).
    fence: vk::Fence,
    source: Option<Source>,
    staging: Option<Buffer>,
    /// The staging buffer holds an image not yet copied into the source.
    pending_upload: bool,
    /// The window's size in pixels; (0, 0) while minimised.
    window_size: [u32; 2],
    /// Set on resize or when the swapchain is out of date / suboptimal.
    stale: bool,
    /// Whether the swapchain images can be copied from (then [`Presenter::request_capture`] works).
    can_capture: bool,
    /// Set by [`Presenter::request_capture`]: the next present also copies what it shows here.
    capture: Option<Buffer>,
    /// Where in the captured swapchain image the image was blitted, and the swapchain's size and
    /// format then; set when the copy is recorded.
    captured: Option<([u32; 4], vk::Extent2D, vk::Format)>,
}

/// The pixels a present put in the window, read back from the swapchain image: the part the image
/// was fitted into, as 8-bit RGB, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// What one [`Presenter::present`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presented {
    Shown,
    /// Nothing to show into (minimised window, swapchain out of date): try again later.
    Skipped,
}

impl Presenter {
    /// A presenter for a window of `window_size` pixels. The context must have been created with
    /// [`super::ContextOptions::window`].
    pub fn new(ctx: &Arc<GpuContext>, window_size: [u32; 2]) -> Result<Presenter, GpuError> {
        if ctx.surface.is_none() {
            return Err(GpuError::Usage(
                "a Presenter needs a context created with a window".into(),
            ));
        }
        let device = &ctx.device;
        let loader = ash::khr::swapchain::Device::new(&ctx.instance, device);
        // Create everything with null handles first so that Drop cleans up whatever a failure leaves.
        let mut p = Presenter {
            ctx: ctx.clone(),
            loader,
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            acquired: vk::Semaphore::null(),
            copied: Vec::new(),
            pool: vk::CommandPool::null(),
            cb: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            source: None,
            staging: None,
            pending_upload: false,
            window_size,
            stale: true,
            can_capture: false,
            capture: None,
            captured: None,
        };
        // SAFETY: plain object creation on a valid device.
        unsafe {
            p.acquired = device
                .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                .map_err(|e| GpuError::vk("vkCreateSemaphore", e))?;
            p.fence = device
                .create_fence(
                    &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateFence", e))?;
        }
        // Re-recorded for every present (see `record`).
        (p.pool, p.cb) = ctx.create_command_buffer()?;
        p.rebuild()?;
        Ok(p)
    }

    /// The window was resized: the swapchain is rebuilt before the next present.
    pub fn resize(&mut self, window_size: [u32; 2]) {
        if window_size != self.window_size {
            self.window_size = window_size;
            self.stale = true;
        }
    }

    /// The swapchain's size in pixels.
    pub fn extent(&self) -> [u32; 2] {
        [self.extent.width, self.extent.height]
    }

    /// Asks the next present that shows something to also copy the swapchain image back, for
    /// [`Presenter::take_capture`]. Returns false (and does nothing) when the swapchain images cannot
    /// be copied from on this device.
    pub fn request_capture(&mut self) -> Result<bool, GpuError> {
        if !self.can_capture {
            return Ok(false);
        }
        let bytes = u64::from(self.extent.width) * u64::from(self.extent.height) * 4;
        // Sized for the current swapchain; a resize before the present re-requests in record().
        self.capture = Some(Buffer::new(
            &self.ctx,
            "preview capture",
            bytes.max(4),
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?);
        self.captured = None;
        Ok(true)
    }

    /// The pixels the captured present showed, where the image was: waits for that present's copy.
    /// `None` if no capture was requested or none was recorded yet.
    pub fn take_capture(&mut self) -> Result<Option<Capture>, GpuError> {
        let Some(([x0, y0, x1, y1], extent, format)) = self.captured else {
            return Ok(None);
        };
        // SAFETY: the fence of the present that recorded the copy.
        unsafe {
            self.ctx
                .device
                .wait_for_fences(&[self.fence], true, u64::MAX)
        }
        .map_err(|e| GpuError::vk("vkWaitForFences", e))?;
        let Some(buffer) = self.capture.take() else {
            return Ok(None);
        };
        self.captured = None;
        let bytes = buffer.read_bytes()?;
        let bgr = matches!(
            format,
            vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
        );
        let row = extent.width as usize * 4;
        let mut rgb = Vec::with_capacity((x1 - x0) as usize * (y1 - y0) as usize * 3);
        for y in y0..y1 {
            for x in x0..x1 {
                let i = y as usize * row + x as usize * 4;
                let p = bytes.get(i..i + 4).ok_or_else(|| {
                    GpuError::Usage("the capture buffer is smaller than the swapchain".into())
                })?;
                if bgr {
                    rgb.extend([p[2], p[1], p[0]]);
                } else {
                    rgb.extend([p[0], p[1], p[2]]);
                }
            }
        }
        Ok(Some(Capture {
            width: x1 - x0,
            height: y1 - y0,
            rgb,
        }))
    }

    fn surface(&self) -> Result<&Surface, GpuError> {
        self.ctx
            .surface
            .as_ref()
            .ok_or_else(|| GpuError::Usage("the context has no surface".into()))
    }

    /// Waits until the queue has finished everything submitted (the renderer's work included).
    fn wait_queue_idle(&self) -> Result<(), GpuError> {
        let queue = self.ctx.queue.lock().unwrap_or_else(|p| p.into_inner());
        // SAFETY: the queue is externally synchronised by its mutex.
        unsafe { self.ctx.device.queue_wait_idle(*queue) }
            .map_err(|e| GpuError::vk("vkQueueWaitIdle", e))
    }

    /// (Re)creates the swapchain for the current window size. Leaves `stale` set when the window has
    /// no area (minimised): nothing can be shown then.
    fn rebuild(&mut self) -> Result<(), GpuError> {
        let surface = self.surface()?;
        let pd = self.ctx.physical_device;
        // SAFETY: queries on a valid surface and physical device.
        let (caps, formats, modes) = unsafe {
            (
                surface
                    .loader
                    .get_physical_device_surface_capabilities(pd, surface.raw)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR", e))?,
                surface
                    .loader
                    .get_physical_device_surface_formats(pd, surface.raw)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfaceFormatsKHR", e))?,
                surface
                    .loader
                    .get_physical_device_surface_present_modes(pd, surface.raw)
                    .map_err(|e| GpuError::vk("vkGetPhysicalDeviceSurfacePresentModesKHR", e))?,
            )
        };
        // u32::MAX means "the swapchain decides": then the window's size, within the limits.
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: self.window_size[0].clamp(
                    caps.min_image_extent.width,
                    caps.max_image_extent.width.max(1),
                ),
                height: self.window_size[1].clamp(
                    caps.min_image_extent.height,
                    caps.max_image_extent.height.max(1),
                ),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            self.stale = true;
            return Ok(());
        }
        if !caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_DST)
        {
            return Err(GpuError::Limit(format!(
                "the window's swapchain on {} cannot be a transfer destination, which the preview needs. \
                 Use `vkpath render` instead, or another device (VKPATH_DEVICE).",
                self.ctx.device_info().name
            )));
        }
        let format = choose_format(&formats).ok_or_else(|| {
            GpuError::Limit(format!(
                "the window offers no 8-bit RGBA/BGRA format on {}. Use `vkpath render` instead.",
                self.ctx.device_info().name
            ))
        })?;
        // Mailbox never blocks the present on the display; FIFO is always there. The preview paces
        // its presents itself.
        let mode = if modes.contains(&vk::PresentModeKHR::MAILBOX) {
            vk::PresentModeKHR::MAILBOX
        } else {
            vk::PresentModeKHR::FIFO
        };
        // Copying from the swapchain is only for --screenshot (what the window shows, read back).
        let can_capture = caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_SRC);
        let usage = if can_capture {
            vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC
        } else {
            vk::ImageUsageFlags::TRANSFER_DST
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let old = self.swapchain;
        if old != vk::SwapchainKHR::null() {
            // The old swapchain's images may still be read by a present in flight.
            self.wait_queue_idle()?;
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(surface.raw)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(choose_alpha(caps.supported_composite_alpha))
            .present_mode(mode)
            .clipped(true)
            .old_swapchain(old);
        // SAFETY: valid create info; the old swapchain is retired here and destroyed just below.
        let swapchain = unsafe { self.loader.create_swapchain(&info, None) }
            .map_err(|e| GpuError::vk("vkCreateSwapchainKHR", e))?;
        if old != vk::SwapchainKHR::null() {
            unsafe { self.loader.destroy_swapchain(old, None) };
        }
        self.swapchain = swapchain;
        self.images = unsafe { self.loader.get_swapchain_images(swapchain) }
            .map_err(|e| GpuError::vk("vkGetSwapchainImagesKHR", e))?;
        while self.copied.len() < self.images.len() {
            let s = unsafe {
                self.ctx
                    .device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
            }
            .map_err(|e| GpuError::vk("vkCreateSemaphore", e))?;
            self.copied.push(s);
        }
        self.format = format.format;
        self.extent = extent;
        self.can_capture = can_capture;
        self.stale = false;
        Ok(())
    }

    /// Shows an image: `rgba` (when given) is a new one of `size` pixels, 4 bytes each, top row first,
    /// to upload; `None` shows the last one again (after a resize, or to keep presenting while the
    /// renderer works). Before any image was given, the window is cleared to black.
    pub fn present(&mut self, rgba: Option<(&[u8], [u32; 2])>) -> Result<Presented, GpuError> {
        let device = self.ctx.device.clone();
        // SAFETY: the fence belongs to this device; waiting on it makes the command buffer, the staging
        // buffer and the source image free to reuse.
        unsafe { device.wait_for_fences(&[self.fence], true, u64::MAX) }
            .map_err(|e| GpuError::vk("vkWaitForFences", e))?;
        if let Some((bytes, size)) = rgba {
            self.stage(bytes, size)?;
        }
        if self.stale {
            self.rebuild()?;
            if self.stale {
                return Ok(Presented::Skipped);
            }
        }
        // SAFETY: the swapchain is valid; `acquired` is unsignalled (its last wait has completed).
        let acquired = unsafe {
            self.loader.acquire_next_image(
                self.swapchain,
                1_000_000_000,
                self.acquired,
                vk::Fence::null(),
            )
        };
        let index = match acquired {
            Ok((i, suboptimal)) => {
                self.stale |= suboptimal;
                i
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                return Ok(Presented::Skipped);
            }
            Err(vk::Result::TIMEOUT) | Err(vk::Result::NOT_READY) => {
                return Ok(Presented::Skipped);
            }
            Err(e) => return Err(GpuError::vk("vkAcquireNextImageKHR", e)),
        };
        let target = self.images[index as usize];
        let copied = self.copied[index as usize];
        self.record(target)?;
        let wait = [self.acquired];
        let stages = [vk::PipelineStageFlags::TRANSFER];
        let cbs = [self.cb];
        let signal = [copied];
        let submit = vk::SubmitInfo::default()
            .wait_semaphores(&wait)
            .wait_dst_stage_mask(&stages)
            .command_buffers(&cbs)
            .signal_semaphores(&signal);
        let swapchains = [self.swapchain];
        let indices = [index];
        let present = vk::PresentInfoKHR::default()
            .wait_semaphores(&signal)
            .swapchains(&swapchains)
            .image_indices(&indices);
        let presented = {
            let queue = self.ctx.queue.lock().unwrap_or_else(|p| p.into_inner());
            // SAFETY: the command buffer is recorded, the fence unsignalled; the queue is locked.
            unsafe {
                device
                    .reset_fences(&[self.fence])
                    .map_err(|e| GpuError::vk("vkResetFences", e))?;
                device
                    .queue_submit(*queue, &[submit], self.fence)
                    .map_err(|e| GpuError::vk("vkQueueSubmit", e))?;
                self.loader.queue_present(*queue, &present)
            }
        };
        match presented {
            Ok(suboptimal) => self.stale |= suboptimal,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => self.stale = true,
            Err(e) => return Err(GpuError::vk("vkQueuePresentKHR", e)),
        }
        Ok(Presented::Shown)
    }

    /// Copies a new image into the staging buffer, (re)creating it and the source image when the size
    /// changes. The previous present has completed (its fence).
    fn stage(&mut self, bytes: &[u8], size: [u32; 2]) -> Result<(), GpuError> {
        let needed = u64::from(size[0]) * u64::from(size[1]) * 4;
        if bytes.len() as u64 != needed || needed == 0 {
            return Err(GpuError::Usage(format!(
                "present of {} bytes for a {}x{} RGBA image",
                bytes.len(),
                size[0],
                size[1]
            )));
        }
        if self.source.as_ref().map(|s| s.size) != Some(size) {
            self.free_source();
            self.source = Some(self.create_source(size)?);
            self.staging = Some(Buffer::new(
                &self.ctx,
                "preview staging",
                needed,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        match &mut self.staging {
            Some(b) => b.write(bytes)?,
            None => return Err(GpuError::Usage("no preview staging buffer".into())),
        }
        self.pending_upload = true;
        Ok(())
    }

    fn create_source(&self, size: [u32; 2]) -> Result<Source, GpuError> {
        let device = &self.ctx.device;
        // The source has the swapchain's sRGB-ness (see the module comment): the bytes are then shown
        // unchanged.
        let format = if is_srgb(self.format) {
            vk::Format::R8G8B8A8_SRGB
        } else {
            vk::Format::R8G8B8A8_UNORM
        };
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: size[0],
                height: size[1],
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info; destroyed in free_source or on the failures below.
        let image = unsafe { device.create_image(&info, None) }
            .map_err(|e| GpuError::vk("vkCreateImage", e))?;
        let requirements = unsafe { device.get_image_memory_requirements(image) };
        let allocation = self
            .ctx
            .allocator()
            .as_mut()
            .ok_or_else(|| GpuError::Alloc("the allocator is gone".into()))
            .and_then(|a| {
                a.allocate(&AllocationCreateDesc {
                    name: "preview image",
                    requirements,
                    location: MemoryLocation::GpuOnly,
                    linear: false,
                    allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                })
                .map_err(|e| GpuError::Alloc(format!("preview image: {e}")))
            });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_image(image, None) };
                return Err(e);
            }
        };
        let mut source = Source {
            image,
            allocation: Some(allocation),
            size,
            initialised: false,
        };
        let bound = source
            .allocation
            .as_ref()
            .map(|a| unsafe { device.bind_image_memory(image, a.memory(), a.offset()) });
        if let Some(Err(e)) = bound {
            self.destroy_source(&mut source);
            return Err(GpuError::vk("vkBindImageMemory", e));
        }
        Ok(source)
    }

    fn destroy_source(&self, s: &mut Source) {
        // SAFETY: no work using the image is in flight (callers wait for the fence or the queue).
        unsafe { self.ctx.device.destroy_image(s.image, None) };
        if let Some(a) = s.allocation.take()
            && let Some(alloc) = self.ctx.allocator().as_mut()
        {
            let _ = alloc.free(a);
        }
    }

    fn free_source(&mut self) {
        if let Some(mut s) = self.source.take() {
            self.destroy_source(&mut s);
        }
    }

    /// Records one present into `self.cb`: upload the staged image (if one is pending), clear the
    /// swapchain image `target`, blit the source into it (fitted, aspect kept), optionally read it back,
    /// and hand it to the presentation engine. Every step but the last runs in the transfer stage, in
    /// this order; each leaves `target` in the layout the next one expects.
    fn record(&mut self, target: vk::Image) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        let cb = self.cb;
        // SAFETY: the command buffer is idle (the caller waited for the fence); every handle is alive.
        unsafe {
            device
                .reset_command_buffer(cb, vk::CommandBufferResetFlags::empty())
                .map_err(|e| GpuError::vk("vkResetCommandBuffer", e))?;
            device
                .begin_command_buffer(
                    cb,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(|e| GpuError::vk("vkBeginCommandBuffer", e))?;
        }
        // SAFETY: `cb` is recording (begun above, ended below) and `target` is an image of the current
        // swapchain; the source, staging and capture resources are alive and idle (fence waited).
        unsafe {
            self.record_upload();
            self.record_clear_and_blit(target);
            let layout = self.record_capture(target);
            self.record_present_transition(target, layout);
        }
        // SAFETY: `cb` is recording.
        unsafe { self.ctx.device.end_command_buffer(cb) }
            .map_err(|e| GpuError::vk("vkEndCommandBuffer", e))
    }

    /// Records the copy of the staged 8-bit image into the source image, when one is pending (a new
    /// image was given to [`Presenter::present`]); otherwise records nothing and the source keeps the
    /// last image. Leaves the source in `TRANSFER_SRC_OPTIMAL`, ready to be blitted, and marks it
    /// initialised.
    ///
    /// # Safety
    /// `self.cb` is recording (called from [`Presenter::record`] only); the staging buffer and source
    /// image are alive and no earlier work on them is still running.
    unsafe fn record_upload(&mut self) {
        let device = &self.ctx.device;
        let cb = self.cb;
        let transfer = vk::PipelineStageFlags::TRANSFER;
        let (true, Some(src), Some(staging)) =
            (self.pending_upload, &mut self.source, &self.staging)
        else {
            return;
        };
        // The first upload finds the image UNDEFINED; later ones find it where the last blit read it.
        // Either way its old content is overwritten whole, and the copy's writes wait for the previous
        // blit's reads (write after read).
        let from = if src.initialised {
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL
        } else {
            vk::ImageLayout::UNDEFINED
        };
        // SAFETY: see the function's contract; the copy covers the whole image, which the staging
        // buffer holds (both sized by `stage`).
        unsafe {
            image_barrier(
                device,
                cb,
                color_barrier(
                    src.image,
                    from,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::TRANSFER_READ,
                    vk::AccessFlags::TRANSFER_WRITE,
                ),
                transfer,
                transfer,
            );
            device.cmd_copy_buffer_to_image(
                cb,
                staging.raw,
                src.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[vk::BufferImageCopy::default()
                    .image_subresource(COLOR_LAYERS)
                    .image_extent(vk::Extent3D {
                        width: src.size[0],
                        height: src.size[1],
                        depth: 1,
                    })],
            );
            // The copy's writes are made visible to the blit's reads, in the layout the blit reads.
            image_barrier(
                device,
                cb,
                color_barrier(
                    src.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::TRANSFER_READ,
                ),
                transfer,
                transfer,
            );
        }
        src.initialised = true;
        self.pending_upload = false;
    }

    /// Records the clear of the swapchain image `target` to opaque black (the bars around a fitted
    /// image, or the whole window before any image was given), then, once the source holds an image,
    /// its blit into the rectangle [`fit`] gives for the swapchain's size. Leaves `target` in
    /// `TRANSFER_DST_OPTIMAL`.
    ///
    /// # Safety
    /// `self.cb` is recording (called from [`Presenter::record`] only, after
    /// [`Presenter::record_upload`]); `target` is an image of the current swapchain.
    unsafe fn record_clear_and_blit(&self, target: vk::Image) {
        let device = &self.ctx.device;
        let cb = self.cb;
        let transfer = vk::PipelineStageFlags::TRANSFER;
        // SAFETY: see the function's contract.
        unsafe {
            // The swapchain image: its old content is not needed (from UNDEFINED). The acquire semaphore
            // is waited at the transfer stage, which this barrier's source stage chains to.
            image_barrier(
                device,
                cb,
                color_barrier(
                    target,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::TRANSFER_WRITE,
                ),
                transfer,
                transfer,
            );
            device.cmd_clear_color_image(
                cb,
                target,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearColorValue {
                    float32: [0.0, 0.0, 0.0, 1.0],
                },
                &[COLOR_RANGE],
            );
            let Some(src) = self.source.as_ref().filter(|s| s.initialised) else {
                return;
            };
            // Write after write on the same image: the clear, then the blit over part of it.
            image_barrier(
                device,
                cb,
                color_barrier(
                    target,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::TRANSFER_WRITE,
                ),
                transfer,
                transfer,
            );
            let [x0, y0, x1, y1] = fit(src.size, [self.extent.width, self.extent.height]);
            let corner = |x: u32, y: u32, z: i32| vk::Offset3D {
                x: x as i32,
                y: y as i32,
                z,
            };
            // Offsets are corners: z from 0 to 1 is the single layer of a 2D image.
            let region = vk::ImageBlit::default()
                .src_subresource(COLOR_LAYERS)
                .src_offsets([corner(0, 0, 0), corner(src.size[0], src.size[1], 1)])
                .dst_subresource(COLOR_LAYERS)
                .dst_offsets([corner(x0, y0, 0), corner(x1, y1, 1)]);
            // Nearest: at 1:1 (the usual case) it copies the bytes exactly, and it needs no
            // filterable format.
            device.cmd_blit_image(
                cb,
                src.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                target,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
                vk::Filter::NEAREST,
            );
        }
    }

    /// Records the readback for [`Presenter::request_capture`]: when a capture buffer is waiting, the
    /// source holds an image (so this present shows one) and the buffer still fits the swapchain (it
    /// may have been resized since the request), copies the whole swapchain image into it and notes
    /// where the image was blitted (`self.captured`). Returns the layout `target` is left in:
    /// `TRANSFER_SRC_OPTIMAL` after a copy, else still `TRANSFER_DST_OPTIMAL`.
    ///
    /// # Safety
    /// `self.cb` is recording (called from [`Presenter::record`] only, after
    /// [`Presenter::record_clear_and_blit`]); `target` is an image of the current swapchain, in
    /// `TRANSFER_DST_OPTIMAL`.
    unsafe fn record_capture(&mut self, target: vk::Image) -> vk::ImageLayout {
        let device = &self.ctx.device;
        let cb = self.cb;
        let transfer = vk::PipelineStageFlags::TRANSFER;
        let buffer_bytes = u64::from(self.extent.width) * u64::from(self.extent.height) * 4;
        let shown = self
            .source
            .as_ref()
            .filter(|s| s.initialised)
            .map(|s| fit(s.size, [self.extent.width, self.extent.height]));
        let (Some(buffer), Some(rect)) = (&self.capture, shown) else {
            return vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        };
        if buffer.size() < buffer_bytes {
            return vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        }
        // SAFETY: see the function's contract; the buffer holds the whole image (checked above).
        unsafe {
            // Read back what this present shows: the blit's writes, then a copy to the buffer.
            image_barrier(
                device,
                cb,
                color_barrier(
                    target,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::TRANSFER_READ,
                ),
                transfer,
                transfer,
            );
            device.cmd_copy_image_to_buffer(
                cb,
                target,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[vk::BufferImageCopy::default()
                    .image_subresource(COLOR_LAYERS)
                    .image_extent(vk::Extent3D {
                        width: self.extent.width,
                        height: self.extent.height,
                        depth: 1,
                    })],
            );
            // The copy's writes become visible to the host once the fence signals (take_capture
            // waits for it before reading the buffer).
            device.cmd_pipeline_barrier(
                cb,
                transfer,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ)],
                &[],
                &[],
            );
        }
        self.captured = Some((rect, self.extent, self.format));
        vk::ImageLayout::TRANSFER_SRC_OPTIMAL
    }

    /// Records the final change of `target` from `layout` (where the earlier steps left it) to
    /// `PRESENT_SRC_KHR`, which presentation requires. The transfer writes must be done first; nothing
    /// later in this submit accesses the image (hence `BOTTOM_OF_PIPE` and no destination access), and
    /// the present waits on the `copied` semaphore the submit signals, which makes them visible.
    ///
    /// # Safety
    /// `self.cb` is recording (called from [`Presenter::record`] only, last); `target` is an image of
    /// the current swapchain, in `layout`.
    unsafe fn record_present_transition(&self, target: vk::Image, layout: vk::ImageLayout) {
        // SAFETY: see the function's contract.
        unsafe {
            image_barrier(
                &self.ctx.device,
                self.cb,
                color_barrier(
                    target,
                    layout,
                    vk::ImageLayout::PRESENT_SRC_KHR,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::empty(),
                ),
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            );
        }
    }
}

impl Drop for Presenter {
    fn drop(&mut self) {
        let _ = self.wait_queue_idle();
        self.free_source();
        let d = &self.ctx.device;
        // SAFETY: the queue is idle, so nothing of ours is in flight; null handles are ignored.
        unsafe {
            if self.swapchain != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(self.swapchain, None);
            }
            for &s in &self.copied {
                d.destroy_semaphore(s, None);
            }
            d.destroy_semaphore(self.acquired, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}

/// The one mip level and layer of a color image: all of the source and swapchain images.
const COLOR_RANGE: vk::ImageSubresourceRange = vk::ImageSubresourceRange {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    base_mip_level: 0,
    level_count: 1,
    base_array_layer: 0,
    layer_count: 1,
};

/// [`COLOR_RANGE`] as the layers of a copy or blit region.
const COLOR_LAYERS: vk::ImageSubresourceLayers = vk::ImageSubresourceLayers {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    mip_level: 0,
    base_array_layer: 0,
    layer_count: 1,
};

/// A layout change (`from` to `to`) of the whole color `image`, making the `src` accesses before it
/// available to the `dst` accesses after it. No queue family transfer: one queue does everything.
fn color_barrier(
    image: vk::Image,
    from: vk::ImageLayout,
    to: vk::ImageLayout,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .image(image)
        .old_layout(from)
        .new_layout(to)
        .src_access_mask(src)
        .dst_access_mask(dst)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .subresource_range(COLOR_RANGE)
}

/// Records a pipeline barrier that holds just `barrier` (no memory or buffer barriers, no dependency
/// flags), between the `src_stage` work before it and the `dst_stage` work after it.
///
/// # Safety
/// `cb` is a command buffer of `device` in the recording state, and the barrier's image is alive.
unsafe fn image_barrier(
    device: &ash::Device,
    cb: vk::CommandBuffer,
    barrier: vk::ImageMemoryBarrier,
    src_stage: vk::PipelineStageFlags,
    dst_stage: vk::PipelineStageFlags,
) {
    // SAFETY: see the function's contract.
    unsafe {
        device.cmd_pipeline_barrier(
            cb,
            src_stage,
            dst_stage,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[barrier],
        )
    };
}

fn is_srgb(f: vk::Format) -> bool {
    matches!(f, vk::Format::B8G8R8A8_SRGB | vk::Format::R8G8B8A8_SRGB)
}

/// An 8-bit RGBA/BGRA format, UNORM first (see the module comment).
fn choose_format(formats: &[vk::SurfaceFormatKHR]) -> Option<vk::SurfaceFormatKHR> {
    let preference = [
        vk::Format::B8G8R8A8_UNORM,
        vk::Format::R8G8B8A8_UNORM,
        vk::Format::B8G8R8A8_SRGB,
        vk::Format::R8G8B8A8_SRGB,
    ];
    preference
        .iter()
        .find_map(|want| formats.iter().find(|f| f.format == *want).copied())
}

fn choose_alpha(supported: vk::CompositeAlphaFlagsKHR) -> vk::CompositeAlphaFlagsKHR {
    [
        vk::CompositeAlphaFlagsKHR::OPAQUE,
        vk::CompositeAlphaFlagsKHR::INHERIT,
        vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
        vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
    ]
    .into_iter()
    .find(|a| supported.contains(*a))
    .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE)
}

/// Where an image of `image` pixels goes in a window of `window` pixels: as large as fits with its
/// aspect ratio kept (whole pixels), centred. Returns `[x0, y0, x1, y1]`, the corners (x1, y1 excluded).
pub fn fit(image: [u32; 2], window: [u32; 2]) -> [u32; 4] {
    let [iw, ih] = image.map(u64::from);
    let [ww, wh] = window.map(u64::from);
    if iw == 0 || ih == 0 {
        return [0, 0, 0, 0];
    }
    // Scale s = min(ww / iw, wh / ih), in integers: width-limited when ww * ih <= wh * iw.
    let (w, h) = if ww * ih <= wh * iw {
        (ww, (ih * ww / iw).max(1).min(wh))
    } else {
        ((iw * wh / ih).max(1).min(ww), wh)
    };
    let x0 = (ww - w) / 2;
    let y0 = (wh - h) / 2;
    [x0 as u32, y0 as u32, (x0 + w) as u32, (y0 + h) as u32]
}

#[cfg(test)]
mod tests {
    use super::fit;

    #[test]
    fn fit_keeps_the_aspect_ratio_and_centres() {
        // Same size: 1:1.
        assert_eq!(fit([512, 512], [512, 512]), [0, 0, 512, 512]);
        // Wider window: pillar-boxed.
        assert_eq!(fit([512, 512], [800, 400]), [200, 0, 600, 400]);
        // Taller window: letter-boxed.
        assert_eq!(fit([400, 200], [300, 200]), [0, 25, 300, 175]);
        // Tiny window: never empty.
        assert_eq!(fit([1000, 10], [10, 10]), [0, 4, 10, 5]);
    }
}
