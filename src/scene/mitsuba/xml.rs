//! Reading the XML: [`Parser`] reads the main file and its includes (roxmltree) into the objects of
//! super::objects, with Mitsuba 3's rules for the file format: `<default>` and `$name` substitution in
//! attribute values, `<include>`, `id` and `<ref>`, the value tags, nested `<transform>` operations (each one
//! left-multiplies the transform so far), version 0.x's camelCase names. Anything it does not know is an
//! error (or, with `lenient`, a warning and the element skipped). Plugin types are not interpreted here:
//! that is the translation's.

use super::objects::{Loc, Obj, Prop, SEE_DOCS, Value, Xf, listed};
use super::spectra::spectrum_to_rgb;
use crate::scene::toml_text::absolute;
use crate::scene::{SceneError, read_scene_text};
use glam::{DMat3, DMat4, DVec3};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Mitsuba 3's limit on nested `<include>`s.
const INCLUDE_DEPTH_LIMIT: usize = 15;

/// The most `<include>`s one scene may read in all. The depth limit bounds how deep includes nest, not
/// how wide: 12 files of 8 includes each (3.5 kB on disk) would read 8^11 files. Real scenes include a
/// handful of files; Mitsuba has no such limit.
pub(super) const MAX_INCLUDES: usize = 10_000;

/// The most bytes of XML one scene may read across its main file and every include (each one counted
/// as often as it is included): the limit of one scene file, [`crate::scene::MAX_SCENE_FILE_BYTES`].
const MAX_XML_BYTES: u64 = crate::scene::MAX_SCENE_FILE_BYTES;

/// How much `$name` substitution may add to the attribute values, over the whole scene: this many
/// times the XML read, plus [`EXPANSION_ALLOWANCE`] bytes. A `<default>` that doubles the one before
/// it, 40 times over, would otherwise ask for 2^40 times its text (a 1.5 kB file, a terabyte); a real
/// scene's parameters (sample counts, resolutions, a file name used in a few places) add a few bytes
/// per use.
pub(super) const EXPANSION_FACTOR: u64 = 16;

/// See [`EXPANSION_FACTOR`].
pub(super) const EXPANSION_ALLOWANCE: u64 = 1 << 20;

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

pub(super) struct Parser {
    lenient: bool,
    pub(super) warnings: Vec<String>,
    /// Parameters: the command line's (`-D name=value`) first, then the `<default>`s seen so far; the
    /// first definition of a name wins, as in Mitsuba (whose command line overrides `<default>`).
    params: Vec<(String, String)>,
    /// The command line's parameter names, and whether the file declared or used each: one it never
    /// mentions is a warning (a misspelt `-D` would otherwise change nothing, silently).
    defines: Vec<(String, bool)>,
    pub(super) ids: HashMap<String, Rc<Obj>>,
    /// The files being read, outermost first (canonical paths), to find include cycles.
    chain: Vec<PathBuf>,
    main_dir: PathBuf,
    /// The folders `<path>` elements added, in the order read (searched newest first, before the main
    /// file's folder).
    paths: Vec<PathBuf>,
    /// How many elements deep the walk is (across includes), against [`MAX_XML_DEPTH`].
    depth: usize,
    /// Bytes of XML read so far (main file and includes), against [`MAX_XML_BYTES`].
    read_bytes: u64,
    /// `<include>`s read so far, against [`MAX_INCLUDES`].
    includes: usize,
    /// Bytes `$name` substitution has added so far (see [`EXPANSION_FACTOR`]).
    expanded_bytes: u64,
}

/// The deepest nesting of elements read: the walk recurses once per level, and a hostile file of a few
/// hundred kB could nest tens of thousands of levels and overflow the stack. Real scenes nest a handful
/// (scene > shape > bsdf > bsdf > texture > transform op); Mitsuba has no such limit, and nothing a
/// renderer reads needs more than a few dozen.
pub(super) const MAX_XML_DEPTH: usize = 100;

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
    // roxmltree's tokenizer recurses once per level of nesting: a deep file would overflow the stack
    // inside it, before the walk's own limit is reached. So the depth is measured on the text first.
    if let Some(line) = line_past_depth(text, MAX_XML_DEPTH) {
        return Err(SceneError::at(
            path,
            Some(line),
            None,
            format!("elements nested more than {MAX_XML_DEPTH} deep"),
            "Real scenes nest a few levels (shape, bsdf, texture); this file is damaged or hostile.",
        ));
    }
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

/// The line of the first element opened more than `max` elements deep, if any: a scan of the tags alone
/// (start tags count up unless self-closing, end tags down; comments, CDATA, processing instructions and
/// declarations are skipped, `>` inside quoted attribute values does not end a tag). Malformed text is
/// left to the XML parser, which reports it.
fn line_past_depth(text: &str, max: usize) -> Option<usize> {
    let b = text.as_bytes();
    let skip_past = |from: usize, end: &[u8]| {
        b[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(b.len(), |i| from + i + end.len())
    };
    let (mut i, mut depth) = (0, 0usize);
    while let Some(off) = b[i..].iter().position(|&c| c == b'<') {
        let start = i + off;
        let rest = &b[start + 1..];
        i = if rest.starts_with(b"!--") {
            skip_past(start, b"-->")
        } else if rest.starts_with(b"![CDATA[") {
            skip_past(start, b"]]>")
        } else if rest.starts_with(b"?") {
            skip_past(start, b"?>")
        } else if rest.starts_with(b"!") {
            skip_past(start, b">")
        } else if rest.starts_with(b"/") {
            depth = depth.saturating_sub(1);
            skip_past(start, b">")
        } else {
            // A start tag: find its '>' outside quotes, and whether it closes itself.
            let mut j = start + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j < b.len() && b[j - 1] != b'/' {
                depth += 1;
                if depth > max {
                    return Some(1 + b[..start].iter().filter(|&&c| c == b'\n').count());
                }
            }
            j + 1
        };
        if i >= b.len() {
            break;
        }
    }
    None
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
    /// Where files are looked for after beside the naming file: the `<path>` folders, newest first, then
    /// the main file's folder (Mitsuba's file resolver, which `<path>` prepends to).
    pub(super) fn search_dirs(&self) -> Vec<PathBuf> {
        self.paths
            .iter()
            .rev()
            .cloned()
            .chain(std::iter::once(self.main_dir.clone()))
            .collect()
    }

    /// A parser for a scene whose main file is in `main_dir` (absolute).
    pub(super) fn new(lenient: bool, main_dir: PathBuf, defines: &[(String, String)]) -> Parser {
        let mut params: Vec<(String, String)> = Vec::new();
        for (n, v) in defines {
            if !params.iter().any(|(m, _)| m == n) {
                params.push((n.clone(), v.clone()));
            }
        }
        Parser {
            lenient,
            warnings: Vec::new(),
            defines: params.iter().map(|(n, _)| (n.clone(), false)).collect(),
            params,
            ids: HashMap::new(),
            chain: Vec::new(),
            main_dir,
            paths: Vec::new(),
            depth: 0,
            read_bytes: 0,
            includes: 0,
            expanded_bytes: 0,
        }
    }

    /// The file's parameters with their values (-D first, then the `<default>`s not overridden).
    pub(super) fn parameters(&self) -> &[(String, String)] {
        &self.params
    }

    /// Notes that the file declares or uses parameter `name` (see `defines`).
    fn mention(&mut self, name: &str) {
        if let Some(d) = self.defines.iter_mut().find(|(n, _)| n == name) {
            d.1 = true;
        }
    }

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
        let mut params = self.params.clone();
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
                    let reference = format!("${n}");
                    let uses = value.matches(&reference).count() as u64;
                    if uses == 0 {
                        continue;
                    }
                    self.mention(n);
                    // Counted before the new value is built, so that an expansion bomb is refused
                    // before it allocates.
                    let added = uses * (v.len() as u64).saturating_sub(reference.len() as u64);
                    self.expanded_bytes = self.expanded_bytes.saturating_add(added);
                    let budget = EXPANSION_FACTOR * self.read_bytes + EXPANSION_ALLOWANCE;
                    if self.expanded_bytes > budget {
                        return Err(loc.error(
                            format!(
                                "attribute {name}: substituting ${n} would make the scene's parameters \
                                 add more than {budget} bytes to its {} bytes of XML (at most \
                                 {EXPANSION_FACTOR} times the XML plus {} MiB): a <default> that \
                                 expands itself over and over",
                                self.read_bytes,
                                EXPANSION_ALLOWANCE >> 20
                            ),
                            "Give the <default> values directly instead of building them from one another.",
                        ));
                    }
                    value = value.replace(&reference, v);
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
    pub(super) fn main_file(&mut self, path: &Path) -> Result<Obj, SceneError> {
        let text = read_scene_text(path)?;
        self.read_bytes = text.len() as u64;
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
        // A -D the file neither declares nor uses is a mistake (a misspelt name, another file's
        // parameter): refused naming it, as Mitsuba 3's "Found unused parameters" (cli.md).
        if let Some((name, _)) = self.defines.iter().find(|(_, seen)| !seen) {
            let declared: Vec<&str> = self
                .params
                .iter()
                .map(|(n, _)| n.as_str())
                .filter(|n| self.defines.iter().all(|(d, seen)| d != n || *seen))
                .collect();
            let names = if declared.is_empty() {
                "it declares no parameter".to_string()
            } else {
                format!("it declares {}", declared.join(", "))
            };
            return Err(loc.error(
                format!(
                    "-D {name}=...: the scene has no <default name=\"{name}\"> and no attribute uses ${name}"
                ),
                &format!("Remove -D {name}, or give a name the file uses ({names})."),
            ));
        }
        Ok(Obj {
            tag: "scene".into(),
            kind: "scene".into(),
            loc,
            props,
            legacy: src.upgrade,
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

    /// One element (and, recursively, what it holds), refused past [`MAX_XML_DEPTH`] levels.
    fn element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        if self.depth >= MAX_XML_DEPTH {
            let loc = self.loc(src, node, Self::describe(node));
            return Err(loc.error(
                format!("elements nested more than {MAX_XML_DEPTH} deep"),
                "Real scenes nest a few levels (shape, bsdf, texture); this file is damaged or hostile.",
            ));
        }
        self.depth += 1;
        let read = self.element_at_depth(src, node, out);
        self.depth -= 1;
        read
    }

    fn element_at_depth(
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
                self.mention(name);
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
            "float" | "integer" | "boolean" | "string" => self.number_or_string(src, node, tag, loc, out),
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
            "rgb" => self.rgb_element(src, node, loc, out),
            "spectrum" if node.attribute("type").is_none() => self.spectrum_element(src, node, loc, out),
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
            t if OBJECT_TAGS.contains(&t) || (t == "spectrum") => self.object_element(src, node, tag, loc, out),
            "path" => self.path_element(src, node, loc),
            "alias" => self.unknown(loc, format!("<{tag}> is not read by vkpath")),
            other => self.unknown(loc, format!("<{other}> is not a Mitsuba 3 element vkpath reads")),
        }
    }

    /// `<float>`, `<integer>`, `<boolean>`, `<string>`: a named value.
    fn number_or_string(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        tag: &str,
        loc: Loc,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        let a = self.attrs(src, node, &["name", "value"], &["name", "value"])?;
        let v = a.get("value").unwrap_or("");
        let value = match tag {
            "float" => Value::Float(parse_float(v).ok_or_else(|| {
                loc.error(
                    format!("value=\"{v}\" is not a number"),
                    "Write a decimal number, e.g. value=\"0.5\".",
                )
            })?),
            "integer" => Value::Integer(v.trim().parse().map_err(|_| {
                loc.error(
                    format!("value=\"{v}\" is not an integer"),
                    "Write a whole number, e.g. value=\"64\".",
                )
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

    /// `<rgb>`: a colour, three numbers or one grey.
    fn rgb_element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        loc: Loc,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
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

    /// `<spectrum>` without a type: one number (uniform), wavelength:value pairs or a file of them, as the colour Mitsuba's RGB variants make of it.
    fn spectrum_element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        loc: Loc,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        let a = self.attrs(src, node, &["name", "value", "filename"], &["name"])?;
        let name = a.get("name").unwrap_or("").to_string();
        let v = a.get("value").unwrap_or("");
        let samples = match a.get("filename") {
            Some(_) if a.get("value").is_some() => {
                return Err(loc.error(
                    "a spectrum with both a value and a filename",
                    "Give one of them.",
                ));
            }
            Some(file) => Some(self.spectrum_file(src, file, &loc)?),
            None => None,
        };
        if let Some(x) = parse_float(v).filter(|_| samples.is_none()) {
            out.push(Prop {
                name,
                value: Value::Spectrum(x),
                loc,
            });
            return Ok(());
        }
        // Wavelength:value pairs, as the colour Mitsuba's RGB variants make of them (spectra.rs):
        // bounded (a reflectance) unless inside an emitter or an index of refraction.
        let Some(samples) = samples.or_else(|| spectrum_samples(v)) else {
            return Err(loc.error(
                format!("value=\"{v}\" is neither one number nor wavelength:value pairs in increasing wavelength (nm), two at least"),
                "Write value=\"0.5\" or value=\"400:0.343, 404:0.445, ...\".",
            ));
        };
        let in_emitter = node.parent_element().map(|p| p.tag_name().name()) == Some("emitter");
        let unbounded = in_emitter || ["eta", "k", "int_ior", "ext_ior"].contains(&name.as_str());
        out.push(Prop {
            name,
            value: Value::Rgb(spectrum_to_rgb(&samples, !unbounded)),
            loc,
        });
        Ok(())
    }

    /// A plugin object (`<bsdf>`, `<shape>`, ...): its parameters read, given once each, and its id registered.
    fn object_element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        tag: &str,
        loc: Loc,
        out: &mut Vec<Prop>,
    ) -> Result<(), SceneError> {
        if tag == "spectrum" {
            return self.unknown(
                loc,
                "a <spectrum type=...> plugin: vkpath renders in RGB and reads uniform spectra and wavelength:value lists only".into(),
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
            tag: tag.to_string(),
            kind: a.get("type").unwrap_or("").to_string(),
            loc: loc.clone(),
            props,
            legacy: src.upgrade,
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

    /// `<path>`: a folder added to where files are looked for, relative to the file that names it.
    fn path_element(
        &mut self,
        src: &Src,
        node: roxmltree::Node,
        loc: Loc,
    ) -> Result<(), SceneError> {
        // Mitsuba's file resolver gains a folder: relative to the file that names it.
        let a = self.attrs(src, node, &["value"], &["value"])?;
        let value = a.get("value").unwrap_or("");
        let p = Path::new(value);
        let dir = if p.is_absolute() {
            p.to_path_buf()
        } else {
            absolute(
                &absolute(&src.file)
                    .parent()
                    .unwrap_or(Path::new(""))
                    .join(p),
            )
        };
        if !dir.is_dir() {
            return Err(loc.error(
                format!("the <path> folder \"{value}\" does not exist ({})", dir.display()),
                "A <path> adds a folder to search for files; it is relative to the file that names it.",
            ));
        }
        self.paths.push(dir);
        Ok(())
    }

    /// The file `name` names from `src`, found as Mitsuba's file resolver finds it ([`resolve`]), or an
    /// error at `loc` saying that the `what` was not found and where it was looked for.
    fn find_file(
        &self,
        src: &Src,
        name: &str,
        loc: &Loc,
        what: &str,
        hint: &str,
    ) -> Result<PathBuf, SceneError> {
        resolve(name, &src.file, &self.search_dirs()).ok_or_else(|| {
            loc.error(
                format!(
                    "the {what} \"{name}\" was not found (looked beside {} and in {})",
                    src.file.display(),
                    listed_dirs(&self.search_dirs())
                ),
                hint,
            )
        })
    }

    /// `<spectrum filename="...">`: a spectral data file as Mitsuba 3 reads one (`spectrum_from_file`):
    /// one `wavelength value` pair a line (nm; white space between), empty lines and lines starting with
    /// `#` skipped, anything more on a line an error; here also in increasing wavelength, two pairs at
    /// least, as a `value` list must be. Found as an include is (beside the naming file, then the `<path>`
    /// folders and the main file's); read under the scene-file size limit.
    fn spectrum_file(
        &self,
        src: &Src,
        name: &str,
        loc: &Loc,
    ) -> Result<Vec<(f64, f64)>, SceneError> {
        let path = self.find_file(
            src,
            name,
            loc,
            "spectrum file",
            "Check the filename: it is relative to the file that names it.",
        )?;
        let text = read_named(&path, loc, "spectrum file", "Check the filename.")?;
        let bad = |line: usize, why: String| {
            loc.error(
                format!("{}, line {line}: {why}", path.display()),
                "A spectrum file holds one \"wavelength value\" pair a line (nm), in increasing \
                 wavelength; lines starting with # are comments.",
            )
        };
        let mut pairs: Vec<(f64, f64)> = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let t = line.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let words: Vec<&str> = t.split_whitespace().collect();
            let [l, v] = words[..] else {
                return Err(bad(
                    i + 1,
                    format!("\"{t}\" is not one wavelength and one value"),
                ));
            };
            let (Some(l), Some(v)) = (parse_float(l), parse_float(v)) else {
                return Err(bad(i + 1, format!("\"{t}\" is not two numbers")));
            };
            if pairs.last().is_some_and(|p| p.0 >= l) {
                return Err(bad(i + 1, format!("the wavelength {l} does not increase")));
            }
            pairs.push((l, v));
        }
        if pairs.len() < 2 {
            return Err(bad(
                text.lines().count(),
                "it holds fewer than two wavelength-value pairs".into(),
            ));
        }
        Ok(pairs)
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
        let target = self.find_file(
            src,
            name,
            &loc,
            "included file",
            "Check the include's filename: it is relative to the including file.",
        )?;
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
        self.includes += 1;
        if self.includes > MAX_INCLUDES {
            return Err(loc.error(
                format!(
                    "the scene reads more than {MAX_INCLUDES} <include>s in all (files including one \
                     another many times over)"
                ),
                "Include each file once; to use an object in many places, give it an id and <ref> it.",
            ));
        }
        let text = read_named(
            &target,
            &loc,
            "included file",
            "Check the include's filename.",
        )?;
        self.read_bytes += text.len() as u64;
        if self.read_bytes > MAX_XML_BYTES {
            return Err(loc.error(
                format!(
                    "the scene's XML, with {} and every include counted each time it is included, \
                     exceeds {} MiB",
                    target.display(),
                    MAX_XML_BYTES >> 20
                ),
                "Include each file once; large geometry belongs in mesh files (.ply, .obj).",
            ));
        }
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
                            // Sixteen (or nine) entries of which one is not a finite number: say which.
                            let tokens: Vec<&str> = v
                                .split(|c: char| c == ',' || c.is_whitespace())
                                .filter(|t| !t.is_empty())
                                .collect();
                            let bad = tokens.iter().find(|t| parse_float(t).is_none());
                            return Err(match bad {
                                Some(t) if tokens.len() == 16 || tokens.len() == 9 => loc.error(
                                    format!(
                                        "a <matrix> entry \"{t}\" is not a finite number (of its {} entries)",
                                        tokens.len()
                                    ),
                                    "Write every entry as a finite decimal number.",
                                ),
                                _ => loc.error(
                                    format!(
                                        "a <matrix> value must be 16 numbers (or 9), row by row; it has {} entries",
                                        tokens.len()
                                    ),
                                    "Write value=\"m00 m01 m02 m03 m10 ... m33\".",
                                ),
                            });
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
pub(super) fn parse_float(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// A spectrum's `value` as (wavelength, value) pairs: `l:v` separated by commas or spaces, in
/// increasing wavelength, two at least; None otherwise.
fn spectrum_samples(s: &str) -> Option<Vec<(f64, f64)>> {
    let pairs: Option<Vec<(f64, f64)>> = s
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            let (l, v) = t.split_once(':')?;
            Some((parse_float(l)?, parse_float(v)?))
        })
        .collect();
    let pairs = pairs?;
    (pairs.len() >= 2 && pairs.windows(2).all(|w| w[0].0 < w[1].0)).then_some(pairs)
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

/// The text of the `what` at `path` (under the scene-file size limit), or an error at `loc`.
fn read_named(path: &Path, loc: &Loc, what: &str, hint: &str) -> Result<String, SceneError> {
    read_scene_text(path).map_err(|e| {
        loc.error(
            format!("the {what} {} cannot be read: {e}", path.display()),
            hint,
        )
    })
}

/// A file named in `file`: absolute as given, else beside `file`, else in the first of `dirs` (the
/// `<path>` folders, newest first, then the main file's folder: Parser::search_dirs) where it exists.
/// None when none has it.
pub(super) fn resolve(name: &str, file: &Path, dirs: &[PathBuf]) -> Option<PathBuf> {
    let p = Path::new(name);
    if name.is_empty() {
        return None;
    }
    if p.is_absolute() {
        return p.exists().then(|| p.to_path_buf());
    }
    let beside = absolute(file).parent().map(|d| d.join(p));
    std::iter::once(beside)
        .chain(dirs.iter().map(|d| Some(d.join(p))))
        .flatten()
        .map(|c| absolute(&c))
        .find(|c| c.exists())
}

/// Folders for a message: "a, b and c".
fn listed_dirs(dirs: &[PathBuf]) -> String {
    let shown: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
    match shown.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        Some((last, _)) => last.clone(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nesting_is_measured_on_the_text() {
        let nested = |n: usize| format!("<a>{}{}</a>", "<b x='>'>".repeat(n), "</b>".repeat(n));
        assert_eq!(line_past_depth(&nested(99), 100), None);
        assert_eq!(line_past_depth(&nested(100), 100), Some(1));
        // Self-closing tags, comments, CDATA and declarations do not count.
        let flat = format!(
            "<?xml version='1.0'?>\n<!DOCTYPE x>\n<a>{}<!-- <b> <b> -->\n<![CDATA[<b><b>]]></a>",
            "<b/>".repeat(500)
        );
        assert_eq!(line_past_depth(&flat, 2), None);
        let deep = format!("<a>\n<b>\n<c>{}", "</c></b></a>");
        assert_eq!(line_past_depth(&deep, 2), Some(3));
    }

    #[test]
    fn camel_case_names_upgrade_as_mitsuba() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("maxDepth"), "max_depth");
        assert_eq!(snake_case("radius"), "radius");
    }
}
