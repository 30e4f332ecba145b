//! `vkpath merge`: partial renders (checkpoints of disjoint `--sample-range`s of one render) into the
//! image, and optionally the checkpoint, of their union.

use super::report::{MergeReport, print_json, shown_paths};
use super::{check_output_formats, usage};
use clap::Args;
use std::path::PathBuf;
use vkpath::Error;
use vkpath::checkpoint::{Checkpoint, Header};
use vkpath::denoise::{Denoiser, DeviceChoice, Quality};
use vkpath::output::{Aov, ImageFile, ImageMetadata, Layers, raw_channels, write_images};

#[derive(Args)]
pub struct MergeArgs {
    /// Partial renders: checkpoint files written by `vkpath render --part I/N` or `--sample-range A..B`
    /// with `--checkpoint FILE`; a directory (its *.ckpt files) or a quoted glob ('parts/*.ckpt').
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// No warnings (parts computed on different devices).
    #[arg(long)]
    quiet: bool,
    /// Extra EXR layers: `variance` (the others need the scene: vkpath render --aov).
    #[arg(long)]
    aov: Option<String>,
    /// Output image; repeatable; .png or .exr.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Also write the merged state as a checkpoint (to merge further, or resume with more samples).
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// Print one JSON object on stdout when done.
    #[arg(long)]
    json: bool,
    /// Denoise the merged frame (Intel Open Image Denoise), from the albedo and normal images the parts
    /// keep when rendered with --denoise or render.denoise = true (which also makes the merge denoise
    /// without this flag). The EXR keeps the raw estimate as raw.R/G/B.
    #[arg(long)]
    denoise: bool,
}

/// `vkpath merge`: refuses to run with nowhere to write or an output of unknown format, reads every
/// part (each checked on its own), merges them (refusing parts of another render or overlapping
/// ranges), and writes the outputs and the checkpoint.
pub fn run_merge(m: MergeArgs) -> Result<i32, Error> {
    if m.outputs.is_empty() && m.checkpoint.is_none() {
        return Err(usage(
            "vkpath merge needs somewhere to write: -o OUT.png / -o OUT.exr and/or --checkpoint FILE.",
        ));
    }
    check_output_formats(&m.outputs)?;
    let aovs = match &m.aov {
        Some(list) => Aov::parse_list(list).map_err(|e| usage(format!("--aov: {e}.")))?,
        None => Vec::new(),
    };
    if let Some(other) = aovs.iter().find(|a| !a.from_sums()) {
        return Err(usage(format!(
            "vkpath merge --aov can add only the variance and spp layers, which the parts hold; {} is rendered \
             from the scene: vkpath render --aov {}.",
            other.name(),
            other.name()
        )));
    }
    if !aovs.is_empty()
        && !m.outputs.iter().any(|o| {
            vkpath::film::OutputFormat::from_path(o) == Some(vkpath::film::OutputFormat::Exr)
        })
    {
        return Err(usage(
            "--aov adds layers to the EXR output, and no -o names an .exr file: add -o OUT.exr.",
        ));
    }
    if m.denoise && m.outputs.is_empty() {
        return Err(usage(
            "--denoise denoises the merged image, and no -o names one: add -o OUT.png or -o OUT.exr (the \
             merged checkpoint keeps the parts' aux images, to denoise later).",
        ));
    }
    let files = expand_parts(&m.parts)?;
    let inputs = files.iter().map(|p| (p.clone(), "a part merged")).collect();
    super::paths::check_outputs(&m.outputs, m.checkpoint.as_deref(), inputs, None)?;
    let hint = "Render that part again (vkpath render --part I/N or --sample-range A..B, with \
                --checkpoint FILE) or leave it out.";
    // The headers first (the checks of a merge need nothing else), then each part's pixels in turn.
    let headers = files
        .iter()
        .map(|p| {
            Checkpoint::read_header(p)
                .map(|h| (p.clone(), h))
                .map_err(|e| e.with_checkpoint_hint(hint))
        })
        .collect::<Result<Vec<_>, _>>()?;
    // The parts' scene may ask for denoising (render.denoise = true); the denoiser is loaded before any
    // pixel is read, so that a missing one is refused first.
    let denoise =
        !m.outputs.is_empty() && (m.denoise || headers.iter().all(|(_, h)| h.display.denoise));
    let denoiser = if denoise {
        Some(Denoiser::new(DeviceChoice::Cpu)?)
    } else {
        None
    };
    if denoise && let Some((path, _)) = headers.iter().find(|(_, h)| h.aux_samples.is_none()) {
        return Err(Error::Checkpoint {
            path: path.clone(),
            message: "this part carries no albedo and normal images, which the denoiser needs: render the \
                      parts with --denoise (or render.denoise = true in the scene), which makes each part's \
                      checkpoint keep them, or merge without --denoise."
                .into(),
        });
    }
    let merged = vkpath::checkpoint::merge::merge_files(&headers, |p| {
        Checkpoint::read(p).map_err(|e| e.with_checkpoint_hint(hint))
    })?;
    if !m.quiet {
        warn_devices(&headers);
    }
    let film = merged.film();
    let settings = merged.image_settings();
    let h = &merged.header;
    let metadata = ImageMetadata {
        scene: h.scene.clone(),
        scene_hash: h.identity.scene_hash.clone(),
        spp: film.spp,
        seed: h.identity.seed,
        // The parts do not record their time (a retried part writes the same bytes as the first try).
        seconds: None,
        device: h.device.clone(),
    };
    let mut layers = Layers {
        variance: aovs.contains(&Aov::Variance),
        spp: aovs.contains(&Aov::Spp),
        ..Layers::default()
    };
    let (written, description) = match (&denoiser, &merged.aux) {
        (Some(d), Some(aux)) => {
            layers.extra = raw_channels(&film.mean);
            (
                d.denoise_film(&film, aux, Quality::High)?,
                Some(d.describe()),
            )
        }
        _ => (film.clone(), None),
    };
    write_images(
        &m.outputs,
        &ImageFile {
            film: &written,
            settings: &settings,
            metadata: Some(&metadata),
            layers: &layers,
            denoised: description.as_deref(),
        },
    )?;
    if let Some(path) = &m.checkpoint {
        merged.write(path)?;
    }
    if m.json {
        let rel = film.estimated_rel_error();
        print_json(&MergeReport {
            scene: &merged.header.scene,
            width: film.width,
            height: film.height,
            spp: film.spp,
            parts: files.len(),
            sample_ranges: &merged.header.ranges,
            estimated_rel_error: rel.is_finite().then_some(rel),
            device: &merged.header.device,
            outputs: shown_paths(&m.outputs),
            checkpoint: m.checkpoint.as_ref().map(|p| p.display().to_string()),
        });
    }
    Ok(0)
}

/// The part files named on the command line: a file as it is, a directory's `*.ckpt` files (sorted by
/// name), and a pattern with `*`, `?` or `[` that is not itself a file (quoted, so the shell did not
/// expand it) as the files it matches. A directory or pattern that yields no file is an error, and so is
/// a path that does not exist (named, so that a typo is not merged as "no parts").
fn expand_parts(args: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for arg in args {
        let shown = arg.display();
        if arg.is_dir() {
            let entries = std::fs::read_dir(arg).map_err(|e| {
                usage(format!(
                    "cannot list the directory {shown} of parts to merge: {e}."
                ))
            })?;
            let mut found: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "ckpt") && p.is_file())
                .collect();
            if found.is_empty() {
                return Err(usage(format!(
                    "the directory {shown} holds no part to merge (no *.ckpt file): give the directory \
                     the parts were written to (vkpath render --part I/N --checkpoint DIR/part-I.ckpt)."
                )));
            }
            found.sort();
            files.extend(found);
        } else if !arg.exists() && arg.to_str().is_some_and(|t| t.contains(['*', '?', '['])) {
            let pattern = arg.to_str().unwrap_or_default();
            let matches = glob::glob(pattern).map_err(|e| {
                usage(format!(
                    "{pattern} is not a valid pattern of parts to merge: {e}."
                ))
            })?;
            let found: Vec<PathBuf> = matches
                .filter_map(Result::ok)
                .filter(|p| p.is_file())
                .collect();
            if found.is_empty() {
                return Err(usage(format!(
                    "the pattern {pattern} matches no part to merge: check the directory the parts were \
                     written to."
                )));
            }
            files.extend(found);
        } else {
            files.push(arg.clone());
        }
    }
    Ok(files)
}

/// Warns on stderr when the parts were computed on different devices: the merge is an unbiased estimate
/// either way, but its bits are a single render's only when one device computed every part (another
/// device's floating-point results may differ in the last bits).
fn warn_devices(parts: &[(PathBuf, Header)]) {
    let mut devices: Vec<(&str, Vec<String>)> = Vec::new();
    for (path, h) in parts {
        let name = path.display().to_string();
        match devices.iter_mut().find(|(d, _)| *d == h.device) {
            Some((_, files)) => files.push(name),
            None => devices.push((&h.device, vec![name])),
        }
    }
    if devices.len() > 1 {
        let list: Vec<String> = devices
            .iter()
            .map(|(d, files)| format!("{d} ({})", files.join(", ")))
            .collect();
        eprintln!(
            "vkpath: warning: the parts were computed on different devices: {}. The merged image is an \
             unbiased estimate, but it is not bit-identical to a render on a single device.",
            list.join("; ")
        );
    }
}
