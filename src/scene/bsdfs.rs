//! The registry of materials (BSDFs): one row per kind, and everything else follows from the rows.
//!
//! A kind is a WGSL file defining six functions (`<name>_sample`, `_eval`, `_pdf`, `_albedo`,
//! `_is_delta`, `_transmits`; the interface is documented in `shaders/bsdfs/common.wgsl`) and its row in
//! [`kinds`]: the built-in kinds of [`BSDFS`] (`shaders/bsdfs/<name>.wgsl`), then one row per material
//! plugin (`crate::materials`: a folder `src/materials/<name>/` with its declaration and its WGSL). From
//! the rows:
//! - the kind's number is its row's index ([`kind`] for the built-in ones, whose Rust `MAT_*` constants
//!   of `kernel::abi` it defines; the WGSL constants are generated with them, so the two cannot disagree);
//! - the kernel's module `bsdf.wgsl` (the six dispatchers, one branch per row) and `bsdf_kinds.wgsl`
//!   (the `MAT_*` constants and the `HAS_*` feature overrides) are generated (`kernel::library`);
//! - each row is a feature of the kernel (`kernel::features`): a scene that uses no material of the kind
//!   gets a kernel without its code, reported under the row's `feature` name;
//! - a plugin ([`Keys::Plugin`]) is read from a scene file by the generic material reader
//!   (`scene::parse`), its parameters checked, textured and packed into the GPU record's parameter block
//!   by their declared types; the kinds marked [`Keys::Builtin`] predate the plugins and keep their own
//!   readers there (their keys have cross-field rules: a conductor's three ways to give its Fresnel, a
//!   dielectric that is smooth or rough by its roughness) and the record's shared fields.
//!
//! Adding a material: see `crate::materials` (a folder, its docs row, its test).

use crate::materials::{self, MaterialPlugin};
use std::sync::LazyLock;

/// One material kind.
pub struct BsdfKind {
    /// The file `shaders/bsdfs/<name>.wgsl`, the prefix of its six functions, and (upper-cased) its
    /// `MAT_<NAME>` constant.
    pub name: &'static str,
    /// The file's text.
    pub source: &'static str,
    /// The kernel feature's name in reports (`features_absent`, `vkpath bench specialisation`); its
    /// override is `HAS_<FEATURE>`.
    pub feature: &'static str,
    /// How a scene file gives the material.
    pub keys: Keys,
}

/// How a scene file's `[materials]` entry gives a kind.
#[derive(Clone, Copy)]
pub enum Keys {
    /// Read by its own code in `scene::parse` (`type` is the name there; `dielectric` gives both smooth
    /// and rough glass).
    Builtin,
    /// A material plugin (`crate::materials`): read, checked, packed and textured by its declaration.
    Plugin(&'static MaterialPlugin),
}

/// The built-in kinds. The order is their numbering (`MAT_*`); the plugins' kinds follow ([`kinds`]).
pub const BSDFS: &[BsdfKind] = &[
    BsdfKind {
        name: "diffuse",
        source: include_str!("../../shaders/bsdfs/diffuse.wgsl"),
        feature: "diffuse",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "mirror",
        source: include_str!("../../shaders/bsdfs/mirror.wgsl"),
        feature: "mirror",
        keys: Keys::Builtin,
    },
    BsdfKind {
        // Smooth glass; `type = "dielectric"` with a roughness is the rough kind below.
        name: "dielectric",
        source: include_str!("../../shaders/bsdfs/dielectric.wgsl"),
        feature: "dielectric",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "emitter",
        source: include_str!("../../shaders/bsdfs/emitter.wgsl"),
        feature: "emitters",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "conductor",
        source: include_str!("../../shaders/bsdfs/conductor.wgsl"),
        feature: "conductor",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "rough_dielectric",
        source: include_str!("../../shaders/bsdfs/rough_dielectric.wgsl"),
        feature: "rough_dielectric",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "plastic",
        source: include_str!("../../shaders/bsdfs/plastic.wgsl"),
        feature: "plastic",
        keys: Keys::Builtin,
    },
    BsdfKind {
        name: "metallic_roughness",
        source: include_str!("../../shaders/bsdfs/metallic_roughness.wgsl"),
        feature: "metallic_roughness",
        keys: Keys::Builtin,
    },
    BsdfKind {
        // metallic_roughness with the Khronos PBR extensions' layers (`scene::GltfLayers`): read by the
        // metallic_roughness reader, uploaded as this kind when a layer is present.
        name: "gltf_pbr",
        source: include_str!("../../shaders/bsdfs/gltf_pbr.wgsl"),
        feature: "gltf_pbr",
        keys: Keys::Builtin,
    },
    BsdfKind {
        // A thin pane of glass: reflection and straight transmission (Mitsuba's `thindielectric`).
        name: "thin_dielectric",
        source: include_str!("../../shaders/bsdfs/thin_dielectric.wgsl"),
        feature: "thin_dielectric",
        keys: Keys::Builtin,
    },
    BsdfKind {
        // Mitsuba 3's `principled` (Burley's Disney BSDF), its reflecting lobes.
        name: "principled",
        source: include_str!("../../shaders/bsdfs/principled.wgsl"),
        feature: "principled",
        keys: Keys::Builtin,
    },
];

/// Files the kinds' files require that are not kinds themselves (shared code).
pub const SHARED_FILES: &[(&str, &str)] = &[
    (
        "bsdfs/common.wgsl",
        include_str!("../../shaders/bsdfs/common.wgsl"),
    ),
    (
        "bsdfs/coated.wgsl",
        include_str!("../../shaders/bsdfs/coated.wgsl"),
    ),
];

/// Every kind: the built-in ones, then one per material plugin (`crate::materials::PLUGINS`, in their
/// order), whose source is the plugin's file followed by the WGSL generated from its parameters.
pub fn kinds() -> &'static [BsdfKind] {
    static KINDS: LazyLock<Vec<BsdfKind>> = LazyLock::new(|| {
        let plugins = materials::PLUGINS.iter().map(|p| {
            let mut source = p.source.to_string();
            source += &p.wgsl();
            BsdfKind {
                name: p.name,
                // Leaked once: the table lives as long as the program.
                source: source.leak(),
                feature: p.name,
                keys: Keys::Plugin(p),
            }
        });
        BSDFS
            .iter()
            .map(|k| BsdfKind {
                name: k.name,
                source: k.source,
                feature: k.feature,
                keys: k.keys,
            })
            .chain(plugins)
            .collect()
    });
    &KINDS
}

/// The number of a built-in kind named `name` (its row's index), for constants: a name not in the table
/// fails to compile. (A plugin's number is its place in [`kinds`]: [`by_toml_type`].)
pub const fn kind(name: &str) -> u32 {
    let mut i = 0;
    while i < BSDFS.len() {
        if str_eq(BSDFS[i].name, name) {
            return i as u32;
        }
        i += 1;
    }
    panic!("no such material kind in the registry")
}

/// `a == b` in a `const fn` (the registries' [`kind`] lookups; also `kernel::light_kinds`).
pub(crate) const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The plugin kind whose scene-file `type` is `toml_type`, and its number.
pub fn by_toml_type(toml_type: &str) -> Option<(u32, &'static MaterialPlugin)> {
    kinds().iter().enumerate().find_map(|(i, k)| match k.keys {
        Keys::Plugin(p) if p.name == toml_type => Some((i as u32, p)),
        _ => None,
    })
}

/// The plugin of kind number `kind`, if it is one.
pub fn plugin_of(kind: u32) -> Option<&'static MaterialPlugin> {
    match kinds().get(kind as usize)?.keys {
        Keys::Plugin(p) => Some(p),
        Keys::Builtin => None,
    }
}

impl BsdfKind {
    /// `MAT_<NAME>`.
    pub fn constant(&self) -> String {
        format!("MAT_{}", self.name.to_uppercase())
    }

    /// `HAS_<FEATURE>`.
    pub fn feature_constant(&self) -> String {
        format!("HAS_{}", self.feature.to_uppercase())
    }

    /// The library name of its file (a plugin's under `materials/`).
    pub fn file(&self) -> String {
        match self.keys {
            Keys::Builtin => format!("bsdfs/{}.wgsl", self.name),
            Keys::Plugin(_) => format!("materials/{}.wgsl", self.name),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_file_defines_its_six_functions() {
        for k in kinds() {
            for f in ["sample", "eval", "pdf", "albedo", "is_delta", "transmits"] {
                let def = format!("fn {}_{f}(mat: Material", k.name);
                assert!(
                    k.source.contains(&def),
                    "{} does not define `{def}`",
                    k.file()
                );
            }
            let first = k.file();
            let first = first.rsplit('/').next().expect("a name");
            assert!(
                k.source.starts_with(&format!("// {}: ", k.file()))
                    || k.source.starts_with(&format!("// {first}: "))
            );
        }
    }

    #[test]
    fn names_are_unique_and_kinds_are_indices() {
        for (i, k) in BSDFS.iter().enumerate() {
            assert_eq!(kind(k.name), i as u32);
        }
        for k in kinds() {
            assert_eq!(kinds().iter().filter(|o| o.feature == k.feature).count(), 1);
            assert_eq!(kinds().iter().filter(|o| o.name == k.name).count(), 1);
        }
        assert_eq!(
            by_toml_type("rough_diffuse").map(|(i, p)| (i as usize, p.name)),
            Some((BSDFS.len(), "rough_diffuse")),
            "plugins follow the built-in kinds in their folders' order"
        );
        assert!(
            by_toml_type("diffuse").is_none(),
            "a built-in kind has its own reader"
        );
    }
}
