//! Merging partial renders: the parts of disjoint `--sample-range`s of one render added into the state
//! of their union (`vkpath merge`).

use super::{Aux, Checkpoint, Header, Part, count_samples, show_ranges};
use crate::Error;
use crate::kernel::abi::{GpuAccum, GpuSplatAccum};
use std::path::{Path, PathBuf};

/// Adds partial renders of disjoint sample ranges of the same render into the state of their union.
///
/// Each pixel's sums of samples are exact integers (long accumulators, [`crate::accum`]): the parts'
/// are added exactly, so the merged sums, and hence the image, are bit for bit those of a single render
/// of the union, whatever the split. The sums of squares (which only feed the variance estimate) are
/// Kahan pairs: each is read exactly in f64 as s - c, the parts' are added in f64 in the order of their
/// first sample index (so the result does not depend on the order the parts are given in), and stored
/// back as a Kahan pair (s = the f32 nearest the total, c = s - total rounded to f32). The variance of the
/// union is kept to within a few ulps of a single render's. `tests/checkpoint.rs` tests both.
pub fn merge(parts: &[(PathBuf, Checkpoint)]) -> Result<Checkpoint, Error> {
    let headers: Vec<(PathBuf, &Header)> =
        parts.iter().map(|(p, c)| (p.clone(), &c.header)).collect();
    let plan = check_headers(&headers)?;
    let mut sum = Sum::new(plan.pixels);
    for &i in &plan.order {
        sum.add(&parts[i].1.accum);
        sum.add_splat(&parts[i].1);
        sum.keep_aux(&parts[i].1);
    }
    Ok(sum.finish(plan))
}

/// [`merge`] of state files given by their headers (read by [`Checkpoint::read_header`]), reading each
/// part's pixels with `read` only when it is its turn to be added, and dropping them after: the headers
/// are checked before any pixel is decoded, and the host holds the merged state (96 bytes a pixel), the
/// running sums of squares (24) and one part (96 and its compressed bytes), however many parts there
/// are.
pub fn merge_files(
    headers: &[(PathBuf, Header)],
    read: impl Fn(&Path) -> Result<Checkpoint, Error>,
) -> Result<Checkpoint, Error> {
    let borrowed: Vec<(PathBuf, &Header)> = headers.iter().map(|(p, h)| (p.clone(), h)).collect();
    let plan = check_headers(&borrowed)?;
    let bytes = plan.pixels as u64
        * (MERGED_BYTES_PER_PIXEL + crate::render::host_use::CHECKPOINT_BYTES_PER_PIXEL);
    crate::memory::check_available(bytes, &format!("merging {} parts", headers.len())).map_err(
        |m| Error::Checkpoint {
            path: headers[0].0.clone(),
            message: format!("{m}. Merge on a machine with more memory."),
        },
    )?;
    let mut sum = Sum::new(plan.pixels);
    for &i in &plan.order {
        let (path, header) = &headers[i];
        let part = read(path)?;
        if &part.header != header {
            return Err(Error::Checkpoint {
                path: path.clone(),
                message: "its header changed while the parts were merged (the file was rewritten): merge \
                          again once the renders are done."
                    .into(),
            });
        }
        sum.add(&part.accum);
        sum.add_splat(&part);
        sum.keep_aux(&part);
    }
    Ok(sum.finish(plan))
}

/// Host bytes per pixel of a merge besides the part being read: the merged state and the sums of
/// squares in f64.
const MERGED_BYTES_PER_PIXEL: u64 = crate::render::tiles::ACCUM_BYTES_PER_PIXEL + 24;

/// What the headers decide: the merged header, the pixels, and the order the parts are added in.
struct Plan {
    header: Header,
    pixels: usize,
    order: Vec<usize>,
}

/// The checks of a merge, on the headers alone: one render (identity), one split if any, disjoint
/// ranges, at most 2^32 - 1 samples in all.
fn check_headers(parts: &[(PathBuf, &Header)]) -> Result<Plan, Error> {
    let Some((first_path, first)) = parts.first() else {
        return Err(Error::Usage(
            "merge needs at least one partial render.".into(),
        ));
    };
    let identity = &first.identity;
    let pixels = identity.width as usize * identity.height as usize;
    for (path, part) in &parts[1..] {
        let d = part.identity.differences(identity);
        if !d.is_empty() {
            return Err(Error::Checkpoint {
                path: path.clone(),
                message: format!(
                    "this partial render is of another render than {}: {}. Merge only the parts of one \
                     render (same scene file, flags and vkpath version).",
                    first_path.display(),
                    d.join("; ")
                ),
            });
        }
    }
    if let Some((path, _)) = parts.iter().find(|(_, h)| h.adaptive) {
        return Err(Error::Checkpoint {
            path: path.clone(),
            message: "this is the checkpoint of an adaptive render (render.adaptive), which is never a \
                      part of a render: resume it with vkpath render --resume instead of merging it."
                .into(),
        });
    }
    check_split(parts)?;
    // Every range, with the part it comes from, sorted by start: overlaps would count samples twice.
    let mut ranges: Vec<([u32; 2], usize)> = parts
        .iter()
        .enumerate()
        .flat_map(|(i, (_, h))| h.ranges.iter().map(move |r| (*r, i)))
        .collect();
    ranges.sort();
    for w in ranges.windows(2) {
        let ((a, i), (b, j)) = (w[0], w[1]);
        if a[1] > b[0] {
            let (pa, pb) = (&parts[i].0, &parts[j].0);
            return Err(Error::Checkpoint {
                path: pb.clone(),
                message: format!(
                    "its samples {}..{} overlap the samples {}..{} of {}: merging would count them twice. \
                     Merge partial renders of disjoint --sample-range's only.",
                    b[0],
                    b[1],
                    a[0],
                    a[1],
                    pa.display()
                ),
            });
        }
    }
    let all_ranges: Vec<[u32; 2]> = ranges.iter().map(|(r, _)| *r).collect();
    count_samples(&all_ranges).map_err(|m| Error::Checkpoint {
        path: first_path.clone(),
        message: format!("the merged render would be invalid: {m}."),
    })?;
    // Parts in the order of their first sample.
    let mut order: Vec<usize> = (0..parts.len()).collect();
    order.sort_by_key(|&i| parts[i].1.ranges.first().map_or(0, |r| r[0]));
    let mut devices: Vec<&str> = Vec::new();
    for &i in &order {
        let d = parts[i].1.device.as_str();
        if !devices.contains(&d) {
            devices.push(d);
        }
    }
    Ok(Plan {
        header: Header {
            identity: identity.clone(),
            scene: first.scene.clone(),
            device: devices.join(" + "),
            ranges: all_ranges,
            display: first.display,
            part: None,
            // Set by the merge from the parts' aux images (see `merge_files`).
            aux_samples: None,
            // Every part's identity is the render's, whose scene says whether it splats; set by the
            // merge from the parts' sums.
            splat: false,
            adaptive: false,
        },
        pixels,
        order,
    })
}

/// The running sums of a merge: exact sums of samples, and the sums of squares in f64 (see [`merge`]).
struct Sum {
    accum: Vec<GpuAccum>,
    squares: Vec<[f64; 3]>,
    /// The denoiser's aux images of the first part (in sample order) that has them, with their sample
    /// count. Every part of a render renders the same ones (`Aux`), so any would do; the first in sample
    /// order makes the merge independent of the order the parts are given in.
    aux: Option<(Aux, u32)>,
    /// The splatted sums of a splatted render's parts, added exactly (`None` until a part has them).
    splat: Option<Vec<GpuSplatAccum>>,
}

impl Sum {
    fn new(pixels: usize) -> Sum {
        Sum {
            accum: vec![GpuAccum::default(); pixels],
            squares: vec![[0.0; 3]; pixels],
            aux: None,
            splat: None,
        }
    }

    /// Adds a part's pixels (as many as the merged image's: the identities agree).
    fn add(&mut self, part: &[GpuAccum]) {
        for ((out, sq), a) in self.accum.iter_mut().zip(&mut self.squares).zip(part) {
            // At most 2^32 - 1 samples in all (check_headers), so 192 bits cannot overflow.
            crate::accum::add_sums(out, a);
            for (total, (s, c)) in sq.iter_mut().zip(a.sum_sq.iter().zip(&a.sum_sq_c)) {
                *total += f64::from(*s) - f64::from(*c);
            }
        }
    }

    /// Adds a part's splatted sums, exactly (a part without them adds nothing: the parts of one render
    /// all have them or none does, their scenes being one).
    fn add_splat(&mut self, part: &Checkpoint) {
        let Some(sums) = &part.splat else {
            return;
        };
        let out = self
            .splat
            .get_or_insert_with(|| vec![GpuSplatAccum::default(); sums.len()]);
        for (o, s) in out.iter_mut().zip(sums) {
            crate::accum::add_splat(o, s);
        }
    }

    /// Keeps `part`'s aux images when none are kept yet.
    fn keep_aux(&mut self, part: &Checkpoint) {
        if self.aux.is_none()
            && let (Some(aux), Some(n)) = (&part.aux, part.header.aux_samples)
        {
            self.aux = Some((aux.clone(), n));
        }
    }

    fn finish(mut self, mut plan: Plan) -> Checkpoint {
        for (out, sq) in self.accum.iter_mut().zip(&self.squares) {
            for (c, total) in sq.iter().enumerate() {
                (out.sum_sq[c], out.sum_sq_c[c]) = kahan_pair(*total);
            }
        }
        plan.header.aux_samples = self.aux.as_ref().map(|(_, n)| *n);
        plan.header.splat = self.splat.is_some();
        Checkpoint {
            header: plan.header,
            accum: self.accum,
            aux: self.aux.map(|(a, _)| a),
            splat: self.splat,
            adaptive: None,
        }
    }
}

/// The parts of a farm render (`--part I/N`, [`Part`] in each header) must be all of one split: each
/// part of it once, and each whole. Refuses, naming the files, a mix of parts and other states, parts of
/// different splits, a part given twice (two files of the same part), a part that stopped before its end
/// (a cancelled task's checkpoint), and missing parts (with their sample ranges). States without a part
/// (`--sample-range` renders, merged states) are left to the range checks.
fn check_split(parts: &[(PathBuf, &Header)]) -> Result<(), Error> {
    let Some((first_path, first)) = parts.iter().find_map(|(p, h)| Some((p, h.part?))) else {
        return Ok(());
    };
    // Parts seen, by index (a map: the count comes from a file and may be large).
    let mut seen: std::collections::BTreeMap<u32, &PathBuf> = std::collections::BTreeMap::new();
    for (path, h) in parts {
        let refuse = |message: String| {
            Err(Error::Checkpoint {
                path: path.clone(),
                message,
            })
        };
        let Some(part) = h.part else {
            return refuse(format!(
                "it is not a part of a --part split, and {} is (part {}): merge the parts of one split \
                 (vkpath merge DIR), then merge that with other renders if needed.",
                first_path.display(),
                first.show()
            ));
        };
        if (part.count, part.samples) != (first.count, first.samples) {
            return refuse(format!(
                "it is part {} of a {}-sample render, and {} is part {} of a {}-sample render: merge the \
                 parts of one split only.",
                part.show(),
                part.samples,
                first_path.display(),
                first.show(),
                first.samples
            ));
        }
        if let Some(other) = seen.get(&part.index) {
            return refuse(if other == &path {
                "it is given twice (a directory or pattern and the file itself?): each part must be \
                 given once."
                    .into()
            } else {
                format!(
                    "it is part {} again, as {} is: each part must be given once. Keep one of the two \
                     files.",
                    part.show(),
                    other.display()
                )
            });
        }
        seen.insert(part.index, path);
        let range = part.range();
        if h.ranges != [range] {
            return refuse(format!(
                "it holds the samples {} of part {}'s {}..{}: its task stopped before the end (cancelled or \
                 failed). Finish it with `vkpath render SCENE --part {} --resume {}` (the same scene and \
                 flags), then merge again.",
                show_ranges(&h.ranges),
                part.show(),
                range[0],
                range[1],
                part.show(),
                path.display()
            ));
        }
    }
    let missing_count = first.count as usize - seen.len();
    if missing_count > 0 {
        // The first few missing parts, found within seen.len() + SHOWN steps.
        const SHOWN: usize = 8;
        let missing = (0..first.count)
            .filter(|i| !seen.contains_key(i))
            .take(SHOWN)
            .map(|index| Part { index, ..first });
        let mut shown: Vec<String> = missing
            .map(|p| {
                let [a, b] = p.range();
                format!("{} (samples {a}..{b})", p.show())
            })
            .collect();
        if missing_count > SHOWN {
            shown.push(format!("and {} more", missing_count - SHOWN));
        }
        return Err(Error::Usage(format!(
            "{missing_count} of the {} parts of this render {} missing: {}. Render {} (vkpath render SCENE \
             --part I/{} --checkpoint FILE, with the scene and flags of the others: {} is part {}), then \
             merge again.",
            first.count,
            if missing_count == 1 { "is" } else { "are" },
            shown.join(", "),
            if missing_count == 1 { "it" } else { "them" },
            first.count,
            first_path.display(),
            first.show()
        )));
    }
    Ok(())
}

/// A total as a Kahan pair (s, c) with s - c ≈ total: s the nearest f32, c the f32 nearest s - total.
fn kahan_pair(total: f64) -> (f32, f32) {
    let s = total as f32;
    let c = (f64::from(s) - total) as f32;
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checkpoint::tests::state;

    #[test]
    fn merge_refuses_overlaps_and_adds_disjoint_ranges() {
        let a = (PathBuf::from("a"), state(vec![[0, 4]], 3.0));
        let b = (PathBuf::from("b"), state(vec![[2, 6]], 3.0));
        let e = merge(&[a.clone(), b]).unwrap_err().to_string();
        assert!(e.contains("overlap"), "{e}");
        let c = (PathBuf::from("c"), state(vec![[4, 8]], 1.0));
        let m = merge(&[c.clone(), a.clone()]).unwrap();
        assert_eq!(m.header.ranges, vec![[0, 4], [4, 8]]);
        assert_eq!(m.samples(), 8);
        // Order of the arguments does not matter.
        assert_eq!(merge(&[a, c]).unwrap(), m);
        // Sums are exact: 3 + 1, and 1e-20 + 1e-20 (exactly twice the f32 nearest 1e-20).
        let p = &m.accum[0];
        assert_eq!(crate::accum::to_f64(&crate::accum::channel(p, 0)), 4.0);
        assert_eq!(
            crate::accum::to_f64(&crate::accum::channel(p, 2)),
            2.0 * f64::from(1e-20f32)
        );
        let sq = (9.0f64 - f64::from(1e-9f32)) + (1.0 - f64::from(1e-9f32));
        assert_eq!(p.sum_sq[0] as f64 - p.sum_sq_c[0] as f64, sq);
    }
    /// A part of a 4-part split of 16 samples, whole.
    fn part(index: u32) -> (PathBuf, Checkpoint) {
        let p = Part::new(index, 4, 16).unwrap();
        let mut c = state(vec![p.range()], 1.0);
        c.header.part = Some(p);
        (PathBuf::from(format!("part-{index}.ckpt")), c)
    }

    /// The parts of a split merge when all are there once and whole; a missing, duplicated or unfinished
    /// part, a part of another split and a state that is not a part are refused, naming the files.
    #[test]
    fn a_split_is_merged_only_whole() {
        let all: Vec<_> = (0..4).map(part).collect();
        let m = merge(&all).unwrap();
        assert_eq!(m.samples(), 16);
        assert_eq!(m.header.part, None);
        let err = |parts: &[(PathBuf, Checkpoint)]| merge(parts).unwrap_err().to_string();

        let e = err(&[part(0), part(2)]);
        assert!(
            e.contains("2 of the 4 parts")
                && e.contains("1/4 (samples 4..8)")
                && e.contains("3/4 (samples 12..16)"),
            "{e}"
        );
        let mut copy = part(1);
        copy.0 = PathBuf::from("copy-of-1.ckpt");
        let e = err(&[part(0), part(1), copy, part(2), part(3)]);
        assert!(
            e.contains("copy-of-1.ckpt") && e.contains("part-1.ckpt") && e.contains("again"),
            "{e}"
        );
        let mut cut = part(2);
        cut.1.header.ranges = vec![[8, 10]];
        let e = err(&[part(0), part(1), cut, part(3)]);
        assert!(
            e.contains("part-2.ckpt") && e.contains("8..10") && e.contains("--resume"),
            "{e}"
        );
        let mut other = part(3);
        other.1.header.part = Some(Part::new(3, 4, 32).unwrap());
        other.1.header.ranges = vec![other.1.header.part.unwrap().range()];
        assert!(err(&[part(0), part(1), part(2), other]).contains("32-sample"));
        let plain = (PathBuf::from("range.ckpt"), state(vec![[16, 20]], 1.0));
        let e = err(&[part(0), part(1), part(2), part(3), plain]);
        assert!(e.contains("range.ckpt") && e.contains("not a part"), "{e}");
    }
}
