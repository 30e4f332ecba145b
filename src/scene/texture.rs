//! Texture references: how a material parameter reads an image (docs/scene-format.md, "Textured
//! parameters"). A parameter is a constant or a texture reference; a textured parameter is the constant
//! (the reference's `factor`) times the texture's value at the hit, the glTF 2.0 model
//! (`baseColorFactor` x `baseColorTexture`). The kernel's side is shaders/texture.wgsl.

use super::image_texture::Texture;
use std::sync::Arc;

/// Which channel(s) of the image a texture reference gives: all three colour channels, or one, spread
/// over the three components (a scalar parameter reads the first).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Channel {
    #[default]
    Rgb,
    R,
    G,
    B,
    A,
    /// Rec. 709 luminance of the linear colour: 0.2126 R + 0.7152 G + 0.0722 B.
    Luminance,
}

impl Channel {
    /// Every channel with its name in scene files.
    pub const ALL: [(Channel, &'static str); 6] = [
        (Channel::Rgb, "rgb"),
        (Channel::R, "r"),
        (Channel::G, "g"),
        (Channel::B, "b"),
        (Channel::A, "a"),
        (Channel::Luminance, "luminance"),
    ];
}

/// How a lookup between texel centres is filtered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TextureFilter {
    /// The four nearest texels, weighted by distance (texture.wgsl, texture_lookup).
    #[default]
    Bilinear,
    /// The texel whose square contains the point.
    Nearest,
}

/// What a uv outside [0, 1] reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane.
    #[default]
    Repeat,
    /// The edge texels extend outwards.
    Clamp,
    /// The image tiles the plane, every other copy mirrored (so that edges match).
    Mirror,
}

/// An image as a material parameter reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    pub image: Arc<Texture>,
    pub channel: Channel,
    /// The texels are sRGB-encoded colour (decoded before filtering); else linear values.
    pub srgb: bool,
    pub filter: TextureFilter,
    pub wrap: Wrap,
    /// uv' = R(rotation) (scale * uv) + offset: KHR_texture_transform's order (scale, rotation, offset),
    /// the rotation counter-clockwise in degrees in the uv plane (u to the right, v up).
    pub scale: [f32; 2],
    pub offset: [f32; 2],
    pub rotation_deg: f32,
}

impl TextureRef {
    /// The whole image, repeated, bilinear, all channels, no transform: what the `[[mesh]]` texture keys
    /// (`texture`, `emission_texture`, ...) make of their image. A `colour` image is sRGB-encoded when it
    /// has 8 bits per channel (PNG, JPEG), linear when it is floating point (EXR, HDR); data (a
    /// metallic-roughness or normal map) is linear.
    pub fn plain(image: Arc<Texture>, colour: bool) -> TextureRef {
        TextureRef {
            srgb: colour && !image.half,
            image,
            channel: Channel::Rgb,
            filter: TextureFilter::Bilinear,
            wrap: Wrap::Repeat,
            scale: [1.0, 1.0],
            offset: [0.0, 0.0],
            rotation_deg: 0.0,
        }
    }

    /// The same reference reading one channel.
    pub fn with_channel(mut self, channel: Channel) -> TextureRef {
        self.channel = channel;
        self
    }

    /// The matrix M of uv' = M uv + offset, row-major [m00, m01, m10, m11]: R(theta) diag(scale), with
    /// R(theta) = [[cos, -sin], [sin, cos]]. Exactly the identity for scale 1 and rotation 0.
    pub fn uv_matrix(&self) -> [f32; 4] {
        let (sin, cos) = if self.rotation_deg == 0.0 {
            (0.0, 1.0)
        } else {
            let (s, c) = f64::from(self.rotation_deg).to_radians().sin_cos();
            (s as f32, c as f32)
        };
        let [su, sv] = self.scale;
        [cos * su, -sin * sv, sin * su, cos * sv]
    }
}

/// A material's textured parameters and surface modifiers (docs/scene-format.md). Each textured
/// parameter's factor is the material's constant for that parameter (in `Bsdf`, `Emission`).
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialTextures {
    /// Albedo, base colour, a mirror's tint or a Schlick conductor's base colour.
    pub albedo: Option<TextureRef>,
    /// Perceptual roughness (both axes): roughness = constant x texel, GGX alpha = roughness^2.
    pub roughness: Option<TextureRef>,
    pub metallic: Option<TextureRef>,
    /// Emitted radiance (an emitter's `radiance`, another material's `emission`).
    pub emission: Option<TextureRef>,
    /// The fraction of light the surface stops: `opacity` x texel.
    pub opacity: Option<TextureRef>,
    /// In [0, 1]; 1 (the default) is opaque.
    pub opacity_value: f32,
    /// A cut-out: opacity below it is a hole, at or above it solid. `None`: stochastic transparency.
    pub alpha_cutoff: Option<f32>,
    /// A height map (linear) and its scale, scene units per unit of texel value.
    pub bump: Option<(TextureRef, f32)>,
    /// A tangent-space normal map (linear) and the factor of its x and y.
    pub normal_map: Option<(TextureRef, f32)>,
    /// Only the front face scatters (the side the geometric normal faces); a ray reaching the back is
    /// absorbed (Mitsuba's BSDFs without `twosided`). False: both faces scatter alike.
    pub one_sided: bool,
    /// The material the back face shows (an index into the scene's materials): the `back` modifier,
    /// Mitsuba's twosided with two BSDFs.
    pub back: Option<u32>,
    /// The material a hit shows instead, with probability `blend_weight` (times the texture): the
    /// `blend` modifier, Mitsuba's blendbsdf.
    pub blend: Option<u32>,
    pub blend_weight: f32,
    pub blend_weight_texture: Option<TextureRef>,
    /// A plugin material's textured parameters: the block word that takes the texture's index and the
    /// texture (`crate::materials::Slot::texture_word`).
    pub block: Vec<(usize, TextureRef)>,
}

impl Default for MaterialTextures {
    /// No texture, opaque.
    fn default() -> MaterialTextures {
        MaterialTextures {
            albedo: None,
            roughness: None,
            metallic: None,
            emission: None,
            opacity: None,
            opacity_value: 1.0,
            alpha_cutoff: None,
            bump: None,
            normal_map: None,
            one_sided: false,
            back: None,
            blend: None,
            blend_weight: 0.5,
            blend_weight_texture: None,
            block: Vec::new(),
        }
    }
}

impl MaterialTextures {
    /// Whether the material has no texture and no modifier: a plain constant material.
    pub fn is_plain(&self) -> bool {
        *self == MaterialTextures::default()
    }
}
