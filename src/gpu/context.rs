//! The Vulkan context: instance (with optional Khronos validation), the chosen physical device, a logical
//! device with one compute queue, a command pool and the memory allocator.

use super::GpuError;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{CStr, c_void};
use std::sync::{Arc, Mutex};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// What `vkpath info` reports for one physical device.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub device_type: String,
    pub api_version: String,
    pub driver_version: u32,
    /// The driver's name and version string (VkPhysicalDeviceDriverProperties), e.g. "llvmpipe: Mesa
    /// 25.0.7 (LLVM 15.0.6)"; empty when the device does not report them.
    pub driver: String,
    /// For Mesa's lavapipe (driver id MESA_LLVMPIPE), the Mesa version [major, minor] from its
    /// driver string; `None` for every other driver.
    pub lavapipe_mesa: Option<[u32; 2]>,
    pub has_compute_queue: bool,
    pub max_compute_workgroup_count: [u32; 3],
    pub max_compute_workgroup_invocations: u32,
    pub max_storage_buffer_range: u32,
    pub max_uniform_buffer_range: u32,
    /// The widest and tallest 2D image (maxImageDimension2D): a data image's rows (`gpu::image`).
    pub max_image_dimension_2d: u32,
    pub max_memory_allocation_size: u64,
    pub device_local_memory_bytes: u64,
    /// The device's UUID (VkPhysicalDeviceIDProperties::deviceUUID, core in Vulkan 1.1): the same
    /// identifier CUDA, HIP and SYCL report for the same GPU, by which the denoiser picks its device.
    pub uuid: [u8; 16],
    /// Whether the device offers `robustBufferAccess`; vkpath enables it wherever it is offered
    /// ([`GpuContext::robust_buffer_access`]).
    pub robust_buffer_access: bool,
}

/// Options for creating a [`GpuContext`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable `VK_LAYER_KHRONOS_validation` and record every message of severity warning or above.
    /// Also enabled by the environment variable `VKPATH_VALIDATION=1`.
    pub validation: bool,
    /// Pick the first device whose name contains this (case-insensitive); also `VKPATH_DEVICE`.
    pub device_substring: Option<String>,
    /// A window to present to (`vkpath preview`): the instance then gets the surface extensions, the
    /// device `VK_KHR_swapchain`, and the queue must be able to both compute and present to it. The
    /// window must outlive the context.
    #[cfg(feature = "preview")]
    pub window: Option<super::present::WindowHandles>,
}

/// Messages the validation layer reported (errors and warnings), shared with the debug callback.
#[derive(Default)]
struct DebugSink {
    errors: Mutex<Vec<String>>,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
        && !user.is_null()
        && !data.is_null()
    {
        // SAFETY: `user` is the DebugSink boxed in GpuContext, alive until the messenger is destroyed;
        // `data` is valid for the duration of the callback.
        let sink = unsafe { &*(user as *const DebugSink) };
        let msg = unsafe { (*data).message_as_c_str() }
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_else(|| "<no message>".into());
        if let Ok(mut errors) = sink.errors.lock() {
            errors.push(msg);
        }
    }
    vk::FALSE
}

/// The device, its queue and allocator. Shared (`Arc`) by buffers and kernels, which must not outlive it.
pub struct GpuContext {
    // Keeps the Vulkan loader library loaded for as long as the instance lives.
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug: Option<(
        ash::ext::debug_utils::Instance,
        vk::DebugUtilsMessengerEXT,
        Box<DebugSink>,
    )>,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    pub(crate) allocator: Mutex<Option<Allocator>>,
    pub(crate) limits: vk::PhysicalDeviceLimits,
    pub(crate) pipeline_cache: vk::PipelineCache,
    /// Compute pipelines by their SPIR-V, made once per context and kept until it drops (see
    /// [`super::kernel::Kernel::new`]).
    pub(crate) pipelines: Mutex<std::collections::HashMap<Vec<u32>, super::kernel::Pipeline>>,
    /// The window's surface (`ContextOptions::window`); destroyed before the instance.
    #[cfg(feature = "preview")]
    pub(crate) surface: Option<super::present::Surface>,
    #[cfg(feature = "preview")]
    pub(crate) physical_device: vk::PhysicalDevice,
    info: DeviceInfo,
    reason: String,
    /// Whether the device was created with `robustBufferAccess` (see [`GpuContext::robust_buffer_access`]).
    robust_buffer_access: bool,
}

fn device_type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

/// Preference order when no name is given: discrete, integrated, virtual, CPU (lavapipe), other.
fn device_type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn load_entry() -> Result<ash::Entry, GpuError> {
    // SAFETY: loading the system Vulkan loader library; no other code runs during the load.
    unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoVulkan(e.to_string()))
}

fn env_flag(name: &str) -> bool {
    std::env::var(name)
        .map(|v| !v.is_empty() && v != "0")
        .unwrap_or(false)
}

fn create_instance(
    entry: &ash::Entry,
    validation: bool,
    extra_extensions: &[*const std::ffi::c_char],
) -> Result<ash::Instance, GpuError> {
    let app_name = c"vkpath";
    let app_info = vk::ApplicationInfo::default()
        .application_name(app_name)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_1);
    let mut layers = Vec::new();
    let mut extensions = extra_extensions.to_vec();
    if validation {
        // SAFETY: plain query of the loader.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(|e| GpuError::vk("vkEnumerateInstanceLayerProperties", e))?;
        let found = available.iter().any(|l| {
            l.layer_name_as_c_str()
                .map(|n| n == VALIDATION_LAYER)
                .unwrap_or(false)
        });
        if !found {
            return Err(GpuError::ValidationUnavailable);
        }
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let create_info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    // SAFETY: create_info and everything it points to live until the call returns.
    let instance = unsafe { entry.create_instance(&create_info, None) };
    match instance {
        Ok(i) => Ok(i),
        Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => Err(GpuError::NoDevice),
        Err(e) => Err(GpuError::vk("vkCreateInstance", e)),
    }
}

fn describe(instance: &ash::Instance, index: usize, pd: vk::PhysicalDevice) -> DeviceInfo {
    // SAFETY: pd comes from this instance's enumeration.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let queues = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    let mem = unsafe { instance.get_physical_device_memory_properties(pd) };
    let mut maint3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut ids = vk::PhysicalDeviceIDProperties::default();
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    // The instance asks for Vulkan 1.1, so the driver properties (core in 1.2) may be chained only
    // where the device has VK_KHR_driver_properties.
    let has_driver_props = unsafe { instance.enumerate_device_extension_properties(pd) }
        .map(|exts| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str() == Ok(ash::khr::driver_properties::NAME))
        })
        .unwrap_or(false);
    let mut props2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut maint3)
        .push_next(&mut ids);
    if has_driver_props {
        props2 = props2.push_next(&mut driver);
    }
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let (driver_text, lavapipe_mesa) = if has_driver_props {
        let name = driver
            .driver_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let info = driver
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mesa = (driver.driver_id == vk::DriverId::MESA_LLVMPIPE)
            .then(|| mesa_version(&info))
            .flatten();
        (format!("{name}: {info}"), mesa)
    } else {
        (String::new(), None)
    };
    let device_local = mem.memory_heaps[..mem.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .sum();
    let v = props.api_version;
    DeviceInfo {
        index,
        name: props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        device_type: device_type_name(props.device_type).into(),
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        ),
        driver_version: props.driver_version,
        driver: driver_text,
        lavapipe_mesa,
        has_compute_queue: queues
            .iter()
            .any(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE)),
        max_compute_workgroup_count: props.limits.max_compute_work_group_count,
        max_compute_workgroup_invocations: props.limits.max_compute_work_group_invocations,
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        max_uniform_buffer_range: props.limits.max_uniform_buffer_range,
        max_image_dimension_2d: props.limits.max_image_dimension2_d,
        max_memory_allocation_size: maint3.max_memory_allocation_size,
        device_local_memory_bytes: device_local,
        uuid: ids.device_uuid,
        robust_buffer_access: unsafe { instance.get_physical_device_features(pd) }
            .robust_buffer_access
            == vk::TRUE,
    }
}

/// The [major, minor] of a Mesa driver string such as "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)".
fn mesa_version(info: &str) -> Option<[u32; 2]> {
    let rest = &info[info.find("Mesa ")? + 5..];
    let mut parts = rest.split(|c: char| !c.is_ascii_digit());
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some([major, minor])
}

/// The oldest Mesa whose lavapipe vkpath runs at full speed: Mesa 24 and 25 run the same kernels, to
/// the same bits, 1.4-3x faster than Mesa 22.3 on the course scenes (docs/performance.md).
pub const FAST_LAVAPIPE_MESA: u32 = 24;

impl DeviceInfo {
    /// A warning for a lavapipe older than [`FAST_LAVAPIPE_MESA`], with the fix; `None` otherwise.
    pub fn old_lavapipe_warning(&self) -> Option<String> {
        let [major, minor] = self.lavapipe_mesa?;
        (major < FAST_LAVAPIPE_MESA).then(|| {
            format!(
                "lavapipe from Mesa {major}.{minor} is slow: Mesa {FAST_LAVAPIPE_MESA} or newer renders \
                 the same image 1.4-3x faster. On Debian 12, `ci/setup.sh` installs Mesa 25 from \
                 bookworm-backports; Ubuntu 24.04 and Debian 13 ship Mesa 24 and 25."
            )
        })
    }
}

/// Lists the Vulkan devices without creating a logical device (for `vkpath info`).
pub fn list_devices() -> Result<Vec<DeviceInfo>, GpuError> {
    let entry = load_entry()?;
    let instance = create_instance(&entry, false, &[])?;
    // SAFETY: the instance is valid; destroyed below.
    let pds = unsafe { instance.enumerate_physical_devices() };
    let result = pds
        .map(|pds| {
            pds.iter()
                .enumerate()
                .map(|(i, &pd)| describe(&instance, i, pd))
                .collect()
        })
        .map_err(|e| GpuError::vk("vkEnumeratePhysicalDevices", e));
    unsafe { instance.destroy_instance(None) };
    result
}

/// Chooses a device: by name substring when given, else the best-ranked type with a compute queue.
/// Returns the index and a sentence saying why.
pub fn choose_device(
    devices: &[DeviceInfo],
    substring: Option<&str>,
) -> Result<(usize, String), GpuError> {
    let usable: Vec<&DeviceInfo> = devices.iter().filter(|d| d.has_compute_queue).collect();
    if usable.is_empty() {
        return Err(GpuError::NoDevice);
    }
    if let Some(sub) = substring {
        let needle = sub.to_lowercase();
        return usable
            .iter()
            .find(|d| d.name.to_lowercase().contains(&needle))
            .map(|d| {
                (
                    d.index,
                    format!("its name contains \"{sub}\" (VKPATH_DEVICE)"),
                )
            })
            .ok_or_else(|| GpuError::DeviceNotFound {
                wanted: sub.to_string(),
                available: usable.iter().map(|d| d.name.clone()).collect(),
            });
    }
    let rank = |d: &DeviceInfo| match d.device_type.as_str() {
        "discrete GPU" => device_type_rank(vk::PhysicalDeviceType::DISCRETE_GPU),
        "integrated GPU" => device_type_rank(vk::PhysicalDeviceType::INTEGRATED_GPU),
        "virtual GPU" => device_type_rank(vk::PhysicalDeviceType::VIRTUAL_GPU),
        "CPU" => device_type_rank(vk::PhysicalDeviceType::CPU),
        _ => 4,
    };
    let best = usable
        .iter()
        .min_by_key(|d| (rank(d), d.index))
        .copied()
        .ok_or(GpuError::NoDevice)?;
    Ok((
        best.index,
        format!(
            "it is a {} with a compute queue (preference: discrete GPU, integrated GPU, virtual GPU, CPU)",
            best.device_type
        ),
    ))
}

impl GpuContext {
    /// Creates the context on the preferred device (see [`choose_device`]).
    pub fn new(options: &ContextOptions) -> Result<Arc<GpuContext>, GpuError> {
        let validation = options.validation || env_flag("VKPATH_VALIDATION");
        let substring = options.device_substring.clone().or_else(|| {
            std::env::var("VKPATH_DEVICE")
                .ok()
                .filter(|s| !s.is_empty())
        });
        let entry = load_entry()?;
        #[cfg(feature = "preview")]
        let window_extensions = match &options.window {
            Some(w) => super::present::instance_extensions(w)?,
            None => Vec::new(),
        };
        #[cfg(not(feature = "preview"))]
        let window_extensions = Vec::new();
        let instance = create_instance(&entry, validation, &window_extensions)?;
        // From here on, failures must destroy what was created: build in a closure and clean up on error.
        let mut debug = None;
        if validation {
            let sink = Box::new(DebugSink::default());
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*sink as *const DebugSink as *mut c_void);
            // SAFETY: `sink` is boxed and kept with the messenger; the callback only reads it.
            match unsafe { loader.create_debug_utils_messenger(&info, None) } {
                Ok(m) => debug = Some((loader, m, sink)),
                Err(e) => {
                    unsafe { instance.destroy_instance(None) };
                    return Err(GpuError::vk("vkCreateDebugUtilsMessengerEXT", e));
                }
            }
        }
        let cleanup_instance = |debug: &Option<(
            ash::ext::debug_utils::Instance,
            vk::DebugUtilsMessengerEXT,
            Box<DebugSink>,
        )>| unsafe {
            if let Some((loader, m, _)) = debug {
                loader.destroy_debug_utils_messenger(*m, None);
            }
            instance.destroy_instance(None);
        };
        let pds = match unsafe { instance.enumerate_physical_devices() } {
            Ok(p) => p,
            Err(e) => {
                cleanup_instance(&debug);
                return Err(GpuError::vk("vkEnumeratePhysicalDevices", e));
            }
        };
        let infos: Vec<DeviceInfo> = pds
            .iter()
            .enumerate()
            .map(|(i, &pd)| describe(&instance, i, pd))
            .collect();
        let (index, reason) = match choose_device(&infos, substring.as_deref()) {
            Ok(c) => c,
            Err(e) => {
                cleanup_instance(&debug);
                return Err(e);
            }
        };
        let physical = pds[index];
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        #[cfg_attr(not(feature = "preview"), allow(unused_mut))]
        let mut queue_family = families
            .iter()
            .position(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .unwrap_or(0) as u32;
        #[cfg_attr(not(feature = "preview"), allow(unused_mut))]
        let mut device_extensions: Vec<*const std::ffi::c_char> = Vec::new();
        // With a window: its surface, and a queue family that computes and presents to it (one queue
        // for both keeps the ordering simple: a present waits for the copy submitted before it).
        #[cfg(feature = "preview")]
        let surface = match &options.window {
            None => None,
            Some(w) => {
                let found = super::present::Surface::new(&entry, &instance, w).and_then(|s| {
                    match s.compute_present_family(physical, &families) {
                        Some(f) => Ok((s, f)),
                        None => {
                            s.destroy();
                            Err(GpuError::Limit(format!(
                                "the Vulkan device {} cannot present to this window from a compute \
                                 queue. Pick another device with VKPATH_DEVICE, or use `vkpath render`.",
                                infos[index].name
                            )))
                        }
                    }
                });
                match found {
                    Ok((s, f)) => {
                        queue_family = f;
                        device_extensions.push(ash::khr::swapchain::NAME.as_ptr());
                        Some(s)
                    }
                    Err(e) => {
                        cleanup_instance(&debug);
                        return Err(e);
                    }
                }
            }
        };
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // robustBufferAccess where the device has it (every Vulkan 1.0 device must, but only as a
        // feature to enable): an index past the end of a storage or uniform buffer then reads zero or a
        // value inside the buffer and writes nothing, instead of being undefined behaviour. The kernel's
        // SPIR-V leaves buffer indices unchecked (naga's checks cost 37-42 % on sphere scenes on
        // lavapipe, docs/performance.md); the driver's check is the guard on GPUs, where an out-of-bounds
        // read can otherwise fault the device.
        let robust_buffer_access = infos[index].robust_buffer_access;
        let features =
            vk::PhysicalDeviceFeatures::default().robust_buffer_access(robust_buffer_access);
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&device_extensions)
            .enabled_features(&features);
        let device = match unsafe { instance.create_device(physical, &device_info, None) } {
            Ok(d) => d,
            Err(e) => {
                #[cfg(feature = "preview")]
                if let Some(s) = &surface {
                    s.destroy();
                }
                cleanup_instance(&debug);
                return Err(GpuError::vk("vkCreateDevice", e));
            }
        };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let allocator = match Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        }) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_device(None) };
                #[cfg(feature = "preview")]
                if let Some(s) = &surface {
                    s.destroy();
                }
                cleanup_instance(&debug);
                return Err(GpuError::Alloc(e.to_string()));
            }
        };
        let limits = unsafe { instance.get_physical_device_properties(physical) }.limits;
        // One pipeline cache for the context, for drivers that share work between pipelines through it
        // (renderers of the same SPIR-V share the pipeline itself: `pipelines`). A failure just means
        // no cache.
        let pipeline_cache =
            unsafe { device.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None) }
                .unwrap_or(vk::PipelineCache::null());
        Ok(Arc::new(GpuContext {
            _entry: entry,
            instance,
            debug,
            device,
            queue: Mutex::new(queue),
            queue_family,
            allocator: Mutex::new(Some(allocator)),
            limits,
            pipeline_cache,
            pipelines: Mutex::new(Default::default()),
            #[cfg(feature = "preview")]
            surface,
            #[cfg(feature = "preview")]
            physical_device: physical,
            info: infos[index].clone(),
            reason,
            robust_buffer_access,
        }))
    }

    /// The chosen device.
    pub fn device_info(&self) -> &DeviceInfo {
        &self.info
    }

    /// Why this device was chosen, in words.
    pub fn choice_reason(&self) -> &str {
        &self.reason
    }

    /// Whether buffer accesses are bounds-checked by the driver (`robustBufferAccess`, enabled wherever
    /// the device offers it): an out-of-range index into a storage or uniform buffer reads zero or a value
    /// of that buffer and writes nothing, so that a wrong index in the kernel cannot fault the device.
    pub fn robust_buffer_access(&self) -> bool {
        self.robust_buffer_access
    }

    /// Whether the Khronos validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// Error messages reported by the validation layer so far (empty when validation is off).
    pub fn validation_errors(&self) -> Vec<String> {
        self.debug
            .as_ref()
            .and_then(|(_, _, sink)| sink.errors.lock().ok().map(|e| e.clone()))
            .unwrap_or_default()
    }

    /// A command pool on the context's queue family and one primary command buffer from it, for an
    /// owner that re-records that single buffer before each submit (a kernel, the presenter): hence
    /// `RESET_COMMAND_BUFFER`, so the buffer can be reset on its own. The caller owns the pool and
    /// destroys it (which frees the buffer); if the allocation fails, the pool is destroyed here, so
    /// that a failure leaves nothing behind.
    pub(crate) fn create_command_buffer(
        &self,
    ) -> Result<(vk::CommandPool, vk::CommandBuffer), GpuError> {
        // SAFETY: plain object creation on a valid device; on failure the pool has no buffers and is
        // not yet known to anyone else.
        unsafe {
            let pool = self
                .device
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(self.queue_family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateCommandPool", e))?;
            match self.device.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            ) {
                Ok(buffers) => Ok((pool, buffers[0])),
                Err(e) => {
                    self.device.destroy_command_pool(pool, None);
                    Err(GpuError::vk("vkAllocateCommandBuffers", e))
                }
            }
        }
    }

    pub(crate) fn allocator(&self) -> std::sync::MutexGuard<'_, Option<Allocator>> {
        // A poisoned lock means a panic elsewhere already; the allocator itself is still consistent.
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        // SAFETY: every buffer and kernel holds an Arc to the context, so none is alive any more.
        unsafe {
            let _ = self.device.device_wait_idle();
            // The allocator frees its memory blocks: it must go before the device.
            self.allocator().take();
            let pipelines = self.pipelines.get_mut().unwrap_or_else(|e| e.into_inner());
            for (_, p) in pipelines.drain() {
                p.destroy(&self.device);
            }
            self.device
                .destroy_pipeline_cache(self.pipeline_cache, None);
            self.device.destroy_device(None);
            // The swapchain (which holds an Arc of this context) is gone, so the surface may go.
            #[cfg(feature = "preview")]
            if let Some(s) = &self.surface {
                s.destroy();
            }
            if let Some((loader, m, _)) = &self.debug {
                loader.destroy_debug_utils_messenger(*m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// A lavapipe of Mesa `mesa` with small limits: for the tests of what depends on the device (here and
/// in `render`).
#[cfg(test)]
impl DeviceInfo {
    pub(crate) fn test_lavapipe(mesa: [u32; 2]) -> DeviceInfo {
        DeviceInfo {
            index: 0,
            name: "llvmpipe".into(),
            device_type: "CPU".into(),
            api_version: "1.3.0".into(),
            driver_version: 0,
            driver: String::new(),
            lavapipe_mesa: Some(mesa),
            has_compute_queue: true,
            max_compute_workgroup_count: [1; 3],
            max_compute_workgroup_invocations: 1,
            max_storage_buffer_range: 1,
            max_uniform_buffer_range: 65536,
            max_image_dimension_2d: 16384,
            max_memory_allocation_size: 1,
            device_local_memory_bytes: 1,
            uuid: [0; 16],
            robust_buffer_access: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesa_versions_are_read_from_driver_strings() {
        assert_eq!(
            mesa_version("Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"),
            Some([25, 0])
        );
        assert_eq!(mesa_version("Mesa 22.3.6 (LLVM 15.0.6)"), Some([22, 3]));
        assert_eq!(mesa_version("Mesa 24.2"), Some([24, 2]));
        assert_eq!(mesa_version("535.104.05"), None);
        assert_eq!(mesa_version("Mesa x"), None);
    }

    fn lavapipe(mesa: [u32; 2]) -> DeviceInfo {
        DeviceInfo::test_lavapipe(mesa)
    }

    #[test]
    fn only_an_old_lavapipe_is_warned_about() {
        let mut d = lavapipe([22, 3]);
        let w = d.old_lavapipe_warning().expect("Mesa 22.3 is old");
        assert!(w.contains("Mesa 22.3") && w.contains("ci/setup.sh"), "{w}");
        d.lavapipe_mesa = Some([24, 0]);
        assert_eq!(d.old_lavapipe_warning(), None);
        d.lavapipe_mesa = None;
        assert_eq!(d.old_lavapipe_warning(), None);
    }
}
