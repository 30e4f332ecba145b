//! The `vkpath` command line (contract: docs/cli.md). Parses flags, calls the library, maps errors to
//! exit codes: 0 success, 2 bad input (scene, flags), 1 anything else.

use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;
use vkpath::gpu::{ContextOptions, GpuContext};
use vkpath::render::{Budget, RenderOptions, Renderer, StopReason, render_progressive};
use vkpath::{Error, Scene};

#[derive(Parser)]
#[command(
    name = "vkpath",
    version,
    about = "A physically based path tracer on Vulkan compute"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the embedded course scene when none is given) to PNG/EXR.
    Render(RenderArgs),
    /// Open a window and watch the render converge (not supported yet).
    Preview {
        /// Scene file.
        scene: PathBuf,
    },
    /// Benchmarks that report measured ratios.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// List the Vulkan devices, the one chosen and why, and its limits.
    Info {
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Samples/s of each scene with its specialised kernel, the generic kernel and (for diffuse/point-light
    /// scenes) a hand-trimmed kernel, as a Markdown table.
    Specialisation {
        /// Scene files (default: every .toml in ./scenes).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 128)]
        width: u32,
        #[arg(long, default_value_t = 128)]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Timed passes per kernel (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: u32,
        /// Print the rows as JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Instead, measure what each absent feature's absence gains (one kernel per feature put back).
        #[arg(long)]
        ablation: bool,
    },
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// Output file; repeatable; the format follows the extension (.png, .exr). Default: <scene-stem>.png.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Samples per pixel (overrides the scene); with --time, the upper bound.
    #[arg(long)]
    spp: Option<u32>,
    /// Stop after the first pass that ends past this many seconds.
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f64>,
    /// Stop when the estimated relative error falls below E (not supported yet).
    #[arg(long = "target-error", allow_negative_numbers = true)]
    target_error: Option<f64>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    seed: Option<u32>,
    /// Image width in pixels (overrides the scene).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene).
    #[arg(long)]
    height: Option<u32>,
    /// Scattering events per path (overrides the scene).
    #[arg(long = "max-bounces")]
    max_bounces: Option<u32>,
    /// Rewrite the outputs after every N samples per pixel.
    #[arg(long = "progress-every")]
    progress_every: Option<u32>,
    /// Print one JSON object on stdout when the render ends.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Samples per pixel in each pass (default: adapted to about a quarter second per pass).
    #[arg(long = "samples-per-pass")]
    samples_per_pass: Option<u32>,
    /// Start Russian roulette after this many bounces ("off" disables it). Default 3.
    #[arg(long = "roulette-depth")]
    roulette_depth: Option<String>,
    /// Run the one all-features kernel instead of the kernel specialised for this scene.
    #[arg(long)]
    generic: bool,
}

fn usage(msg: impl Into<String>) -> Error {
    Error::Usage(msg.into())
}

/// Applies the command-line overrides to the scene and checks them as the scene file's rules would.
fn apply_overrides(scene: &mut Scene, a: &RenderArgs) -> Result<(), Error> {
    if let Some(spp) = a.spp {
        if spp == 0 {
            return Err(usage("--spp must be at least 1."));
        }
        scene.render.samples = spp;
    }
    if let Some(w) = a.width {
        scene.image.width = w;
    }
    if let Some(h) = a.height {
        scene.image.height = h;
    }
    let (w, h) = (scene.image.width as u64, scene.image.height as u64);
    if w == 0 || h == 0 || w > 65536 || h > 65536 || w * h > (1 << 28) {
        return Err(usage(format!(
            "an image of {w}x{h} pixels is not allowed: width and height must be 1..=65536 and their product at most 2^28 (268435456)."
        )));
    }
    if let Some(b) = a.max_bounces {
        scene.render.max_bounces = b;
    }
    if let Some(s) = a.seed {
        scene.render.seed = s;
    }
    Ok(())
}

fn render_options(a: &RenderArgs) -> Result<RenderOptions, Error> {
    let mut o = RenderOptions {
        generic: a.generic,
        ..Default::default()
    };
    if let Some(k) = a.samples_per_pass {
        if k == 0 {
            return Err(usage("--samples-per-pass must be at least 1."));
        }
        o.samples_per_pass = Some(k);
    }
    if let Some(r) = &a.roulette_depth {
        o.roulette_depth = match r.as_str() {
            "off" => u32::MAX,
            s => s.parse().map_err(|_| {
                usage(format!(
                    "--roulette-depth takes a number of bounces or \"off\", not \"{s}\"."
                ))
            })?,
        };
    }
    Ok(o)
}

fn run_render(a: RenderArgs) -> Result<i32, Error> {
    if a.target_error.is_some() {
        return Err(usage(
            "--target-error is not supported yet in this version of vkpath; use --spp or --time to bound the render.",
        ));
    }
    let budget_time = match a.time {
        Some(t) if !(t.is_finite() && t > 0.0) => {
            return Err(usage(format!(
                "--time must be a positive number of seconds, not {t}."
            )));
        }
        Some(t) => Some(Duration::from_secs_f64(t)),
        None => None,
    };
    if a.progress_every == Some(0) {
        return Err(usage("--progress-every must be at least 1."));
    }
    let mut scene = match &a.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    apply_overrides(&mut scene, &a)?;
    let options = render_options(&a)?;
    let outputs = if a.outputs.is_empty() {
        vec![PathBuf::from(format!("{}.png", scene.stem()))]
    } else {
        a.outputs.clone()
    };
    for o in &outputs {
        if vkpath::film::OutputFormat::from_path(o).is_none() {
            return Err(usage(format!(
                "cannot tell the image format of output {}: use a .png or .exr extension.",
                o.display()
            )));
        }
    }

    // Ctrl-C ends the render after the pass in flight; the outputs are then written.
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // If a handler cannot be installed (e.g. one already exists in an embedding), Ctrl-C just kills us.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }

    let ctx = GpuContext::new(&ContextOptions::default())?;
    let mut renderer = Renderer::new(&ctx, &scene, &options)?;
    let budget = Budget {
        spp: scene.render.samples,
        time: budget_time,
        checkpoint_every: a.progress_every,
    };
    let bar = if !a.quiet && std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(scene.render.samples as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {pos}/{len} spp ({per_sec}, eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(bar)
    } else {
        None
    };
    let (reason, elapsed) =
        render_progressive(&mut renderer, &options, &budget, &stop, |r, report| {
            if let Some(bar) = &bar {
                bar.set_position(report.samples_done as u64);
            }
            if report.checkpoint && report.samples_done < budget.spp {
                let film = r.film()?;
                for o in &outputs {
                    film.write(o, &scene.image)?;
                }
            }
            Ok(())
        })?;
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let film = renderer.film()?;
    if film.spp == 0 {
        eprintln!("vkpath: interrupted before the first pass ended; no image was written.");
        return Ok(1);
    }
    for o in &outputs {
        film.write(o, &scene.image)?;
    }
    if reason == StopReason::Interrupted && !a.quiet {
        eprintln!(
            "vkpath: interrupted; wrote the image with {} samples per pixel.",
            film.spp
        );
    }
    let validation_errors = ctx.validation_errors();
    let seconds = elapsed.as_secs_f64();
    let samples = scene.image.width as f64 * scene.image.height as f64 * film.spp as f64;
    if a.json {
        let rel = film.estimated_rel_error();
        let json = serde_json::json!({
            "scene": scene.display_name(),
            "width": scene.image.width,
            "height": scene.image.height,
            "spp": film.spp,
            "seconds": seconds,
            "samples_per_second": samples / seconds.max(1e-12),
            "estimated_rel_error": if rel.is_finite() { serde_json::json!(rel) } else { serde_json::Value::Null },
            "device": ctx.device_info().name,
            "max_bounces": scene.render.max_bounces,
            "seed": scene.render.seed,
            "stop_reason": reason,
            "outputs": outputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "validation_errors": validation_errors.len(),
            "kernel": if renderer.features() == &vkpath::gpu::features::FeatureSet::generic() { "generic" } else { "specialised" },
            "features_absent": renderer.features().absent(),
        });
        println!("{json}");
    }
    if !validation_errors.is_empty() {
        for e in &validation_errors {
            eprintln!("vkpath: Vulkan validation error: {e}");
        }
        eprintln!(
            "vkpath: the Vulkan validation layer reported {} error(s) (VKPATH_VALIDATION is set); this is a bug in vkpath.",
            validation_errors.len()
        );
        return Ok(1);
    }
    Ok(0)
}

fn run_bench(b: BenchCommand) -> Result<i32, Error> {
    match b {
        BenchCommand::Specialisation {
            scenes,
            width,
            height,
            spp,
            runs,
            json,
            ablation,
        } => {
            if width == 0 || height == 0 || spp == 0 || runs == 0 {
                return Err(usage(
                    "--width, --height, --spp and --runs must be at least 1.",
                ));
            }
            let scenes = if scenes.is_empty() {
                vkpath::bench::scene_files(std::path::Path::new("scenes"))?
            } else {
                scenes
            };
            if scenes.is_empty() {
                return Err(usage("no scene files given and none found in ./scenes."));
            }
            let ctx = GpuContext::new(&ContextOptions::default())?;
            let settings = vkpath::bench::BenchSettings {
                width,
                height,
                spp,
                runs,
            };
            let device = &ctx.device_info().name;
            if ablation {
                let rows = vkpath::bench::ablation(&ctx, &scenes, settings)?;
                if json {
                    println!("{}", serde_json::json!({ "device": device, "rows": rows }));
                } else {
                    print!("{}", vkpath::bench::ablation_table(&rows, settings, device));
                }
                return Ok(0);
            }
            let rows = vkpath::bench::specialisation(&ctx, &scenes, settings)?;
            if json {
                println!(
                    "{}",
                    serde_json::json!({ "device": ctx.device_info().name, "rows": rows })
                );
            } else {
                print!(
                    "{}",
                    vkpath::bench::specialisation_table(&rows, settings, &ctx.device_info().name)
                );
            }
            Ok(0)
        }
    }
}

fn run_info(json: bool) -> Result<i32, Error> {
    let devices = vkpath::gpu::context::list_devices()?;
    let substring = std::env::var("VKPATH_DEVICE")
        .ok()
        .filter(|s| !s.is_empty());
    let (chosen, reason) = vkpath::gpu::context::choose_device(&devices, substring.as_deref())?;
    if json {
        let v = serde_json::json!({ "devices": devices, "chosen": chosen, "reason": reason });
        println!("{v}");
        return Ok(0);
    }
    for d in &devices {
        let mark = if d.index == chosen { "*" } else { " " };
        println!(
            "{mark} [{}] {} ({}, Vulkan {})",
            d.index, d.name, d.device_type, d.api_version
        );
    }
    let d = &devices[chosen];
    println!("chosen: [{}] {}, because {}", d.index, d.name, reason);
    println!("limits:");
    println!(
        "  max compute workgroup count:       {:?}",
        d.max_compute_workgroup_count
    );
    println!(
        "  max compute workgroup invocations: {}",
        d.max_compute_workgroup_invocations
    );
    println!(
        "  max storage buffer range:          {} bytes",
        d.max_storage_buffer_range
    );
    println!(
        "  max memory allocation size:        {} bytes",
        d.max_memory_allocation_size
    );
    println!(
        "  device-local memory:               {} bytes",
        d.device_local_memory_bytes
    );
    Ok(0)
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version: print and exit 0
        Err(e) => {
            // Clap's usage errors span several paragraphs; the contract asks for one.
            let text = e.to_string();
            let msg: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("vkpath: {}", msg.join(" "));
            std::process::exit(2);
        }
    };
    let result = match cli.command {
        Command::Render(a) => run_render(a),
        Command::Preview { scene } => Err(usage(format!(
            "`vkpath preview {}`: the windowed preview is not supported yet in this version of vkpath; use `vkpath render --progress-every N` and watch the output file.",
            scene.display()
        ))),
        Command::Info { json } => run_info(json),
        Command::Bench(b) => run_bench(b),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("vkpath: error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}
