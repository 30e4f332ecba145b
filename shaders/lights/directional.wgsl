// lights/directional.wgsl: a directional light (a sun: a delta direction or a small cone).
//
// requires: lights/common.wgsl

// --- Directional light (a sun) -------------------------------------------------------------------------
// From infinitely far: every point sees it along the same directions. A delta light (radius = 0) arrives
// along `position` with L = E (pdf 1); a sun of angular radius a fills the cone of half-angle a around
// it with radiance Le, sampled uniformly in that cone (pdf 1 / (2 pi (1 - cos a))), so that
// L cos / pdf averages to Le pi sin^2(a) cos = E cos on a surface whose horizon the cone clears.
// The two numbers are drawn in both cases (so that later dimensions line up).
fn directional_light_sample(light: Light, u: vec2<f32>) -> LightLiSample {
    if light.radius == 0.0 {
        return LightLiSample(light.intensity, light.position, 1.0, vec3<f32>(0.0), T_MISS, true, NO_LIGHT);
    }
    let cone = sample_cone_local(light.radius, u);
    let wi = frame_to_world(frame_from_normal(light.position), cone.local);
    return LightLiSample(light.intensity, wi, cone_pdf(cone.one_minus_cos, light.radius), vec3<f32>(0.0),
                         T_MISS, false, NO_LIGHT);
}

// Whether direction w (unit) lies in a directional light's cone (never, for a delta light).
fn directional_light_covers(light: Light, w: vec3<f32>) -> bool {
    let delta = w - light.position;
    return light.radius > 0.0 && 0.5 * dot(delta, delta) <= light.radius;
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

fn directional_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                               rng: ptr<function, Rng>) -> LightLiSample {
    return directional_light_sample(light, rng_next2(rng));
}

// Uniform in the cone (0 outside it, and for a delta sun).
fn directional_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    var pdf = 0.0;
    if directional_light_covers(light, wi) {
        pdf = 1.0 / (TWO_PI * light.radius);
    }
    return pdf;
}

// An escaping ray inside the sun's cone sees its radiance.
fn directional_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(0.0), light.intensity, directional_light_covers(light, w));
}
