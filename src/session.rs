//! A render session: one render from its first pass to its files on disk, as a library type.
//!
//! [`Session::start`] makes the renderer and decides where this run's samples start and end (from a
//! checkpoint resumed, from a `--sample-range` or `--part`, or from 0); [`Session::run`] runs the
//! progressive passes until the sample budget, the time budget, the target error or a stop request ends
//! them (the stopping rules are `render::render_progressive`'s), rewriting the progress images and the
//! checkpoint on their cadence on the way; [`Session::finish`] writes the final checkpoint, then the
//! images with their AOV layers. The session remembers which of its files are whole on disk, so that a
//! failure part-way can say what to go on from ([`Session::saved_hint`]).
//!
//! `vkpath render` (`cli/render.rs`), and through it every render-farm part, is a session with a command
//! line around it: the command parses and checks the flags, shows a progress bar through
//! [`Session::run`]'s observer, and prints the report. The session writes nothing else and prints
//! nothing: what the caller should tell the user comes back as values (warnings, the plan, the files).
//!
//! It sits above `render`, `checkpoint` and `output` (which it ties together) and below `cli`: the
//! render module knows nothing of files, and checkpoints know the renderer, so a session inside either
//! would make their imports circular.

use crate::Error;
use crate::Scene;
use crate::checkpoint::{Aux, Checkpoint, Part, show_ranges};
use crate::denoise::{Denoiser, Quality};
use crate::film::Film;
use crate::gpu::GpuContext;
use crate::kernel::abi::{AOV_ALBEDO, AOV_DEPTH, AOV_NORMAL};
use crate::output::{Aov, ImageFile, ImageMetadata, Layers, raw_channels, write_images};
use crate::render::{
    AOV_MAX_SPP, Budget, PassReport, RenderOptions, Renderer, SaveEvery, StopReason, render_aov,
    render_progressive,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// What to render, how long, and where to write: everything a session decides from.
pub struct Request<'a> {
    /// The scene, with any command-line overrides already applied.
    pub scene: &'a Scene,
    pub options: &'a RenderOptions,
    /// The images to write (PNG or EXR; all or nothing, at each progress write and at the end).
    pub outputs: &'a [PathBuf],
    /// Where the state is saved (`--checkpoint`, or the file resumed from).
    pub checkpoint: Option<&'a Path>,
    /// The checkpoint resumed, read and checked for damage by the caller (before any device work).
    pub resume: Option<(PathBuf, Checkpoint)>,
    /// `--sample-range A..B`: the samples A..B of the render, alone.
    pub range: Option<[u32; 2]>,
    /// `--part I/N`: its range, recorded in the checkpoint so that `vkpath merge` knows the split.
    pub part: Option<Part>,
    /// The EXR's extra layers.
    pub aovs: &'a [Aov],
    /// Denoise the final images with this (`--denoise`): the albedo and normal layers are rendered for
    /// it whether or not `aovs` asks for them, and the EXR keeps the raw estimate as `raw.R/G/B`.
    pub denoiser: Option<&'a Denoiser>,
    /// The final checkpoint carries the denoiser's aux images (albedo and normal): a part of a render to
    /// be denoised, so that `vkpath merge` can denoise the frame (which needs no denoiser here).
    pub keep_aux: bool,
    /// Stop after the first pass that ends past this duration.
    pub time: Option<Duration>,
    /// Stop once the estimated relative error is below this.
    pub target_error: Option<f64>,
    /// Rewrite the images whenever the sample count reaches a multiple of this.
    pub progress_every: Option<u32>,
    /// How often the checkpoint is rewritten (when there is one).
    pub save_every: Option<SaveEvery>,
}

/// Where this run's samples start and end.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The samples per pixel the render ends with: B - A of a range, else the scene's (or --spp's).
    pub target_spp: u32,
    /// The samples per pixel already in the accumulator when the passes start (from a checkpoint).
    pub resumed_samples: u32,
    /// What the user should know but that does not stop the render (a checkpoint made on another
    /// device).
    pub warnings: Vec<String>,
}

/// What is on disk when a render fails part-way, for the error message: the last checkpoint and the
/// last image written, with their sample counts.
#[derive(Default)]
struct Saved {
    checkpoint: Option<(PathBuf, u32)>,
    /// The images of the last progress write (all of them: they are written all or nothing).
    images: Option<(Vec<PathBuf>, u32)>,
}

impl Saved {
    /// One sentence per file still on disk, to append to the error's paragraph.
    fn hint(&self) -> String {
        let mut s = String::new();
        if let Some((p, n)) = &self.checkpoint {
            s.push_str(&format!(
                " The last checkpoint, {} ({n} samples per pixel), is intact: go on with --resume {}.",
                p.display(),
                p.display()
            ));
        }
        if let Some((paths, n)) = &self.images {
            let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
            s.push_str(&format!(
                " The last progress image{}, {} ({n} samples per pixel), {} intact.",
                if names.len() == 1 { "" } else { "s" },
                names.join(", "),
                if names.len() == 1 { "is" } else { "are" }
            ));
        }
        s
    }
}

/// One render in progress (see the module's documentation).
pub struct Session<'a> {
    options: &'a RenderOptions,
    aovs: &'a [Aov],
    denoiser: Option<&'a Denoiser>,
    /// See [`Request::keep_aux`].
    keep_aux: bool,
    /// A partial render (`--sample-range`, `--part`): its AOV layers are rendered with the whole
    /// render's samples per pixel (up to AOV_MAX_SPP), so that every part has the same ones.
    partial: bool,
    /// Seconds the denoiser took on the final image, once it has run.
    denoise_seconds: Option<f64>,
    budget: Budget,
    renderer: Renderer,
    plan: Plan,
    files: Files<'a>,
    /// What the last [`Session::finish`] made besides the raw film.
    finished: Option<Finished>,
}

/// What [`Session::finish`] makes besides the raw film, kept for callers that hold the images in memory
/// (the Python module) rather than read them back from disk.
pub struct Finished {
    /// The AOV layers, as the EXR holds them (with `raw.R/G/B` in `extra` when denoised).
    pub layers: Layers,
    /// The denoised image, when a denoiser was given.
    pub denoised: Option<Film>,
}

impl<'a> Session<'a> {
    /// Makes the renderer for `request.scene` on `ctx` and plans the samples (see [`plan_samples`]):
    /// a resumed checkpoint is put on the device here, or the refusal says why it does not fit.
    pub fn start(ctx: &Arc<GpuContext>, request: Request<'a>) -> Result<Session<'a>, Error> {
        // What this session holds on the host per pixel, for the renderer's up-front memory check.
        let host = crate::render::host_use::HostUse {
            images: !request.outputs.is_empty(),
            checkpoint: request.checkpoint.is_some() || request.resume.is_some(),
            aov_layers: aov_list(request.aovs, request.denoiser.is_some() || request.keep_aux)
                .iter()
                .filter(|a| !a.from_sums())
                .count() as u32,
            denoise: request.denoiser.is_some(),
        };
        let partial = request.range.is_some();
        let options = RenderOptions {
            host_bytes_per_pixel: host.bytes_per_pixel(),
            ..request.options.clone()
        };
        let mut renderer = Renderer::new(ctx, request.scene, &options)?;
        let resumed_from = request.resume.as_ref().map(|(p, _)| p.clone());
        let plan = plan_samples(
            &mut renderer,
            request.scene,
            request.range,
            request.part,
            request.resume,
        )?;
        let mut saved = Saved::default();
        // Resuming into the file resumed from: that file is the last intact checkpoint until a new one
        // is written.
        if let (Some(c), Some(r)) = (request.checkpoint, &resumed_from)
            && c == r
            && plan.resumed_samples > 0
        {
            saved.checkpoint = Some((c.to_path_buf(), plan.resumed_samples));
        }
        // The driver's own compile (at the first dispatch, on lavapipe) before the clock starts, and
        // after everything that can refuse the request (a checkpoint that does not match).
        renderer.warm_up()?;
        Ok(Session {
            options: request.options,
            aovs: request.aovs,
            denoiser: request.denoiser,
            keep_aux: request.keep_aux,
            partial,
            denoise_seconds: None,
            budget: Budget {
                spp: plan.target_spp,
                time: request.time,
                progress_every: request.progress_every,
                save_every: request.save_every,
                target_error: request.target_error,
            },
            files: Files {
                scene: request.scene,
                outputs: request.outputs,
                checkpoint: request.checkpoint,
                part: request.part,
                saved,
                scene_hash: renderer.identity().scene_hash,
                device: ctx.device_info().name.clone(),
                started: Instant::now(),
            },
            renderer,
            plan,
            finished: None,
        })
    }

    /// Runs passes until the sample budget, the time, the target error or `stop` (Ctrl-C) ends the
    /// render, rewriting the images at every `progress_every` and the checkpoint at every `save_every`
    /// on the way, but not after the last pass: [`Session::finish`] writes those once. `observe` sees
    /// the renderer after every pass, before those writes (a progress bar). How it stopped, and when.
    pub fn run(
        &mut self,
        stop: &AtomicBool,
        mut observe: impl FnMut(&mut Renderer, &PassReport) -> Result<(), Error>,
    ) -> Result<(StopReason, Duration), Error> {
        let target = self.budget.spp;
        let variance = self.aovs.contains(&Aov::Variance);
        let spp = self.aovs.contains(&Aov::Spp);
        let files = &mut self.files;
        render_progressive(
            &mut self.renderer,
            self.options,
            &self.budget,
            stop,
            |r, report| {
                observe(r, report)?;
                let ending = report.samples_done >= target;
                if report.progress && !ending {
                    let film = r.film()?;
                    let layers = Layers {
                        variance,
                        spp,
                        ..Layers::default()
                    };
                    files.write_images(&film, &layers, None)?;
                }
                if report.save_state && !ending {
                    files.save_checkpoint(r, None)?;
                }
                Ok(())
            },
        )
    }

    /// The final state to the checkpoint file, then the final image (with the AOV layers; denoised,
    /// with the raw estimate beside it, when a denoiser was given) to every output: also after an
    /// interrupt, so that the render can go on from there. The film rendered (raw), or `None` when no
    /// pass ended (nothing is written then).
    pub fn finish(&mut self) -> Result<Option<Film>, Error> {
        let film = self.renderer.film()?;
        if film.spp == 0 {
            return Ok(None);
        }
        // The checkpoint first: if an image cannot be written after all, the samples are kept.
        self.files.save_checkpoint(&mut self.renderer, None)?;
        // A part's layers are the whole render's (every part the same: see `partial`).
        let aov_spp = if self.partial {
            self.files.scene.render.samples
        } else {
            film.spp
        };
        let mut layers = aov_layers(
            self.renderer.context(),
            self.files.scene,
            self.options,
            &aov_list(self.aovs, self.denoiser.is_some() || self.keep_aux),
            aov_spp,
        )?;
        if self.keep_aux {
            // Again, with the aux images (the samples are already safe in the first).
            let aux = aux_of(&layers)?;
            let samples = aov_spp.clamp(1, AOV_MAX_SPP);
            self.files
                .save_checkpoint(&mut self.renderer, Some((aux, samples)))?;
        }
        let Some(denoiser) = self.denoiser else {
            self.files.write_images(&film, &layers, None)?;
            self.finished = Some(Finished {
                layers,
                denoised: None,
            });
            return Ok(Some(film));
        };
        let started = Instant::now();
        let denoised = denoiser.denoise_film(&film, &aux_of(&layers)?, Quality::High)?;
        self.denoise_seconds = Some(started.elapsed().as_secs_f64());
        // The aux layers rendered for the denoiser alone are not written.
        if !self.aovs.contains(&Aov::Albedo) {
            layers.albedo = None;
        }
        if !self.aovs.contains(&Aov::Normal) {
            layers.normal = None;
        }
        layers.extra = raw_channels(&film.mean);
        self.files
            .write_images(&denoised, &layers, Some(&denoiser.describe()))?;
        self.finished = Some(Finished {
            layers,
            denoised: Some(denoised),
        });
        Ok(Some(film))
    }

    /// The layers and the denoised image of the last [`Session::finish`] that returned a film.
    pub fn finished(&self) -> Option<&Finished> {
        self.finished.as_ref()
    }

    /// What the render did (`vkpath render --json`'s object), once [`Session::run`] has ended with
    /// `reason` after `elapsed` and [`Session::finish`] has returned `film`. Reads the sample-fault
    /// counters back from the device (a failed read counts none).
    pub fn report(&self, film: &Film, reason: StopReason, elapsed: Duration) -> RenderReport {
        let renderer = &self.renderer;
        let scene = self.files.scene;
        let seconds = elapsed.as_secs_f64();
        let pixels = scene.image.width as f64 * scene.image.height as f64;
        // With adaptive sampling, each pixel's own count (those of a checkpoint resumed taken off).
        let (samples, mean_spp) = match renderer.adaptive() {
            Some(ad) => {
                let all = ad.counts().iter().map(|&n| n as f64).sum::<f64>();
                (all - ad.restored_samples() as f64, all / pixels.max(1.0))
            }
            None => (
                pixels * (film.spp - self.plan.resumed_samples) as f64,
                film.spp as f64,
            ),
        };
        let rel = film.estimated_rel_error();
        let stats = renderer.scene_stats();
        let ctx = renderer.context();
        RenderReport {
            scene: scene.display_name(),
            width: scene.image.width,
            height: scene.image.height,
            spp: film.spp,
            mean_spp,
            adaptive: renderer.adaptive().map(|ad| AdaptiveReport {
                threshold: ad.settings.threshold,
                min_spp: ad.settings.min_spp,
                pixels_active: ad.active().len(),
            }),
            seconds,
            samples_per_second: samples / seconds.max(1e-12),
            estimated_rel_error: rel.is_finite().then_some(rel),
            device: ctx.device_info().name.clone(),
            max_bounces: crate::scene::bounces_as_written(scene.render.max_bounces),
            seed: scene.render.seed,
            stop_reason: reason,
            outputs: self
                .outputs()
                .iter()
                .map(|p| p.display().to_string())
                .collect(),
            validation_errors: ctx.validation_errors().len(),
            triangles: stats.triangles,
            instances: stats.instances,
            bvh_nodes: stats.bvh_nodes,
            bvh_build_ms: stats.bvh_build_ms,
            kernel: kernel_name(renderer.features()),
            features_absent: renderer.features().absent(),
            sample_ranges: renderer.ranges().to_vec(),
            strips: renderer.tile_layout().strips.len(),
            tiles_per_sample: renderer.tiles_per_sample(),
            resumed_spp: self.plan.resumed_samples,
            checkpoint: self.checkpoint().map(|p| p.display().to_string()),
            sample_faults: renderer.sample_faults().unwrap_or_default(),
        }
    }

    /// Seconds the denoiser took on the final image (after [`Session::finish`] with a denoiser).
    pub fn denoise_seconds(&self) -> Option<f64> {
        self.denoise_seconds
    }

    /// One sentence per file still whole on disk (the last checkpoint, the last progress images), to
    /// append to the message of an error part-way.
    pub fn saved_hint(&self) -> String {
        self.files.saved.hint()
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    pub fn scene(&self) -> &Scene {
        self.files.scene
    }

    pub fn outputs(&self) -> &[PathBuf] {
        self.files.outputs
    }

    pub fn checkpoint(&self) -> Option<&Path> {
        self.files.checkpoint
    }

    pub fn part(&self) -> Option<Part> {
        self.files.part
    }
}

/// The session's files: where they go, what their metadata says, and which are whole on disk.
struct Files<'a> {
    /// The scene rendered: its display transform for the images, its name for checkpoints.
    scene: &'a Scene,
    outputs: &'a [PathBuf],
    checkpoint: Option<&'a Path>,
    /// `--part`: recorded in the checkpoint, so that `vkpath merge` knows the split.
    part: Option<Part>,
    saved: Saved,
    /// For the images' metadata: the render's content hash, the device, and when this run's passes
    /// started.
    scene_hash: String,
    device: String,
    started: Instant,
}

impl Files<'_> {
    /// Writes `film` with `layers` to every output, all or nothing, with the render's metadata (and
    /// what denoised the film, when it is denoised), noting them as written.
    fn write_images(
        &mut self,
        film: &Film,
        layers: &Layers,
        denoised: Option<&str>,
    ) -> Result<(), Error> {
        let metadata = ImageMetadata {
            scene: self.scene.display_name(),
            scene_hash: self.scene_hash.clone(),
            spp: film.spp,
            seed: self.scene.render.seed,
            seconds: Some(self.started.elapsed().as_secs_f64()),
            device: self.device.clone(),
        };
        write_images(
            self.outputs,
            &ImageFile {
                film,
                settings: &self.scene.image,
                metadata: Some(&metadata),
                layers,
                denoised,
            },
        )?;
        if !self.outputs.is_empty() {
            self.saved.images = Some((self.outputs.to_vec(), film.spp));
        }
        Ok(())
    }

    /// Writes the renderer's state to the checkpoint file, when there is one (with the denoiser's aux
    /// images and their samples per pixel, when given), noting it as written.
    fn save_checkpoint(&mut self, r: &mut Renderer, aux: Option<(Aux, u32)>) -> Result<(), Error> {
        if let Some(path) = self.checkpoint {
            let mut state = Checkpoint::of(r, self.scene)?;
            state.header.part = self.part;
            if let Some((aux, samples)) = aux {
                state.header.aux_samples = Some(samples);
                state.aux = Some(aux);
            }
            state.write(path)?;
            self.saved.checkpoint = Some((path.to_path_buf(), r.samples_done()));
        }
        Ok(())
    }
}

/// The layers for a render of `spp` samples per pixel: the variance from the render's own sums, the
/// others each rendered by the kernel specialised for it with min(spp, AOV_MAX_SPP) samples.
fn aov_layers(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    options: &RenderOptions,
    list: &[Aov],
    spp: u32,
) -> Result<Layers, Error> {
    let mut layers = Layers {
        variance: list.contains(&Aov::Variance),
        spp: list.contains(&Aov::Spp),
        ..Layers::default()
    };
    let spp = spp.clamp(1, AOV_MAX_SPP);
    for aov in list {
        let (code, slot) = match aov {
            Aov::Albedo => (AOV_ALBEDO, &mut layers.albedo),
            Aov::Normal => (AOV_NORMAL, &mut layers.normal),
            Aov::Depth => (AOV_DEPTH, &mut layers.depth),
            Aov::Variance | Aov::Spp => continue,
        };
        *slot = Some(render_aov(ctx, scene, options, code, spp)?);
    }
    Ok(layers)
}

/// The layers to render: those asked for, and albedo and normal when denoising.
fn aov_list(asked: &[Aov], denoise: bool) -> Vec<Aov> {
    let mut list = asked.to_vec();
    if denoise {
        for aux in [Aov::Albedo, Aov::Normal] {
            if !list.contains(&aux) {
                list.push(aux);
            }
        }
        list.sort();
    }
    list
}

/// The denoiser's aux images from the albedo and normal layers.
fn aux_of(layers: &Layers) -> Result<Aux, Error> {
    let (Some(albedo), Some(normal)) = (&layers.albedo, &layers.normal) else {
        return Err(Error::Denoise(
            "the albedo and normal layers the denoiser needs were not rendered".into(),
        ));
    };
    Ok(Aux::from_films(albedo, normal))
}

/// The refusal of a checkpoint made with another setting of a knob that its state depends on: "this
/// checkpoint {held} {what} and this render {render} ({knob}): resume it with ...".
fn setting_differs(path: &Path, held: &str, what: &str, render: &str, knob: &str) -> Error {
    Error::Checkpoint {
        path: path.to_path_buf(),
        message: format!(
            "this checkpoint {held} {what} and this render {render} ({knob}): resume it with the scene \
             file and flags it was made with."
        ),
    }
}

/// Decides where the samples start: from the checkpoint resumed (which must be of this render, and, for
/// a partial render, of the start of the same `--sample-range` or the same `--part`: anything else would
/// render other samples), at the start of the range, or at 0. Puts the resumed state on the device, and
/// warns when it was computed on another device.
fn plan_samples(
    renderer: &mut Renderer,
    scene: &Scene,
    range: Option<[u32; 2]>,
    part: Option<Part>,
    resumed: Option<(PathBuf, Checkpoint)>,
) -> Result<Plan, Error> {
    let target_spp = match range {
        Some([a0, b0]) => b0 - a0,
        None => scene.render.samples,
    };
    let mut warnings = Vec::new();
    match (&resumed, range) {
        (Some((path, c)), range) => {
            c.check_identity(path, &renderer.identity())?;
            let held = show_ranges(&c.header.ranges);
            let first = c.header.ranges.first().map_or(0, |r| r[0]);
            let refusal = match range {
                Some(_) if part.is_some() && c.header.part != part => Some(format!(
                    "this checkpoint is {}, not part {} of this render: resume each part from its own file.",
                    c.header
                        .part
                        .map_or("not a part of a --part split".into(), |p| format!(
                            "part {}",
                            p.show()
                        )),
                    part.map_or(String::new(), |p| p.show())
                )),
                Some([a0, b0])
                    if c.header.ranges.len() != 1 || first != a0 || c.next_sample() > b0 =>
                {
                    Some(format!(
                        "this checkpoint holds the samples {held}, which is not the start of --sample-range {a0}..{b0}. Resume it with the --sample-range it was made with."
                    ))
                }
                None if first != 0 => Some(format!(
                    "this is a partial render of the samples {held}: resume it with its --sample-range {first}..B, or combine it with the other parts with `vkpath merge`."
                )),
                _ => None,
            };
            if let Some(message) = refusal {
                return Err(Error::Checkpoint {
                    path: path.clone(),
                    message,
                });
            }
            renderer.restore(&c.header.ranges, &c.accum)?;
            match (&c.splat, renderer.splats()) {
                (Some(sums), true) => renderer.restore_splat(sums)?,
                (None, false) => {}
                (held, splats) => {
                    return Err(setting_differs(
                        path,
                        if held.is_some() { "holds" } else { "has no" },
                        "splatted sums",
                        if splats { "splats" } else { "does not splat" },
                        "render.splat",
                    ));
                }
            }
            match (&c.adaptive, renderer.adaptive().is_some()) {
                (Some(counts), true) => renderer.restore_adaptive(counts)?,
                (None, false) => {}
                (held, adaptive) => {
                    return Err(setting_differs(
                        path,
                        if held.is_some() { "is" } else { "is not" },
                        "of an adaptive render",
                        if adaptive {
                            "samples adaptively"
                        } else {
                            "does not"
                        },
                        "render.adaptive, --adaptive",
                    ));
                }
            }
            let device = &renderer.context().device_info().name;
            if &c.header.device != device {
                warnings.push(format!(
                    "the checkpoint was computed on {}, this render runs on {device}; the image is a valid estimate, but bit-for-bit equality with an uninterrupted render is promised only on the same device.",
                    c.header.device
                ));
            }
        }
        (None, Some([a0, _])) => renderer.start_at(a0)?,
        (None, None) => {}
    }
    // `resumed` (the whole state, as large as the accumulator) is freed here, before the passes.
    Ok(Plan {
        target_spp,
        resumed_samples: renderer.samples_done(),
        warnings,
    })
}

/// Which kernel a renderer runs, for reports: specialised and generic kernels give the same bits.
pub fn kernel_name(features: &crate::kernel::features::FeatureSet) -> &'static str {
    if features.is_generic() {
        "generic"
    } else {
        "specialised"
    }
}

/// `vkpath render --json` (and a Python render's `summary`): what was rendered, how fast, how it ended, and how the work was cut.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderReport {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel in the image, resumed ones included (with adaptive sampling, the most any
    /// pixel took).
    pub spp: u32,
    /// The mean over the pixels of their samples (`spp` unless adaptive sampling stopped some early).
    pub mean_spp: f64,
    /// Adaptive sampling's threshold and the pixels still sampling when the render ended; `null`
    /// without adaptive sampling.
    pub adaptive: Option<AdaptiveReport>,
    pub seconds: f64,
    /// Samples traced by this run (not the resumed ones) per second.
    pub samples_per_second: f64,
    /// `null` where the film has no estimate: below 2 samples per pixel, or for a black image.
    pub estimated_rel_error: Option<f64>,
    pub device: String,
    /// -1: no limit.
    pub max_bounces: i64,
    pub seed: u32,
    pub stop_reason: StopReason,
    pub outputs: Vec<String>,
    /// How many errors the validation layer reported (VKPATH_VALIDATION).
    pub validation_errors: usize,
    /// Triangles uploaded (an instanced mesh's once, however many placements it has).
    pub triangles: usize,
    /// Placements of instanced meshes (0 in a scene without).
    pub instances: usize,
    pub bvh_nodes: usize,
    pub bvh_build_ms: f64,
    /// [`kernel_name`].
    pub kernel: &'static str,
    pub features_absent: Vec<&'static str>,
    pub sample_ranges: Vec<[u32; 2]>,
    pub strips: usize,
    pub tiles_per_sample: usize,
    /// Samples per pixel taken from the checkpoint resumed (0 when none).
    pub resumed_spp: u32,
    pub checkpoint: Option<String>,
    /// Samples of this run that the accumulator clamped (radiance of 2^64 or more) or dropped as not
    /// finite: both 0 in a sane scene (see accumulate.wgsl).
    pub sample_faults: crate::render::SampleFaults,
}

/// Adaptive sampling in [`RenderReport`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct AdaptiveReport {
    pub threshold: f64,
    pub min_spp: u32,
    /// Pixels still sampling at the end (0 when every pixel met the threshold).
    pub pixels_active: usize,
}
