// sampling.wgsl: warping uniform numbers into the distributions the integrator needs, each warp with its
// density (`*_pdf`) beside it. The chi-square tests (tests/shader_sampling.rs) bin the warps' samples and
// compare them with these very pdf functions, integrated over each bin on the GPU: a pdf that disagrees
// with its warp fails there, as a material's or light's does in tests/shader_bsdf.rs and shader_lights.rs.
//
// requires: (nothing)

const PI: f32 = 3.14159265358979323846;
const TWO_PI: f32 = 6.28318530717958647692;
const INV_PI: f32 = 0.31830988618379067154;
const SQRT_2: f32 = 1.41421356237309504880;

// An orthonormal basis (t, b, n) around a unit vector n, without branches on n's direction except its sign:
// Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017.
struct Frame {
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

fn frame_from_normal(n: vec3<f32>) -> Frame {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return Frame(t, bt, n);
}

fn frame_to_world(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return v.x * f.t + v.y * f.b + v.z * f.n;
}

// Cosine-weighted direction on the hemisphere about z, in a local frame (Malley's method: a uniform
// disk point, lifted): pdf(w) = cos(theta) / pi.
fn sample_cosine_local(u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}

// The same about n: pdf(w) = cos(theta) / pi, with cos(theta) = dot(w, n).
fn sample_cosine_hemisphere(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    return frame_to_world(frame_from_normal(n), sample_cosine_local(u));
}

// Density of sample_cosine_hemisphere per unit solid angle, given cos(theta) = dot(w, n): cos / pi
// above the surface, 0 below.

fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

// Uniform point on the unit disk, polar mapping: r = sqrt(u1), phi = 2 pi u2; pdf = 1/pi.
fn sample_uniform_disk(u: vec2<f32>) -> vec2<f32> {
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    return vec2<f32>(r * cos(phi), r * sin(phi));
}

// Density of sample_uniform_disk per unit area: 1/pi inside the unit disk, 0 outside.
fn uniform_disk_pdf(p: vec2<f32>) -> f32 {
    return select(0.0, INV_PI, dot(p, p) <= 1.0);
}

// Uniform direction inside the cone of half-angle theta_max around `axis`, given
// one_minus_cos_max = 1 - cos(theta_max) (passed in that form so that tiny cones keep their precision).
// cos(theta) = 1 - u1 * (1 - cos theta_max), phi = 2 pi u2; pdf = 1 / (2 pi (1 - cos theta_max)) per sr.
fn sample_cone(axis: vec3<f32>, one_minus_cos_max: f32, u: vec2<f32>) -> vec3<f32> {
    return frame_to_world(frame_from_normal(axis), sample_cone_local(one_minus_cos_max, u).local);
}

// sample_cone in the frame of the axis (z up), with the angles it drew: for a caller that needs more than
// the direction (the point on a sphere light, lights/sphere.wgsl).
struct ConeSample {
    local: vec3<f32>,
    one_minus_cos: f32,
    sin2: f32, // sin^2 theta
    cos_phi: f32,
    sin_phi: f32,
}

fn sample_cone_local(one_minus_cos_max: f32, u: vec2<f32>) -> ConeSample {
    let one_minus_cos = u.x * one_minus_cos_max;
    let cos_theta = 1.0 - one_minus_cos;
    // sin^2 = 1 - cos^2 = (1 - cos)(1 + cos), written without cancellation for small angles.
    let sin2 = one_minus_cos * (2.0 - one_minus_cos);
    let sin_theta = sqrt(max(0.0, sin2));
    let phi = TWO_PI * u.y;
    let cos_phi = cos(phi);
    let sin_phi = sin(phi);
    return ConeSample(vec3<f32>(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta), one_minus_cos,
                      sin2, cos_phi, sin_phi);
}

// Density of sample_cone per unit solid angle for a direction whose 1 - cos(theta) from the axis is
// `one_minus_cos` (that form for the same reason as above): 1 / (2 pi (1 - cos theta_max)) inside the
// cone, 0 outside.
fn cone_pdf(one_minus_cos: f32, one_minus_cos_max: f32) -> f32 {
    return select(0.0, 1.0 / (TWO_PI * one_minus_cos_max), one_minus_cos <= one_minus_cos_max);
}

// The cone subtended by a sphere of radius r whose centre is at squared distance d2 > r^2:
// sin^2(theta_max) = r^2 / d2 and 1 - cos = sin^2 / (1 + cos), exact even when r << d.
fn sphere_cone_one_minus_cos(r: f32, d2: f32) -> f32 {
    let sin2 = min(1.0, r * r / d2);
    let cos_max = sqrt(max(0.0, 1.0 - sin2));
    return sin2 / (1.0 + cos_max);
}

// Box–Muller: two independent N(0, sigma^2) offsets from two uniforms.
// 1 - u1 lies in (0, 1], so the logarithm is finite. Vulkan bounds log only to an absolute 2^-21 on
// [0.5, 2] (lavapipe's log(1 - 2^-24) is 73% too large), so log of a value just below 1 may come out
// positive: the max keeps the root from being NaN.
fn sample_gaussian2(u: vec2<f32>, sigma: f32) -> vec2<f32> {
    let r = sigma * sqrt(max(0.0, -2.0 * log(1.0 - u.x)));
    let phi = TWO_PI * u.y;
    return vec2<f32>(r * cos(phi), r * sin(phi));
}

// erfc(x) for x >= 0 (Abramowitz & Stegun 7.1.26: |error| <= 1.5e-7, from a rational function of
// t = 1 / (1 + p x) times exp(-x^2), so that it stays accurate in the tail where 1 - erf(x) cancels).
fn erfc_nonneg(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    return poly * exp(-x * x);
}

fn erf_approx(x: f32) -> f32 {
    return sign(x) * (1.0 - erfc_nonneg(abs(x)));
}

// The inverse error function on (-1, 1) (Giles, "Approximating the erfinv function", GPU Computing Gems
// 2011: the single-precision polynomials in w = -ln(1 - x^2), relative error about 1e-7 before rounding).
fn erfinv_approx(x: f32) -> f32 {
    var w = -log(max((1.0 - x) * (1.0 + x), 1e-30));
    var p: f32;
    if w < 5.0 {
        w = w - 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

// One coordinate of the tent filter of radius r, f(x) = max(0, 1 - |x| / r) / r (a triangle of unit
// area), by inverting its CDF: F(x) = (1 + x / r)^2 / 2 on [-r, 0] and 1 - (1 - x / r)^2 / 2 on [0, r], so
// x = r (sqrt(2 u) - 1) for u < 1/2 and r (1 - sqrt(2 - 2 u)) otherwise. Mitsuba 3's tent filter is this
// triangle in x times the same in y (separable), and so is this 2-D sample.
fn sample_tent(u: f32, r: f32) -> f32 {
    if u < 0.5 {
        return r * (sqrt(2.0 * u) - 1.0);
    }
    return r * (1.0 - sqrt(2.0 - 2.0 * u));
}

fn sample_tent2(u: vec2<f32>, r: f32) -> vec2<f32> {
    return vec2<f32>(sample_tent(u.x, r), sample_tent(u.y, r));
}

// The tent's CDF (above): F(x) = (1 + x / r)^2 / 2 on [-r, 0], 1 - (1 - x / r)^2 / 2 on [0, r]. F(-r) = 0
// and F(r) = 1 exactly.
fn tent_cdf(x: f32, r: f32) -> f32 {
    let t = clamp(x / r, -1.0, 1.0);
    return select(1.0 - 0.5 * (1.0 - t) * (1.0 - t), 0.5 * (1.0 + t) * (1.0 + t), t < 0.0);
}

// One coordinate of the tent of radius r cut off to [lo, hi] (-r <= lo < hi <= r) and renormalised: the
// CDF inverted on [F(lo), F(hi)], x = F^-1(F(lo) + u (F(hi) - F(lo))). Uncut (lo = -r, hi = r) it is
// sample_tent(u, r) bit for bit (0 + u * 1 = u).
fn sample_tent_within(u: f32, r: f32, lo: f32, hi: f32) -> f32 {
    let a = tent_cdf(lo, r);
    let b = tent_cdf(hi, r);
    return clamp(sample_tent(a + u * (b - a), r), lo, hi);
}

// One coordinate of a Gaussian of std-dev sigma cut off to [lo, hi] and renormalised, by inverting its
// CDF Phi(x) = (1 + erf(x / (sigma sqrt 2))) / 2 on [Phi(lo), Phi(hi)]: in erf's terms
// x = sigma sqrt(2) erfinv(e(lo) + u (e(hi) - e(lo))), e(x) = erf(x / (sigma sqrt 2)) (erf_approx's
// absolute error 1.5e-7 and erfinv_approx's relative 1e-7 move the density by as little).
fn sample_gaussian_within(u: f32, sigma: f32, lo: f32, hi: f32) -> f32 {
    let s = sigma * SQRT_2;
    let a = erf_approx(lo / s);
    let b = erf_approx(hi / s);
    return clamp(s * erfinv_approx(a + u * (b - a)), lo, hi);
}

// Density of sample_gaussian2 per unit area at offset x: exp(-|x|^2 / (2 sigma^2)) / (2 pi sigma^2).
fn gaussian2_pdf(x: vec2<f32>, sigma: f32) -> f32 {
    let s2 = sigma * sigma;
    return exp(-dot(x, x) / (2.0 * s2)) / (TWO_PI * s2);
}

// The power heuristic (Veach 1997, §9.2.4, exponent 2): the weight of a sample drawn with density `a`
// when another strategy could have drawn it with density `b`, a^2 / (a^2 + b^2); the two weights of one
// direction sum to 1. Written as 1 / (1 + (b/a)^2) so that the huge densities of tiny lights (1e20 and
// more) do not overflow when squared; a = 0 gives 0.
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a == 0.0 {
        return 0.0;
    }
    let r = b / a;
    return 1.0 / (1.0 + r * r);
}

// Uniform point on a triangle, as barycentrics (b0, b1, b2) of its vertices: b0 = 1 - sqrt(u1),
// b1 = u2 sqrt(u1) (Shirley & Chiu's warp of the square). pdf = 1 / area.
fn sample_uniform_triangle(u: vec2<f32>) -> vec3<f32> {
    let su = sqrt(u.x);
    let b0 = 1.0 - su;
    let b1 = u.y * su;
    return vec3<f32>(b0, b1, max(0.0, 1.0 - b0 - b1));
}

// The angle between unit vectors a and b, accurate near 0 and pi (2 asin of half the chord rather than
// acos of the dot product).
fn angle_between(a: vec3<f32>, b: vec3<f32>) -> f32 {
    if dot(a, b) < 0.0 {
        return PI - 2.0 * asin(min(1.0, 0.5 * length(a + b)));
    }
    return 2.0 * asin(min(1.0, 0.5 * length(b - a)));
}

// The solid angle of the spherical triangle with unit vertices a, b, c (Van Oosterom & Strackee 1983):
// tan(omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a); atan2 keeps omega right above pi (a
// negative denominator) up to 2 pi.
fn spherical_triangle_area(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let triple = abs(dot(a, cross(b, c)));
    return 2.0 * atan2(triple, 1.0 + dot(a, b) + dot(b, c) + dot(c, a));
}

// A direction uniform in solid angle over the spherical triangle with unit vertices a, b, c and solid
// angle `area` (> 0): Arvo, "Stratified Sampling of Spherical Triangles", SIGGRAPH 1995. u1 chooses the
// sub-triangle (a, b, c') of area u1 * area, which fixes c' on the arc from a to c; u2 then chooses the
// point on the arc from b to c' by the cosine of its angle from b, linear in u2. pdf = 1 / area.
// Its f32 precision degrades as the triangle shrinks (1 - c'.b cancels): lights/triangles.wgsl samples triangles
// below TRIANGLE_SPHERICAL_MIN_SR by area instead.
fn sample_spherical_triangle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, area: f32,
                             u: vec2<f32>) -> vec3<f32> {
    // The angle at vertex a: between the planes through (a, b) and (a, c).
    let alpha = angle_between(normalize(cross(a, b)), normalize(cross(a, c)));
    let area_hat = u.x * area;
    let s = sin(area_hat - alpha);
    let t = cos(area_hat - alpha);
    let cos_alpha = cos(alpha);
    let sin_alpha = sin(alpha);
    let uu = t - cos_alpha;
    let vv = s + sin_alpha * dot(a, b); // dot(a, b): the cosine of the edge (a, b)'s arc length
    let q = clamp(((vv * t - uu * s) * cos_alpha - vv) / ((vv * s + uu * t) * sin_alpha), -1.0, 1.0);
    let c_hat = q * a + sqrt(max(0.0, 1.0 - q * q)) * normalize(c - dot(c, a) * a);
    let z = 1.0 - u.y * (1.0 - dot(c_hat, b));
    let perp = c_hat - dot(c_hat, b) * b;
    let len = length(perp);
    if len == 0.0 {
        return b; // c' = b: the arc has shrunk to b itself
    }
    return normalize(z * b + sqrt(max(0.0, 1.0 - z * z)) * (perp / len));
}
