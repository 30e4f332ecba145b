// materials.wgsl: the scattering functions. Diffuse (Lambert), perfect mirror, smooth dielectric.

const MAT_DIFFUSE: u32 = 0u;
const MAT_MIRROR: u32 = 1u;
const MAT_DIELECTRIC: u32 = 2u;
// The surface of a sphere light: emits, absorbs everything (a path ends there).
const MAT_EMITTER: u32 = 3u;

// Mirror reflection of the incoming direction d about the unit normal n.
fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

// Exact Fresnel reflectance of a smooth dielectric interface for unpolarised light.
// cos_i: cosine of the incidence angle (>= 0); eta = n_t / n_i (transmitted over incident index).
// F = (r_par^2 + r_perp^2) / 2 with r_par = (eta cos_i - cos_t)/(eta cos_i + cos_t),
// r_perp = (cos_i - eta cos_t)/(cos_i + eta cos_t); total internal reflection (sin_t >= 1) gives F = 1.
fn fresnel_dielectric(cos_i_in: f32, eta: f32) -> f32 {
    if eta == 1.0 {
        return 0.0; // index-matched: no interface at all (exactly, not up to rounding)
    }
    let cos_i = clamp(cos_i_in, 0.0, 1.0);
    let sin2_i = max(0.0, 1.0 - cos_i * cos_i);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

// Snell refraction of unit direction d through a surface with unit normal n facing the incoming side
// (dot(d, n) < 0), eta = n_t / n_i. w_t = d/eta + (cos_i/eta - cos_t) n. The caller has excluded total
// internal reflection (fresnel_dielectric returned < 1). eta = 1 returns d unchanged, bit for bit.
fn refract_dir(d: vec3<f32>, n: vec3<f32>, eta: f32) -> vec3<f32> {
    if eta == 1.0 {
        return d;
    }
    let cos_i = clamp(-dot(d, n), 0.0, 1.0);
    let sin2_t = max(0.0, 1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = sqrt(max(0.0, 1.0 - sin2_t));
    return normalize(d / eta + (cos_i / eta - cos_t) * n);
}
