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
//!   keyword and the EXR software attribute).
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
}

impl Aov {
    pub const ALL: [(Aov, &'static str); 4] = [
        (Aov::Albedo, "albedo"),
        (Aov::Normal, "normal"),
        (Aov::Variance, "variance"),
        (Aov::Depth, "depth"),
    ];

    pub fn name(self) -> &'static str {
        Aov::ALL
            .iter()
            .find(|(a, _)| *a == self)
            .map_or("?", |(_, n)| n)
    }

    /// `albedo,normal,variance,depth` (any subset, any order, each once).
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
    pub albedo: Option<Film>,
    pub normal: Option<Film>,
    pub depth: Option<Film>,
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
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer
            .write_image_data(rgb.as_raw())
            .map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
        Ok(bytes)
    }

    fn encode_exr(&self) -> Result<Vec<u8>, String> {
        use exr::prelude::*;
        let f = self.film;
        let channel =
            |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
        let plane = |data: &[[f32; 3]], c: usize| data.iter().map(|p| p[c]).collect::<Vec<f32>>();
        let mut channels = vec![
            channel("R", plane(&f.mean, 0)),
            channel("G", plane(&f.mean, 1)),
            channel("B", plane(&f.mean, 2)),
        ];
        let rgb = ["R", "G", "B"];
        if self.layers.variance {
            for (c, n) in rgb.iter().enumerate() {
                channels.push(channel(&format!("variance.{n}"), plane(&f.variance, c)));
            }
        }
        if let Some(a) = &self.layers.albedo {
            for (c, n) in rgb.iter().enumerate() {
                channels.push(channel(&format!("albedo.{n}"), plane(&a.mean, c)));
            }
        }
        if let Some(nf) = &self.layers.normal {
            for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
                // The kernel stores n / 2 + 1/2 (the accumulator sums non-negative values only).
                let values = nf.mean.iter().map(|p| 2.0 * p[c] - 1.0).collect();
                channels.push(channel(&format!("normal.{n}"), values));
            }
        }
        if let Some(d) = &self.layers.depth {
            channels.push(channel("depth.Z", crate::output::Layers::depth_values(d)));
        }
        let mut attributes = LayerAttributes {
            software_name: Text::new_or_none(format!("vkpath {}", crate::VKPATH_VERSION)),
            ..LayerAttributes::default()
        };
        if let Some(m) = self.metadata {
            for (k, v) in m.entries() {
                // EXR text is Latin-1: a value it cannot hold (a scene name in another script) is written
                // with its other characters replaced by '?'.
                let latin1: String = v
                    .chars()
                    .map(|c| if (c as u32) < 256 { c } else { '?' })
                    .collect();
                let value = match k {
                    "vkpath:seconds" => AttributeValue::F64(m.seconds.unwrap_or(f64::NAN)),
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
            },
        )
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
        assert!(e.contains("albedo, normal, variance, depth"), "{e}");
    }
}
