//! The registry of materials (BSDFs): one row per kind, and everything else follows from the rows.
//!
//! A material kind is its WGSL file, `shaders/bsdfs/<name>.wgsl`, which defines six functions
//! (`<name>_sample`, `_eval`, `_pdf`, `_albedo`, `_is_delta`, `_transmits`; the interface is documented
//! in `shaders/bsdfs/common.wgsl`), and its row in [`BSDFS`]. From the table:
//! - the kind's number is its row's index ([`kind`]; the Rust `MAT_*` constants of `kernel::abi` are
//!   defined by it, and the WGSL ones are generated with it, so the two cannot disagree);
//! - the kernel's module `bsdf.wgsl` (the six dispatchers, one branch per row) and `bsdf_kinds.wgsl`
//!   (the `MAT_*` constants and the `HAS_*` feature overrides) are generated (`kernel::library`);
//! - each row is a feature of the kernel (`kernel::features`): a scene that uses no material of the kind
//!   gets a kernel without its code, reported under the row's `feature` name;
//! - a row with [`Keys::Params`] is read from a scene file by the generic material reader
//!   (`scene::parse`), its parameters checked, textured and uploaded by their [`ParamValue`]; the
//!   kinds marked [`Keys::Builtin`] predate the table and keep their own readers there (their keys have
//!   cross-field rules: a conductor's three ways to give its Fresnel, a dielectric that is smooth or
//!   rough by its roughness).
//!
//! Adding a material: the WGSL file, a row here, its keys in docs/scene-format.md, and a test through the
//! shared adapter (tests/common/bsdf.rs). `rough_diffuse` was added that way.

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
pub enum Keys {
    /// Read by its own code in `scene::parse` (`type` is the name there; `dielectric` gives both smooth
    /// and rough glass).
    Builtin,
    /// Read by the generic reader: `type = "<toml_type>"` and these keys (each a constant or, where the
    /// value allows, a texture), plus the keys every material takes (emission, the surface modifiers).
    Params {
        toml_type: &'static str,
        params: &'static [Param],
    },
}

/// One key of a material read by the generic reader.
pub struct Param {
    pub key: &'static str,
    pub value: ParamValue,
    /// What the key means, for error messages: the hint after a bad value.
    pub hint: &'static str,
}

/// What a key holds, how it is checked, and where it is uploaded (`GpuMaterial`).
#[derive(Clone, Copy)]
pub enum ParamValue {
    /// A linear RGB colour with components in [0, 1], or a texture; uploaded as `albedo` (and its
    /// texture in the albedo slot). `None`: the key is required.
    Albedo { default: Option<[f32; 3]> },
    /// A perceptual roughness r in [0, 1] (one number, or a texture), uploaded as alpha = r^2 on both
    /// axes (`alpha_x`, `alpha_y`; a texture in the roughness slot, squared on the device).
    Roughness { default: f32 },
}

/// The table. The order is the kinds' numbering (`MAT_*`): append new kinds.
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
        // Oren & Nayar's rough diffuse reflector (Mitsuba's `roughdiffuse`).
        name: "rough_diffuse",
        source: include_str!("../../shaders/bsdfs/rough_diffuse.wgsl"),
        feature: "rough_diffuse",
        keys: Keys::Params {
            toml_type: "rough_diffuse",
            params: &[
                Param {
                    key: "albedo",
                    value: ParamValue::Albedo { default: None },
                    hint: "Albedo is the fraction of light reflected per channel; energy conservation needs it in [0, 1].",
                },
                Param {
                    key: "roughness",
                    value: ParamValue::Roughness { default: 0.5 },
                    hint: "roughness^2 is the RMS slope of the surface's facets (Mitsuba's alpha); 0 is Lambert's diffuse.",
                },
            ],
        },
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

/// The number of the kind named `name` (its row's index), for constants: a name not in the table fails
/// to compile.
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

/// The kind whose scene-file `type` is `toml_type` and is read by the generic reader.
pub fn by_toml_type(toml_type: &str) -> Option<(u32, &'static BsdfKind)> {
    BSDFS.iter().enumerate().find_map(|(i, k)| match k.keys {
        Keys::Params { toml_type: t, .. } if t == toml_type => Some((i as u32, k)),
        _ => None,
    })
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

    /// The library name of its file.
    pub fn file(&self) -> String {
        format!("bsdfs/{}.wgsl", self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_file_defines_its_six_functions() {
        for k in BSDFS {
            for f in ["sample", "eval", "pdf", "albedo", "is_delta", "transmits"] {
                let def = format!("fn {}_{f}(mat: Material", k.name);
                assert!(
                    k.source.contains(&def),
                    "{} does not define `{def}`",
                    k.file()
                );
            }
            assert!(k.source.starts_with(&format!("// {}: ", k.file())));
        }
    }

    #[test]
    fn names_are_unique_and_kinds_are_indices() {
        for (i, k) in BSDFS.iter().enumerate() {
            assert_eq!(kind(k.name), i as u32);
            assert_eq!(BSDFS.iter().filter(|o| o.feature == k.feature).count(), 1);
        }
        assert_eq!(
            by_toml_type("rough_diffuse").map(|(i, _)| i),
            Some(kind("rough_diffuse"))
        );
        assert!(
            by_toml_type("diffuse").is_none(),
            "a built-in kind has its own reader"
        );
    }
}
