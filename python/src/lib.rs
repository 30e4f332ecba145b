//! `vkpath._vkpath`: the native half of vkpath's Python module (the other half, `python/vkpath/`, turns
//! what this returns into NumPy arrays and Python objects; docs/python.md is the user's guide).
//!
//! A scene is held as the vkpath TOML document every importer turns its file into (src/scene/import.rs)
//! and as the [`vkpath::Scene`] read from it. An edit (camera, film size, a material's or a light's keys)
//! changes the document and reads it again through the same reader as a scene file, so that an edited
//! scene is exactly the scene of the edited file, checked by the same rules; the mesh files, textures and
//! environment map it names are not read again ([`FileCache`]). A render builds a renderer for the scene
//! on the process's one GPU context; the kernel comes from the renderer's process-wide cache, so it is
//! compiled again only when the scene's features change.
//!
//! Images cross into Python as `bytearray`s of native-endian f32 values (which NumPy wraps without a
//! copy): the module needs no NumPy headers and builds against CPython's stable ABI (abi3, 3.9+).

use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyByteArray;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use vkpath::denoise::{Denoiser, DeviceChoice};
use vkpath::film::{Film, OutputFormat};
use vkpath::gpu::{ContextOptions, GpuContext};
use vkpath::output::{Aov, ImageFile, Layers};
use vkpath::render::adaptive::AdaptiveSettings;
use vkpath::render::{RenderOptions, StopReason};
use vkpath::scene::import::Importer;
use vkpath::scene::translated::ImportOptions;
use vkpath::scene::{FileCache, ImageSettings};
use vkpath::session::{Request, Session};
use vkpath::{Error, Scene};

/// A vkpath error as the Python exception a user expects: bad input (a scene, an argument) is a
/// `ValueError`, a file that cannot be written an `OSError`, the device or the denoiser a
/// `RuntimeError`; each carries vkpath's one-paragraph message.
fn py_err(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::Scene(_) | Error::Usage(_) | Error::Checkpoint { .. } => {
            PyValueError::new_err(message)
        }
        Error::Io { .. } => PyOSError::new_err(message),
        Error::Gpu(_) | Error::DenoiserMissing(_) | Error::Denoise(_) => {
            PyRuntimeError::new_err(message)
        }
    }
}

fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// The process's GPU context, made at the first render and kept: a context costs the driver's start-up
/// (and on lavapipe a thread pool), and the kernel cache lives as long as the process.
fn context() -> Result<Arc<GpuContext>, Error> {
    static CONTEXT: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);
    let mut held = CONTEXT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(ctx) = held.as_ref() {
        return Ok(ctx.clone());
    }
    let ctx = GpuContext::new(&ContextOptions::default())?;
    *held = Some(ctx.clone());
    Ok(ctx)
}

/// A scene: its TOML document and what vkpath read from it (see the module's documentation).
#[pyclass(name = "Scene", module = "vkpath._vkpath")]
struct PyScene {
    /// Where the scene came from: messages, and the folder its relative paths start from.
    path: Option<PathBuf>,
    /// The vkpath TOML document the scene is read from (the file's own text for a TOML scene, the
    /// importer's translation for glTF and Mitsuba XML), with the edits made since.
    doc: toml::Table,
    /// What the reader said about the file as loaded (edits add none).
    warnings: Vec<String>,
    files: Mutex<FileCache>,
    scene: Scene,
}

/// A TOML document's table from JSON text (the Python side hands dicts over as `json.dumps` text; TOML's
/// tables keep the order of the JSON object, as a scene file's materials keep theirs).
fn table_from_json(json: &str, what: &str) -> PyResult<toml::Table> {
    serde_json::from_str(json).map_err(|e| {
        value_error(format!(
            "{what} cannot be a vkpath scene: {e}. Give a dict of the scene format's tables, keys and \
             values (str, int, float, bool, and lists and dicts of them; no None)."
        ))
    })
}

/// Reads `doc` as a scene file at `label` would be, its files through `files`.
fn read_doc(doc: &toml::Table, label: &Path, files: &mut FileCache) -> Result<Scene, Error> {
    let text = toml::to_string(doc).map_err(|e| Error::Usage(e.to_string()))?;
    Ok(Scene::from_toml_str_cached(&text, Some(label), files)?)
}

impl PyScene {
    /// Reads `doc` as a scene file at `label` would be, through the scene's file cache.
    fn read(&self, doc: &toml::Table, label: &Path) -> Result<Scene, Error> {
        let mut files = self.files.lock().unwrap_or_else(|e| e.into_inner());
        read_doc(doc, label, &mut files)
    }

    /// The name errors of an edited scene give as the file: its own, marked as edited (the lines they
    /// give are those of `Scene.toml`, the edited document), in the scene's folder.
    fn edited_label(&self) -> PathBuf {
        let path = self.path.clone().unwrap_or_else(|| PathBuf::from("scene"));
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        path.with_file_name(format!("{name} (as edited)"))
    }
}

/// `vkpath.load(path, ...)`: any scene file vkpath reads (TOML, glTF 2.0, Mitsuba XML with `defines`
/// as `-D name=value`), `camera` as `vkpath render --camera` (an index, or "auto").
#[pyfunction]
#[pyo3(signature = (path, defines, camera=None, xml_lenient=false))]
fn load(
    path: PathBuf,
    defines: Vec<(String, String)>,
    camera: Option<String>,
    xml_lenient: bool,
) -> PyResult<PyScene> {
    let (camera, auto_camera) = match camera.as_deref() {
        None => (None, false),
        Some("auto") => (None, true),
        Some(n) => (
            Some(n.parse::<usize>().map_err(|_| {
                value_error(format!(
                    "camera={n:?}: give a camera's index (0 for the first) or \"auto\"."
                ))
            })?),
            false,
        ),
    };
    let options = ImportOptions {
        camera,
        auto_camera,
        xml_lenient,
        defines,
        environment_given: false,
    };
    let mut files = FileCache::default();
    let (scene, text) = Importer::for_path(&path)
        .load_cached(&path, &options, &mut files)
        .map_err(|e| py_err(e.into()))?;
    let doc = text.parse::<toml::Table>().map_err(|e| {
        PyRuntimeError::new_err(format!(
            "{}: the TOML vkpath made of it does not read back ({e}); this is a bug in vkpath.",
            path.display()
        ))
    })?;
    Ok(PyScene {
        path: Some(path),
        doc,
        warnings: scene.warnings.clone(),
        files: Mutex::new(files),
        scene,
    })
}

/// `vkpath.load_dict(d)`: a scene given as the TOML format's tables (as JSON text), its relative paths
/// from `base_dir`.
#[pyfunction]
fn load_dict(json: &str, base_dir: PathBuf) -> PyResult<PyScene> {
    let doc = table_from_json(json, "the dict")?;
    let path = base_dir.join("<dict>");
    let mut files = FileCache::default();
    let scene = read_doc(&doc, &path, &mut files).map_err(py_err)?;
    Ok(PyScene {
        path: Some(path),
        doc,
        warnings: scene.warnings.clone(),
        files: Mutex::new(files),
        scene,
    })
}

/// What `Scene.render` hands to the Python side: the summary's JSON, the width and height, the named
/// channels, and whether Ctrl-C stopped it.
type RenderedPy<'py> = (
    String,
    u32,
    u32,
    Vec<(String, Bound<'py, PyByteArray>)>,
    bool,
);

/// What one render returns to the Python side.
struct Rendered {
    /// `--json`'s object, as JSON text.
    summary: String,
    width: u32,
    height: u32,
    /// The image's channels and the AOV layers', named as the EXR names them.
    channels: Vec<(String, Vec<f32>)>,
    /// Ctrl-C stopped it.
    interrupted: bool,
}

#[pymethods]
impl PyScene {
    /// The scene's TOML document, as vkpath reads it (with the edits).
    #[getter]
    fn toml(&self) -> PyResult<String> {
        toml::to_string(&self.doc).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    /// The document as JSON text (the Python side's dict views).
    fn json(&self) -> PyResult<String> {
        serde_json::to_string(&self.doc).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    #[getter]
    fn width(&self) -> u32 {
        self.scene.image.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.scene.image.height
    }

    #[getter]
    fn material_names(&self) -> Vec<String> {
        self.scene.material_names.clone()
    }

    /// Replaces the document by `json` (the Python side has merged the edit into it) when the scene it
    /// makes reads: else the scene is left as it was and the reader's error is raised.
    fn replace(&mut self, json: &str) -> PyResult<()> {
        let doc = table_from_json(json, "the edited scene")?;
        let scene = self.read(&doc, &self.edited_label()).map_err(py_err)?;
        self.doc = doc;
        self.scene = scene;
        Ok(())
    }

    /// Renders the scene; see `vkpath.Scene.render` (python/vkpath/__init__.py) for the arguments.
    #[pyo3(signature = (spp=None, time=None, target_error=None, seed=None, aovs=Vec::new(), denoise=false, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        spp: Option<u32>,
        time: Option<f64>,
        target_error: Option<f64>,
        seed: Option<u32>,
        aovs: Vec<String>,
        denoise: bool,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<RenderedPy<'py>> {
        let mut scene = self.scene.clone();
        if let Some(n) = spp {
            if n == 0 {
                return Err(value_error("spp must be at least 1."));
            }
            scene.render.samples = n;
        }
        if let Some(s) = seed {
            scene.render.seed = s;
        }
        let time = time
            .map(|t| {
                if t.is_finite() && t > 0.0 && t <= 1e9 {
                    Ok(std::time::Duration::from_secs_f64(t))
                } else {
                    Err(value_error(format!(
                        "time must be a positive number of seconds (at most 1e9), not {t}."
                    )))
                }
            })
            .transpose()?;
        if let Some(e) = target_error
            && !(e.is_finite() && e > 0.0)
        {
            return Err(value_error(format!(
                "target_error must be a positive relative error (e.g. 0.02 for 2%), not {e}."
            )));
        }
        let aovs = if aovs.is_empty() {
            Vec::new()
        } else {
            Aov::parse_list(&aovs.join(","))
                .map_err(|m| value_error(format!("aovs={aovs:?}: {m}.")))?
        };
        let denoise = denoise || scene.image.denoise;
        if !scene.render.settle_splat(denoise) {
            return Err(value_error(
                "the scene asks for splatting (render.splat = true), which does not go with adaptive \
                 sampling (render.adaptive = true): a splatted pixel averages its neighbours' samples, \
                 which adaptive sampling takes in unequal numbers. Set one of them to false \
                 (scene.set(\"render\", splat=False)).",
            ));
        }
        let options = RenderOptions {
            adaptive: AdaptiveSettings::asked(&scene.render.adaptive, target_error),
            ..RenderOptions::default()
        };
        let stop = AtomicBool::new(false);
        // An exception raised by the progress callable, re-raised once the render has stopped.
        let raised: Mutex<Option<PyErr>> = Mutex::new(None);
        let rendered = py.detach(|| -> Result<Option<Rendered>, Error> {
            let ctx = context()?;
            let denoiser = if denoise {
                Some(Denoiser::new(DeviceChoice::for_vulkan(ctx.device_info()))?)
            } else {
                None
            };
            let mut session = Session::start(
                &ctx,
                Request {
                    scene: &scene,
                    options: &options,
                    outputs: &[],
                    checkpoint: None,
                    resume: None,
                    range: None,
                    part: None,
                    aovs: &aovs,
                    denoiser: denoiser.as_ref(),
                    keep_aux: false,
                    time,
                    target_error,
                    progress_every: None,
                    save_every: None,
                },
            )?;
            let target = session.plan().target_spp;
            let (reason, elapsed) = session.run(&stop, |_, report| {
                // Python's own signal handler only records a Ctrl-C: it is seen here, after each pass,
                // and stops the render with what was sampled (as the command line does).
                // A KeyboardInterrupt (Ctrl-C, which may land while the progress callable runs) stops
                // the render with what was sampled; any other exception stops it and is raised.
                Python::attach(|py| {
                    let called = match &progress {
                        Some(f) => f.call1(py, (report.samples_done, target)).map(drop),
                        None => Ok(()),
                    };
                    if let Err(e) = called.and_then(|()| py.check_signals()) {
                        if !e.is_instance_of::<PyKeyboardInterrupt>(py) {
                            *raised.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                        }
                        stop.store(true, Ordering::SeqCst);
                    }
                });
                Ok(())
            })?;
            let Some(film) = session.finish()? else {
                return Ok(None);
            };
            let summary = session.report(&film, reason, elapsed);
            let summary = serde_json::to_value(&summary)
                .map(|v| v.to_string())
                .map_err(|e| Error::Usage(e.to_string()))?;
            let empty = Layers::default();
            let (image, layers) = match session.finished() {
                Some(f) => (f.denoised.as_ref().unwrap_or(&film), &f.layers),
                None => (&film, &empty),
            };
            let channels = ImageFile {
                film: image,
                settings: &scene.image,
                metadata: None,
                layers,
                denoised: None,
            }
            .channels();
            Ok(Some(Rendered {
                summary,
                width: film.width,
                height: film.height,
                channels,
                interrupted: reason == StopReason::Interrupted,
            }))
        });
        if let Some(e) = raised.into_inner().unwrap_or_else(|p| p.into_inner()) {
            return Err(e);
        }
        let Some(r) = rendered.map_err(py_err)? else {
            return Err(PyKeyboardInterrupt::new_err(
                "the render was interrupted before its first pass ended: there is no image.",
            ));
        };
        let channels = r
            .channels
            .iter()
            .map(|(name, values)| {
                (
                    name.clone(),
                    PyByteArray::new(py, bytemuck::cast_slice(values)),
                )
            })
            .collect();
        Ok((r.summary, r.width, r.height, channels, r.interrupted))
    }
}

/// The display settings for `write` and `png`: the scene's (`[image]`), else those of a scene file
/// without an `[image]` table.
fn display_settings(scene: Option<&PyScene>, width: u32, height: u32) -> PyResult<ImageSettings> {
    let mut settings = match scene {
        Some(s) => s.scene.image,
        None => {
            let minimal = "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nfov = 60\n";
            Scene::from_toml_str(minimal, None)
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
                .image
        }
    };
    settings.width = width;
    settings.height = height;
    Ok(settings)
}

/// An image (H x W x 3 f32 values, row-major from the top left) as a film of one sample.
fn film_of(rgb: &[u8], width: u32, height: u32) -> PyResult<Film> {
    let values: Vec<f32> = bytemuck::pod_collect_to_vec(rgb);
    let pixels = width as usize * height as usize;
    if values.len() != 3 * pixels {
        return Err(value_error(format!(
            "the image has {} values, and a {width}x{height} RGB image has {}.",
            values.len(),
            3 * pixels
        )));
    }
    let mean: Vec<[f32; 3]> = values.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    Ok(Film {
        width,
        height,
        spp: 1,
        pixel_spp: Vec::new(),
        variance: vec![[f32::NAN; 3]; pixels],
        mean,
    })
}

/// `vkpath.write`: the image to a PNG (through the display transform) or an EXR (linear, with `layers`
/// as extra channels named as `vkpath render --aov` names them), atomically.
#[pyfunction]
#[pyo3(signature = (path, rgb, width, height, layers, scene=None))]
fn write(
    path: PathBuf,
    rgb: &[u8],
    width: u32,
    height: u32,
    layers: Vec<(String, Vec<u8>)>,
    scene: Option<PyRef<'_, PyScene>>,
) -> PyResult<()> {
    let Some(format) = OutputFormat::from_path(&path) else {
        return Err(value_error(format!(
            "cannot tell the image format of {}: use a .png or .exr extension.",
            path.display()
        )));
    };
    if format == OutputFormat::Png && !layers.is_empty() {
        return Err(value_error(format!(
            "{}: a PNG holds the image alone; write the layers to an .exr file.",
            path.display()
        )));
    }
    let film = film_of(rgb, width, height)?;
    let settings = display_settings(scene.as_deref(), width, height)?;
    let extra = layers
        .into_iter()
        .map(|(name, bytes)| (name, bytemuck::pod_collect_to_vec(&bytes)))
        .collect();
    let layers = Layers {
        extra,
        ..Layers::default()
    };
    vkpath::output::write_images(
        &[path],
        &ImageFile {
            film: &film,
            settings: &settings,
            metadata: None,
            layers: &layers,
            denoised: None,
        },
    )
    .map_err(py_err)
}

/// The PNG file's bytes of an image (the notebook's `_repr_png_`).
#[pyfunction]
#[pyo3(signature = (rgb, width, height, scene=None))]
fn png<'py>(
    py: Python<'py>,
    rgb: &[u8],
    width: u32,
    height: u32,
    scene: Option<PyRef<'_, PyScene>>,
) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
    let film = film_of(rgb, width, height)?;
    let settings = display_settings(scene.as_deref(), width, height)?;
    let bytes = ImageFile {
        film: &film,
        settings: &settings,
        metadata: None,
        layers: &Layers::default(),
        denoised: None,
    }
    .encode(OutputFormat::Png)
    .map_err(PyRuntimeError::new_err)?;
    Ok(pyo3::types::PyBytes::new(py, &bytes))
}

/// An image file's RGB values as `vkpath compare` reads them (EXR: linear f32; PNG: the 8-bit values),
/// with its width and height.
#[pyfunction]
fn read_image<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(Bound<'py, PyByteArray>, u32, u32)> {
    let (w, h, values) = vkpath::compare::read_rgb(&path).map_err(py_err)?;
    Ok((PyByteArray::new(py, bytemuck::cast_slice(&values)), w, h))
}

/// `vkpath compare`'s report of two images' values (f32, the same length) as JSON text.
#[pyfunction]
fn compare(a: &[u8], b: &[u8], width: u32, height: u32) -> PyResult<String> {
    let a: Vec<f32> = bytemuck::pod_collect_to_vec(a);
    let b: Vec<f32> = bytemuck::pod_collect_to_vec(b);
    if a.len() != b.len() {
        return Err(value_error(format!(
            "the images have {} and {} values: only images of the same size can be compared.",
            a.len(),
            b.len()
        )));
    }
    let report = vkpath::compare::compare(width, height, &a, &b);
    serde_json::to_string(&report).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// How many kernels this process has compiled (naga's compile, once per feature set; the driver's own
/// compile of the same SPIR-V is found in its shader cache).
#[pyfunction]
fn kernels_compiled() -> usize {
    vkpath::render::kernels_compiled()
}

#[pymodule]
fn _vkpath(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", vkpath::VKPATH_VERSION)?;
    m.add_class::<PyScene>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(load_dict, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(png, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(kernels_compiled, m)?)?;
    Ok(())
}
