//! `[camera]`, `[image]` and `[render]`: the view, the image and its display transform, and how it is
//! rendered.

use super::Checker;
use super::error::SceneError;
use super::raw::{RawCamera, RawGamma, RawImage, RawRender};
use crate::scene::{
    Camera, Filter, Gamma, ImageSettings, LightSampling, Projection, RenderSettings, Sampler,
    Tonemap,
};
use glam::Vec3;
use toml::Spanned;

impl Checker<'_> {
    pub(super) fn camera(&self, raw: &Spanned<RawCamera>) -> Result<Camera, SceneError> {
        let c = raw.get_ref();
        let position = self.vec3(&c.position, "camera.position")?;
        let look_at = self.vec3(&c.look_at, "camera.look_at")?;
        let projection = match &c.kind {
            None => Projection::Perspective,
            Some(k) => match k.get_ref().as_str() {
                "perspective" => Projection::Perspective,
                "orthographic" => Projection::Orthographic,
                other => {
                    return Err(self.error(
                        k.span(),
                        "camera.type",
                        format!("unknown camera type \"{other}\""),
                        "Use \"perspective\" (the default, with fov) or \"orthographic\" (with extent).",
                    ));
                }
            },
        };
        // Each projection has its own key for the size of the view, and refuses the other's.
        let (fov_deg, extent) = match projection {
            Projection::Perspective => {
                if let Some(e) = &c.extent {
                    return Err(self.error(
                        e.span(),
                        "camera.extent",
                        "a perspective camera has no `extent`",
                        "Remove `extent`, or set `type = \"orthographic\"` for a parallel projection.",
                    ));
                }
                let fov = self.required(
                    &c.fov,
                    raw,
                    "camera.fov",
                    "a perspective camera needs a fov",
                )?;
                let fov_deg = self.number_unless(
                    fov,
                    "camera.fov",
                    |fov| !(fov > 0.0 && fov < 180.0),
                    "the field of view must be strictly between 0 and 180 degrees",
                    "fov is the horizontal angle across the image width in degrees; 60 is a typical value.",
                )?;
                (fov_deg, 0.0)
            }
            Projection::Orthographic => {
                if let Some(f) = &c.fov {
                    return Err(self.error(
                        f.span(),
                        "camera.fov",
                        "an orthographic camera has no `fov`",
                        "Remove `fov`: `extent` gives the width of the view in scene units.",
                    ));
                }
                let extent = self.required(
                    &c.extent,
                    raw,
                    "camera.extent",
                    "an orthographic camera needs an extent",
                )?;
                let extent = self.number_unless(
                    extent,
                    "camera.extent",
                    |e| e <= 0.0,
                    "the extent must be > 0",
                    "extent is the width of the view in scene units (the height follows the image's aspect).",
                )?;
                (0.0, extent)
            }
        };
        if look_at == position {
            return Err(self.error(
                c.look_at.span(),
                "camera.look_at",
                format!(
                    "look_at equals position ({position}), so the camera has no view direction"
                ),
                "Move look_at to the point the camera should aim at.",
            ));
        }

        // The geometry checks run in f64: the difference or squared length of two finite f32 vectors
        // can overflow f32, but not f64.
        let view = sub64(look_at, position);
        let view_length = length64(view);

        // A defaulted `up` has no span of its own; the [camera] header is the nearest place to point.
        let (up, up_span) = match &c.up {
            Some(up) => (self.vec3(up, "camera.up")?, up.span()),
            None => (Vec3::Y, raw.span()),
        };
        let up64 = [f64::from(up.x), f64::from(up.y), f64::from(up.z)];
        let up_length = length64(up64);
        if up_length == 0.0 {
            return Err(self.error(
                up_span,
                "camera.up",
                "the up vector is zero",
                "Set camera.up to the direction that should point up in the image, e.g. [0, 1, 0].",
            ));
        }
        let view_dir = scale64(view, 1.0 / view_length);
        let up_dir = scale64(up64, 1.0 / up_length);
        if length64(cross64(up_dir, view_dir)) < 1e-6 {
            let which = if c.up.is_some() {
                "the up vector"
            } else {
                "the default up vector [0, 1, 0]"
            };
            return Err(self.error(
                up_span,
                "camera.up",
                format!("{which} is parallel to the view direction (look_at - position), so the image has no defined up"),
                "Set camera.up to a direction that is not along the line of sight.",
            ));
        }

        let aperture = c.aperture.as_ref().map_or(Ok(0.0), |a| {
            self.number_unless(
                a,
                "camera.aperture",
                |a| a < 0.0,
                "the aperture (lens radius) must be >= 0",
                "Use 0 for a pinhole camera, or a positive lens radius in scene units for depth of field.",
            )
        })?;
        if let (Projection::Orthographic, Some(a)) = (projection, &c.aperture)
            && aperture > 0.0
        {
            return Err(self.error(
                a.span(),
                "camera.aperture",
                "an orthographic camera has no lens: depth of field needs a perspective camera",
                "Remove `aperture` (or set it to 0), or use `type = \"perspective\"`.",
            ));
        }

        let focus_distance = match &c.focus_distance {
            Some(d) => self.number_unless(
                d,
                "camera.focus_distance",
                |d| d <= 0.0,
                "the focus distance must be > 0",
                "Give the distance along the view axis to the plane in focus, in scene units, or leave it out to focus on look_at.",
            )?,
            None => {
                // The default, |look_at - position|, can exceed f32's range for extreme coordinates.
                let d = view_length as f32;
                if !d.is_finite() {
                    return Err(self.error(
                        c.look_at.span(),
                        "camera.look_at",
                        "look_at is so far from position that the distance between them overflows a 32-bit float",
                        "Bring the scene's coordinates into a smaller range.",
                    ));
                }
                d
            }
        };

        Ok(Camera {
            position,
            look_at,
            up,
            projection,
            fov_deg,
            extent,
            aperture,
            focus_distance,
        })
    }

    pub(super) fn image(&self, raw: Option<&RawImage>) -> Result<ImageSettings, SceneError> {
        // A missing [image] table is an empty one: every key takes its default below.
        let empty = RawImage::default();
        let raw = raw.unwrap_or(&empty);
        const MAX_SIDE: u32 = 65536;
        const MAX_PIXELS: u64 = 1 << 28;
        let side_hint = "Image sides are in pixels, between 1 and 65536.";
        let width = raw.width.as_ref().map_or(Ok(512), |w| {
            self.integer(w, "image.width", 1, MAX_SIDE, side_hint)
        })?;
        let height = raw.height.as_ref().map_or(Ok(512), |h| {
            self.integer(h, "image.height", 1, MAX_SIDE, side_hint)
        })?;
        let pixels = u64::from(width) * u64::from(height);
        if pixels > MAX_PIXELS {
            // Both defaults are small, so at least one side was given; point at it.
            let (span, key) = match (&raw.width, &raw.height) {
                (Some(w), _) => (w.span(), "image.width"),
                (None, Some(h)) => (h.span(), "image.height"),
                (None, None) => (0..0, "image.width"),
            };
            return Err(self.error(
                span,
                key,
                format!("{width} x {height} is {pixels} pixels, more than the limit of {MAX_PIXELS} (2^28)"),
                "Render a smaller image, e.g. 16384 x 16384 at most.",
            ));
        }

        let exposure = raw.exposure.as_ref().map_or(Ok(1.0), |e| {
            self.number_unless(
                e,
                "image.exposure",
                |e| e < 0.0,
                "the exposure must be >= 0",
                "Exposure is a linear multiplier on radiance before the display transform; 1 leaves it unchanged.",
            )
        })?;

        let gamma = match &raw.gamma {
            None => Gamma::Power(2.2),
            Some(g) => match g.get_ref() {
                RawGamma::Number(value) => Gamma::Power(self.number_unless(
                    &Spanned::new(g.span(), *value),
                    "image.gamma",
                    |gamma| gamma <= 0.0,
                    "a numeric gamma must be > 0",
                    "Use 2.2 (the default) or the string \"srgb\".",
                )?),
                RawGamma::Name(name) if name == "srgb" => Gamma::Srgb,
                RawGamma::Name(name) => {
                    return Err(self.error(
                        g.span(),
                        "image.gamma",
                        format!("unknown gamma \"{name}\""),
                        "Use a positive number such as 2.2, or the string \"srgb\" for the sRGB transfer curve.",
                    ));
                }
            },
        };

        Ok(ImageSettings {
            width,
            height,
            exposure,
            gamma,
            tonemap: Tonemap::None, // render.tonemap, set by `scene`
            denoise: false,         // render.denoise, set by `scene`
        })
    }

    /// `render.tonemap`: "none" (default) or "aces".
    pub(super) fn tonemap(&self, raw: Option<&RawRender>) -> Result<Tonemap, SceneError> {
        match raw.and_then(|r| r.tonemap.as_ref()) {
            None => Ok(Tonemap::None),
            Some(t) => match t.get_ref().as_str() {
                "none" => Ok(Tonemap::None),
                "aces" => Ok(Tonemap::Aces),
                other => Err(self.error(
                    t.span(),
                    "render.tonemap",
                    format!("unknown tonemap \"{other}\""),
                    "Use \"none\" (the course's clamp, the default) or \"aces\" (Narkowicz's ACES filmic fit).",
                )),
            },
        }
    }

    /// The `[render]` settings, and `render.background` (which `environment` turns into the light).
    pub(super) fn render(
        &self,
        raw: Option<&RawRender>,
    ) -> Result<(RenderSettings, Vec3), SceneError> {
        // A missing [render] table is an empty one: every key takes its default below.
        let empty = RawRender::default();
        let raw = raw.unwrap_or(&empty);
        let samples = raw.samples.as_ref().map_or(Ok(64), |s| {
            self.integer(
                s,
                "render.samples",
                1,
                u32::MAX,
                "samples is the number of paths per pixel; it must be at least 1.",
            )
        })?;
        let max_bounces = raw.max_bounces.as_ref().map_or(Ok(5), |b| {
            if *b.get_ref() == -1 {
                return Ok(crate::scene::NO_BOUNCE_LIMIT);
            }
            self.integer(
                b,
                "render.max_bounces",
                0,
                u32::MAX - 1,
                "max_bounces counts scattering events per path; 0 shows lights and the background \
                 only, -1 sets no limit (paths end by Russian roulette).",
            )
        })?;
        let seed = raw.seed.as_ref().map_or(Ok(0), |s| {
            self.integer(
                s,
                "render.seed",
                0,
                u32::MAX,
                "The seed is a 32-bit unsigned integer.",
            )
        })?;
        let (filter, filter_sigma, filter_radius) = self.render_filter(raw)?;
        let background = raw.background.as_ref().map_or(Ok(Vec3::ZERO), |b| {
            self.vec3_unless(
                b,
                "render.background",
                |b| b.min_element() < 0.0,
                "background radiance cannot be negative",
                "Give a linear RGB radiance with components >= 0; [0, 0, 0] is black.",
            )
        })?;
        let (sampler, light_sampling, clamp) = self.render_sampling(raw)?;
        let adaptive = self.render_adaptive(raw)?;
        let settings = RenderSettings {
            samples,
            max_bounces,
            seed,
            filter,
            filter_sigma,
            filter_radius,
            sample_border: raw.sample_border.as_ref().is_none_or(|b| *b.get_ref()),
            splat: raw.splat.as_ref().map(|b| *b.get_ref()),
            adaptive,
            sampler,
            light_sampling,
            clamp,
        };
        self.check_splat(raw, &settings)?;
        Ok((settings, background))
    }

    /// `render.filter` and its width: (filter, Gaussian sigma, tent radius), in pixels.
    fn render_filter(&self, raw: &RawRender) -> Result<(Filter, f32, f32), SceneError> {
        let filter = match &raw.filter {
            None => Filter::Gaussian,
            Some(f) => match f.get_ref().as_str() {
                "gaussian" => Filter::Gaussian,
                "box" => Filter::Box,
                "none" => Filter::None,
                "tent" => Filter::Tent,
                other => {
                    return Err(self.error(
                        f.span(),
                        "render.filter",
                        format!("unknown pixel filter \"{other}\""),
                        "Use \"gaussian\" (the default), \"box\", \"tent\" or \"none\".",
                    ));
                }
            },
        };
        let filter_sigma = raw.filter_sigma.as_ref().map_or(Ok(0.5), |s| {
            self.number_unless(
                s,
                "render.filter_sigma",
                |sigma| sigma <= 0.0,
                "the filter's standard deviation must be > 0",
                "filter_sigma is in pixels; 0.5 is the default. Use filter = \"none\" for no filtering.",
            )
        })?;
        let filter_radius = raw.filter_radius.as_ref().map_or(Ok(1.0), |r| {
            self.number_unless(
                r,
                "render.filter_radius",
                |radius| radius <= 0.0,
                "the tent filter's radius must be > 0",
                "filter_radius is in pixels; 1 is the default.",
            )
        })?;
        Ok((filter, filter_sigma, filter_radius))
    }

    /// `render.sampler`, `render.light_sampling` and the firefly `render.clamp`.
    fn render_sampling(
        &self,
        raw: &RawRender,
    ) -> Result<(Sampler, LightSampling, Option<f32>), SceneError> {
        let sampler = match &raw.sampler {
            None => Sampler::Sobol,
            Some(s) => match s.get_ref().as_str() {
                "independent" => Sampler::Independent,
                "sobol" => Sampler::Sobol,
                other => {
                    return Err(self.error(
                        s.span(),
                        "render.sampler",
                        format!("unknown sampler \"{other}\""),
                        "Use \"sobol\" (the default) or \"independent\".",
                    ));
                }
            },
        };
        let light_sampling = match &raw.light_sampling {
            None => LightSampling::Mis,
            Some(s) => match LightSampling::from_name(s.get_ref()) {
                Some(l) => l,
                None => {
                    return Err(self.error(
                        s.span(),
                        "render.light_sampling",
                        format!("unknown light sampling strategy \"{}\"", s.get_ref()),
                        format!(
                            "Use {} (\"mis\" is the default).",
                            LightSampling::names_listed()
                        ),
                    ));
                }
            },
        };
        let clamp = match &raw.clamp {
            None => None,
            Some(c) => Some(self.number_unless(
                c,
                "render.clamp",
                |c| c <= 0.0,
                "the firefly clamp must be > 0",
                "clamp is the largest radiance a sample may carry in any channel (biased: leave it out for an unbiased image).",
            )?),
        };
        Ok((sampler, light_sampling, clamp))
    }

    /// Adaptive sampling's keys: `render.adaptive`, `adaptive_threshold`, `adaptive_min_samples`.
    fn render_adaptive(&self, raw: &RawRender) -> Result<crate::scene::Adaptive, SceneError> {
        Ok(crate::scene::Adaptive {
            on: raw.adaptive.as_ref().map(|b| *b.get_ref()),
            threshold: match &raw.adaptive_threshold {
                None => None,
                Some(t) => Some(f64::from(self.number_unless(
                    t,
                    "render.adaptive_threshold",
                    |t| t <= 0.0,
                    "the adaptive threshold must be > 0",
                    "adaptive_threshold is the relative error at which a pixel stops sampling, e.g. 0.01.",
                )?)),
            },
            min_samples: match &raw.adaptive_min_samples {
                None => None,
                Some(n) => Some(self.integer(
                    n,
                    "render.adaptive_min_samples",
                    2,
                    u32::MAX,
                    "adaptive_min_samples is the samples every pixel takes before any stops (and \
                     between checks); it must be at least 2, for a variance.",
                )?),
            },
        })
    }

    /// `render.splat = true` where the filter cannot be splatted, or with adaptive sampling: refused.
    fn check_splat(&self, raw: &RawRender, settings: &RenderSettings) -> Result<(), SceneError> {
        if let Some(splat) = &raw.splat
            && *splat.get_ref()
            && !settings.can_splat()
        {
            return Err(self.error(
                splat.span(),
                "render.splat",
                "splatting needs a tent or Gaussian filter of radius at most 7.5 pixels and samples \
                 that stay on the image"
                    .to_string(),
                "Set filter = \"tent\" or \"gaussian\" and sample_border = false, or leave splat out \
                 (each pixel then keeps its own samples).",
            ));
        }
        if let (Some(adaptive), Some(splat)) = (&raw.adaptive, &raw.splat)
            && *adaptive.get_ref()
            && *splat.get_ref()
        {
            return Err(self.error(
                splat.span(),
                "render.splat",
                "splatting does not go with adaptive sampling (render.adaptive = true): a splatted pixel \
                 averages its neighbours' samples, which adaptive sampling takes in unequal numbers"
                    .to_string(),
                "Leave out one of splat and adaptive (an adaptive render keeps each pixel's own samples).",
            ));
        }
        Ok(())
    }
}

// f64 helpers for the camera checks (glam's DVec3 would do too; these keep the f32 -> f64 step visible).

fn sub64(a: Vec3, b: Vec3) -> [f64; 3] {
    [
        f64::from(a.x) - f64::from(b.x),
        f64::from(a.y) - f64::from(b.y),
        f64::from(a.z) - f64::from(b.z),
    ]
}

fn length64(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn scale64(v: [f64; 3], s: f64) -> [f64; 3] {
    [v[0] * s, v[1] * s, v[2] * s]
}

fn cross64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use crate::scene::parse::tests::{MINIMAL, parse};
    use crate::scene::{Filter, Gamma};

    #[test]
    fn gamma_srgb_selects_the_srgb_curve() {
        let scene = parse(&format!("{MINIMAL}\n[image]\ngamma = \"srgb\"\n"));
        assert_eq!(scene.image.gamma, Gamma::Srgb);
        let scene = parse(&format!("{MINIMAL}\n[image]\ngamma = 1.8\n"));
        assert_eq!(scene.image.gamma, Gamma::Power(1.8));
    }

    #[test]
    fn limits_are_inclusive() {
        let text = format!(
            "{MINIMAL}\n[image]\nwidth = 65536\nheight = 4096\nexposure = 0\n[render]\nmax_bounces = 0\nseed = 4294967295\nfilter = \"none\"\n\
             [materials]\nblack = {{ type = \"diffuse\", albedo = [0, 0, 1] }}\n"
        );
        let scene = parse(&text);
        assert_eq!((scene.image.width, scene.image.height), (65536, 4096));
        assert_eq!(scene.render.seed, u32::MAX);
        assert_eq!(scene.render.max_bounces, 0);
        assert_eq!(scene.render.filter, Filter::None);
    }
}
