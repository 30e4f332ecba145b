//! Mitsuba 3 XML scenes, read as vkpath scenes (`vkpath render scene.xml`).
//!
//! As for glTF (super::import), the XML becomes the vkpath TOML text that says what vkpath understood
//! of it, and that text is read by the TOML reader, so every check and default is the TOML reader's and
//! `vkpath convert scene.xml -o scene.toml` writes the same text. Each line of the TOML remembers the XML
//! element it came from, so that an error the TOML reader finds (an albedo above 1, an unreadable mesh)
//! is reported at the XML file, line and element, not at a line of text the user never saw.
//!
//! Two stages:
//!
//! 1. [`Parser`] reads the XML (roxmltree) into a tree of [`Obj`]ects and their named properties, with
//!    Mitsuba 3's rules for the file format: `<default>` and `$name` substitution in attribute values,
//!    `<include>`, `id` and `<ref>`, nested `<transform>` operations (each one left-multiplies the
//!    transform so far), the value tags. Anything it does not know is an error (or, with `lenient`, a
//!    warning and the element skipped).
//! 2. [`Tr`] translates the objects into TOML: one sensor, its film and sampler, the integrator, the
//!    emitters and the shapes with their BSDFs. Each plugin reads its parameters through [`Args`], which
//!    remembers which ones were used: a parameter no one read is an error that names it (Mitsuba 3 does
//!    the same: "unreferenced property"), so nothing in the file is silently ignored.
//!
//! docs/scene-format.md, "Mitsuba 3 XML scenes", lists every element, its mapping and what is refused.
//! The maths of each conversion (camera frame, field of view, transforms, the disk) is next to its code.

use super::toml_text::{self, absolute, relative_to, toml_string};
use super::{Scene, SceneError};
use glam::{DMat3, DMat4, DVec3, DVec4};
use std::cell::Cell;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// vkpath's `max_bounces` for Mitsuba's `max_depth = -1` (no limit, Mitsuba's default): a path is ended
/// by Russian roulette long before (vkpath's survival probability is at most 0.95 per bounce after the
/// roulette depth, so 1024 bounces are reached with probability below 0.95^1000 ~ 5e-23).
pub const INFINITE_DEPTH_BOUNCES: u32 = 1024;

/// Segments of the polygon that stands for Mitsuba's `disk` (see [`disk_triangles`]).
pub const DISK_SEGMENTS: usize = 64;

/// Mitsuba 3's limit on nested `<include>`s.
const INCLUDE_DEPTH_LIMIT: usize = 15;

const SEE_DOCS: &str =
    "See docs/scene-format.md, \"Mitsuba 3 XML scenes\", for the elements vkpath reads and how.";

/// How to read an XML scene.
#[derive(Clone, Debug, Default)]
pub struct XmlOptions {
    /// The sensor to render from (0-based, in file order); the first when `None`.
    pub camera: Option<usize>,
    /// Skip unknown elements, plugins and parameters with a warning each, instead of refusing the file.
    pub lenient: bool,
    /// Write file paths relative to this directory (absolute); the XML file's own directory when `None`
    /// (the TOML is then read as if it sat beside the XML).
    pub paths_relative_to: Option<PathBuf>,
}

/// What an XML scene becomes: the TOML text, what the reader noticed, and where each TOML line came from.
pub struct Translated {
    pub toml: String,
    pub warnings: Vec<String>,
    origins: Vec<Option<Loc>>,
}

impl Translated {
    /// An error of the TOML reader on this text, placed at the XML element its line came from.
    fn relocate(&self, e: SceneError) -> SceneError {
        let origin = e
            .line()
            .and_then(|l| self.origins.get(l.wrapping_sub(1)))
            .and_then(Option::as_ref);
        match origin {
            Some(loc) => {
                let key = match e.key() {
                    Some(k) => format!("{} (read as vkpath's {k})", loc.element),
                    None => loc.element.clone(),
                };
                e.relocated(loc.file.display().to_string(), Some(loc.line), Some(key))
            }
            None => e,
        }
    }
}

/// Whether a scene file is read as Mitsuba 3 XML (its extension is `.xml`, any case).
pub fn is_xml(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Reads the XML scene at `path` and loads the vkpath scene it becomes.
pub fn load(path: &Path, options: &XmlOptions) -> Result<Scene, SceneError> {
    let t = xml_scene(path, options)?;
    let mut scene = Scene::from_toml_str(&t.toml, Some(path)).map_err(|e| t.relocate(e))?;
    let mut warnings = t.warnings;
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    Ok(scene)
}

/// The vkpath TOML for the XML scene at `path` (see the module comment).
pub fn xml_scene(path: &Path, options: &XmlOptions) -> Result<Translated, SceneError> {
    let main = absolute(path);
    let main_dir = main.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut parser = Parser {
        lenient: options.lenient,
        warnings: Vec::new(),
        params: Vec::new(),
        ids: HashMap::new(),
        chain: Vec::new(),
        main_dir: main_dir.clone(),
    };
    let scene = parser.main_file(path)?;
    let mut tr = Tr {
        ids: &parser.ids,
        lenient: options.lenient,
        warnings: std::mem::take(&mut parser.warnings),
        main_dir,
        refer_dir: options
            .paths_relative_to
            .as_deref()
            .map(absolute)
            .unwrap_or_else(|| main.parent().map(Path::to_path_buf).unwrap_or_default()),
        materials: HashMap::new(),
        material_names: Vec::new(),
        out_materials: TomlOut::default(),
        out_shapes: TomlOut::default(),
        out_lights: TomlOut::default(),
        environment: None,
    };
    tr.check_refs(&scene)?;
    let mut head = tr.scene(&scene, path, options.camera)?;
    head.append(std::mem::take(&mut tr.out_materials));
    head.append(std::mem::take(&mut tr.out_shapes));
    head.append(std::mem::take(&mut tr.out_lights));
    Ok(Translated {
        toml: head.text,
        warnings: tr.warnings,
        origins: head.origins,
    })
}

// ---------------------------------------------------------------------------------------------------
// The XML as objects and properties
// ---------------------------------------------------------------------------------------------------

/// Where an element is: its file, its 1-based line, and the element as written (`<float name="radius">`),
/// which errors give as their key.
#[derive(Clone, Debug)]
struct Loc {
    file: Rc<PathBuf>,
    line: usize,
    element: String,
}

impl Loc {
    fn error(&self, problem: impl Into<String>, hint: &str) -> SceneError {
        SceneError::at(
            &self.file,
            Some(self.line),
            Some(self.element.clone()),
            problem,
            hint,
        )
    }

    /// `file, line N, <element>: ` before a warning.
    fn warning(&self, what: impl std::fmt::Display) -> String {
        format!(
            "{}, line {}, {}: {what}",
            self.file.display(),
            self.line,
            self.element
        )
    }
}

/// A transform, and the lookat it is when it is exactly one `<lookat>` (the camera is then written with
/// that origin, target and up, as a user would write it).
#[derive(Clone, Debug)]
struct Xf {
    m: DMat4,
    lookat: Option<(DVec3, DVec3, Option<DVec3>)>,
}

#[derive(Clone, Debug)]
enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    Str(String),
    /// `<point>` or `<vector>`.
    Vector(DVec3),
    Rgb(DVec3),
    /// A uniform `<spectrum value="x">`.
    Spectrum(f64),
    Transform(Xf),
    Object(Rc<Obj>),
    /// `<ref id="...">`, resolved when used (Mitsuba allows references to objects defined later).
    Ref(String),
}

impl Value {
    fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "<float>",
            Value::Integer(_) => "<integer>",
            Value::Boolean(_) => "<boolean>",
            Value::Str(_) => "<string>",
            Value::Vector(_) => "<point> or <vector>",
            Value::Rgb(_) => "<rgb>",
            Value::Spectrum(_) => "<spectrum>",
            Value::Transform(_) => "<transform>",
            Value::Object(_) => "a nested object",
            Value::Ref(_) => "<ref>",
        }
    }
}

/// A property of an object: its `name` ("" for an unnamed nested object or reference).
#[derive(Clone, Debug)]
struct Prop {
    name: String,
    value: Value,
    loc: Loc,
}

/// A Mitsuba object: `<bsdf type="diffuse" id="...">` with its properties (`tag` "bsdf", `kind` "diffuse").
#[derive(Debug)]
struct Obj {
    tag: String,
    kind: String,
    loc: Loc,
    props: Vec<Prop>,
}

/// The element tags that are objects (plugins).
const OBJECT_TAGS: &[&str] = &[
    "bsdf",
    "shape",
    "emitter",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

struct Parser {
    lenient: bool,
    warnings: Vec<String>,
    /// `<default>`s seen so far, first definition wins (as Mitsuba's).
    params: Vec<(String, String)>,
    ids: HashMap<String, Rc<Obj>>,
    /// The files being read, outermost first (canonical paths), to find include cycles.
    chain: Vec<PathBuf>,
    main_dir: PathBuf,
}

/// The file being read.
struct Src<'a, 'input> {
    file: Rc<PathBuf>,
    doc: &'a roxmltree::Document<'input>,
    /// Version below 2.0.0: camelCase parameter names are read as snake_case (Mitsuba 3's upgrade).
    upgrade: bool,
}

/// An element's attributes after `$name` substitution, in file order.
struct Attrs(Vec<(String, String)>);

impl Attrs {
    fn get(&self, name: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

fn parse_xml<'i>(path: &Path, text: &'i str) -> Result<roxmltree::Document<'i>, SceneError> {
    roxmltree::Document::parse(text).map_err(|e| {
        SceneError::at(
            path,
            Some(e.pos().row as usize),
            None,
            format!("the file is not well-formed XML: {e}"),
            "Mitsuba 3 scenes are XML files; fix the syntax at that line.",
        )
    })
}

/// Mitsuba's version string: three numbers separated by dots (or spaces).
fn parse_version(v: &str) -> Option<(u32, u32, u32)> {
    let parts: Vec<&str> = v
        .split(|c: char| c == '.' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .collect();
    match parts[..] {
        [a, b, c] => Some((a.parse().ok()?, b.parse().ok()?, c.parse().ok()?)),
        _ => None,
    }
}

/// Mitsuba 0.x's camelCase names as Mitsuba 3 reads them: `toWorld` -> `to_world`, `intIOR` -> `int_ior`.
fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::new();
    let mut i = 0;
    while i < chars.len() {
        out.push(chars[i]);
        if chars[i].is_ascii_lowercase() && chars.get(i + 1).is_some_and(char::is_ascii_uppercase) {
            out.push('_');
            i += 1;
            while let Some(c) = chars.get(i).filter(|c| c.is_ascii_uppercase()) {
                out.push(c.to_ascii_lowercase());
                i += 1;
            }
            continue;
        }
        i += 1;
    }
    out
}

impl Parser {
    fn loc(&self, src: &Src, node: roxmltree::Node, element: String) -> Loc {
        Loc {
            file: src.file.clone(),
            line: src.doc.text_pos_at(node.range().start).row as usize,
            element,
        }
    }

    /// The element as a key: its tag with its `type`, `name` and `id` (those it has).
    fn describe(node: roxmltree::Node) -> String {
        let mut s = format!("<{}", node.tag_name().name());
        for a in ["type", "name", "id"] {
            if let Some(v) = node.attribute(a) {
                let v: String = v.chars().take(60).collect();
                let _ = write!(s, " {a}=\"{v}\"");
            }
        }
        s + ">"
    }

    /// The attributes of `node`, with `$name` replaced by the `<default>`s (longest names first, as
    /// Mitsuba), checked against `allowed` (an unknown one is an error) and `required`.
    fn attrs(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        allowed: &[&str],
        required: &[&str],
    ) -> Result<Attrs, SceneError> {
        let loc = self.loc(src, node, Self::describe(node));
        let mut params: Vec<&(String, String)> = self.params.iter().collect();
        params.sort_by_key(|(n, _)| std::cmp::Reverse(n.len()));
        let mut out = Vec::new();
        for a in node.attributes() {
            let name = a.name();
            if !allowed.contains(&name) {
                let problem = format!(
                    "<{}> has no attribute \"{name}\" (it takes {})",
                    node.tag_name().name(),
                    listed(allowed)
                );
                if self.lenient {
                    self.warnings
                        .push(loc.warning(format!("{problem}; ignored (--xml-lenient)")));
                    continue;
                }
                return Err(loc.error(problem, SEE_DOCS));
            }
            let mut value = a.value().to_string();
            if value.contains('$') {
                for (n, v) in &params {
                    value = value.replace(&format!("${n}"), v);
                }
                if value.contains('$') {
                    return Err(loc.error(
                        format!("attribute {name}=\"{value}\" uses a parameter that no <default> defines"),
                        "Define it with <default name=\"...\" value=\"...\"/> before it is used.",
                    ));
                }
            }
            if name == "name" && src.upgrade && node.tag_name().name() != "default" {
                value = snake_case(&value);
            }
            out.push((name.to_string(), value));
        }
        let attrs = Attrs(out);
        for r in required {
            if attrs.get(r).is_none() {
                return Err(loc.error(
                    format!("<{}> needs the attribute \"{r}\"", node.tag_name().name()),
                    SEE_DOCS,
                ));
            }
        }
        Ok(attrs)
    }

    /// Reads the main file: its root must be `<scene version="...">`.
    fn main_file(&mut self, path: &Path) -> Result<Obj, SceneError> {
        let text = super::read_scene_text(path)?;
        let doc = parse_xml(path, &text)?;
        self.chain
            .push(path.canonicalize().unwrap_or_else(|_| absolute(path)));
        let root = doc.root_element();
        let mut src = Src {
            file: Rc::new(path.to_path_buf()),
            doc: &doc,
            upgrade: false,
        };
        let loc = self.loc(&src, root, Self::describe(root));
        if root.tag_name().name() != "scene" {
            return Err(loc.error(
                format!(
                    "the root element is <{}>, not <scene>",
                    root.tag_name().name()
                ),
                "A Mitsuba 3 scene file is <scene version=\"3.0.0\"> ... </scene>.",
            ));
        }
        let attrs = self.attrs(&src, root, &["version"], &["version"])?;
        src.upgrade = self.version(&loc, attrs.get("version"))?;
        let mut props = Vec::new();
        self.children(&src, root, &mut props)?;
        Ok(Obj {
            tag: "scene".into(),
            kind: "scene".into(),
            loc,
            props,
        })
    }

    /// Checks a version attribute; true when it is below 2.0.0 (names are then upgraded).
    fn version(&mut self, loc: &Loc, v: Option<&str>) -> Result<bool, SceneError> {
        let Some(v) = v else { return Ok(false) };
        let Some(version) = parse_version(v) else {
            return Err(loc.error(
                format!("version=\"{v}\" is not a version number"),
                "Give the Mitsuba version the scene was written for, three numbers: version=\"3.0.0\".",
            ));
        };
        Ok(version < (2, 0, 0))
    }

    /// Every child of `node` (an object or the scene) into `out`.
    fn children(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        for child in node.children() {
            match child.node_type() {
                roxmltree::NodeType::Element => self.element(src, child, out)?,
                roxmltree::NodeType::Text if !child.text().unwrap_or("").trim().is_empty() => {
                    let loc = self.loc(src, child, Self::describe(node));
                    return Err(loc.error(
                        "unexpected text inside the element",
                        "Mitsuba elements hold other elements only; values go in attributes.",
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// An element that is not what vkpath reads: an error, or with `lenient` a warning.
    fn unknown(&mut self, loc: Loc, problem: String) -> Result<(), SceneError> {
        if self.lenient {
            self.warnings
                .push(loc.warning(format!("{problem}; skipped (--xml-lenient)")));
            Ok(())
        } else {
            Err(loc.error(
                problem,
                &format!(
                    "{SEE_DOCS} Or give --xml-lenient to skip what vkpath does not read (with a warning each)."
                ),
            ))
        }
    }

    fn element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        let tag = node.tag_name().name();
        let loc = self.loc(src, node, Self::describe(node));
        match tag {
            "default" => {
                let a = self.attrs(src, node, &["name", "value"], &["name", "value"])?;
                let (name, value) = (a.get("name").unwrap_or(""), a.get("value").unwrap_or(""));
                if name.is_empty() {
                    return Err(loc.error("<default> needs a non-empty name", SEE_DOCS));
                }
                if !self.params.iter().any(|(n, _)| n == name) {
                    self.params.push((name.to_string(), value.to_string()));
                }
                Ok(())
            }
            "include" => self.include(src, node, loc, out),
            "ref" => {
                let a = self.attrs(src, node, &["id", "name"], &["id"])?;
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Ref(a.get("id").unwrap_or("").to_string()),
                    loc,
                });
                Ok(())
            }
            "float" | "integer" | "boolean" | "string" => {
                let a = self.attrs(src, node, &["name", "value"], &["name", "value"])?;
                let v = a.get("value").unwrap_or("");
                let value = match tag {
                    "float" => Value::Float(parse_float(v).ok_or_else(|| {
                        loc.error(format!("value=\"{v}\" is not a number"), "Write a decimal number, e.g. value=\"0.5\".")
                    })?),
                    "integer" => Value::Integer(v.trim().parse().map_err(|_| {
                        loc.error(format!("value=\"{v}\" is not an integer"), "Write a whole number, e.g. value=\"64\".")
                    })?),
                    "boolean" => Value::Boolean(match v.trim().to_ascii_lowercase().as_str() {
                        "true" => true,
                        "false" => false,
                        _ => {
                            return Err(loc.error(
                                format!("value=\"{v}\" is not a boolean"),
                                "Write value=\"true\" or value=\"false\".",
                            ));
                        }
                    }),
                    _ => Value::Str(v.to_string()),
                };
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value,
                    loc,
                });
                Ok(())
            }
            "point" | "vector" => {
                let a = self.attrs(src, node, &["name", "value", "x", "y", "z"], &["name"])?;
                let v = xyz(&a, 0.0).map_err(|p| loc.error(p, "Give value=\"x, y, z\" or the attributes x, y and z."))?;
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Vector(v),
                    loc,
                });
                Ok(())
            }
            "rgb" => {
                let a = self.attrs(src, node, &["name", "value"], &["name", "value"])?;
                let v = a.get("value").unwrap_or("");
                let numbers = numbers(v);
                let rgb = match numbers.as_deref() {
                    Some([g]) => DVec3::splat(*g),
                    Some([r, g, b]) => DVec3::new(*r, *g, *b),
                    _ => {
                        return Err(loc.error(
                            format!("value=\"{v}\" is not one or three numbers"),
                            "Write value=\"r, g, b\" (or one number for a grey).",
                        ));
                    }
                };
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Rgb(rgb),
                    loc,
                });
                Ok(())
            }
            "spectrum" if node.attribute("type").is_none() => {
                let a = self.attrs(src, node, &["name", "value", "filename"], &["name"])?;
                let problem = "vkpath reads a uniform <spectrum value=\"x\"> (one number) only: it renders in RGB";
                let hint = "Give the colour as <rgb name=\"...\" value=\"r, g, b\"/> instead.";
                if a.get("filename").is_some() {
                    return Err(loc.error(problem, hint));
                }
                let v = a.get("value").unwrap_or("");
                let Some(x) = parse_float(v) else {
                    return Err(loc.error(format!("{problem}, not value=\"{v}\""), hint));
                };
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Spectrum(x),
                    loc,
                });
                Ok(())
            }
            "transform" => {
                let a = self.attrs(src, node, &["name"], &["name"])?;
                let xf = self.transform(src, node)?;
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Transform(xf),
                    loc,
                });
                Ok(())
            }
            "translate" | "rotate" | "scale" | "lookat" | "matrix" => Err(loc.error(
                format!("<{tag}> is a transform operation outside a <transform>"),
                "Put it inside <transform name=\"to_world\"> ... </transform>.",
            )),
            "scene" => Err(loc.error(
                "a <scene> inside another element",
                "A file has one <scene>, its root; to combine files use <include filename=\"...\"/>.",
            )),
            t if OBJECT_TAGS.contains(&t) || (t == "spectrum") => {
                if t == "spectrum" {
                    return self.unknown(
                        loc,
                        "a <spectrum type=...> plugin: vkpath renders in RGB and reads uniform spectra only".into(),
                    );
                }
                let a = self.attrs(src, node, &["type", "id", "name"], &["type"])?;
                let mut props = Vec::new();
                self.children(src, node, &mut props)?;
                for (i, p) in props.iter().enumerate() {
                    if !p.name.is_empty() && props[..i].iter().any(|q| q.name == p.name) {
                        return Err(p.loc.error(
                            format!("the parameter \"{}\" is given twice", p.name),
                            "Give each parameter once.",
                        ));
                    }
                }
                let obj = Rc::new(Obj {
                    tag: t.to_string(),
                    kind: a.get("type").unwrap_or("").to_string(),
                    loc: loc.clone(),
                    props,
                });
                if let Some(id) = a.get("id") {
                    if let Some(prev) = self.ids.get(id) {
                        return Err(loc.error(
                            format!(
                                "the id \"{id}\" is already used by {} at {}, line {}",
                                prev.loc.element,
                                prev.loc.file.display(),
                                prev.loc.line
                            ),
                            "Give every object its own id.",
                        ));
                    }
                    self.ids.insert(id.to_string(), obj.clone());
                }
                out.push(Prop {
                    name: a.get("name").unwrap_or("").to_string(),
                    value: Value::Object(obj),
                    loc,
                });
                Ok(())
            }
            "alias" | "path" => self.unknown(loc, format!("<{tag}> is not read by vkpath")),
            other => self.unknown(loc, format!("<{other}> is not a Mitsuba 3 element vkpath reads")),
        }
    }

    /// `<include filename="...">`: relative to the including file, else to the main file's folder
    /// (Mitsuba's file resolver); a `<scene>` root's children join the including element, any other root
    /// element is one child of it.
    fn include(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        loc: Loc,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        let a = self.attrs(src, node, &["filename"], &["filename"])?;
        let name = a.get("filename").unwrap_or("");
        let Some(target) = resolve(name, &src.file, &self.main_dir) else {
            return Err(loc.error(
                format!(
                    "the included file \"{name}\" was not found (looked beside {} and in {})",
                    src.file.display(),
                    self.main_dir.display()
                ),
                "Check the include's filename: it is relative to the including file.",
            ));
        };
        let canonical = target.canonicalize().unwrap_or_else(|_| target.clone());
        if let Some(i) = self.chain.iter().position(|p| *p == canonical) {
            let cycle: Vec<String> = self.chain[i..]
                .iter()
                .chain(std::iter::once(&canonical))
                .map(|p| p.display().to_string())
                .collect();
            return Err(loc.error(
                format!(
                    "{} includes {}, which is already being read: an include cycle ({})",
                    src.file.display(),
                    target.display(),
                    cycle.join(" -> ")
                ),
                "Remove the include that closes the cycle.",
            ));
        }
        if self.chain.len() > INCLUDE_DEPTH_LIMIT {
            return Err(loc.error(
                format!("includes nest deeper than {INCLUDE_DEPTH_LIMIT} files (Mitsuba's limit)"),
                "Flatten the includes.",
            ));
        }
        let text = super::read_scene_text(&target).map_err(|e| {
            loc.error(
                format!("the included file {} cannot be read: {e}", target.display()),
                "Check the include's filename.",
            )
        })?;
        let doc = parse_xml(&target, &text)?;
        self.chain.push(canonical);
        let mut inner = Src {
            file: Rc::new(target),
            doc: &doc,
            upgrade: src.upgrade,
        };
        let root = doc.root_element();
        let result = if root.tag_name().name() == "scene" {
            let root_loc = self.loc(&inner, root, Self::describe(root));
            let a = self.attrs(&inner, root, &["version"], &[])?;
            if a.get("version").is_some() {
                inner.upgrade = self.version(&root_loc, a.get("version"))?;
            }
            self.children(&inner, root, out)
        } else {
            self.element(&inner, root, out)
        };
        self.chain.pop();
        result
    }

    /// A `<transform>`: its operations in order, each left-multiplying the transform so far (Mitsuba's
    /// order: `<translate/><rotate/>` is rotate(translate(p)), i.e. M = R T).
    fn transform(&mut self, src: &Src, node: roxmltree::Node) -> Result<Xf, SceneError> {
        let mut m = DMat4::IDENTITY;
        let mut ops = 0;
        let mut lookat = None;
        for child in node.children() {
            match child.node_type() {
                roxmltree::NodeType::Element => {}
                roxmltree::NodeType::Text if !child.text().unwrap_or("").trim().is_empty() => {
                    let loc = self.loc(src, child, Self::describe(node));
                    return Err(loc.error("unexpected text inside <transform>", SEE_DOCS));
                }
                _ => continue,
            }
            let tag = child.tag_name().name();
            let loc = self.loc(src, child, Self::describe(child));
            let op = match tag {
                "translate" => {
                    let a = self.attrs(src, child, &["value", "x", "y", "z"], &[])?;
                    let t = xyz(&a, 0.0)
                        .map_err(|p| loc.error(p, "Give value=\"x, y, z\" or x, y, z."))?;
                    DMat4::from_translation(t)
                }
                "scale" => {
                    let a = self.attrs(src, child, &["value", "x", "y", "z"], &[])?;
                    let s = xyz(&a, 1.0).map_err(|p| {
                        loc.error(
                            p,
                            "Give value=\"s\" (uniform), value=\"x, y, z\" or x, y, z.",
                        )
                    })?;
                    DMat4::from_scale(s)
                }
                "rotate" => {
                    let a =
                        self.attrs(src, child, &["value", "x", "y", "z", "angle"], &["angle"])?;
                    let axis = xyz(&a, 0.0).map_err(|p| {
                        loc.error(p, "Give the axis as value=\"x, y, z\" or x, y, z.")
                    })?;
                    let angle_text = a.get("angle").unwrap_or("");
                    let angle = parse_float(angle_text).ok_or_else(|| {
                        loc.error(
                            format!("angle=\"{angle_text}\" is not a number"),
                            "The angle is in degrees.",
                        )
                    })?;
                    if axis.length_squared() == 0.0 {
                        return Err(
                            loc.error("the rotation axis is zero", "Give the axis, e.g. y=\"1\".")
                        );
                    }
                    // The right-handed rotation by `angle` degrees about the unit axis (Rodrigues' formula,
                    // counter-clockwise looking down the axis), as Mitsuba's Transform4f::rotate.
                    DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let a = self.attrs(src, child, &["value"], &["value"])?;
                    let v = a.get("value").unwrap_or("");
                    // The values are written row by row (Mitsuba: matrix(i, j) = value[4 i + j]).
                    match numbers(v).as_deref() {
                        Some(n) if n.len() == 16 => {
                            let mut rows = [0.0; 16];
                            rows.copy_from_slice(n);
                            DMat4::from_cols_array(&rows).transpose()
                        }
                        Some(n) if n.len() == 9 => {
                            let mut rows = [0.0; 9];
                            rows.copy_from_slice(n);
                            DMat4::from_mat3(DMat3::from_cols_array(&rows).transpose())
                        }
                        _ => {
                            return Err(loc.error(
                                "a <matrix> value must be 16 numbers (or 9), row by row",
                                "Write value=\"m00 m01 m02 m03 m10 ... m33\".",
                            ));
                        }
                    }
                }
                "lookat" | "lookAt" if tag == "lookat" || src.upgrade => {
                    let a = self.attrs(
                        src,
                        child,
                        &["origin", "target", "up"],
                        &["origin", "target"],
                    )?;
                    let vec = |name: &str| -> Result<Option<DVec3>, SceneError> {
                        match a.get(name) {
                            None => Ok(None),
                            Some(v) => match numbers(v).as_deref() {
                                Some([x, y, z]) => Ok(Some(DVec3::new(*x, *y, *z))),
                                _ => Err(loc.error(
                                    format!("{name}=\"{v}\" is not three numbers"),
                                    "Write it as \"x, y, z\".",
                                )),
                            },
                        }
                    };
                    let (origin, target, up) = (vec("origin")?, vec("target")?, vec("up")?);
                    let (origin, target) = (origin.unwrap_or_default(), target.unwrap_or_default());
                    let m = look_at(origin, target, up).ok_or_else(|| {
                        loc.error(
                            "an invalid lookat: the target is the origin, or up is parallel to the view direction",
                            "Give a target away from the origin and an up not along target - origin.",
                        )
                    })?;
                    lookat = Some((origin, target, up));
                    m
                }
                other => {
                    return Err(loc.error(
                        format!("<{other}> inside a <transform>"),
                        "A <transform> holds translate, rotate, scale, lookat and matrix operations only.",
                    ));
                }
            };
            m = op * m;
            ops += 1;
        }
        if !m.is_finite() {
            let loc = self.loc(src, node, Self::describe(node));
            return Err(loc.error("the transform is not finite", "Use finite numbers."));
        }
        Ok(Xf {
            m,
            lookat: if ops == 1 { lookat } else { None },
        })
    }
}

/// Mitsuba's lookat: the camera frame with +z towards the target, +x = up x z (to the LEFT in the image),
/// +y = z x x (up), at the origin. Without `up`, the first vector of the frame that Duff et al. 2017
/// build around the view direction (Mitsuba's coordinate_system). None when degenerate.
fn look_at(origin: DVec3, target: DVec3, up: Option<DVec3>) -> Option<DMat4> {
    let dir = (target - origin).normalize_or_zero();
    if dir == DVec3::ZERO {
        return None;
    }
    let up = match up {
        Some(u) if u.length_squared() > 0.0 => u,
        _ => {
            let sign = 1.0f64.copysign(dir.z);
            let a = -1.0 / (sign + dir.z);
            let b = dir.x * dir.y * a;
            DVec3::new(1.0 + sign * dir.x * dir.x * a, sign * b, -sign * dir.x)
        }
    };
    let left = up.cross(dir).normalize_or_zero();
    if left == DVec3::ZERO {
        return None;
    }
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// A finite number as Mitsuba's parser reads one.
fn parse_float(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// Numbers separated by commas and/or white space (Mitsuba's tokenizer); None if one is not a number.
fn numbers(s: &str) -> Option<Vec<f64>> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(parse_float)
        .collect()
}

/// `value="x y z"` (or one number for all three), or the attributes x, y, z (`default` for those absent).
fn xyz(a: &Attrs, default: f64) -> Result<DVec3, String> {
    if let Some(v) = a.get("value") {
        if a.get("x").is_some() || a.get("y").is_some() || a.get("z").is_some() {
            return Err("value cannot be given together with x, y or z".into());
        }
        return match numbers(v).as_deref() {
            Some([s]) => Ok(DVec3::splat(*s)),
            Some([x, y, z]) => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(format!("value=\"{v}\" is not one or three numbers")),
        };
    }
    let mut out = [default; 3];
    for (i, n) in ["x", "y", "z"].iter().enumerate() {
        if let Some(v) = a.get(n) {
            out[i] = parse_float(v).ok_or_else(|| format!("{n}=\"{v}\" is not a number"))?;
        }
    }
    Ok(DVec3::from_array(out))
}

fn listed(names: &[&str]) -> String {
    match names {
        [] => "none".into(),
        [one] => format!("\"{one}\""),
        [rest @ .., last] => format!(
            "{} and \"{last}\"",
            rest.iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// A file named in `file`: absolute as given, else beside `file`, else in the main file's folder (the
/// first that exists). None when none exists.
fn resolve(name: &str, file: &Path, main_dir: &Path) -> Option<PathBuf> {
    let p = Path::new(name);
    if name.is_empty() {
        return None;
    }
    if p.is_absolute() {
        return p.exists().then(|| p.to_path_buf());
    }
    let beside = absolute(file).parent().map(|d| d.join(p));
    [beside, Some(main_dir.join(p))]
        .into_iter()
        .flatten()
        .map(|c| absolute(&c))
        .find(|c| c.exists())
}

// ---------------------------------------------------------------------------------------------------
// TOML output
// ---------------------------------------------------------------------------------------------------

/// TOML text being written, with the XML element each line came from.
#[derive(Default)]
struct TomlOut {
    text: String,
    origins: Vec<Option<Loc>>,
}

impl TomlOut {
    fn line(&mut self, s: impl AsRef<str>, origin: Option<&Loc>) {
        for l in s.as_ref().split('\n') {
            self.text += l;
            self.text.push('\n');
            self.origins.push(origin.cloned());
        }
    }

    fn append(&mut self, other: TomlOut) {
        self.text += &other.text;
        self.origins.extend(other.origins);
    }
}

/// A number as TOML writes it, rounded to the f32 the scene stores.
fn num(x: f64) -> String {
    toml_text::num(x as f32)
}

fn vec3(v: DVec3) -> String {
    toml_text::vec3(v.as_vec3().to_array())
}

// ---------------------------------------------------------------------------------------------------
// Parameters of one object
// ---------------------------------------------------------------------------------------------------

/// A colour parameter: a colour, or a bitmap texture's file (which vkpath applies per mesh).
#[derive(Clone, Debug)]
enum ColorTex {
    Color(DVec3),
    Bitmap(PathBuf, Loc),
}

/// An object's parameters, remembering which were read.
struct Args<'o> {
    obj: &'o Obj,
    used: Vec<Cell<bool>>,
}

impl<'o> Args<'o> {
    fn new(obj: &'o Obj) -> Args<'o> {
        Args {
            obj,
            used: obj.props.iter().map(|_| Cell::new(false)).collect(),
        }
    }

    fn prop(&self, name: &str) -> Option<&'o Prop> {
        let i = self.obj.props.iter().position(|p| p.name == name)?;
        self.used[i].set(true);
        Some(&self.obj.props[i])
    }

    fn wrong(p: &Prop, expected: &str) -> SceneError {
        p.loc.error(
            format!(
                "\"{}\" is {}, but vkpath reads it as {expected}",
                p.name,
                p.value.kind()
            ),
            SEE_DOCS,
        )
    }

    /// Parameter `name` as `read` takes it from its value, or `None` when the object has none; a value of
    /// another kind is an error that says what vkpath reads it as (`expected`).
    fn typed<T>(
        &self,
        name: &str,
        expected: &str,
        read: impl Fn(&'o Value) -> Option<T>,
    ) -> Result<Option<(T, &'o Loc)>, SceneError> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        match read(&p.value) {
            Some(v) => Ok(Some((v, &p.loc))),
            None => Err(Self::wrong(p, expected)),
        }
    }

    fn float(&self, name: &str) -> Result<Option<(f64, &'o Loc)>, SceneError> {
        self.typed(name, "a <float>", |v| match v {
            Value::Float(x) => Some(*x),
            Value::Integer(i) => Some(*i as f64),
            _ => None,
        })
    }

    fn float_or(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        Ok(self.float(name)?.map_or(default, |(x, _)| x))
    }

    fn int(&self, name: &str) -> Result<Option<(i64, &'o Loc)>, SceneError> {
        self.typed(name, "an <integer>", |v| match v {
            Value::Integer(i) => Some(*i),
            _ => None,
        })
    }

    fn boolean(&self, name: &str) -> Result<Option<(bool, &'o Loc)>, SceneError> {
        self.typed(name, "a <boolean>", |v| match v {
            Value::Boolean(b) => Some(*b),
            _ => None,
        })
    }

    fn string(&self, name: &str) -> Result<Option<(&'o str, &'o Loc)>, SceneError> {
        self.typed(name, "a <string>", |v| match v {
            Value::Str(s) => Some(s.as_str()),
            _ => None,
        })
    }

    fn vector(&self, name: &str) -> Result<Option<(DVec3, &'o Loc)>, SceneError> {
        self.typed(name, "a <point> or <vector>", |v| match v {
            Value::Vector(v) => Some(*v),
            _ => None,
        })
    }

    fn transform(&self, name: &str) -> Result<Option<(&'o Xf, &'o Loc)>, SceneError> {
        self.typed(name, "a <transform>", |v| match v {
            Value::Transform(x) => Some(x),
            _ => None,
        })
    }

    /// The nested or referenced objects of element `tag` (any name: Mitsuba's shapes find their BSDF by
    /// its kind, not its name).
    fn objects(
        &self,
        tag: &str,
        ids: &HashMap<String, Rc<Obj>>,
    ) -> Result<Vec<(Rc<Obj>, &'o Loc)>, SceneError> {
        let mut out = Vec::new();
        for (i, p) in self.obj.props.iter().enumerate() {
            let obj = match &p.value {
                Value::Object(o) => o.clone(),
                Value::Ref(id) => resolve_ref(ids, id, &p.loc)?,
                _ => continue,
            };
            if obj.tag == tag {
                self.used[i].set(true);
                out.push((obj, &p.loc));
            }
        }
        Ok(out)
    }

    /// At most one object of element `tag`.
    fn object(
        &self,
        tag: &str,
        ids: &HashMap<String, Rc<Obj>>,
    ) -> Result<Option<(Rc<Obj>, &'o Loc)>, SceneError> {
        let mut all = self.objects(tag, ids)?;
        if all.len() > 1 {
            return Err(all[1].1.error(
                format!("{} has more than one <{tag}>", self.obj.loc.element),
                "Give it one.",
            ));
        }
        Ok(all.pop())
    }
}

fn resolve_ref(ids: &HashMap<String, Rc<Obj>>, id: &str, loc: &Loc) -> Result<Rc<Obj>, SceneError> {
    ids.get(id).cloned().ok_or_else(|| {
        loc.error(
            format!("no object has the id \"{id}\""),
            "Refer to the id of an object defined in the scene (<bsdf type=\"...\" id=\"...\">).",
        )
    })
}

// ---------------------------------------------------------------------------------------------------
// Translation
// ---------------------------------------------------------------------------------------------------

/// A bitmap texture's file, and the element that names it.
type Bitmap = (PathBuf, Loc);

/// A BSDF as vkpath material keys (`key = value` lines), and its bitmap texture.
#[derive(Clone)]
struct MatOut {
    lines: Vec<(String, Loc)>,
    texture: Option<Bitmap>,
}

/// A film as vkpath's image size and pixel filter (its name and Gaussian sigma).
struct FilmOut {
    width: i64,
    height: i64,
    filter: (&'static str, Option<f64>),
}

struct Tr<'p> {
    ids: &'p HashMap<String, Rc<Obj>>,
    lenient: bool,
    warnings: Vec<String>,
    main_dir: PathBuf,
    refer_dir: PathBuf,
    /// Material name by (BSDF object, emitted radiance): shapes that share both share the material.
    materials: HashMap<(usize, [u64; 3]), (String, Option<Bitmap>)>,
    material_names: Vec<String>,
    out_materials: TomlOut,
    out_shapes: TomlOut,
    out_lights: TomlOut,
    environment: Option<Loc>,
}

/// A camera as vkpath keys.
struct CameraOut {
    lines: Vec<String>,
    width: i64,
    height: i64,
    samples: i64,
    seed: i64,
    sampler: &'static str,
    filter: (&'static str, Option<f64>),
    film_loc: Loc,
    sampler_loc: Loc,
}

const ORTHO_TOL: f64 = 1e-3;

impl Tr<'_> {
    /// Checks every `<ref>` in the scene resolves (also those a plugin never reads).
    fn check_refs(&self, obj: &Obj) -> Result<(), SceneError> {
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
    fn finish(&mut self, args: &Args, known: &[&str]) -> Result<(), SceneError> {
        for (p, used) in args.obj.props.iter().zip(&args.used) {
            if used.get() {
                continue;
            }
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
    fn unsupported(&mut self, obj: &Obj, reads: &str) -> Result<(), SceneError> {
        let problem = format!(
            "vkpath does not read Mitsuba's {} plugin \"{}\" (it reads {reads})",
            obj.tag, obj.kind
        );
        if self.lenient {
            self.warnings.push(
                obj.loc
                    .warning(format!("{problem}; skipped (--xml-lenient)")),
            );
            Ok(())
        } else {
            Err(obj.loc.error(
                problem,
                &format!("{SEE_DOCS} Or give --xml-lenient to skip it with a warning."),
            ))
        }
    }

    /// An approximation Mitsuba would not make: refused, or with `lenient` a warning.
    fn approximate(&mut self, loc: &Loc, problem: String, hint: &str) -> Result<(), SceneError> {
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
    fn refer(&self, p: &Path) -> String {
        let rel = relative_to(p, &self.refer_dir).unwrap_or_else(|| p.to_path_buf());
        toml_string(&rel.to_string_lossy())
    }

    fn file(&self, name: &str, loc: &Loc) -> PathBuf {
        resolve(name, &loc.file, &self.main_dir).unwrap_or_else(|| {
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
                "emitter" => emitters.push(obj),
                // Definitions that shapes refer to by id.
                "bsdf" | "texture" => {}
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
                INFINITE_DEPTH_BOUNCES,
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
            head.line(format!("filter_sigma = {}", num(s)), Some(&cam.film_loc));
        }

        // Emitters (lights and the environment), then shapes (which write the materials).
        let mut env = TomlOut::default();
        for e in &emitters {
            self.emitter(e, &mut env)?;
        }
        if !env.text.is_empty() {
            head.line("", None);
            head.append(env);
        }
        for (i, s) in shapes.iter().enumerate() {
            self.shape(s, i)?;
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

    fn integrator(&mut self, obj: &Obj) -> Result<(u32, String), SceneError> {
        if obj.kind != "path" {
            let problem = format!(
                "vkpath is a path tracer: it does not read Mitsuba's integrator \"{}\"",
                obj.kind
            );
            return Err(obj.loc.error(
                problem,
                "Use <integrator type=\"path\"> (max_depth 2 is direct lighting).",
            ));
        }
        let args = Args::new(obj);
        let depth = args.int("max_depth")?;
        let rr = args.int("rr_depth")?;
        if let Some((true, loc)) = args.boolean("hide_emitters")? {
            return Err(loc.error(
                "hide_emitters = true: vkpath always shows the emitters the camera sees",
                "Remove hide_emitters (or set it to false).",
            ));
        }
        self.finish(&args, &["max_depth", "rr_depth", "hide_emitters"])?;
        if let Some((r, loc)) = rr
            && r != 3
        {
            self.warnings.push(loc.warning(format!(
                "rr_depth = {r} is not used: vkpath starts Russian roulette after --roulette-depth bounces \
                 (default 3); both are unbiased, only the noise differs"
            )));
        }
        // Mitsuba's max_depth counts path segments (1: emitters seen directly, 2: direct light), vkpath's
        // max_bounces scattering events (0: emitters only, 1: direct light): max_bounces = max_depth - 1.
        match depth {
            None | Some((-1, _)) => Ok((
                INFINITE_DEPTH_BOUNCES,
                "Mitsuba max_depth = -1 (no limit)".into(),
            )),
            Some((d, _)) if d >= 1 && d - 1 <= i64::from(u32::MAX) => {
                Ok(((d - 1) as u32, format!("Mitsuba max_depth = {d}")))
            }
            Some((d, loc)) => Err(loc.error(
                format!("max_depth = {d}: vkpath needs -1 (no limit) or a depth of at least 1"),
                "max_depth counts path segments: 1 shows the emitters only, 2 is direct light.",
            )),
        }
    }

    fn sensor(&mut self, obj: &Obj) -> Result<CameraOut, SceneError> {
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
        let (width, height, filter, film_loc) = match &film {
            Some((f, _)) => {
                let FilmOut {
                    width,
                    height,
                    filter,
                } = self.film(f)?;
                (width, height, filter, f.loc.clone())
            }
            None => (768, 576, ("gaussian", Some(0.5)), obj.loc.clone()),
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
        let _ = args.boolean("sample_border")?;
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
                    other => {
                        return Err(f.loc.error(
                            format!(
                                "vkpath does not read Mitsuba's reconstruction filter \"{other}\""
                            ),
                            "Use <rfilter type=\"box\"/> or <rfilter type=\"gaussian\"> (stddev).",
                        ));
                    }
                };
                let known: &[&str] = if out.0 == "box" { &[] } else { &["stddev"] };
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
            ],
        )?;
        Ok(FilmOut {
            width,
            height,
            filter,
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

    /// An emitter directly in the scene: a light, or the environment.
    fn emitter(&mut self, obj: &Obj, env: &mut TomlOut) -> Result<(), SceneError> {
        let args = Args::new(obj);
        let loc = Some(&obj.loc);
        match obj.kind.as_str() {
            "point" => {
                // Mitsuba's intensity I is W/sr; vkpath's point light has I = power x color / (4 pi):
                // power = 4 pi max(I), color = I / max(I).
                let intensity = self.color(&args, "intensity", DVec3::ONE)?;
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
            "directional" => {
                let irradiance = self.color(&args, "irradiance", DVec3::ONE)?;
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
                    let radiance = self.color(&args, "radiance", DVec3::ONE)?;
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
                    "point, directional, constant, envmap and area (inside a shape)",
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

    /// A colour parameter that may not be a texture.
    fn color(&mut self, args: &Args, name: &str, default: DVec3) -> Result<DVec3, SceneError> {
        match self.color_tex(args, name, default)? {
            ColorTex::Color(c) => Ok(c),
            ColorTex::Bitmap(_, loc) => Err(loc.error(
                format!("a bitmap texture as \"{name}\": vkpath textures a diffuse or plastic reflectance only"),
                "Give a colour (<rgb>) here.",
            )),
        }
    }

    /// A colour parameter: `<rgb>`, a uniform `<spectrum>`, a `<float>` (grey), or a texture: `bitmap`
    /// (a file) or `srgb` (a colour).
    fn color_tex(
        &mut self,
        args: &Args,
        name: &str,
        default: DVec3,
    ) -> Result<ColorTex, SceneError> {
        let Some(p) = args.prop(name) else {
            return Ok(ColorTex::Color(default));
        };
        let obj = match &p.value {
            Value::Rgb(c) => return Ok(ColorTex::Color(*c)),
            Value::Spectrum(x) | Value::Float(x) => return Ok(ColorTex::Color(DVec3::splat(*x))),
            Value::Integer(i) => return Ok(ColorTex::Color(DVec3::splat(*i as f64))),
            Value::Object(o) => o.clone(),
            Value::Ref(id) => resolve_ref(self.ids, id, &p.loc)?,
            _ => return Err(Args::wrong(p, "a colour (<rgb>, <spectrum> or a texture)")),
        };
        if obj.tag != "texture" {
            return Err(obj.loc.error(
                format!("\"{name}\" is a <{}>, not a colour or texture", obj.tag),
                "Give an <rgb> or a <texture type=\"bitmap\">.",
            ));
        }
        let targs = Args::new(&obj);
        let out = match obj.kind.as_str() {
            "srgb" => {
                let c = match targs.prop("color") {
                    Some(Prop {
                        value: Value::Rgb(c) | Value::Vector(c),
                        ..
                    }) => *c,
                    Some(q) => return Err(Args::wrong(q, "an <rgb>")),
                    None => {
                        return Err(obj.loc.error(
                            "an srgb texture needs a color",
                            "Give <rgb name=\"color\" .../>.",
                        ));
                    }
                };
                let _ = targs.boolean("unbounded")?;
                self.finish(&targs, &["color", "unbounded"])?;
                ColorTex::Color(c)
            }
            "bitmap" => {
                let Some((file, floc)) = targs.string("filename")? else {
                    return Err(obj.loc.error(
                        "a bitmap texture needs a filename (vkpath does not read in-memory bitmaps)",
                        "Give <string name=\"filename\" value=\"texture.png\"/>.",
                    ));
                };
                let path = self.file(file, floc);
                if let Some((true, l)) = targs.boolean("raw")? {
                    return Err(l.error(
                        "raw = true: vkpath decodes 8-bit textures as sRGB (and EXR/HDR as linear) always",
                        "Remove raw, or store the texture linear in an EXR file.",
                    ));
                }
                if let Some((f, l)) = targs.string("filter_type")?
                    && f != "bilinear"
                {
                    return Err(l.error(
                        format!("filter_type \"{f}\": vkpath filters textures bilinearly"),
                        "Remove filter_type (bilinear is the default).",
                    ));
                }
                if let Some((w, l)) = targs.string("wrap_mode")?
                    && w != "repeat"
                {
                    return Err(l.error(
                        format!("wrap_mode \"{w}\": vkpath repeats textures"),
                        "Remove wrap_mode (repeat is the default).",
                    ));
                }
                self.finish(&targs, &["filename", "raw", "filter_type", "wrap_mode"])?;
                ColorTex::Bitmap(path, floc.clone())
            }
            _ => {
                return Err(obj.loc.error(
                    format!("vkpath does not read Mitsuba's texture \"{}\"", obj.kind),
                    "Use a bitmap texture (a file) or an <rgb>.",
                ));
            }
        };
        Ok(out)
    }

    /// An IOR parameter: a number or one of Mitsuba's named media.
    fn ior(&self, args: &Args, name: &str, default: &str) -> Result<f64, SceneError> {
        let Some(p) = args.prop(name) else {
            return Ok(named_ior(default).unwrap_or(1.0));
        };
        match &p.value {
            Value::Float(x) => Ok(*x),
            Value::Integer(i) => Ok(*i as f64),
            Value::Spectrum(x) => Ok(*x),
            Value::Str(s) => named_ior(s).ok_or_else(|| {
                p.loc.error(
                    format!("\"{s}\" is not one of Mitsuba's named indices of refraction"),
                    &format!(
                        "Give a number, or one of: {}.",
                        IOR_TABLE
                            .iter()
                            .map(|(n, _)| *n)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            }),
            _ => Err(Args::wrong(p, "a <float> or a named medium (<string>)")),
        }
    }

    /// A microfacet BSDF's roughness: vkpath's perceptual roughness r has GGX alpha = r^2, so
    /// r = sqrt(alpha). Mitsuba's default distribution is Beckmann, which vkpath does not have.
    fn roughness(&mut self, args: &Args, obj: &Obj) -> Result<f64, SceneError> {
        match args.string("distribution")? {
            None => self.approximate(
                &obj.loc,
                "Mitsuba's default microfacet distribution is Beckmann; vkpath's is GGX".into(),
                "Add <string name=\"distribution\" value=\"ggx\"/> to read it as GGX.",
            )?,
            Some(("ggx", _)) => {}
            Some((d, l)) => {
                let l = l.clone();
                self.approximate(
                    &l,
                    format!("the microfacet distribution \"{d}\": vkpath's is GGX"),
                    "Use distribution ggx.",
                )?
            }
        }
        let _ = args.boolean("sample_visible")?;
        if let Some(p) = args.prop("alpha_u").or_else(|| args.prop("alpha_v")) {
            return Err(p.loc.error(
                "anisotropic alpha_u / alpha_v: vkpath's tangent frame is not Mitsuba's, so the highlight would stretch along other directions",
                "Give one alpha.",
            ));
        }
        let alpha = args.float("alpha")?;
        let (a, loc) = alpha.map_or((0.1, &obj.loc), |(a, l)| (a, l));
        if !(0.0..=1.0).contains(&a) {
            return Err(loc.error(
                format!("alpha = {a}: vkpath's roughness sqrt(alpha) must be in [0, 1]"),
                "Give alpha in [0, 1].",
            ));
        }
        Ok(a.sqrt())
    }

    /// A BSDF as vkpath material keys. `twosided` is accepted and unwrapped: vkpath shades both faces of
    /// every surface (Mitsuba's other BSDFs are black from behind).
    fn bsdf(&mut self, obj: &Obj) -> Result<Option<MatOut>, SceneError> {
        let args = Args::new(obj);
        let at = |s: String| (s, obj.loc.clone());
        let mut lines = Vec::new();
        let mut texture = None;
        let kind = obj.kind.as_str();
        match kind {
            "twosided" => {
                let inner = args.objects("bsdf", self.ids)?;
                self.finish(&args, &["bsdf"])?;
                return match inner.as_slice() {
                    [(b, _)] => self.bsdf(b),
                    _ => Err(obj.loc.error(
                        "a twosided BSDF with other than one nested BSDF (vkpath has no different front and back materials)",
                        "Nest exactly one BSDF.",
                    )),
                };
            }
            "diffuse" => {
                lines.push(at("type = \"diffuse\"".into()));
                match self.color_tex(&args, "reflectance", DVec3::splat(0.5))? {
                    ColorTex::Color(c) => lines.push(at(format!("albedo = {}", vec3(c)))),
                    ColorTex::Bitmap(p, l) => {
                        lines.push(at(
                            "albedo = [0.5, 0.5, 0.5]   # replaced by the texture".into()
                        ));
                        texture = Some((p, l));
                    }
                }
                self.finish(&args, &["reflectance"])?;
            }
            "conductor" | "roughconductor" => {
                let material = args.string("material")?;
                let eta = args.prop("eta").map(|_| ());
                let k = args.prop("k").map(|_| ());
                let tint = self.color(&args, "specular_reflectance", DVec3::ONE)?;
                let rough = if kind == "roughconductor" {
                    Some(self.roughness(&args, obj)?)
                } else {
                    None
                };
                match (material, eta.is_some() || k.is_some()) {
                    (Some((_, l)), true) => {
                        return Err(
                            l.error("both a material and eta / k are given", "Give one of them.")
                        );
                    }
                    (None, true) => {
                        let eta = self.color(&args, "eta", DVec3::ZERO)?;
                        let k = self.color(&args, "k", DVec3::ONE)?;
                        lines.push(at("type = \"conductor\"".into()));
                        lines.push(at(format!("eta = {}", vec3(eta))));
                        lines.push(at(format!("k = {}", vec3(k))));
                    }
                    (m, false) => {
                        let (name, mloc) = m.map_or(("none", &obj.loc), |(n, l)| (n, l));
                        let preset = match name {
                            "none" => None,
                            "Au" => Some("gold"),
                            "Ag" => Some("silver"),
                            "Cu" => Some("copper"),
                            "Al" => Some("aluminium"),
                            other => {
                                return Err(mloc.error(
                                    format!("the conductor material \"{other}\" is not one vkpath has"),
                                    "vkpath has Au, Ag, Cu, Al (its presets gold, silver, copper, aluminium) and none (a perfect mirror); or give eta and k.",
                                ));
                            }
                        };
                        match preset {
                            Some(p) => {
                                lines.push(at("type = \"conductor\"".into()));
                                lines.push(at(format!("preset = \"{p}\"")));
                            }
                            None if rough.is_none_or(|r| r == 0.0) => {
                                // Reflectance 1 times specular_reflectance: vkpath's mirror and its tint.
                                lines.push(at("type = \"mirror\"".into()));
                                lines.push(at(format!("tint = {}", vec3(tint))));
                            }
                            None => {
                                // Reflectance 1, rough: Schlick's form with f0 = 1 is exactly 1.
                                lines.push(at("type = \"conductor\"".into()));
                                lines.push(at("base_color = [1.0, 1.0, 1.0]".into()));
                            }
                        }
                    }
                }
                let is_mirror = lines.iter().any(|(l, _)| l == "type = \"mirror\"");
                if !is_mirror && tint != DVec3::ONE {
                    // specular_reflectance multiplies the Fresnel reflectance: vkpath's conductor tint.
                    lines.push(at(format!("tint = {}", vec3(tint))));
                }
                if let Some(r) = rough {
                    lines.push(at(format!("roughness = {}", num(r))));
                }
                let known: &[&str] = if kind == "conductor" {
                    &["material", "eta", "k", "specular_reflectance"]
                } else {
                    &[
                        "material",
                        "eta",
                        "k",
                        "specular_reflectance",
                        "distribution",
                        "alpha",
                        "sample_visible",
                    ]
                };
                self.finish(&args, known)?;
            }
            "dielectric" | "roughdielectric" => {
                // vkpath's ior is the interior's over the exterior's (the outside medium has ior 1).
                let ior = self.ior(&args, "int_ior", "bk7")? / self.ior(&args, "ext_ior", "air")?;
                for name in ["specular_reflectance", "specular_transmittance"] {
                    if self.color(&args, name, DVec3::ONE)? != DVec3::ONE {
                        let p = args.prop(name).map_or(&obj.loc, |p| &p.loc);
                        return Err(p.error(
                            format!("{name} other than 1: vkpath's dielectrics have no tint"),
                            "Remove it.",
                        ));
                    }
                }
                lines.push(at("type = \"dielectric\"".into()));
                lines.push(at(format!("ior = {}", num(ior))));
                if kind == "roughdielectric" {
                    let r = self.roughness(&args, obj)?;
                    lines.push(at(format!("roughness = {}", num(r))));
                }
                let known: &[&str] = if kind == "dielectric" {
                    &[
                        "int_ior",
                        "ext_ior",
                        "specular_reflectance",
                        "specular_transmittance",
                    ]
                } else {
                    &[
                        "int_ior",
                        "ext_ior",
                        "specular_reflectance",
                        "specular_transmittance",
                        "distribution",
                        "alpha",
                        "sample_visible",
                    ]
                };
                self.finish(&args, known)?;
            }
            "plastic" | "roughplastic" => {
                let ior = self.ior(&args, "int_ior", "polypropylene")?
                    / self.ior(&args, "ext_ior", "air")?;
                if self.color(&args, "specular_reflectance", DVec3::ONE)? != DVec3::ONE {
                    return Err(obj.loc.error(
                        "specular_reflectance other than 1: vkpath's plastic coat has no tint",
                        "Remove it.",
                    ));
                }
                // vkpath's plastic is Mitsuba's with nonlinear = true (the base's internal reflections
                // tinted by its albedo: a / (1 - a Fdr)); Mitsuba's default is false.
                match args.boolean("nonlinear")? {
                    Some((true, _)) => {}
                    other => {
                        let l = other.map_or(&obj.loc, |(_, l)| l).clone();
                        self.approximate(
                            &l,
                            "nonlinear = false (Mitsuba's default): vkpath's plastic is Mitsuba's nonlinear one".into(),
                            "Add <boolean name=\"nonlinear\" value=\"true\"/>.",
                        )?;
                    }
                }
                lines.push(at("type = \"plastic\"".into()));
                match self.color_tex(&args, "diffuse_reflectance", DVec3::splat(0.5))? {
                    ColorTex::Color(c) => lines.push(at(format!("albedo = {}", vec3(c)))),
                    ColorTex::Bitmap(p, l) => {
                        lines.push(at(
                            "albedo = [0.5, 0.5, 0.5]   # replaced by the texture".into()
                        ));
                        texture = Some((p, l));
                    }
                }
                lines.push(at(format!("ior = {}", num(ior))));
                if kind == "roughplastic" {
                    let r = self.roughness(&args, obj)?;
                    lines.push(at(format!("roughness = {}", num(r))));
                    if r > 0.0 {
                        self.warnings.push(obj.loc.warning(
                            "vkpath's rough plastic is not Mitsuba's roughplastic: it keeps the smooth coat's \
                             transmission, so it reflects more (about 1% more at roughness 0.1, 18% at 0.5)",
                        ));
                    }
                }
                let known: &[&str] = if kind == "plastic" {
                    &[
                        "int_ior",
                        "ext_ior",
                        "diffuse_reflectance",
                        "specular_reflectance",
                        "nonlinear",
                    ]
                } else {
                    &[
                        "int_ior",
                        "ext_ior",
                        "diffuse_reflectance",
                        "specular_reflectance",
                        "nonlinear",
                        "distribution",
                        "alpha",
                        "sample_visible",
                    ]
                };
                self.finish(&args, known)?;
            }
            _ => {
                self.unsupported(
                    obj,
                    "diffuse, conductor, roughconductor, dielectric, roughdielectric, plastic, roughplastic and twosided",
                )?;
                return Ok(None);
            }
        }
        Ok(Some(MatOut { lines, texture }))
    }

    /// The material of a shape with `bsdf` (Mitsuba's default: diffuse, reflectance 0.5) and `emission`
    /// (an area emitter's radiance): its name in [materials], written the first time, and its texture.
    fn material(
        &mut self,
        bsdf: Option<&Rc<Obj>>,
        emission: Option<(DVec3, &Loc)>,
        shape_name: &str,
        shape_loc: &Loc,
    ) -> Result<(String, Option<Bitmap>), SceneError> {
        let key = (
            bsdf.map_or(0, |b| Rc::as_ptr(b) as usize),
            emission.map_or([u64::MAX; 3], |(e, _)| e.to_array().map(f64::to_bits)),
        );
        if let Some((name, tex)) = self.materials.get(&key) {
            return Ok((name.clone(), tex.clone()));
        }
        let out = match bsdf {
            Some(b) => self.bsdf(b)?,
            None => None,
        };
        let out = out.unwrap_or_else(|| MatOut {
            lines: vec![
                ("type = \"diffuse\"".into(), shape_loc.clone()),
                (
                    "albedo = [0.5, 0.5, 0.5]   # Mitsuba's default BSDF".into(),
                    shape_loc.clone(),
                ),
            ],
            texture: None,
        });
        let id = bsdf.and_then(|b| {
            self.ids
                .iter()
                .find(|(_, o)| Rc::ptr_eq(o, b))
                .map(|(id, _)| id.clone())
        });
        let base = match (&id, emission) {
            (Some(id), None) => id.clone(),
            (Some(id), Some(_)) => format!("{id}+{shape_name}"),
            (None, _) => shape_name.to_string(),
        };
        let mut name = base.clone();
        let mut n = 2;
        while self.material_names.contains(&name) {
            name = format!("{base}#{n}");
            n += 1;
        }
        self.material_names.push(name.clone());
        let o = &mut self.out_materials;
        let origin = bsdf.map_or(shape_loc, |b| &b.loc);
        o.line("", None);
        o.line(format!("[materials.{}]", toml_string(&name)), Some(origin));
        for (l, loc) in &out.lines {
            o.line(l, Some(loc));
        }
        if let Some((e, loc)) = emission {
            // Mitsuba's area emitter emits on the side its shape's normal faces: vkpath's front side.
            o.line(format!("emission = {}", vec3(e)), Some(loc));
        }
        self.materials
            .insert(key, (name.clone(), out.texture.clone()));
        Ok((name, out.texture))
    }

    fn shape(&mut self, obj: &Obj, index: usize) -> Result<(), SceneError> {
        let kind = obj.kind.as_str();
        if !matches!(
            kind,
            "sphere" | "rectangle" | "cube" | "disk" | "obj" | "ply"
        ) {
            return self.unsupported(obj, "sphere, rectangle, cube, disk, obj and ply shapes");
        }
        let args = Args::new(obj);
        let bsdf = args.object("bsdf", self.ids)?;
        let emitter = args.object("emitter", self.ids)?;
        let emission = match &emitter {
            None => None,
            Some((e, _)) if e.kind == "area" => {
                let eargs = Args::new(e);
                let radiance = self.color(&eargs, "radiance", DVec3::ONE)?;
                self.finish(&eargs, &["radiance"])?;
                Some((radiance, &e.loc))
            }
            Some((e, _)) => {
                return Err(e.loc.error(
                    format!(
                        "an emitter \"{}\" inside a shape: a shape emits through an area emitter",
                        e.kind
                    ),
                    "Use <emitter type=\"area\"> inside the shape.",
                ));
            }
        };
        let xf = args.transform("to_world")?;
        let m = xf.map_or(DMat4::IDENTITY, |(x, _)| x.m);
        let xf_loc = xf.map_or(&obj.loc, |(_, l)| l).clone();
        let flip = args.boolean("flip_normals")?;
        let shape_name = format!("shape{index}-{kind}");
        let (material, texture) = self.material(
            bsdf.as_ref().map(|(b, _)| b),
            emission,
            &shape_name,
            &obj.loc,
        )?;
        let material = toml_string(&material);
        let loc = Some(&obj.loc);
        let mesh_kind = matches!(kind, "obj" | "ply");
        if texture.is_some() && !mesh_kind {
            return Err(obj.loc.error(
                format!("a bitmap texture on a {kind}: vkpath textures meshes (obj, ply) only, at their uvs"),
                "Give the shape a plain colour, or make it an OBJ mesh with texture coordinates.",
            ));
        }
        match kind {
            "sphere" => {
                // Mitsuba places the unit sphere by to_world x translate(center) x scale(radius).
                let center = args.vector("center")?.map_or(DVec3::ZERO, |(c, _)| c);
                let radius = match args.float("radius")? {
                    None => 1.0,
                    Some((r, _)) if r > 0.0 => r,
                    Some((r, l)) => {
                        return Err(l.error(
                            format!("radius = {r}: a sphere's radius must be > 0"),
                            "Give a positive radius.",
                        ));
                    }
                };
                if let Some((true, l)) = flip {
                    return Err(l.error(
                        "flip_normals on a sphere: vkpath's sphere normals point outwards",
                        "Remove flip_normals.",
                    ));
                }
                self.finish(
                    &args,
                    &[
                        "center",
                        "radius",
                        "to_world",
                        "flip_normals",
                        "bsdf",
                        "emitter",
                    ],
                )?;
                let full =
                    m * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
                let (c, r) = similarity(&full).ok_or_else(|| {
                    xf_loc.error(
                        "the sphere's to_world scales unevenly or shears it: an ellipsoid, which vkpath's spheres cannot be",
                        "Scale spheres uniformly (or give radius).",
                    )
                })?;
                let o = &mut self.out_shapes;
                o.line("", None);
                o.line("[[sphere]]", loc);
                o.line(format!("center   = {}", vec3(c)), loc);
                o.line(format!("radius   = {}", num(r)), loc);
                o.line(format!("material = {material}"), loc);
            }
            "rectangle" | "cube" | "disk" => {
                self.finish(&args, &["to_world", "flip_normals", "bsdf", "emitter"])?;
                let local = match kind {
                    "rectangle" => rectangle_triangles(),
                    "cube" => cube_triangles(),
                    _ => disk_triangles(),
                };
                // Mitsuba's rectangle and disk take their normal through the inverse transpose, so a
                // mirroring to_world (det < 0) keeps it on the side that +z maps to, while the winding of
                // the mirrored vertices turns to the other side: reverse it to keep the emitting side.
                // (The cube is a mesh there, whose normals follow the winding.)
                let det = DMat3::from_mat4(m).determinant();
                let reverse = (det < 0.0 && kind != "cube") != flip.is_some_and(|(f, _)| f);
                let o = &mut self.out_shapes;
                for [a, b, c] in local {
                    let [a, b, c] = [a, b, c].map(|p| m.transform_point3(p));
                    let (b, c) = if reverse { (c, b) } else { (b, c) };
                    o.line("", None);
                    o.line("[[triangle]]", loc);
                    o.line(
                        format!("vertices = [{}, {}, {}]", vec3(a), vec3(b), vec3(c)),
                        loc,
                    );
                    o.line(format!("material = {material}"), loc);
                }
            }
            _ => {
                let Some((name, floc)) = args.string("filename")? else {
                    return Err(obj.loc.error(
                        format!("a {kind} shape needs a filename"),
                        "Give <string name=\"filename\" value=\"mesh.obj\"/>.",
                    ));
                };
                let file = self.file(name, floc);
                let face_normals = args.boolean("face_normals")?.is_some_and(|(f, _)| f);
                if let Some((true, l)) = flip {
                    return Err(l.error(
                        "flip_normals on a mesh: vkpath's [[mesh]] keeps the file's winding",
                        "Reverse the faces in the mesh file instead.",
                    ));
                }
                let flip_uv = args.boolean("flip_tex_coords")?;
                if texture.is_some() {
                    // vkpath's uv (0, 0) is the image's bottom-left corner: Mitsuba's OBJ reader with
                    // flip_tex_coords = true (its default). Its PLY reader does not flip.
                    let flipped = flip_uv.map_or(kind == "obj", |(f, _)| f);
                    if !flipped {
                        return Err(obj.loc.error(
                            "a texture on a mesh whose texture coordinates Mitsuba does not flip (a PLY, or flip_tex_coords = false): vkpath's uv (0, 0) is the image's bottom-left corner",
                            "Use an OBJ with flip_tex_coords true (the default).",
                        ));
                    }
                }
                self.finish(
                    &args,
                    &[
                        "filename",
                        "face_normals",
                        "flip_tex_coords",
                        "to_world",
                        "flip_normals",
                        "bsdf",
                        "emitter",
                    ],
                )?;
                let (scale, rotate, translate) = placement(&m).ok_or_else(|| {
                    xf_loc.error(
                        "the mesh's to_world is not a uniform scale, rotation and translation (it scales unevenly, shears or mirrors)",
                        "vkpath places a [[mesh]] by a uniform scale, a rotation and a translation: bake other transforms into the mesh file.",
                    )
                })?;
                let file_ref = self.refer(&file);
                let texture_ref = texture.as_ref().map(|(t, l)| (self.refer(t), l));
                let o = &mut self.out_shapes;
                o.line("", None);
                o.line("[[mesh]]", loc);
                o.line(format!("obj       = {file_ref}"), Some(floc));
                o.line(format!("material  = {material}"), loc);
                o.line(format!("scale     = {}", num(scale)), Some(&xf_loc));
                o.line(format!("rotate    = {}", vec3(rotate)), Some(&xf_loc));
                o.line(format!("translate = {}", vec3(translate)), Some(&xf_loc));
                o.line(format!("smooth    = {}", !face_normals), loc);
                if let Some((t, tloc)) = texture_ref {
                    o.line(format!("texture   = {t}"), Some(tloc));
                }
            }
        }
        Ok(())
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

/// Mitsuba's named indices of refraction (Hecht, Optics; Mitsuba 3's ior table).
const IOR_TABLE: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

fn named_ior(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    IOR_TABLE.iter().find(|(n, _)| *n == lower).map(|(_, v)| *v)
}

/// A transform's uniform scale as (centre, radius) of the unit sphere it maps: None unless its 3 x 3 part
/// is a rotation (or reflection) times one positive scale.
fn similarity(m: &DMat4) -> Option<(DVec3, f64)> {
    let (x, y, z) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    let s = x.length();
    let ok = s > 0.0
        && s.is_finite()
        && (y.length() - s).abs() <= ORTHO_TOL * s
        && (z.length() - s).abs() <= ORTHO_TOL * s
        && x.dot(y).abs() <= ORTHO_TOL * s * s
        && x.dot(z).abs() <= ORTHO_TOL * s * s
        && y.dot(z).abs() <= ORTHO_TOL * s * s
        && m.row(3).abs_diff_eq(DVec4::W, 1e-9);
    ok.then(|| (m.w_axis.truncate(), s))
}

/// A mesh transform as vkpath's [[mesh]] placement: p -> R (s p) + t with R = Rz(c) Ry(b) Rx(a) (degrees
/// about x, then y, then z). From R = M3 / s (a proper rotation):
/// R = [[cb cc, sa sb cc - ca sc, ca sb cc + sa sc], [cb sc, sa sb sc + ca cc, ca sb sc - sa cc],
///      [-sb, sa cb, ca cb]], so b = asin(-R20), a = atan2(R21, R22), c = atan2(R10, R00); at the gimbal
/// lock (cb = 0) only a - c (or a + c) is defined: a = 0, c = atan2(-R01, R11).
fn placement(m: &DMat4) -> Option<(f64, DVec3, DVec3)> {
    let (_, s) = similarity(m)?;
    let r = DMat3::from_mat4(*m) / s;
    if r.determinant() < 0.0 {
        return None;
    }
    // glam's DMat3 is column-major: r.col(j)[i] is row i, column j.
    let e = |i: usize, j: usize| r.col(j)[i];
    let sb = (-e(2, 0)).clamp(-1.0, 1.0);
    let b = sb.asin();
    let (a, c) = if sb.abs() < 1.0 - 1e-9 {
        (e(2, 1).atan2(e(2, 2)), e(1, 0).atan2(e(0, 0)))
    } else {
        (0.0, (-e(0, 1)).atan2(e(1, 1)))
    };
    Some((
        s,
        DVec3::new(a.to_degrees(), b.to_degrees(), c.to_degrees()),
        m.w_axis.truncate(),
    ))
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

/// Mitsuba's rectangle: [-1, 1]^2 at z = 0, normal +z, as two counter-clockwise triangles.
fn rectangle_triangles() -> Vec<[DVec3; 3]> {
    let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    vec![
        [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
        [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
    ]
}

/// Mitsuba's cube: [-1, 1]^3, 12 triangles wound counter-clockwise seen from outside.
fn cube_triangles() -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    // Each face: its outward axis n and two axes u, v with u x v = n; corners c +- u +- v.
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            let mut u = DVec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let q = |a: f64, b: f64| n + a * u + b * v;
            out.push([q(-1.0, -1.0), q(1.0, -1.0), q(1.0, 1.0)]);
            out.push([q(-1.0, -1.0), q(1.0, 1.0), q(-1.0, 1.0)]);
        }
    }
    out
}

/// Mitsuba's disk (the unit disk at z = 0, normal +z) as a fan of [`DISK_SEGMENTS`] triangles: a regular
/// N-gon whose area equals the disk's. An N-gon of circumradius R has area (N / 2) R^2 sin(2 pi / N), so
/// R = sqrt(2 pi / (N sin(2 pi / N))) = 1.000803 for N = 64: the emitted power and the area are exact,
/// and the outline stays within 0.08% of the unit circle (vertices 0.08% outside, edge midpoints
/// R cos(pi / N) = 0.99960, 0.04% inside).
fn disk_triangles() -> Vec<[DVec3; 3]> {
    let n = DISK_SEGMENTS as f64;
    let tau = std::f64::consts::TAU;
    let r = (tau / (n * (tau / n).sin())).sqrt();
    let at = |k: usize| {
        let phi = tau * k as f64 / n;
        DVec3::new(r * phi.cos(), r * phi.sin(), 0.0)
    };
    (0..DISK_SEGMENTS)
        .map(|k| [DVec3::ZERO, at(k), at((k + 1) % DISK_SEGMENTS)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_upgrade_as_mitsuba() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("maxDepth"), "max_depth");
        assert_eq!(snake_case("radius"), "radius");
    }

    #[test]
    fn placement_recovers_euler_angles() {
        let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
            * DMat4::from_rotation_z(0.3)
            * DMat4::from_rotation_y(-0.4)
            * DMat4::from_rotation_x(1.1)
            * DMat4::from_scale(DVec3::splat(2.0));
        let (s, r, t) = placement(&m).unwrap();
        assert!((s - 2.0).abs() < 1e-12);
        assert!((r - DVec3::new(1.1, -0.4, 0.3) * (180.0 / std::f64::consts::PI)).length() < 1e-9);
        assert!((t - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!(placement(&DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0))).is_none());
        assert!(placement(&DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).is_none());
    }

    #[test]
    fn the_disk_polygon_has_the_disk_area_and_faces_z() {
        let area: f64 = disk_triangles()
            .iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a).z / 2.0)
            .sum();
        assert!((area - std::f64::consts::PI).abs() < 1e-12, "{area}");
        for [a, b, c] in cube_triangles() {
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0) > 0.0, "cube faces point outwards");
        }
    }

    #[test]
    fn y_rotation_reads_the_angle() {
        let a = y_rotation(&DMat4::from_rotation_y(90f64.to_radians())).unwrap();
        assert!((a - 90.0).abs() < 1e-9);
        assert!(y_rotation(&DMat4::from_rotation_x(0.3)).is_none());
    }
}
