//! `rough_diffuse`: Oren and Nayar's rough diffuse reflector, their qualitative model (Mitsuba 3's
//! `roughdiffuse` with `use_fast_approx`; the model and its sampling in rough_diffuse.wgsl). Mitsuba's
//! `roughdiffuse` gives `alpha` rather than vkpath's roughness (alpha = roughness^2), so the Mitsuba
//! importer keeps its own arm for it (scene::mitsuba::materials).

use super::{MaterialPlugin, Param, ParamType};

pub const PLUGIN: MaterialPlugin = MaterialPlugin {
    name: "rough_diffuse",
    source: include_str!("rough_diffuse.wgsl"),
    summary: "Oren and Nayar's rough diffuse reflector (their qualitative model; Mitsuba's roughdiffuse with use_fast_approx).",
    mitsuba: &[],
    anisotropy: None,
    check: None,
    params: &[
        Param {
            key: "albedo",
            ty: ParamType::Color {
                default: None,
                max: 1.0,
            },
            doc: "Albedo is the fraction of light reflected per channel; energy conservation needs it in [0, 1].",
        },
        Param {
            key: "roughness",
            ty: ParamType::Float {
                default: Some(0.5),
                min: 0.0,
                max: 1.0,
                textured: true,
            },
            doc: "roughness^2 is the RMS slope of the surface's facets (Mitsuba's alpha); 0 is Lambert's diffuse.",
        },
    ],
};
