//! [`HairHighlightMaterial`]: the material the specular sampling quads are drawn with.

use bevy::pbr::{ExtendedMaterial, MaterialExtension};
use bevy::prelude::*;
use bevy::render::render_resource::AsBindGroup;

/// The material of specular sampling quads: a `StandardMaterial` (unlit, alpha-blended, the
/// highlight texture by default; see [`HighlightMaterial`](super::HighlightMaterial)) shaded
/// exactly as Bevy shades it. Its own type lets the quads that the GPU builds be drawn by the
/// count the highlight pass writes (only the quads that show) without touching how any other
/// `StandardMaterial` is drawn.
pub type HairHighlightMaterial = ExtendedMaterial<StandardMaterial, HairHighlightQuads>;

/// The [`MaterialExtension`] of [`HairHighlightMaterial`]: it adds nothing to the shading.
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Debug, Default, PartialEq)]
pub struct HairHighlightQuads {}

impl MaterialExtension for HairHighlightQuads {}

/// A highlight material with `base`'s look.
pub fn highlight_material(base: StandardMaterial) -> HairHighlightMaterial {
    ExtendedMaterial {
        base,
        extension: HairHighlightQuads {},
    }
}
