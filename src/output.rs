//! Image files: what a render writes, and how.
//!
//! - PNG: the display image (8-bit, through the scene's display transform), tagged with the transfer
//!   curve it was encoded with (an `sRGB` chunk for the sRGB curve, a `gAMA` chunk for a power), so that
//!   viewers and browsers show it as vkpath meant it.
//! - EXR: linear radiance as 32-bit floats, `R`, `G`, `B`, and the layers asked for with `--aov`, as
//!   channels of the same part named `<layer>.<channel>` (the convention compositors and denoisers split
//!   layers by): `variance.R/G/B` (the estimated variance of each pixel's mean, s^2 / n), `albedo.R/G/B`,
//!   `normal.X/Y/Z` (world space) and `depth.Z` (distance along the camera ray; +inf where no sample hit).
//! - Both carry how the image was made ([`ImageMetadata`]): vkpath's version, the scene and its content
//!   hash, samples per pixel, seed, device and (for a render) seconds, as PNG `iTXt` chunks (UTF-8) and
//!   EXR header attributes, under the keys `vkpath:version`, `vkpath:scene`, `vkpath:scene_hash`,
//!   `vkpath:spp`, `vkpath:seed`, `vkpath:device` and `vkpath:seconds` (plus PNG's standard `Software`
//!   keyword and the EXR software attribute); `vkpath:denoised` says what denoised a denoised image (its
//!   EXR then holds the raw estimate as `raw.R/G/B`). An EXR also records the display transform its PNG
//!   siblings were encoded with (`vkpath:exposure`, `vkpath:gamma`: a number or `srgb`,
//!   `vkpath:tonemap`), so that `vkpath denoise` can write the same PNG from it.
//!
//! Several outputs are written all or nothing, as far as the file system allows: every file is encoded
//! and written to a temporary file beside its target first, and only when all of them are on disk are they
//! renamed over their targets. A failure before the renames leaves every target as it was; a rename that
//! fails after others succeeded (which needs the file system to fail between two renames in one
//! directory) is reported with the files already replaced named.

use crate::film::{Film, OutputFormat};
use crate::fs_atomic::{directory_of, sync_parent_dir, temp_path_for};
use crate::scene::{Gamma, ImageSettings};
use std::path::{Path, PathBuf};

/// How an image was made, written into it.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageMetadata {
    /// The scene as the user named it.
    pub scene: String,
    /// The render's content hash (the identity checkpoints are matched by).
    pub scene_hash: String,
    pub spp: u32,
    pub seed: u32,
    /// Seconds this run spent rendering (a resumed render counts its own run only); none for a merge, whose
    /// parts do not record their time (so that a retried part writes the same bytes as the first try).
    pub seconds: Option<f64>,
    pub device: String,
}

impl ImageMetadata {
    /// The (key, value) pairs, in the order they are written.
    pub fn entries(&self) -> Vec<(&'static str, String)> {
        let mut v = vec![
            ("vkpath:version", crate::VKPATH_VERSION.to_string()),
            ("vkpath:scene", self.scene.clone()),
            ("vkpath:scene_hash", self.scene_hash.clone()),
            ("vkpath:spp", self.spp.to_string()),
            ("vkpath:seed", self.seed.to_string()),
            ("vkpath:device", self.device.clone()),
        ];
        if let Some(s) = self.seconds {
            v.push(("vkpath:seconds", format!("{s:.3}")));
        }
        v
    }
}

impl ImageMetadata {
    /// The metadata an EXR written by vkpath records (None for any other EXR).
    pub fn from_attributes(exr: &ExrChannels) -> Option<ImageMetadata> {
        let text = |k: &str| exr.attribute(k).map(str::to_string);
        Some(ImageMetadata {
            scene: text("vkpath:scene")?,
            scene_hash: text("vkpath:scene_hash").unwrap_or_default(),
            spp: exr.attribute("vkpath:spp")?.parse().ok()?,
            seed: exr.attribute("vkpath:seed")?.parse().ok()?,
            seconds: exr
                .attribute("vkpath:seconds")
                .and_then(|s| s.parse().ok())
                .filter(|s: &f64| s.is_finite()),
            device: text("vkpath:device").unwrap_or_default(),
        })
    }
}

/// An extra EXR layer (`--aov`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Aov {
    /// The reflectance of the first non-specular surface a camera path meets, times the tint of the
    /// mirrors and glass on the way (what denoisers take as albedo).
    Albedo,
    /// The shading normal (world space, as the surface defines it: outward on spheres) at that surface.
    Normal,
    /// The estimated variance of each pixel's mean (s^2 / n), from the render's own sums.
    Variance,
    /// The distance from the camera to the first surface along the camera ray.
    Depth,
    /// The samples behind each pixel's mean (with adaptive sampling, each pixel's own count).
    Spp,
}

impl Aov {
    pub const ALL: [(Aov, &'static str); 5] = [
        (Aov::Albedo, "albedo"),
        (Aov::Normal, "normal"),
        (Aov::Variance, "variance"),
        (Aov::Depth, "depth"),
        (Aov::Spp, "spp"),
    ];

    /// Whether the layer comes from the render's own sums (no kernel of its own renders it).
    pub fn from_sums(self) -> bool {
        matches!(self, Aov::Variance | Aov::Spp)
    }

    pub fn name(self) -> &'static str {
        Aov::ALL
            .iter()
            .find(|(a, _)| *a == self)
            .map_or("?", |(_, n)| n)
    }

    /// `albedo,normal,variance,depth,spp` (any subset, any order, each once).
    pub fn parse_list(text: &str) -> Result<Vec<Aov>, String> {
        let mut list = Vec::new();
        for word in text.split(',').map(str::trim) {
            let Some((aov, _)) = Aov::ALL.iter().find(|(_, n)| *n == word) else {
                return Err(format!(
                    "\"{word}\" is not a layer vkpath writes; the layers are {}",
                    Aov::ALL.map(|(_, n)| n).join(", ")
                ));
            };
            if list.contains(aov) {
                return Err(format!("\"{word}\" is given twice"));
            }
            list.push(*aov);
        }
        list.sort();
        Ok(list)
    }
}

/// The layers beside the beauty image: the films of the kernel-computed AOVs (albedo's means are the
/// layer's values; normal's are n / 2 + 1/2; depth's film holds [mean distance over all samples with
/// misses as 0, fraction of samples that hit, 0]), and whether to write the variance.
#[derive(Clone, Debug, Default)]
pub struct Layers {
    pub variance: bool,
    /// Write the samples behind each pixel (`spp.Y`).
    pub spp: bool,
    pub albedo: Option<Film>,
    pub normal: Option<Film>,
    pub depth: Option<Film>,
    /// Channels written as they are (name, one value per pixel): the raw estimate beside a denoised
    /// image (`raw.R/G/B`), the layers `vkpath denoise` carries over from its input.
    pub extra: Vec<(String, Vec<f32>)>,
}

/// A normal film's mean as the unit normal it encodes: the kernel accumulates n / 2 + 1/2 (the
/// accumulator sums non-negative values only), so n = 2 m - 1.
pub fn normal_from_film(m: [f32; 3]) -> [f32; 3] {
    m.map(|v| 2.0 * v - 1.0)
}

/// The raw estimate `color` as the EXR channels `raw.R`, `raw.G`, `raw.B`, written beside a denoised
/// image.
pub fn raw_channels(color: &[[f32; 3]]) -> Vec<(String, Vec<f32>)> {
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, name)| (format!("raw.{name}"), color.iter().map(|p| p[c]).collect()))
        .collect()
}

impl Layers {
    /// Depth per pixel from the depth film: the mean distance of the samples that hit (R / G), or +inf
    /// where none did.
    pub fn depth_values(depth: &Film) -> Vec<f32> {
        depth
            .mean
            .iter()
            .map(|p| {
                if p[1] > 0.0 {
                    p[0] / p[1]
                } else {
                    f32::INFINITY
                }
            })
            .collect()
    }
}

/// Everything one image file is made of.
pub struct ImageFile<'a> {
    pub film: &'a Film,
    pub settings: &'a ImageSettings,
    pub metadata: Option<&'a ImageMetadata>,
    pub layers: &'a Layers,
    /// What denoised the film's means (`vkpath:denoised`), when they are denoised.
    pub denoised: Option<&'a str>,
}

impl ImageFile<'_> {
    /// The text attributes beyond the metadata: what denoised the image.
    fn notes(&self) -> Vec<(&'static str, String)> {
        self.denoised
            .map(|d| ("vkpath:denoised", d.to_string()))
            .into_iter()
            .collect()
    }
}

impl ImageFile<'_> {
    /// The file's bytes in `format`.
    pub fn encode(&self, format: OutputFormat) -> Result<Vec<u8>, String> {
        match format {
            OutputFormat::Png => self.encode_png(),
            OutputFormat::Exr => self.encode_exr(),
        }
    }

    fn encode_png(&self) -> Result<Vec<u8>, String> {
        let rgb = self.film.to_rgb8(self.settings);
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, rgb.width(), rgb.height());
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        match self.settings.gamma {
            // The sRGB chunk (with the gAMA and cHRM fallbacks the PNG specification recommends).
            Gamma::Srgb => encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual),
            // v^(1/g) encoding: the file gamma is 1/g.
            Gamma::Power(g) => encoder.set_source_gamma(png::ScaledFloat::new(1.0 / g)),
        }
        let text = |e: &mut png::Encoder<_>, k: &str, v: String| {
            e.add_itxt_chunk(k.to_string(), v)
                .map_err(|e| e.to_string())
        };
        text(
            &mut encoder,
            "Software",
            format!("vkpath {}", crate::VKPATH_VERSION),
        )?;
        if let Some(m) = self.metadata {
            for (k, v) in m.entries() {
                text(&mut encoder, k, v)?;
            }
        }
        for (k, v) in self.notes() {
            text(&mut encoder, k, v)?;
        }
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer
            .write_image_data(rgb.as_raw())
            .map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
        Ok(bytes)
    }

    /// The EXR's channels, named as written (`R`, `G`, `B`, then `variance.R`, `spp.Y`, `albedo.R`,
    /// `normal.X`, `depth.Z`, ... for the layers asked), each one value per pixel, row-major from the top
    /// left: the one definition of what each layer holds, for the EXR and for the Python module's arrays.
    pub fn channels(&self) -> Vec<(String, Vec<f32>)> {
        let f = self.film;
        let plane = |data: &[[f32; 3]], c: usize| data.iter().map(|p| p[c]).collect::<Vec<f32>>();
        let rgb = ["R", "G", "B"];
        let mut channels: Vec<(String, Vec<f32>)> = rgb
            .iter()
            .enumerate()
            .map(|(c, n)| (n.to_string(), plane(&f.mean, c)))
            .collect();
        if self.layers.variance {
            for (c, n) in rgb.iter().enumerate() {
                channels.push((format!("variance.{n}"), plane(&f.variance, c)));
            }
        }
        if self.layers.spp {
            let counts = (0..f.mean.len()).map(|i| f.samples_of(i) as f32).collect();
            channels.push(("spp.Y".into(), counts));
        }
        if let Some(a) = &self.layers.albedo {
            for (c, n) in rgb.iter().enumerate() {
                channels.push((format!("albedo.{n}"), plane(&a.mean, c)));
            }
        }
        if let Some(nf) = &self.layers.normal {
            for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
                let values = nf.mean.iter().map(|p| normal_from_film(*p)[c]).collect();
                channels.push((format!("normal.{n}"), values));
            }
        }
        if let Some(d) = &self.layers.depth {
            channels.push(("depth.Z".into(), Layers::depth_values(d)));
        }
        channels.extend(self.layers.extra.iter().cloned());
        channels
    }

    fn encode_exr(&self) -> Result<Vec<u8>, String> {
        use exr::prelude::*;
        let f = self.film;
        let channels: Vec<AnyChannel<FlatSamples>> = self
            .channels()
            .into_iter()
            .map(|(name, values)| AnyChannel::new(name.as_str(), FlatSamples::F32(values)))
            .collect();
        let mut attributes = LayerAttributes {
            software_name: Text::new_or_none(format!("vkpath {}", crate::VKPATH_VERSION)),
            ..LayerAttributes::default()
        };
        // The display transform goes with the metadata: an image written without (Film::write) keeps the
        // attributes it had, and its bytes (the exr crate writes attributes in a HashMap's order, which
        // varies between runs once there are two).
        let mut entries: Vec<(&str, String)> =
            self.metadata.map(|m| m.entries()).unwrap_or_default();
        entries.extend(self.notes());
        if self.metadata.is_some() {
            entries.extend(display_attributes(self.settings));
        }
        {
            for (k, v) in entries {
                // EXR text is Latin-1: a value it cannot hold (a scene name in another script) is written
                // with its other characters replaced by '?'.
                let latin1: String = v
                    .chars()
                    .map(|c| if (c as u32) < 256 { c } else { '?' })
                    .collect();
                let value = match k {
                    "vkpath:seconds" => AttributeValue::F64(
                        self.metadata.and_then(|m| m.seconds).unwrap_or(f64::NAN),
                    ),
                    _ => AttributeValue::Text(Text::new_or_panic(latin1)),
                };
                attributes.other.insert(Text::new_or_panic(k), value);
            }
        }
        let layer = Layer::new(
            (f.width as usize, f.height as usize),
            attributes,
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(channels)),
        );
        let mut bytes = std::io::Cursor::new(Vec::new());
        Image::from_layer(layer)
            .write()
            .non_parallel()
            .to_buffered(&mut bytes)
            .map_err(|e| e.to_string())?;
        Ok(bytes.into_inner())
    }
}

impl Film {
    /// Writes the film to `path` (format from the extension), atomically: a temporary file in the same
    /// directory, flushed and synced, then renamed over the target. A crash never leaves a partial image.
    /// No metadata and no extra layers: [`write_images`] writes those.
    pub fn write(&self, path: &Path, settings: &ImageSettings) -> Result<(), crate::Error> {
        write_images(
            &[path.to_path_buf()],
            &ImageFile {
                film: self,
                settings,
                metadata: None,
                layers: &Layers::default(),
                denoised: None,
            },
        )
    }
}

/// The display transform as EXR attributes (see the module's documentation).
fn display_attributes(s: &ImageSettings) -> [(&'static str, String); 3] {
    [
        ("vkpath:exposure", format!("{}", s.exposure)),
        (
            "vkpath:gamma",
            match s.gamma {
                Gamma::Srgb => "srgb".to_string(),
                Gamma::Power(g) => format!("{g}"),
            },
        ),
        (
            "vkpath:tonemap",
            match s.tonemap {
                crate::scene::Tonemap::None => "none".to_string(),
                crate::scene::Tonemap::Aces => "aces".to_string(),
            },
        ),
    ]
}

/// An EXR file's first layer, every channel as f32 (any of EXR's sample types), with its text
/// attributes: what `vkpath denoise` reads.
pub struct ExrChannels {
    pub width: u32,
    pub height: u32,
    /// (name, one value per pixel, row-major from the top left), in the file's order.
    pub channels: Vec<(String, Vec<f32>)>,
    /// The layer's and the file's text attributes (name, value).
    pub attributes: Vec<(String, String)>,
}

impl ExrChannels {
    /// The channel called `name`, if any.
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// The three channels `prefix.a`, `prefix.b`, `prefix.c` (`prefix` empty: `a`, `b`, `c`) as pixels,
    /// when all three are there.
    pub fn rgb(&self, prefix: &str, names: [&str; 3]) -> Option<Vec<[f32; 3]>> {
        let full = |n: &str| {
            if prefix.is_empty() {
                n.to_string()
            } else {
                format!("{prefix}.{n}")
            }
        };
        let [a, b, c] = names.map(|n| self.channel(&full(n)));
        let (a, b, c) = (a?, b?, c?);
        Some((0..a.len()).map(|i| [a[i], b[i], c[i]]).collect())
    }

    /// The text attribute called `name`.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The display transform recorded by vkpath (see the module's documentation), or the defaults
    /// (exposure 1, sRGB, no tone curve) for what is not recorded.
    pub fn display_settings(&self) -> ImageSettings {
        let exposure = self
            .attribute("vkpath:exposure")
            .and_then(|v| v.parse::<f32>().ok())
            .filter(|e| e.is_finite() && *e > 0.0)
            .unwrap_or(1.0);
        let gamma = match self.attribute("vkpath:gamma") {
            Some(v) => match v.parse::<f32>() {
                Ok(g) if g.is_finite() && g > 0.0 => Gamma::Power(g),
                _ => Gamma::Srgb,
            },
            None => Gamma::Srgb,
        };
        let tonemap = match self.attribute("vkpath:tonemap") {
            Some("aces") => crate::scene::Tonemap::Aces,
            _ => crate::scene::Tonemap::None,
        };
        ImageSettings {
            width: self.width,
            height: self.height,
            exposure,
            gamma,
            tonemap,
            denoise: false,
        }
    }

    /// Reads `path`: the header first, its pixels checked against the memory available (each channel's
    /// values as f32, and as stored) before any is decoded. Errors name the file.
    pub fn read(path: &Path) -> Result<ExrChannels, crate::Error> {
        use exr::prelude::*;
        let bad = |message: String| crate::Error::Usage(format!("{}: {message}", path.display()));
        let meta = exr::meta::MetaData::read_from_file(path, false)
            .map_err(|e| bad(format!("cannot read it as an OpenEXR file ({e})")))?;
        let Some(header) = meta.headers.first() else {
            return Err(bad("the OpenEXR file has no image layer".into()));
        };
        let size = header.layer_size;
        let values = size.area() as u64 * header.channels.list.len() as u64;
        crate::memory::check_available(values * 8, &format!("reading {}", path.display()))
            .map_err(bad)?;
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .map_err(|e| bad(format!("cannot read it as an OpenEXR file ({e})")))?;
        let layer = &image.layer_data;
        let channels = layer
            .channel_data
            .list
            .iter()
            .map(|ch| {
                let values = match &ch.sample_data {
                    FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                    FlatSamples::F32(v) => v.clone(),
                    FlatSamples::U32(v) => v.iter().map(|u| *u as f32).collect(),
                };
                (ch.name.to_string(), values)
            })
            .collect();
        let text = |v: &AttributeValue| match v {
            AttributeValue::Text(t) => Some(t.to_string()),
            AttributeValue::F64(f) => Some(f.to_string()),
            AttributeValue::F32(f) => Some(f.to_string()),
            AttributeValue::I32(i) => Some(i.to_string()),
            _ => None,
        };
        let attributes = layer
            .attributes
            .other
            .iter()
            .chain(image.attributes.other.iter())
            .filter_map(|(k, v)| text(v).map(|t| (k.to_string(), t)))
            .collect();
        Ok(ExrChannels {
            width: layer.size.width() as u32,
            height: layer.size.height() as u32,
            channels,
            attributes,
        })
    }
}

/// Writes `image` to every path (the format from each extension), all or nothing (see the module's
/// documentation).
pub fn write_images(paths: &[PathBuf], image: &ImageFile) -> Result<(), crate::Error> {
    let mut staged: Vec<(PathBuf, PathBuf)> = Vec::new();
    let unstage = |staged: &[(PathBuf, PathBuf)]| {
        for (tmp, _) in staged {
            let _ = std::fs::remove_file(tmp);
        }
    };
    for path in paths {
        let result = stage(path, image);
        match result {
            Ok(tmp) => staged.push((tmp, path.clone())),
            Err(e) => {
                unstage(&staged);
                let others = paths.len() > 1;
                return Err(match e {
                    crate::Error::Io { path, message } if others => crate::Error::Io {
                        path,
                        message: format!(
                            "{message} (none of the {} outputs was written: the files already there \
                             are unchanged)",
                            paths.len()
                        ),
                    },
                    e => e,
                });
            }
        }
    }
    let mut done: Vec<&Path> = Vec::new();
    for (i, (tmp, path)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            unstage(&staged[i..]);
            let written = if done.is_empty() {
                "none of the outputs was replaced".to_string()
            } else {
                format!(
                    "already replaced: {}; the others are unchanged",
                    done.iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            return Err(crate::Error::Io {
                path: path.clone(),
                message: format!("{e} ({written})"),
            });
        }
        done.push(path);
    }
    for (_, path) in &staged {
        sync_parent_dir(path);
    }
    Ok(())
}

/// Encodes `image` for `path` and writes it to a synced temporary file beside it; returns that file.
fn stage(path: &Path, image: &ImageFile) -> Result<PathBuf, crate::Error> {
    let format = OutputFormat::from_path(path).ok_or_else(|| {
        crate::Error::Usage(format!(
            "cannot tell the image format of {}: use a .png or .exr extension",
            path.display()
        ))
    })?;
    let io = |message: String| crate::Error::Io {
        path: path.to_path_buf(),
        message,
    };
    let bytes = image.encode(format).map_err(io)?;
    let tmp = temp_path_for(path);
    let written = (|| {
        use std::io::Write;
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&bytes)?;
        f.sync_all()
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(format!("{e} (in {})", directory_of(path).display())));
    }
    Ok(tmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film() -> Film {
        Film {
            width: 2,
            height: 1,
            spp: 4,
            pixel_spp: Vec::new(),
            mean: vec![[0.5, 0.25, 1.0], [2.0, 0.0, 0.125]],
            variance: vec![[0.01, 0.02, 0.03], [0.0, 0.0, 0.0]],
        }
    }

    fn settings() -> ImageSettings {
        ImageSettings {
            width: 2,
            height: 1,
            exposure: 1.0,
            gamma: Gamma::Power(2.2),
            tonemap: crate::scene::Tonemap::None,
            denoise: false,
        }
    }

    /// Two outputs, the second of which cannot be written (its directory is gone): neither is written,
    /// the file already at the first path keeps its bytes, and no temporary file is left behind.
    #[test]
    fn outputs_are_written_all_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let first = d.join("a.png");
        std::fs::write(&first, b"the user's file").unwrap();
        let paths = [first.clone(), d.join("gone/b.exr")];
        let (f, s) = (film(), settings());
        let image = ImageFile {
            film: &f,
            settings: &s,
            metadata: None,
            layers: &Layers::default(),
            denoised: None,
        };
        let e = write_images(&paths, &image).unwrap_err().to_string();
        assert!(
            e.contains("gone/b.exr") && e.contains("none of the 2 outputs"),
            "{e}"
        );
        assert_eq!(std::fs::read(&first).unwrap(), b"the user's file");
        let names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["a.png"], "temporary files left behind");
        // Both writable: both written.
        std::fs::create_dir(d.join("gone")).unwrap();
        write_images(&paths, &image).unwrap();
        assert!(image::open(&first).is_ok() && image::open(&paths[1]).is_ok());
    }

    /// Layer lists: any order, each once, sorted; unknown names refused with the known ones.
    #[test]
    fn aov_lists() {
        assert_eq!(
            Aov::parse_list("depth, albedo").unwrap(),
            [Aov::Albedo, Aov::Depth]
        );
        assert!(
            Aov::parse_list("albedo,albedo")
                .unwrap_err()
                .contains("twice")
        );
        let e = Aov::parse_list("position").unwrap_err();
        assert!(e.contains("albedo, normal, variance, depth, spp"), "{e}");
    }
}
