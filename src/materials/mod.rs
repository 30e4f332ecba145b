//! Material plugins: a material kind as one folder, `src/materials/<kind>/`, holding its Rust module
//! (`mod.rs`: a [`MaterialPlugin`] named `PLUGIN`, its documented parameters with their types and
//! defaults) and its WGSL (`<kind>.wgsl`: the six functions of the BSDF interface,
//! shaders/bsdfs/common.wgsl). Nothing else names the kind: `build.rs` finds the folders and lists them
//! in [`PLUGINS`], and everything else follows from the declaration —
//! - the scene file's `[materials]` reader (`scene::parse`) reads `type = "<kind>"` and each parameter
//!   by its type (a colour or number, textured where the type allows, a choice among names, a boolean),
//!   checks it and names the file, line and key of a bad value;
//! - the Mitsuba importer reads `<bsdf type="...">` of the plugin's [`MaterialPlugin::mitsuba`] names,
//!   each parameter by its key (the keys are Mitsuba's), and writes the TOML form;
//! - the GPU record (`kernel::abi::GpuMaterial`) carries the parameters in its per-kind parameter block
//!   (`block`, [`BLOCK_WORDS`] words), laid out by [`MaterialPlugin::layout`];
//! - the WGSL the plugin's functions read the block through is generated ([`MaterialPlugin::wgsl`]): a
//!   struct `<Kind>Params` with a field per parameter by its name, `fn <kind>_params(mat: Material)`,
//!   and for textured parameters `fn <kind>_textured(mat, uv)`, which the hit's texturing calls;
//! - the registry (`scene::bsdfs`), the WGSL dispatchers, the kernel's feature table and the scene
//!   format's key table (docs/scene-format.md, held by a test) take a row per plugin.
//!
//! This is Mitsuba 3's shape (a BSDF is one file with its parameters, documentation and registration)
//! with pbrt-v4's closed dispatch (the kinds are known when the kernel is generated: one branch per
//! kind, none through pointers). The declaration is data, not code, so that the host's reader, the
//! importer and the GPU layout cannot disagree with each other. This module depends on nothing else of
//! the crate: the scene model, the readers and the kernel depend on it.
//!
//! A textured parameter's value at a hit is its constant times the texture's value there (as every
//! textured parameter of vkpath), looked up before the BSDF is called.
//!
//! Adding a material: a folder here with `mod.rs` (its `PLUGIN`) and `<kind>.wgsl`, its row in
//! docs/scene-format.md ("Material plugins"), and its test through the shared BSDF adapter
//! (tests/common/bsdf.rs). `ward` was added that way.

include!(concat!(env!("OUT_DIR"), "/material_plugins.rs"));

/// The words (f32 values) of a material's parameter block: `GpuMaterial::block`,
/// `Material::block` in bsdfs/common.wgsl (four vec4s, for the uniform twin's 16-byte stride).
pub const BLOCK_WORDS: usize = 16;

/// A texture word's value for "no texture". The block holds f32 values only: a texture's index k as the
/// number k (exact below 2^24, more textures than a scene can bind), a choice's index and a boolean
/// likewise, so that no word is a NaN's bit pattern (a block compares equal to itself, and survives
/// any copy that treats it as numbers).
pub const NO_TEXTURE_WORD: f32 = -1.0;

/// One material kind.
pub struct MaterialPlugin {
    /// The scene file's `type`, the prefix of its WGSL functions, its `MAT_<NAME>` constant and its
    /// kernel feature's name.
    pub name: &'static str,
    /// Its WGSL file's text (`<name>.wgsl` in its folder).
    pub source: &'static str,
    /// One sentence: the model and where it comes from (the scene format's section).
    pub summary: &'static str,
    /// The Mitsuba plugin types (`<bsdf type="...">`, any version) read as this kind, each parameter by
    /// its key, with the same defaults. Empty: the importer has its own mapping or none.
    pub mitsuba: &'static [&'static str],
    /// The two parameters (roughness along the tangent, along the bitangent) whose values differ on an
    /// anisotropic material: the kernel then computes a tangent at each hit (`HAS_ANISOTROPY`). `None`:
    /// the kind is isotropic.
    pub anisotropy: Option<(&'static str, &'static str)>,
    /// A rule across parameters, on the values read (one per parameter): the key to blame and the
    /// problem. `None`: each parameter's own range is the whole rule.
    pub check: Option<Check>,
    pub params: &'static [Param],
}

/// A plugin's rule across its parameters ([`MaterialPlugin::check`]).
pub type Check = fn(&[Value]) -> Result<(), (&'static str, String)>;

/// One parameter of a material kind.
pub struct Param {
    /// Its key in the scene file (Mitsuba's name where Mitsuba has the parameter), and its field in
    /// the generated `<Kind>Params`.
    pub key: &'static str,
    pub ty: ParamType,
    /// What it means, with its units: the hint after a bad value, and the scene format's row.
    pub doc: &'static str,
}

/// A parameter's type: how it is read, checked, defaulted, packed and seen in WGSL.
#[derive(Clone, Copy, Debug)]
pub enum ParamType {
    /// A linear RGB colour with components in [0, `max`] (`f32::INFINITY`: any >= 0), or a texture:
    /// `vec3<f32>` in WGSL. `None`: the key is required.
    Color { default: Option<[f32; 3]>, max: f32 },
    /// A number in [`min`, `max`], or (`textured`) a texture: `f32`.
    Float {
        default: Option<f32>,
        min: f32,
        max: f32,
        textured: bool,
    },
    /// One of `options` by name: `u32`, the option's index, with a constant `<KIND>_<KEY>_<OPTION>` per
    /// option.
    Choice {
        options: &'static [&'static str],
        default: &'static str,
    },
    /// `true` or `false`: `bool`.
    Bool { default: bool },
}

impl ParamType {
    /// Words of the block its value takes (not counting a texture's).
    pub fn words(&self) -> usize {
        match self {
            ParamType::Color { .. } => 3,
            _ => 1,
        }
    }

    /// Whether a texture may give it.
    pub fn textured(&self) -> bool {
        match self {
            ParamType::Color { .. } => true,
            ParamType::Float { textured, .. } => *textured,
            _ => false,
        }
    }

    /// The WGSL type of its field.
    fn wgsl_type(&self) -> &'static str {
        match self {
            ParamType::Color { .. } => "vec3<f32>",
            ParamType::Float { .. } => "f32",
            ParamType::Choice { .. } => "u32",
            ParamType::Bool { .. } => "bool",
        }
    }

    /// How the docs describe the type.
    pub fn describe(&self) -> String {
        let num = |x: f32| {
            if x == f32::INFINITY {
                "inf".to_string()
            } else {
                format!("{x}")
            }
        };
        match self {
            ParamType::Color { max, .. } => {
                format!("colour in [0, {}] or texture", num(*max))
            }
            ParamType::Float {
                min, max, textured, ..
            } => format!(
                "number in [{}, {}]{}",
                num(*min),
                num(*max),
                if *textured { " or texture" } else { "" }
            ),
            ParamType::Choice { options, .. } => {
                let names: Vec<String> = options.iter().map(|o| format!("\"{o}\"")).collect();
                format!("one of {}", names.join(", "))
            }
            ParamType::Bool { .. } => "boolean".to_string(),
        }
    }

    /// Its default as the scene format writes it, or `None` if required.
    pub fn default_text(&self) -> Option<String> {
        match self {
            ParamType::Color { default, .. } => default.map(|[r, g, b]| format!("[{r}, {g}, {b}]")),
            ParamType::Float { default, .. } => default.map(|d| format!("{d}")),
            ParamType::Choice { default, .. } => Some(format!("\"{default}\"")),
            ParamType::Bool { default } => Some(format!("{default}")),
        }
    }
}

/// Where one parameter lives in the block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// The first word of its value.
    pub word: usize,
    /// The word holding its texture's index ([`NO_TEXTURE_WORD`]: none), for a textured type.
    pub texture_word: Option<usize>,
}

/// A parameter's value as read from a scene file, before packing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Color([f32; 3]),
    Float(f32),
    /// The chosen option's index.
    Choice(u32),
    Bool(bool),
}

impl MaterialPlugin {
    /// Each parameter's slot, in the order of [`MaterialPlugin::params`]: its value's words, then its
    /// texture word if the type may be textured.
    pub fn layout(&self) -> Vec<Slot> {
        let mut next = 0;
        self.params
            .iter()
            .map(|p| {
                let word = next;
                next += p.ty.words();
                let texture_word = p.ty.textured().then(|| {
                    next += 1;
                    next - 1
                });
                Slot { word, texture_word }
            })
            .collect()
    }

    /// The words the block uses.
    pub fn block_len(&self) -> usize {
        self.layout()
            .iter()
            .zip(self.params)
            .map(|(s, p)| s.texture_word.map_or(s.word + p.ty.words(), |t| t + 1))
            .max()
            .unwrap_or(0)
    }

    /// The parameter keyed `key`.
    pub fn param(&self, key: &str) -> Option<(usize, &Param)> {
        self.params.iter().enumerate().find(|(_, p)| p.key == key)
    }

    /// The block of `values` (one per parameter, in order, each of its parameter's type, as the reader
    /// gives them; textures none: their words are filled when the textures are uploaded).
    pub fn pack(&self, values: &[Value]) -> [f32; BLOCK_WORDS] {
        let mut block = [0.0; BLOCK_WORDS];
        for (slot, value) in self.layout().iter().zip(values) {
            match *value {
                Value::Color(c) => block[slot.word..slot.word + 3].copy_from_slice(&c),
                Value::Float(x) => block[slot.word] = x,
                Value::Choice(i) => block[slot.word] = i as f32,
                Value::Bool(b) => block[slot.word] = f32::from(u8::from(b)),
            }
            if let Some(t) = slot.texture_word {
                block[t] = NO_TEXTURE_WORD;
            }
        }
        block
    }

    /// The values packed in `block` (the inverse of [`MaterialPlugin::pack`]).
    pub fn unpack(&self, block: &[f32; BLOCK_WORDS]) -> Vec<Value> {
        self.layout()
            .iter()
            .zip(self.params)
            .map(|(slot, p)| {
                let f = |i: usize| block[slot.word + i];
                match p.ty {
                    ParamType::Color { .. } => Value::Color([f(0), f(1), f(2)]),
                    ParamType::Float { .. } => Value::Float(f(0)),
                    ParamType::Choice { .. } => Value::Choice(f(0) as u32),
                    ParamType::Bool { .. } => Value::Bool(f(0) != 0.0),
                }
            })
            .collect()
    }

    /// Whether a material of this kind packed as `block` is anisotropic ([`MaterialPlugin::anisotropy`]):
    /// its two roughnesses differ in value or texture.
    pub fn is_anisotropic(&self, block: &[f32; BLOCK_WORDS]) -> bool {
        let Some((u, v)) = self.anisotropy else {
            return false;
        };
        let layout = self.layout();
        let words = |key: &str| {
            let (i, _) = self.param(key).expect("anisotropy names parameters");
            (
                block[layout[i].word],
                layout[i].texture_word.map(|t| block[t]),
            )
        };
        words(u) != words(v)
    }

    /// `MAT_<NAME>`'s `<NAME>`, and the prefix of the choice constants.
    fn upper(&self) -> String {
        self.name.to_uppercase()
    }

    /// The generated struct's name: `ward` -> `WardParams`, `rough_diffuse` -> `RoughDiffuseParams`.
    pub fn struct_name(&self) -> String {
        let mut out: String = self
            .name
            .split('_')
            .map(|w| {
                let mut c = w.chars();
                c.next()
                    .map(|f| f.to_ascii_uppercase().to_string() + c.as_str())
                    .unwrap_or_default()
            })
            .collect();
        out += "Params";
        out
    }

    /// Whether any parameter may be textured (the kind then has a `<name>_textured` function).
    pub fn has_textures(&self) -> bool {
        self.params.iter().any(|p| p.ty.textured())
    }

    /// The WGSL generated from the declaration: the parameters as a struct, the function that reads it
    /// from the block, the choices' constants, and the texturing of the textured parameters. Appended
    /// to the plugin's own file in the shader library.
    pub fn wgsl(&self) -> String {
        let layout = self.layout();
        let mut out = format!(
            "\n// --- Generated from src/materials/{}/mod.rs (src/materials/mod.rs, MaterialPlugin::wgsl): the\n\
             // kind's parameters, read from its block (Material::block) by name.\n\n",
            self.name
        );
        for p in self.params {
            if let ParamType::Choice { options, .. } = p.ty {
                for (i, o) in options.iter().enumerate() {
                    out += &format!(
                        "const {}_{}_{}: u32 = {i}u;\n",
                        self.upper(),
                        p.key.to_uppercase(),
                        constant_case(o)
                    );
                }
            }
        }
        out += &format!("struct {} {{\n", self.struct_name());
        for p in self.params {
            out += &format!("    {}: {},\n", p.key, p.ty.wgsl_type());
        }
        out += "}\n\n";
        let fields: Vec<String> = self
            .params
            .iter()
            .zip(&layout)
            .map(|(p, s)| match p.ty {
                ParamType::Color { .. } => format!(
                    "vec3<f32>({}, {}, {})",
                    word(s.word),
                    word(s.word + 1),
                    word(s.word + 2)
                ),
                ParamType::Float { .. } => word(s.word),
                ParamType::Choice { .. } => format!("u32({})", word(s.word)),
                ParamType::Bool { .. } => format!("{} != 0.0", word(s.word)),
            })
            .collect();
        out += &format!(
            "fn {}_params(mat: Material) -> {} {{\n    return {}(\n        {},\n    );\n}}\n",
            self.name,
            self.struct_name(),
            self.struct_name(),
            fields.join(",\n        ")
        );
        out
    }

    /// `fn <name>_textured(mat: Material, uv: vec2<f32>) -> Material`: each textured parameter that
    /// has a texture multiplied by the texture's value at `uv`, through one call of texture_lookup in a
    /// loop over the textures present (as `textured_material` in scene.wgsl, for the same reason: each
    /// call site of the lookup is compiled in full). `None` for a kind without textured parameters.
    pub fn wgsl_textured(&self) -> Option<String> {
        let textured: Vec<(&Param, Slot)> = self
            .params
            .iter()
            .zip(self.layout())
            .filter(|(p, _)| p.ty.textured())
            .collect();
        if textured.is_empty() {
            return None;
        }
        let tex = |s: &Slot| word(s.texture_word.expect("textured"));
        let scale = |p: &Param, s: &Slot| match p.ty {
            ParamType::Color { .. } => format!(
                "vec3<f32>({}, {}, {})",
                word(s.word),
                word(s.word + 1),
                word(s.word + 2)
            ),
            _ => format!("vec3<f32>({})", word(s.word)),
        };
        let mut out = format!(
            "// {}'s textured parameters at uv (generated: MaterialPlugin::wgsl_textured, src/materials/mod.rs).\n\
             fn {}_textured(mat: Material, uv: vec2<f32>) -> Material {{\n    var m = mat;\n    var todo = 0u;\n",
            self.name, self.name
        );
        for (i, (_, s)) in textured.iter().enumerate() {
            out += &format!(
                "    todo |= select(0u, {}u, {} >= 0.0);\n",
                1u32 << i,
                tex(s)
            );
        }
        let (p0, s0) = &textured[0];
        out += &format!(
            "    while todo != 0u {{\n        let k = firstTrailingBit(todo);\n        todo &= todo - 1u;\n        \
             var texture = {};\n        var scale = {};\n",
            tex(s0),
            scale(p0, s0)
        );
        for (i, (p, s)) in textured.iter().enumerate().skip(1) {
            out += &format!(
                "        if k == {i}u {{\n            texture = {};\n            scale = {};\n        }}\n",
                tex(s),
                scale(p, s)
            );
        }
        out += "        let value = texture_lookup(u32(texture), uv, scale);\n";
        for (i, (p, s)) in textured.iter().enumerate() {
            let set = match p.ty {
                ParamType::Color { .. } => (0..3)
                    .map(|c| format!("{} = value.{};", word_mut(s.word + c), ["x", "y", "z"][c]))
                    .collect::<Vec<_>>()
                    .join(" "),
                _ => format!("{} = value.x;", word_mut(s.word)),
            };
            out += &format!("        if k == {i}u {{\n            {set}\n        }}\n");
        }
        out += "    }\n    return m;\n}\n";
        Some(out)
    }
}

impl MaterialPlugin {
    /// The kind's section of docs/scene-format.md ("Material plugins"), as the declaration gives it: a
    /// test holds the document to it, so the docs cannot drift from the reader.
    pub fn docs_section(&self) -> String {
        let mut out = format!("### `{}`\n\n{}", self.name, self.summary);
        if !self.mitsuba.is_empty() {
            let names: Vec<String> = self.mitsuba.iter().map(|m| format!("`{m}`")).collect();
            out += &format!(
                " Mitsuba's {} reads as this kind, each parameter by its key.",
                names.join(", ")
            );
        }
        out += "\n\n| key | value | default | meaning |\n| --- | --- | --- | --- |\n";
        for p in self.params {
            out += &format!(
                "| `{}` | {} | {} | {} |\n",
                p.key,
                p.ty.describe(),
                p.ty.default_text()
                    .map_or("required".into(), |d| format!("`{d}`")),
                p.doc
            );
        }
        out
    }
}

/// Word `i` of `mat`'s block, by constant indices (see material_coat in bsdfs/common.wgsl for why
/// constant).
fn word(i: usize) -> String {
    format!("mat.block[{}].{}", i / 4, ["x", "y", "z", "w"][i % 4])
}

/// Word `i` of the block of the `var m` being textured.
fn word_mut(i: usize) -> String {
    format!("m.block[{}].{}", i / 4, ["x", "y", "z", "w"][i % 4])
}

/// An option's name as a constant's suffix: `ward-duer` -> `WARD_DUER`.
fn constant_case(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_uppercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// The plugin whose scene-file `type` is `name`.
pub fn by_name(name: &str) -> Option<&'static MaterialPlugin> {
    PLUGINS.iter().copied().find(|p| p.name == name)
}

/// The plugin that reads Mitsuba's `<bsdf type="mitsuba_type">`.
pub fn by_mitsuba_type(mitsuba_type: &str) -> Option<&'static MaterialPlugin> {
    PLUGINS
        .iter()
        .copied()
        .find(|p| p.mitsuba.contains(&mitsuba_type))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_plugin_fits_its_block_and_names_itself() {
        assert!(!PLUGINS.is_empty(), "build.rs found no plugin folder");
        for p in PLUGINS {
            assert!(
                p.block_len() <= BLOCK_WORDS,
                "{}: {} words",
                p.name,
                p.block_len()
            );
            assert!(
                p.source.starts_with(&format!("// {}.wgsl: ", p.name)),
                "{}.wgsl starts with its name",
                p.name
            );
            for f in ["sample", "eval", "pdf", "albedo", "is_delta", "transmits"] {
                let def = format!("fn {}_{f}(mat: Material", p.name);
                assert!(p.source.contains(&def), "{} lacks `{def}`", p.name);
            }
            let mut keys: Vec<_> = p.params.iter().map(|q| q.key).collect();
            keys.sort();
            keys.dedup();
            assert_eq!(keys.len(), p.params.len(), "{}: keys unique", p.name);
            for q in p.params {
                match q.ty {
                    ParamType::Choice { options, default } => assert!(options.contains(&default)),
                    ParamType::Float {
                        default: Some(d),
                        min,
                        max,
                        ..
                    } => assert!((min..=max).contains(&d), "{}.{}", p.name, q.key),
                    _ => {}
                }
            }
        }
    }

    #[test]
    fn slots_do_not_overlap_and_pack_round_trips() {
        for p in PLUGINS {
            let mut used = [false; BLOCK_WORDS];
            for (s, q) in p.layout().iter().zip(p.params) {
                let words = (s.word..s.word + q.ty.words()).chain(s.texture_word);
                for w in words {
                    assert!(!used[w], "{}: word {w} twice", p.name);
                    used[w] = true;
                }
            }
            let values: Vec<Value> = p
                .params
                .iter()
                .enumerate()
                .map(|(i, q)| match q.ty {
                    ParamType::Color { .. } => Value::Color([i as f32, 0.5, 0.25]),
                    ParamType::Float { .. } => Value::Float(i as f32 + 0.125),
                    ParamType::Choice { options, .. } => Value::Choice(options.len() as u32 - 1),
                    ParamType::Bool { .. } => Value::Bool(true),
                })
                .collect();
            let block = p.pack(&values);
            assert_eq!(p.unpack(&block), values);
            for s in p.layout() {
                if let Some(t) = s.texture_word {
                    assert_eq!(block[t], NO_TEXTURE_WORD);
                }
            }
        }
    }

    #[test]
    fn the_scene_format_documents_every_plugin_as_declared() {
        let doc = include_str!("../../docs/scene-format.md");
        for p in PLUGINS {
            let section = p.docs_section();
            assert!(
                doc.contains(&section),
                "docs/scene-format.md lacks (or differs from) the section of `{}`; it reads:\n\n{section}",
                p.name
            );
            if let Some((u, v)) = p.anisotropy {
                assert!(p.param(u).is_some() && p.param(v).is_some(), "{}", p.name);
            }
        }
    }

    #[test]
    fn generated_names() {
        let p = MaterialPlugin {
            name: "rough_thing",
            source: "",
            summary: "",
            mitsuba: &[],
            anisotropy: None,
            check: None,
            params: &[],
        };
        assert_eq!(p.struct_name(), "RoughThingParams");
        assert_eq!(constant_case("ward-duer"), "WARD_DUER");
        assert_eq!(word(5), "mat.block[1].y");
    }
}
