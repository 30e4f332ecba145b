//! Tiles: how an image is cut to fit the device.
//!
//! Two limits apply, and the image is cut once for each:
//!
//! - **Buffers.** The accumulator takes 96 bytes per pixel (`GpuAccum`), and one storage buffer may span
//!   at most `maxStorageBufferRange` bytes (128 MiB on lavapipe: 1,398,101 pixels) and one allocation at most
//!   `maxMemoryAllocationSize`. The image is cut into *strips* of whole rows, each with its own
//!   accumulator buffer, no larger than the smallest of those limits and [`MAX_STRIP_BYTES`]. A strip of
//!   whole rows keeps the accumulator row-major: strip k holds the pixels from index `rows.0 * width` on.
//! - **Dispatches.** One dispatch covers one *tile* of a strip. A tile is at most
//!   `maxComputeWorkGroupCount` workgroups in each dimension, and at most `region_pixels` pixels, which
//!   the renderer adapts so that a dispatch takes about its target duration (a desktop GPU's watchdog
//!   resets the device when one dispatch runs for seconds).
//!
//! Neither cut changes the image: a pixel's samples use the same random numbers and are added to its
//! sums in the same order whatever the tile it falls in (tests/tiling.rs holds tiled == untiled, bit for
//! bit).

use crate::gpu::GpuContext;
use crate::kernel::abi::GpuAccum;

/// Bytes of accumulator per pixel.
pub const ACCUM_BYTES_PER_PIXEL: u64 = std::mem::size_of::<GpuAccum>() as u64;

/// The largest accumulator strip, whatever the device allows: it bounds the host-visible staging
/// buffer (as large as the largest strip) that reads the film back and restores checkpoints.
pub const MAX_STRIP_BYTES: u64 = 256 << 20;

/// The device limits that decide the cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileLimits {
    /// The largest accumulator buffer: min(maxStorageBufferRange, maxMemoryAllocationSize,
    /// [`MAX_STRIP_BYTES`]).
    pub max_buffer_bytes: u64,
    /// maxComputeWorkGroupCount in x and y.
    pub max_groups: [u32; 2],
}

impl TileLimits {
    pub fn of(ctx: &GpuContext) -> TileLimits {
        let d = ctx.device_info();
        let mut max_buffer_bytes = u64::from(d.max_storage_buffer_range).min(MAX_STRIP_BYTES);
        if d.max_memory_allocation_size > 0 {
            max_buffer_bytes = max_buffer_bytes.min(d.max_memory_allocation_size);
        }
        TileLimits {
            max_buffer_bytes,
            max_groups: [
                d.max_compute_workgroup_count[0],
                d.max_compute_workgroup_count[1],
            ],
        }
    }
}

/// A tile: the pixels from `origin` (included) to `end` (excluded); or, with adaptive sampling, the
/// `list = [start, len]` pixels still sampling from `active_pixels[start]` on, dispatched in rows
/// `end[0]` wide (`origin` (0, 0), `end[1]` rows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub origin: [u32; 2],
    pub end: [u32; 2],
    pub list: Option<[u32; 2]>,
}

impl Tile {
    pub fn size(&self) -> [u32; 2] {
        [self.end[0] - self.origin[0], self.end[1] - self.origin[1]]
    }

    pub fn pixels(&self) -> u64 {
        let [w, h] = self.size();
        u64::from(w) * u64::from(h)
    }
}

/// The cut of one image: strips of rows (one accumulator buffer each) and how to tile them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileLayout {
    pub width: u32,
    pub height: u32,
    /// The kernel's workgroup size in x and y (tiles are multiples of it where they can be).
    pub workgroup: [u32; 2],
    /// Row ranges `[first, end)`, top to bottom, covering the image.
    pub strips: Vec<[u32; 2]>,
    /// A fixed largest tile (width, height) in pixels, when asked for (`--tile`): strips are then at
    /// most this many rows, and tiles exactly this size (smaller at the image's edges).
    pub fixed_tile: Option<[u32; 2]>,
    pub max_groups: [u32; 2],
}

impl TileLayout {
    /// Cuts a `width` x `height` image for a device with `limits`. The error says which limit a single
    /// row of workgroups already exceeds (it cannot happen for images of at most 65536 pixels a side on a
    /// conforming device, whose storage buffers span at least 128 MiB).
    pub fn new(
        width: u32,
        height: u32,
        workgroup: [u32; 2],
        limits: TileLimits,
        fixed_tile: Option<[u32; 2]>,
    ) -> Result<TileLayout, String> {
        let workgroup = [workgroup[0].max(1), workgroup[1].max(1)];
        let row_bytes = u64::from(width) * ACCUM_BYTES_PER_PIXEL;
        let mut rows = limits.max_buffer_bytes / row_bytes.max(1);
        if rows >= u64::from(workgroup[1]) {
            rows -= rows % u64::from(workgroup[1]);
        }
        if let Some([_, th]) = fixed_tile {
            rows = rows.min(u64::from(th.max(1)));
        }
        if rows == 0 {
            return Err(format!(
                "one row of {width} pixels needs {row_bytes} bytes of accumulator, more than the {} bytes \
                 one buffer may hold on this device",
                limits.max_buffer_bytes
            ));
        }
        let rows = rows.min(u64::from(height)) as u32;
        let mut strips = Vec::new();
        let mut y = 0;
        while y < height {
            let end = y.saturating_add(rows).min(height);
            strips.push([y, end]);
            y = end;
        }
        Ok(TileLayout {
            width,
            height,
            workgroup,
            strips,
            fixed_tile: fixed_tile.map(|[w, h]| [w.max(1), h.max(1)]),
            max_groups: [limits.max_groups[0].max(1), limits.max_groups[1].max(1)],
        })
    }

    /// Pixels in strip `i`.
    pub fn strip_pixels(&self, i: usize) -> u64 {
        let [a, b] = self.strips[i];
        u64::from(b - a) * u64::from(self.width)
    }

    /// Bytes of the largest strip's accumulator.
    pub fn max_strip_bytes(&self) -> u64 {
        (0..self.strips.len())
            .map(|i| self.strip_pixels(i) * ACCUM_BYTES_PER_PIXEL)
            .max()
            .unwrap_or(0)
    }

    /// Bytes of all the strips' accumulators.
    pub fn total_bytes(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height) * ACCUM_BYTES_PER_PIXEL
    }

    /// The tiles of strip `i`, each at most `region_pixels` pixels (unless a single workgroup row is
    /// larger) and at most the device's workgroup counts, multiples of the workgroup size except at the
    /// image's edges. With a fixed tile, the tiles of the fixed size instead.
    pub fn tiles(&self, i: usize, region_pixels: u64) -> Vec<Tile> {
        let [y0, y1] = self.strips[i];
        let [gw, gh] = self.workgroup;
        let (tw, th) = match self.fixed_tile {
            Some([w, h]) => (w, h),
            None => {
                let r = region_pixels.max(u64::from(gw) * u64::from(gh));
                let w = u64::from(self.width);
                if w * u64::from(gh) <= r {
                    // Whole rows: as many workgroup rows as fit.
                    let rows = (r / w) / u64::from(gh) * u64::from(gh);
                    (self.width, rows.clamp(1, u64::from(u32::MAX)) as u32)
                } else {
                    // One workgroup row, cut across.
                    let cols = (r / u64::from(gh)) / u64::from(gw) * u64::from(gw);
                    (cols.clamp(1, u64::from(self.width)) as u32, gh)
                }
            }
        };
        // The device's workgroup counts bound a dispatch.
        let tw = tw.min(self.max_groups[0].saturating_mul(gw)).max(1);
        let th = th.min(self.max_groups[1].saturating_mul(gh)).max(1);
        let mut tiles = Vec::new();
        let mut y = y0;
        while y < y1 {
            let ye = y.saturating_add(th).min(y1);
            let mut x = 0;
            while x < self.width {
                let xe = x.saturating_add(tw).min(self.width);
                tiles.push(Tile {
                    list: None,
                    origin: [x, y],
                    end: [xe, ye],
                });
                x = xe;
            }
            y = ye;
        }
        tiles
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAVAPIPE: TileLimits = TileLimits {
        max_buffer_bytes: 128 << 20,
        max_groups: [65535, 65535],
    };

    /// Every pixel of the image is in exactly one tile of exactly one strip.
    fn assert_partition(l: &TileLayout, region_pixels: u64) {
        let mut covered = vec![0u8; l.width as usize * l.height as usize];
        for (i, s) in l.strips.iter().enumerate() {
            for t in l.tiles(i, region_pixels) {
                assert!(
                    t.origin[1] >= s[0] && t.end[1] <= s[1],
                    "{t:?} outside strip {s:?}"
                );
                let [gw, gh] = [
                    t.size()[0].div_ceil(l.workgroup[0]),
                    t.size()[1].div_ceil(l.workgroup[1]),
                ];
                assert!(gw <= l.max_groups[0] && gh <= l.max_groups[1]);
                for y in t.origin[1]..t.end[1] {
                    for x in t.origin[0]..t.end[0] {
                        covered[(y * l.width + x) as usize] += 1;
                    }
                }
            }
            assert!(
                l.strip_pixels(i) * ACCUM_BYTES_PER_PIXEL
                    <= LAVAPIPE.max_buffer_bytes.max(l.width as u64 * 64)
            );
        }
        assert!(covered.iter().all(|&c| c == 1));
    }

    #[test]
    fn small_images_are_one_strip_and_one_tile() {
        let l = TileLayout::new(512, 512, [8, 8], LAVAPIPE, None).unwrap();
        assert_eq!(l.strips, vec![[0, 512]]);
        assert_eq!(l.tiles(0, 1 << 20).len(), 1);
        assert_partition(&l, 1 << 20);
    }

    #[test]
    fn large_images_are_cut_into_strips_within_the_buffer_limit() {
        // 4096 x 4096 x 96 B = 1.5 GiB. A row is 393,216 B, so 128 MiB holds 341 rows, 336 once
        // rounded down to the 8-row workgroup: ceil(4096 / 336) = 13 strips on lavapipe.
        let l = TileLayout::new(4096, 4096, [8, 8], LAVAPIPE, None).unwrap();
        assert_eq!(l.strips.len(), 13);
        assert_eq!(l.max_strip_bytes(), 336 * 4096 * 96);
        // The largest image the format allows: 16384 x 16384 x 96 B = 24 GiB; 128 MiB holds 85 rows
        // of 1,572,864 B, 80 when rounded down: ceil(16384 / 80) = 205 strips.
        let l = TileLayout::new(16384, 16384, [8, 8], LAVAPIPE, None).unwrap();
        assert_eq!(l.strips.len(), 205);
        let l = TileLayout::new(65536, 4096, [8, 8], LAVAPIPE, None).unwrap();
        assert!(l.strips.iter().all(|s| (s[1] - s[0]) % 8 == 0));
    }

    #[test]
    fn tiles_partition_every_strip() {
        for (w, h, region, fixed) in [
            (250, 130, 1 << 20, Some([64, 64])),
            (250, 130, 1 << 20, Some([40, 24])),
            (250, 130, 1 << 20, Some([1, 1])),
            (250, 130, 1000, None),
            (250, 130, 64, None),
            (16384, 64, 1 << 18, None),
            (7, 3, 1, None),
        ] {
            let l = TileLayout::new(w, h, [8, 8], LAVAPIPE, fixed).unwrap();
            assert_partition(&l, region);
        }
        // A tiny workgroup-count limit forces many tiles per strip.
        let tiny = TileLimits {
            max_buffer_bytes: 1 << 16,
            max_groups: [3, 2],
        };
        let l = TileLayout::new(100, 60, [8, 8], tiny, None).unwrap();
        assert!(l.strips.len() > 1);
        let mut covered = 0;
        for i in 0..l.strips.len() {
            for t in l.tiles(i, 1 << 30) {
                assert!(t.size()[0] <= 24 && t.size()[1] <= 16, "{t:?}");
                covered += t.pixels();
            }
        }
        assert_eq!(covered, 6000);
    }

    #[test]
    fn adaptive_tiles_stay_near_the_pixel_budget() {
        let l = TileLayout::new(4000, 512, [8, 8], LAVAPIPE, None).unwrap();
        // Whole rows when a workgroup row fits in the budget ...
        let t = l.tiles(0, 100_000);
        assert_eq!(t[0].size(), [4000, 24]);
        // ... else one workgroup row cut across.
        let t = l.tiles(0, 10_000);
        assert_eq!(t[0].size(), [1248, 8]);
    }
}
