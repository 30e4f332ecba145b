// lights/environment.wgsl: light from infinitely far: uniform, or an equirectangular map.
//
// requires: lights/common.wgsl

// --- Environment light (LIGHT_ENVIRONMENT) ---------------------------------------------------------------
// Radiance arriving from infinitely far: uniform (`intensity`), or `intensity` times an equirectangular
// map laid out as Mitsuba 3's `envmap` (src/scene/environment.rs states the convention: u from
// atan2(x, -z), v = theta / pi, pixel columns at u = (k + 1/2) / W, rows at v = j / (H - 1), bilinear
// between them). Sampled uniformly over the sphere without a map (pdf 1 / (4 pi)); with one, a cell of
// the (H - 1) x W grid between pixel samples from the tabulated 2-D distribution (its probability P, by
// the marginal CDF over rows then the row's CDF over columns), uniformly within it:
// pdf(u, v) = P W (H - 1), and per unit solid angle pdf(u, v) / (2 pi^2 sin theta).

// The map's RGB radiance, three floats per pixel, rows from the top; and its distribution: the H - 1
// values of the CDF over rows, then per row the W values of its CDF over columns (environment.rs).
@group(0) @binding(14) var<storage, read> env_texels: array<f32>;
@group(0) @binding(15) var<storage, read> env_cdf: array<f32>;

// World direction -> the map's frame (the inverse of the rotation by the light's angle about +y), and back.
fn env_to_map(light: Light, w: vec3<f32>) -> vec3<f32> {
    let c = light.position.x;
    let s = light.position.y;
    return vec3<f32>(c * w.x - s * w.z, w.y, s * w.x + c * w.z);
}

fn env_to_world(light: Light, m: vec3<f32>) -> vec3<f32> {
    let c = light.position.x;
    let s = light.position.y;
    return vec3<f32>(c * m.x + s * m.z, m.y, -s * m.x + c * m.z);
}

fn env_uv(m: vec3<f32>) -> vec2<f32> {
    let u = atan2(m.x, -m.z) / TWO_PI;
    return vec2<f32>(u - floor(u), acos(clamp(m.y, -1.0, 1.0)) * INV_PI);
}

fn env_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = TWO_PI * uv.x;
    let theta = PI * uv.y;
    let st = sin(theta);
    return vec3<f32>(st * sin(phi), cos(theta), -st * cos(phi));
}

// The cell of (u, v) (column k, row j of cells) and the position inside it, in [0, 1]^2.
struct EnvCell {
    k: u32,
    j: u32,
    f: vec2<f32>,
}

fn env_cell(light: Light, uv: vec2<f32>) -> EnvCell {
    let w = f32(light.map_width);
    let x = fract(uv.x - 0.5 / w) * w;
    let y = uv.y * f32(light.map_height - 1u);
    let k = min(u32(x), light.map_width - 1u);
    let j = min(u32(y), light.map_height - 2u);
    return EnvCell(k, j, vec2<f32>(x - f32(k), y - f32(j)));
}

fn env_texel(light: Light, k: u32, j: u32) -> vec3<f32> {
    let i = 3u * (j * light.map_width + k);
    return vec3<f32>(env_texels[i], env_texels[i + 1u], env_texels[i + 2u]);
}

// The map's bilinear radiance in cell `cell` (columns wrap around).
fn env_map_radiance(light: Light, cell: EnvCell) -> vec3<f32> {
    let k1 = select(cell.k + 1u, 0u, cell.k + 1u == light.map_width);
    let top = mix(env_texel(light, cell.k, cell.j), env_texel(light, k1, cell.j), cell.f.x);
    let bottom = mix(env_texel(light, cell.k, cell.j + 1u), env_texel(light, k1, cell.j + 1u), cell.f.x);
    return mix(top, bottom, cell.f.y);
}

// The CDF value before entry i of the CDF that starts at env_cdf[first]: 0 for i = 0. (select evaluates
// both of its values, and the kernel's buffer accesses are not bounds-checked, so the index must stay in
// the buffer either way.)
fn env_cdf_before(first: u32, i: u32) -> f32 {
    return select(0.0, env_cdf[first + max(i, 1u) - 1u], i > 0u);
}

// The probability of cell (k, j), from its CDFs.
fn env_cell_probability(light: Light, k: u32, j: u32) -> f32 {
    let rows = light.map_height - 1u;
    let p_row = env_cdf[j] - env_cdf_before(0u, j);
    let base = rows + j * light.map_width;
    let p_col = env_cdf[base + k] - env_cdf_before(base, k);
    return p_row * p_col;
}

// The first of the `count` CDF values from env_cdf[first] that exceeds u (binary search; the last is 1).
fn env_cdf_search(first: u32, count: u32, u: f32) -> u32 {
    var lo = 0u;
    var hi = count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if env_cdf[first + mid] > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

fn has_env_map(light: Light) -> bool {
    if HAS_ENVIRONMENT_MAP {
        return light.map_width > 0u;
    }
    return false;
}

// The radiance arriving along -w, i.e. seen looking in direction w.
fn environment_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    var l = light.intensity;
    if has_env_map(light) {
        l *= env_map_radiance(light, env_cell(light, env_uv(env_to_map(light, w))));
    }
    return l;
}

fn environment_pdf(light: Light, w: vec3<f32>) -> f32 {
    var pdf = 1.0 / (4.0 * PI);
    if has_env_map(light) {
        let m = env_to_map(light, w);
        let sin_theta = length(m.xz); // not sqrt(1 - y^2), which is 0 in f32 within 3e-4 rad of a pole
        let cell = env_cell(light, env_uv(m));
        let cells = f32(light.map_width * (light.map_height - 1u));
        pdf = select(0.0, env_cell_probability(light, cell.k, cell.j) * cells / (2.0 * PI * PI * sin_theta),
                     sin_theta > 0.0);
    }
    return pdf;
}

// A direction to the environment (two numbers: the row and the column, each reused within its cell).
fn environment_sample(light: Light, strategy: u32, u: vec2<f32>) -> LightLiSample {
    var ls = no_light_sample();
    if lights_sampled(strategy) {
        if has_env_map(light) {
            let rows = light.map_height - 1u;
            let w = light.map_width;
            let j = env_cdf_search(0u, rows, u.x);
            let row_lo = env_cdf_before(0u, j);
            let fy = clamp((u.x - row_lo) / (env_cdf[j] - row_lo), 0.0, 1.0);
            let base = rows + j * w;
            let k = env_cdf_search(base, w, u.y);
            let col_lo = env_cdf_before(base, k);
            let fx = clamp((u.y - col_lo) / (env_cdf[base + k] - col_lo), 0.0, 1.0);
            let uv = vec2<f32>(fract((f32(k) + 0.5 + fx) / f32(w)), (f32(j) + fy) / f32(rows));
            let m = env_direction(uv);
            let sin_theta = sin(PI * uv.y);
            let p = env_cell_probability(light, k, j) * f32(w * rows);
            if sin_theta > 0.0 && p > 0.0 {
                let l = light.intensity * env_map_radiance(light, EnvCell(k, j, vec2<f32>(fx, fy)));
                ls = LightLiSample(l, env_to_world(light, m), p / (2.0 * PI * PI * sin_theta), vec3<f32>(0.0),
                                   T_MISS, false, NO_LIGHT);
            }
        } else {
            let wi = sample_cone(vec3<f32>(0.0, 1.0, 0.0), 2.0, u);
            ls = LightLiSample(light.intensity, wi, 1.0 / (4.0 * PI), vec3<f32>(0.0), T_MISS, false, NO_LIGHT);
        }
    }
    return ls;
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

fn environment_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                               rng: ptr<function, Rng>) -> LightLiSample {
    return environment_sample(light, strategy, rng_next2(rng));
}

fn environment_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    return select(0.0, environment_pdf(light, wi), lights_sampled(strategy));
}

// Any escaping ray sees the environment.
fn environment_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return environment_radiance(light, w);
}
