//! `vkpath denoise IN.exr -o OUT...`: denoises an EXR that carries albedo and normal layers (a render
//! with `--aov albedo,normal`, a merged farm frame) with Intel Open Image Denoise, as `--denoise` does
//! at the end of a render (src/denoise.rs).

use super::{check_output_formats, usage};
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use vkpath::Error;
use vkpath::denoise::{DeviceChoice, Inputs, Quality};
use vkpath::film::Film;
use vkpath::output::{ExrChannels, ImageFile, ImageMetadata, Layers, raw_channels, write_images};

#[derive(Args)]
pub struct DenoiseArgs {
    /// An EXR with the layers albedo.R/G/B and normal.X/Y/Z beside R, G, B (vkpath render --aov
    /// albedo,normal -o IN.exr; vkpath merge of parts rendered so). An EXR already denoised is denoised
    /// again from its raw.R/G/B layers.
    input: PathBuf,
    /// Output image; repeatable; .png (through the display transform the EXR records) or .exr (the
    /// denoised R, G, B, the raw estimate as raw.R/G/B, and the input's other layers).
    #[arg(short = 'o', long = "output", required = true)]
    outputs: Vec<PathBuf>,
    /// No summary line on stderr.
    #[arg(long)]
    quiet: bool,
}

/// `vkpath denoise`: checks the outputs, loads the denoiser (a missing one is refused before anything
/// is read or written), reads the EXR, denoises it on the CPU device and writes every output, all or
/// nothing.
pub fn run_denoise(a: DenoiseArgs) -> Result<i32, Error> {
    check_output_formats(&a.outputs)?;
    let inputs = vec![(a.input.clone(), "the image denoised")];
    super::paths::check_outputs(&a.outputs, None, inputs, None)?;
    let denoiser = vkpath::denoise::Denoiser::new(DeviceChoice::Cpu)?;
    let exr = ExrChannels::read(&a.input)?;
    let name = a.input.display();
    // An image denoised before is denoised again from its raw estimate, not from its denoised pixels.
    let (color, from_raw) = match exr.rgb("raw", ["R", "G", "B"]) {
        Some(raw) => (raw, true),
        None => (
            exr.rgb("", ["R", "G", "B"])
                .ok_or_else(|| usage(format!("{name} has no R, G and B channels to denoise.")))?,
            false,
        ),
    };
    let aux = exr
        .rgb("albedo", ["R", "G", "B"])
        .zip(exr.rgb("normal", ["X", "Y", "Z"]));
    let Some((albedo, normal)) = aux else {
        return Err(usage(format!(
            "{name} has no albedo.R/G/B and normal.X/Y/Z layers, which the denoiser needs beside the \
             image: render it with --aov albedo,normal -o FILE.exr (or with --denoise, which denoises \
             at the end of the render)."
        )));
    };
    let started = Instant::now();
    let denoised = denoiser.denoise(
        &Inputs {
            width: exr.width,
            height: exr.height,
            color: &color,
            albedo: &albedo,
            normal: &normal,
        },
        Quality::High,
    )?;
    let seconds = started.elapsed().as_secs_f64();
    let spp = exr
        .attribute("vkpath:spp")
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let n = denoised.len();
    let film = Film {
        width: exr.width,
        height: exr.height,
        spp,
        pixel_spp: Vec::new(),
        mean: denoised,
        variance: vec![[0.0; 3]; n],
    };
    // The raw estimate, then every other channel of the input as it is.
    let mut extra = raw_channels(&color);
    extra.extend(
        exr.channels
            .iter()
            .filter(|(n, _)| !matches!(n.as_str(), "R" | "G" | "B") && !n.starts_with("raw."))
            .cloned(),
    );
    let metadata = ImageMetadata::from_attributes(&exr);
    let description = denoiser.describe();
    write_images(
        &a.outputs,
        &ImageFile {
            film: &film,
            settings: &exr.display_settings(),
            metadata: metadata.as_ref(),
            layers: &Layers {
                extra,
                ..Layers::default()
            },
            denoised: Some(&description),
        },
    )?;
    if !a.quiet {
        let outputs: Vec<String> = a.outputs.iter().map(|p| p.display().to_string()).collect();
        eprintln!(
            "vkpath: denoised {name} ({} x {}{}) in {seconds:.2} s with {description} -> {}",
            exr.width,
            exr.height,
            if from_raw {
                ", from its raw layers"
            } else {
                ""
            },
            outputs.join(", ")
        );
    }
    Ok(0)
}
