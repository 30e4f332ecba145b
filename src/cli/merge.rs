//! `vkpath merge`: partial renders (checkpoints of disjoint `--sample-range`s of one render) into the
//! image, and optionally the checkpoint, of their union.

use super::report::{MergeReport, print_json, shown_paths};
use super::{check_output_formats, usage};
use clap::Args;
use std::path::PathBuf;
use vkpath::Error;
use vkpath::checkpoint::Checkpoint;

#[derive(Args)]
pub struct MergeArgs {
    /// Partial renders: checkpoint files written by `vkpath render --sample-range A..B --checkpoint FILE`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output image; repeatable; .png or .exr.
    #[arg(short = 'o', long = "output")]
    outputs: Vec<PathBuf>,
    /// Also write the merged state as a checkpoint (to merge further, or resume with more samples).
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// Print one JSON object on stdout when done.
    #[arg(long)]
    json: bool,
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
    let inputs = m
        .parts
        .iter()
        .map(|p| (p.clone(), "a part merged"))
        .collect();
    super::paths::check_outputs(&m.outputs, m.checkpoint.as_deref(), inputs, None)?;
    let mut parts = Vec::with_capacity(m.parts.len());
    for p in &m.parts {
        parts.push((
            p.clone(),
            Checkpoint::read(p).map_err(|e| {
                e.with_checkpoint_hint(
                    "Render that part again (vkpath render --sample-range A..B --checkpoint FILE) or \
                     leave it out.",
                )
            })?,
        ));
    }
    let merged = vkpath::checkpoint::merge::merge(&parts)?;
    // The parts can be as large as the merged state each: free them before writing.
    drop(parts);
    let film = merged.film();
    let settings = merged.image_settings();
    for o in &m.outputs {
        film.write(o, &settings)?;
    }
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
            parts: m.parts.len(),
            sample_ranges: &merged.header.ranges,
            estimated_rel_error: rel.is_finite().then_some(rel),
            device: &merged.header.device,
            outputs: shown_paths(&m.outputs),
            checkpoint: m.checkpoint.as_ref().map(|p| p.display().to_string()),
        });
    }
    Ok(0)
}
