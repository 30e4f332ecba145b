//! Emitters directly in the scene: point and directional lights (`[[light]]`), and the constant or
//! envmap environment (`[environment]`). Area emitters belong to their shapes (super::shapes).

use super::args::Args;
use super::context::Tr;
use super::objects::Obj;
use super::toml_out::{TomlOut, num, vec3};
use crate::scene::SceneError;
use glam::{DMat3, DMat4, DVec3};

impl Tr<'_> {
    /// An emitter directly in the scene: a light, or the environment.
    pub(super) fn emitter(&mut self, obj: &Obj, env: &mut TomlOut) -> Result<(), SceneError> {
        let args = Args::new(obj);
        let loc = Some(&obj.loc);
        match obj.kind.as_str() {
            "point" => {
                // Mitsuba's intensity I is W/sr; vkpath's point light has I = power x color / (4 pi):
                // power = 4 pi max(I), color = I / max(I).
                let intensity = self.emitted(&args, "intensity")?;
                let position = self.position(&args, "position")?;
                self.finish(&args, &["intensity", "position", "to_world"])?;
                let (power, color) = power_and_color(4.0 * std::f64::consts::PI, intensity);
                let o = &mut self.out_lights;
                o.line("", None);
                o.line("[[light]]", loc);
                o.line("type     = \"point\"", loc);
                o.line(format!("position = {}", vec3(position)), loc);
                o.line(
                    format!("power    = {}         # 4 pi x intensity", num(power)),
                    loc,
                );
                o.line(format!("color    = {}", vec3(color)), loc);
            }
            "spot" => {
                // Mitsuba's spot emits along its to_world's local +z from its origin: intensity I
                // (W/sr) on the axis, full out to beam_width, linear in the angle to 0 at cutoff_angle
                // (degrees; defaults 20 and 3/4 of the cutoff): vkpath's spot light, the same falloff.
                let intensity = self.emitted(&args, "intensity")?;
                let (position, target) = match args.transform("to_world")? {
                    Some((x, _)) => (
                        x.m.transform_point3(DVec3::ZERO),
                        x.m.transform_point3(DVec3::Z),
                    ),
                    None => (DVec3::ZERO, DVec3::Z),
                };
                let cutoff = args.float_or("cutoff_angle", 20.0)?;
                let beam = args.float_or("beam_width", 0.75 * cutoff)?;
                self.finish(
                    &args,
                    &["intensity", "to_world", "cutoff_angle", "beam_width"],
                )?;
                let (i, color) = power_and_color(1.0, intensity);
                let o = &mut self.out_lights;
                o.line("", None);
                o.line("[[light]]", loc);
                o.line("type         = \"spot\"", loc);
                o.line(format!("position     = {}", vec3(position)), loc);
                o.line(format!("look_at      = {}", vec3(target)), loc);
                o.line(format!("intensity    = {}", num(i)), loc);
                o.line(format!("cutoff_angle = {}", num(cutoff)), loc);
                o.line(format!("beam_width   = {}", num(beam)), loc);
                o.line(format!("color        = {}", vec3(color)), loc);
            }
            "directional" => {
                let irradiance = self.emitted(&args, "irradiance")?;
                let direction = match (args.vector("direction")?, args.transform("to_world")?) {
                    (Some(_), Some((_, l))) => {
                        return Err(
                            l.error("both direction and to_world are given", "Give one of them.")
                        );
                    }
                    (Some((d, _)), None) => d,
                    // The light travels along the transform's local +z.
                    (None, Some((x, _))) => x.m.transform_vector3(DVec3::Z),
                    (None, None) => DVec3::Z,
                };
                self.finish(&args, &["irradiance", "direction", "to_world"])?;
                let (e, color) = power_and_color(1.0, irradiance);
                let o = &mut self.out_lights;
                o.line("", None);
                o.line("[[light]]", loc);
                o.line("type       = \"directional\"", loc);
                o.line(format!("direction  = {}", vec3(direction)), loc);
                o.line(format!("irradiance = {}", num(e)), loc);
                o.line(format!("color      = {}", vec3(color)), loc);
            }
            "constant" | "envmap" => {
                if let Some(prev) = &self.environment {
                    return Err(obj.loc.error(
                        format!(
                            "a second environment emitter (the first is at line {} of {})",
                            prev.line,
                            prev.file.display()
                        ),
                        "vkpath has one environment: keep one constant or envmap emitter.",
                    ));
                }
                self.environment = Some(obj.loc.clone());
                env.line("[environment]", loc);
                if obj.kind == "constant" {
                    let radiance = self.emitted(&args, "radiance")?;
                    self.finish(&args, &["radiance"])?;
                    env.line(format!("radiance = {}", vec3(radiance)), loc);
                } else {
                    let Some((name, floc)) = args.string("filename")? else {
                        return Err(obj.loc.error(
                            "an envmap needs a filename",
                            "Give <string name=\"filename\" value=\"sky.exr\"/>.",
                        ));
                    };
                    let file = self.file(name, floc);
                    let scale = args.float_or("scale", 1.0)?;
                    if !(scale >= 0.0 && scale.is_finite()) {
                        let loc = args.prop("scale").map_or(&obj.loc, |p| &p.loc);
                        return Err(loc.error(
                            format!("the envmap's scale {scale} is negative or not finite"),
                            "Give a scale of 0 or more.",
                        ));
                    }
                    let rotate = match args.transform("to_world")? {
                        None => 0.0,
                        Some((x, l)) => y_rotation(&x.m).ok_or_else(|| {
                            l.error(
                                "the envmap's to_world is not a rotation about +y",
                                "vkpath rotates an environment map about +y only (`rotate`): use <rotate y=\"1\" angle=\"...\"/>.",
                            )
                        })?,
                    };
                    let _ = args.string("filter_type")?;
                    self.finish(&args, &["filename", "scale", "to_world", "filter_type"])?;
                    env.line(format!("map      = {}", self.refer(&file)), Some(floc));
                    env.line(format!("radiance = {}", vec3(DVec3::splat(scale))), loc);
                    env.line(format!("rotate   = {}", num(rotate)), loc);
                }
            }
            "area" => {
                return Err(obj.loc.error(
                    "an area emitter directly in the scene: it belongs inside the <shape> that emits",
                    "Put <emitter type=\"area\"> inside a <shape>.",
                ));
            }
            _ => {
                self.unsupported(
                    obj,
                    "point, spot, directional, constant, envmap and area (inside a shape)",
                )?;
            }
        }
        Ok(())
    }

    /// A point's position: the parameter `name`, or the origin of `to_world` (not both).
    fn position(&mut self, args: &Args, name: &str) -> Result<DVec3, SceneError> {
        match (args.vector(name)?, args.transform("to_world")?) {
            (Some(_), Some((_, l))) => Err(l.error(
                format!("both {name} and to_world are given"),
                "Give one of them.",
            )),
            (Some((p, _)), None) => Ok(p),
            (None, Some((x, _))) => Ok(x.m.transform_point3(DVec3::ZERO)),
            (None, None) => Ok(DVec3::ZERO),
        }
    }
}

impl Tr<'_> {
    /// An emitted quantity (radiance, intensity, irradiance; default 1): a colour with no negative or
    /// non-finite channel. Mitsuba would add negative light; vkpath refuses it rather than render a light
    /// that takes energy away (or, clamped, a black one in silence).
    pub(super) fn emitted(&mut self, args: &Args, name: &str) -> Result<DVec3, SceneError> {
        let c = self.color(args, name, DVec3::ONE)?;
        if c.is_finite() && c.min_element() >= 0.0 {
            return Ok(c);
        }
        let loc = args.prop(name).map(|p| &p.loc);
        Err(loc.unwrap_or(&args.obj.loc).error(
            format!(
                "{name} ({}, {}, {}) is negative or not finite: a light cannot emit less than nothing",
                c.x, c.y, c.z
            ),
            "Give values of 0 or more (0 for a light that is off).",
        ))
    }
}

/// (power or irradiance, colour) for a radiometric quantity `q` given per channel: `unit x max(q)` and
/// `q / max(q)` (colour [1, 1, 1] for a grey; [0, 0, 0] with power `unit` for black).
fn power_and_color(unit: f64, q: DVec3) -> (f64, DVec3) {
    let m = q.max_element();
    if m > 0.0 {
        (unit * m, q / m)
    } else {
        (unit, q.max(DVec3::ZERO))
    }
}

/// The angle in degrees of a rotation about +y (right-handed: R(a) takes +z to (sin a, 0, cos a)), or
/// None when the transform's 3 x 3 part is not one (a translation does not matter: the environment is
/// infinitely far).
fn y_rotation(m: &DMat4) -> Option<f64> {
    let r = DMat3::from_mat4(*m);
    let a = r.z_axis.x.atan2(r.z_axis.z);
    let expected = DMat3::from_rotation_y(a);
    r.abs_diff_eq(expected, 1e-4)
        .then(|| a.to_degrees())
        .filter(|a| a.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_rotation_reads_the_angle() {
        let a = y_rotation(&DMat4::from_rotation_y(90f64.to_radians())).unwrap();
        assert!((a - 90.0).abs() < 1e-9);
        assert!(y_rotation(&DMat4::from_rotation_x(0.3)).is_none());
    }
}
