//! `vkpath preview` (feature `preview`): a window that shows the progressive accumulation as it
//! converges.
//!
//! Two threads share one Vulkan context and queue:
//! - the render thread runs passes of one sample per pixel and, every [`PUBLISH_INTERVAL`] (and after
//!   the first sample), reads the film back and turns it into the 8-bit image with the PNG's display
//!   transform ([`Film::to_rgb8`]): that image is what the window shows and what `--screenshot` saves;
//! - the main thread runs the window (winit) and presents the latest image at up to
//!   [`PreviewSettings::max_presents_per_second`], whether or not a new one has arrived.
//!
//! D toggles the denoised view: the render thread then also denoises the film it publishes (Intel Open
//! Image Denoise at its `Balanced` quality, with albedo and normal layers rendered once per camera), no
//! more often than every [`DENOISE_BUDGET`] times the last denoise's own duration, so that denoising
//! takes at most a fifth of the render thread's time; the samples go on accumulating raw.
//!
//! They never wait for each other for long: the image is cut into strips of a few rows
//! (`RenderOptions::max_tile`), each strip's sample is its own queue submission, so a present's copy
//! waits at most one strip's work in the shared queue; the film is read back on the render thread.

pub mod control;

use crate::Error;
use crate::film::Film;
use crate::gpu::present::{Capture, Presented, Presenter, WindowHandles};
use crate::gpu::{ContextOptions, GpuContext, GpuError};
use crate::render::{RenderOptions, Renderer};
use crate::scene::{Camera, Scene};
use control::{Action, Step};
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// How often the render thread reads the film back for the window. A read-back costs a copy of the
/// accumulator and the display transform (tens of milliseconds at 512x512 on lavapipe), so doing it
/// after every pass would take a good part of the tracing time; four images a second look fluid
/// enough for an image that converges.
pub const PUBLISH_INTERVAL: Duration = Duration::from_millis(250);

/// The denoised view's pacing: after a denoise that took t, the next waits until 4 t have passed, so
/// that denoising takes at most t / (t + 4 t) = 1/5 of the render thread (OIDN takes seconds at 512x512
/// on two CPU cores, milliseconds on a GPU: the rule adapts to both).
pub const DENOISE_BUDGET: u32 = 4;

/// Samples per pixel of the aux layers the denoised view renders per camera (antialiased enough for
/// the network; cheap next to the render).
const PREVIEW_AUX_SPP: u32 = 8;

/// The pixels of one strip of rows (one queue submission per sample, see the module comment): a few
/// milliseconds of work on lavapipe for the course scene, so a present waits at most that long behind
/// the renderer. Smaller strips keep a present waiting less (larger ones, at 512x512 on lavapipe, kept it
/// waiting tens of milliseconds), at the price of throughput: many submissions per sample trace fewer
/// samples/s than `vkpath render` does (docs/performance.md has the measurements, with their dates). On a
/// GPU it only means a few more (cheap) submissions.
const STRIP_PIXELS: u32 = 8 * 1024;

/// What `vkpath preview` was asked to do.
#[derive(Clone, Debug)]
pub struct PreviewSettings {
    pub scene: Scene,
    pub options: RenderOptions,
    /// Stop accumulating at this many samples per pixel (the window stays open); `None`: never stop.
    pub max_spp: Option<u32>,
    /// Exit after this many presents of a rendered image (`--frames`).
    pub frames: Option<u64>,
    /// Save what the last present showed here as PNG when exiting (`--screenshot`): the window's
    /// pixels where the image was, read back from the swapchain (at the window's scale), or, on a
    /// device whose swapchain cannot be read, the image as uploaded.
    pub screenshot: Option<PathBuf>,
    /// Scripted actions (`--script`), for tests.
    pub script: Vec<Step>,
    /// Where S saves: `<save_dir>/<scene stem>-<spp>spp.png` and `.exr`.
    pub save_dir: PathBuf,
    /// The presents per second the window aims at (it presents the latest image again while the
    /// renderer works, so that resizes and drags show at once).
    pub max_presents_per_second: f64,
}

/// What a preview did, for `--json` and the tests.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PreviewReport {
    pub scene: String,
    pub device: String,
    /// The image size (the window shows it scaled to fit).
    pub width: u32,
    pub height: u32,
    /// Presents of a rendered image.
    pub presents: u64,
    /// Presents per second, from the first present to the last.
    pub presents_per_second: f64,
    /// The longest time between two presents, in milliseconds (after the first image).
    pub longest_present_gap_ms: f64,
    /// Distinct images (new sample counts or restarts) shown.
    pub images_shown: u64,
    /// Samples per pixel of the image shown last (what `--screenshot` saved).
    pub spp: u32,
    /// Samples per second traced since the last restart.
    pub samples_per_second: f64,
    /// The estimated relative error of the image shown last (`None` below 2 spp).
    pub estimated_rel_error: Option<f64>,
    pub restarts: u32,
    pub resizes: u32,
    /// The window's last size in pixels.
    pub window: [u32; 2],
    pub screenshot: Option<PathBuf>,
    /// Where the screenshot's pixels came from: "swapchain" (read back from the window's swapchain
    /// image) or "image" (the image as uploaded, when the swapchain cannot be read).
    pub screenshot_source: Option<String>,
    /// Files written by S (or a scripted save).
    pub saved: Vec<PathBuf>,
    /// Saves that failed, with why.
    pub save_errors: Vec<String>,
    pub seconds: f64,
    /// Whether the Vulkan validation layer was on (`VKPATH_VALIDATION=1`).
    pub validation: bool,
    /// Messages of the Vulkan validation layer (when enabled), errors only.
    pub validation_errors: Vec<String>,
    /// Denoised images shown (D, or a scripted `denoise`).
    pub denoised_images_shown: u64,
    /// Why the denoised view could not be shown, when it could not (no denoiser installed).
    pub denoise_error: Option<String>,
}

/// One image from the render thread.
struct Frame {
    /// `to_rgb8` of `film`: what is shown and what the screenshot saves.
    rgb: image::RgbImage,
    /// The same bytes with an opaque alpha, as uploaded.
    rgba: Vec<u8>,
    film: Film,
    /// Counts every image published (so that a restart at the same spp still shows as new).
    serial: u64,
    samples_per_second: f64,
    /// The image is the denoised film (`film` stays the raw one).
    denoised: bool,
}

/// What the two threads share.
#[derive(Default)]
struct Shared {
    frame: Option<Arc<Frame>>,
    /// Requests from the window to the render thread.
    restart: bool,
    camera: Option<Camera>,
    /// Whether the window wants the denoised view (D).
    denoise: bool,
    /// Why the denoised view is not available (the render thread could not load the denoiser).
    denoise_error: Option<String>,
    quit: bool,
    /// The render thread's failure; the window then closes and `run` returns it.
    error: Option<Error>,
}

fn lock(shared: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    // A poisoned lock means the other thread panicked; its data is still a consistent snapshot.
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

/// Opens the window and runs until it is closed (Esc, Q, the window's close button) or `--frames`
/// presents are done.
pub fn run(settings: PreviewSettings) -> Result<PreviewReport, Error> {
    let event_loop = EventLoop::new().map_err(|e| no_window(&e.to_string()))?;
    let mut app = App::new(settings);
    let ran = event_loop.run_app(&mut app);
    let report = app.finish();
    ran.map_err(|e| no_window(&e.to_string()))?;
    report
}

fn no_window(why: &str) -> Error {
    Error::Gpu(GpuError::Limit(format!(
        "cannot open a window ({why}). The preview needs an X11 display: set DISPLAY to a running X \
         server (or run it under `xvfb-run -a`), or use `vkpath render --progress-every N` and watch the \
         output file."
    )))
}

/// The window side: window, presenter, input, pacing.
struct App {
    settings: PreviewSettings,
    // Field order is drop order: the presenter (swapchain) before the context, the context (surface)
    // before the window.
    presenter: Option<Presenter>,
    ctx: Option<Arc<GpuContext>>,
    window: Option<Window>,
    shared: Arc<Mutex<Shared>>,
    render_thread: Option<JoinHandle<()>>,
    saves: Vec<JoinHandle<Result<Vec<PathBuf>, String>>>,
    /// The camera as orbited so far.
    camera: Camera,
    shown: Option<Arc<Frame>>,
    next_present: Instant,
    first_present: Option<Instant>,
    last_present: Option<Instant>,
    last_title: Instant,
    /// A message shown in the title for a few seconds (e.g. what S saved).
    notice: Option<(String, Instant)>,
    drag: Option<PhysicalPosition<f64>>,
    cursor: PhysicalPosition<f64>,
    mouse_down: bool,
    next_step: usize,
    /// The last present's pixels, read back from the swapchain (for `--screenshot`).
    capture: Option<Capture>,
    capture_requested: bool,
    report: PreviewReport,
    error: Option<Error>,
    started: Instant,
}

impl App {
    fn new(settings: PreviewSettings) -> App {
        let report = PreviewReport {
            scene: settings.scene.display_name(),
            width: settings.scene.image.width,
            height: settings.scene.image.height,
            ..Default::default()
        };
        App {
            camera: settings.scene.camera,
            settings,
            presenter: None,
            ctx: None,
            window: None,
            shared: Arc::new(Mutex::new(Shared::default())),
            render_thread: None,
            saves: Vec::new(),
            shown: None,
            next_present: Instant::now(),
            first_present: None,
            last_present: None,
            last_title: Instant::now(),
            notice: None,
            drag: None,
            cursor: PhysicalPosition::new(0.0, 0.0),
            mouse_down: false,
            next_step: 0,
            capture: None,
            capture_requested: false,
            report,
            error: None,
            started: Instant::now(),
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    /// Creates the window, the context on it, the presenter and the render thread.
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Error> {
        let [w, h] = [
            self.settings.scene.image.width,
            self.settings.scene.image.height,
        ];
        // The window starts at the image's size (1:1), within reason for a screen.
        let scale = (1024.0 / w.max(h) as f64).min(1.0);
        let size = PhysicalSize::new(
            ((w as f64 * scale).round() as u32).max(1),
            ((h as f64 * scale).round() as u32).max(1),
        );
        let window = event_loop
            .create_window(
                Window::default_attributes()
                    .with_title(format!("vkpath preview: {}", self.report.scene))
                    .with_inner_size(size),
            )
            .map_err(|e| no_window(&e.to_string()))?;
        let handles = WindowHandles {
            display: window
                .display_handle()
                .map_err(|e| no_window(&e.to_string()))?
                .as_raw(),
            window: window
                .window_handle()
                .map_err(|e| no_window(&e.to_string()))?
                .as_raw(),
        };
        let inner = window.inner_size();
        self.window = Some(window);
        let ctx = GpuContext::new(&ContextOptions {
            window: Some(handles),
            ..Default::default()
        })?;
        self.report.device = ctx.device_info().name.clone();
        self.report.window = [inner.width, inner.height];
        self.presenter = Some(Presenter::new(&ctx, [inner.width, inner.height])?);
        let thread_ctx = ctx.clone();
        self.ctx = Some(ctx);
        let shared = self.shared.clone();
        let scene = self.settings.scene.clone();
        let mut options = self.settings.options.clone();
        let rows = (STRIP_PIXELS / w.max(1)).clamp(1, h.max(1));
        options.max_tile = Some(match options.max_tile {
            Some([tw, th]) => [tw, th.min(rows)],
            None => [w, rows],
        });
        let max_spp = self.settings.max_spp;
        let spawned = std::thread::Builder::new()
            .name("vkpath render".into())
            .spawn(move || {
                if let Err(e) = render_loop(&thread_ctx, scene, &options, max_spp, &shared) {
                    lock(&shared).error = Some(e);
                }
            })
            .map_err(|e| Error::Usage(format!("cannot start the render thread: {e}")))?;
        self.render_thread = Some(spawned);
        Ok(())
    }

    /// Presents the latest image if one is due; runs the script and `--frames`.
    fn tick(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Error> {
        let (frame, error) = {
            let mut s = lock(&self.shared);
            (s.frame.clone(), s.error.take())
        };
        if let Some(e) = error {
            return Err(e);
        }
        let now = Instant::now();
        if now < self.next_present {
            return Ok(());
        }
        let interval = Duration::from_secs_f64(1.0 / self.settings.max_presents_per_second);
        // Catch up with the clock without bursting after a stall.
        self.next_present = (self.next_present + interval).max(now);
        let Some(frame) = frame else {
            return Ok(()); // nothing rendered yet
        };
        let is_new = self.shown.as_ref().map(|f| f.serial) != Some(frame.serial);
        let Some(presenter) = self.presenter.as_mut() else {
            return Ok(());
        };
        let last = self
            .settings
            .frames
            .is_some_and(|n| self.report.presents + 1 >= n);
        if last && self.settings.screenshot.is_some() && !self.capture_requested {
            self.capture_requested = presenter.request_capture()?;
        }
        let upload = is_new.then(|| {
            (
                frame.rgba.as_slice(),
                [frame.rgb.width(), frame.rgb.height()],
            )
        });
        if presenter.present(upload)? == Presented::Skipped {
            return Ok(());
        }
        if is_new {
            self.report.images_shown += 1;
            if frame.denoised {
                self.report.denoised_images_shown += 1;
            }
        }
        if last && self.capture_requested {
            self.capture = presenter.take_capture()?;
        }
        self.shown = Some(frame);
        self.report.presents += 1;
        let now = Instant::now();
        if let Some(last) = self.last_present {
            let gap = (now - last).as_secs_f64() * 1e3;
            self.report.longest_present_gap_ms = self.report.longest_present_gap_ms.max(gap);
        }
        self.first_present.get_or_insert(now);
        self.last_present = Some(now);
        self.update_title(false);
        while let Some(step) = self.settings.script.get(self.next_step) {
            if step.at > self.report.presents {
                break;
            }
            let action = step.action.clone();
            self.next_step += 1;
            self.act(&action);
        }
        if self
            .settings
            .frames
            .is_some_and(|n| self.report.presents >= n)
        {
            event_loop.exit();
        }
        Ok(())
    }

    fn act(&mut self, action: &Action) {
        match *action {
            Action::Restart => {
                lock(&self.shared).restart = true;
                self.report.restarts += 1;
            }
            Action::Orbit(az, el) => self.orbit(az, el),
            Action::Save => self.save(),
            Action::Denoise => {
                let on = {
                    let mut s = lock(&self.shared);
                    s.denoise = !s.denoise;
                    s.denoise
                };
                self.notice(
                    if on {
                        "denoised view (D)"
                    } else {
                        "raw view (D)"
                    }
                    .into(),
                );
            }
            Action::Resize(w, h) => {
                if let Some(window) = &self.window {
                    // The Resized event follows (or the size is applied at once: then none is sent).
                    if let Some(size) = window.request_inner_size(PhysicalSize::new(w, h)) {
                        self.resized(size);
                    }
                }
            }
        }
    }

    fn resized(&mut self, size: PhysicalSize<u32>) {
        if let Some(p) = self.presenter.as_mut() {
            p.resize([size.width, size.height]);
        }
        if self.report.window != [size.width, size.height] {
            self.report.resizes += 1;
            self.report.window = [size.width, size.height];
        }
        // Show the current image at the new size at once.
        self.next_present = Instant::now();
    }

    fn orbit(&mut self, azimuth_deg: f32, elevation_deg: f32) {
        self.camera = control::orbit(&self.camera, azimuth_deg, elevation_deg);
        // The render thread takes the latest camera before its next pass (drags coalesce).
        lock(&self.shared).camera = Some(self.camera);
    }

    /// S: writes the image shown (PNG, the same bytes) and its film (EXR, linear) on a thread of its
    /// own, so that neither the window nor the accumulation waits for the encoders.
    fn save(&mut self) {
        let Some(frame) = self.shown.clone() else {
            self.notice("nothing to save yet".into());
            return;
        };
        let stem = format!("{}-{}spp", self.settings.scene.stem(), frame.film.spp);
        let png = self.settings.save_dir.join(format!("{stem}.png"));
        let exr = self.settings.save_dir.join(format!("{stem}.exr"));
        let image = self.settings.scene.image;
        self.notice(format!("saving {}", png.display()));
        let dir = self.settings.save_dir.clone();
        self.saves.push(std::thread::spawn(move || {
            std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            write_png(&frame.rgb, &png).map_err(|e| e.to_string())?;
            frame.film.write(&exr, &image).map_err(|e| e.to_string())?;
            Ok(vec![png, exr])
        }));
    }

    fn notice(&mut self, text: String) {
        self.notice = Some((text, Instant::now()));
        self.update_title(true);
    }

    /// The title bar is the overlay: samples per pixel, samples per second, the estimated error, the
    /// presents per second, and the last notice. Updated a few times a second at most.
    fn update_title(&mut self, now: bool) {
        if !now && self.last_title.elapsed() < Duration::from_millis(250) {
            return;
        }
        self.last_title = Instant::now();
        let (Some(window), Some(frame)) = (&self.window, &self.shown) else {
            return;
        };
        let rel = frame.film.estimated_rel_error();
        let error = if rel.is_finite() {
            format!(" | error ~{:.1}%", rel * 100.0)
        } else {
            String::new()
        };
        let notice = match &self.notice {
            Some((text, at)) if at.elapsed() < Duration::from_secs(4) => format!(" | {text}"),
            _ => String::new(),
        };
        let denoise_error = lock(&self.shared).denoise_error.clone();
        let view = match (&denoise_error, frame.denoised) {
            (Some(_), _) => " | denoising not available (see stderr)",
            (None, true) => " | denoised",
            (None, false) => "",
        };
        window.set_title(&format!(
            "vkpath preview: {} | {} spp{view} | {:.2} Msamples/s{error} | {:.0} presents/s{notice}",
            self.report.scene,
            frame.film.spp,
            frame.samples_per_second / 1e6,
            self.presents_per_second()
        ));
    }

    fn presents_per_second(&self) -> f64 {
        match (self.first_present, self.last_present) {
            (Some(a), Some(b)) if b > a => {
                (self.report.presents - 1) as f64 / (b - a).as_secs_f64()
            }
            _ => 0.0,
        }
    }

    /// Stops the render thread, waits for saves, writes the screenshot, and fills in the report.
    fn finish(&mut self) -> Result<PreviewReport, Error> {
        lock(&self.shared).quit = true;
        // The render thread ends after the pass in flight (up to a second at 512x512 on lavapipe):
        // hide the window now, so that quitting looks immediate.
        if let Some(w) = &self.window {
            w.set_visible(false);
        }
        if let Some(t) = self.render_thread.take() {
            let _ = t.join();
        }
        for s in self.saves.drain(..) {
            match s.join() {
                Ok(Ok(paths)) => self.report.saved.extend(paths),
                Ok(Err(e)) => self.report.save_errors.push(e),
                Err(_) => self
                    .report
                    .save_errors
                    .push("the save thread panicked".into()),
            }
        }
        let thread_error = lock(&self.shared).error.take();
        self.report.denoise_error = lock(&self.shared).denoise_error.take();
        if let Some(e) = self.error.take().or(thread_error) {
            return Err(e);
        }
        if let Some(path) = &self.settings.screenshot {
            let Some(frame) = &self.shown else {
                return Err(Error::Usage(
                    "the window was closed before it showed an image, so there is no screenshot to \
                     save; let it run longer (--frames N with N at least 1)."
                        .into(),
                ));
            };
            let captured = self
                .capture
                .take()
                .and_then(|c| image::RgbImage::from_raw(c.width, c.height, c.rgb));
            let source = match &captured {
                Some(_) => "swapchain",
                None => "image",
            };
            write_png(captured.as_ref().unwrap_or(&frame.rgb), path)?;
            self.report.screenshot = Some(path.clone());
            self.report.screenshot_source = Some(source.into());
        }
        if let Some(frame) = &self.shown {
            self.report.spp = frame.film.spp;
            self.report.samples_per_second = frame.samples_per_second;
            let rel = frame.film.estimated_rel_error();
            self.report.estimated_rel_error = rel.is_finite().then_some(rel);
        }
        self.report.presents_per_second = self.presents_per_second();
        self.report.seconds = self.started.elapsed().as_secs_f64();
        // Everything on the device is done (the render thread has ended): drop the swapchain, read
        // the validation messages, then let the context go.
        self.presenter = None;
        if let Some(ctx) = self.ctx.take() {
            self.report.validation = ctx.validation_enabled();
            self.report.validation_errors = ctx.validation_errors();
        }
        Ok(self.report.clone())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        if let Err(e) = self.open(event_loop) {
            self.fail(event_loop, e);
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => self.resized(size),
            WindowEvent::RedrawRequested => self.next_present = Instant::now(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Escape) => event_loop.exit(),
                    Key::Character(c) if c.eq_ignore_ascii_case("q") => event_loop.exit(),
                    Key::Character(c) if c.eq_ignore_ascii_case("r") && !event.repeat => {
                        self.act(&Action::Restart)
                    }
                    Key::Character(c) if c.eq_ignore_ascii_case("s") && !event.repeat => {
                        self.act(&Action::Save)
                    }
                    Key::Character(c) if c.eq_ignore_ascii_case("d") && !event.repeat => {
                        self.act(&Action::Denoise)
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                self.mouse_down = state == ElementState::Pressed;
                self.drag = self.mouse_down.then_some(self.cursor);
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = position;
                if let Some(from) = self.drag {
                    let dx = (position.x - from.x) as f32;
                    let dy = (position.y - from.y) as f32;
                    // Drag right: the camera moves left around the subject (the scene turns with the
                    // hand); drag up: the camera rises.
                    self.orbit(
                        -dx * control::DEGREES_PER_PIXEL,
                        dy * control::DEGREES_PER_PIXEL,
                    );
                    self.drag = Some(position);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            return;
        }
        if let Err(e) = self.tick(event_loop) {
            self.fail(event_loop, e);
            return;
        }
        event_loop.set_control_flow(ControlFlow::WaitUntil(self.next_present));
    }
}

/// Writes an 8-bit RGB image as PNG, atomically.
fn write_png(rgb: &image::RgbImage, path: &Path) -> Result<(), Error> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    rgb.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| Error::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    crate::fs_atomic::write_atomically(path, bytes.get_ref())
}

/// The render thread: passes of one sample per pixel, an image published every [`PUBLISH_INTERVAL`],
/// restarts and camera changes between passes.
fn render_loop(
    ctx: &Arc<GpuContext>,
    mut scene: Scene,
    options: &RenderOptions,
    max_spp: Option<u32>,
    shared: &Mutex<Shared>,
) -> Result<(), Error> {
    let mut renderer = Renderer::new(ctx, &scene, options)?;
    let mut serial = 0u64;
    let mut last_publish: Option<Instant> = None;
    let mut tracing = Duration::ZERO;
    let mut view = DenoisedView::default();
    // Whether the last image published was asked to be denoised (D).
    let mut published_denoise = false;
    loop {
        let (quit, restart, camera, denoise) = {
            let mut s = lock(shared);
            (
                s.quit,
                std::mem::take(&mut s.restart),
                s.camera.take(),
                s.denoise,
            )
        };
        if quit {
            return Ok(());
        }
        if let Some(c) = camera {
            // A new camera is a new render: rebuilding the renderer keeps everything derived from the
            // scene consistent (the kernel and pipeline come from the caches).
            scene.camera = c;
            drop(renderer);
            renderer = Renderer::new(ctx, &scene, options)?;
            view.aux = None;
        } else if restart {
            renderer.reset()?;
        }
        if camera.is_some() || restart {
            last_publish = None;
            tracing = Duration::ZERO;
        }
        let done = renderer.samples_done();
        // D pressed since the last image: publish again, also once the samples have stopped.
        let toggled = done > 0 && denoise != published_denoise;
        let stopped = max_spp.is_some_and(|m| done >= m);
        if stopped && !toggled {
            std::thread::sleep(Duration::from_millis(20));
            continue;
        }
        if !stopped {
            let t0 = Instant::now();
            renderer.run_pass(1)?;
            tracing += t0.elapsed();
        }
        let done = renderer.samples_done();
        let finished = max_spp.is_some_and(|m| done >= m);
        let due =
            last_publish.is_none_or(|t| t.elapsed() >= PUBLISH_INTERVAL) || finished || toggled;
        if due {
            let film = renderer.film()?;
            let denoised = if denoise {
                view.denoise(ctx, &scene, options, &film, finished, shared)?
            } else {
                None
            };
            published_denoise = denoise;
            let rgb = match &denoised {
                Some(d) => d.to_rgb8(&scene.image),
                None => film.to_rgb8(&scene.image),
            };
            let rgba = rgb.pixels().flat_map(|p| [p[0], p[1], p[2], 255]).collect();
            let pixels = f64::from(film.width) * f64::from(film.height);
            serial += 1;
            let frame = Frame {
                rgb,
                rgba,
                samples_per_second: pixels * f64::from(done) / tracing.as_secs_f64().max(1e-9),
                film,
                serial,
                denoised: denoised.is_some(),
            };
            lock(shared).frame = Some(Arc::new(frame));
            last_publish = Some(Instant::now());
        }
    }
}

/// The render thread's denoised view: the denoiser (loaded on the first D), the aux images of the current
/// camera, and the pacing (see the module's documentation).
#[derive(Default)]
struct DenoisedView {
    denoiser: Option<crate::denoise::Denoiser>,
    /// The load failed: said once, then the raw view goes on.
    unavailable: bool,
    aux: Option<crate::checkpoint::Aux>,
    /// The last denoise: when it ended, how long it took, and its image with the spp it was made at.
    last: Option<(Instant, Duration, Film)>,
}

impl DenoisedView {
    /// The denoised image of `film` when one is due (or the last one, while the next is not due; a
    /// `last` film, after which no other comes, is always denoised itself), `None` when denoising is not
    /// available.
    fn denoise(
        &mut self,
        ctx: &Arc<GpuContext>,
        scene: &Scene,
        options: &RenderOptions,
        film: &Film,
        last: bool,
        shared: &Mutex<Shared>,
    ) -> Result<Option<Film>, Error> {
        if self.unavailable {
            return Ok(None);
        }
        if self.denoiser.is_none() {
            match crate::denoise::Denoiser::new(crate::denoise::DeviceChoice::for_vulkan(
                ctx.device_info(),
            )) {
                Ok(d) => self.denoiser = Some(d),
                Err(e) => {
                    eprintln!("vkpath: warning: the denoised view (D) is not available: {e}");
                    lock(shared).denoise_error = Some(e.to_string());
                    self.unavailable = true;
                    return Ok(None);
                }
            }
        }
        if let Some((at, took, image)) = &self.last
            && image.spp <= film.spp
            && (!last || image.spp == film.spp)
            && image.width == film.width
            && at.elapsed() < *took * DENOISE_BUDGET
            && self.aux.is_some()
        {
            return Ok(Some(image.clone()));
        }
        let started = Instant::now();
        if self.aux.is_none() {
            let aux_options = RenderOptions {
                max_tile: None,
                ..options.clone()
            };
            let layer =
                |code| crate::render::render_aov(ctx, scene, &aux_options, code, PREVIEW_AUX_SPP);
            let albedo = layer(crate::kernel::abi::AOV_ALBEDO)?;
            let normal = layer(crate::kernel::abi::AOV_NORMAL)?;
            self.aux = Some(crate::checkpoint::Aux::from_films(&albedo, &normal));
            self.last = None;
        }
        let (Some(d), Some(aux)) = (&self.denoiser, &self.aux) else {
            return Ok(None);
        };
        let image = d.denoise_film(film, aux, crate::denoise::Quality::Balanced)?;
        self.last = Some((Instant::now(), started.elapsed(), image.clone()));
        Ok(Some(image))
    }
}
