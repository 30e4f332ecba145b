//! `[[light]]` and `[environment]`: the lights, and the light from infinitely far.

use super::Checker;
use super::error::SceneError;
use super::raw::{RawLight, RawScene};
use crate::scene::Light;
use crate::scene::SpotFalloff;
use crate::scene::environment::{self, Environment};
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;
use toml::Spanned;

impl Checker<'_> {
    pub(super) fn light(&self, i: usize, raw: &Spanned<RawLight>) -> Result<Light, SceneError> {
        let l = raw.get_ref();
        let key = |field: &str| format!("light[{i}].{field}");
        let kind = l.kind.get_ref().as_str();
        // Point and sphere lights are given by their power; a sun by its irradiance.
        let power = || -> Result<f32, SceneError> {
            let power = self.required(
                &l.power,
                raw,
                &key("power"),
                &format!("a {kind} light needs a power"),
            )?;
            self.number_unless(
                power,
                &key("power"),
                |p| p <= 0.0,
                "a light's power must be > 0",
                "power is the light's total emitted flux in watts; remove the light rather than giving it no power.",
            )
        };
        let color = l.color.as_ref().map_or(Ok(Vec3::ONE), |c| {
            self.vec3_unless(
                c,
                &key("color"),
                |c| c.min_element() < 0.0,
                "light color components cannot be negative",
                "color multiplies power per channel; use components >= 0 ([1, 1, 1] is white).",
            )
        })?;
        let (allowed, light): (&[&str], _) = match kind {
            "point" => {
                let power = power()?;
                let position = self.required(
                    &l.position,
                    raw,
                    &key("position"),
                    "a point light needs a position",
                )?;
                let position = self.vec3(position, &key("position"))?;
                (
                    &["position", "power"],
                    Light::Point {
                        position,
                        power,
                        color,
                    },
                )
            }
            "sphere" => {
                let power = power()?;
                let center = self.required(
                    &l.center,
                    raw,
                    &key("center"),
                    "a sphere light needs a center",
                )?;
                let center = self.vec3(center, &key("center"))?;
                let radius = self.required(
                    &l.radius,
                    raw,
                    &key("radius"),
                    "a sphere light needs a radius",
                )?;
                let radius_span = radius.span();
                let radius = self.positive_radius(radius, &key("radius"), "sphere light")?;
                // The shader works with the light's radiance P / (4 pi^2 r^2) in f32: a radius so small
                // that it overflows (r below ~1e-18) cannot be rendered as a sphere.
                let radiance =
                    power as f64 / (4.0 * std::f64::consts::PI.powi(2) * (radius as f64).powi(2));
                if radiance > f32::MAX as f64 / 16.0
                    || (radius as f64).powi(2) < f32::MIN_POSITIVE as f64
                {
                    return Err(self.error(
                        radius_span,
                        &key("radius"),
                        format!(
                            "a sphere light of radius {radius} and power {power} W has a radiance of {radiance:e}, \
                             beyond what 32-bit floats hold"
                        ),
                        "Use a point light for a source this small (it is the same light as the radius goes to 0).",
                    ));
                }
                (
                    &["center", "radius", "power"],
                    Light::Sphere {
                        center,
                        radius,
                        power,
                        color,
                    },
                )
            }
            "directional" => (
                &["direction", "irradiance", "angle"],
                self.directional_light(raw, &key, color)?,
            ),
            "spot" => (
                &[
                    "position",
                    "look_at",
                    "power",
                    "intensity",
                    "cutoff_angle",
                    "beam_width",
                    "falloff",
                ],
                self.spot_light(raw, &key, color)?,
            ),
            other => {
                return Err(self.error(
                    l.kind.span(),
                    &key("type"),
                    format!("unknown light type \"{other}\""),
                    "Use \"point\" (with position), \"sphere\" (with center and radius), \"directional\" \
                     (with direction and irradiance) or \"spot\" (with position, look_at and power or \
                     intensity).",
                ));
            }
        };
        let present = [
            ("position", l.position.as_ref().map(Spanned::span)),
            ("center", l.center.as_ref().map(Spanned::span)),
            ("radius", l.radius.as_ref().map(Spanned::span)),
            ("power", l.power.as_ref().map(Spanned::span)),
            ("direction", l.direction.as_ref().map(Spanned::span)),
            ("irradiance", l.irradiance.as_ref().map(Spanned::span)),
            ("angle", l.angle.as_ref().map(Spanned::span)),
            ("look_at", l.look_at.as_ref().map(Spanned::span)),
            ("intensity", l.intensity.as_ref().map(Spanned::span)),
            ("cutoff_angle", l.cutoff_angle.as_ref().map(Spanned::span)),
            ("beam_width", l.beam_width.as_ref().map(Spanned::span)),
            ("falloff", l.falloff.as_ref().map(Spanned::span)),
        ];
        self.reject_foreign_keys(
            &present,
            allowed,
            &format!("light[{i}]"),
            &format!("a {kind} light"),
        )?;
        Ok(light)
    }

    /// `type = "directional"`: a sun (see [`Light::Directional`]).
    fn directional_light(
        &self,
        raw: &Spanned<RawLight>,
        key: &dyn Fn(&str) -> String,
        color: Vec3,
    ) -> Result<Light, SceneError> {
        let l = raw.get_ref();
        let direction = self.required(
            &l.direction,
            raw,
            &key("direction"),
            "a directional light needs a direction",
        )?;
        let d = self.vec3(direction, &key("direction"))?;
        let length = d.as_dvec3().length();
        if !(length > 0.0 && length.is_finite() && (d.as_dvec3() / length).as_vec3().is_finite()) {
            return Err(self.error(
                direction.span(),
                &key("direction"),
                format!("the direction [{}, {}, {}] has no length", d.x, d.y, d.z),
                "Give the direction the light travels in, e.g. [0, -1, 0] for light from straight above.",
            ));
        }
        let irradiance = self.required(
            &l.irradiance,
            raw,
            &key("irradiance"),
            "a directional light needs an irradiance",
        )?;
        let irradiance = self.number_unless(
            irradiance,
            &key("irradiance"),
            |e| e <= 0.0,
            "a directional light's irradiance must be > 0",
            "irradiance is in W/m^2 on a surface facing the light (the sun gives about 1000).",
        )?;
        let angle_deg = match &l.angle {
            None => 0.0,
            Some(a) => self.number_unless(
                a,
                &key("angle"),
                |a| !(0.0..180.0).contains(&a),
                "the angular diameter must be in [0, 180) degrees",
                "Use 0 for a delta light (sharp shadows) or the source's angular diameter (the sun: 0.53).",
            )?,
        };
        Ok(Light::Directional {
            direction: (d.as_dvec3() / length).as_vec3(),
            irradiance,
            color,
            angle_deg,
        })
    }

    /// `type = "spot"` (see [`Light::Spot`]): its cone from `position` towards `look_at`, half-angles
    /// `cutoff_angle` in (0, 90] and `beam_width` in (0, cutoff] (default 3/4 of the cutoff, Mitsuba's),
    /// and either its `power` (W into the cone: the on-axis intensity is power / the falloff's solid
    /// angle, `scene::spot_cone_solid_angle`) or its on-axis `intensity` (W/sr).
    fn spot_light(
        &self,
        raw: &Spanned<RawLight>,
        key: &dyn Fn(&str) -> String,
        color: Vec3,
    ) -> Result<Light, SceneError> {
        let l = raw.get_ref();
        let position = self.required(
            &l.position,
            raw,
            &key("position"),
            "a spot light needs a position",
        )?;
        let position = self.vec3(position, &key("position"))?;
        let look_at = self.required(
            &l.look_at,
            raw,
            &key("look_at"),
            "a spot light needs a look_at",
        )?;
        let target = self.vec3(look_at, &key("look_at"))?;
        let axis = (target - position).as_dvec3();
        let length = axis.length();
        if !(length > 0.0 && length.is_finite()) {
            return Err(self.error(
                look_at.span(),
                &key("look_at"),
                "look_at is the spot light's own position (or too far to subtract)",
                "Give the point the spot light aims at, away from its position.",
            ));
        }
        let cutoff_deg = match &l.cutoff_angle {
            None => 20.0,
            Some(c) => self.number_unless(
                c,
                &key("cutoff_angle"),
                |c| !(c > 0.0 && c <= 90.0),
                "the cutoff angle must be in (0, 90] degrees",
                "cutoff_angle is the half-angle of the cone, in degrees, where the light ends.",
            )?,
        };
        let falloff = match &l.falloff {
            None => SpotFalloff::Linear,
            Some(f) => match f.get_ref().as_str() {
                "linear" => SpotFalloff::Linear,
                "smooth" => SpotFalloff::Smooth,
                other => {
                    return Err(self.error(
                        f.span(),
                        &key("falloff"),
                        format!("unknown falloff \"{other}\""),
                        "Use \"linear\" (in the angle, Mitsuba's spot; the default) or \"smooth\" (glTF's: the \
                         square of a ramp in the cosine).",
                    ));
                }
            },
        };
        // The smooth falloff is defined with no beam at all (glTF's innerConeAngle 0).
        let smooth = falloff == SpotFalloff::Smooth;
        let beam_deg = match &l.beam_width {
            None => 0.75 * cutoff_deg,
            Some(b) => self.number_unless(
                b,
                &key("beam_width"),
                |b| !((b > 0.0 || (smooth && b == 0.0)) && b <= cutoff_deg),
                "the beam width must be in (0, cutoff_angle] degrees ([0, cutoff_angle] with the smooth falloff)",
                "beam_width is the half-angle of full intensity, in degrees, at most cutoff_angle (default 3/4 of it).",
            )?,
        };
        let intensity = match (&l.power, &l.intensity) {
            (Some(_), Some(i)) => {
                return Err(self.error(
                    i.span(),
                    &key("intensity"),
                    "a spot light has both power and intensity",
                    "Give one: power (W emitted into the cone) or intensity (W/sr on the axis).",
                ));
            }
            (None, None) => {
                return Err(self.error(
                    raw.span(),
                    &key("power"),
                    "a spot light needs a power or an intensity",
                    "Give power (W emitted into the cone) or intensity (W/sr on the axis).",
                ));
            }
            (Some(p), None) => {
                let power = self.number_unless(
                    p,
                    &key("power"),
                    |p| p <= 0.0,
                    "a light's power must be > 0",
                    "power is the light's total emitted flux in watts; remove the light rather than giving it no power.",
                )?;
                let omega = crate::scene::spot_cone_solid_angle(
                    f64::from(cutoff_deg),
                    f64::from(beam_deg),
                    falloff,
                );
                (f64::from(power) / omega) as f32
            }
            (None, Some(i)) => self.number_unless(
                i,
                &key("intensity"),
                |i| i <= 0.0,
                "a spot light's intensity must be > 0",
                "intensity is in W/sr along the spot's axis.",
            )?,
        };
        Ok(Light::Spot {
            position,
            axis: (axis / length).as_vec3(),
            intensity,
            color,
            cutoff_deg,
            beam_deg,
            falloff,
        })
    }

    /// `[environment]`, or the uniform `render.background` it replaces (giving both is an error: which
    /// one is meant?).
    pub(super) fn environment(
        &self,
        raw: &RawScene,
        background: Vec3,
        base: &Path,
        cache: &mut super::FileCache,
    ) -> Result<Environment, SceneError> {
        let Some(env) = &raw.environment else {
            return Ok(Environment {
                radiance: background,
                ..Default::default()
            });
        };
        let background_key = raw.render.as_ref().and_then(|r| r.background.as_ref());
        if let Some(b) = background_key {
            return Err(self.error(
                b.span(),
                "render.background",
                "the scene has both render.background and an [environment] table",
                "[environment] replaces render.background: give its uniform radiance as environment.radiance.",
            ));
        }
        let e = env.get_ref();
        let map = match &e.map {
            None => None,
            Some(m) => {
                let path = base.join(m.get_ref());
                // Read once per cache (an edited scene read again does not read its map again).
                let map = match cache.environments.get(&path) {
                    Some(map) => map.clone(),
                    None => {
                        let loaded = environment::load_map(&path).map_err(|problem| {
                            self.error(
                                m.span(),
                                "environment.map",
                                problem,
                                "The path is relative to the scene file; the map must be an equirectangular \
                                 .exr or .hdr image of linear radiance.",
                            )
                        })?;
                        let loaded = Arc::new(loaded);
                        cache.environments.insert(path, loaded.clone());
                        loaded
                    }
                };
                Some(map)
            }
        };
        let default = if map.is_some() { Vec3::ONE } else { Vec3::ZERO };
        let radiance = e.radiance.as_ref().map_or(Ok(default), |r| {
            self.vec3_unless(
                r,
                "environment.radiance",
                |r| r.min_element() < 0.0,
                "environment radiance cannot be negative",
                "Give a linear RGB radiance (W sr^-1 m^-2) with components >= 0; with a map it multiplies the map.",
            )
        })?;
        let rotate_deg = e
            .rotate
            .as_ref()
            .map_or(Ok(0.0), |r| self.number(r, "environment.rotate"))?;
        Ok(Environment {
            radiance,
            map,
            rotate_deg,
        })
    }
}
