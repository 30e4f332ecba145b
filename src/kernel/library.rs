//! The WGSL library: every shader file, and how a kernel's source is assembled from what it declares.
//!
//! WGSL has no `#include`. Each file says what it needs in a header line
//! `// requires: a.wgsl, b.wgsl` (or `// requires: (nothing)`), and [`assemble`] concatenates the closure
//! of a kernel's requirements, each file once, every file after the files it requires (WGSL does not
//! care about the order of module-scope declarations, so the order only makes the source readable). The
//! production kernel (`trace.wgsl`) and every test kernel are assembled the same way from the same files:
//! a test of `intersect_sphere` tests exactly the code that renders, and no list of modules is written
//! out anywhere else.

use super::light_kinds;
use crate::scene::bsdfs;
use std::collections::HashSet;
use std::sync::LazyLock;

/// Every file of the library, by the name `requires` lines use.
pub const MODULES: &[(&str, &str)] = &[
    ("features.wgsl", include_str!("../../shaders/features.wgsl")),
    ("rng.wgsl", include_str!("../../shaders/rng.wgsl")),
    ("sampling.wgsl", include_str!("../../shaders/sampling.wgsl")),
    (
        "intersect.wgsl",
        include_str!("../../shaders/intersect.wgsl"),
    ),
    (
        "microfacet.wgsl",
        include_str!("../../shaders/microfacet.wgsl"),
    ),
    ("camera.wgsl", include_str!("../../shaders/camera.wgsl")),
    (
        "accumulate.wgsl",
        include_str!("../../shaders/accumulate.wgsl"),
    ),
    (
        "scene_data.wgsl",
        include_str!("../../shaders/scene_data.wgsl"),
    ),
    ("bvh.wgsl", include_str!("../../shaders/bvh.wgsl")),
    ("texture.wgsl", include_str!("../../shaders/texture.wgsl")),
    ("opacity.wgsl", include_str!("../../shaders/opacity.wgsl")),
    ("scene.wgsl", include_str!("../../shaders/scene.wgsl")),
    ("trace.wgsl", include_str!("../../shaders/trace.wgsl")),
    ("splat.wgsl", include_str!("../../shaders/splat.wgsl")),
    (
        "bench/trimmed_diffuse_point.wgsl",
        include_str!("../../shaders/bench/trimmed_diffuse_point.wgsl"),
    ),
];

/// The modules generated from the registries: from the material registry (`scene::bsdfs`),
/// `bsdf_kinds.wgsl` (the kinds' numbers and feature constants) and `bsdf.wgsl` (the dispatchers the
/// integrator calls); from the light registry (`kernel::light_kinds`), `light_kinds.wgsl` and
/// `lights.wgsl`, likewise.
pub const BSDF_KINDS: &str = "bsdf_kinds.wgsl";
pub const BSDF: &str = "bsdf.wgsl";
pub const LIGHT_KINDS: &str = "light_kinds.wgsl";
pub const LIGHTS: &str = "lights.wgsl";
/// Generated from the material plugins (`crate::materials`): the texturing of their textured parameters.
pub const PLUGIN_TEXTURES: &str = "plugin_textures.wgsl";

/// A generated dispatcher: its name and signature, the kind function's suffix and arguments, and the
/// value when no kind matched.
type Dispatcher = (&'static str, &'static str, &'static str, &'static str);

/// The six functions every material file defines, as the dispatchers call them. A kind the kernel has
/// no code for absorbs, is black and is a "delta" (nothing for next-event estimation).
const BSDF_DISPATCHERS: &[Dispatcher] = &[
    (
        "bsdf_sample(mat: Material, wo: vec3<f32>, sh: Shading, rng: ptr<function, Rng>) -> BsdfSample",
        "sample(mat, wo, sh, rng)",
        "BsdfSample",
        "bsdf_absorbed()",
    ),
    (
        "bsdf_eval(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> vec3<f32>",
        "eval(mat, wo, wi, sh)",
        "vec3<f32>",
        "vec3<f32>(0.0)",
    ),
    (
        "bsdf_pdf(mat: Material, wo: vec3<f32>, wi: vec3<f32>, sh: Shading) -> f32",
        "pdf(mat, wo, wi, sh)",
        "f32",
        "0.0",
    ),
    (
        "bsdf_albedo(mat: Material) -> vec3<f32>",
        "albedo(mat)",
        "vec3<f32>",
        "vec3<f32>(0.0)",
    ),
    (
        "bsdf_is_delta(mat: Material) -> bool",
        "is_delta(mat)",
        "bool",
        "true",
    ),
    (
        "bsdf_transmits(mat: Material) -> bool",
        "transmits(mat)",
        "bool",
        "false",
    ),
];

/// The three functions every light file defines (lights/common.wgsl documents them). A kind the kernel
/// has no code for gives no sample, density 0 and no radiance.
const LIGHT_DISPATCHERS: &[Dispatcher] = &[
    (
        "light_sample_li(light: Light, p: vec3<f32>, strategy: u32, rng: ptr<function, Rng>) -> LightLiSample",
        "light_sample_li(light, p, strategy, rng)",
        "LightLiSample",
        "no_light_sample()",
    ),
    (
        "light_pdf_li(light: Light, p: vec3<f32>, wi: vec3<f32>, strategy: u32) -> f32",
        "light_pdf_li(light, p, wi, strategy)",
        "f32",
        "0.0",
    ),
    (
        "light_radiance(light: Light, w: vec3<f32>) -> vec3<f32>",
        "light_radiance(light, w)",
        "vec3<f32>",
        "vec3<f32>(0.0)",
    ),
];

/// One registry row as the generators see it: its name (the prefix of its functions), its `MAT_*` or
/// `LIGHT_*` constant, its `HAS_*` override and its file.
struct Row {
    name: &'static str,
    constant: String,
    feature_constant: String,
    file: String,
}

fn bsdf_rows() -> Vec<Row> {
    let row = |k: &bsdfs::BsdfKind| Row {
        name: k.name,
        constant: k.constant(),
        feature_constant: k.feature_constant(),
        file: k.file(),
    };
    bsdfs::kinds().iter().map(row).collect()
}

fn light_rows() -> Vec<Row> {
    let row = |k: &light_kinds::LightKind| Row {
        name: k.name,
        constant: k.constant(),
        feature_constant: k.feature_constant(),
        file: k.file(),
    };
    light_kinds::LIGHTS.iter().map(row).collect()
}

/// The text of a kinds module (`bsdf_kinds.wgsl`, `light_kinds.wgsl`): a constant per row (the row's
/// index) and a `HAS_*` override per row, like those of features.wgsl, set by the feature table
/// (`kernel::features`).
fn generate_kinds(name: &str, registry: &str, rows: &[Row]) -> String {
    let mut out = format!(
        "// {name}, generated from the {registry} by src/kernel/library.rs: each kind's number and its\n\
         // feature constant, an override like those of features.wgsl, set by the feature table\n\
         // (src/kernel/features.rs).\n\
         //\n\
         // requires: (nothing)\n\n",
    );
    for (i, r) in rows.iter().enumerate() {
        out += &format!("const {}: u32 = {i}u;\n", r.constant);
    }
    out += "\n";
    for r in rows {
        out += &format!("override {}: bool = true;\n", r.feature_constant);
    }
    out
}

/// The text of a dispatch module (`bsdf.wgsl`, `lights.wgsl`): each dispatcher a branch per row under
/// the row's feature constant, so that a kernel specialised for a scene keeps only the kinds the scene
/// uses; with one kind (`single`: SINGLE_MATERIAL_KIND, SINGLE_LIGHT_KIND) the kind test goes too. Each
/// dispatcher has one exit: on lavapipe, whose invocations run as SIMD lanes, a return inside a branch
/// costs mask bookkeeping at every later statement.
fn generate_dispatchers(
    header: &str,
    requires: &[String],
    dispatchers: &[Dispatcher],
    rows: &[Row],
    kind_of: &str,
    single: &str,
) -> String {
    let mut out = format!("{header}//\n// requires: {}\n", requires.join(", "));
    for (signature, call, ty, none) in dispatchers {
        out += &format!("\nfn {signature} {{\n    var r: {ty} = {none};\n");
        for r in rows {
            out += &format!(
                "    if {} {{\n        if {single} || {kind_of} == {} {{\n            r = {}_{call};\n        }}\n    }}\n",
                r.feature_constant, r.constant, r.name
            );
        }
        out += "    return r;\n}\n";
    }
    out
}

/// The text of `bsdf.wgsl`.
fn generate_bsdf() -> String {
    let rows = bsdf_rows();
    let mut requires = vec!["features.wgsl".to_string(), BSDF_KINDS.to_string()];
    requires.extend(rows.iter().map(|r| r.file.clone()));
    generate_dispatchers(
        "// bsdf.wgsl, generated from the material registry (src/scene/bsdfs.rs) by src/kernel/library.rs:\n\
         // the interface the integrator calls (bsdf_sample, bsdf_eval, bsdf_pdf, bsdf_albedo, bsdf_is_delta,\n\
         // bsdf_transmits), each a branch per material kind calling the kind's own function\n\
         // (shaders/bsdfs/<kind>.wgsl; the interface is documented in bsdfs/common.wgsl).\n",
        &requires,
        BSDF_DISPATCHERS,
        &rows,
        "mat.kind",
        "SINGLE_MATERIAL_KIND",
    )
}

/// The text of `lights.wgsl`.
fn generate_lights() -> String {
    let rows = light_rows();
    let mut requires = vec![
        "features.wgsl".to_string(),
        LIGHT_KINDS.to_string(),
        "lights/common.wgsl".to_string(),
    ];
    requires.extend(rows.iter().map(|r| r.file.clone()));
    generate_dispatchers(
        "// lights.wgsl, generated from the light registry (src/kernel/light_kinds.rs) by\n\
         // src/kernel/library.rs: the interface the integrator calls (light_sample_li, light_pdf_li,\n\
         // light_radiance: pbrt-v4's SampleLi, PDF_Li and L), each a branch per light kind calling the\n\
         // kind's own function (shaders/lights/<kind>.wgsl; the interface is documented in\n\
         // lights/common.wgsl).\n",
        &requires,
        LIGHT_DISPATCHERS,
        &rows,
        "light.kind",
        "SINGLE_LIGHT_KIND",
    )
}

/// The text of `plugin_textures.wgsl`: `plugin_textured(mat, uv)`, which `textured_material`
/// (scene.wgsl) calls, a branch per plugin kind with textured parameters, and each such kind's
/// `<kind>_textured` (`MaterialPlugin::wgsl_textured`).
fn generate_plugin_textures() -> String {
    let textured: Vec<(&bsdfs::BsdfKind, String)> = bsdfs::kinds()
        .iter()
        .filter_map(|k| match k.keys {
            bsdfs::Keys::Plugin(p) => p.wgsl_textured().map(|f| (k, f)),
            bsdfs::Keys::Builtin => None,
        })
        .collect();
    let mut requires = vec![
        "features.wgsl".to_string(),
        BSDF_KINDS.to_string(),
        "texture.wgsl".to_string(),
    ];
    requires.extend(textured.iter().map(|(k, _)| k.file()));
    let mut out = format!(
        "// plugin_textures.wgsl, generated from the material plugins (src/materials) by src/kernel/library.rs:\n\
         // a plugin material's textured parameters at a hit, each the constant times the texture's value.\n\
         //\n// requires: {}\n\nfn plugin_textured(mat: Material, uv: vec2<f32>) -> Material {{\n    var m = mat;\n",
        requires.join(", ")
    );
    for (k, _) in &textured {
        out += &format!(
            "    if {} {{\n        if mat.kind == {} {{\n            m = {}_textured(mat, uv);\n        }}\n    }}\n",
            k.feature_constant(),
            k.constant(),
            k.name
        );
    }
    out += "    return m;\n}\n";
    for (_, f) in &textured {
        out += "\n";
        out += f;
    }
    out
}

static GENERATED: LazyLock<[(&str, String); 5]> = LazyLock::new(|| {
    [
        (
            BSDF_KINDS,
            generate_kinds(
                BSDF_KINDS,
                "material registry (src/scene/bsdfs.rs)",
                &bsdf_rows(),
            ),
        ),
        (BSDF, generate_bsdf()),
        (
            LIGHT_KINDS,
            generate_kinds(
                LIGHT_KINDS,
                "light registry (src/kernel/light_kinds.rs)",
                &light_rows(),
            ),
        ),
        (LIGHTS, generate_lights()),
        (PLUGIN_TEXTURES, generate_plugin_textures()),
    ]
});

/// The production kernel's root file.
pub const TRACE: &str = "trace.wgsl";

/// A kernel written by hand for diffuse spheres and point lights only: the bound that specialisation is
/// measured against (`vkpath bench specialisation`).
pub const TRIMMED_DIFFUSE_POINT: &str = "bench/trimmed_diffuse_point.wgsl";

/// The text of a library file: a file of `shaders/`, a material's (`scene::bsdfs`), a light's
/// (`kernel::light_kinds`), or a generated one.
pub fn module(name: &str) -> Option<&'static str> {
    let file = MODULES
        .iter()
        .chain(bsdfs::SHARED_FILES)
        .chain(light_kinds::SHARED_FILES)
        .find(|(n, _)| *n == name);
    let kind = || {
        let bsdf = bsdfs::kinds().iter().find(|k| k.file() == name);
        let light = || light_kinds::LIGHTS.iter().find(|k| k.file() == name);
        bsdf.map(|k| k.source).or_else(|| light().map(|k| k.source))
    };
    let generated = || {
        GENERATED
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| t.as_str())
    };
    file.map(|(_, t)| *t).or_else(kind).or_else(generated)
}

/// Every library file's name and text, generated ones included.
pub fn all_modules() -> Vec<(String, &'static str)> {
    let mut all: Vec<(String, &'static str)> = MODULES
        .iter()
        .chain(bsdfs::SHARED_FILES)
        .chain(light_kinds::SHARED_FILES)
        .map(|(n, t)| (n.to_string(), *t))
        .collect();
    all.extend(bsdfs::kinds().iter().map(|k| (k.file(), k.source)));
    all.extend(light_kinds::LIGHTS.iter().map(|k| (k.file(), k.source)));
    all.extend(GENERATED.iter().map(|(n, t)| (n.to_string(), t.as_str())));
    all
}

/// The files a WGSL text declares it requires, in the order written.
pub fn requirements(text: &str) -> Vec<&str> {
    text.lines()
        .filter_map(|l| l.trim_start().strip_prefix("// requires:"))
        .flat_map(|rest| rest.split([',', ' ']))
        .map(str::trim)
        .filter(|n| !n.is_empty() && *n != "(nothing)")
        .collect()
}

/// An unknown name in a `requires` line.
#[derive(Debug, thiserror::Error)]
#[error(
    "{file} requires {name}, which is not a file of the shader library (src/kernel/library.rs)"
)]
pub struct UnknownModule {
    pub file: String,
    pub name: String,
}

/// The source of a kernel whose own text is `root` (named `root_name` in the markers): the files it
/// requires, transitively, then `root` itself, each preceded by a `// ---- name ----` line so that naga's
/// messages can be traced back to a file.
pub fn assemble_text(root_name: &str, root: &str) -> Result<String, UnknownModule> {
    fn visit(
        name: &str,
        text: &str,
        seen: &mut HashSet<String>,
        out: &mut String,
    ) -> Result<(), UnknownModule> {
        for dep in requirements(text) {
            if seen.insert(dep.to_string()) {
                let dep_text = module(dep).ok_or_else(|| UnknownModule {
                    file: name.to_string(),
                    name: dep.to_string(),
                })?;
                visit(dep, dep_text, seen, out)?;
                out.push_str(&format!("// ---- {dep} ----\n{dep_text}\n"));
            }
        }
        Ok(())
    }
    let mut seen = HashSet::from([root_name.to_string()]);
    let mut out = String::new();
    visit(root_name, root, &mut seen, &mut out)?;
    out.push_str(&format!("// ---- {root_name} ----\n{root}\n"));
    Ok(out)
}

/// The source of the library file `name` as a kernel (see [`assemble_text`]).
pub fn assemble(name: &str) -> Result<String, UnknownModule> {
    let text = module(name).ok_or_else(|| UnknownModule {
        file: "(kernel root)".into(),
        name: name.to_string(),
    })?;
    assemble_text(name, text)
}

/// The full source of the production kernel.
pub fn trace_source() -> String {
    assemble(TRACE).expect("the library's own requires lines name library files")
}

/// The splat gather's root file (a kernel of its own, run after each pass of a splatted render).
pub const SPLAT: &str = "splat.wgsl";

/// The full source of the splat gather kernel.
pub fn splat_source() -> String {
    assemble(SPLAT).expect("the library's own requires lines name library files")
}

/// The full source of the hand-trimmed benchmark kernel.
pub fn trimmed_source() -> String {
    assemble(TRIMMED_DIFFUSE_POINT).expect("the library's own requires lines name library files")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_module_declares_its_requirements() {
        for (name, text) in all_modules() {
            assert!(
                text.contains("// requires:"),
                "{name} has no `// requires:` line"
            );
            for dep in requirements(text) {
                assert!(module(dep).is_some(), "{name} requires unknown {dep}");
            }
        }
    }

    #[test]
    fn assembly_puts_requirements_first_and_each_once() {
        let src = trace_source();
        let pos = |n: &str| {
            src.find(&format!("// ---- {n} ----"))
                .unwrap_or_else(|| panic!("{n} missing from the trace kernel"))
        };
        assert!(pos("sampling.wgsl") < pos("bsdf.wgsl"));
        assert!(pos("bsdf.wgsl") < pos("scene_data.wgsl"));
        assert!(pos("scene.wgsl") < pos("trace.wgsl"));
        assert_eq!(src.matches("// ---- rng.wgsl ----").count(), 1);
        // The benchmark kernel is not part of the production kernel.
        assert!(!src.contains("// ---- bench/"));
    }

    #[test]
    fn unknown_requirement_is_an_error() {
        let e = assemble_text("t.wgsl", "// requires: nope.wgsl\n").unwrap_err();
        assert_eq!(e.name, "nope.wgsl");
    }
}
