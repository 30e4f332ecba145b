//! The environment: light arriving from infinitely far away, uniform or from an equirectangular map.
//!
//! A map is oriented and interpolated exactly as Mitsuba 3's `envmap` emitter, so that the same file
//! lights a scene the same way in both renderers (the contract says so; benches/peers checks it):
//!
//! * a direction d in the map's frame has texture coordinates u = atan2(d.x, -d.z) / (2 pi) (wrapped to
//!   [0, 1)) and v = acos(d.y) / pi: +y is up, v = 0 the zenith, the map's top row; u runs from -z
//!   through +x. The map's frame is the world rotated by `rotate` degrees about +y (right-handed: the
//!   world direction of a map direction m is R_y(rotate) m).
//! * the pixels are samples of a bilinear patch: column k sits at u = (k + 1/2) / W (wrapping around),
//!   row j at v = j / (H - 1), so the first and last rows are the poles. Radiance at (u, v) is the
//!   bilinear mix of the four samples around it.
//!
//! Sampling (shaders/lights/environment.wgsl) is piecewise constant over the (H - 1) x W cells between those samples,
//! each cell weighted by the mean luminance of its four corners times sin(theta) at its centre (the
//! Jacobian of the (u, v) -> direction map is 2 pi^2 sin(theta)): pbrt-v4's ImageInfiniteLight and
//! Mitsuba's envmap sample in proportion to the same product. A cell's weight is positive wherever the
//! bilinear radiance inside it is, so the sampler covers every direction that carries light.

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The largest map read, in pixels (8192 x 4096): its texels and distribution take 0.5 GiB on the device.
pub const MAX_MAP_PIXELS: u64 = 8192 * 4096;

/// Light from infinitely far away (`[environment]`): `radiance` alone is a uniform environment (the
/// contract's `render.background`); with a map, `radiance` multiplies it per channel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Environment {
    pub radiance: Vec3,
    pub map: Option<Arc<EnvironmentMap>>,
    /// Degrees about +y.
    pub rotate_deg: f32,
}

impl Environment {
    /// Whether any light arrives from it (a black environment is no light at all).
    pub fn is_black(&self) -> bool {
        self.radiance.max_element() <= 0.0
            || self
                .map
                .as_ref()
                .is_some_and(|m| m.texels.iter().all(|t| t.iter().all(|&c| c <= 0.0)))
    }
}

/// An equirectangular map of linear RGB radiance, rows from the top (v = 0, the zenith).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// Row-major, `width * height` RGB triples.
    pub texels: Vec<[f32; 3]>,
}

/// Reads an `.exr` or `.hdr` map with the `image` crate's decoders. Errors are one sentence for the
/// scene's error message (which adds file, line and key).
pub fn load_map(path: &Path) -> Result<EnvironmentMap, String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let format = match ext.as_str() {
        "exr" => image::ImageFormat::OpenExr,
        "hdr" => image::ImageFormat::Hdr,
        _ => {
            return Err(format!(
                "{} is not an .exr or .hdr file (environment maps are linear radiance)",
                path.display()
            ));
        }
    };
    // The file is opened twice: its size is checked from the header before any pixel is decoded.
    let reader = || -> Result<_, String> {
        let file = std::fs::File::open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let mut reader = image::ImageReader::with_format(std::io::BufReader::new(file), format);
        reader.no_limits();
        Ok(reader)
    };
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if w < 2 || h < 2 {
        return Err(format!(
            "{} is {w} x {h} pixels; an environment map needs at least 2 x 2",
            path.display()
        ));
    }
    if w as u64 * h as u64 > MAX_MAP_PIXELS {
        return Err(format!(
            "{} is {w} x {h} pixels, more than the {MAX_MAP_PIXELS} this renderer reads",
            path.display()
        ));
    }
    let img = reader()?
        .decode()
        .map_err(|e| format!("cannot decode {}: {e}", path.display()))?
        .into_rgb32f();
    let texels: Vec<[f32; 3]> = img.pixels().map(|p| p.0).collect();
    if let Some(bad) = texels
        .iter()
        .position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        let (x, y) = (bad as u32 % w, bad as u32 / w);
        return Err(format!(
            "{} has a negative or non-finite radiance at pixel ({x}, {y}): {:?}",
            path.display(),
            texels[bad]
        ));
    }
    Ok(EnvironmentMap {
        path: path.to_path_buf(),
        width: w,
        height: h,
        texels,
    })
}

/// The weight sampling gives each channel when it reduces a radiance to one number: the mean (every
/// channel counts alike; the same rule picks emissive triangles).
pub fn channel_mean(rgb: [f32; 3]) -> f64 {
    (rgb[0] as f64 + rgb[1] as f64 + rgb[2] as f64) / 3.0
}

impl EnvironmentMap {
    /// The sampling distribution over the (H - 1) x W cells (see the module's docs), as the shader reads
    /// it: first the H - 1 values of the CDF over rows (the last is 1), then for each row its W values
    /// of the CDF over columns within the row. A row (or map) with no light gets a uniform CDF: it is
    /// never chosen, or the map gives no light at all.
    pub fn distribution(&self) -> Vec<f32> {
        let (w, h) = (self.width as usize, self.height as usize);
        let rows = h - 1;
        let lum = |x: usize, y: usize| channel_mean(self.texels[y * w + x % w]);
        let mut row_weights = Vec::with_capacity(rows);
        let mut columns = Vec::with_capacity(rows * w);
        for j in 0..rows {
            // The cell's centre is half a cell below row j: theta = pi (j + 1/2) / (H - 1).
            let sin_theta = (std::f64::consts::PI * (j as f64 + 0.5) / rows as f64).sin();
            let cells: Vec<f64> = (0..w)
                .map(|k| {
                    0.25 * (lum(k, j) + lum(k + 1, j) + lum(k, j + 1) + lum(k + 1, j + 1))
                        * sin_theta
                })
                .collect();
            let total: f64 = cells.iter().sum();
            row_weights.push(total);
            columns.extend(cdf(&cells, total));
        }
        let total: f64 = row_weights.iter().sum();
        let mut out = cdf(&row_weights, total);
        out.extend(columns);
        out
    }
}

/// The normalised running sum of `weights` (whose sum is `total`), ending at exactly 1; uniform when
/// `total` is not positive.
fn cdf(weights: &[f64], total: f64) -> Vec<f32> {
    let n = weights.len();
    let mut acc = 0.0;
    let mut out: Vec<f32> = weights
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            if total > 0.0 {
                acc += x;
                (acc / total) as f32
            } else {
                (i + 1) as f32 / n as f32
            }
        })
        .collect();
    if let Some(last) = out.last_mut() {
        *last = 1.0;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> EnvironmentMap {
        EnvironmentMap {
            path: PathBuf::from("test.exr"),
            width: w,
            height: h,
            texels: (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| [f(x, y); 3])
                .collect(),
        }
    }

    #[test]
    fn a_uniform_map_weighs_cells_by_sin_theta() {
        let m = map(4, 5, |_, _| 2.0);
        let d = m.distribution();
        assert_eq!(d.len(), 4 + 4 * 4);
        // Row CDF: cumulative sin((j + 1/2) pi / 4), normalised.
        let s: Vec<f64> = (0..4)
            .map(|j| (std::f64::consts::PI * (j as f64 + 0.5) / 4.0).sin())
            .collect();
        let total: f64 = s.iter().sum();
        let mut acc = 0.0;
        for j in 0..4 {
            acc += s[j];
            assert!((d[j] as f64 - acc / total).abs() < 1e-6, "row {j}");
        }
        // Every row's column CDF is uniform.
        for (i, c) in d[4..].iter().enumerate() {
            assert!((*c as f64 - ((i % 4) + 1) as f64 / 4.0).abs() < 1e-6);
        }
    }

    #[test]
    fn a_cell_is_weighted_by_its_corners_wrapping_around() {
        // One bright pixel in the last column of row 1: it is a corner of cells (j, 2) and (j, 3) (whose
        // right corners wrap around to column 0) in both rows of cells j = 0, 1.
        let m = map(4, 3, |x, y| if (x, y) == (3, 1) { 8.0 } else { 0.0 });
        let d = m.distribution();
        assert_eq!(&d[..2], &[0.5, 1.0]);
        let row0 = &d[2..6];
        assert_eq!(row0, &[0.0, 0.0, 0.5, 1.0]);
        let row1 = &d[6..10];
        assert_eq!(row1, &[0.0, 0.0, 0.5, 1.0]);
    }

    #[test]
    fn a_black_map_has_a_uniform_distribution_and_is_black() {
        let m = map(2, 2, |_, _| 0.0);
        assert_eq!(m.distribution(), vec![1.0, 0.5, 1.0]);
        let env = Environment {
            radiance: Vec3::ONE,
            map: Some(Arc::new(m)),
            rotate_deg: 0.0,
        };
        assert!(env.is_black());
    }
}
