//! Default toon ramps, generated in code: two- and three-tone cartoon, depth fade, back light and
//! specular. A ramp's x axis is the light intensity; its y axis is chosen by the material's
//! [`RampMode`](super::RampMode). RGB multiplies the hair colour; `1 - alpha` adds the specular
//! colour, so an ordinary opaque texture has no highlight.

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};

/// Width (intensity steps) of the generated ramps.
pub const RAMP_WIDTH: u32 = 64;
/// Height (y steps) of the generated ramps.
pub const RAMP_HEIGHT: u32 = 32;

/// Handles to the generated ramps, inserted by the toon material plugin.
#[derive(Resource, Clone, Debug)]
pub struct ToonRamps {
    /// Two tones: shadow and lit.
    pub two_tone: Handle<Image>,
    /// Three tones: shadow, mid and lit (the default).
    pub three_tone: Handle<Image>,
    /// Three tones near (y = 1), washed out far away (y = 0). Use with `RampMode::Depth`.
    pub depth: Handle<Image>,
    /// Three tones, with a lit rim where `|N.V|^r` is low. Use with `RampMode::BackLight`.
    pub back_light: Handle<Image>,
    /// Three tones, with a white highlight band at high `(N.H)^s`. Use with `RampMode::Specular`.
    pub specular: Handle<Image>,
}

/// Tone thresholds of a cartoon ramp: `(start of band, shade)` from dark to light.
pub fn three_tone(x: f32) -> f32 {
    if x < 0.15 {
        0.45
    } else if x < 0.55 {
        0.72
    } else {
        1.0
    }
}

pub(crate) fn two_tone(x: f32) -> f32 {
    if x < 0.4 { 0.55 } else { 1.0 }
}

/// Builds a ramp image from `f(x, y) -> (shade, highlight)`, `x`, `y` and results in `[0, 1]`,
/// `y = 0` the bottom row. Nearest sampling and clamped edges keep bands hard.
pub fn ramp_image(f: impl Fn(f32, f32) -> (f32, f32)) -> Image {
    let mut data = Vec::with_capacity((RAMP_WIDTH * RAMP_HEIGHT * 4) as usize);
    for row in 0..RAMP_HEIGHT {
        // Texture rows go top to bottom; y goes bottom to top.
        let y = 1.0 - (row as f32 + 0.5) / RAMP_HEIGHT as f32;
        for col in 0..RAMP_WIDTH {
            let x = (col as f32 + 0.5) / RAMP_WIDTH as f32;
            let (shade, highlight) = f(x, y);
            let s = (shade.clamp(0.0, 1.0) * 255.0).round() as u8;
            let a = ((1.0 - highlight.clamp(0.0, 1.0)) * 255.0).round() as u8;
            data.extend_from_slice(&[s, s, s, a]);
        }
    }
    ramp_texture(
        RAMP_WIDTH,
        RAMP_HEIGHT,
        data,
        ImageFilterMode::Nearest,
        "toon ramp",
    )
}

/// An RGBA8 ramp texture of `width` x `height` texels, clamped at its edges, sampled with
/// `filter` (no mipmaps).
fn ramp_texture(
    width: u32,
    height: u32,
    data: Vec<u8>,
    filter: ImageFilterMode,
    label: &'static str,
) -> Image {
    let mut image = Image::new(
        Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8Unorm,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        label: Some(label.into()),
        address_mode_u: ImageAddressMode::ClampToEdge,
        address_mode_v: ImageAddressMode::ClampToEdge,
        mag_filter: filter,
        min_filter: filter,
        mipmap_filter: ImageFilterMode::Nearest,
        ..default()
    });
    image
}

/// The darkest tone of a ramp made by [`band_ramp`]: the brightest at which the toon shader's
/// shade colour takes its full weight (`w = 2 (1 - tone)`), so an MToon shade colour is drawn
/// exactly however dark it is against the base colour.
pub(crate) const BAND_DARKEST: f32 = 0.5;

/// Texels across a ramp made by [`band_ramp`].
const BAND_RAMP_WIDTH: u32 = 256;

/// A two-tone ramp (one row) that turns from [`BAND_DARKEST`] to lit as the light crosses
/// `threshold - softness` to `threshold + softness`, by the smooth step cel shading turns with,
/// sampled linearly so a soft turn is a gradient: an MToon material's shading band for its hair
/// (see [`mtoon_cel_band`](super::mtoon_cel_band)).
pub(crate) fn band_ramp(threshold: f32, softness: f32) -> Image {
    let soft = softness.max(0.001);
    let data = (0..BAND_RAMP_WIDTH)
        .flat_map(|col| {
            let x = (col as f32 + 0.5) / BAND_RAMP_WIDTH as f32;
            let t = ((x - (threshold - soft)) / (2.0 * soft)).clamp(0.0, 1.0);
            let tone = BAND_DARKEST + (1.0 - BAND_DARKEST) * t * t * (3.0 - 2.0 * t);
            let s = (tone * 255.0).round() as u8;
            [s, s, s, 255]
        })
        .collect();
    ramp_texture(
        BAND_RAMP_WIDTH,
        1,
        data,
        ImageFilterMode::Linear,
        "toon ramp of an MToon band",
    )
}

impl ToonRamps {
    /// Generates the ramps into `images`.
    pub fn generate(images: &mut Assets<Image>) -> Self {
        Self {
            two_tone: images.add(ramp_image(|x, _| (two_tone(x), 0.0))),
            three_tone: images.add(ramp_image(|x, _| (three_tone(x), 0.0))),
            depth: images.add(ramp_image(|x, y| {
                // Four depth bands; far ones flatten toward a pale tone.
                let fade = 1.0 - (y * 4.0).floor().min(3.0) / 3.0;
                (three_tone(x) * (1.0 - fade) + 0.9 * fade, 0.0)
            })),
            back_light: images.add(ramp_image(|x, y| {
                if y < 0.3 {
                    (1.0, 0.0)
                } else {
                    (three_tone(x), 0.0)
                }
            })),
            specular: images.add(ramp_image(|x, y| {
                let highlight = if y > 0.8 && x > 0.15 { 0.8 } else { 0.0 };
                (three_tone(x), highlight)
            })),
        }
    }
}

/// A white, linearly filtered `w x h` texture whose alpha is `alpha(u, v)` at texel centres
/// (`u`, `v` in `[0, 1]`); `repeat_u` makes it tile along `u`.
fn white_alpha_image(
    label: &'static str,
    (w, h): (u32, u32),
    repeat_u: bool,
    alpha: impl Fn(f32, f32) -> f32,
) -> Image {
    let mut data = Vec::with_capacity((w * h * 4) as usize);
    for row in 0..h {
        let v = (row as f32 + 0.5) / h as f32;
        for col in 0..w {
            let u = (col as f32 + 0.5) / w as f32;
            let a = alpha(u, v).clamp(0.0, 1.0);
            data.extend_from_slice(&[255, 255, 255, (a * 255.0).round() as u8]);
        }
    }
    let mut image = Image::new(
        Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        label: Some(label.into()),
        address_mode_u: if repeat_u {
            ImageAddressMode::Repeat
        } else {
            ImageAddressMode::ClampToEdge
        },
        address_mode_v: ImageAddressMode::ClampToEdge,
        mag_filter: ImageFilterMode::Linear,
        min_filter: ImageFilterMode::Linear,
        ..default()
    });
    image
}

/// The default stroke texture for object-space silhouettes: an ink line, opaque in the middle and
/// soft at both edges across `v`, with a little pressure variation along `u` (which repeats).
pub fn stroke_texture_image() -> Image {
    white_alpha_image("silhouette stroke", (128, 16), true, |u, v| {
        // Opaque core, soft edges.
        let across = (1.6 * (1.0 - (2.0 * v - 1.0).abs().powi(2))).min(1.0);
        let u = u * std::f32::consts::TAU;
        across * (0.95 + 0.05 * (3.0 * u).sin() * (7.0 * u).cos())
    })
}

/// The default highlight texture for specular sampling quads: white, opaque along the middle of
/// the strip and fading to its sides and ends.
pub fn highlight_texture_image() -> Image {
    white_alpha_image("specular quad", (64, 16), false, |u, v| {
        let across = 1.0 - (2.0 * v - 1.0).powi(2);
        across * (std::f32::consts::PI * u).sin() * 1.4
    })
}
