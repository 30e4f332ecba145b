// texture.wgsl: mesh textures (the `textures` table), sampled with bilinear filtering, colour textures
// after sRGB decoding.
//
// requires: scene_data.wgsl

// The sRGB transfer curve undone (IEC 61966-2-1): an 8-bit texel value c in [0, 1] encodes the linear
// value c / 12.92 for c <= 0.04045 and ((c + 0.055) / 1.055)^2.4 above. Albedo is a linear quantity, so
// texels are decoded before they are filtered: averaging encoded values would darken every edge.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let curve = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(curve, c / 12.92, c <= vec3<f32>(0.04045));
}

// Texel (x, y) as a linear value: colour textures (TEXTURE_SRGB) decoded, data textures (a
// metallic-roughness map) as stored, c / 255.
fn texel_linear(tex: TextureInfo, x: u32, y: u32) -> vec3<f32> {
    let c = unpack4x8unorm(texels[tex.offset + y * tex.width + x]).rgb;
    if (tex.flags & TEXTURE_SRGB) != 0u {
        return srgb_to_linear(c);
    }
    return c;
}

// Texture `index` of the table at uv, repeated outside [0, 1)^2. uv (0, 0) is the bottom-left corner of the image
// (the OBJ convention) and texel (x, y) is centred at ((x + 0.5) / w, 1 - (y + 0.5) / h). Bilinear
// filtering: with the sample at continuous texel coordinates (x0 + fx, y0 + fy), x0 and y0 integers and
// fx, fy in [0, 1), the value is the weighted mean of the four nearest texel centres,
//   (1 - fx)(1 - fy) T[x0, y0] + fx (1 - fy) T[x0 + 1, y0] + (1 - fx) fy T[x0, y0 + 1] + fx fy T[x0 + 1, y0 + 1],
// weights that are >= 0 and sum to 1, so the result stays within the texels' range. At a texel centre
// (fx = fy = 0) it is that texel exactly.
fn texture_bilinear(index: u32, uv: vec2<f32>) -> vec3<f32> {
    return texture_bilinear_scaled(index, uv, vec3<f32>(1.0));
}

// The texture times `scale` (a glTF factor), as the weighted mean of the scaled texels: the same value,
// but the last operation is an addition, never a multiplication. (The compiler fuses a multiplication
// whose only use is an addition into one fused multiply-add, which rounds once instead of twice; whether
// a product has one use differs between the generic and a specialised kernel, so a product handed on to
// the BSDF, which adds it (1 - metallic, a Schlick f0 + ...), could round differently in the two. A sum
// handed on rounds the same in both.)
fn texture_bilinear_scaled(index: u32, uv: vec2<f32>, scale: vec3<f32>) -> vec3<f32> {
    let tex = textures[index];
    let w = tex.width;
    let h = tex.height;
    // Wrap into [0, 1] first, so that huge uvs never reach an integer conversion.
    let u = uv.x - floor(uv.x);
    let v = uv.y - floor(uv.y);
    let x = u * f32(w) - 0.5; // in [-0.5, w - 0.5]
    let y = (1.0 - v) * f32(h) - 0.5; // rows from the top
    let xf = floor(x);
    let yf = floor(y);
    let fx = x - xf;
    let fy = y - yf;
    // xf in [-1, w - 1]: -1 wraps to the last column (and likewise for rows).
    let x0 = u32(i32(xf) + i32(w)) % w;
    let y0 = u32(i32(yf) + i32(h)) % h;
    let x1 = (x0 + 1u) % w;
    let y1 = (y0 + 1u) % h;
    return (1.0 - fx) * (1.0 - fy) * (scale * texel_linear(tex, x0, y0))
         + fx * (1.0 - fy) * (scale * texel_linear(tex, x1, y0))
         + (1.0 - fx) * fy * (scale * texel_linear(tex, x0, y1))
         + fx * fy * (scale * texel_linear(tex, x1, y1));
}
