//! Denoising with Intel Open Image Denoise (OIDN), loaded at run time.
//!
//! OIDN's `RT` filter is a U-Net trained on path-traced images: it takes the noisy radiance (`color`,
//! linear HDR) with two auxiliary images of the first non-specular surface each camera path meets, its
//! `albedo` and its shading `normal`, and predicts the converged image. vkpath already renders both aux
//! images (`--aov albedo,normal`, `session::aov_layers`: the kernel specialised for each, with up to
//! `AOV_MAX_SPP` jittered samples a pixel), so denoising is a host step after the render.
//!
//! **Loaded, not linked.** vkpath builds, renders and passes its other tests without OIDN: the library is
//! opened with `dlopen` (libloading) when a command asks for denoising, and only the dozen C functions
//! used here are looked up (OIDN 2's C API, `OpenImageDenoise/oidn.h`). The `oidn` crate links the
//! library at build time, which would make OIDN a build dependency of every user; behind a cargo feature
//! it would split the binaries people get into two kinds. Where it is looked for, in order:
//! `$VKPATH_OIDN_DIR` alone when that is set (so a test can point at a folder without it); else the
//! system's loader path (Arch, Fedora, Homebrew and conda package `libOpenImageDenoise.so.2`); else
//! [`DEFAULT_DIR`]`/lib`, where `ci/setup.sh --denoise` unpacks the official build on Debian and Ubuntu.
//!
//! **For files the aux images are prefiltered** (OIDN's documentation, "Denoising with prefiltering"):
//! each is first passed through its own `RT` filter (albedo alone, normal alone), and the beauty filter
//! is then told the aux images are clean (`cleanAux`), which at `High` quality selects OIDN's large
//! network. vkpath's aux images average up to 64 jittered samples, so they are clean on plain surfaces
//! but keep noise wherever a pixel's samples reach different surfaces: depth of field, glass and mirror
//! chains, sub-pixel geometry; without prefiltering the network must allow for that noise everywhere.
//! Measured at 512x512, 16 spp, on two CPU cores: 2.55 s against 0.39 s without, for a relative MSE
//! 23 % lower on the Cornell box and 4 % lower on the course scene; at 16 spp that is still the better
//! image at equal time on the Cornell box (the 2 s buy 9 more samples a pixel there, 33 on the faster
//! course scene, where it is not). Files get the best image per sample; the preview window, which
//! denoises again and again, gets `Balanced` without prefiltering (0.39 s; prefiltered `Balanced` took
//! 1.15 s and was no better). docs/denoising.md has the table.
//!
//! **Devices.** OIDN's CPU device by default (and always when the Vulkan device is a CPU, as lavapipe
//! is). When the Vulkan device is a GPU, the OIDN physical device with the same UUID (CUDA, HIP and SYCL
//! report the UUID Vulkan does) is used when OIDN has one, else the CPU. Images go through the host:
//! the film is read back for the files anyway, and the copy is a few milliseconds against the filter's
//! seconds (sharing the film through Vulkan external memory would save that copy only).
//!
//! **Determinism.** OIDN promises the same output for the same input on the same device (the CPU
//! device's kernels are deterministic for a given instruction set); vkpath adds nothing that varies.

use crate::Error;
use libloading::Library;
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};

/// Where `ci/setup.sh --denoise` installs OIDN (its libraries in `lib/`, the layout of OIDN's own
/// release archives, whose libraries find each other through `$ORIGIN/../lib`); vkpath looks there last.
pub const DEFAULT_DIR: &str = "/usr/local/lib/vkpath-oidn";
/// The environment variable naming OIDN's install folder (the one with `lib/`; `ci/setup.sh` installs
/// into it too); when set, vkpath looks nowhere else.
pub const DIR_VARIABLE: &str = "VKPATH_OIDN_DIR";
/// The oldest OIDN whose C API is the one declared here (2.0 renamed the parameter setters and added
/// buffers and physical devices). `oidnGetDeviceInt(device, "version")` is 10000 major + 100 minor +
/// patch.
const MIN_VERSION: i32 = 2_00_00;

#[cfg(target_os = "linux")]
const LIBRARY_NAME: &str = "libOpenImageDenoise.so.2";
#[cfg(target_os = "macos")]
const LIBRARY_NAME: &str = "libOpenImageDenoise.2.dylib";
#[cfg(target_os = "windows")]
const LIBRARY_NAME: &str = "OpenImageDenoise.dll";
#[cfg(not(any(target_os = "linux", target_os = "macos", target_os = "windows")))]
const LIBRARY_NAME: &str = "libOpenImageDenoise.so.2";

/// How to install OIDN, for the error when it is missing.
pub const INSTALL_HINT: &str = "Install Intel Open Image Denoise 2: on Debian or Ubuntu run `ci/setup.sh \
     --denoise` from vkpath's source tree (it unpacks the official build into /usr/local/lib/vkpath-oidn); \
     elsewhere use the system's package (Arch: openimagedenoise, Fedora: oidn, Homebrew: open-image-denoise, \
     conda-forge: oidn) or the release archive from openimagedenoise.github.io, and set VKPATH_OIDN_DIR \
     to the folder whose lib/ holds libOpenImageDenoise.so.2 when it is not on the loader's path.";

// OIDN 2's C types: opaque handles and C enums (ints).
type OidnDevice = *mut c_void;
type OidnBuffer = *mut c_void;
type OidnFilter = *mut c_void;
/// OIDNDeviceType: DEFAULT 0, CPU 1, SYCL 2, CUDA 3, HIP 4, METAL 5.
const DEVICE_TYPE_CPU: c_int = 1;
/// OIDNFormat FLOAT3: three packed f32 per pixel.
const FORMAT_FLOAT3: c_int = 3;
/// OIDNQuality: DEFAULT 0, FAST 4, BALANCED 5, HIGH 6.
const QUALITY_HIGH: c_int = 6;
const QUALITY_BALANCED: c_int = 5;

/// The functions used, looked up once. The library stays open as long as this lives.
struct Api {
    new_device: unsafe extern "C" fn(c_int) -> OidnDevice,
    new_device_by_uuid: unsafe extern "C" fn(*const c_void) -> OidnDevice,
    num_physical_devices: unsafe extern "C" fn() -> c_int,
    physical_device_int: unsafe extern "C" fn(c_int, *const c_char) -> c_int,
    physical_device_bool: unsafe extern "C" fn(c_int, *const c_char) -> bool,
    physical_device_string: unsafe extern "C" fn(c_int, *const c_char) -> *const c_char,
    physical_device_data: unsafe extern "C" fn(c_int, *const c_char, *mut usize) -> *const c_void,
    commit_device: unsafe extern "C" fn(OidnDevice),
    device_int: unsafe extern "C" fn(OidnDevice, *const c_char) -> c_int,
    device_error: unsafe extern "C" fn(OidnDevice, *mut *const c_char) -> c_int,
    release_device: unsafe extern "C" fn(OidnDevice),
    new_buffer: unsafe extern "C" fn(OidnDevice, usize) -> OidnBuffer,
    write_buffer: unsafe extern "C" fn(OidnBuffer, usize, usize, *const c_void),
    read_buffer: unsafe extern "C" fn(OidnBuffer, usize, usize, *mut c_void),
    release_buffer: unsafe extern "C" fn(OidnBuffer),
    new_filter: unsafe extern "C" fn(OidnDevice, *const c_char) -> OidnFilter,
    #[allow(clippy::type_complexity)]
    set_filter_image: unsafe extern "C" fn(
        OidnFilter,
        *const c_char,
        OidnBuffer,
        c_int,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    set_filter_bool: unsafe extern "C" fn(OidnFilter, *const c_char, bool),
    set_filter_int: unsafe extern "C" fn(OidnFilter, *const c_char, c_int),
    commit_filter: unsafe extern "C" fn(OidnFilter),
    execute_filter: unsafe extern "C" fn(OidnFilter),
    release_filter: unsafe extern "C" fn(OidnFilter),
    /// Last: the functions above point into it.
    _library: Library,
}

impl Api {
    /// Looks up every function in `library`; a missing one means a library that is not OIDN 2.
    fn new(library: Library, path: &Path) -> Result<Api, String> {
        // SAFETY: each symbol is OIDN 2's C function of that name, with the signature of oidn.h.
        unsafe {
            macro_rules! f {
                ($name:literal) => {
                    *library.get(concat!($name, "\0").as_bytes()).map_err(|e| {
                        format!(
                            "{} has no function {} ({e}): it is not Open Image Denoise 2",
                            path.display(),
                            $name
                        )
                    })?
                };
            }
            Ok(Api {
                new_device: f!("oidnNewDevice"),
                new_device_by_uuid: f!("oidnNewDeviceByUUID"),
                num_physical_devices: f!("oidnGetNumPhysicalDevices"),
                physical_device_int: f!("oidnGetPhysicalDeviceInt"),
                physical_device_bool: f!("oidnGetPhysicalDeviceBool"),
                physical_device_string: f!("oidnGetPhysicalDeviceString"),
                physical_device_data: f!("oidnGetPhysicalDeviceData"),
                commit_device: f!("oidnCommitDevice"),
                device_int: f!("oidnGetDeviceInt"),
                device_error: f!("oidnGetDeviceError"),
                release_device: f!("oidnReleaseDevice"),
                new_buffer: f!("oidnNewBuffer"),
                write_buffer: f!("oidnWriteBuffer"),
                read_buffer: f!("oidnReadBuffer"),
                release_buffer: f!("oidnReleaseBuffer"),
                new_filter: f!("oidnNewFilter"),
                set_filter_image: f!("oidnSetFilterImage"),
                set_filter_bool: f!("oidnSetFilterBool"),
                set_filter_int: f!("oidnSetFilterInt"),
                commit_filter: f!("oidnCommitFilter"),
                execute_filter: f!("oidnExecuteFilter"),
                release_filter: f!("oidnReleaseFilter"),
                _library: library,
            })
        }
    }
}

/// The places OIDN is looked for, in order (see the module's documentation).
pub fn candidates() -> Vec<PathBuf> {
    match std::env::var_os(DIR_VARIABLE) {
        Some(dir) if !dir.is_empty() => vec![Path::new(&dir).join("lib").join(LIBRARY_NAME)],
        _ => vec![
            PathBuf::from(LIBRARY_NAME),
            Path::new(DEFAULT_DIR).join("lib").join(LIBRARY_NAME),
        ],
    }
}

/// Which OIDN device to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The CPU device.
    Cpu,
    /// The OIDN physical device with this UUID when there is one (the Vulkan GPU's), else the CPU.
    Matching([u8; 16]),
}

impl DeviceChoice {
    /// The choice for a render on this Vulkan device: its UUID when it is a GPU, else the CPU.
    pub fn for_vulkan(info: &crate::gpu::DeviceInfo) -> DeviceChoice {
        if info.device_type.contains("GPU") {
            DeviceChoice::Matching(info.uuid)
        } else {
            DeviceChoice::Cpu
        }
    }
}

/// The quality/speed trade: `High` for files, `Balanced` for the preview window (measured in
/// docs/denoising.md: at 512x512 on two CPU cores 2.55 s against 0.39 s, relative MSE 3 to 23 % higher).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// OIDN's `High` quality with the aux images prefiltered (see the module's documentation).
    High,
    /// OIDN's `Balanced` quality on the aux images as rendered (no prefilter: `cleanAux` off).
    Balanced,
}

/// The images one denoise reads: linear RGB radiance, and the first surface's albedo and normal (world
/// space, unit length or zero), each `width * height` pixels, row-major.
pub struct Inputs<'a> {
    pub width: u32,
    pub height: u32,
    pub color: &'a [[f32; 3]],
    pub albedo: &'a [[f32; 3]],
    pub normal: &'a [[f32; 3]],
}

/// An open OIDN device: the library, the device and what it is.
pub struct Denoiser {
    api: Api,
    device: OidnDevice,
    /// Where the library was loaded from.
    pub library: PathBuf,
    /// OIDN's version, e.g. "2.5.1".
    pub version: String,
    /// The device, in words: "CPU", or the GPU's name and kind ("NVIDIA H200 (CUDA)").
    pub device_name: String,
}

impl Drop for Denoiser {
    fn drop(&mut self) {
        // SAFETY: the device was created by this library and is released once.
        unsafe { (self.api.release_device)(self.device) };
    }
}

fn c(name: &str) -> CString {
    CString::new(name).expect("parameter names have no NUL")
}

/// The error when OIDN cannot be loaded: what was tried, and how to install it (exit status 2).
fn missing(tried: &[(PathBuf, String)]) -> Error {
    let tried: Vec<String> = tried
        .iter()
        .map(|(p, e)| format!("{} ({e})", p.display()))
        .collect();
    Error::DenoiserMissing(format!(
        "denoising needs Intel Open Image Denoise, which is not installed here (tried {}). {INSTALL_HINT}",
        tried.join("; ")
    ))
}

impl Denoiser {
    /// Loads OIDN from the first of [`candidates`] that opens, and creates the device `choice` asks
    /// for. A missing library is [`Error::DenoiserMissing`] (exit status 2, with the install hint).
    pub fn new(choice: DeviceChoice) -> Result<Denoiser, Error> {
        let mut tried = Vec::new();
        for path in candidates() {
            // SAFETY: loading runs the library's initialisers; OIDN's only register its devices.
            match unsafe { Library::new(&path) } {
                Ok(library) => {
                    let api = Api::new(library, &path).map_err(Error::DenoiserMissing)?;
                    return Denoiser::open(api, path, choice);
                }
                Err(e) => {
                    let message = short_dl_error(&e.to_string(), &path);
                    tried.push((path, message))
                }
            }
        }
        Err(missing(&tried))
    }

    /// Creates the device and checks its version.
    fn open(api: Api, library: PathBuf, choice: DeviceChoice) -> Result<Denoiser, Error> {
        let (device, device_name) = match choice {
            DeviceChoice::Matching(uuid) => match gpu_with_uuid(&api, &uuid) {
                Some(name) => {
                    // SAFETY: the UUID is 16 bytes, as oidnNewDeviceByUUID reads.
                    let d = unsafe { (api.new_device_by_uuid)(uuid.as_ptr().cast()) };
                    (d, name)
                }
                // SAFETY: a plain call.
                None => (unsafe { (api.new_device)(DEVICE_TYPE_CPU) }, "CPU".into()),
            },
            DeviceChoice::Cpu => (unsafe { (api.new_device)(DEVICE_TYPE_CPU) }, "CPU".into()),
        };
        if device.is_null() {
            let message = last_error(&api, std::ptr::null_mut()).unwrap_or_default();
            return Err(Error::Denoise(format!(
                "Open Image Denoise ({}) could not create its {device_name} device: {message}",
                library.display()
            )));
        }
        // SAFETY: a valid device.
        unsafe { (api.commit_device)(device) };
        let mut denoiser = Denoiser {
            version: String::new(),
            api,
            device,
            library,
            device_name,
        };
        denoiser.check("committing the device")?;
        let v = unsafe { (denoiser.api.device_int)(device, c("version").as_ptr()) };
        denoiser.version = format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100);
        if v < MIN_VERSION {
            return Err(Error::DenoiserMissing(format!(
                "{} is Open Image Denoise {}, and vkpath needs 2.0 or newer. {INSTALL_HINT}",
                denoiser.library.display(),
                denoiser.version
            )));
        }
        Ok(denoiser)
    }

    /// OIDN's pending error on this device, as ours.
    fn check(&self, doing: &str) -> Result<(), Error> {
        match last_error(&self.api, self.device) {
            None => Ok(()),
            Some(message) => Err(Error::Denoise(format!(
                "Open Image Denoise {} ({}) failed {doing}: {message}",
                self.version, self.device_name
            ))),
        }
    }

    /// What denoised an image (at [`Quality::High`], the files' quality), for its metadata.
    pub fn describe(&self) -> String {
        format!(
            "Intel Open Image Denoise {}, RT filter (high quality) on {}, albedo and normal prefiltered",
            self.version, self.device_name
        )
    }

    /// The denoised color image of `inputs` (see the module's documentation for the steps).
    pub fn denoise(&self, inputs: &Inputs, quality: Quality) -> Result<Vec<[f32; 3]>, Error> {
        let (w, h) = (inputs.width as usize, inputs.height as usize);
        let n = w * h;
        for (name, image) in [
            ("color", inputs.color),
            ("albedo", inputs.albedo),
            ("normal", inputs.normal),
        ] {
            if image.len() != n {
                return Err(Error::Denoise(format!(
                    "the {name} image has {} pixels, not {w} x {h}",
                    image.len()
                )));
            }
        }
        crate::memory::check_available(
            n as u64 * crate::render::host_use::DENOISE_BYTES_PER_PIXEL,
            &format!("denoising {w}x{h} pixels"),
        )
        .map_err(|m| Error::Denoise(format!("{m}: denoise on a machine with more memory")))?;
        let level = match quality {
            Quality::High => QUALITY_HIGH,
            Quality::Balanced => QUALITY_BALANCED,
        };
        let bytes = n * 12;
        let color = self.buffer(bytes, Some(inputs.color))?;
        let albedo = self.buffer(bytes, Some(inputs.albedo))?;
        let normal = self.buffer(bytes, Some(inputs.normal))?;
        let output = self.buffer(bytes, None)?;
        // High: the aux images, each denoised in place by a filter that sees only it, then the beauty
        // filter told they are clean (see the module's documentation).
        let prefilter = quality == Quality::High;
        if prefilter {
            self.run_filter(
                &[("albedo", &albedo), ("output", &albedo)],
                w,
                h,
                level,
                &[],
            )?;
            self.run_filter(
                &[("normal", &normal), ("output", &normal)],
                w,
                h,
                level,
                &[],
            )?;
        }
        self.run_filter(
            &[
                ("color", &color),
                ("albedo", &albedo),
                ("normal", &normal),
                ("output", &output),
            ],
            w,
            h,
            level,
            &[("hdr", true), ("cleanAux", prefilter)],
        )?;
        let mut out = vec![[0.0f32; 3]; n];
        // SAFETY: the buffer holds `bytes` bytes and `out` has room for them.
        unsafe { (self.api.read_buffer)(output.0, 0, bytes, out.as_mut_ptr().cast()) };
        self.check("reading the output")?;
        Ok(out)
    }

    /// `film` with its means denoised from the aux images `aux` (the variance stays the raw estimate's):
    /// what `--denoise`, `vkpath merge --denoise`, the bench and the preview's D do.
    pub fn denoise_film(
        &self,
        film: &crate::film::Film,
        aux: &crate::checkpoint::Aux,
        quality: Quality,
    ) -> Result<crate::film::Film, Error> {
        let mean = self.denoise(
            &Inputs {
                width: film.width,
                height: film.height,
                color: &film.mean,
                albedo: &aux.albedo,
                normal: &aux.normal,
            },
            quality,
        )?;
        Ok(crate::film::Film {
            mean,
            ..film.clone()
        })
    }

    /// A device buffer of `bytes`, filled from `data` when given.
    fn buffer(&self, bytes: usize, data: Option<&[[f32; 3]]>) -> Result<Buffer<'_>, Error> {
        // SAFETY: a valid device; the result is checked for null below.
        let b = unsafe { (self.api.new_buffer)(self.device, bytes) };
        if b.is_null() {
            self.check("allocating a buffer")?;
            return Err(Error::Denoise(format!(
                "Open Image Denoise could not allocate {bytes} bytes"
            )));
        }
        let buffer = Buffer(b, &self.api);
        if let Some(data) = data {
            // SAFETY: `data` holds exactly `bytes` bytes (checked by the caller) and the buffer as many.
            unsafe { (self.api.write_buffer)(b, 0, bytes, data.as_ptr().cast()) };
        }
        self.check("filling a buffer")?;
        Ok(buffer)
    }

    /// One `RT` filter over `images` (name, buffer) with the boolean parameters `flags`, run to the end.
    fn run_filter(
        &self,
        images: &[(&str, &Buffer)],
        w: usize,
        h: usize,
        quality: c_int,
        flags: &[(&str, bool)],
    ) -> Result<(), Error> {
        let api = &self.api;
        // SAFETY: a valid device; every handle below is checked and released by `Filter`'s drop.
        let filter = Filter(
            unsafe { (api.new_filter)(self.device, c("RT").as_ptr()) },
            api,
        );
        if filter.0.is_null() {
            self.check("creating the RT filter")?;
            return Err(Error::Denoise("no RT filter in this library".into()));
        }
        unsafe {
            for (name, buffer) in images {
                (api.set_filter_image)(
                    filter.0,
                    c(name).as_ptr(),
                    buffer.0,
                    FORMAT_FLOAT3,
                    w,
                    h,
                    0,
                    0,
                    0,
                );
            }
            for (name, value) in flags {
                (api.set_filter_bool)(filter.0, c(name).as_ptr(), *value);
            }
            (api.set_filter_int)(filter.0, c("quality").as_ptr(), quality);
            (api.commit_filter)(filter.0);
        }
        self.check("preparing the filter")?;
        unsafe { (api.execute_filter)(filter.0) };
        self.check("denoising")
    }
}

/// An OIDN buffer, released when dropped.
struct Buffer<'a>(OidnBuffer, &'a Api);

impl Drop for Buffer<'_> {
    fn drop(&mut self) {
        // SAFETY: created by this library, released once.
        unsafe { (self.1.release_buffer)(self.0) }
    }
}

/// An OIDN filter, released when dropped.
struct Filter<'a>(OidnFilter, &'a Api);

impl Drop for Filter<'_> {
    fn drop(&mut self) {
        if !self.0.is_null() {
            // SAFETY: created by this library, released once.
            unsafe { (self.1.release_filter)(self.0) }
        }
    }
}

/// The device's (or, with a null device, the last device creation's) pending error message.
fn last_error(api: &Api, device: OidnDevice) -> Option<String> {
    let mut message: *const c_char = std::ptr::null();
    // SAFETY: OIDN writes a pointer to a NUL-terminated string it owns, valid until the next call.
    let code = unsafe { (api.device_error)(device, &mut message) };
    (code != 0).then(|| {
        let text = if message.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        format!("error {code}: {text}")
    })
}

/// The OIDN GPU (not CPU) physical device whose UUID is `uuid`, as "name (kind)".
fn gpu_with_uuid(api: &Api, uuid: &[u8; 16]) -> Option<String> {
    // SAFETY: plain queries of physical devices by index below the count OIDN reports.
    unsafe {
        for id in 0..(api.num_physical_devices)() {
            let kind = (api.physical_device_int)(id, c("type").as_ptr());
            if kind == DEVICE_TYPE_CPU
                || !(api.physical_device_bool)(id, c("uuidSupported").as_ptr())
            {
                continue;
            }
            let mut size = 0usize;
            let data = (api.physical_device_data)(id, c("uuid").as_ptr(), &mut size);
            if data.is_null() || size != 16 {
                continue;
            }
            if std::slice::from_raw_parts(data.cast::<u8>(), 16) == uuid {
                let name = (api.physical_device_string)(id, c("name").as_ptr());
                let name = if name.is_null() {
                    "GPU".to_string()
                } else {
                    CStr::from_ptr(name).to_string_lossy().into_owned()
                };
                let kind = match kind {
                    2 => "SYCL",
                    3 => "CUDA",
                    4 => "HIP",
                    5 => "Metal",
                    _ => "GPU",
                };
                return Some(format!("{name} ({kind})"));
            }
        }
    }
    None
}

/// dlopen's message without the path it starts with (the caller names it); a message about another
/// file (a library it needs) is kept whole.
fn short_dl_error(message: &str, path: &Path) -> String {
    let path = path.display().to_string();
    message
        .strip_prefix(&path)
        .and_then(|m| m.strip_prefix(": "))
        .unwrap_or(message)
        .to_string()
}

/// Whether OIDN can be loaded here, and what it is, for `vkpath info`: "Intel Open Image Denoise 2.5.1
/// (PATH), CPU device", or why not.
pub fn availability(choice: DeviceChoice) -> Result<String, String> {
    match Denoiser::new(choice) {
        Ok(d) => Ok(format!(
            "Intel Open Image Denoise {} ({}), {} device",
            d.version,
            d.library.display(),
            d.device_name
        )),
        Err(e) => Err(e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// dlopen's message loses the path it repeats (the error names it already), but a message about a
    /// library the one opened needs keeps that library's name.
    #[test]
    fn loader_messages_name_what_is_missing_once() {
        let path = Path::new("/opt/oidn/lib/libOpenImageDenoise.so.2");
        let own = "/opt/oidn/lib/libOpenImageDenoise.so.2: cannot open shared object file: No such file or directory";
        assert_eq!(
            short_dl_error(own, path),
            "cannot open shared object file: No such file or directory"
        );
        let dependency = "libOpenImageDenoise_core.so.2.5.1: cannot open shared object file: No such file or directory";
        assert_eq!(short_dl_error(dependency, path), dependency);
    }
}
