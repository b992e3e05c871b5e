//! Tonal art maps for materials: the hatching tones a [`ToonHairMaterial`] samples, generated on
//! first need. Runs without the `ui` feature: a game without the panel gets hatching too.

use bevy::prelude::*;

use super::{HatchingMode, ToonHairMaterial};
use crate::hatching::{StrokeImage, TamSettings, generate, tonal_art_map_image};

/// How the tonal art map is generated when a material first asks for hatching without one
/// (see [`assign_tonal_art_maps`]). Small by default so switching hatching on takes a moment,
/// not seconds.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub struct HatchingMapSettings(pub TamSettings);

impl Default for HatchingMapSettings {
    fn default() -> Self {
        // Thin pen strokes (2 px), the darkest tone half ink: strokes, not bars.
        Self(TamSettings {
            tones: 6,
            resolution: 256,
            mip_levels: 3,
            strokes_per_tone: 120,
            candidates: 4,
            stroke_length: 0.45,
            stroke_width_px: 2.0,
            darkest_tone: 0.5,
            ..default()
        })
    }
}

/// The tonal art map given to materials that ask for hatching without one: generated on first
/// need, or set it yourself beforehand to use your own map.
#[derive(Resource, Clone, Debug, Default)]
pub struct TonalArtMapCache(pub Option<Handle<Image>>);

/// Gives every [`ToonHairMaterial`] that asks for hatching but has no tonal art map the shared
/// generated one (made once, from [`HatchingMapSettings`]), so that switching hatching on in the
/// panel, or loading a preset with hatching, just works. Runs in `PostUpdate`.
pub fn assign_tonal_art_maps(
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    mut images: ResMut<Assets<Image>>,
    mut cache: ResMut<TonalArtMapCache>,
    settings: Res<HatchingMapSettings>,
    mut failed: Local<bool>,
) {
    let needy: Vec<AssetId<ToonHairMaterial>> = materials
        .iter()
        .filter(|(_, m)| m.hatching != HatchingMode::None && m.tonal_art_map.is_none())
        .map(|(id, _)| id)
        .collect();
    if needy.is_empty() || *failed {
        return;
    }
    let map = match &cache.0 {
        Some(map) => map.clone(),
        None => {
            let start = std::time::Instant::now();
            match generate(&StrokeImage::default(), &settings.0, |_, _| {}) {
                Ok(tam) => {
                    info!(
                        "generated a {} px tonal art map for hatching in {:.2} s",
                        tam.resolution(),
                        start.elapsed().as_secs_f32()
                    );
                    let handle = images.add(tonal_art_map_image(&tam));
                    cache.0 = Some(handle.clone());
                    handle
                }
                Err(e) => {
                    // Once: the settings will not get better by themselves.
                    error!("cannot generate a tonal art map for hatching: {e}");
                    *failed = true;
                    return;
                }
            }
        }
    };
    for id in needy {
        if let Some(mut m) = materials.get_mut(id) {
            m.tonal_art_map = Some(map.clone());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::ToonShading;

    #[test]
    fn hatching_materials_get_one_shared_generated_map() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>()
            .init_asset::<ToonHairMaterial>()
            .init_resource::<HatchingMapSettings>()
            .init_resource::<TonalArtMapCache>()
            .add_systems(Update, assign_tonal_art_maps);
        let mut materials = app.world_mut().resource_mut::<Assets<ToonHairMaterial>>();
        let plain = materials.add(ToonHairMaterial::default());
        let hatched = [HatchingMode::Screen, HatchingMode::Surface].map(|hatching| {
            materials.add(ToonHairMaterial::new(
                ToonShading {
                    hatching,
                    ..default()
                },
                Handle::default(),
            ))
        });
        app.update();
        let materials = app.world().resource::<Assets<ToonHairMaterial>>();
        assert!(materials.get(&plain).unwrap().tonal_art_map.is_none());
        let maps = hatched.map(|h| materials.get(&h).unwrap().tonal_art_map.clone());
        let map = maps[0].clone().expect("hatching material got a map");
        assert_eq!(maps[1].as_ref(), Some(&map), "one map, shared");
        let image = app.world().resource::<Assets<Image>>().get(&map).unwrap();
        let settings = HatchingMapSettings::default().0;
        assert_eq!(
            image.texture_descriptor.size.depth_or_array_layers as usize,
            settings.tones
        );
    }
}

#[cfg(test)]
mod look {
    use super::*;

    /// The map materials get by default: pen strokes, not bars. Thin strokes, a light first tone
    /// and a darkest tone that still reads as hatching (paper between the strokes).
    #[test]
    fn the_default_map_is_thin_light_pen_strokes() {
        let settings = HatchingMapSettings::default().0;
        let map = generate(&StrokeImage::default(), &settings, |_, _| {}).unwrap();
        let inks: Vec<f32> = (0..map.tones).map(|t| map.levels[0].mean_ink(t)).collect();
        println!(
            "default hatching map: {} px strokes, mean ink per tone {inks:.3?}",
            settings.stroke_width_px
        );
        assert!(settings.stroke_width_px <= 2.5, "strokes read as bars");
        assert!(
            inks[0] <= 0.12,
            "the lightest tone is already dark: {inks:?}"
        );
        let darkest = inks[map.tones - 1];
        assert!(
            (0.35..=0.65).contains(&darkest),
            "the darkest tone must read as hatching, not ink: {darkest}"
        );
        assert!(
            inks.windows(2).all(|w| w[1] > w[0]),
            "tones darken: {inks:?}"
        );
    }
}
