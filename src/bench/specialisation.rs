//! `vkpath bench specialisation`: samples per second of each scene with its specialised kernel, the generic
//! kernel and (where it applies) the hand-trimmed kernel; and the ablation, what each absent feature's
//! absence buys.

use super::{BenchSettings, median, pass_times};
use crate::gpu::GpuContext;
use crate::kernel::abi::{FILTER_NONE, LIGHT_POINT, MAT_DIFFUSE};
use crate::kernel::features::{Feature, FeatureSet, features};
use crate::kernel::{library, specialise};
use crate::render::{RenderOptions, Renderer};
use crate::{Error, Scene};
use std::path::PathBuf;
use std::sync::Arc;

/// One scene's line of the specialisation benchmark: samples per second of each kernel (median of the
/// runs), and the specialised/generic ratio.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SpecialisationRow {
    pub scene: String,
    pub absent: Vec<&'static str>,
    pub specialised_samples_per_second: f64,
    pub generic_samples_per_second: f64,
    pub ratio: f64,
    /// For scenes the hand-trimmed kernel can render (diffuse spheres, point lights, pixel centre,
    /// pinhole, black background): its samples per second, and specialised/trimmed.
    pub trimmed_samples_per_second: Option<f64>,
    pub specialised_over_trimmed: Option<f64>,
}

/// The features the hand-trimmed kernel has code for (shaders/bench/trimmed_diffuse_point.wgsl):
/// diffuse spheres, point lights and Russian roulette.
fn trimmed_features() -> [Feature; 4] {
    [
        Feature::Spheres,
        Feature::Material(MAT_DIFFUSE),
        Feature::Light(LIGHT_POINT),
        Feature::Roulette,
    ]
}

/// Whether the hand-trimmed kernel renders this feature set exactly: it needs its three essentials and
/// nothing outside what it has code for. The test runs over every row of the feature table (material
/// kinds included, from their registry), so a feature added later is excluded without a list to keep.
/// The uniform twins are how the specialised kernel reads the arrays, not what it renders: the trimmed
/// kernel reads the same values from the storage bindings.
fn trimmed_applies(f: &FeatureSet) -> bool {
    let has = trimmed_features();
    has[..3].iter().all(|&x| f.has(x))
        && features().iter().all(|row| {
            !f.has(row.feature)
                || has.contains(&row.feature)
                || matches!(row.feature, Feature::UniformArray(_) | Feature::DataImages)
        })
        && f.knob("filter") == Some(FILTER_NONE)
}

/// Times each scene with its specialised kernel, the generic kernel and (where it applies) the trimmed
/// kernel. Runs alternate between the kernels so that a slow moment of the machine hits all of them.
pub fn specialisation(
    ctx: &Arc<GpuContext>,
    scenes: &[PathBuf],
    settings: BenchSettings,
) -> Result<Vec<SpecialisationRow>, Error> {
    let trimmed_kernel = Arc::new(specialise::compile(&library::trimmed_source())?);
    let mut rows = Vec::new();
    for path in scenes {
        let mut scene = Scene::load(path)?;
        scene.image.width = settings.width;
        scene.image.height = settings.height;
        let specialised = Renderer::new(ctx, &scene, &RenderOptions::default())?;
        let features = *specialised.features();
        let generic = Renderer::new(
            ctx,
            &scene,
            &RenderOptions {
                generic: true,
                ..Default::default()
            },
        )?;
        let mut renderers = vec![specialised, generic];
        if trimmed_applies(&features) {
            renderers.push(Renderer::with_kernel(
                ctx,
                &scene,
                &RenderOptions::default(),
                trimmed_kernel.clone(),
            )?);
        }
        let rate = time_renderers(&mut renderers, settings)?;
        rows.push(SpecialisationRow {
            scene: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            absent: features.absent(),
            specialised_samples_per_second: rate[0],
            generic_samples_per_second: rate[1],
            ratio: rate[0] / rate[1],
            trimmed_samples_per_second: rate.get(2).copied(),
            specialised_over_trimmed: rate.get(2).map(|t| rate[0] / t),
        });
    }
    Ok(rows)
}

/// One line of the ablation: the cost of putting one absent feature's code back into a scene's kernel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AblationRow {
    pub scene: String,
    pub feature: &'static str,
    /// samples/s of the specialised kernel divided by samples/s with this feature's code added back.
    pub gain: f64,
}

/// For each scene and each feature its specialised kernel leaves out, times the specialised kernel
/// against the same kernel with that one feature switched back on (its code present, never used):
/// the speed-up each absence buys.
pub fn ablation(
    ctx: &Arc<GpuContext>,
    scenes: &[PathBuf],
    settings: BenchSettings,
) -> Result<Vec<AblationRow>, Error> {
    let mut rows = Vec::new();
    for path in scenes {
        let mut scene = Scene::load(path)?;
        scene.image.width = settings.width;
        scene.image.height = settings.height;
        let base = Renderer::new(ctx, &scene, &RenderOptions::default())?;
        let features = *base.features();
        let mut variants = vec![base];
        let mut names = Vec::new();
        for name in features.absent() {
            let mut with = features;
            with.enable(name);
            let kernel = crate::render::kernel_for(&with)?;
            variants.push(Renderer::with_kernel(
                ctx,
                &scene,
                &RenderOptions::default(),
                kernel,
            )?);
            names.push(name);
        }
        let rate = time_renderers(&mut variants, settings)?;
        for (i, name) in names.into_iter().enumerate() {
            rows.push(AblationRow {
                scene: path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                feature: name,
                gain: rate[0] / rate[i + 1],
            });
        }
    }
    Ok(rows)
}

/// Median samples/s of each renderer over `settings.runs` timed passes, interleaved.
fn time_renderers(renderers: &mut [Renderer], settings: BenchSettings) -> Result<Vec<f64>, Error> {
    let samples = settings.width as f64 * settings.height as f64 * settings.spp as f64;
    let times = pass_times(renderers, settings)?;
    Ok(times
        .into_iter()
        .map(|t| samples / median(t.iter().map(|p| p.wall).collect()))
        .collect())
}

/// The ablation as a Markdown table.
pub fn ablation_table(rows: &[AblationRow], settings: BenchSettings, device: &str) -> String {
    let mut out = format!(
        "Speed-up bought by each absent feature (specialised kernel vs the same with that feature's code put back), \
         {}x{}, {} spp per timed pass, median of {} runs, on {device}.\n\n| scene | feature | gain |\n| --- | --- | ---: |\n",
        settings.width, settings.height, settings.spp, settings.runs
    );
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {:.3} |\n",
            r.scene, r.feature, r.gain
        ));
    }
    out
}

/// The rows as a Markdown table.
pub fn specialisation_table(
    rows: &[SpecialisationRow],
    settings: BenchSettings,
    device: &str,
) -> String {
    let mut out = format!(
        "Specialised vs generic kernel, {}x{}, {} spp per timed pass, median of {} runs, on {device}.\n\n\
         | scene | absent features | specialised Msamples/s | generic Msamples/s | specialised / generic | specialised / hand-trimmed |\n\
         | --- | --- | ---: | ---: | ---: | ---: |\n",
        settings.width, settings.height, settings.spp, settings.runs
    );
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {} |\n",
            r.scene,
            if r.absent.is_empty() {
                "none".to_string()
            } else {
                r.absent.join(", ")
            },
            r.specialised_samples_per_second / 1e6,
            r.generic_samples_per_second / 1e6,
            r.ratio,
            r.specialised_over_trimmed
                .map(|x| format!("{x:.3}"))
                .unwrap_or_else(|| "".into()),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::upload::{GpuScene, params_for};

    fn features_of(materials: &str) -> FeatureSet {
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[render]\nfilter = \"none\"\n\
             [materials]\n{materials}\n\
             [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"a\"\n\
             [[sphere]]\ncenter = [2, 0, 0]\nradius = 1\nmaterial = \"b\"\n\
             [[light]]\ntype = \"point\"\nposition = [0, 5, 5]\npower = 100\n"
        );
        let scene = Scene::from_toml_str(&text, None).expect("scene");
        FeatureSet::of(&GpuScene::build(&scene), &params_for(&scene, 3))
    }

    /// The trimmed kernel (diffuse only) is no bound for a scene with a conductor: the hand-kept list
    /// this replaced forgot the glossy materials and timed such scenes against it.
    #[test]
    fn trimmed_kernel_applies_to_diffuse_point_scenes_only() {
        let diffuse = "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
                       b = { type = \"diffuse\", albedo = [0.2, 0.5, 0.5] }";
        assert!(trimmed_applies(&features_of(diffuse)));
        let metal = "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
                     b = { type = \"conductor\", preset = \"gold\", roughness = 0.3 }";
        assert!(!trimmed_applies(&features_of(metal)));
        let rough = "a = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
                     b = { type = \"rough_diffuse\", albedo = [0.5, 0.5, 0.5] }";
        assert!(!trimmed_applies(&features_of(rough)));
    }
}
