// lights/sphere.wgsl: a sphere light (an emitting sphere of uniform radiance), sampled by the cone it
// subtends or by area.
//
// requires: lights/common.wgsl

// --- Sphere light, cone strategy ---------------------------------------------------------------------
// A direction uniform in the cone the sphere subtends from p (pdf 1 / (2 pi (1 - cos theta_max)) per
// sr, sampling.wgsl's sample_cone_local): every direction in it sees the sphere, so no sample is wasted,
// and L = Le on all of them. The point on the sphere where wi meets it, which shadow rays aim at, comes
// from the sampled angle rather than from intersecting the ray (which loses the point at the cone's rim
// to rounding): with D = |c - p|, sin(theta_max) = r / D and theta the sampled angle from the axis, the
// near root t = D cos(theta) - sqrt(r^2 - D^2 sin^2(theta)) puts the point's normal at the angle alpha
// from -axis with cos(alpha) = (D - t cos(theta)) / r = sin^2(theta) / sin(theta_max)
// + cos(theta) sqrt(1 - sin^2(theta) / sin^2(theta_max)) (pbrt-v4 §6.2.4 derives the same), in the
// plane of the axis and wi. The point c + r n is then on the sphere to rounding, whatever the error in
// alpha.
fn sphere_light_sample_cone(light: Light, p: vec3<f32>, u: vec2<f32>) -> LightLiSample {
    let to_center = light.position - p;
    let d2 = dot(to_center, to_center);
    let r = light.radius;
    if d2 <= r * r {
        return no_light_sample(); // inside the light: it does not illuminate its own interior
    }
    let dc = sqrt(d2);
    let axis = to_center / dc;
    let omc_max = sphere_cone_one_minus_cos(r, d2);
    let cone = sample_cone_local(omc_max, u);
    let frame = frame_from_normal(axis);
    let wi = frame_to_world(frame, cone.local);
    let cos_t = cone.local.z;
    let sin2_t = cone.sin2;
    let sin_max = min(1.0, r / dc);
    let ratio = min(1.0, sin2_t / (sin_max * sin_max));
    let cos_alpha = min(1.0, sin2_t / sin_max + cos_t * sqrt(1.0 - ratio));
    let sin_alpha = sqrt(max(0.0, 1.0 - cos_alpha * cos_alpha));
    let n_light = frame_to_world(frame, vec3<f32>(sin_alpha * cone.cos_phi, sin_alpha * cone.sin_phi,
                                                  -cos_alpha));
    let p_light = light.position + r * n_light;
    return LightLiSample(light.intensity, wi, cone_pdf(cone.one_minus_cos, omc_max), p_light,
                         length(p_light - p), false, NO_LIGHT);
}

// --- Sphere light, area strategy (the course's method) -----------------------------------------------
// A point x_l = c + R m on the hemisphere of the light that faces p, with m cosine-distributed about
// a = (p - c)/|p - c|: density per unit area pdf_A = (m . a) / (pi R^2), per unit solid angle at p
// pdf = pdf_A d^2 / cos(theta_l), with d = |x_l - p| and theta_l the angle at x_l between m and the
// direction back to p. Every point of the sphere visible from p lies on that hemisphere, and a point of it
// with cos(theta_l) <= 0 is hidden by the sphere itself, so the estimate is unbiased. Compared with the
// cone it wastes the samples near the hemisphere's rim that p cannot see, and its pdf varies across the
// light: more noise, most of all when p is close to the light.
fn sphere_light_sample_area(light: Light, p: vec3<f32>, u: vec2<f32>) -> LightLiSample {
    let to_p = p - light.position;
    let dc2 = dot(to_p, to_p);
    let r = light.radius;
    if dc2 <= r * r {
        return no_light_sample();
    }
    let axis = to_p / sqrt(dc2);
    let m = sample_cosine_hemisphere(axis, u);
    let cos_m = dot(m, axis);
    let x_l = light.position + r * m;
    let to_light = x_l - p;
    let d2 = dot(to_light, to_light);
    let d = sqrt(d2);
    let wi = to_light / d;
    let cos_l = -dot(m, wi);
    if cos_l <= 0.0 || cos_m <= 0.0 {
        return no_light_sample();
    }
    let pdf = cos_m * d2 / (PI * r * r * cos_l);
    return LightLiSample(light.intensity, wi, pdf, x_l, d, false, NO_LIGHT);
}

// The density sphere_light_sample_area gives direction wi from p (0 if wi misses the sphere).
fn sphere_light_pdf_area(light: Light, p: vec3<f32>, wi: vec3<f32>) -> f32 {
    let r = light.radius;
    let t = intersect_sphere(p, wi, light.position, r, 0.0, T_MISS);
    if t == T_MISS {
        return 0.0;
    }
    let x_l = p + t * wi;
    let m = (x_l - light.position) / r;
    let to_p = p - light.position;
    let cos_m = dot(m, to_p) / length(to_p);
    let cos_l = -dot(m, wi);
    if cos_l <= 0.0 || cos_m <= 0.0 {
        return 0.0;
    }
    return cos_m * t * t / (PI * r * r * cos_l);
}

// The density sphere_light_sample_cone gives direction wi from p: uniform over the directions that
// meet the sphere (decided by intersecting the ray, as for a BSDF-sampled ray that found the light; at the
// cone's rim the two tests can disagree by rounding, on a set of directions of negligible measure).
fn sphere_light_pdf_cone(light: Light, p: vec3<f32>, wi: vec3<f32>) -> f32 {
    let to_center = light.position - p;
    let d2 = dot(to_center, to_center);
    if d2 <= light.radius * light.radius {
        return 0.0;
    }
    if intersect_sphere(p, wi, light.position, light.radius, 0.0, T_MISS) == T_MISS {
        return 0.0;
    }
    return 1.0 / (TWO_PI * sphere_cone_one_minus_cos(light.radius, d2));
}

// The strategy's sample: read from params by the generic kernel (LIGHT_SAMPLING_FROM_PARAMS), fixed by a
// constant in a specialised one. Every guard is a bare constant, so pruning keeps only the strategy used.
fn sphere_light_sample(light: Light, p: vec3<f32>, strategy: u32, u: vec2<f32>) -> LightLiSample {
    var ls = no_light_sample();
    if LIGHT_SAMPLING_FROM_PARAMS {
        if strategy == LIGHT_SAMPLING_AREA {
            ls = sphere_light_sample_area(light, p, u);
        } else if strategy != LIGHT_SAMPLING_NONE {
            ls = sphere_light_sample_cone(light, p, u); // cone, and the light half of mis
        }
    }
    if LIGHT_SAMPLING_IS_AREA {
        ls = sphere_light_sample_area(light, p, u);
    }
    if LIGHT_SAMPLING_IS_CONE {
        ls = sphere_light_sample_cone(light, p, u);
    }
    if LIGHT_SAMPLING_IS_MIS {
        ls = sphere_light_sample_cone(light, p, u);
    }
    return ls;
}

fn sphere_light_pdf(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    var pdf = 0.0;
    if LIGHT_SAMPLING_FROM_PARAMS {
        if strategy == LIGHT_SAMPLING_AREA {
            pdf = sphere_light_pdf_area(light, p, wi);
        } else if strategy != LIGHT_SAMPLING_NONE {
            pdf = sphere_light_pdf_cone(light, p, wi);
        }
    }
    if LIGHT_SAMPLING_IS_AREA {
        pdf = sphere_light_pdf_area(light, p, wi);
    }
    if LIGHT_SAMPLING_IS_CONE {
        pdf = sphere_light_pdf_cone(light, p, wi);
    }
    if LIGHT_SAMPLING_IS_MIS {
        pdf = sphere_light_pdf_cone(light, p, wi);
    }
    return pdf;
}

// --- The interface (lights/common.wgsl) -----------------------------------------------------------

// The two numbers are drawn whatever the strategy ("none" included), so that the numbers drawn after them
// are at the same dimensions in every variant.
fn sphere_light_sample_li(light: Light, p: vec3<f32>, strategy: u32,
                          rng: ptr<function, Rng>) -> LightLiSample {
    let u = rng_next2(rng);
    return sphere_light_sample(light, p, strategy, u);
}

fn sphere_light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32 {
    return sphere_light_pdf(light, p, wi, strategy);
}

// A ray that hits the sphere sees its surface radiance.
fn sphere_light_radiance(light: Light, w: vec3<f32>) -> vec3<f32> {
    return light.intensity;
}
