//! Checkpoints and partial renders: the renderer's accumulation state on disk.
//!
//! A checkpoint holds, for every pixel, the accumulator exactly as the GPU holds it (`GpuAccum`: each
//! channel's exact sum of samples as a long accumulator, and the Kahan pair of the sum of their squares),
//! which sample indices it holds, and
//! the identity of the render they belong to. Because a sample's random numbers depend only on (pixel,
//! sample index, dimension, seed) and the GPU adds samples to a pixel in index order, uploading the
//! state and going on with the next sample index gives the same bits as a render that never stopped.
//!
//! The same file is a *partial render* when it holds a range of samples (`--sample-range A..B`);
//! [`merge::merge`] adds partial renders of disjoint ranges into the state of their union. The sums of
//! samples are exact integers, so the merged sums, and the image, have the bits of a single render of the
//! union.
//!
//! File layout (all integers and floats little-endian):
//!
//! | bytes | content |
//! | --- | --- |
//! | 8 | magic `VKPATHCP` |
//! | 4 | format version (u32, [`FORMAT_VERSION`]) |
//! | 4 | header length H (u32, at most [`MAX_HEADER_BYTES`]) |
//! | H | header, UTF-8 JSON ([`Header`]) |
//! | 96 × width × height | the pixels' `GpuAccum`, row-major from the top-left: 18 u32 limbs (3 channels × 6, little-endian limb order), then 3 f32 sums of squares and their 3 f32 compensations |
//! | 4 | CRC-32 (IEEE) of every byte before it: magic, version, header and pixels |
//!
//! The checksum covers the header too: an edited sample range or identity is refused like a damaged
//! pixel, before anything in the file is used. Files are written atomically (temporary file, fsync,
//! rename): a crash leaves the previous checkpoint or the new one, never a mix.

pub mod merge;

use crate::Error;
use crate::film::{Film, write_atomically_with};
use crate::kernel::abi::GpuAccum;
use crate::scene::{Gamma, ImageSettings, Scene};
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::path::Path;

// A header holds the render's identity, defined beside the renderer (which computes it) so that the
// renderer does not depend on this file format. Re-exported because a header cannot be built or read
// without it (tests/fuzz_scene.rs builds one through this path).
pub use crate::render::identity::{Identity, VKPATH_VERSION};

/// The first bytes of every checkpoint file.
pub const MAGIC: [u8; 8] = *b"VKPATHCP";
/// The layout version; a file of another version is refused.
/// Version 3: the checksum covers the whole file (version 2 checked only the pixels; version 1 held
/// Kahan pairs instead of exact sums).
pub const FORMAT_VERSION: u32 = 3;
/// A header longer than this is refused before it is read (it is a few hundred bytes).
pub const MAX_HEADER_BYTES: u32 = 1 << 20;

const ACCUM_BYTES: usize = std::mem::size_of::<GpuAccum>();

// ---------------------------------------------------------------------------------------------------
// The header
// ---------------------------------------------------------------------------------------------------

/// The display transform, kept so that `vkpath merge` can write PNGs as the scene would.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Display {
    pub exposure: f32,
    /// A power (`2.2`) or `null` for the sRGB curve.
    pub gamma: Option<f32>,
    /// `render.tonemap` ("none" when absent: checkpoints written before it existed).
    #[serde(default)]
    pub tonemap: crate::scene::Tonemap,
}

impl Display {
    pub fn of(image: &ImageSettings) -> Display {
        Display {
            exposure: image.exposure,
            gamma: match image.gamma {
                Gamma::Power(g) => Some(g),
                Gamma::Srgb => None,
            },
            tonemap: image.tonemap,
        }
    }

    /// Image settings for writing a film of `width` x `height` with this display transform.
    pub fn image_settings(&self, width: u32, height: u32) -> ImageSettings {
        ImageSettings {
            width,
            height,
            exposure: self.exposure,
            gamma: match self.gamma {
                Some(g) => Gamma::Power(g),
                None => Gamma::Srgb,
            },
            tonemap: self.tonemap,
        }
    }
}

/// The JSON header of a checkpoint file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    pub identity: Identity,
    /// The scene as the user named it (for messages only).
    pub scene: String,
    /// The device (or devices, after a merge) that computed the sums.
    pub device: String,
    /// The sample indices held, as sorted, disjoint, non-empty half-open ranges `[start, end)`. One range
    /// is one unbroken chain of passes (a render, resumed or not); several come from a merge.
    pub ranges: Vec<[u32; 2]>,
    pub display: Display,
}

/// The ranges' total sample count, or why the ranges are invalid.
fn count_samples(ranges: &[[u32; 2]]) -> Result<u32, String> {
    if ranges.is_empty() {
        return Err("it holds no samples".into());
    }
    let mut total: u64 = 0;
    for (i, r) in ranges.iter().enumerate() {
        if r[0] >= r[1] {
            return Err(format!("its sample range {}..{} is empty", r[0], r[1]));
        }
        if i > 0 && ranges[i - 1][1] > r[0] {
            return Err(format!(
                "its sample ranges {}..{} and {}..{} overlap or are out of order",
                ranges[i - 1][0],
                ranges[i - 1][1],
                r[0],
                r[1]
            ));
        }
        total += u64::from(r[1] - r[0]);
    }
    u32::try_from(total).map_err(|_| "it holds more than 2^32 - 1 samples per pixel".into())
}

/// Ranges written as `0..64, 128..192`.
pub fn show_ranges(ranges: &[[u32; 2]]) -> String {
    ranges
        .iter()
        .map(|r| format!("{}..{}", r[0], r[1]))
        .collect::<Vec<_>>()
        .join(", ")
}

// ---------------------------------------------------------------------------------------------------
// The state
// ---------------------------------------------------------------------------------------------------

/// An accumulation state: what [`crate::Renderer::accum_state`] reads back, and what a checkpoint file
/// holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub header: Header,
    /// One entry per pixel, row-major from the top-left.
    pub accum: Vec<GpuAccum>,
}

impl Checkpoint {
    /// The renderer's current state (read back from the device) as a checkpoint of a render of `scene`.
    pub fn of(renderer: &mut crate::Renderer, scene: &Scene) -> Result<Checkpoint, Error> {
        let accum = renderer.accum_state()?;
        Ok(Checkpoint {
            header: Header {
                identity: renderer.identity(),
                scene: scene.display_name(),
                device: renderer.context().device_info().name.clone(),
                ranges: renderer.ranges().to_vec(),
                display: Display::of(&scene.image),
            },
            accum,
        })
    }

    /// Samples per pixel held.
    pub fn samples(&self) -> u32 {
        count_samples(&self.header.ranges).unwrap_or(0)
    }

    /// The next sample index a render going on from this state traces: the end of its last range.
    pub fn next_sample(&self) -> u32 {
        self.header.ranges.last().map_or(0, |r| r[1])
    }

    /// Means and variances, exactly as the renderer's `film()` would give them for this state.
    pub fn film(&self) -> Film {
        Film::from_sums(
            self.header.identity.width,
            self.header.identity.height,
            self.samples(),
            &self.accum,
        )
    }

    /// Image settings with the stored display transform.
    pub fn image_settings(&self) -> ImageSettings {
        self.header
            .display
            .image_settings(self.header.identity.width, self.header.identity.height)
    }

    /// Writes the state to `path` atomically (temporary file, fsync, rename).
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        let payload = accum_bytes(&self.accum);
        let json = serde_json::to_vec(&self.header).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            message: format!("cannot encode the checkpoint header: {e}"),
        })?;
        let header_len = u32::try_from(json.len()).unwrap_or(u32::MAX);
        let mut crc = crc32fast::Hasher::new();
        let head = [
            &MAGIC[..],
            &FORMAT_VERSION.to_le_bytes(),
            &header_len.to_le_bytes(),
        ]
        .concat();
        for part in [&head[..], &json, &payload] {
            crc.update(part);
        }
        let crc = crc.finalize();
        write_atomically_with(path, |f| {
            f.write_all(&head)?;
            f.write_all(&json)?;
            f.write_all(&payload)?;
            f.write_all(&crc.to_le_bytes())
        })
    }

    /// Reads and checks a state file: magic, version, header, sizes and checksum. Never panics on any
    /// bytes; every problem is an [`Error::Checkpoint`] naming the file.
    pub fn read(path: &Path) -> Result<Checkpoint, Error> {
        let cannot = |e: std::io::Error| Error::Checkpoint {
            path: path.to_path_buf(),
            message: format!("cannot read the checkpoint: {e}. Check the path."),
        };
        let file = std::fs::File::open(path).map_err(cannot)?;
        let len = file.metadata().map_err(cannot)?.len();
        // The header is checked, and the file's length against it, before the pixels are read: a
        // wrong file of many GB is refused without being read.
        Checkpoint::decode(&mut std::io::BufReader::new(file), len).map_err(|e| match e {
            Decode::Io(e) => cannot(e),
            Decode::Invalid(message) => Error::Checkpoint {
                path: path.to_path_buf(),
                message: format!("{message}. The file is not a usable vkpath checkpoint."),
            },
        })
    }

    /// Parses a state file's bytes; the error says what is wrong, without the file name.
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, String> {
        Checkpoint::decode(&mut &bytes[..], bytes.len() as u64).map_err(|e| match e {
            Decode::Io(e) => e.to_string(),
            Decode::Invalid(m) => m,
        })
    }

    /// Decodes a state from `r`, which holds `len` bytes.
    fn decode(r: &mut impl Read, len: u64) -> Result<Checkpoint, Decode> {
        let invalid = |m: String| Decode::Invalid(m);
        let ends = || Decode::Invalid("it ends inside its header".into());
        let mut head = [0u8; 16];
        if len < head.len() as u64 {
            // Too short for the fixed part: say whether it even starts like a checkpoint.
            let mut some = Vec::new();
            r.take(16).read_to_end(&mut some).map_err(Decode::Io)?;
            if !MAGIC.starts_with(&some[..some.len().min(MAGIC.len())]) {
                return Err(invalid(SIGNATURE.into()));
            }
            return Err(ends());
        }
        r.read_exact(&mut head).map_err(Decode::Io)?;
        if head[..8] != MAGIC {
            return Err(invalid(SIGNATURE.into()));
        }
        let version = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
        if version != FORMAT_VERSION {
            return Err(invalid(format!(
                "its layout version is {version}, and this vkpath reads version {FORMAT_VERSION}"
            )));
        }
        let header_len = u32::from_le_bytes([head[12], head[13], head[14], head[15]]);
        if header_len > MAX_HEADER_BYTES || u64::from(header_len) > len - 16 {
            return Err(invalid(format!(
                "its header length ({header_len} bytes) is larger than the file or the limit of {MAX_HEADER_BYTES}"
            )));
        }
        let mut json = vec![0u8; header_len as usize];
        r.read_exact(&mut json).map_err(Decode::Io)?;
        // The header is parsed for the sizes only; nothing in it is trusted before the checksum.
        let header: Header = serde_json::from_slice(&json)
            .map_err(|e| invalid(format!("its header is not valid: {e}")))?;
        let id = &header.identity;
        let pixels = u64::from(id.width) * u64::from(id.height);
        if pixels == 0 || pixels > 1 << 28 {
            return Err(invalid(format!(
                "its image size {}x{} is outside 1..=2^28 pixels",
                id.width, id.height
            )));
        }
        let expected = pixels * ACCUM_BYTES as u64;
        let held = len - 16 - u64::from(header_len);
        if held != expected + 4 {
            return Err(invalid(format!(
                "it should hold {} bytes of pixel data and checksum for {}x{} pixels but holds {held} (a truncated or damaged file)",
                expected + 4,
                id.width,
                id.height
            )));
        }
        let mut payload = vec![0u8; expected as usize];
        r.read_exact(&mut payload).map_err(Decode::Io)?;
        let mut stored = [0u8; 4];
        r.read_exact(&mut stored).map_err(Decode::Io)?;
        let mut crc = crc32fast::Hasher::new();
        for part in [&head[..], &json, &payload] {
            crc.update(part);
        }
        let (crc, stored) = (crc.finalize(), u32::from_le_bytes(stored));
        if crc != stored {
            return Err(invalid(format!(
                "it fails its checksum (CRC-32 {crc:08x} of its header and pixels, {stored:08x} stored): \
                 the file is damaged or was edited"
            )));
        }
        count_samples(&header.ranges).map_err(invalid)?;
        Ok(Checkpoint {
            header,
            accum: accum_from_bytes(&payload),
        })
    }

    /// Refuses, with a message that says what differs and what to do, a state that does not belong to
    /// the render `identity` describes.
    pub fn check_identity(&self, path: &Path, identity: &Identity) -> Result<(), Error> {
        let differences = self.header.identity.differences(identity);
        if differences.is_empty() {
            return Ok(());
        }
        Err(Error::Checkpoint {
            path: path.to_path_buf(),
            message: format!(
                "this checkpoint belongs to another render (of {}): {}. Resume with the scene file and \
                 flags it was made with, or render afresh without --resume.",
                self.header.scene,
                differences.join("; ")
            ),
        })
    }
}

/// Why a state could not be decoded: the file could not be read, or its content is wrong.
enum Decode {
    Io(std::io::Error),
    Invalid(String),
}

const SIGNATURE: &str = "it does not start with the vkpath checkpoint signature";

/// The pixels as little-endian bytes.
fn accum_bytes(accum: &[GpuAccum]) -> std::borrow::Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        std::borrow::Cow::Borrowed(bytemuck::cast_slice(accum))
    } else {
        // Every field is a 4-byte word (u32 limbs, f32 sums): swap each word.
        let words: &[u32] = bytemuck::cast_slice(accum);
        std::borrow::Cow::Owned(words.iter().flat_map(|w| w.to_le_bytes()).collect())
    }
}

/// Pixels from little-endian bytes (a whole number of `GpuAccum`s).
fn accum_from_bytes(bytes: &[u8]) -> Vec<GpuAccum> {
    bytes
        .chunks_exact(ACCUM_BYTES)
        .map(|px| {
            let mut a = GpuAccum::default();
            let words: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut a));
            for (w, b) in words.iter_mut().zip(px.chunks_exact(4)) {
                *w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
            a
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::abi::ACCUM_LIMBS;

    /// A state of a 2x1 image holding `ranges`, built without a GPU (also used by the merge's tests).
    pub(super) fn state(ranges: Vec<[u32; 2]>, value: f32) -> Checkpoint {
        Checkpoint {
            header: Header {
                identity: Identity {
                    vkpath_version: VKPATH_VERSION.into(),
                    scene_hash: "0123456789abcdef".into(),
                    width: 2,
                    height: 1,
                    seed: 0,
                    max_bounces: 5,
                    roulette_depth: 3,
                    sampler: "independent".into(),
                    light_sampling: "mis".into(),
                },
                scene: "test".into(),
                device: "dev".into(),
                ranges,
                display: Display {
                    exposure: 1.0,
                    gamma: Some(2.2),
                    tonemap: crate::scene::Tonemap::None,
                },
            },
            accum: vec![
                {
                    let mut a = GpuAccum::default();
                    for (c, x) in [value, 0.5, 1e-20].into_iter().enumerate() {
                        let mut limbs = [0u32; ACCUM_LIMBS];
                        crate::accum::add_f32(&mut limbs, x);
                        crate::accum::set_channel(&mut a, c, &limbs);
                    }
                    a.sum_sq = [value * value, 0.25, 0.0];
                    a.sum_sq_c = [1e-9, 0.0, 0.0];
                    a
                };
                2
            ],
        }
    }

    #[test]
    fn bytes_round_trip_and_damage_is_detected() {
        let s = state(vec![[0, 4]], 3.0);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.ckpt");
        s.write(&path).unwrap();
        let back = Checkpoint::read(&path).unwrap();
        assert_eq!(back.accum, s.accum);
        assert_eq!(back.header.ranges, s.header.ranges);
        let mut bytes = std::fs::read(&path).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        assert!(
            Checkpoint::from_bytes(&bytes)
                .unwrap_err()
                .contains("checksum")
        );
        assert!(
            Checkpoint::from_bytes(&bytes[..bytes.len() - 64])
                .unwrap_err()
                .contains("truncated")
        );
        // Every prefix is refused without a panic.
        for n in 0..bytes.len() {
            assert!(Checkpoint::from_bytes(&bytes[..n]).is_err());
        }
    }

    /// Issue 18, failure 1: the checksum covers the header. A checkpoint whose stored sample range is
    /// edited from 0..4 to 0..5 (the same length, valid JSON, a consistent file otherwise) was resumed as
    /// if it held 5 samples per pixel: an image 20 % too dark. Now it is refused.
    #[test]
    fn an_edited_header_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.ckpt");
        state(vec![[0, 4]], 3.0).write(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let at = bytes
            .windows(7)
            .position(|w| w == b"[[0,4]]")
            .expect("the ranges in the header");
        let mut edited = bytes.clone();
        edited[at + 4] = b'5';
        let e = Checkpoint::from_bytes(&edited).unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        // And every single-bit flip anywhere in the file is refused.
        for i in 0..bytes.len() {
            let mut flipped = bytes.clone();
            flipped[i] ^= 0x04;
            assert!(
                Checkpoint::from_bytes(&flipped).is_err(),
                "bit flip at byte {i} accepted"
            );
        }
    }

    /// A wrong file of many GB (sparse here) is refused from its first bytes, or from its length, without
    /// its content being read.
    #[test]
    fn huge_wrong_files_are_refused_without_being_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big");
        std::fs::File::create(&path)
            .unwrap()
            .set_len(8 << 30)
            .unwrap();
        let start = std::time::Instant::now();
        let e = Checkpoint::read(&path).unwrap_err().to_string();
        assert!(e.contains("signature"), "{e}");
        // A valid header followed by gigabytes: the length is wrong for the image it describes.
        let good = dir.path().join("good");
        state(vec![[0, 1]], 1.0).write(&good).unwrap();
        let bytes = std::fs::read(&good).unwrap();
        let f = std::fs::File::create(&path).unwrap();
        std::io::Write::write_all(&mut &f, &bytes).unwrap();
        f.set_len(8 << 30).unwrap();
        let e = Checkpoint::read(&path).unwrap_err().to_string();
        assert!(e.contains("truncated or damaged"), "{e}");
        assert!(start.elapsed().as_secs() < 2, "the files were read");
    }
}
