//! Hair assets and their loaders: grooms, head collision shapes and hair animations.
//!
//! The formats are documented in `docs/formats.md`. Every loader reports bad input as a
//! [`HairAssetError`] naming the file, the line and column and what is wrong; none panics, and a
//! failed load leaves every other asset untouched.
//!
//! | asset | file | loader |
//! |-------|------|--------|
//! | [`HairGroom`] | `*.hair.xml` | [`HairGroomLoader`] |
//! | [`HeadCollision`] | `*.collision.xml` | [`HeadCollisionLoader`] |
//! | [`HairAnimation`] | `*.hairanim.xml` | [`HairAnimationLoader`] (keyframe grooms load as dependencies) |

mod animation;
mod collision;
mod error;
mod groom;
#[cfg(test)]
mod tests;

pub use animation::{
    AnimationDescription, HairAnimation, HairAnimationLoader, HairKeyframe, KeyReference, MAX_KEYS,
    parse_animation,
};
pub use collision::{
    CollisionSphere, HeadCollision, HeadCollisionLoader, MAX_SPHERES, parse_collision,
};
pub use error::HairAssetError;
pub use groom::{
    HairGroom, HairGroomLoader, MAX_PARTICLES, MAX_PARTICLES_PER_STRAND, MAX_STRANDS,
    MIN_SEGMENT_LENGTH, parse_groom,
};

use bevy::prelude::*;

/// Registers the hair asset types and their loaders. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairAssetPlugin;

impl Plugin for HairAssetPlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<HairGroom>()
            .init_asset::<HeadCollision>()
            .init_asset::<HairAnimation>()
            .register_asset_loader(HairGroomLoader)
            .register_asset_loader(HeadCollisionLoader)
            .register_asset_loader(HairAnimationLoader);
    }
}
