//! GPU side: the WGSL modules shared by the crate's materials and passes.
//!
//! Shared modules start with `#define_import_path bevy_cartoon_hair::<module>` and are registered
//! by [`HairShaderLibraryPlugin`]; `cargo test` composes and validates every one of them with
//! naga (see `shader_validation`), so a WGSL mistake fails the tests, not a user's frame.

use bevy::prelude::*;
use bevy::shader::load_shader_library;

#[cfg(test)]
mod shader_validation;

/// Every WGSL library module of the crate, as `(import path, source)`, for validation and tools.
pub const SHADER_LIBRARY: &[(&str, &str)] =
    &[("bevy_cartoon_hair::curves", include_str!("curves.wgsl"))];

/// Registers the crate's WGSL library modules so materials can `#import` them. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairShaderLibraryPlugin;

impl Plugin for HairShaderLibraryPlugin {
    fn build(&self, app: &mut App) {
        load_shader_library!(app, "curves.wgsl");
    }
}
