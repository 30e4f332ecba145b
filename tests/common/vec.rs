//! Small f64 vector helpers shared by the shader tests' CPU references (tests/shader_camera.rs,
//! tests/shader_bsdf.rs, tests/shader_sampling.rs).

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
