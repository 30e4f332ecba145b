// camera.wgsl: primary rays. A pinhole or thin-lens camera with a horizontal field of view, and an
// orthographic camera (parallel rays).
//
// requires: (nothing)

const CAMERA_PERSPECTIVE: u32 = 0u;
const CAMERA_ORTHOGRAPHIC: u32 = 1u;

struct CameraRay {
    o: vec3<f32>,
    d: vec3<f32>,
}

// A film position (in pixels) on a plane spanning [-half_width, half_width] across the image width,
// with square pixels: x to the right, y up.
fn film_to_plane(half_width: f32, width: u32, height: u32, film: vec2<f32>) -> vec2<f32> {
    let half_w = 0.5 * f32(width);
    let half_h = 0.5 * f32(height);
    return vec2<f32>((film.x - half_w) / half_w * half_width, (half_h - film.y) / half_w * half_width);
}

// `film` is a position on the image in pixels, (0,0) the top-left corner, x right, y down; the pixel
// (i, j) covers [i, i+1) x [j, j+1). The image plane at distance 1 spans [-tan(fov/2), tan(fov/2)]
// across the width; pixels are square. `lens` is a uniform sample of the unit disk.
//
// Thin lens: every ray through the lens point o + aperture*(lens.x right + lens.y up) passes through the
// point the pinhole ray meets on the plane in focus (distance focus_distance along `forward`), so that
// plane is sharp and the rest blurs with a circle of confusion proportional to the aperture.
fn camera_ray(position: vec3<f32>, right: vec3<f32>, up: vec3<f32>, forward: vec3<f32>,
              tan_half_fov: f32, width: u32, height: u32, film: vec2<f32>,
              lens_radius: f32, focus_distance: f32, lens: vec2<f32>) -> CameraRay {
    let s = film_to_plane(tan_half_fov, width, height, film);
    let dir = normalize(forward + s.x * right + s.y * up);
    if lens_radius <= 0.0 {
        return CameraRay(position, dir);
    }
    // dot(dir, forward) > 0 always (fov < 180), so the focus point position + k dir, k = focus_distance
    // / dot(dir, forward), is in front of the camera. The direction from the lens point position + a to
    // it is k dir - a; it is computed divided by k, as dir - a / k, which has the same direction but no
    // longer overflows when the focus distance is huge (1e30 gave |k dir|^2 = inf and a zero direction;
    // the limit is the focus at infinity, where every lens point sees along dir).
    let offset = lens_radius * (lens.x * right + lens.y * up);
    let origin = position + offset;
    return CameraRay(origin, normalize(dir - offset * (dot(dir, forward) / focus_distance)));
}

// Orthographic: every ray goes along `forward`, from the point of the film plane through `position`
// that the film position maps to. The film spans [-half_width, half_width] across the image width (in
// scene units) with square pixels, mapped exactly as the perspective image plane above.
fn orthographic_ray(position: vec3<f32>, right: vec3<f32>, up: vec3<f32>, forward: vec3<f32>,
                    half_width: f32, width: u32, height: u32, film: vec2<f32>) -> CameraRay {
    let s = film_to_plane(half_width, width, height, film);
    return CameraRay(position + s.x * right + s.y * up, forward);
}
