//! The WGSL library: every shader file, and how a kernel's source is assembled from what it declares.
//!
//! WGSL has no `#include`. Each file says what it needs in a header line
//! `// requires: a.wgsl, b.wgsl` (or `// requires: (nothing)`), and [`assemble`] concatenates the closure
//! of a kernel's requirements, each file once, every file after the files it requires (WGSL does not
//! care about the order of module-scope declarations, so the order only makes the source readable). The
//! production kernel (`trace.wgsl`) and every test kernel are assembled the same way from the same files:
//! a test of `intersect_sphere` tests exactly the code that renders, and no list of modules is written
//! out anywhere else.

use std::collections::HashSet;

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
    ("bsdf.wgsl", include_str!("../../shaders/bsdf.wgsl")),
    ("lights.wgsl", include_str!("../../shaders/lights.wgsl")),
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
    (
        "bench/trimmed_diffuse_point.wgsl",
        include_str!("../../shaders/bench/trimmed_diffuse_point.wgsl"),
    ),
];

/// The production kernel's root file.
pub const TRACE: &str = "trace.wgsl";

/// A kernel written by hand for diffuse spheres and point lights only: the bound that specialisation is
/// measured against (`vkpath bench specialisation`).
pub const TRIMMED_DIFFUSE_POINT: &str = "bench/trimmed_diffuse_point.wgsl";

/// The text of a library file.
pub fn module(name: &str) -> Option<&'static str> {
    MODULES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
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

/// The full source of the hand-trimmed benchmark kernel.
pub fn trimmed_source() -> String {
    assemble(TRIMMED_DIFFUSE_POINT).expect("the library's own requires lines name library files")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_module_declares_its_requirements() {
        for (name, text) in MODULES {
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
