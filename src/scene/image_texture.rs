//! Image textures: an image file (PNG, JPEG, EXR, HDR), or an image held in memory (a glTF buffer's),
//! decoded into the texels the shader samples ([`Texture`]). How a material reads one is `texture.rs`.

use std::path::{Path, PathBuf};

/// The most texels one texture may have (2^28: 1 GiB of RGBA8 on the device), checked from the file's
/// header before it is decoded.
pub const MAX_TEXTURE_TEXELS: u64 = 1 << 28;

/// The most host memory decoding takes per texel: the decoder's RGBA f32 (EXR, HDR) and vkpath's f16.
const DECODE_BYTES_PER_TEXEL: u64 = 16 + 8;

/// An RGBA image, rows from the top, as the shader samples it (texture.wgsl): 8 bits per channel
/// (PNG, JPEG: sRGB-encoded colour or linear data, as a texture reference says), or f16 (EXR, HDR:
/// linear values).
#[derive(Clone, PartialEq)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left texel. 8-bit: one word per texel, `r | g << 8 | b << 16 | a << 24`
    /// (WGSL's `unpack4x8unorm` order). `half`: two words per texel, `r | g << 16` and `b | a << 16`, each
    /// an IEEE binary16 (WGSL's `unpack2x16float` order).
    pub texels: Vec<u32>,
    pub half: bool,
    /// Not an image but Mitsuba 3's `checkerboard` ([`Texture::checkerboard`]): `texels` holds its two
    /// colours as six f32 (linear RGB, colour 0 then colour 1), read exactly (texture.wgsl).
    pub checkerboard: bool,
}

impl Texture {
    /// The procedural checkerboard of two colours (Mitsuba 3's `checkerboard` texture): at texture
    /// coordinates uv, with f = uv - floor(uv), colour 0 where f.x > 1/2 and f.y > 1/2 agree (both or
    /// neither), colour 1 where they differ: four squares per unit of uv. The colours are stored as f32
    /// bits, so a checkerboard reads its colours exactly (no 8-bit or f16 rounding).
    pub fn checkerboard(colors: [[f32; 3]; 2]) -> Texture {
        Texture {
            path: PathBuf::from("checkerboard"),
            width: 2,
            height: 2,
            texels: colors.iter().flatten().map(|c| c.to_bits()).collect(),
            half: false,
            checkerboard: true,
        }
    }
}

impl std::fmt::Debug for Texture {
    /// The file, size and format; not the texels (millions of them).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Texture")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("half", &self.half)
            .field("checkerboard", &self.checkerboard)
            .finish_non_exhaustive()
    }
}

/// Reads an image file as an sRGB RGBA8 texture (PNG, JPEG, EXR, HDR).
pub fn load_texture(path: &Path) -> Result<Texture, String> {
    let bytes = crate::memory::read_file(path)
        .map_err(|e| format!("cannot read the texture {}: {e}", path.display()))?;
    decode_texture(&bytes, path)
}

/// Decodes an image held in memory (a glTF buffer's), `what` naming it in messages.
pub fn load_texture_bytes(bytes: &[u8], what: &str) -> Result<Texture, String> {
    decode_texture(bytes, Path::new(what))
}

fn decode_texture(bytes: &[u8], path: &Path) -> Result<Texture, String> {
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("cannot read the texture {}: {e}", path.display()))
    };
    // The size comes from the header, before any texel is decoded: a small file declaring a huge image
    // (a decompression bomb) is refused without the memory it would take.
    let (width, height) = reader()?
        .into_dimensions()
        .map_err(|e| format!("cannot decode the texture {}: {e}", path.display()))?;
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_TEXTURE_TEXELS {
        return Err(format!(
            "the texture {} is {width} x {height} texels; it must have between 1 and 2^28 texels",
            path.display()
        ));
    }
    // Decoding holds the decoder's image (up to 16 bytes a texel: RGBA f32 for EXR) and vkpath's
    // (4 or 8): checked against the machine before it is allocated.
    crate::memory::check_available(
        u64::from(width) * u64::from(height) * DECODE_BYTES_PER_TEXEL,
        &format!("decoding the {width} x {height} texture {}", path.display()),
    )?;
    if reader()?.format() == Some(image::ImageFormat::Jpeg) {
        return decode_jpeg(bytes, path, width, height);
    }
    let decoded = reader()?
        .decode()
        .map_err(|e| format!("cannot decode the texture {}: {e}", path.display()))?;
    // PNG and JPEG hold 8 bits per channel, RGBA8 on the device. EXR and HDR decode to floats (linear
    // radiance, reflectance or heights): kept as RGBA f16 (two words per texel), unclipped, so that an
    // emission or height map keeps its range. (Non-finite values become 0; f16 saturates at 65504.)
    let (texels, half) = match decoded {
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_) => {
            let linear = decoded.to_rgba32f();
            let h = |v: f32| {
                let v = if v.is_finite() { v } else { 0.0 };
                u32::from(half::f16::from_f32(v).to_bits())
            };
            let texels = linear
                .pixels()
                .flat_map(|p| {
                    let [r, g, b, a] = p.0;
                    [h(r) | h(g) << 16, h(b) | h(a) << 16]
                })
                .collect();
            (texels, true)
        }
        other => {
            let rgba = other.to_rgba8();
            (
                rgba.pixels().map(|p| u32::from_le_bytes(p.0)).collect(),
                false,
            )
        }
    };
    Ok(Texture {
        path: path.to_path_buf(),
        width,
        height,
        texels,
        half,
        checkerboard: false,
    })
}

/// A JPEG texture, decoded by the jpeg-decoder crate, whose colour conversion and chroma upsampling
/// follow libjpeg's (the decoder Mitsuba and most renderers use) more closely than the image crate's
/// zune-jpeg: on the wallpaper of Bitterli's staircase, zune-jpeg's mean blue was 0.42 of 255 above
/// libjpeg's (0.23 %; the scene rendered 0.34 % bluer than Mitsuba, 3 standard errors), jpeg-decoder's is
/// 0.08 above. Greyscale and RGB images become RGBA8 texels; CMYK is refused.
fn decode_jpeg(bytes: &[u8], path: &Path, width: u32, height: u32) -> Result<Texture, String> {
    let mut decoder = jpeg_decoder::Decoder::new(bytes);
    let pixels = decoder
        .decode()
        .map_err(|e| format!("cannot decode the texture {}: {e}", path.display()))?;
    let info = decoder
        .info()
        .ok_or_else(|| format!("cannot decode the texture {}: no header", path.display()))?;
    if (u32::from(info.width), u32::from(info.height)) != (width, height) {
        return Err(format!(
            "cannot decode the texture {}: its header gives two sizes",
            path.display()
        ));
    }
    let rgba = |r: u8, g: u8, b: u8| u32::from_le_bytes([r, g, b, 255]);
    let texels: Vec<u32> = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => pixels.iter().map(|&l| rgba(l, l, l)).collect(),
        // 16-bit greyscale (big-endian): its high byte, as the 8-bit texture it becomes.
        jpeg_decoder::PixelFormat::L16 => pixels
            .chunks_exact(2)
            .map(|l| rgba(l[0], l[0], l[0]))
            .collect(),
        jpeg_decoder::PixelFormat::RGB24 => pixels
            .chunks_exact(3)
            .map(|c| rgba(c[0], c[1], c[2]))
            .collect(),
        jpeg_decoder::PixelFormat::CMYK32 => {
            return Err(format!(
                "the texture {} is a CMYK JPEG; vkpath reads greyscale and RGB ones",
                path.display()
            ));
        }
    };
    if texels.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(format!(
            "cannot decode the texture {}: it ends early",
            path.display()
        ));
    }
    Ok(Texture {
        path: path.to_path_buf(),
        width,
        height,
        texels,
        half: false,
        checkerboard: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// JPEG textures are read as 8-bit texels like PNG; EXR and HDR ones keep their linear values as
    /// f16, unclipped (1.5 stays 1.5).
    #[test]
    fn jpeg_textures_load_as_8_bit_and_exr_and_hdr_as_half_floats() {
        let dir = tempfile::tempdir().unwrap();
        // (Values HDR's shared-exponent RGBE and f16 both hold exactly: multiples of 2^-7 below 2.)
        let linear = [0.5f32, 0.0625, 1.5];
        let float = image::Rgb32FImage::from_fn(4, 2, |_, _| image::Rgb(linear));
        for ext in ["exr", "hdr"] {
            let path = dir.path().join(format!("t.{ext}"));
            float.save(&path).unwrap();
            let t = load_texture(&path).unwrap_or_else(|e| panic!("{ext}: {e}"));
            assert_eq!((t.width, t.height, t.half), (4, 2, true));
            assert_eq!(t.texels.len(), 16);
            let f = |bits: u32| half::f16::from_bits(bits as u16).to_f32();
            let (rg, ba) = (t.texels[10], t.texels[11]); // texel 5
            let got = [f(rg & 0xffff), f(rg >> 16), f(ba & 0xffff), f(ba >> 16)];
            assert_eq!(got, [linear[0], linear[1], linear[2], 1.0], "{ext}");
        }
        let srgb = image::RgbImage::from_fn(8, 8, |_, _| image::Rgb([200, 100, 50]));
        let path = dir.path().join("t.jpg");
        srgb.save(&path).unwrap();
        let t = load_texture(&path).expect("jpeg");
        let [r, g, b, _] = t.texels[27].to_le_bytes();
        // (JPEG is lossy: a flat colour comes back within a few levels.)
        assert!(
            r.abs_diff(200) <= 3 && g.abs_diff(100) <= 3 && b.abs_diff(50) <= 3,
            "{r} {g} {b}"
        );
    }

    /// JPEG through jpeg-decoder: a smooth RGB gradient comes back within a few levels everywhere (its
    /// mean within half a level per channel: no colour shift), a greyscale JPEG as grey RGBA texels, and
    /// a truncated file is an error naming it.
    #[test]
    fn jpeg_textures_keep_their_colours_and_greys() {
        let dir = tempfile::tempdir().unwrap();
        let src = image::RgbImage::from_fn(64, 48, |x, y| {
            image::Rgb([(60 + 2 * x) as u8, (40 + 3 * y) as u8, (200 - x - y) as u8])
        });
        let path = dir.path().join("g.jpg");
        src.save(&path).unwrap();
        let t = load_texture(&path).expect("jpeg");
        assert_eq!((t.width, t.height, t.half), (64, 48, false));
        let mut sum = [0i64; 3];
        for (p, q) in src.pixels().zip(&t.texels) {
            let got = q.to_le_bytes();
            for k in 0..3 {
                assert!(got[k].abs_diff(p[k]) <= 6, "{:?} vs {:?}", got, p);
                sum[k] += i64::from(got[k]) - i64::from(p[k]);
            }
            assert_eq!(got[3], 255);
        }
        let n = (64 * 48) as f64;
        assert!(
            sum.iter().all(|&d| (d as f64 / n).abs() < 0.5),
            "mean shift {sum:?} / {n}"
        );
        let grey = image::GrayImage::from_fn(16, 16, |x, _| image::Luma([(16 * x) as u8]));
        let gpath = dir.path().join("grey.jpg");
        grey.save(&gpath).unwrap();
        let t = load_texture(&gpath).expect("grey jpeg");
        for q in &t.texels {
            let [r, g, b, a] = q.to_le_bytes();
            assert!(r == g && g == b && a == 255);
        }
        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.path().join("cut.jpg");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        // A decoder may fill a truncated scan; it must not panic, and an error names the file.
        if let Err(e) = load_texture(&cut) {
            assert!(e.contains("cut.jpg"), "{e}");
        }
    }

    /// Issue 18, failure 5: a 62 kB PNG declaring 23000 x 23000 was refused only after it was decoded
    /// (7.9 s, 2.5 GB). The size now comes from the header: a PNG whose header declares that size and
    /// which holds almost no image data is refused for its size (decoding it would fail otherwise).
    #[test]
    fn a_huge_texture_is_refused_from_its_header() {
        fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
            let mut crc = crc32fast::Hasher::new();
            crc.update(kind);
            crc.update(data);
            [
                &(data.len() as u32).to_be_bytes()[..],
                kind,
                data,
                &crc.finalize().to_be_bytes(),
            ]
            .concat()
        }
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&23000u32.to_be_bytes());
        ihdr.extend_from_slice(&23000u32.to_be_bytes());
        ihdr.extend_from_slice(&[8, 6, 0, 0, 0]); // 8-bit RGBA, no interlace
        let png = [
            &b"\x89PNG\r\n\x1a\n"[..],
            &chunk(b"IHDR", &ihdr),
            // A zlib stream of nothing: the 2 GB of texels it declares are not there.
            &chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]),
            &chunk(b"IEND", &[]),
        ]
        .concat();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bomb.png");
        std::fs::write(&path, png).unwrap();
        let e = load_texture(&path).unwrap_err();
        assert!(e.contains("23000 x 23000") && e.contains("2^28"), "{e}");
    }
}
