// lights/point.wgsl: a point light.
//
// requires: lights/common.wgsl

// --- Point light -------------------------------------------------------------------------------------
// Intensity I (W/sr) at `position`: irradiance I cos(theta) / r^2 on a surface at distance r. Delta in
// position, so pdf = 1 and L = I / r^2.
fn point_light_sample(light: Light, p: vec3<f32>) -> LightLiSample {
    let to_light = light.position - p;
    let d2 = dot(to_light, to_light);
    if d2 == 0.0 {
        return no_light_sample();
    }
    let dist = sqrt(d2);
    return LightLiSample(light.intensity / d2, to_light / dist, 1.0, light.position, dist, true, NO_LIGHT);
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

fn point_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                         rng: ptr<function, Rng>) -> LightLiSample {
    return point_light_sample(light, p);
}

// A delta in position: no direction found by another strategy is the one towards the point.
fn point_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    return 0.0;
}

// No ray reaches a point.
fn point_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}
