//! `vkpath bench ...`: the benchmarks that report measured ratios (the library's `vkpath::bench`), with
//! their flags checked here and their results printed as tables or JSON.

use super::report::{DeviceRows, print_json};
use super::{load_scene, usage};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use vkpath::Error;
use vkpath::bench::{BenchSettings, convergence, mesh, specialisation, throughput};
use vkpath::gpu::{ContextOptions, GpuContext};

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Error against a reference vs time for each knob setting, at doubling spp: a CSV, a log-log PNG
    /// and a Markdown table of the time to reach 5%, 2% and 1% relative error.
    Convergence(ConvergenceArgs),
    /// Samples/s of each scene in ./scenes at fixed settings (median, min, max of several passes).
    Throughput {
        /// Scene files (default: every .toml in ./scenes).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        width: u32,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        spp: u32,
        /// Timed passes per scene.
        #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Print the rows as JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Samples/s and BVH build time for generated meshes of growing size in the course's box, and
    /// BVH vs brute force on the smaller ones, as a Markdown table.
    Mesh {
        /// Triangle counts (default 1000 10000 100000 1000000).
        #[arg(allow_negative_numbers = true)]
        sizes: Vec<usize>,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        width: u32,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 8, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        spp: u32,
        /// Timed passes per mesh (the median is reported).
        #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Also time brute force (no BVH) for meshes up to this many triangles.
        #[arg(
            long = "brute-force-up-to",
            default_value_t = 10_000,
            allow_negative_numbers = true
        )]
        brute_force_up_to: usize,
    },
    /// Samples/s of each scene with its specialised kernel, the generic kernel and (for diffuse/point-light
    /// scenes) a hand-trimmed kernel, as a Markdown table.
    Specialisation {
        /// Scene files (default: every .toml in ./scenes).
        scenes: Vec<PathBuf>,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        width: u32,
        #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        height: u32,
        /// Samples per pixel of each timed pass.
        #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
        spp: u32,
        /// Timed passes per kernel (the median is reported).
        #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
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
pub struct ConvergenceArgs {
    /// Scene file (TOML). Default: the embedded course scene.
    scene: Option<PathBuf>,
    /// A converged linear EXR of the same size to compare with (e.g. the one an earlier run wrote).
    #[arg(long, conflicts_with = "reference_spp")]
    reference: Option<PathBuf>,
    /// Samples per pixel of the reference rendered when --reference is not given.
    #[arg(long = "reference-spp", default_value_t = 4096, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    reference_spp: u32,
    /// Largest samples per pixel measured (the curve has 1, 2, 4, ... up to it).
    #[arg(long = "max-spp", default_value_t = 256, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    max_spp: u32,
    #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    width: u32,
    #[arg(long, default_value_t = 128, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    height: u32,
    /// Settings to measure, comma-separated: default, or knob=value joined by + (knobs: max_bounces,
    /// roulette, samples_per_pass, sampler, light_sampling).
    #[arg(long, default_value = vkpath::bench::convergence::DEFAULT_KNOBS)]
    knobs: String,
    /// Directory of the CSV, the PNG and the rendered reference.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
    /// Also each setting's denoised curve: the image --denoise would write at each sample count, its
    /// time with the aux layers' and the denoiser's (Intel Open Image Denoise).
    #[arg(long)]
    denoise: bool,
}

/// `vkpath bench ...`: each benchmark with its flags.
pub fn run_bench(b: BenchCommand) -> Result<i32, Error> {
    match b {
        BenchCommand::Convergence(a) => run_convergence(a),
        BenchCommand::Throughput {
            scenes,
            width,
            height,
            spp,
            runs,
            json,
        } => run_throughput(scenes, bench_settings(width, height, spp, runs)?, json),
        BenchCommand::Mesh {
            sizes,
            width,
            height,
            spp,
            runs,
            brute_force_up_to,
        } => run_mesh(
            sizes,
            bench_settings(width, height, spp, runs)?,
            brute_force_up_to,
        ),
        BenchCommand::Specialisation {
            scenes,
            width,
            height,
            spp,
            runs,
            json,
            ablation,
        } => run_specialisation(
            scenes,
            bench_settings(width, height, spp, runs)?,
            json,
            ablation,
        ),
    }
}

/// `vkpath bench convergence`: checks the sizes and the knob settings before any device work, then
/// measures; the CSV and the plot go to `--out`, the table to stdout.
fn run_convergence(a: ConvergenceArgs) -> Result<i32, Error> {
    if a.width == 0 || a.height == 0 || a.max_spp == 0 || a.reference_spp == 0 {
        return Err(usage(
            "--width, --height, --max-spp and --reference-spp must be at least 1.",
        ));
    }
    let mut scene = load_scene(a.scene.as_deref(), None)?;
    scene.image.width = a.width;
    scene.image.height = a.height;
    let settings = convergence::parse_settings(&a.knobs, &scene)?;
    let config = convergence::Config {
        scene,
        settings,
        reference: a.reference,
        reference_spp: a.reference_spp,
        max_spp: a.max_spp,
        out_dir: a.out,
        denoise: a.denoise,
    };
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let report = convergence::run(&ctx, &config, |line| eprintln!("vkpath: {line}"))?;
    eprintln!(
        "vkpath: wrote {} and {}",
        report.csv.display(),
        report.plot.display()
    );
    print!("{}", report.table);
    Ok(0)
}

/// The size and repetitions shared by the timing benchmarks, each at least 1.
fn bench_settings(width: u32, height: u32, spp: u32, runs: u32) -> Result<BenchSettings, Error> {
    if width == 0 || height == 0 || spp == 0 || runs == 0 {
        return Err(usage(
            "--width, --height, --spp and --runs must be at least 1.",
        ));
    }
    Ok(BenchSettings {
        width,
        height,
        spp,
        runs,
    })
}

/// The scenes a benchmark times: those given, or every scene in ./scenes.
fn bench_scenes(scenes: Vec<PathBuf>) -> Result<Vec<PathBuf>, Error> {
    let scenes = if scenes.is_empty() {
        vkpath::bench::scene_files(std::path::Path::new("scenes"))?
    } else {
        scenes
    };
    if scenes.is_empty() {
        return Err(usage("no scene files given and none found in ./scenes."));
    }
    Ok(scenes)
}

/// `vkpath bench throughput`: the rows as a table, or JSON with the device.
fn run_throughput(scenes: Vec<PathBuf>, settings: BenchSettings, json: bool) -> Result<i32, Error> {
    let scenes = bench_scenes(scenes)?;
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let device = &ctx.device_info().name;
    let rows = throughput::throughput(&ctx, &scenes, settings)?;
    if json {
        print_json(&DeviceRows {
            device,
            rows: &rows,
        });
    } else {
        print!("{}", throughput::throughput_table(&rows, settings, device));
    }
    Ok(0)
}

/// `vkpath bench mesh`: the default sizes unless some are given; the rows as a table.
fn run_mesh(
    sizes: Vec<usize>,
    settings: BenchSettings,
    brute_force_up_to: usize,
) -> Result<i32, Error> {
    let sizes = if sizes.is_empty() {
        mesh::DEFAULT_SIZES.to_vec()
    } else {
        sizes
    };
    // Checked before anything is built: an unbounded size allocated until the machine ran out of memory.
    if let Some(&n) = sizes
        .iter()
        .find(|&&n| n == 0 || n > mesh::MAX_BENCH_TRIANGLES)
    {
        return Err(usage(format!(
            "vkpath bench mesh takes triangle counts from 1 to {}, not {n}.",
            mesh::MAX_BENCH_TRIANGLES
        )));
    }
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let rows = mesh::mesh_scaling(&ctx, &sizes, settings, brute_force_up_to)?;
    print!(
        "{}",
        mesh::mesh_scaling_table(&rows, settings, &ctx.device_info().name)
    );
    Ok(0)
}

/// `vkpath bench specialisation`: the kernels compared, or with `--ablation` each absent feature's
/// gain; the rows as a table, or JSON with the device.
fn run_specialisation(
    scenes: Vec<PathBuf>,
    settings: BenchSettings,
    json: bool,
    ablation: bool,
) -> Result<i32, Error> {
    let scenes = bench_scenes(scenes)?;
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let device = &ctx.device_info().name;
    if ablation {
        let rows = specialisation::ablation(&ctx, &scenes, settings)?;
        if json {
            print_json(&DeviceRows {
                device,
                rows: &rows,
            });
        } else {
            print!(
                "{}",
                specialisation::ablation_table(&rows, settings, device)
            );
        }
        return Ok(0);
    }
    let rows = specialisation::specialisation(&ctx, &scenes, settings)?;
    if json {
        print_json(&DeviceRows {
            device,
            rows: &rows,
        });
    } else {
        print!(
            "{}",
            specialisation::specialisation_table(&rows, settings, device)
        );
    }
    Ok(0)
}
