// texture.wgsl: texture lookups. A texture reference (`TextureInfo`, the `textures` table) is an image's
// texels with the way a material parameter reads them: a uv transform, a wrap mode, a filter, the
// channel(s) it takes and whether the texels are sRGB-encoded (src/scene/texture.rs has the host's side,
// docs/scene-format.md the keys).
//
// requires: scene_data.wgsl, features.wgsl
//
// Filtering policy: bilinear (or nearest) on the full-resolution image, no mip levels. A path tracer
// integrates over each pixel's footprint with many samples anyway, so a minified texture converges to
// its area average instead of aliasing; mip levels would only save the noise of the first samples, at
// the cost of ray differentials through every bounce. (Mitsuba 3's `bitmap` makes the same choice.)

// TextureInfo::flags.
const TEXTURE_SRGB: u32 = 1u; // colour texels, sRGB-encoded: decoded before filtering
const TEXTURE_HALF: u32 = 2u; // two words per texel, RGBA as four f16 (EXR and HDR images); else RGBA8
const TEXTURE_NEAREST: u32 = 4u; // nearest texel; else bilinear
const TEXTURE_CLAMP: u32 = 8u; // uv outside [0, 1] clamps to the edge; else repeats
const TEXTURE_MIRROR: u32 = 16u; // uv outside [0, 1] repeats mirrored
const TEXTURE_CHECKERBOARD: u32 = 32u; // Mitsuba's checkerboard: two colours as six f32 (texture_checkerboard)
// Bits 8-10: which channel(s) the texture gives, spread over the three components.
const TEXTURE_CHANNEL_SHIFT: u32 = 8u;
const TEXTURE_CHANNEL_RGB: u32 = 0u;
const TEXTURE_CHANNEL_R: u32 = 1u;
const TEXTURE_CHANNEL_G: u32 = 2u;
const TEXTURE_CHANNEL_B: u32 = 3u;
const TEXTURE_CHANNEL_A: u32 = 4u;
const TEXTURE_CHANNEL_LUMINANCE: u32 = 5u;

// The sRGB transfer curve undone (IEC 61966-2-1): an 8-bit texel value c in [0, 1] encodes the linear
// value c / 12.92 for c <= 0.04045 and ((c + 0.055) / 1.055)^2.4 above. Albedo is a linear quantity, so
// texels are decoded before they are filtered: averaging encoded values would darken every edge.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let curve = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(curve, c / 12.92, c <= vec3<f32>(0.04045));
}

// Texel (x, y) as a linear value, the texture's channel spread over the three components: colour
// textures (TEXTURE_SRGB) decoded, data (a roughness or normal map) as stored, c / 255 (or the f16
// value). Alpha is always linear. Luminance is Rec. 709's, of the linear colour.
fn texel_linear(tex: TextureInfo, x: u32, y: u32) -> vec3<f32> {
    let i = y * tex.width + x;
    var c = vec4<f32>(0.0);
    if (tex.flags & TEXTURE_HALF) != 0u {
        let w = tex.offset + 2u * i;
        c = vec4<f32>(unpack2x16float(texel_at(w)), unpack2x16float(texel_at(w + 1u)));
    } else {
        c = unpack4x8unorm(texel_at(tex.offset + i));
    }
    var rgb = c.rgb;
    if (tex.flags & TEXTURE_SRGB) != 0u {
        rgb = srgb_to_linear(rgb);
    }
    return texture_channel(rgb, c.a, tex.flags);
}

// The texture's channel (TEXTURE_CHANNEL_*) of a linear colour rgb with alpha a, spread over the three
// components.
fn texture_channel(rgb: vec3<f32>, a: f32, flags: u32) -> vec3<f32> {
    var out = rgb;
    switch (flags >> TEXTURE_CHANNEL_SHIFT) & 7u {
        case TEXTURE_CHANNEL_R: {
            out = vec3<f32>(rgb.r);
        }
        case TEXTURE_CHANNEL_G: {
            out = vec3<f32>(rgb.g);
        }
        case TEXTURE_CHANNEL_B: {
            out = vec3<f32>(rgb.b);
        }
        case TEXTURE_CHANNEL_A: {
            out = vec3<f32>(a);
        }
        case TEXTURE_CHANNEL_LUMINANCE: {
            out = vec3<f32>(dot(rgb, vec3<f32>(0.2126, 0.7152, 0.0722)));
        }
        default: {}
    }
    return out;
}

// Mitsuba 3's procedural `checkerboard` at (transformed) uv: with f = uv - floor(uv), colour 0 where
// f.x > 1/2 and f.y > 1/2 agree, colour 1 where they differ (Mitsuba's `eval`), so four squares per unit
// of uv, colour 0 at the origin's corner. The colours are six f32 at the texture's offset, read exactly.
// (Wrap and filter do not apply: the pattern tiles the plane and has no texels to filter.)
fn texture_checkerboard(tex: TextureInfo, uv: vec2<f32>) -> vec3<f32> {
    let f = uv - floor(uv);
    let w = tex.offset + select(0u, 3u, (f.x > 0.5) != (f.y > 0.5));
    let rgb = vec3<f32>(bitcast<f32>(texel_at(w)), bitcast<f32>(texel_at(w + 1u)), bitcast<f32>(texel_at(w + 2u)));
    return texture_channel(rgb, 1.0, tex.flags);
}

// A coordinate outside [0, 1] brought back in by the wrap mode: repeat keeps the fractional part,
// mirror reflects every other period (t in [0, 2), then 2 - t on the second half), clamp clamps.
fn texture_wrap(u: f32, flags: u32) -> f32 {
    if (flags & TEXTURE_CLAMP) != 0u {
        return clamp(u, 0.0, 1.0);
    }
    if (flags & TEXTURE_MIRROR) != 0u {
        let t = u - 2.0 * floor(0.5 * u);
        return select(t, 2.0 - t, t > 1.0);
    }
    return u - floor(u);
}

// Texel index i (possibly -1 or n, a neighbour of an edge texel) inside [0, n): repeat wraps around;
// clamp and mirror both give the edge texel (the mirror image of texel -1 is texel 0).
fn texel_index(i: i32, n: u32, flags: u32) -> u32 {
    if (flags & (TEXTURE_CLAMP | TEXTURE_MIRROR)) != 0u {
        return u32(clamp(i, 0, i32(n) - 1));
    }
    return u32(i + i32(n)) % n;
}

// The uv a texture reads at surface coordinates uv: uv' = M uv + offset, M = R(rotation) diag(scale)
// (KHR_texture_transform's order: scale, then rotate, then offset). The identity (M = I, offset 0)
// returns uv unchanged, bit for bit (1 u + 0 v + 0 = u exactly).
fn texture_uv(tex: TextureInfo, uv: vec2<f32>) -> vec2<f32> {
    let m = tex.uv_matrix;
    return vec2<f32>(m.x * uv.x + m.y * uv.y, m.z * uv.x + m.w * uv.y) + tex.uv_offset;
}

// Texture `index` of the table at surface coordinates uv, times `scale` (a parameter's factor; see
// below). uv (0, 0) is the bottom-left corner of the image (the OBJ convention) and texel (x, y) is
// centred at ((x + 0.5) / w, 1 - (y + 0.5) / h).
//
// Bilinear filtering: with the sample at continuous texel coordinates (x0 + fx, y0 + fy), x0 and y0
// integers and fx, fy in [0, 1), the value is the weighted mean of the four nearest texel centres,
//   (1 - fx)(1 - fy) T[x0, y0] + fx (1 - fy) T[x0 + 1, y0] + (1 - fx) fy T[x0, y0 + 1] + fx fy T[x0 + 1, y0 + 1],
// weights that are >= 0 and sum to 1, so the result stays within the texels' range. At a texel centre
// (fx = fy = 0) it is that texel exactly. Nearest: the texel whose square contains the sample.
//
// The factor multiplies each texel before the weighted sum rather than the sum after: the same value,
// but the last operation is an addition, never a multiplication. (The compiler fuses a multiplication
// whose only use is an addition into one fused multiply-add, which rounds once instead of twice; whether
// a product has one use differs between the generic and a specialised kernel, so a product handed on to
// the BSDF, which adds it (1 - metallic, a Schlick f0 + ...), could round differently in the two. A sum
// handed on rounds the same in both.)
fn texture_lookup(index: u32, uv_in: vec2<f32>, scale: vec3<f32>) -> vec3<f32> {
    let tex = texture_info_at(index);
    let uv = texture_uv(tex, uv_in);
    var value = vec3<f32>(0.0);
    var image = true;
    if HAS_CHECKERBOARD {
        if (tex.flags & TEXTURE_CHECKERBOARD) != 0u {
            value = scale * texture_checkerboard(tex, uv);
            image = false;
        }
    }
    if image {
        value = image_lookup(tex, uv, scale);
    }
    return value;
}

// An image texture's filtered value at the transformed uv, times `scale` (see texture_lookup).
//
// One loop over the taps (one for nearest, four for bilinear) rather than four written-out texel reads:
// lavapipe inlines every call and expands each storage-buffer read whose index differs between lanes
// into branches per lane, so every texel read written here is compiled once per texture lookup in the
// kernel; a loop whose trip count the compiler cannot know keeps one (docs/performance.md, "What the
// first sample waits for"). The sum runs over the taps in the order of the formula above.
fn image_lookup(tex: TextureInfo, uv: vec2<f32>, scale: vec3<f32>) -> vec3<f32> {
    let w = tex.width;
    let h = tex.height;
    // Wrapped into [0, 1] first, so that huge uvs never reach an integer conversion.
    let u = texture_wrap(uv.x, tex.flags);
    let v = texture_wrap(uv.y, tex.flags);
    var taps = 4u;
    var x0 = 0u;
    var y0 = 0u;
    var x1 = 0u;
    var y1 = 0u;
    var fx = 0.0;
    var fy = 0.0;
    if (tex.flags & TEXTURE_NEAREST) != 0u {
        // The texel whose square contains the sample, weight 1.
        taps = 1u;
        x0 = min(u32(u * f32(w)), w - 1u);
        y0 = min(u32((1.0 - v) * f32(h)), h - 1u);
    } else {
        let x = u * f32(w) - 0.5; // in [-0.5, w - 0.5]
        let y = (1.0 - v) * f32(h) - 0.5; // rows from the top
        let xf = floor(x);
        let yf = floor(y);
        fx = x - xf;
        fy = y - yf;
        // xf in [-1, w - 1]: -1 is the last column when repeating, the first when clamping (and likewise
        // for rows).
        x0 = texel_index(i32(xf), w, tex.flags);
        y0 = texel_index(i32(yf), h, tex.flags);
        x1 = texel_index(i32(xf) + 1, w, tex.flags);
        y1 = texel_index(i32(yf) + 1, h, tex.flags);
    }
    var value = vec3<f32>(0.0);
    for (var k = 0u; k < taps; k++) {
        // Tap k: bit 0 the column (x0 or x1), bit 1 the row (y0 or y1).
        let right = (k & 1u) != 0u;
        let below = (k & 2u) != 0u;
        let weight = select(1.0 - fx, fx, right) * select(1.0 - fy, fy, below);
        value += weight * (scale * texel_linear(tex, select(x0, x1, right), select(y0, y1, below)));
    }
    return value;
}

// The texture's value at uv (factor 1).
fn texture_value(index: u32, uv: vec2<f32>) -> vec3<f32> {
    return texture_lookup(index, uv, vec3<f32>(1.0));
}

// Material m's textures and modifiers: its entry of `material_textures` (or of its uniform twin), or none
// (opaque, untextured) when the buffer is empty (the host uploads it only when some material has one; the generic kernel
// still runs such scenes).
fn material_textures_of(m: u32) -> MaterialTextures {
    var t = MaterialTextures(NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE,
                             NO_TEXTURE, 0u, 1.0, 0.0, 1.0, 1.0, 0u, 0.0, NO_TEXTURE, 0u);
    if UNIFORM_MATERIAL_TEXTURES {
        // Its twin only holds a table that is there, one entry per material (UniformArray::fits).
        t = material_textures_uniform[m];
    } else {
        if m < arrayLength(&material_textures) {
            t = material_textures[m];
        }
    }
    return t;
}
