// lights/spot.wgsl: a spot light.
//
// requires: lights/common.wgsl

// --- Spot light --------------------------------------------------------------------------------------
// A point at `position` whose radiant intensity is I f(theta) (W/sr), theta the angle from its unit
// `axis`: f = 1 inside the beam (theta <= b), 0 beyond the cutoff (theta >= c), and linear in the angle
// between, f = (c - theta) / (c - b): Mitsuba 3's `spot` emitter. Delta in position, so pdf = 1 and
// L = I f / r^2. (The power it emits, and so I for a given power, is in src/kernel/upload.rs,
// spot_cone_solid_angle.)
//
// The angles are compared through sin(c - theta) = sin c cos theta - cos c sin theta (and the same for b),
// with cos theta = w.axis and sin theta = |w x axis| and the cone's cosines and sines from the host, and
// c - theta = atan2(sin(c - theta), cos(c - theta)): a GPU's cos and acos may be off by 2^-11 absolute
// (the Vulkan precision rules), which would move the cutoff by a fraction of a degree, while atan2's
// error is relative to its (here small) result.
//
// The smooth falloff (spot_falloff 1; glTF's KHR_lights_punctual, its recommended implementation):
// t = clamp((cos theta - cos c) / (cos b - cos c), 0, 1), f = t^2.
fn spot_falloff(light: Light, w: vec3<f32>) -> f32 {
    let cos_t = dot(w, light.axis);
    if light.spot_falloff == 1u {
        let t = clamp((cos_t - light.spot_cone.x) * light.spot_inv_width, 0.0, 1.0);
        return t * t;
    }
    let sin_t = length(cross(w, light.axis));
    let cone = light.spot_cone; // (cos c, sin c, cos b, sin b)
    let sin_to_cutoff = cone.y * cos_t - cone.x * sin_t;
    if sin_to_cutoff <= 0.0 || cos_t <= 0.0 {
        return 0.0;
    }
    if cone.w * cos_t - cone.z * sin_t >= 0.0 {
        return 1.0; // inside the beam
    }
    let to_cutoff = atan2(sin_to_cutoff, cone.x * cos_t + cone.y * sin_t);
    return clamp(to_cutoff * light.spot_inv_width, 0.0, 1.0);
}

fn spot_light_sample(light: Light, p: vec3<f32>) -> LightLiSample {
    let to_light = light.position - p;
    let d2 = dot(to_light, to_light);
    if d2 == 0.0 {
        return no_light_sample();
    }
    let dist = sqrt(d2);
    let f = spot_falloff(light, -to_light / dist);
    if f == 0.0 {
        return no_light_sample();
    }
    return LightLiSample(light.intensity * (f / d2), to_light / dist, 1.0, light.position, dist, true, NO_LIGHT);
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

fn spot_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                        rng: ptr<function, Rng>) -> LightLiSample {
    return spot_light_sample(light, p);
}

// A delta in position: no direction found by another strategy is the one towards the point.
fn spot_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    return 0.0;
}

// No ray reaches a point.
fn spot_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}
