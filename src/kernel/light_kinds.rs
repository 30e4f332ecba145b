//! The registry of light kinds: one row per kind of light the kernel samples, and everything else
//! follows from the rows (as the material registry, `scene::bsdfs`, does for BSDFs).
//!
//! A light kind is its WGSL file, `shaders/lights/<name>.wgsl`, which defines three functions
//! (`<name>_light_sample_li`, `_light_pdf_li`, `_light_radiance`: pbrt-v4's `SampleLi`, `PDF_Li` and `L`;
//! the interface is documented in `shaders/lights/common.wgsl`), and its row in [`LIGHTS`]. From the
//! table:
//! - the kind's number is its row's index ([`kind`]; the Rust `LIGHT_*` constants of `kernel::abi` are
//!   defined by it, and the WGSL ones are generated with it);
//! - the kernel's module `lights.wgsl` (the three dispatchers, one branch per row) and `light_kinds.wgsl`
//!   (the `LIGHT_*` constants and the `HAS_*` feature overrides) are generated (`kernel::library`);
//! - each row is a feature of the kernel (`kernel::features`): a scene without a light of the kind gets
//!   a kernel without its code, reported under the row's `feature` name.
//!
//! These are the kernel's kinds, not the scene file's: a scene's `[[light]]` types, emitting spheres,
//! emitting triangles and its environment become them in `kernel::upload` (all emitting triangles
//! together are one light, `triangles`). Adding a light kind: the WGSL file, a row here, its upload, and
//! its scene keys (docs/scene-format.md).

use crate::scene::bsdfs::str_eq;

/// One light kind.
pub struct LightKind {
    /// The file `shaders/lights/<name>.wgsl`, the prefix of its three functions, and (upper-cased) its
    /// `LIGHT_<NAME>` constant.
    pub name: &'static str,
    /// The file's text.
    pub source: &'static str,
    /// The kernel feature's name in reports (`features_absent`, `vkpath bench specialisation`); its
    /// override is `HAS_<FEATURE>`.
    pub feature: &'static str,
}

/// The table. The order is the kinds' numbering (`LIGHT_*`): append new kinds.
pub const LIGHTS: &[LightKind] = &[
    LightKind {
        name: "point",
        source: include_str!("../../shaders/lights/point.wgsl"),
        feature: "point_lights",
    },
    LightKind {
        name: "sphere",
        source: include_str!("../../shaders/lights/sphere.wgsl"),
        feature: "sphere_lights",
    },
    LightKind {
        // Suns: light from infinitely far, a delta direction or a small cone.
        name: "directional",
        source: include_str!("../../shaders/lights/directional.wgsl"),
        feature: "directional_lights",
    },
    LightKind {
        // Every emitting triangle of the scene (of `[[triangle]]`s and meshes), as one light: a sample
        // picks one in proportion to its power.
        name: "triangles",
        source: include_str!("../../shaders/lights/triangles.wgsl"),
        feature: "triangle_lights",
    },
    LightKind {
        // Light from infinity: uniform (`background`), or an equirectangular map.
        name: "environment",
        source: include_str!("../../shaders/lights/environment.wgsl"),
        feature: "environment",
    },
    LightKind {
        // A point light whose intensity falls off from its axis to a cutoff angle (Mitsuba's `spot`).
        name: "spot",
        source: include_str!("../../shaders/lights/spot.wgsl"),
        feature: "spot_lights",
    },
];

/// Files the kinds' files require that are not kinds themselves (shared code).
pub const SHARED_FILES: &[(&str, &str)] = &[(
    "lights/common.wgsl",
    include_str!("../../shaders/lights/common.wgsl"),
)];

/// The number of the kind named `name` (its row's index), for constants: a name not in the table fails
/// to compile.
pub const fn kind(name: &str) -> u32 {
    let mut i = 0;
    while i < LIGHTS.len() {
        if str_eq(LIGHTS[i].name, name) {
            return i as u32;
        }
        i += 1;
    }
    panic!("no such light kind in the registry")
}

impl LightKind {
    /// `LIGHT_<NAME>`.
    pub fn constant(&self) -> String {
        format!("LIGHT_{}", self.name.to_uppercase())
    }

    /// `HAS_<FEATURE>`.
    pub fn feature_constant(&self) -> String {
        format!("HAS_{}", self.feature.to_uppercase())
    }

    /// The library name of its file.
    pub fn file(&self) -> String {
        format!("lights/{}.wgsl", self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_file_defines_its_three_functions() {
        for k in LIGHTS {
            for f in [
                "sample_li(light: Light",
                "pdf_li(light: Light",
                "radiance(light: Light",
            ] {
                let def = format!("fn {}_light_{f}", k.name);
                assert!(
                    k.source.contains(&def),
                    "{} does not define `{def}`",
                    k.file()
                );
            }
        }
    }

    #[test]
    fn kinds_are_numbered_by_row() {
        for (i, k) in LIGHTS.iter().enumerate() {
            assert_eq!(kind(k.name), i as u32);
        }
    }
}
