//! [`ImageSpaceOutline`]: image-space silhouette edges (thesis 4.3.7; Redmond et al., Shin et
//! al.), a post-process pass that inks the outline of the hair and the character.
//!
//! Edges come from a buffer in which objects are flat, Bevy's depth and normal prepass, never
//! from the lit colour: the toon ramp's bands inside the hair are not edges. Per frame, on each
//! camera with an enabled [`ImageSpaceOutline`], three fullscreen passes in the `Core3d` schedule
//! (`outline.wesl`):
//!
//! 1. `detect`: Sobel (both kernels, magnitude `sqrt(gx^2 + gy^2)`) on the prepass depth and/or
//!    normals, thresholded with [`ImageSpaceOutline::threshold`] into an edge mask. The default
//!    source, [`OutlineSource::Mass`], finds the edges of the hair as one mass: a hair mask the
//!    hair's own prepass writes (the normal target's alpha), coverage, and large relative depth
//!    steps; the inside of the hair stays clean unless
//!    [`ImageSpaceOutline::inner_threshold`] asks for inner lines;
//! 2. `dilate_x`: a pixel becomes edge if an edge lies within
//!    [`ImageSpaceOutline::dilation_x`] pixels horizontally;
//! 3. `composite`: the same vertically with [`ImageSpaceOutline::dilation_y`], then the
//!    [`ImageSpaceOutline::color`] is mixed over the frame (with
//!    [`ImageSpaceOutline::hair_tint`], where the line runs along hair, the colour of the hair
//!    beside it, found in the hair mask, times the tint).
//!
//! **Anti-aliasing** comes from the camera's MSAA (`Msaa::Sample4`, Bevy's default): the prepass
//! textures are then multisampled, and sample `s` of every pixel is the picture rendered at one
//! sub-pixel offset. Edges are found and dilated in each of up to four samples on their own (one
//! channel of the edge mask each), and the ink covers a pixel by the share of its samples that
//! are inked, so slanted lines run straight instead of in stair steps. With `Msaa::Off` the ink
//! is hard-edged, whole pixels.
//!
//! The pass runs after tone mapping, so the ink is exactly the colour asked for.
//!
//! The thesis could not switch its outline back on once off. Here
//! [`ImageSpaceOutline::enabled`] may change any number of times: while off the component is not
//! extracted, so the pass is skipped, and the prepasses the plugin added for it are removed.

mod pass;
mod pipeline;
mod prepass;

use bevy::core_pipeline::tonemapping::tonemapping;
use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::ecs::query::QueryItem;
use bevy::ecs::system::lifetimeless::Read;
use bevy::prelude::*;
use bevy::render::extract_component::{
    DynamicUniformIndex, ExtractComponent, ExtractComponentPlugin, UniformComponentPlugin,
};
use bevy::render::render_resource::ShaderType;
use bevy::render::sync_component::SyncComponent;

use crate::math::finite_or;

use pass::{OutlineBindGroups, OutlineTextures};
use pass::{image_space_outline, prepare_outline_bind_groups, prepare_outline_textures};
use pipeline::OutlinePipelineIds;
#[cfg(test)]
pub(crate) use pipeline::OutlinePipelineKey;
use pipeline::{init_outline_pipelines, prepare_outline_pipelines};
use prepass::sync_outline_prepasses;

use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

/// The most pixels [`ImageSpaceOutline::dilation_x`] and [`ImageSpaceOutline::dilation_y`] reach;
/// larger values are clamped to it (the shader's loops are bounded).
pub const MAX_OUTLINE_DILATION: u32 = 32;

/// [`GpuImageSpaceOutline::inner_threshold`] when there are no inner lines: above any Sobel
/// magnitude of unit normals (at most 4).
const NO_INNER_LINES: f32 = 1.0e9;

/// Which flat buffer the edges are detected in. Each choice is its own pipeline (shader defs
/// `EDGE_DEPTH`, `EDGE_NORMALS`), and adds only the prepasses it reads.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum OutlineSource {
    /// The outline of the hair as one mass, the thesis's own idea (Sobel on a solid-shaded
    /// render): an edge where hair meets anything else (a hair mask the hair's prepass writes
    /// into the normal target's alpha), where anything meets the background, and where the
    /// depth steps by more than [`ImageSpaceOutline::threshold`] relative to the nearer surface
    /// (0.3: the far side is 1.43x as far). Strands lying on other strands are not edges, so
    /// the inside of the hair stays clean; [`ImageSpaceOutline::inner_threshold`] adds inner
    /// lines from the normals. Reads the depth and normal prepasses.
    #[default]
    Mass,
    /// Depth and normals: silhouettes against the background and against objects behind
    /// (depth), and creases where a strand crosses another at the same depth (normals). On
    /// hair this inks nearly every strand.
    DepthAndNormals,
    /// Depth only (`DepthPrepass`): silhouettes, no creases; the cheapest.
    Depth,
    /// Normals only (`NormalPrepass`): creases and silhouettes, but strands parallel to each
    /// other at different depths merge.
    Normals,
}

impl OutlineSource {
    /// Reads the depth prepass.
    pub fn uses_depth(self) -> bool {
        matches!(self, Self::Mass | Self::DepthAndNormals | Self::Depth)
    }

    /// Reads the normal prepass.
    pub fn uses_normals(self) -> bool {
        matches!(self, Self::Mass | Self::DepthAndNormals | Self::Normals)
    }
}

/// Image-space outline on a camera (`Camera3d`): an ink line wherever the depth or normals jump.
///
/// Add it to the camera; the [`ImageSpaceOutlinePlugin`] adds the `DepthPrepass` and
/// `NormalPrepass` it needs while enabled (and removes them again when disabled, unless they
/// were there before). Every field can change every frame.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct ImageSpaceOutline {
    /// Draw the outline. Switch it off and on as often as you like; while off the pass costs one
    /// check per frame and the prepasses added for it are removed. Default: `true`.
    pub enabled: bool,
    /// Edge Threshold: the Sobel magnitude above which a pixel is an edge. A jump from an object
    /// to the background measures about 1; lower values also ink creases and strands close in
    /// front of others, higher values only the outer silhouette. Default: `0.3`.
    pub threshold: f32,
    /// X Dilation: a pixel becomes edge if an edge lies within this many pixels horizontally.
    /// Wider lines cost a longer loop; clamped to [`MAX_OUTLINE_DILATION`]. Default: `1`.
    pub dilation_x: u32,
    /// Y Dilation: a pixel becomes edge if an edge lies within this many pixels vertically.
    /// Clamped to [`MAX_OUTLINE_DILATION`]. Default: `1`.
    pub dilation_y: u32,
    /// Ink colour; its alpha is the ink's opacity over the frame. Default: black.
    pub color: Color,
    /// The flat buffer edges are found in. Default: [`OutlineSource::Mass`].
    pub source: OutlineSource,
    /// Inner lines, with [`OutlineSource::Mass`] only: a pixel whose Sobel magnitude on the
    /// prepass normals exceeds this is also an edge (about 0.3 inks most strands' creases, 1.0
    /// only sharp folds). `None`: the mass's outline alone. Default: `None`.
    pub inner_threshold: Option<f32>,
    /// Lines between locks, with [`OutlineSource::Mass`] only: a line where one lock of the
    /// crate's hair lies over another, so that locks of one tone do not merge into one shape.
    /// `None`: no such lines. Default: `None`.
    #[reflect(default)]
    pub lock_lines: Option<LockLines>,
    /// The mass outline in the hair's own colour, with [`OutlineSource::Mass`] only: `Some(c)`
    /// draws the outline where it runs along hair in the colour of the hair beside it times `c`
    /// (`srgb(0.45, 0.3, 0.3)`: a darker line in the hair's hue and tone, the coloured line
    /// anime and illustration draw around hair instead of black), at the outline's opacity.
    /// Where no hair lies within the line's reach (another object's own outline) the line keeps
    /// [`color`](Self::color). Channels are clamped to 0-4 (non-finite ones read as 0). `None`:
    /// the outline's ink everywhere. Default: `None`.
    #[reflect(default)]
    pub hair_tint: Option<Color>,
}

/// Lines where one lock lies over another ([`ImageSpaceOutline::lock_lines`]).
///
/// Each strand of a hair is a lock with an id (its index modulo 3, which the hair's prepass
/// writes next to its normals). A hair pixel gets a line when, within
/// [`LockLines::width_px`], hair of another id lies behind it by more than
/// [`LockLines::threshold`] of its distance: the edge of the lock on top is inked, a lock's own
/// folds are not (one id), and locks side by side at one depth stay one shape. Three ids are
/// few: two overlapping strands of the same id (every third in the groom's order) draw no line.
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq, Clone)]
pub struct LockLines {
    /// The depth step, relative to the nearer lock's distance, above which a lock lying over
    /// another gets a line: `0.01` is one centimetre at one metre. Default: `0.004`.
    pub threshold: f32,
    /// How far from the lower lock the line reaches onto the upper one, in pixels (the mass
    /// outline's dilation does not widen it). Clamped to `[1, 4]`. Default: `1`.
    pub width_px: u32,
    /// The view distances (metres) over which the lines fade out: full up to `fade.x`, none
    /// past `fade.y`, so a crowd far away is not a tangle of lines. Perspective cameras only;
    /// `fade.y <= fade.x` never fades. Default: `(3, 8)`.
    pub fade: Vec2,
    /// Lines in the hair's own colour: `Some(c)` draws each line in the colour of the lock it
    /// lies on times `c` (`srgb(0.5, 0.35, 0.35)`: a darker line in the lock's hue and tone, as
    /// anime colours the lines inside hair), at the outline's opacity; the mass outline keeps the
    /// outline's ink. Channels are clamped to 0-4 (non-finite ones read as 0). `None`: in the
    /// outline's ink. Default: `None`.
    #[reflect(default)]
    pub hair_tint: Option<Color>,
}

impl Default for LockLines {
    fn default() -> Self {
        Self {
            threshold: 0.004,
            width_px: 1,
            fade: Vec2::new(3.0, 8.0),
            hair_tint: None,
        }
    }
}

impl Default for ImageSpaceOutline {
    fn default() -> Self {
        Self {
            enabled: true,
            threshold: 0.3,
            dilation_x: 1,
            dilation_y: 1,
            color: Color::BLACK,
            source: OutlineSource::Mass,
            inner_threshold: None,
            lock_lines: None,
            hair_tint: None,
        }
    }
}

/// The uniform block of an enabled [`ImageSpaceOutline`] (`outline.wesl`), on the render world's
/// view entity.
#[derive(Component, Clone, Copy, Debug, Default, ShaderType)]
pub struct GpuImageSpaceOutline {
    /// Linear RGBA ink.
    pub color: Vec4,
    /// Sobel magnitude threshold.
    pub threshold: f32,
    /// Horizontal dilation in pixels, clamped.
    pub dilation_x: u32,
    /// Vertical dilation in pixels, clamped.
    pub dilation_y: u32,
    /// Normal Sobel magnitude above which [`OutlineSource::Mass`] draws inner lines; a huge
    /// value when there are none.
    pub inner_threshold: f32,
    /// [`LockLines::threshold`].
    pub lock_threshold: f32,
    /// [`LockLines::width_px`], `0` when there are no lines between locks.
    pub lock_width: u32,
    /// [`LockLines::fade`].
    pub lock_fade: Vec2,
    /// The camera's near plane for the fade, `0` when it is not a perspective camera.
    pub near: f32,
    /// [`LockLines::hair_tint`] in linear RGB; alpha 1 when it is set, 0 when the lines take the
    /// outline's ink.
    pub lock_tint: Vec4,
    /// [`ImageSpaceOutline::hair_tint`] in linear RGB; alpha 1 when it is set, 0 when the mass
    /// outline takes the outline's ink.
    pub mass_tint: Vec4,
}

/// Which detection pipeline a view needs: its [`OutlineSource`], on the render world's view
/// entity.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OutlineSourceKey(pub OutlineSource);

impl SyncComponent<RenderApp> for ImageSpaceOutline {
    // Everything the pass keeps on a view goes when the outline is disabled or removed.
    type Target = (
        GpuImageSpaceOutline,
        OutlineSourceKey,
        DynamicUniformIndex<GpuImageSpaceOutline>,
        OutlinePipelineIds,
        OutlineTextures,
        OutlineBindGroups,
    );
}

impl ExtractComponent<RenderApp> for ImageSpaceOutline {
    type QueryData = (Read<ImageSpaceOutline>, Option<Read<Projection>>);
    type QueryFilter = With<Camera3d>;
    type Out = (GpuImageSpaceOutline, OutlineSourceKey);

    fn extract_component(
        (outline, projection): QueryItem<'_, '_, Self::QueryData>,
    ) -> Option<Self::Out> {
        // Disabled: not extracted, so the render world has nothing to run the pass on.
        if !outline.enabled {
            return None;
        }
        let threshold =
            finite_or(outline.threshold, ImageSpaceOutline::default().threshold).max(0.0);
        // Lines between locks need the mass's hair mask.
        let lock = outline
            .lock_lines
            .filter(|_| outline.source == OutlineSource::Mass);
        Some((
            GpuImageSpaceOutline {
                color: super::linear_color(outline.color, 0.0, 1e4)
                    .truncate()
                    .extend(finite_or(outline.color.alpha(), 1.0).clamp(0.0, 1.0)),
                threshold,
                dilation_x: outline.dilation_x.min(MAX_OUTLINE_DILATION),
                dilation_y: outline.dilation_y.min(MAX_OUTLINE_DILATION),
                inner_threshold: outline
                    .inner_threshold
                    .filter(|t| t.is_finite())
                    .map_or(NO_INNER_LINES, |t| t.max(0.0)),
                lock_threshold: lock.map_or(0.0, |l| finite_or(l.threshold, 0.004).max(0.0)),
                lock_width: lock.map_or(0, |l| l.width_px.clamp(1, 4)),
                lock_fade: lock
                    .map(|l| l.fade)
                    .filter(|f| f.is_finite())
                    .unwrap_or(Vec2::ZERO),
                near: match projection {
                    Some(Projection::Perspective(p)) if p.near.is_finite() => p.near.max(0.0),
                    _ => 0.0,
                },
                lock_tint: lock.and_then(|l| l.hair_tint).map_or(Vec4::ZERO, |c| {
                    super::linear_color(c, 0.0, 4.0).truncate().extend(1.0)
                }),
                // The hair beside the line is found in the mass's hair mask.
                mass_tint: outline
                    .hair_tint
                    .filter(|_| outline.source == OutlineSource::Mass)
                    .map_or(Vec4::ZERO, |c| {
                        super::linear_color(c, 0.0, 4.0).truncate().extend(1.0)
                    }),
            },
            OutlineSourceKey(outline.source),
        ))
    }
}

/// Draws [`ImageSpaceOutline`]s. Part of [`CartoonHairPlugins`](crate::CartoonHairPlugins)
/// (feature `render`).
#[derive(Default)]
pub struct ImageSpaceOutlinePlugin;

impl Plugin for ImageSpaceOutlinePlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "outline.wesl");
        app.register_type::<ImageSpaceOutline>()
            .register_type::<LockLines>()
            .add_plugins((
                ExtractComponentPlugin::<ImageSpaceOutline>::default(),
                UniformComponentPlugin::<GpuImageSpaceOutline>::default(),
            ))
            // Extraction reads the prepass components after the main schedule, so anywhere in
            // PostUpdate is in time for this frame.
            .add_systems(PostUpdate, sync_outline_prepasses);

        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .add_systems(RenderStartup, init_outline_pipelines)
            .add_systems(
                Render,
                (
                    prepare_outline_pipelines.in_set(RenderSystems::Prepare),
                    prepare_outline_textures.in_set(RenderSystems::PrepareResources),
                    prepare_outline_bind_groups.in_set(RenderSystems::PrepareBindGroups),
                ),
            )
            .add_systems(
                Core3d,
                image_space_outline
                    .in_set(Core3dSystems::PostProcess)
                    // Ink after tone mapping keeps its exact colour.
                    .after(tonemapping),
            );
    }
}
