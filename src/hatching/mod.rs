//! Hatching: a tonal art map (TAM) generator (Praun et al. 2001) and its conversion to a GPU
//! texture.
//!
//! [`tam::generate`] builds the tones and their custom mip levels on the CPU (no GPU, no image
//! editor step: the thesis compiled its mipmaps by hand in GIMP). [`tonal_art_map_image`] packs
//! them into one Bevy [`Image`]: a 2D array texture with a layer per tone, lightest first, and the
//! generated levels as its mip chain, so the GPU's trilinear filtering keeps stroke width constant
//! on screen. The `generate_tam` example writes the tones and mips as PNGs.

mod raster;
mod settings;
mod stroke_image;
pub mod tam;
#[cfg(test)]
mod tam_tests;

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor};
use bevy::prelude::*;
use bevy::render::render_resource::{
    Extent3d, TextureDataOrder, TextureDimension, TextureFormat, TextureViewDescriptor,
    TextureViewDimension,
};

pub use settings::{TamError, TamSettings};
pub use stroke_image::{MAX_STROKE_IMAGE_SIZE, StrokeImage};
pub use tam::{TamLevel, TonalArtMap, generate};

/// Packs a tonal art map into a 2D array texture (`R8Unorm`, one layer per tone, lightest first;
/// `1.0` is paper, `0.0` ink) whose mip chain is the map's own levels, with a repeating,
/// trilinear sampler so hatching tiles.
pub fn tonal_art_map_image(map: &TonalArtMap) -> Image {
    let size = map.resolution() as u32;
    let mut data = Vec::new();
    // Layer-major: every mip of tone 0, then every mip of tone 1, ...
    for tone in 0..map.tones {
        for level in &map.levels {
            data.extend_from_slice(&level.tones[tone]);
        }
    }
    let mut image = Image::new_uninit(
        Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: map.tones as u32,
        },
        TextureDimension::D2,
        TextureFormat::R8Unorm,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.data = Some(data);
    image.data_order = TextureDataOrder::LayerMajor;
    image.texture_descriptor.mip_level_count = map.levels.len() as u32;
    image.texture_view_descriptor = Some(TextureViewDescriptor {
        dimension: Some(TextureViewDimension::D2Array),
        ..default()
    });
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        label: Some("tonal art map".into()),
        address_mode_u: ImageAddressMode::Repeat,
        address_mode_v: ImageAddressMode::Repeat,
        mag_filter: ImageFilterMode::Linear,
        min_filter: ImageFilterMode::Linear,
        mipmap_filter: ImageFilterMode::Linear,
        ..default()
    });
    image
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_holds_every_tone_and_level_in_order() {
        let settings = TamSettings {
            tones: 3,
            resolution: 64,
            mip_levels: 2,
            strokes_per_tone: 8,
            candidates: 3,
            ..default()
        };
        let map = generate(&StrokeImage::default(), &settings, |_, _| {}).unwrap();
        let image = tonal_art_map_image(&map);
        assert_eq!(image.texture_descriptor.size.depth_or_array_layers, 3);
        assert_eq!(image.texture_descriptor.mip_level_count, 2);
        let data = image.data.as_ref().unwrap();
        assert_eq!(data.len(), 3 * (64 * 64 + 32 * 32));
        // Tone 1, level 1 starts after tone 0's two levels and tone 1's level 0.
        let at = 64 * 64 + 32 * 32 + 64 * 64;
        assert_eq!(&data[at..at + 32 * 32], &map.levels[1].tones[1][..]);
    }
}
