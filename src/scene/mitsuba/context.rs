//! The translator ([`Tr`]): its state (the ids, the warnings, the folders, the materials written so far,
//! the TOML being written) and the rules every plugin's translation follows: a parameter no one read, a
//! plugin vkpath does not read and an approximation Mitsuba would not make are errors, or with `lenient`
//! warnings; file paths are resolved as Mitsuba's and written relative to where the TOML is read from.
//! The plugins' translations are `impl Tr` blocks of their own files (translate.rs, sensor.rs,
//! emitters.rs, shapes.rs, materials.rs, colors.rs).

use super::args::{Args, resolve_ref};
use super::objects::{Loc, Obj, SEE_DOCS, Value, listed};
use super::toml_out::TomlOut;
use super::xml::resolve;
use crate::scene::SceneError;
use crate::scene::toml_text::{absolute, relative_to, toml_string};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// How far from orthogonal (or from equal lengths) a transform's axes may be, relative to their length.
pub(super) const ORTHO_TOL: f64 = 1e-3;

/// The translator of a scene's objects into TOML.
pub(super) struct Tr<'p> {
    pub(super) ids: &'p HashMap<String, Rc<Obj>>,
    /// The file's parameters (`<default>`s and -D), by name, with the values they have: what a
    /// message can point at when a value came from one.
    pub(super) parameters: Vec<(String, String)>,
    /// Emitters (and shapes that emit) skipped by a lenient reading.
    pub(super) skipped_lights: usize,
    pub(super) lenient: bool,
    pub(super) warnings: Vec<String>,
    /// Where files are found after beside the file naming them (`Parser::search_dirs`).
    pub(super) search_dirs: Vec<PathBuf>,
    pub(super) refer_dir: PathBuf,
    /// Material name by (BSDF object, emitted radiance): shapes that share both share the material; and
    /// the element of a bitmap it reads, if it reads one (only meshes have the uvs to read it at).
    pub(super) materials: HashMap<(usize, [u64; 3]), (String, Option<Loc>)>,
    pub(super) material_names: Vec<String>,
    pub(super) out_materials: TomlOut,
    pub(super) out_shapes: TomlOut,
    pub(super) out_lights: TomlOut,
    pub(super) environment: Option<Loc>,
    /// The BSDFs being translated, outermost first (their addresses), to refuse a BSDF that holds
    /// itself through `<ref>`s instead of recursing until the stack overflows.
    pub(super) bsdf_stack: Vec<usize>,
    /// The BSDFs and textures translated so far (their addresses): a definition at the top level that no
    /// shape used is translated once more at the end, so that what it says is checked as Mitsuba checks
    /// it (an unknown plugin or parameter is refused even where nothing refers to it).
    pub(super) translated: std::collections::HashSet<usize>,
    /// The meshes of shapegroups written so far (their addresses), by the name of the `[[mesh]]` that
    /// places them first: the group's later instances write `[[instance]]`s of it.
    pub(super) shared_meshes: HashMap<usize, String>,
}

impl<'p> Tr<'p> {
    /// A translator of the objects `ids` names (and of those they hold), its warnings so far `warnings`
    /// (the reader's); files are found as Mitsuba's resolver finds them (beside the naming file, else in
    /// `search_dirs`: the `<path>` folders, then the main file's) and written relative to `refer_dir`.
    pub(super) fn new(
        ids: &'p HashMap<String, Rc<Obj>>,
        lenient: bool,
        warnings: Vec<String>,
        search_dirs: Vec<PathBuf>,
        refer_dir: PathBuf,
    ) -> Tr<'p> {
        Tr {
            ids,
            parameters: Vec::new(),
            skipped_lights: 0,
            lenient,
            warnings,
            search_dirs,
            refer_dir,
            materials: HashMap::new(),
            material_names: Vec::new(),
            out_materials: TomlOut::default(),
            out_shapes: TomlOut::default(),
            out_lights: TomlOut::default(),
            environment: None,
            bsdf_stack: Vec::new(),
            translated: Default::default(),
            shared_meshes: HashMap::new(),
        }
    }

    /// Checks every `<ref>` in the scene resolves (also those a plugin never reads).
    pub(super) fn check_refs(&self, obj: &Obj) -> Result<(), SceneError> {
        for p in &obj.props {
            match &p.value {
                Value::Ref(id) => {
                    resolve_ref(self.ids, id, &p.loc)?;
                }
                Value::Object(o) => self.check_refs(o)?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Parameters no one read: errors (or warnings with `lenient`) that name each, and what is read.
    pub(super) fn finish(&mut self, args: &Args, known: &[&str]) -> Result<(), SceneError> {
        for p in args.unread() {
            let what = if p.name.is_empty() {
                format!("the nested {}", p.loc.element)
            } else {
                format!("the parameter \"{}\"", p.name)
            };
            let problem = format!(
                "{what} is not one that vkpath reads for {} (it reads {})",
                args.obj.loc.element,
                listed(known)
            );
            if self.lenient {
                self.warnings
                    .push(p.loc.warning(format!("{problem}; ignored (--xml-lenient)")));
            } else {
                return Err(p.loc.error(
                    problem,
                    &format!("{SEE_DOCS} Or give --xml-lenient to skip it with a warning."),
                ));
            }
        }
        Ok(())
    }

    /// A plugin vkpath does not read: an error, or with `lenient` a warning (the caller skips it).
    pub(super) fn unsupported(&mut self, obj: &Obj, reads: &str) -> Result<(), SceneError> {
        let problem = format!(
            "vkpath does not read Mitsuba's {} plugin \"{}\" (it reads {reads})",
            obj.tag, obj.kind
        );
        if self.lenient {
            self.warnings.push(
                obj.loc
                    .warning(format!("{problem}; skipped (--xml-lenient)")),
            );
            let emits = |o: &Obj| {
                o.tag == "emitter"
                    || o.props
                        .iter()
                        .any(|p| matches!(&p.value, Value::Object(e) if e.tag == "emitter"))
            };
            if emits(obj) {
                self.skipped_lights += 1;
            }
            Ok(())
        } else {
            Err(obj.loc.error(
                problem,
                &format!("{SEE_DOCS} Or give --xml-lenient to skip it with a warning."),
            ))
        }
    }

    /// An approximation Mitsuba would not make: refused, or with `lenient` a warning.
    pub(super) fn approximate(
        &mut self,
        loc: &Loc,
        problem: String,
        hint: &str,
    ) -> Result<(), SceneError> {
        if self.lenient {
            self.warnings
                .push(loc.warning(format!("{problem}; read approximately (--xml-lenient)")));
            Ok(())
        } else {
            Err(loc.error(
                problem,
                &format!("{hint} Or give --xml-lenient to read it approximately, with a warning."),
            ))
        }
    }

    /// A file path as the TOML gives it: relative to the folder the TOML is read from when it can be.
    pub(super) fn refer(&self, p: &Path) -> String {
        let rel = relative_to(p, &self.refer_dir).unwrap_or_else(|| p.to_path_buf());
        toml_string(&rel.to_string_lossy())
    }

    pub(super) fn file(&self, name: &str, loc: &Loc) -> PathBuf {
        resolve(name, &loc.file, &self.search_dirs).unwrap_or_else(|| {
            let p = Path::new(name);
            if p.is_absolute() {
                p.to_path_buf()
            } else {
                absolute(
                    &absolute(&loc.file)
                        .parent()
                        .unwrap_or(Path::new(""))
                        .join(p),
                )
            }
        })
    }
}
