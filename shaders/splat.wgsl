// splat.wgsl: the film-side gather of a splatted render (render.splat): after a pass has traced every
// pixel's samples and left one record per sample in `splat_samples` (trace.wgsl, splat_record), each
// invocation adds to its pixel q the samples of the (2K + 1)^2 pixels around it whose filter footprint
// covers q's centre, each weighted by the filter:
//
//     sum_q += w(x_s - c_q) L_s,   weight_q += w(x_s - c_q),   pixel q = sum_q / weight_q,
//
// with x_s the sample's film position (uniform over its own pixel), c_q = q + (0.5, 0.5) and w the
// separable filter f(dx) f(dy). That is Mitsuba 3's film (ImageBlock::put, then the division by the
// weight channel when the image is developed): the filter-weighted average of every sample that falls
// in the pixel's footprint. Near the image's edges only samples on the image take part, so the filter
// is cut off there and renormalised: `sample_border = false`, Mitsuba's default (a splatted render needs
// it; RenderSettings::splats). The ratio is consistent, not unbiased (a ratio estimator), as Mitsuba's
// is; against each pixel averaging its own filter-importance-sampled samples it has less variance at
// equal samples, because every sample informs up to (2K + 1)^2 pixels instead of one.
//
// Exact, like the per-pixel sums (accumulate.wgsl): w is rounded to a multiple of 2^-SPLAT_WEIGHT_BITS;
// for each sample index the neighbourhood's w L are summed in f32 in a fixed order (a pure function of
// that sample index's records, which one pass always holds together) and that sum is added to the exact
// long accumulator, the rounded weights to a 64-bit integer. So the sums do not depend on the order of
// the additions or on how the render was cut into passes, tiles, checkpoints or farm parts.
//
// Filters (Mitsuba 3's, in pixels): the tent f(d) = max(0, 1 - |d| / r) of radius r; the Gaussian
// f(d) = max(0, exp(-d^2 / (2 sigma^2)) - exp(-8)) over its radius 4 sigma (Mitsuba subtracts the value
// at the radius so that the filter reaches 0 there). K = ceil(R - 1/2) for the radius R: a sample of
// pixel q + d lies within R of c_q only if |d| - 1/2 < R on each axis.
//
// lavapipe ends an invocation's loops after 65535 iterations in total (trace.wgsl), so the host gives
// one dispatch at most as many samples as fit that budget (render::splat_gather_chunk).
//
// requires: accumulate.wgsl

const SPLAT_FILTER_GAUSSIAN: u32 = 2u;

struct SplatConstants {
    width: u32,
    height: u32,
    // The bound strip's rows row0 .. row1 - 1; its entry 0 is pixel accum_base (row-major, whole image).
    accum_base: u32,
    row0: u32,
    row1: u32,
    // The records gathered: samples first .. first + count - 1 of the pass (record i of pixel p is
    // splat_samples[i * width * height + p]).
    first: u32,
    count: u32,
    filter_kind: u32, // FILTER_TENT or FILTER_GAUSSIAN (abi.rs)
    filter_width: f32, // the tent's radius or the Gaussian's standard deviation, in pixels
    reach: u32, // K: the neighbours within K pixels on each axis can reach the pixel's centre
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> splat_constants: SplatConstants;
@group(0) @binding(1) var<storage, read> splat_samples: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> splat_accum: array<SplatAccum>;

// The 1-D filter at offset d (pixels).
fn splat_filter(d: f32, kind: u32, width: f32) -> f32 {
    if kind == SPLAT_FILTER_GAUSSIAN {
        let r = 4.0 * width;
        let g = exp(-0.5 * d * d / (width * width)) - exp(-8.0);
        return select(0.0, max(g, 0.0), abs(d) < r);
    }
    return max(0.0, 1.0 - abs(d) / width);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = splat_constants;
    let q = vec2<u32>(gid.x, c.row0 + gid.y);
    if q.x >= c.width || q.y >= c.row1 {
        return;
    }
    let slot = q.y * c.width + q.x - c.accum_base;
    let entry = splat_accum[slot];
    var acc: Accum;
    acc.sum = entry.sum;
    var weight_lo = entry.weight[0];
    var weight_hi = entry.weight[1];
    let pixels = c.width * c.height;
    let k = i32(c.reach);
    let center = vec2<f32>(q) + vec2<f32>(0.5);
    let unit = f32(1u << SPLAT_WEIGHT_BITS);
    // Rows and columns of the neighbourhood clipped to the image: samples exist on the image only.
    let y0 = max(i32(q.y) - k, 0);
    let y1 = min(i32(q.y) + k, i32(c.height) - 1);
    let x0 = max(i32(q.x) - k, 0);
    let x1 = min(i32(q.x) + k, i32(c.width) - 1);
    for (var i = c.first; i < c.first + c.count; i++) {
        // Sample index i's contributions from the whole neighbourhood, summed in f32 in a fixed order:
        // a pure function of the records of sample i (all of one pass, so always gathered together),
        // added to the exact sums once. One exact addition per sample instead of (2K + 1)^2.
        var wl = vec3<f32>(0.0);
        var units = 0u; // at most (2K + 1)^2 2^24: exact in a u32 for K <= 7
        for (var y = y0; y <= y1; y++) {
            for (var x = x0; x <= x1; x++) {
                let p = u32(y) * c.width + u32(x);
                let rec = splat_samples[i * pixels + p];
                let pos = vec2<f32>(f32(x), f32(y)) + unpack2x16unorm(bitcast<u32>(rec.w));
                let d = pos - center;
                let w = splat_filter(d.x, c.filter_kind, c.filter_width)
                    * splat_filter(d.y, c.filter_kind, c.filter_width);
                // w rounded to the weight grid (ties to even), then used as that rounded value.
                let n = u32(round(clamp(w, 0.0, 1.0) * unit));
                wl += (f32(n) / unit) * rec.xyz;
                units += n;
            }
        }
        add_exact(&acc, wl);
        let lo = weight_lo + units;
        weight_hi += select(0u, 1u, lo < weight_lo);
        weight_lo = lo;
    }
    var out: SplatAccum;
    out.sum = acc.sum;
    out.weight[0] = weight_lo;
    out.weight[1] = weight_hi;
    splat_accum[slot] = out;
}
