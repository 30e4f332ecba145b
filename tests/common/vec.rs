//! Small f64 vector helpers shared by the shader tests' CPU references (tests/shader_camera.rs,
//! tests/shader_bsdf.rs, tests/shader_glossy.rs, tests/shader_sampling.rs).

pub type V3 = [f64; 3];

pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn length(a: V3) -> f64 {
    dot(a, a).sqrt()
}

pub fn normalize(a: V3) -> V3 {
    let l = length(a);
    a.map(|x| x / l)
}

pub fn add(a: V3, b: V3) -> V3 {
    std::array::from_fn(|k| a[k] + b[k])
}

pub fn sub(a: V3, b: V3) -> V3 {
    std::array::from_fn(|k| a[k] - b[k])
}

pub fn scale(a: V3, s: f64) -> V3 {
    a.map(|x| x * s)
}

/// An f32 vector widened exactly to f64.
pub fn widen(a: [f32; 3]) -> V3 {
    a.map(|x| x as f64)
}

/// The first three components of a vec4 read back from the GPU, widened.
pub fn xyz(v: [f32; 4]) -> V3 {
    [v[0] as f64, v[1] as f64, v[2] as f64]
}

/// A CPU basis (t, b) around the unit n: the BSDF tests rely only on symmetry about n, or pass t to the
/// shader as the tangent.
pub fn basis(n: V3) -> (V3, V3) {
    let a = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t = normalize(cross(a, n));
    (t, cross(n, t))
}

/// The unit direction at polar cosine `cos` and azimuth `phi` about n, in the frame of [`basis`].
pub fn from_angles(n: V3, cos: f64, phi: f64) -> V3 {
    let (t, b) = basis(n);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    std::array::from_fn(|k| sin * phi.cos() * t[k] + sin * phi.sin() * b[k] + cos * n[k])
}
