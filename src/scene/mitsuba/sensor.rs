//! The sensor as vkpath's camera: its frame, field of view and lens from the perspective, thinlens or
//! orthographic sensor, the image size and pixel filter from its film, the samples from its sampler.

use super::args::Args;
use super::context::{ORTHO_TOL, Tr};
use super::objects::{Loc, Obj};
use super::toml_out::{num, vec3};
use super::xml::parse_float;
use crate::scene::SceneError;
use glam::{DMat4, DVec3, DVec4};

/// A film as vkpath's image size and pixel filter (its name, and its width: the Gaussian's sigma or the
/// tent's radius).
struct FilmOut {
    width: i64,
    height: i64,
    filter: (&'static str, Option<f64>),
    sample_border: bool,
}

/// A camera as vkpath keys.
pub(super) struct CameraOut {
    pub(super) lines: Vec<String>,
    pub(super) width: i64,
    pub(super) height: i64,
    pub(super) samples: i64,
    pub(super) seed: i64,
    pub(super) sampler: &'static str,
    pub(super) filter: (&'static str, Option<f64>),
    /// The film's `sample_border` (Mitsuba's default false: samples stay on the image).
    pub(super) sample_border: bool,
    pub(super) film_loc: Loc,
    pub(super) sampler_loc: Loc,
}

impl Tr<'_> {
    /// The sensor as `[camera]` keys, with the image size, samples, seed, sampler and pixel filter of its
    /// film and sampler (Mitsuba's defaults when it has none).
    pub(super) fn sensor(&mut self, obj: &Obj) -> Result<CameraOut, SceneError> {
        let kind = obj.kind.as_str();
        if !matches!(kind, "perspective" | "thinlens" | "orthographic") {
            return Err(obj.loc.error(
                format!("vkpath does not read Mitsuba's sensor \"{kind}\""),
                "Use a perspective, thinlens or orthographic sensor.",
            ));
        }
        let args = Args::new(obj);
        // Film.
        let film = args.object("film", self.ids)?;
        let (width, height, filter, sample_border, film_loc) = match &film {
            Some((f, _)) => {
                let FilmOut {
                    width,
                    height,
                    filter,
                    sample_border,
                } = self.film(f)?;
                (width, height, filter, sample_border, f.loc.clone())
            }
            None => (768, 576, ("gaussian", Some(0.5)), false, obj.loc.clone()),
        };
        // Sampler: Mitsuba's default is `independent` with 4 samples.
        let sampler = args.object("sampler", self.ids)?;
        let (samples, seed, sampler_name, sampler_loc) = match &sampler {
            Some((s, _)) => {
                let (n, seed, name) = self.sampler(s)?;
                (n, seed, name, s.loc.clone())
            }
            None => (4, 0, "independent", obj.loc.clone()),
        };
        let to_world = args.transform("to_world")?;
        let m = to_world.map_or(DMat4::IDENTITY, |(x, _)| x.m);
        let xf_loc = to_world.map_or(&obj.loc, |(_, l)| l);
        let near = args.float("near_clip")?;
        let far = args.float("far_clip")?;
        for (name, clip, clips) in [
            ("near_clip", near, near.is_some_and(|(n, _)| n > 1e-2)),
            ("far_clip", far, far.is_some_and(|(f, _)| f < 1e4)),
        ] {
            if let (Some((v, loc)), true) = (clip, clips) {
                self.warnings.push(loc.warning(format!(
                    "{name} = {v} is not used: vkpath does not clip rays"
                )));
            }
        }
        let _ = args.float("shutter_open")?;
        let _ = args.float("shutter_close")?;

        // The camera frame: Mitsuba's camera looks down its local +z with +y up and +x to the LEFT of
        // the image (its lookat puts up x forward there). So the world forward is M z, up M y, and the
        // image's right, vkpath's forward x up, is -M x. A frame with x = +(y x z) keeps the image
        // unmirrored; the other sign would mirror it, which vkpath's camera cannot.
        let x = m.x_axis.truncate();
        let y = m.y_axis.truncate();
        let z = m.z_axis.truncate();
        let position = m.w_axis.truncate();
        let (lx, ly, lz) = (x.length(), y.length(), z.length());
        let (xn, yn, zn) = (
            x.normalize_or_zero(),
            y.normalize_or_zero(),
            z.normalize_or_zero(),
        );
        let orthogonal = xn != DVec3::ZERO
            && yn != DVec3::ZERO
            && zn != DVec3::ZERO
            && xn.dot(yn).abs() < ORTHO_TOL
            && xn.dot(zn).abs() < ORTHO_TOL
            && yn.dot(zn).abs() < ORTHO_TOL
            && m.row(3).abs_diff_eq(DVec4::W, 1e-9);
        if !orthogonal || !position.is_finite() {
            return Err(xf_loc.error(
                "the camera's to_world is not a rotation and translation (it shears, projects or is degenerate)",
                "Place the camera with <lookat origin=\"...\" target=\"...\" up=\"...\"/>.",
            ));
        }
        if xn.dot(yn.cross(zn)) < 0.0 {
            return Err(xf_loc.error(
                "the camera's to_world mirrors the image (its x axis is not up x forward, e.g. a <scale x=\"-1\"/>)",
                "vkpath's camera cannot mirror the image: remove the mirroring scale.",
            ));
        }
        let mut lines = Vec::new();
        let aspect = width as f64 / height as f64;
        let (pos, look, up) = match to_world.and_then(|(x, _)| x.lookat) {
            Some((o, t, u)) => (o, t, u.unwrap_or(yn)),
            None => (position, position + zn, yn),
        };
        if kind == "orthographic" {
            // Mitsuba's orthographic sensor sees camera-space x in [-1, 1] across the width and y in
            // [-1/aspect, 1/aspect] (square pixels); to_world's scale sizes the view: width 2 |M x|. vkpath
            // gives the width (`extent`) and the height follows the image, so x and y must scale alike.
            if (lx - ly).abs() > ORTHO_TOL * lx.max(ly) {
                return Err(xf_loc.error(
                    format!("the orthographic camera scales x by {lx} and y by {ly}: its pixels would not be square"),
                    "Scale x and y alike; the image's width and height give the aspect ratio.",
                ));
            }
            lines.push("type     = \"orthographic\"".to_string());
            lines.push(format!("position = {}", vec3(pos)));
            lines.push(format!("look_at  = {}", vec3(look)));
            lines.push(format!("up       = {}", vec3(up)));
            lines.push(format!(
                "extent   = {}             # 2 x the to_world scale of camera-space x",
                num(2.0 * lx)
            ));
            let _ = args.float("focus_distance")?;
        } else {
            if (lx - 1.0).abs() > ORTHO_TOL
                || (ly - 1.0).abs() > ORTHO_TOL
                || (lz - 1.0).abs() > ORTHO_TOL
            {
                return Err(xf_loc.error(
                    format!("the perspective camera's to_world scales (axes of length {lx}, {ly}, {lz})"),
                    "Mitsuba refuses scale factors in a perspective camera's transform too: remove the scale.",
                ));
            }
            let fov_x = self.fov(&args, aspect, &obj.loc)?;
            lines.push(format!("position = {}", vec3(pos)));
            lines.push(format!("look_at  = {}", vec3(look)));
            lines.push(format!("up       = {}", vec3(up)));
            lines.push(format!(
                "fov      = {}         # horizontal, degrees",
                num(fov_x)
            ));
            let focus = args.float("focus_distance")?;
            if kind == "thinlens" {
                let Some((radius, _)) = args.float("aperture_radius")? else {
                    return Err(obj.loc.error(
                        "a thinlens sensor needs aperture_radius",
                        "Give <float name=\"aperture_radius\" value=\"...\"/> (the lens radius in scene units).",
                    ));
                };
                let Some((focus, _)) = focus else {
                    return Err(obj.loc.error(
                        "a thinlens sensor needs focus_distance",
                        "Give <float name=\"focus_distance\" value=\"...\"/> (the distance to the plane in focus).",
                    ));
                };
                // Both are in camera space, along its z: the same as vkpath's lens radius and distance
                // along the view axis (the transform has no scale).
                lines.push(format!("aperture = {}", num(radius)));
                lines.push(format!("focus_distance = {}", num(focus)));
            }
        }
        let known: &[&str] = match kind {
            "orthographic" => &[
                "to_world",
                "film",
                "sampler",
                "near_clip",
                "far_clip",
                "shutter_open",
                "shutter_close",
                "focus_distance",
            ],
            "thinlens" => &[
                "to_world",
                "film",
                "sampler",
                "fov",
                "fov_axis",
                "focal_length",
                "near_clip",
                "far_clip",
                "shutter_open",
                "shutter_close",
                "aperture_radius",
                "focus_distance",
            ],
            _ => &[
                "to_world",
                "film",
                "sampler",
                "fov",
                "fov_axis",
                "focal_length",
                "near_clip",
                "far_clip",
                "shutter_open",
                "shutter_close",
                "focus_distance",
            ],
        };
        self.finish(&args, known)?;
        Ok(CameraOut {
            lines,
            width,
            height,
            samples,
            seed,
            sampler: sampler_name,
            filter,
            sample_border,
            film_loc,
            sampler_loc,
        })
    }

    /// Mitsuba's field of view as vkpath's horizontal one, in degrees. With aspect a = width / height and
    /// t = tan(fov / 2) the half-extent of the image plane at distance 1 along the given axis:
    /// x: fov_x = fov; y: the half-width is a t, fov_x = 2 atan(a t); diagonal: the half-diagonal is t and
    /// the half-width w satisfies w^2 + (w / a)^2 = t^2, w = t / sqrt(1 + 1/a^2), fov_x = 2 atan(w);
    /// smaller / larger: y or x, whichever is the smaller / larger side. Without fov, Mitsuba's
    /// focal_length (35 mm film equivalent, default "50mm") is a diagonal fov of 2 atan(43.27 / (2 f)),
    /// 43.27 mm = sqrt(36^2 + 24^2) being the film's diagonal.
    fn fov(&mut self, args: &Args, aspect: f64, loc: &Loc) -> Result<f64, SceneError> {
        let fov = args.float("fov")?;
        let axis = args.string("fov_axis")?;
        let focal = args.string("focal_length")?;
        let (fov, axis, fov_loc) = match (fov, focal) {
            (Some(_), Some((_, l))) => {
                return Err(l.error(
                    "both fov and focal_length are given",
                    "Give one of them (Mitsuba refuses both too).",
                ));
            }
            (Some((f, l)), None) => {
                let axis = axis.map_or("x".to_string(), |(a, _)| a.to_ascii_lowercase());
                let axis = match axis.as_str() {
                    "smaller" if aspect > 1.0 => "y".to_string(),
                    "smaller" => "x".to_string(),
                    "larger" if aspect > 1.0 => "x".to_string(),
                    "larger" => "y".to_string(),
                    _ => axis,
                };
                (f, axis, l)
            }
            (None, focal) => {
                if let Some((_, l)) = axis {
                    return Err(l.error(
                        "fov_axis is given without fov",
                        "Give <float name=\"fov\" .../> with it.",
                    ));
                }
                let (text, l) = focal.unwrap_or(("50mm", loc));
                let f = parse_float(text.trim().trim_end_matches("mm"))
                    .filter(|f| *f > 0.0)
                    .ok_or_else(|| {
                        l.error(
                            format!("focal_length \"{text}\" is not a length in mm"),
                            "Write it as \"50mm\", or give fov in degrees instead.",
                        )
                    })?;
                let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
                (
                    (diagonal / (2.0 * f)).atan().to_degrees() * 2.0,
                    "diagonal".into(),
                    l,
                )
            }
        };
        let t = (fov.to_radians() / 2.0).tan();
        let fov_x = match axis.as_str() {
            "x" => fov,
            "y" => 2.0 * (aspect * t).atan().to_degrees(),
            "diagonal" => {
                2.0 * (t / (1.0 + 1.0 / (aspect * aspect)).sqrt())
                    .atan()
                    .to_degrees()
            }
            other => {
                return Err(fov_loc.error(
                    format!("fov_axis \"{other}\" is not x, y, diagonal, smaller or larger"),
                    "Give one of those.",
                ));
            }
        };
        if !(fov > 0.0 && fov < 180.0 && fov_x > 0.0 && fov_x < 180.0) {
            return Err(fov_loc.error(
                format!("the field of view {fov} degrees is not in (0, 180)"),
                "Give a field of view between 0 and 180 degrees.",
            ));
        }
        Ok(fov_x)
    }

    /// The film: its size and pixel filter.
    fn film(&mut self, obj: &Obj) -> Result<FilmOut, SceneError> {
        if obj.kind != "hdrfilm" {
            return Err(obj.loc.error(
                format!("vkpath does not read Mitsuba's film \"{}\"", obj.kind),
                "Use <film type=\"hdrfilm\">.",
            ));
        }
        let args = Args::new(obj);
        let width = args.int("width")?.map_or(768, |(w, _)| w);
        let height = args.int("height")?.map_or(576, |(h, _)| h);
        // Output formats: vkpath's output follows -o.
        for name in ["file_format", "pixel_format", "component_format"] {
            let _ = args.string(name)?;
        }
        // sample_border (default false): whether samples are also drawn beyond the image's edges, so that
        // an edge pixel's filter is whole; without, its filter is cut off at the edge (vkpath's
        // render.sample_border says the same).
        let mut sample_border = args.boolean("sample_border")?.is_some_and(|(b, _)| b);
        // Mitsuba 0.5/0.6's film parameters, read in files written for them (Mitsuba 3 refuses them):
        // high_quality_edges is Mitsuba 3's sample_border; attach_log stored the render log in the EXR;
        // banner drew Mitsuba's logo into the image, which vkpath does not (a warning when asked for).
        if obj.legacy {
            sample_border |= args.boolean("high_quality_edges")?.is_some_and(|(b, _)| b);
            let _ = args.boolean("attach_log")?;
            if let Some((true, loc)) = args.boolean("banner")? {
                self.warnings.push(loc.warning(
                    "banner = true: vkpath does not draw Mitsuba 0.5's logo into the image; rendered without it",
                ));
            }
        }
        let rfilter = args.object("rfilter", self.ids)?;
        let filter = match rfilter {
            None => ("gaussian", Some(0.5)),
            Some((f, _)) => {
                let fargs = Args::new(&f);
                let out = match f.kind.as_str() {
                    // Mitsuba's box: radius 0.5 pixel, each sample counts in its own pixel only.
                    "box" => ("box", None),
                    // Mitsuba truncates its Gaussian at 4 standard deviations, vkpath does not: the
                    // difference is the weight beyond 4 sigma, 3e-4 of it.
                    "gaussian" => ("gaussian", Some(fargs.float_or("stddev", 0.5)?)),
                    // Mitsuba's tent: 1 - |x| / radius in x times the same in y, radius 1 pixel by
                    // default; vkpath's is the same separable tent.
                    "tent" => ("tent", Some(fargs.float_or("radius", 1.0)?)),
                    other => {
                        return Err(f.loc.error(
                            format!(
                                "vkpath does not read Mitsuba's reconstruction filter \"{other}\""
                            ),
                            "Use <rfilter type=\"box\"/>, <rfilter type=\"tent\"> (radius) or \
                             <rfilter type=\"gaussian\"> (stddev).",
                        ));
                    }
                };
                let known: &[&str] = match out.0 {
                    "box" => &[],
                    "tent" => &["radius"],
                    _ => &["stddev"],
                };
                self.finish(&fargs, known)?;
                out
            }
        };
        self.finish(
            &args,
            &[
                "width",
                "height",
                "rfilter",
                "file_format",
                "pixel_format",
                "component_format",
                "sample_border",
                // Mitsuba 0.x files only:
                "banner",
                "high_quality_edges",
                "attach_log",
            ][..if obj.legacy { 10 } else { 7 }],
        )?;
        Ok(FilmOut {
            width,
            height,
            filter,
            sample_border,
        })
    }

    /// The sampler: (samples per pixel, seed, vkpath sampler). vkpath's "sobol" stands for Mitsuba's
    /// stratified kinds: the same image in expectation, different noise.
    fn sampler(&mut self, obj: &Obj) -> Result<(i64, i64, &'static str), SceneError> {
        let name = match obj.kind.as_str() {
            "independent" => "independent",
            "stratified" | "multijitter" | "orthogonal" | "ldsampler" => "sobol",
            other => {
                return Err(obj.loc.error(
                    format!("vkpath does not read Mitsuba's sampler \"{other}\""),
                    "Use independent, stratified, multijitter, orthogonal or ldsampler.",
                ));
            }
        };
        let args = Args::new(obj);
        let count = args.int("sample_count")?.map_or(4, |(n, _)| n);
        let seed = args.int("seed")?.map_or(0, |(s, _)| s);
        let _ = args.boolean("jitter")?;
        let known: &[&str] = if name == "independent" {
            &["sample_count", "seed"]
        } else {
            &["sample_count", "seed", "jitter"]
        };
        self.finish(&args, known)?;
        Ok((count, seed, name))
    }
}
