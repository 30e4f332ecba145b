//! `vkpath bench convergence`: how fast each renderer setting approaches the converged image.
//!
//! For every setting (a combination of knob values, see [`KNOBS`]) one renderer renders progressively,
//! and at 1, 2, 4, … samples per pixel the film is read back and compared with a reference. Time is
//! the cumulative time of the passes (each [`Renderer::run_pass`] waits for its samples), as a user's
//! progressive render spends it: kernel compilation, readbacks and the comparisons are not counted.
//!
//! The error of an image I against a reference R (linear radiance, all pixels p and channels c, n of
//! them) is measured three ways:
//! - RMSE = sqrt(Σ (I − R)² / n);
//! - relative error = RMSE / mean(R), the quantity `--json`'s `estimated_rel_error` estimates from the
//!   image's own per-pixel variances (printed next to it);
//! - relative MSE = Σ (I − R)² / (R² + ε) / n with ε = 10⁻², the per-pixel relative measure of the
//!   denoising literature, which weighs dark regions as much as bright ones.
//!
//! And one perceptual measure, SSIM (Wang, Bovik, Sheikh & Simoncelli 2004, "Image quality assessment:
//! from error visibility to structural similarity"), of the displayed images (the scene's exposure, tone
//! curve and gamma; luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the encoded values), with the paper's
//! 11-tap Gaussian window (σ = 1.5) and constants C₁ = (0.01)², C₂ = (0.03)²: the mean over pixels of
//! (2 μ_I μ_R + C₁)(2 σ_IR + C₂) / ((μ_I² + μ_R² + C₁)(σ_I² + σ_R² + C₂)). Why SSIM: a denoiser trades
//! noise for blur, and MSE counts a blurred edge as little as a little noise, where a viewer sees lost
//! detail; SSIM compares local structure (contrast and correlation), so it penalises both. It is the
//! measure the denoising papers and OIDN's own evaluations report beside relative MSE.
//!
//! For an unbiased setting the expected squared error is Var(I) + Var(R), and Var(I) falls as 1/N, so
//! the relative error falls as 1/√N (a line of slope −½ on the log-log plot) down to the reference's own
//! noise. A biased setting (fewer bounces) flattens out at its bias instead.
//!
//! With `--denoise`, each setting has a second curve, "LABEL denoised": at each sample count, the image
//! `vkpath render --denoise` would write at that count (the albedo and normal layers rendered with
//! min(N, 64) samples, then Intel Open Image Denoise), its time the passes' plus the aux passes' plus the
//! denoiser's (the kernels' compilation, as for the raw curve, not counted).

use crate::Error;
use crate::checkpoint::Aux;
use crate::denoise::{Denoiser, Quality};
use crate::film::Film;
use crate::gpu::GpuContext;
use crate::kernel::abi::{AOV_ALBEDO, AOV_NORMAL};
use crate::render::AOV_MAX_SPP;
use crate::render::{RenderOptions, Renderer};
use crate::scene::{Gamma, ImageSettings, LightSampling, Sampler, Scene};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// ε of the relative MSE, in units of linear radiance.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// The reference is rendered with the scene's seed XOR this, so that its samples are independent of the
/// measured renders' (the same seed would replay the same random numbers and hide their error).
pub const REFERENCE_SEED_SALT: u32 = 0x5eed_f00d;

/// The relative errors the table reports the time to reach.
pub const THRESHOLDS: [f64; 3] = [0.05, 0.02, 0.01];

/// A knob: a name, the values it takes (for messages), and how a value changes the scene or the renderer
/// options. Adding a knob is one entry of [`KNOBS`]; e.g. a sampler option would be
/// `Knob { name: "sampler", values: "independent or sobol", apply: |v, _, o| { o.sampler = v.parse()?; Ok(()) } }`.
pub struct Knob {
    pub name: &'static str,
    pub values: &'static str,
    /// Applies `value`; an `Err` says what is wrong with the value (the caller names the flag).
    pub apply:
        fn(value: &str, scene: &mut Scene, options: &mut RenderOptions) -> Result<(), String>,
}

fn count(value: &str, least: u32) -> Result<u32, String> {
    value
        .parse::<u32>()
        .ok()
        .filter(|&v| v >= least)
        .ok_or_else(|| format!("\"{value}\" is not a whole number of at least {least}"))
}

/// Every knob `--knobs` can turn.
pub const KNOBS: &[Knob] = &[
    Knob {
        name: "sampler",
        values: "independent or sobol",
        apply: |v, s, _| {
            s.render.sampler = match v {
                "independent" => Sampler::Independent,
                "sobol" => Sampler::Sobol,
                _ => return Err(format!("\"{v}\" is not a sampler")),
            };
            Ok(())
        },
    },
    Knob {
        name: "light_sampling",
        values: "cone, area, none or mis",
        apply: |v, s, _| {
            s.render.light_sampling = LightSampling::from_name(v)
                .ok_or_else(|| format!("\"{v}\" is not a light-sampling strategy"))?;
            Ok(())
        },
    },
    Knob {
        name: "max_bounces",
        values: "a number of scattering events (0 or more)",
        apply: |v, s, _| {
            s.render.max_bounces = count(v, 0)?;
            Ok(())
        },
    },
    Knob {
        name: "roulette",
        values: "the depth Russian roulette starts at (0 or more), or off",
        apply: |v, _, o| {
            o.roulette_depth = if v == "off" { u32::MAX } else { count(v, 0)? };
            Ok(())
        },
    },
    Knob {
        name: "samples_per_pass",
        values: "a number of samples per pixel in each pass (1 or more), or adaptive",
        apply: |v, _, o| {
            o.samples_per_pass = if v == "adaptive" {
                None
            } else {
                Some(count(v, 1)?)
            };
            Ok(())
        },
    },
];

/// One measured setting: its label (as written in `--knobs`) and the knob values it sets, in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    pub label: String,
    pub values: Vec<(&'static str, String)>,
}

impl Setting {
    /// The setting `default`: the scene and [`RenderOptions::default`] unchanged.
    pub fn default_setting() -> Setting {
        Setting {
            label: "default".into(),
            values: Vec::new(),
        }
    }

    /// Applies the setting to a copy of the scene and the default options.
    pub fn apply(&self, scene: &Scene) -> Result<(Scene, RenderOptions), String> {
        let mut scene = scene.clone();
        let mut options = RenderOptions::default();
        for (name, value) in &self.values {
            let knob = KNOBS
                .iter()
                .find(|k| k.name == *name)
                .ok_or_else(|| format!("unknown knob {name}"))?;
            (knob.apply)(value, &mut scene, &mut options)
                .map_err(|e| format!("{name}={value}: {e}; {name} takes {}", knob.values))?;
        }
        Ok((scene, options))
    }
}

/// The settings measured when `--knobs` is not given: the default, then each knob moved on its own.
pub const DEFAULT_KNOBS: &str = "default,max_bounces=1,max_bounces=2,max_bounces=10,roulette=off,roulette=1,samples_per_pass=1,samples_per_pass=8";

/// Parses `--knobs`: settings separated by commas, each `default` or `knob=value` assignments joined by
/// `+` (e.g. `max_bounces=10+roulette=off`). Values are checked by applying them to `scene`.
pub fn parse_settings(text: &str, scene: &Scene) -> Result<Vec<Setting>, Error> {
    let known = KNOBS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ");
    let mut settings = Vec::new();
    for label in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let mut setting = Setting {
            label: label.to_string(),
            values: Vec::new(),
        };
        if label != "default" {
            for part in label.split('+').map(str::trim) {
                let (name, value) = part.split_once('=').ok_or_else(|| {
                    Error::Usage(format!(
                        "--knobs: \"{part}\" is not knob=value (or default); the knobs are {known}, e.g. --knobs default,max_bounces=2,roulette=off."
                    ))
                })?;
                let knob = KNOBS
                    .iter()
                    .find(|k| k.name == name.trim())
                    .ok_or_else(|| {
                        Error::Usage(format!(
                            "--knobs: there is no knob \"{}\"; the knobs are {known}.",
                            name.trim()
                        ))
                    })?;
                setting.values.push((knob.name, value.trim().to_string()));
            }
        }
        setting
            .apply(scene)
            .map_err(|e| Error::Usage(format!("--knobs: {e}.")))?;
        if settings.iter().any(|s: &Setting| s.label == setting.label) {
            return Err(Error::Usage(format!(
                "--knobs: the setting \"{label}\" is given twice."
            )));
        }
        settings.push(setting);
    }
    if settings.is_empty() {
        return Err(Error::Usage(
            "--knobs names no setting; give e.g. --knobs default,max_bounces=2.".into(),
        ));
    }
    Ok(settings)
}

/// The three errors of an image against a reference (see the module comment).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    pub rmse: f64,
    pub rel_mse: f64,
    pub rel_error: f64,
}

/// The errors of `image` against `reference` (same length; pixels RGB, linear), summed in f64.
pub fn image_errors(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Errors {
    let n = (image.len().min(reference.len()) * 3).max(1) as f64;
    let (mut se, mut rel, mut sum_ref) = (0f64, 0f64, 0f64);
    for (p, r) in image.iter().zip(reference) {
        for (&i, &r) in p.iter().zip(r) {
            let (i, r) = (f64::from(i), f64::from(r));
            let d2 = (i - r) * (i - r);
            se += d2;
            rel += d2 / (r * r + REL_MSE_EPSILON);
            sum_ref += r;
        }
    }
    let rmse = (se / n).sqrt();
    let mean_ref = sum_ref / n;
    Errors {
        rmse,
        rel_mse: rel / n,
        rel_error: if mean_ref > 0.0 {
            rmse / mean_ref
        } else {
            f64::NAN
        },
    }
}

/// The display-encoded luminance of `image` (`width` pixels a row) through `settings`' transform, in
/// [0, 1]: what SSIM compares.
fn display_luminance(image: &[[f32; 3]], settings: &ImageSettings) -> Vec<f64> {
    let encode = |v: f32| -> f64 {
        let v = settings.tonemap.apply(v * settings.exposure);
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        f64::from(match settings.gamma {
            Gamma::Power(g) => v.powf(1.0 / g),
            Gamma::Srgb => crate::film::srgb_encode(v),
        })
    };
    image
        .iter()
        .map(|p| 0.2126 * encode(p[0]) + 0.7152 * encode(p[1]) + 0.0722 * encode(p[2]))
        .collect()
}

/// The mean SSIM of `image` against `reference` (both `width` x `height`, linear RGB) as displayed with
/// `settings` (see the module's documentation). The window is separable: a 1-D Gaussian of 11 taps
/// (σ = 1.5, normalised) along rows then columns, clamped at the image's edges.
pub fn ssim(image: &[[f32; 3]], reference: &[[f32; 3]], settings: &ImageSettings) -> f64 {
    let (w, h) = (settings.width as usize, settings.height as usize);
    if w * h == 0 || image.len() != w * h || reference.len() != w * h {
        return f64::NAN;
    }
    let x = display_luminance(image, settings);
    let y = display_luminance(reference, settings);
    let taps: Vec<f64> = (-5i32..=5)
        .map(|i| (-f64::from(i * i) / (2.0 * 1.5 * 1.5)).exp())
        .collect();
    let norm: f64 = taps.iter().sum();
    // One 1-D pass of the window along the rows (`across`) or the columns, clamped at the edges.
    let pass = |v: &[f64], across: bool| -> Vec<f64> {
        (0..w * h)
            .map(|i| {
                let (r, c) = ((i / w) as i64, (i % w) as i64);
                let at = |o: i64| {
                    if across {
                        (r * w as i64 + (c + o).clamp(0, w as i64 - 1)) as usize
                    } else {
                        ((r + o).clamp(0, h as i64 - 1) * w as i64 + c) as usize
                    }
                };
                (0..11).map(|k| taps[k] * v[at(k as i64 - 5)]).sum::<f64>() / norm
            })
            .collect()
    };
    let blur = |v: &[f64]| pass(&pass(v, true), false);
    let product = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).collect::<Vec<_>>();
    let (mx, my) = (blur(&x), blur(&y));
    let (sxx, syy, sxy) = (
        blur(&product(&x, &x)),
        blur(&product(&y, &y)),
        blur(&product(&x, &y)),
    );
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    let total: f64 = (0..w * h)
        .map(|i| {
            let (vx, vy) = (sxx[i] - mx[i] * mx[i], syy[i] - my[i] * my[i]);
            let cov = sxy[i] - mx[i] * my[i];
            (2.0 * mx[i] * my[i] + c1) * (2.0 * cov + c2)
                / ((mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2))
        })
        .sum();
    total / (w * h) as f64
}

/// The time at which a decreasing error curve reaches `target`: the first segment (s₀, e₀)–(s₁, e₁) with
/// e₀ > target ≥ e₁, interpolated linearly in log-log space, where a power law e = a·sᵏ is a line:
/// log s = log s₀ + (log target − log e₀) · (log s₁ − log s₀) / (log e₁ − log e₀).
/// If the first point is already at or below the target, its time. `None` if never reached.
pub fn time_to_error(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    let first = curve.first()?;
    if first.1 <= target {
        return Some(first.0);
    }
    curve.windows(2).find_map(|w| {
        let ((s0, e0), (s1, e1)) = (w[0], w[1]);
        if !(e0 > target && e1 <= target) {
            return None;
        }
        if !(s0 > 0.0 && s1 > 0.0 && e1 > 0.0) {
            return Some(s1);
        }
        let slope = (s1.ln() - s0.ln()) / (e1.ln() - e0.ln());
        Some((s0.ln() + (target.ln() - e0.ln()) * slope).exp())
    })
}

/// One point of a curve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Point {
    pub setting: String,
    pub spp: u32,
    /// Cumulative seconds of the passes up to this many samples per pixel.
    pub seconds: f64,
    /// width · height · spp / seconds.
    pub samples_per_second: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub rel_error: f64,
    /// The film's own estimate of `rel_error` ([`Film::estimated_rel_error`]); NaN at 1 spp.
    pub estimated_rel_error: f64,
    /// SSIM of the displayed image against the displayed reference (1: identical; see the module's
    /// documentation).
    pub ssim: f64,
}

/// The CSV's header line.
pub const CSV_HEADER: &str =
    "setting,spp,seconds,samples_per_second,rmse,rel_mse,rel_error,estimated_rel_error,ssim";

/// The points as CSV: [`CSV_HEADER`], then one line per point (a NaN is written as an empty field).
pub fn to_csv(points: &[Point]) -> String {
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:.6e}")
        } else {
            String::new()
        }
    };
    let mut out = format!("{CSV_HEADER}\n");
    for p in points {
        // A label holds no comma (commas separate settings in --knobs), so it needs no quoting.
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{}",
            p.setting,
            p.spp,
            num(p.seconds),
            num(p.samples_per_second),
            num(p.rmse),
            num(p.rel_mse),
            num(p.rel_error),
            num(p.estimated_rel_error),
            num(p.ssim)
        );
    }
    out
}

/// The sample counts at which the film is compared: 1, 2, 4, … below `max_spp`, then `max_spp`.
pub fn checkpoints(max_spp: u32) -> Vec<u32> {
    let mut v: Vec<u32> = std::iter::successors(Some(1u32), |&n| n.checked_mul(2))
        .take_while(|&n| n < max_spp)
        .collect();
    v.push(max_spp.max(1));
    v
}

/// Renders `scene` with `options` progressively up to `max_spp`, comparing the film with `reference` at
/// each of [`checkpoints`]. One untimed warm-up pass comes first (the driver may finish compiling on
/// first use), then the renderer is reset. Passes are cut so as to land on the checkpoints; otherwise
/// they are `options.samples_per_pass` long or, when that is `None`, adapted as
/// [`crate::render::render_progressive`] does (towards `options.target_pass_seconds`, at most doubling).
///
/// With a denoiser, also the denoised curve (labelled "`label` denoised"; see the module's
/// documentation), after the raw one.
pub fn measure(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    options: &RenderOptions,
    label: &str,
    reference: &[[f32; 3]],
    max_spp: u32,
    denoiser: Option<&Denoiser>,
) -> Result<Vec<Point>, Error> {
    let mut r = Renderer::new(ctx, scene, options)?;
    r.run_pass(1)?;
    r.reset()?;
    // The aux renderers, compiled (and warmed up) before any timing, as the measured one.
    let mut aux = match denoiser {
        Some(_) => {
            let make = |aov| -> Result<Renderer, Error> {
                let o = RenderOptions {
                    aov,
                    fault: None,
                    ..options.clone()
                };
                let mut a = Renderer::new(ctx, scene, &o)?;
                a.run_pass(1)?;
                Ok(a)
            };
            Some((make(AOV_ALBEDO)?, make(AOV_NORMAL)?))
        }
        None => None,
    };
    let mut denoised = Vec::new();
    let pixels = f64::from(scene.image.width) * f64::from(scene.image.height);
    let mut pass = options.samples_per_pass.unwrap_or(1).max(1);
    let mut seconds = 0.0;
    let mut points = Vec::new();
    for target in checkpoints(max_spp) {
        while r.samples_done() < target {
            let k = pass.min(target - r.samples_done());
            let t0 = Instant::now();
            r.run_pass(k)?;
            let dt = t0.elapsed().as_secs_f64();
            seconds += dt;
            if options.samples_per_pass.is_none() && k == pass {
                let ideal = (options.target_pass_seconds / (dt / f64::from(k)).max(1e-9)).floor();
                pass = (ideal as u32).clamp(1, pass.saturating_mul(2));
            }
        }
        let film = r.film()?;
        let e = image_errors(&film.mean, reference);
        points.push(Point {
            setting: label.to_string(),
            spp: target,
            seconds,
            samples_per_second: pixels * f64::from(target) / seconds.max(1e-12),
            rmse: e.rmse,
            rel_mse: e.rel_mse,
            rel_error: e.rel_error,
            estimated_rel_error: film.estimated_rel_error(),
            ssim: ssim(&film.mean, reference, &scene.image),
        });
        if let (Some(d), Some((albedo, normal))) = (denoiser, aux.as_mut()) {
            let t0 = Instant::now();
            let aux_spp = target.min(AOV_MAX_SPP);
            let layer = |a: &mut Renderer| -> Result<Film, Error> {
                a.reset()?;
                a.run_pass(aux_spp)?;
                Ok(a.film()?)
            };
            let aux = Aux::from_films(&layer(albedo)?, &layer(normal)?);
            let image = d.denoise_film(&film, &aux, Quality::High)?.mean;
            let total = seconds + t0.elapsed().as_secs_f64();
            let e = image_errors(&image, reference);
            denoised.push(Point {
                setting: format!("{label} denoised"),
                spp: target,
                seconds: total,
                samples_per_second: pixels * f64::from(target) / total.max(1e-12),
                rmse: e.rmse,
                rel_mse: e.rel_mse,
                rel_error: e.rel_error,
                estimated_rel_error: f64::NAN,
                ssim: ssim(&image, reference, &scene.image),
            });
        }
    }
    points.extend(denoised);
    Ok(points)
}

/// What `vkpath bench convergence` was asked.
#[derive(Clone, Debug)]
pub struct Config {
    pub scene: Scene,
    pub settings: Vec<Setting>,
    /// A converged image to compare with (EXR, linear, the same size); else one is rendered.
    pub reference: Option<PathBuf>,
    pub reference_spp: u32,
    pub max_spp: u32,
    pub out_dir: PathBuf,
    /// `--denoise`: also each setting's denoised curve.
    pub denoise: bool,
}

/// The reference used: its pixels, where it is, and (when rendered here) its spp and own error.
pub struct Reference {
    pub pixels: Vec<[f32; 3]>,
    pub path: PathBuf,
    pub spp: Option<u32>,
    pub estimated_rel_error: Option<f64>,
}

/// Reads a linear EXR (or any image the `image` crate reads as float RGB) of the given size.
pub fn read_reference(path: &Path, width: u32, height: u32) -> Result<Vec<[f32; 3]>, Error> {
    let img = image::open(path).map_err(|e| {
        Error::Usage(format!(
            "--reference {}: cannot read it as an image ({e}). Give an EXR written by `vkpath render -o REF.exr` or by an earlier `vkpath bench convergence`.",
            path.display()
        ))
    })?;
    let img = img.to_rgb32f();
    if img.width() != width || img.height() != height {
        return Err(Error::Usage(format!(
            "--reference {} is {}x{} pixels but the measured renders are {width}x{height}: give --width {} --height {} or a reference of the render's size.",
            path.display(),
            img.width(),
            img.height(),
            img.width(),
            img.height()
        )));
    }
    Ok(img.pixels().map(|p| p.0).collect())
}

/// Renders the reference: the scene unchanged, default options, an independent seed, `spp` samples per
/// pixel; written to `path` as EXR.
pub fn render_reference(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    spp: u32,
    path: &Path,
) -> Result<Film, Error> {
    let mut scene = scene.clone();
    scene.render.seed ^= REFERENCE_SEED_SALT;
    let mut r = Renderer::new(ctx, &scene, &RenderOptions::default())?;
    // Passes of at most 64 samples per pixel: fewer submits than 1 spp at a time, bounded memory for
    // the command lists.
    while r.samples_done() < spp {
        r.run_pass((spp - r.samples_done()).min(64))?;
    }
    let film = r.film()?;
    film.write(path, &scene.image)?;
    Ok(film)
}

/// Everything measured, and where the files went.
pub struct Report {
    pub points: Vec<Point>,
    pub reference: Reference,
    pub csv: PathBuf,
    pub plot: PathBuf,
    pub table: String,
}

/// Runs the whole benchmark: the reference (read or rendered), every setting, the CSV, the plot and the
/// Markdown table. `log` receives one line per step (the CLI prints them on stderr).
pub fn run(
    ctx: &Arc<GpuContext>,
    config: &Config,
    mut log: impl FnMut(&str),
) -> Result<Report, Error> {
    let scene = &config.scene;
    let (w, h) = (scene.image.width, scene.image.height);
    let stem = scene.stem();
    std::fs::create_dir_all(&config.out_dir).map_err(|e| Error::Io {
        path: config.out_dir.clone(),
        message: e.to_string(),
    })?;
    let reference = match &config.reference {
        Some(p) => Reference {
            pixels: read_reference(p, w, h)?,
            path: p.clone(),
            spp: None,
            estimated_rel_error: None,
        },
        None => {
            let path = config.out_dir.join(format!(
                "{stem}-reference-{w}x{h}-{}spp.exr",
                config.reference_spp
            ));
            log(&format!(
                "rendering the reference: {w}x{h}, {} spp (seed {:#x}) -> {}",
                config.reference_spp,
                scene.render.seed ^ REFERENCE_SEED_SALT,
                path.display()
            ));
            let t0 = Instant::now();
            let film = render_reference(ctx, scene, config.reference_spp, &path)?;
            let est = film.estimated_rel_error();
            log(&format!(
                "reference done in {:.1} s; its own estimated relative error is {:.3}% (reuse it with --reference {})",
                t0.elapsed().as_secs_f64(),
                est * 100.0,
                path.display()
            ));
            Reference {
                pixels: film.mean,
                path,
                spp: Some(config.reference_spp),
                estimated_rel_error: est.is_finite().then_some(est),
            }
        }
    };
    let denoiser = if config.denoise {
        Some(Denoiser::new(crate::denoise::DeviceChoice::for_vulkan(
            ctx.device_info(),
        ))?)
    } else {
        None
    };
    let mut points = Vec::new();
    for s in &config.settings {
        let (sc, options) = s.apply(scene).map_err(Error::Usage)?;
        log(&format!(
            "measuring {} up to {} spp",
            s.label, config.max_spp
        ));
        let curve = measure(
            ctx,
            &sc,
            &options,
            &s.label,
            &reference.pixels,
            config.max_spp,
            denoiser.as_ref(),
        )?;
        for label in [s.label.clone(), format!("{} denoised", s.label)] {
            if let Some(last) = curve.iter().rfind(|p| p.setting == label) {
                log(&format!(
                    "  {label}: {:.2} s, {:.3} Msamples/s, relative error {:.3}% (estimated {:.3}%), SSIM {:.4}",
                    last.seconds,
                    last.samples_per_second / 1e6,
                    last.rel_error * 100.0,
                    last.estimated_rel_error * 100.0,
                    last.ssim
                ));
            }
        }
        points.extend(curve);
    }
    // The denoised curves are drawn and tabulated as settings of their own, after the raw ones.
    let mut curves = config.settings.clone();
    if denoiser.is_some() {
        curves.extend(config.settings.iter().map(|s| Setting {
            label: format!("{} denoised", s.label),
            values: s.values.clone(),
        }));
    }
    let csv = config.out_dir.join(format!("{stem}-convergence.csv"));
    crate::fs_atomic::write_atomically(&csv, to_csv(&points).as_bytes())?;
    let plot = config.out_dir.join(format!("{stem}-convergence.png"));
    // With denoised curves the plot shows relative MSE (the denoising literature's measure, which the
    // equal-time table compares); otherwise the relative error the thresholds are about.
    let metric = if denoiser.is_some() {
        PlotMetric::RelMse
    } else {
        PlotMetric::RelError
    };
    let title = format!(
        "{stem}, {w}x{h}: {} vs time ({})",
        metric.name(),
        ctx.device_info().name
    );
    write_plot(&plot, &title, &curves, &points, metric)?;
    let table = markdown_table(
        scene,
        config,
        &curves,
        &reference,
        &points,
        &ctx.device_info().name,
    );
    Ok(Report {
        points,
        reference,
        csv,
        plot,
        table,
    })
}

/// One row of the table per setting: samples/s at the last point, its error, and the time to reach
/// each of [`THRESHOLDS`].
pub fn markdown_table(
    scene: &Scene,
    config: &Config,
    curves: &[Setting],
    reference: &Reference,
    points: &[Point],
    device: &str,
) -> String {
    let reference_text = match (reference.spp, reference.estimated_rel_error) {
        (Some(n), Some(e)) => format!(
            "a {n} spp reference (own estimated relative error {:.2}%, the floor of every curve)",
            e * 100.0
        ),
        _ => format!("the reference {}", reference.path.display()),
    };
    let mut out = format!(
        "{}, {}x{}, up to {} spp, against {reference_text}, on {device}. Seconds are cumulative pass times of a progressive render; \
         times and spp to an error are log-log interpolated, empty when not reached. The errors do not depend on the \
         machine (same seeds, same bits); the seconds do.\n\n\
         | setting | Msamples/s | rel. error at {} spp | SSIM | s to 5% | s to 2% | s to 1% | spp to 5% | spp to 2% | spp to 1% |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        scene.stem(),
        scene.image.width,
        scene.image.height,
        config.max_spp,
        config.max_spp
    );
    for s in curves {
        let curve: Vec<&Point> = points.iter().filter(|p| p.setting == s.label).collect();
        let Some(last) = curve.last() else { continue };
        let by_time: Vec<(f64, f64)> = curve.iter().map(|p| (p.seconds, p.rel_error)).collect();
        let by_spp: Vec<(f64, f64)> = curve
            .iter()
            .map(|p| (f64::from(p.spp), p.rel_error))
            .collect();
        let reach = |xy: &[(f64, f64)], digits: usize| -> Vec<String> {
            THRESHOLDS
                .iter()
                .map(|&t| {
                    time_to_error(xy, t)
                        .map(|s| format!("{s:.digits$}"))
                        .unwrap_or_default()
                })
                .collect()
        };
        let mut times = reach(&by_time, 3);
        times.extend(reach(&by_spp, 0));
        let label = if s.label == "default" {
            // Spelled out from the scene and RenderOptions::default(), so that it stays true.
            let o = RenderOptions::default();
            format!(
                "default (max_bounces={}, roulette={}, {} passes)",
                scene.render.max_bounces,
                match o.roulette_depth {
                    u32::MAX => "off".to_string(),
                    d => d.to_string(),
                },
                match o.samples_per_pass {
                    None => "adaptive".to_string(),
                    Some(k) => format!("{k}-spp"),
                }
            )
        } else {
            s.label.clone()
        };
        let _ = writeln!(
            out,
            "| {label} | {:.3} | {:.2}% | {:.4} | {} |",
            last.samples_per_second / 1e6,
            last.rel_error * 100.0,
            last.ssim,
            times.join(" | ")
        );
    }
    for s in config.settings.iter() {
        let denoised = format!("{} denoised", s.label);
        let raw: Vec<&Point> = points.iter().filter(|p| p.setting == s.label).collect();
        let den: Vec<&Point> = points.iter().filter(|p| p.setting == denoised).collect();
        if !den.is_empty() {
            out.push_str(&equal_time_table(&s.label, &raw, &den));
        }
    }
    out
}

/// The raw curve's value at `seconds`, interpolated in log-log between the points around it; past its
/// last point, extrapolated along the 1/N law of an unbiased estimator at a fixed rate (MSE ∝ 1/t, so
/// relative MSE × t constant), marked by the `bool`; before its first point, `None`.
fn raw_at(raw: &[(f64, f64)], seconds: f64) -> Option<(f64, bool)> {
    let &(t_last, v_last) = raw.last()?;
    if seconds > t_last {
        return Some((v_last * t_last / seconds, true));
    }
    raw.windows(2).find_map(|w| {
        let ((t0, v0), (t1, v1)) = (w[0], w[1]);
        if !(t0 <= seconds && seconds <= t1) {
            return None;
        }
        if !(t0 > 0.0 && t1 > t0 && v0 > 0.0 && v1 > 0.0) {
            return Some((v1, false));
        }
        let f = (seconds.ln() - t0.ln()) / (t1.ln() - t0.ln());
        Some(((v0.ln() + f * (v1.ln() - v0.ln())).exp(), false))
    })
}

/// The equal-time comparison of a setting's denoised curve with its raw one: at each denoised point's
/// time (its passes, aux passes and denoiser), the raw curve's relative MSE and SSIM at the same time
/// ([`raw_at`]), and the ratio raw / denoised of relative MSE; then where, if anywhere, the raw image
/// overtakes the denoised one.
pub fn equal_time_table(label: &str, raw: &[&Point], den: &[&Point]) -> String {
    let rel: Vec<(f64, f64)> = raw.iter().map(|p| (p.seconds, p.rel_mse)).collect();
    // SSIM rises towards 1: interpolated as 1 - SSIM, which falls like an error.
    let dis: Vec<(f64, f64)> = raw.iter().map(|p| (p.seconds, 1.0 - p.ssim)).collect();
    let mut out = format!(
        "\n{label}: denoised against raw at equal time (relative MSE, ε = {REL_MSE_EPSILON}; * extrapolated \
         along 1/t past the raw curve's end)\n\n\
         | spp | seconds | raw rel. MSE | denoised rel. MSE | raw / denoised | raw SSIM | denoised SSIM |\n\
         | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n"
    );
    let mut overtaken = None;
    for p in den {
        let (Some((r, extrapolated)), Some((d, _))) =
            (raw_at(&rel, p.seconds), raw_at(&dis, p.seconds))
        else {
            continue;
        };
        let mark = if extrapolated { "*" } else { "" };
        let ratio = r / p.rel_mse;
        if ratio < 1.0 && overtaken.is_none() {
            overtaken = Some(p.spp);
        }
        let _ = writeln!(
            out,
            "| {} | {:.2} | {r:.4e}{mark} | {:.4e} | {ratio:.1} | {:.4}{mark} | {:.4} |",
            p.spp,
            p.seconds,
            p.rel_mse,
            1.0 - d,
            p.ssim
        );
    }
    let _ = writeln!(
        out,
        "\n{}",
        match overtaken {
            Some(n) => format!("The raw image overtakes the denoised one at {n} spp (equal time)."),
            None => "The denoised image stays ahead at every sample count measured.".into(),
        }
    );
    out
}

/// What the plot's vertical axis shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlotMetric {
    /// RMSE / mean(reference), with the 5 %, 2 %, 1 % thresholds and the 1/√N line.
    RelError,
    /// Relative MSE, with the 1/N line (MSE falls as 1/N).
    RelMse,
}

impl PlotMetric {
    fn name(self) -> &'static str {
        match self {
            PlotMetric::RelError => "relative error",
            PlotMetric::RelMse => "relative MSE",
        }
    }

    fn of(self, p: &Point) -> f64 {
        match self {
            PlotMetric::RelError => p.rel_error,
            PlotMetric::RelMse => p.rel_mse,
        }
    }
}

/// The font of the plot's text: DejaVu Sans reduced to ASCII (assets/fonts, with its licence).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

/// Draws the log-log plot of relative error against seconds, one line per setting, the 1/√N line
/// through the first setting's first point, and the thresholds, to a PNG at `path`.
pub fn write_plot(
    path: &Path,
    title: &str,
    settings: &[Setting],
    points: &[Point],
    metric: PlotMetric,
) -> Result<(), Error> {
    use plotters::prelude::*;
    const SIZE: (u32, u32) = (1000, 700);
    let fail = |e: String| Error::Io {
        path: path.to_path_buf(),
        message: format!("drawing the plot failed: {e}"),
    };
    // Registering the same font again just replaces it.
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| fail("the embedded font is not a valid TrueType font".into()))?;
    let usable: Vec<&Point> = points
        .iter()
        .filter(|p| p.seconds > 0.0 && metric.of(p) > 0.0 && metric.of(p).is_finite())
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in &usable {
        x0 = x0.min(p.seconds);
        x1 = x1.max(p.seconds);
        y0 = y0.min(metric.of(p));
        y1 = y1.max(metric.of(p));
    }
    if usable.is_empty() {
        (x0, x1, y0, y1) = (1e-3, 1.0, 1e-3, 1.0);
    }
    // Time: whole decades around the data. Error: from a whole decade at or below min(data, 1%) (so the
    // thresholds show) up to the next 1, 2 or 5 times a power of ten above the data.
    let decade_floor = |v: f64| 10f64.powf(v.log10().floor());
    let decade_ceil = |v: f64| 10f64.powf(v.log10().ceil());
    let nice_ceil = |v: f64| {
        let d = decade_floor(v);
        [1.0, 2.0, 5.0, 10.0]
            .into_iter()
            .map(|m| m * d)
            .find(|&c| c >= v)
            .unwrap_or(10.0 * d)
    };
    let (x0, x1) = (decade_floor(x0), decade_ceil(x1 * 1.01));
    let y0 = match metric {
        PlotMetric::RelError => decade_floor(y0.min(0.01 * 0.999)),
        PlotMetric::RelMse => decade_floor(y0),
    };
    let y1 = nice_ceil(y1 * 1.01);

    let mut buf = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .margin_right(40)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| fail(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("seconds (cumulative, progressive passes)")
            .y_desc(match metric {
                PlotMetric::RelError => "relative error = RMSE / mean(reference)",
                PlotMetric::RelMse => "relative MSE = mean (I - R)^2 / (R^2 + 0.01)",
            })
            .x_label_formatter(&|v| format!("{v:.3}"))
            .y_label_formatter(&|v| match metric {
                PlotMetric::RelError => format!("{:.1}%", v * 100.0),
                PlotMetric::RelMse => format!("{v:.0e}"),
            })
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        let orange = RGBColor(255, 170, 90);
        let thresholds: &[f64] = match metric {
            PlotMetric::RelError => &THRESHOLDS,
            PlotMetric::RelMse => &[],
        };
        for (i, &t) in thresholds.iter().enumerate() {
            let drawn = chart
                .draw_series(LineSeries::new([(x0, t), (x1, t)], orange.stroke_width(1)))
                .map_err(|e| fail(e.to_string()))?;
            if i == 0 {
                drawn
                    .label("5%, 2%, 1%")
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], orange));
            }
        }
        for (i, s) in settings.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let line: Vec<(f64, f64)> = usable
                .iter()
                .filter(|p| p.setting == s.label)
                .map(|p| (p.seconds, metric.of(p)))
                .collect();
            chart
                .draw_series(LineSeries::new(line, color.stroke_width(2)))
                .map_err(|e| fail(e.to_string()))?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        // 1/√N through the first point of the first setting: e(t) = e₀ √(t₀ / t), since at a fixed
        // rate N ∝ t (for the MSE, 1/N: e₀ t₀ / t).
        if let Some(first) = settings
            .first()
            .and_then(|s| usable.iter().find(|p| p.setting == s.label))
        {
            let (t0, e0) = (first.seconds, metric.of(first));
            let line = [t0, x1].map(|t| match metric {
                PlotMetric::RelError => (t, e0 * (t0 / t).sqrt()),
                PlotMetric::RelMse => (t, e0 * t0 / t),
            });
            chart
                .draw_series(LineSeries::new(line, BLACK.stroke_width(1)))
                .map_err(|e| fail(e.to_string()))?
                .label(match metric {
                    PlotMetric::RelError => "1/sqrt(N) from the first point",
                    PlotMetric::RelMse => "1/N from the first point",
                })
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .position(SeriesLabelPosition::LowerLeft)
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf)
        .ok_or_else(|| fail("the plot buffer has the wrong size".into()))?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| fail(e.to_string()))?;
    crate::fs_atomic::write_atomically(path, bytes.get_ref())
}
