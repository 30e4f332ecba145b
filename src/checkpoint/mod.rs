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
//! | 8 | payload length P (u64) |
//! | P | the pixels' `GpuAccum`s, byte-planar in blocks, compressed by Zstandard (below) |
//! | 8 | only when the header has `aux_samples`: aux length Q (u64) |
//! | Q | only then: the denoiser's aux images ([`Aux`]: albedo RGB then normal XYZ, f32, compressed) |
//! | 8 | only when the header has `splat`: splat length S (u64) |
//! | S | only then: a splatted render's `GpuSplatAccum`s, byte-planar and compressed as the pixels are |
//! | 8 | only when the header has `adaptive`: length A (u64) |
//! | A | only then: an adaptive render's `[samples, still sampling (0 or 1)]` per pixel (two u32), compressed so |
//! | 4 | CRC-32 (IEEE) of every byte before it: magic, version, header, lengths and payloads |
//!
//! The pixels are row-major from the top-left; each is 96 bytes: 18 u32 limbs (3 channels × 6,
//! little-endian limb order), then 3 f32 sums of squares and their 3 f32 compensations. They are cut into
//! blocks of [`PLANAR_BLOCK`] pixels, and each block is written as 96 planes: byte 0 of every pixel of
//! the block, then byte 1, and so on (the "shuffle" filter of Blosc and HDF5). The high limbs of the
//! exact sums are zero in almost every pixel and the exponent bytes of the f32 sums vary slowly, so
//! their planes are long runs that Zstandard compresses to almost nothing; interleaved, they would sit
//! between noisy low limbs. The planar layout and the compression are exact: the decoded pixels are the
//! bits that were written. The encoder is single-threaded at a fixed level, so the same state always
//! gives the same file (a retried farm task writes the same bytes).
//!
//! The checksum covers the header too: an edited sample range or identity is refused like a damaged
//! pixel, before anything in the file is used (the compressed payload is checked before it is
//! decompressed). Files are written atomically (temporary file, fsync, rename): a crash leaves the
//! previous checkpoint or the new one, never a mix.
//!
//! Version 3 files (the same header, the pixels uncompressed and interleaved, no payload length) are
//! still read.

pub mod merge;

use crate::Error;
use crate::film::Film;
use crate::fs_atomic::write_atomically_with;
use crate::kernel::abi::{GpuAccum, GpuSplatAccum};
use crate::scene::{Gamma, ImageSettings, Scene};
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::path::Path;

// A header holds the render's identity, defined beside the renderer (which computes it) so that the
// renderer does not depend on this file format. Re-exported because a header cannot be built or read
// without it (tests/fuzz_scene.rs builds one through this path).
pub use crate::render::identity::Identity;

/// The first bytes of every checkpoint file.
pub const MAGIC: [u8; 8] = *b"VKPATHCP";
/// The layout version written. Version 4: the pixels byte-planar and compressed. Version 3 (read too):
/// uncompressed, and the checksum covers the whole file (version 2 checked only the pixels; version 1
/// held Kahan pairs instead of exact sums); older versions are refused.
pub const FORMAT_VERSION: u32 = 4;
/// The uncompressed layout, still read.
const FORMAT_VERSION_UNCOMPRESSED: u32 = 3;
/// Pixels per block of the byte-planar layout: 1.5 MiB blocks, large enough that each plane is a long
/// run for the compressor, small enough to stay in cache while a block is transposed.
pub const PLANAR_BLOCK: usize = 1 << 14;
/// Zstandard's level for checkpoints: level 3 (its default) compresses a 1080p state at a few hundred
/// MB/s on one core, so a checkpoint costs well under a second, and higher levels gain little on the
/// planar data (docs/reliability.md has the measured sizes).
const ZSTD_LEVEL: i32 = 3;
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
    /// `render.denoise`: the merged frame is denoised (`vkpath merge` does as `--denoise` asks).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub denoise: bool,
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
            denoise: image.denoise,
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
            denoise: self.denoise,
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
    /// Which part of a farm render this is (`--part I/N`), so that `vkpath merge` can tell a missing,
    /// duplicated or unfinished part by name; absent for any other state.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<Part>,
    /// The file carries the denoiser's aux images ([`Aux`]), rendered with this many samples per pixel:
    /// a part of a render to be denoised (`--denoise`), so that `vkpath merge --denoise` can denoise
    /// the frame. Absent otherwise (and in files from before aux images were kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aux_samples: Option<u32>,
    /// The file carries a splatted render's splatted sums ([`Checkpoint::splat`], `render.splat`) after
    /// the aux images. Absent (false) otherwise.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub splat: bool,
    /// The file carries an adaptive render's per-pixel counts ([`Checkpoint::adaptive`],
    /// `render.adaptive`) after the splatted sums. Absent (false) otherwise.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub adaptive: bool,
}

/// The albedo and normal images a denoiser reads beside the image (`session::aov_layers`), one entry
/// per pixel, row-major: what a part of a render to be denoised carries for the merge. Every part of a
/// render renders the same ones (the same samples 0..min(S, AOV_MAX_SPP) of the whole render's S).
#[derive(Clone, Debug, PartialEq)]
pub struct Aux {
    pub albedo: Vec<[f32; 3]>,
    /// Unit normals (or zero where no surface was hit), components in [-1, 1].
    pub normal: Vec<[f32; 3]>,
}

impl Aux {
    /// The aux images of the albedo and normal AOV films (`render::render_aov`).
    pub fn from_films(albedo: &Film, normal: &Film) -> Aux {
        Aux {
            albedo: albedo.mean.clone(),
            normal: normal
                .mean
                .iter()
                .map(|p| crate::output::normal_from_film(*p))
                .collect(),
        }
    }
}

/// Part `index` (0-based) of `count` of a render of `samples` samples per pixel (`--part I/N`): the
/// contiguous sample range [floor(index S / N), floor((index + 1) S / N)). Consecutive parts tile
/// 0..S exactly and their sizes differ by at most one sample per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Part {
    pub index: u32,
    pub count: u32,
    pub samples: u32,
}

impl Part {
    /// Part `index` of `count` of `samples`, or why there is no such part: every part must hold at
    /// least one sample per pixel.
    pub fn new(index: u32, count: u32, samples: u32) -> Result<Part, String> {
        if count == 0 {
            return Err("a render cannot be cut into 0 parts".into());
        }
        if index >= count {
            return Err(format!(
                "there is no part {index} of {count}: parts are numbered from 0 to {}",
                count - 1
            ));
        }
        if count > samples {
            return Err(format!(
                "a render of {samples} samples per pixel cannot be cut into {count} parts of at least one \
                 sample each: use at most {samples} parts, or more samples (--spp)"
            ));
        }
        Ok(Part {
            index,
            count,
            samples,
        })
    }

    /// The part's sample indices [start, end).
    pub fn range(&self) -> [u32; 2] {
        let at = |i: u32| (u64::from(i) * u64::from(self.samples) / u64::from(self.count)) as u32;
        [at(self.index), at(self.index + 1)]
    }

    /// `I/N`, as `--part` takes it.
    pub fn show(&self) -> String {
        format!("{}/{}", self.index, self.count)
    }
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
    /// The denoiser's aux images, when `header.aux_samples` says the file has them.
    pub aux: Option<Aux>,
    /// A splatted render's splatted sums, one entry per pixel (exactly as the GPU holds them), when
    /// `header.splat` says the file has them.
    pub splat: Option<Vec<GpuSplatAccum>>,
    /// An adaptive render's `[samples taken, 1 if still sampling else 0]` per pixel, when
    /// `header.adaptive` says the file has them. The flag is needed: a pixel stopped by the check at
    /// sample n has n samples, as many as those that go on.
    pub adaptive: Option<Vec<[u32; 2]>>,
}

impl Checkpoint {
    /// The renderer's current state (read back from the device) as a checkpoint of a render of `scene`.
    pub fn of(renderer: &mut crate::Renderer, scene: &Scene) -> Result<Checkpoint, Error> {
        let adaptive = renderer.adaptive().map(|a| a.state());
        let accum = renderer.accum_state()?;
        let splat = if renderer.splats() {
            Some(renderer.splat_state()?)
        } else {
            None
        };
        Ok(Checkpoint {
            header: Header {
                identity: renderer.identity(),
                scene: scene.display_name(),
                device: renderer.context().device_info().name.clone(),
                ranges: renderer.ranges().to_vec(),
                display: Display::of(&scene.image),
                part: None,
                aux_samples: None,
                splat: splat.is_some(),
                adaptive: adaptive.is_some(),
            },
            accum,
            aux: None,
            splat,
            adaptive,
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
        let mut film = Film::for_sums(
            self.header.identity.width,
            self.header.identity.height,
            self.samples(),
        );
        if let Some(a) = &self.adaptive {
            film.pixel_spp = a.iter().map(|p| p[0]).collect();
        }
        film.push_sums(&self.accum);
        if let Some(splat) = &self.splat {
            film.push_splatted(0, splat);
        }
        film
    }

    /// Image settings with the stored display transform.
    pub fn image_settings(&self) -> ImageSettings {
        self.header
            .display
            .image_settings(self.header.identity.width, self.header.identity.height)
    }

    /// Writes the state to `path` atomically (temporary file, fsync, rename).
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        let encoding = |e: std::io::Error| Error::Io {
            path: path.to_path_buf(),
            message: format!("cannot encode the checkpoint: {e}"),
        };
        let json = serde_json::to_vec(&self.header).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            message: format!("cannot encode the checkpoint header: {e}"),
        })?;
        let payload = compress(&self.accum).map_err(encoding)?;
        // The optional sections, each when the header announces it (and only then: the two must
        // agree): its length, then its compressed bytes.
        let section = |bytes: Option<std::io::Result<Vec<u8>>>, announced: bool, what: &str| match (
            bytes, announced,
        ) {
            (Some(bytes), true) => {
                let bytes = bytes.map_err(encoding)?;
                Ok([&(bytes.len() as u64).to_le_bytes()[..], &bytes].concat())
            }
            (None, false) => Ok(Vec::new()),
            _ => Err(Error::Io {
                path: path.to_path_buf(),
                message: format!("the checkpoint's {what} and its header disagree (a bug)"),
            }),
        };
        let aux = section(
            self.aux.as_ref().map(compress_aux),
            self.header.aux_samples.is_some(),
            "aux images",
        )?;
        let splat = section(
            self.splat.as_deref().map(compress),
            self.header.splat,
            "splatted sums",
        )?;
        let adaptive = section(
            self.adaptive.as_deref().map(compress),
            self.header.adaptive,
            "adaptive counts",
        )?;
        let header_len = u32::try_from(json.len()).unwrap_or(u32::MAX);
        let head = [
            &MAGIC[..],
            &FORMAT_VERSION.to_le_bytes(),
            &header_len.to_le_bytes(),
        ]
        .concat();
        let payload_len = (payload.len() as u64).to_le_bytes();
        let mut crc = crc32fast::Hasher::new();
        for part in [
            &head[..],
            &json,
            &payload_len,
            &payload,
            &aux,
            &splat,
            &adaptive,
        ] {
            crc.update(part);
        }
        let crc = crc.finalize();
        write_atomically_with(path, |f| {
            f.write_all(&head)?;
            f.write_all(&json)?;
            f.write_all(&payload_len)?;
            f.write_all(&payload)?;
            f.write_all(&aux)?;
            f.write_all(&splat)?;
            f.write_all(&adaptive)?;
            f.write_all(&crc.to_le_bytes())
        })
    }

    /// Reads and checks a state file: magic, version, header, sizes and checksum. Never panics on any
    /// bytes; every problem is an [`Error::Checkpoint`] naming the file.
    pub fn read(path: &Path) -> Result<Checkpoint, Error> {
        // The header is checked, and the file's length against it, before the pixels are read: a
        // wrong file of many GB is refused without being read.
        decode_file(path, Checkpoint::decode)
    }

    /// Parses a state file's bytes; the error says what is wrong, without the file name.
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, String> {
        Checkpoint::decode(&mut &bytes[..], bytes.len() as u64).map_err(|e| match e {
            Decode::Io(e) => e.to_string(),
            Decode::Invalid(m) | Decode::TooLarge(m) => m,
        })
    }

    /// The header of a state file alone: its identity, ranges and part, checked for shape and size but
    /// not yet against the checksum (which covers the pixels, not read here). What a resume or a merge
    /// checks before reading any pixels: a state of another render, or too large for the machine, is
    /// refused without decoding them.
    pub fn read_header(path: &Path) -> Result<Header, Error> {
        decode_file(path, |r, len| {
            Checkpoint::decode_header(r, len).map(|h| h.header)
        })
    }

    /// Decodes the fixed part and the JSON header from `r`, which holds `len` bytes, and checks the
    /// image size the header claims (1 to 2^28 pixels, and no more than the machine's available memory
    /// can hold decoded).
    fn decode_header(r: &mut impl Read, len: u64) -> Result<Head, Decode> {
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
        let compressed = match version {
            FORMAT_VERSION => true,
            FORMAT_VERSION_UNCOMPRESSED => false,
            _ => {
                return Err(invalid(format!(
                    "its layout version is {version}, and this vkpath reads versions \
                     {FORMAT_VERSION_UNCOMPRESSED} and {FORMAT_VERSION}"
                )));
            }
        };
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
        Ok(Head {
            head,
            json,
            header,
            compressed,
            pixels,
        })
    }

    /// Decodes a state from `r`, which holds `len` bytes.
    fn decode(r: &mut impl Read, len: u64) -> Result<Checkpoint, Decode> {
        let invalid = |m: String| Decode::Invalid(m);
        let Head {
            head,
            json,
            header,
            compressed,
            pixels,
        } = Checkpoint::decode_header(r, len)?;
        let header_len = json.len() as u32;
        let id = &header.identity;
        // A header with a correct checksum may still claim 16384 x 16384 pixels (24 GiB decoded) for a
        // payload of a few kB: checked against the machine before anything that size is allocated.
        let aux_bytes = if header.aux_samples.is_some() {
            AUX_BYTES as u64
        } else {
            0
        } + if header.splat { SPLAT_BYTES as u64 } else { 0 }
            + if header.adaptive {
                ADAPTIVE_BYTES as u64
            } else {
                0
            };
        crate::memory::check_available(
            pixels * (crate::render::host_use::CHECKPOINT_BYTES_PER_PIXEL + aux_bytes),
            &format!("decoding its {}x{} pixels", id.width, id.height),
        )
        .map_err(Decode::TooLarge)?;
        let expected = pixels * ACCUM_BYTES as u64;
        let held = len - 16 - u64::from(header_len);
        let truncated = |should: String| {
            invalid(format!(
                "it should hold {should} for {}x{} pixels but holds {held} bytes after its header (a \
                 truncated or damaged file)",
                id.width, id.height
            ))
        };
        let mut crc = crc32fast::Hasher::new();
        crc.update(&head);
        crc.update(&json);
        let payload_len = if compressed {
            let mut l = [0u8; 8];
            if held < 12 {
                return Err(truncated(
                    "a payload length, a payload and a checksum".into(),
                ));
            }
            r.read_exact(&mut l).map_err(Decode::Io)?;
            crc.update(&l);
            let payload_len = u64::from_le_bytes(l);
            // With aux images or splatted sums, their lengths and bytes follow the payload (their sizes
            // checked below).
            let sections = u64::from(header.aux_samples.is_some())
                + u64::from(header.splat)
                + u64::from(header.adaptive);
            let fits = |payload_len: u64| match sections {
                0 => held == 8 + payload_len + 4,
                n => held >= 8 + payload_len + 8 * n + 4,
            };
            if payload_len > max_compressed_len(expected) || !fits(payload_len) {
                return Err(truncated(format!(
                    "8 bytes of length, {payload_len} of compressed pixels (at most {}) and 4 of checksum",
                    max_compressed_len(expected)
                )));
            }
            payload_len
        } else {
            if held != expected + 4 {
                return Err(truncated(format!(
                    "{} bytes of pixel data and checksum",
                    expected + 4
                )));
            }
            expected
        };
        let mut payload = vec![0u8; payload_len as usize];
        r.read_exact(&mut payload).map_err(Decode::Io)?;
        crc.update(&payload);
        // The optional sections, aux images then splatted sums: each its length and its compressed
        // bytes, present when the header announces it (only compressed files hold them). After the last,
        // exactly the checksum remains.
        let mut consumed = if compressed {
            8 + payload_len
        } else {
            payload_len
        };
        let mut section = |announced: bool, what: &str, decoded: u64| -> Result<Vec<u8>, Decode> {
            if !announced {
                return Ok(Vec::new());
            }
            if !compressed {
                return Err(invalid(format!(
                    "its header announces {what}, which only compressed files hold"
                )));
            }
            let mut l = [0u8; 8];
            r.read_exact(&mut l).map_err(Decode::Io)?;
            crc.update(&l);
            let len = u64::from_le_bytes(l);
            let max = max_compressed_len(decoded);
            if len > max || held < consumed + 8 + len + 4 {
                return Err(truncated(format!(
                    "{consumed} bytes of lengths and compressed data, 8 of the {what}' length, {len} of \
                     {what} (at most {max}) and 4 of checksum"
                )));
            }
            let mut bytes = vec![0u8; len as usize];
            r.read_exact(&mut bytes).map_err(Decode::Io)?;
            crc.update(&bytes);
            consumed += 8 + len;
            Ok(bytes)
        };
        let aux_payload = section(
            header.aux_samples.is_some(),
            "aux images",
            pixels * AUX_BYTES as u64,
        )?;
        let splat_payload = section(header.splat, "splatted sums", pixels * SPLAT_BYTES as u64)?;
        let adaptive_payload = section(
            header.adaptive,
            "adaptive counts",
            pixels * ADAPTIVE_BYTES as u64,
        )?;
        if held != consumed + 4 {
            return Err(truncated(format!(
                "{consumed} bytes of lengths and compressed data and 4 of checksum"
            )));
        }
        let mut stored = [0u8; 4];
        r.read_exact(&mut stored).map_err(Decode::Io)?;
        let (crc, stored) = (crc.finalize(), u32::from_le_bytes(stored));
        if crc != stored {
            return Err(invalid(format!(
                "it fails its checksum (CRC-32 {crc:08x} of its header and pixels, {stored:08x} stored): \
                 the file is damaged or was edited"
            )));
        }
        let samples = count_samples(&header.ranges).map_err(invalid)?;
        if let Some(p) = header.part {
            Part::new(p.index, p.count, p.samples)
                .map_err(|m| invalid(format!("its part {} is not valid: {m}", p.show())))?;
        }
        let accum = if compressed {
            decompress(&payload, pixels as usize).map_err(|e| {
                invalid(format!(
                    "its pixel data does not decompress to {}x{} pixels ({e})",
                    id.width, id.height
                ))
            })?
        } else {
            accum_from_bytes(&payload)
        };
        let aux = if header.aux_samples.is_some() {
            Some(decompress_aux(&aux_payload, pixels as usize).map_err(|e| {
                invalid(format!(
                    "its aux images do not decompress to {}x{} pixels ({e})",
                    id.width, id.height
                ))
            })?)
        } else {
            None
        };
        let splat = if header.splat {
            Some(decompress(&splat_payload, pixels as usize).map_err(|e| {
                invalid(format!(
                    "its splatted sums do not decompress to {}x{} pixels ({e})",
                    id.width, id.height
                ))
            })?)
        } else {
            None
        };
        let adaptive = if header.adaptive {
            let counts: Vec<[u32; 2]> =
                decompress(&adaptive_payload, pixels as usize).map_err(|e| {
                    invalid(format!(
                        "its adaptive counts do not decompress to {}x{} pixels ({e})",
                        id.width, id.height
                    ))
                })?;
            if counts.iter().any(|&[n, on]| n > samples || on > 1) {
                return Err(invalid(format!(
                    "its adaptive counts are not valid (a pixel with more than its {samples} samples, or a \
                     flag other than 0 or 1)"
                )));
            }
            Some(counts)
        } else {
            None
        };
        Ok(Checkpoint {
            header,
            accum,
            aux,
            splat,
            adaptive,
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

impl Header {
    /// What a resume checks from the header alone, before any pixel is decoded: the image size (the
    /// rest of the identity needs the scene uploaded; [`Checkpoint::check_identity`] checks it then).
    /// A state of another size is refused, however many pixels it claims.
    pub fn check_image_size(&self, path: &Path, width: u32, height: u32) -> Result<(), Error> {
        let id = &self.identity;
        if (id.width, id.height) == (width, height) {
            return Ok(());
        }
        Err(Error::Checkpoint {
            path: path.to_path_buf(),
            message: format!(
                "this checkpoint belongs to another render (of {}): its image is {}x{}, this one {width}x{height} \
                 (--width/--height). Resume with the scene file and flags it was made with, or render afresh \
                 without --resume.",
                self.scene, id.width, id.height
            ),
        })
    }
}

/// Opens the state file `path` and decodes it (or a part of it) with `decode`, which is given a reader
/// and the file's length; a problem becomes an [`Error::Checkpoint`] naming the file.
fn decode_file<T>(
    path: &Path,
    decode: impl FnOnce(&mut std::io::BufReader<std::fs::File>, u64) -> Result<T, Decode>,
) -> Result<T, Error> {
    let cannot = |e: std::io::Error| Error::Checkpoint {
        path: path.to_path_buf(),
        message: format!("cannot read the checkpoint: {e}. Check the path."),
    };
    let file = std::fs::File::open(path).map_err(cannot)?;
    let len = file.metadata().map_err(cannot)?.len();
    decode(&mut std::io::BufReader::new(file), len).map_err(|e| match e {
        Decode::Io(e) => cannot(e),
        Decode::Invalid(message) => Error::Checkpoint {
            path: path.to_path_buf(),
            message: format!("{message}. The file is not a usable vkpath checkpoint."),
        },
        Decode::TooLarge(message) => Error::Checkpoint {
            path: path.to_path_buf(),
            message: format!("{message}: it is too large for this machine."),
        },
    })
}

/// Why a state could not be decoded: the file could not be read, or its content is wrong.
enum Decode {
    Io(std::io::Error),
    Invalid(String),
    /// The file claims more pixels than the machine's memory can hold decoded.
    TooLarge(String),
}

const SIGNATURE: &str = "it does not start with the vkpath checkpoint signature";

/// A state file's fixed part and header, decoded (see [`Checkpoint::decode_header`]).
struct Head {
    /// The 16 bytes before the header (magic, version, header length), for the checksum.
    head: [u8; 16],
    /// The header's bytes, for the checksum.
    json: Vec<u8>,
    header: Header,
    compressed: bool,
    pixels: u64,
}

/// The pixels (4-byte words only) as little-endian bytes.
fn accum_bytes<T: bytemuck::Pod>(accum: &[T]) -> std::borrow::Cow<'_, [u8]> {
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
        .map(pixel_from_bytes)
        .collect()
}

/// One pixel (a `GpuAccum` or a `GpuSplatAccum`: 4-byte words only) from its little-endian bytes.
fn pixel_from_bytes<T: bytemuck::Pod>(px: &[u8]) -> T {
    let mut a = T::zeroed();
    let words: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut a));
    for (w, b) in words.iter_mut().zip(px.chunks_exact(4)) {
        *w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    a
}

/// The most compressed bytes a state of `expected` uncompressed bytes may hold: Zstandard's worst case
/// (incompressible input stored in raw blocks) is a few bytes per 128 KiB block more than the input.
fn max_compressed_len(expected: u64) -> u64 {
    expected + expected / 1024 + 4096
}

/// Bytes per pixel of the aux images decoded: albedo and normal, three f32 each.
const AUX_BYTES: usize = 24;

/// The aux images as little-endian f32, albedo then normal, compressed by Zstandard (deterministic: one
/// thread, a fixed level).
fn compress_aux(aux: &Aux) -> std::io::Result<Vec<u8>> {
    let mut encoder = zstd::stream::write::Encoder::new(Vec::new(), ZSTD_LEVEL)?;
    encoder.include_checksum(false)?;
    encoder.include_contentsize(false)?;
    for image in [&aux.albedo, &aux.normal] {
        let bytes: Vec<u8> = image
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        encoder.write_all(&bytes)?;
    }
    encoder.finish()
}

/// The aux images of `pixels` pixels from their compressed bytes (exactly that many, nothing after).
fn decompress_aux(payload: &[u8], pixels: usize) -> std::io::Result<Aux> {
    let mut decoder = zstd::stream::read::Decoder::new(payload)?;
    let mut image = || -> std::io::Result<Vec<[f32; 3]>> {
        // Grown as it decodes (a short payload fails after allocating what it held).
        let mut out = Vec::new();
        let mut px = [0u8; 12];
        for _ in 0..pixels {
            decoder.read_exact(&mut px)?;
            let f = |i: usize| f32::from_le_bytes([px[i], px[i + 1], px[i + 2], px[i + 3]]);
            out.push([f(0), f(4), f(8)]);
        }
        Ok(out)
    };
    let albedo = image()?;
    let normal = image()?;
    let mut rest = [0u8; 1];
    if decoder.read(&mut rest)? != 0 {
        return Err(std::io::Error::other("more data than the pixels"));
    }
    Ok(Aux { albedo, normal })
}

/// Bytes per pixel of an adaptive render's counts decoded.
const ADAPTIVE_BYTES: usize = 8;

/// Bytes per pixel of the splatted sums decoded.
const SPLAT_BYTES: usize = std::mem::size_of::<GpuSplatAccum>();

/// The pixels (`GpuAccum`s, or a splatted render's `GpuSplatAccum`s), byte-planar by blocks (see the
/// module's documentation), compressed by Zstandard.
fn compress<T: bytemuck::Pod>(accum: &[T]) -> std::io::Result<Vec<u8>> {
    let size = std::mem::size_of::<T>();
    let mut encoder = zstd::stream::write::Encoder::new(Vec::new(), ZSTD_LEVEL)?;
    // The file's CRC-32 covers the payload; Zstandard's own frame checksum would only repeat it.
    encoder.include_checksum(false)?;
    encoder.include_contentsize(false)?;
    let mut planes = vec![0u8; PLANAR_BLOCK * size];
    for block in accum.chunks(PLANAR_BLOCK) {
        let n = block.len();
        for (p, px) in accum_bytes(block).chunks_exact(size).enumerate() {
            for (b, &v) in px.iter().enumerate() {
                planes[b * n + p] = v;
            }
        }
        encoder.write_all(&planes[..std::mem::size_of_val(block)])?;
    }
    encoder.finish()
}

/// `pixels` pixels from a compressed payload: exactly that many, or an error (a payload that
/// decompresses to more or fewer bytes is refused, and never allocates more than the pixels need).
fn decompress<T: bytemuck::Pod>(payload: &[u8], pixels: usize) -> std::io::Result<Vec<T>> {
    let size = std::mem::size_of::<T>();
    let mut decoder = zstd::stream::read::Decoder::new(payload)?;
    // Grown block by block as the payload decodes, not reserved whole: a short payload that claims many
    // pixels fails after allocating what it held.
    let mut accum = Vec::new();
    let mut planes = vec![0u8; PLANAR_BLOCK.min(pixels) * size];
    let mut px = vec![0u8; size];
    while accum.len() < pixels {
        let n = PLANAR_BLOCK.min(pixels - accum.len());
        decoder.read_exact(&mut planes[..n * size])?;
        accum.reserve(n);
        for p in 0..n {
            for (b, v) in px.iter_mut().enumerate() {
                *v = planes[b * n + p];
            }
            accum.push(pixel_from_bytes(&px));
        }
    }
    if decoder.read(&mut [0u8; 1])? != 0 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "more data than the pixels",
        ));
    }
    Ok(accum)
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
                    vkpath_version: crate::VKPATH_VERSION.into(),
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
                aux_samples: None,
                splat: false,
                adaptive: false,
                display: Display {
                    exposure: 1.0,
                    gamma: Some(2.2),
                    tonemap: crate::scene::Tonemap::None,
                    denoise: false,
                },
                part: None,
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
            aux: None,
            splat: None,
            adaptive: None,
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
    /// A state whose pixels hold arbitrary bits (noisy low limbs, zero high limbs in most pixels, any
    /// float bits) over more than one planar block round-trips exactly, and compresses.
    #[test]
    fn planar_compression_is_exact_across_blocks() {
        let pixels = PLANAR_BLOCK + 1234;
        let mut s = state(vec![[0, 4]], 1.0);
        s.header.identity.width = pixels as u32;
        s.header.identity.height = 1;
        let mut x: u64 = 0x9e3779b97f4a7c15;
        let mut next = move || {
            // xorshift64*: any bits, reproducibly.
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            (x.wrapping_mul(0x2545f4914f6cdd1d) >> 32) as u32
        };
        s.accum = (0..pixels)
            .map(|p| {
                let mut a = GpuAccum::default();
                let words: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut a));
                for (k, w) in words.iter_mut().enumerate() {
                    // Two low limbs per channel noisy, high limbs zero but in every 97th pixel.
                    let limb = k % ACCUM_LIMBS;
                    *w = if k >= 18 || limb < 2 || p % 97 == 0 {
                        next()
                    } else {
                        0
                    };
                }
                a
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.ckpt");
        s.write(&path).unwrap();
        let back = Checkpoint::read(&path).unwrap();
        // Compared as bits: random float bits include NaNs, which are not equal to themselves.
        let bits = |a: &[GpuAccum]| bytemuck::cast_slice::<GpuAccum, u8>(a).to_vec();
        assert!(bits(&back.accum) == bits(&s.accum), "the pixels changed");
        let size = std::fs::metadata(&path).unwrap().len() as usize;
        assert!(
            size < pixels * ACCUM_BYTES * 3 / 4,
            "{size} bytes for {} uncompressed",
            pixels * ACCUM_BYTES
        );
        // The same state writes the same bytes.
        let again = dir.path().join("again.ckpt");
        s.write(&again).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            std::fs::read(&again).unwrap()
        );
    }

    /// A version 3 file (uncompressed, interleaved pixels: what vkpath wrote before) is still read, to
    /// the same state.
    #[test]
    fn version_3_files_are_still_read() {
        let s = state(vec![[0, 4]], 3.0);
        let json = serde_json::to_vec(&s.header).unwrap();
        let mut bytes = [
            &MAGIC[..],
            &3u32.to_le_bytes(),
            &(json.len() as u32).to_le_bytes(),
            &json,
            &accum_bytes(&s.accum),
        ]
        .concat();
        let crc = crc32fast::hash(&bytes);
        bytes.extend(crc.to_le_bytes());
        assert_eq!(Checkpoint::from_bytes(&bytes).unwrap(), s);
        // Version 2 is refused, naming both versions read.
        bytes[8] = 2;
        let e = Checkpoint::from_bytes(&bytes).unwrap_err();
        assert!(e.contains("version is 2") && e.contains("3 and 4"), "{e}");
    }

    /// A payload that decompresses to more or fewer pixels than the header says is refused, even with a
    /// valid checksum.
    #[test]
    fn a_payload_of_the_wrong_size_is_refused() {
        let s = state(vec![[0, 4]], 3.0);
        let json = serde_json::to_vec(&s.header).unwrap();
        for pixels in [1usize, 3] {
            let payload = compress(&vec![GpuAccum::default(); pixels]).unwrap();
            let mut bytes = [
                &MAGIC[..],
                &FORMAT_VERSION.to_le_bytes(),
                &(json.len() as u32).to_le_bytes(),
                &json,
                &(payload.len() as u64).to_le_bytes(),
                &payload,
            ]
            .concat();
            let crc = crc32fast::hash(&bytes);
            bytes.extend(crc.to_le_bytes());
            let e = Checkpoint::from_bytes(&bytes).unwrap_err();
            assert!(
                e.contains("does not decompress to 2x1 pixels"),
                "{pixels}: {e}"
            );
        }
    }

    /// Parts tile the render's samples exactly, in order, with sizes that differ by at most one; a part
    /// that would be empty is refused.
    #[test]
    fn parts_tile_the_samples() {
        for samples in [1u32, 2, 7, 64, 1000, u32::MAX] {
            for count in [1u32, 2, 3, 4, 7, 64, 1000] {
                if count > samples {
                    assert!(Part::new(0, count, samples).is_err());
                    continue;
                }
                let ranges: Vec<[u32; 2]> = (0..count)
                    .map(|i| Part::new(i, count, samples).unwrap().range())
                    .collect();
                assert_eq!(ranges[0][0], 0);
                assert_eq!(ranges[count as usize - 1][1], samples);
                for w in ranges.windows(2) {
                    assert_eq!(w[0][1], w[1][0]);
                }
                let sizes: Vec<u32> = ranges.iter().map(|r| r[1] - r[0]).collect();
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(*lo >= 1 && hi - lo <= 1, "{samples}/{count}: {lo}..{hi}");
            }
        }
        assert!(Part::new(4, 4, 16).is_err());
        assert!(Part::new(0, 0, 16).is_err());
    }
}
