//! The preview's pure logic, kept apart from the window so that it can be unit-tested: orbiting the
//! camera around `look_at`, and the `--script` steps that drive a window in tests.

use crate::scene::Camera;
use glam::Vec3;

/// Degrees of orbit per pixel of mouse drag.
pub const DEGREES_PER_PIXEL: f32 = 0.3;

/// The closest the orbit lets the camera come to the `up` axis through `look_at`, in degrees: at the
/// pole the camera's right vector (forward x up) would vanish.
const POLE_MARGIN_DEG: f32 = 1.0;

/// The camera moved on the sphere around `look_at` through its position: `azimuth` degrees about the
/// camera's `up` axis, `elevation` degrees towards `up` (stopping short of the poles). The distance to
/// `look_at`, `up`, the field of view and the lens stay as they are.
pub fn orbit(camera: &Camera, azimuth_deg: f32, elevation_deg: f32) -> Camera {
    let up = camera.up.normalize();
    let offset = camera.position - camera.look_at;
    let r = offset.length();
    let dir = offset / r;
    let polar = dir.dot(up).clamp(-1.0, 1.0).acos();
    // A horizontal reference direction: the offset's own, or any perpendicular to up at a pole.
    let horizontal = dir - up * dir.dot(up);
    let e1 = if horizontal.length() > 1e-6 {
        horizontal.normalize()
    } else {
        up.any_orthonormal_vector()
    };
    let e2 = up.cross(e1);
    let margin = POLE_MARGIN_DEG.to_radians();
    let polar = (polar - elevation_deg.to_radians()).clamp(margin, std::f32::consts::PI - margin);
    let phi = azimuth_deg.to_radians();
    let new_dir: Vec3 = up * polar.cos() + (e1 * phi.cos() + e2 * phi.sin()) * polar.sin();
    Camera {
        position: camera.look_at + new_dir * r,
        ..*camera
    }
}

/// One scripted action (`--script`), as a user could do it with the keys and the mouse.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Ask the window system for a new inner size (pixels).
    Resize(u32, u32),
    /// R: restart the accumulation.
    Restart,
    /// A mouse drag: orbit by (azimuth, elevation) degrees.
    Orbit(f32, f32),
    /// S: save the current image.
    Save,
    /// D: show the denoised image, or the raw one again.
    Denoise,
}

/// An action to take once the window has presented `at` images.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub at: u64,
    pub action: Action,
}

/// Parses `--script`: steps separated by `;`, each `N:ACTION` with ACTION one of `resize WxH`,
/// `restart`, `orbit AZ EL` (degrees), `save` or `denoise`, run right after present number N (1-based).
pub fn parse_script(text: &str) -> Result<Vec<Step>, String> {
    let mut steps = Vec::new();
    for part in text.split(';').map(str::trim).filter(|p| !p.is_empty()) {
        let bad = |why: &str| {
            format!(
                "--script step \"{part}\" {why}; a step is N:ACTION with N a present number and ACTION \
                 one of `resize WxH`, `restart`, `orbit AZ EL` (degrees), `save`, `denoise`, steps separated \
                 by `;`."
            )
        };
        let (n, action) = part.split_once(':').ok_or_else(|| bad("has no \"N:\""))?;
        let at: u64 = n
            .trim()
            .parse()
            .map_err(|_| bad("does not start with a present number"))?;
        let words: Vec<&str> = action.split_whitespace().collect();
        let action = match words.as_slice() {
            ["restart"] => Action::Restart,
            ["save"] => Action::Save,
            ["denoise"] => Action::Denoise,
            ["resize", size] => {
                let (w, h) = size
                    .split_once(['x', 'X'])
                    .ok_or_else(|| bad("has a size that is not WxH"))?;
                let w: u32 = w.parse().map_err(|_| bad("has a bad width"))?;
                let h: u32 = h.parse().map_err(|_| bad("has a bad height"))?;
                if w == 0 || h == 0 || w > 16384 || h > 16384 {
                    return Err(bad("has a size outside 1..=16384"));
                }
                Action::Resize(w, h)
            }
            ["orbit", az, el] => {
                let az: f32 = az.parse().map_err(|_| bad("has a bad azimuth"))?;
                let el: f32 = el.parse().map_err(|_| bad("has a bad elevation"))?;
                if !(az.is_finite() && el.is_finite()) {
                    return Err(bad("has a non-finite angle"));
                }
                Action::Orbit(az, el)
            }
            _ => return Err(bad("has an unknown action")),
        };
        steps.push(Step { at, action });
    }
    steps.sort_by_key(|s| s.at);
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            position: Vec3::new(0.0, 1.0, 5.0),
            look_at: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            projection: crate::scene::Projection::Perspective,
            fov_deg: 40.0,
            extent: 0.0,
            aperture: 0.0,
            focus_distance: 5.0,
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-4
    }

    #[test]
    fn orbit_keeps_the_distance_and_turns_about_up() {
        let c = camera();
        assert!(close(orbit(&c, 0.0, 0.0).position, c.position));
        // A quarter turn about +Y takes +Z to +X (right-handed, counter-clockwise seen from above).
        let q = orbit(&c, 90.0, 0.0);
        assert!(
            close(q.position, Vec3::new(5.0, 1.0, 0.0)),
            "{:?}",
            q.position
        );
        assert!(close(orbit(&c, 360.0, 0.0).position, c.position));
        // 30 degrees up: height r sin 30 above look_at, horizontal distance r cos 30.
        let e = orbit(&c, 0.0, 30.0);
        assert!(close(
            e.position,
            Vec3::new(0.0, 1.0 + 2.5, 5.0 * 30f32.to_radians().cos())
        ));
        for (az, el) in [(17.0, 5.0), (-200.0, -40.0), (3.0, 89.0)] {
            let o = orbit(&c, az, el);
            assert!(((o.position - o.look_at).length() - 5.0).abs() < 1e-4);
            assert_eq!((o.look_at, o.up, o.fov_deg), (c.look_at, c.up, c.fov_deg));
        }
    }

    #[test]
    fn orbit_stops_short_of_the_poles() {
        let top = orbit(&camera(), 0.0, 500.0);
        let polar = (top.position - top.look_at).normalize().dot(Vec3::Y).acos();
        assert!(
            (polar.to_degrees() - POLE_MARGIN_DEG).abs() < 1e-3,
            "{polar}"
        );
        let bottom = orbit(&camera(), 0.0, -500.0);
        let polar = (bottom.position - bottom.look_at)
            .normalize()
            .dot(Vec3::Y)
            .acos();
        assert!((polar.to_degrees() - (180.0 - POLE_MARGIN_DEG)).abs() < 1e-3);
        // From the margin, dragging on works: the horizontal direction is kept.
        let back = orbit(&top, 0.0, -89.0);
        assert!(
            close(back.position, camera().position),
            "{:?}",
            back.position
        );
    }

    #[test]
    fn script_parses_and_refuses() {
        let s = parse_script("4: restart; 2:resize 300x200 ;6:orbit 30 -10; 7:save").unwrap();
        assert_eq!(
            s,
            vec![
                Step {
                    at: 2,
                    action: Action::Resize(300, 200)
                },
                Step {
                    at: 4,
                    action: Action::Restart
                },
                Step {
                    at: 6,
                    action: Action::Orbit(30.0, -10.0)
                },
                Step {
                    at: 7,
                    action: Action::Save
                },
            ]
        );
        assert_eq!(parse_script(" ; ").unwrap(), vec![]);
        for bad in [
            "restart",
            "x:restart",
            "1:jump",
            "1:resize 0x5",
            "1:resize 3",
            "1:orbit 1",
            "1:orbit nan 0",
        ] {
            let e = parse_script(bad).unwrap_err();
            assert!(e.contains("--script step"), "{bad}: {e}");
        }
    }
}
