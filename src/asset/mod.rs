//! Hair assets and their loaders: grooms, head collision shapes and hair animations.
//!
//! The formats are documented in `docs/formats.md`. Every loader reports bad input as a
//! [`HairAssetError`] naming the file, the line and column and what is wrong; none panics, and a
//! failed load leaves every other asset untouched.
//!
//! Files are hostile input (players and modders replace them). The loaders read at most a byte
//! limit derived from the count limits (e.g. [`groom_byte_limit`]), parse in one linear pass
//! without building a tree, count strands, particles, spheres and keys before storing them, and
//! resolve animation keys only inside the animation's own asset folder ([`resolve_key_path`]).
//! A game whose asset folder players can write to registers [`regular_file_source`], which
//! refuses FIFOs and devices before Bevy opens them.
//!
//! | asset | file | loader |
//! |-------|------|--------|
//! | [`HairGroom`] | `*.hair.xml` | [`HairGroomLoader`] |
//! | [`HeadCollision`] | `*.collision.xml` | [`HeadCollisionLoader`] |
//! | [`HairAnimation`] | `*.hairanim.xml` | [`HairAnimationLoader`] (keyframe grooms load as dependencies) |
//! | Bevy's `Gltf` | `*.vrm` | [`VrmLoader`], added by [`VrmLoaderPlugin`] (Bevy's glTF loader; any glTF's VRM spring bones become [`VrmSpringBones`], and its MToon shade colours, shading bands and rim lights [`VrmShadeColor`]s, [`VrmShading`]s and [`VrmRim`]s on its meshes, whichever loader opens it) |

mod animation;
mod collision;
mod error;
mod fields;
mod groom;
#[cfg(test)]
mod hostile_tests;
mod prescan;
mod reader;
#[cfg(not(target_arch = "wasm32"))]
mod source;
#[cfg(test)]
mod tests;
mod vrm;
mod vrm_gltf;
mod vrm_mtoon;
mod vrm_mtoon_rim;
mod vrm_mtoon_shading;
#[cfg(test)]
mod vrm_tests;

pub use animation::{
    ANIMATION_BYTE_LIMIT, AnimationDescription, HairAnimation, HairAnimationLoader, HairKeyframe,
    KeyReference, MAX_ANIMATION_PARTICLES, MAX_KEY_PATH, MAX_KEYS, parse_animation,
    resolve_key_path,
};
pub use collision::{
    COLLISION_BYTE_LIMIT, CollisionBox, CollisionCapsule, CollisionPlane, CollisionSphere,
    HeadCollision, HeadCollisionLoader, MAX_SHAPES, parse_collision,
};
pub use error::HairAssetError;
pub use fields::{BYTES_PER_ELEMENT, MAX_COORDINATE, SCALE_RANGE};
pub use groom::{
    ATTRIBUTES_PER_ELEMENT, GROOM_BYTES_PER_PARTICLE, GROOM_BYTES_PER_STRAND, GROOM_PARSE_MEMORY,
    GroomLoaderSettings, HEADER_BYTES, HairGroom, HairGroomLoader, MARKUP_ALLOWANCE,
    MAX_GROOM_MARKUP, MAX_PARTICLES, MAX_PARTICLES_PER_STRAND, MAX_STRANDS, MIN_SEGMENT_LENGTH,
    groom_byte_limit, parse_groom, parse_groom_within,
};
pub use prescan::{MAX_ATTRIBUTES, MAX_DEPTH};
#[cfg(not(target_arch = "wasm32"))]
pub use source::{RegularFileReader, regular_file_source};
pub use vrm::{
    JointLimit, JointLimitShape, MAX_VRM_COLLIDERS, MAX_VRM_COORDINATE, MAX_VRM_FORCE,
    MAX_VRM_GROUPS, MAX_VRM_JOINTS, MAX_VRM_NAME, MAX_VRM_SPRINGS, VrmCollider, VrmError, VrmJoint,
    VrmShape, VrmSpring, VrmSprings, VrmVersion, parse_vrm_springs,
};
pub use vrm_gltf::{VrmLoader, VrmLoaderPlugin, VrmNode, VrmSpringBones};
pub use vrm_mtoon::{MAX_VRM_MATERIALS, VrmShadeColor, parse_vrm_shade_colors};
pub use vrm_mtoon_rim::{MAX_RIM_POWER, VrmRim, parse_vrm_rims};
pub use vrm_mtoon_shading::{VrmShading, parse_vrm_shading};

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
        vrm_gltf::register_handler(app);
    }
}
