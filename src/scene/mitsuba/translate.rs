//! The `<scene>` as TOML: its objects sorted by kind, the `[camera]`, `[image]` and `[render]` tables of
//! the chosen sensor and the integrator, then the emitters and the shapes (which write the materials).

use super::args::{Args, resolve_ref};
use super::context::Tr;
use super::objects::{Loc, Obj, SEE_DOCS, Value};
use super::toml_out::{TomlOut, num};
use crate::scene::SceneError;
use std::path::Path;

impl Tr<'_> {
    /// The TOML of the `<scene>` (its `<ref>`s checked first): the camera, image and render tables and the
    /// environment, then the materials, the shapes and the lights.
    pub(super) fn toml(
        &mut self,
        scene: &Obj,
        path: &Path,
        camera: Option<usize>,
    ) -> Result<TomlOut, SceneError> {
        self.check_refs(scene)?;
        let mut head = self.scene(scene, path, camera)?;
        head.append(std::mem::take(&mut self.out_materials));
        head.append(std::mem::take(&mut self.out_shapes));
        head.append(std::mem::take(&mut self.out_lights));
        Ok(head)
    }

    /// The `<scene>`'s objects sorted by kind (a `<bsdf>` or `<texture>` there is a definition to refer
    /// to), and the head of the TOML: `[camera]` from sensor `camera` (the first when `None`), `[image]`,
    /// `[render]` and the environment. The emitters and the shapes write their own tables.
    fn scene(
        &mut self,
        scene: &Obj,
        path: &Path,
        camera: Option<usize>,
    ) -> Result<TomlOut, SceneError> {
        let mut sensors = Vec::new();
        let mut integrators = Vec::new();
        let mut shapes = Vec::new();
        let mut emitters = Vec::new();
        let mut definitions = Vec::new();
        for p in &scene.props {
            let obj = match &p.value {
                Value::Object(o) => o.clone(),
                Value::Ref(id) => resolve_ref(self.ids, id, &p.loc)?,
                _ => {
                    let problem = format!(
                        "{} directly in the <scene>: the scene takes objects only",
                        p.loc.element
                    );
                    if self.lenient {
                        self.warnings
                            .push(p.loc.warning(format!("{problem}; skipped (--xml-lenient)")));
                        continue;
                    }
                    return Err(p.loc.error(problem, SEE_DOCS));
                }
            };
            match obj.tag.as_str() {
                "sensor" => sensors.push(obj),
                "integrator" => integrators.push(obj),
                "shape" => shapes.push(obj),
                // An area emitter declared with an id at the top level (Mitsuba's own cbox-rgb.xml) is a
                // definition, as a BSDF there is: it emits through the shapes that refer to it by
                // `<ref id>` (shapes.rs reads it there), and is not an emitter of its own.
                "emitter"
                    if obj.kind == "area"
                        && matches!(p.value, Value::Object(_))
                        && self.ids.values().any(|o| std::rc::Rc::ptr_eq(o, &obj)) => {}
                "emitter" => emitters.push(obj),
                // Definitions that shapes refer to by id (checked at the end if none does).
                "bsdf" | "texture" => definitions.push(obj),
                _ => {
                    let problem = format!(
                        "{} directly in the <scene>: vkpath reads sensors, integrators, shapes, emitters, and BSDFs and textures for reference there",
                        obj.loc.element
                    );
                    if self.lenient {
                        self.warnings.push(
                            obj.loc
                                .warning(format!("{problem}; skipped (--xml-lenient)")),
                        );
                        continue;
                    }
                    return Err(obj.loc.error(problem, SEE_DOCS));
                }
            }
        }

        // The sensor.
        let index = camera.unwrap_or(0);
        let Some(sensor) = sensors.get(index) else {
            return Err(if sensors.is_empty() {
                scene.loc.error(
                    "the scene has no <sensor> to render it from",
                    "Add a camera: <sensor type=\"perspective\"> with a <transform name=\"to_world\"><lookat .../></transform>.",
                )
            } else {
                SceneError::at(
                    path,
                    None,
                    Some("--camera".into()),
                    format!(
                        "--camera {index} asks for sensor {index}, but the scene has {} (0 to {})",
                        sensors.len(),
                        sensors.len() - 1
                    ),
                    "Give a sensor index the file has, or leave --camera out for the first.",
                )
            });
        };
        let cam = self.sensor(sensor)?;

        let mut head = TomlOut::default();
        head.line(
            format!(
                "# Read from {} by vkpath (Mitsuba 3 XML): see docs/scene-format.md, \"Mitsuba 3 XML scenes\".",
                path.file_name()
                    .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
            ),
            None,
        );
        head.line("", None);
        head.line("[camera]", Some(&sensor.loc));
        for l in &cam.lines {
            head.line(l, Some(&sensor.loc));
        }
        head.line("", None);
        head.line("[image]", Some(&cam.film_loc));
        head.line(format!("width  = {}", cam.width), Some(&cam.film_loc));
        head.line(format!("height = {}", cam.height), Some(&cam.film_loc));
        head.line(
            "gamma  = \"srgb\"                 # Mitsuba writes 8-bit images sRGB-encoded",
            Some(&cam.film_loc),
        );

        // The integrator: Mitsuba's default is `path` with max_depth = -1.
        if integrators.len() > 1 {
            return Err(integrators[1]
                .loc
                .error("the scene has more than one <integrator>", "Keep one."));
        }
        let (max_bounces, comment, integrator_loc) = match integrators.first() {
            Some(i) => {
                let (b, c) = self.integrator(i)?;
                (b, c, Some(i.loc.clone()))
            }
            None => (
                -1,
                "no <integrator>: Mitsuba's default path tracer, max_depth = -1 (no limit)"
                    .to_string(),
                None,
            ),
        };
        head.line("", None);
        head.line("[render]", None);
        head.line(
            format!("samples      = {}", cam.samples),
            Some(&cam.sampler_loc),
        );
        head.line(
            format!("max_bounces  = {max_bounces}     # {comment}"),
            integrator_loc.as_ref(),
        );
        head.line(
            format!("seed         = {}", cam.seed),
            Some(&cam.sampler_loc),
        );
        head.line(
            format!("sampler      = \"{}\"", cam.sampler),
            Some(&cam.sampler_loc),
        );
        head.line(
            format!("filter       = \"{}\"", cam.filter.0),
            Some(&cam.film_loc),
        );
        if let Some(s) = cam.filter.1 {
            let key = if cam.filter.0 == "tent" {
                "filter_radius"
            } else {
                "filter_sigma"
            };
            head.line(format!("{key} = {}", num(s)), Some(&cam.film_loc));
        }
        head.line(
            format!("sample_border = {}", cam.sample_border),
            Some(&cam.film_loc),
        );

        // Emitters (lights and the environment), then shapes (which write the materials).
        let mut env = TomlOut::default();
        for e in &emitters {
            self.emitter(e, &mut env)?;
        }
        if !env.text.is_empty() {
            head.line("", None);
            head.append(env);
        }
        let mut written = 0;
        for s in &shapes {
            written += self.top_level_shape(s, written)?;
        }
        // Mitsuba instantiates every object of the scene, used or not, and refuses one it does not
        // know or whose parameters it does not read: so does vkpath, translating each definition no
        // shape used (what it writes is dropped; only its errors and warnings count).
        for d in &definitions {
            if self.translated.contains(&(std::rc::Rc::as_ptr(d) as usize)) {
                continue;
            }
            if d.tag == "bsdf" {
                self.check_bsdf(d)?;
            } else {
                self.texture(d)?;
            }
        }
        if !self.out_materials.text.is_empty() {
            let mut m = TomlOut::default();
            m.line("", None);
            m.line("[materials]", None);
            m.append(std::mem::take(&mut self.out_materials));
            self.out_materials = m;
        }
        Ok(head)
    }

    fn integrator(&mut self, obj: &Obj) -> Result<(i64, String), SceneError> {
        if obj.kind == "direct" {
            return self.direct_integrator(obj);
        }
        if SAME_IMAGE.contains(&obj.kind.as_str()) {
            return self.other_algorithm(obj);
        }
        if obj.kind != "path" {
            let problem = format!(
                "vkpath is a path tracer: it does not read Mitsuba's integrator \"{}\"",
                obj.kind
            );
            // A custom plugin picked by a <default> (as Bitterli's scenes do): -D overrides it.
            let hint = match self.parameters.iter().find(|(_, v)| *v == obj.kind) {
                Some((name, _)) => format!(
                    "The file's parameter ${name} picks it: give -D {name}=path to render the scene with \
                     the path tracer, as Mitsuba's own command line would."
                ),
                None => "Use <integrator type=\"path\"> (max_depth 2 is direct lighting).".into(),
            };
            return Err(obj.loc.error(problem, &hint));
        }
        let args = Args::new(obj);
        let depth = args.int("max_depth")?;
        let rr = args.int("rr_depth")?;
        refuse_hidden_emitters(&args)?;
        self.finish(&args, &["max_depth", "rr_depth", "hide_emitters"])?;
        if let Some((r, loc)) = rr
            && r != 3
        {
            self.warnings.push(loc.warning(format!(
                "rr_depth = {r} is not used: vkpath starts Russian roulette after --roulette-depth bounces \
                 (default 3); both are unbiased, only the noise differs"
            )));
        }
        max_bounces(depth)
    }

    /// An integrator of [`SAME_IMAGE`]: another algorithm for the image the path tracer computes, read
    /// as the path tracer with its `max_depth` and a note; its own parameters (photon counts, mutation
    /// settings, radii) change the noise, not the image, and are read past.
    fn other_algorithm(&mut self, obj: &Obj) -> Result<(i64, String), SceneError> {
        let args = Args::new(obj);
        refuse_hidden_emitters(&args)?;
        let depth = args.int("max_depth")?;
        let skipped: Vec<&str> = args
            .unread()
            .map(|p| p.name.as_str())
            .filter(|n| !n.is_empty())
            .collect();
        let biased = matches!(obj.kind.as_str(), "sppm" | "ppm" | "photonmapper");
        self.warnings.push(format!(
            "{}{}",
            crate::scene::NOTE,
            obj.loc.warning(format!(
                "Mitsuba's {} integrator computes the path tracer's image by another algorithm: vkpath \
                 renders it with its path tracer (the same max_depth); only the noise differs{}{}",
                obj.kind,
                if biased {
                    " (and the photon map's blur, which vanishes as Mitsuba's radius shrinks)"
                } else {
                    ""
                },
                if skipped.is_empty() {
                    String::new()
                } else {
                    format!("; its {} read past", skipped.join(", "))
                }
            ))
        ));
        max_bounces(depth)
    }

    /// Mitsuba's `direct` integrator: the emitters seen directly plus direct illumination, by emitter
    /// and BSDF samples weighted by multiple importance sampling. Its expectation is the path tracer's
    /// at max_depth 2 (one scattering event, the light sampled and the BSDF sampled towards emitters,
    /// MIS-weighted), which is what vkpath renders (max_bounces 1). Its sample counts per shading point
    /// (emitter_samples, bsdf_samples, shading_samples) change only the noise: read past with a warning.
    fn direct_integrator(&mut self, obj: &Obj) -> Result<(i64, String), SceneError> {
        let args = Args::new(obj);
        refuse_hidden_emitters(&args)?;
        for name in ["emitter_samples", "bsdf_samples", "shading_samples"] {
            if let Some((n, loc)) = args.int(name)?
                && n != 1
            {
                self.warnings.push(loc.warning(format!(
                    "{name} = {n} is not used: vkpath takes one light and one BSDF sample per path \
                     (the same image in expectation; raise the samples per pixel instead)"
                )));
            }
        }
        self.finish(
            &args,
            &[
                "hide_emitters",
                "emitter_samples",
                "bsdf_samples",
                "shading_samples",
            ],
        )?;
        Ok((
            1,
            "Mitsuba's direct integrator: path tracing with max_depth 2".into(),
        ))
    }
}

/// Mitsuba's integrators that estimate the image the path tracer does by other algorithms (Mitsuba 0.6
/// files name them often): read as the path tracer, with a note.
const SAME_IMAGE: &[&str] = &[
    "bdpt",
    "pssmlt",
    "mlt",
    "erpt",
    "ptracer",
    "sppm",
    "ppm",
    "photonmapper",
];

/// vkpath's bounce limit for Mitsuba's `max_depth` (absent: -1, no limit), with a comment.
fn max_bounces(depth: Option<(i64, &Loc)>) -> Result<(i64, String), SceneError> {
    // Mitsuba's max_depth counts path segments (1: emitters seen directly, 2: direct light), vkpath's
    // max_bounces scattering events (0: emitters only, 1: direct light): max_bounces = max_depth - 1.
    match depth {
        None | Some((-1, _)) => Ok((-1, "Mitsuba max_depth = -1 (no limit)".into())),
        Some((d, _)) if d >= 1 && d - 1 < i64::from(u32::MAX) => {
            Ok((d - 1, format!("Mitsuba max_depth = {d}")))
        }
        Some((d, loc)) => Err(loc.error(
            format!("max_depth = {d}: vkpath needs -1 (no limit) or a depth of at least 1"),
            "max_depth counts path segments: 1 shows the emitters only, 2 is direct light.",
        )),
    }
}

/// An integrator's `hide_emitters = true`: refused (vkpath always shows the emitters the camera sees).
fn refuse_hidden_emitters(args: &Args) -> Result<(), SceneError> {
    match args.boolean("hide_emitters")? {
        Some((true, loc)) => Err(loc.error(
            "hide_emitters = true: vkpath always shows the emitters the camera sees",
            "Remove hide_emitters (or set it to false).",
        )),
        _ => Ok(()),
    }
}
