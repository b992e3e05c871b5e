//! The modelled-hair avatar (`assets/chain_hair/chain_hair.glb`, thick locks on bone chains) in
//! the shipped looks that ink a modelled mesh (the image-space outline: clean_anime and
//! anime_locks; thesis and sketch ink with strokes built from strands), from the front, the side
//! and the back, measured as the look suite measures the ninja.

use std::time::Duration;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{
    FringeShadow, FringeShadowMeshes, FringeShadowMeshesApplied, ToonHairMeshes,
    ToonHairMeshesApplied, ToonRamps,
};
use libtest_mimic::Failed;

use crate::look_suite::{
    BOUNDARY_INKED_LEAST, LOCK_LINES_INSIDE_MOST, OUTLINE_INSIDE_MOST, mask_of, measure,
    set_material,
};
use crate::toon_render::save;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "the_avatar_in_the_outlined_looks_from_three_views",
    the_avatar_in_the_outlined_looks_from_three_views,
)];

/// Each look: the avatar's hair mesh in the look's material, the camera with its outline; the
/// character turned to face the camera, its left and its back. In every view the hair covers
/// at least 1% of the frame and has no black pixel (NaN shading); from the front and the side
/// its tones differ (luma p90 - p10 at least 10); the outline inks at least 85% of the hair's
/// boundary and at most 2% of its inside (15% with lines between locks).
fn the_avatar_in_the_outlined_looks_from_three_views() -> Result<(), Failed> {
    let mut failures = Vec::new();
    for look_name in ["clean_anime", "anime_locks"] {
        let look = HairPreset::look(look_name).ok_or("a shipped look")??;
        let mut r = HeadlessRenderer::new(CaptureSettings {
            width: 320,
            height: 240,
            max_frames: 3_000,
            ..default()
        })?;
        let target = r.target();
        r.app
            .add_plugins(CartoonHairPlugins)
            .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
        let world = r.app.world_mut();
        let ramps = world.resource::<ToonRamps>().clone();
        let mut shipped = ToonHairMaterial::default();
        look.material.apply(&mut shipped, &ramps);
        let handle = world
            .resource_mut::<Assets<ToonHairMaterial>>()
            .add(shipped.clone());
        let assets = world.resource::<AssetServer>().clone();
        let character = world
            .spawn((
                WorldAssetRoot(
                    assets.load(GltfAssetLabel::Scene(0).from_asset("chain_hair/chain_hair.glb")),
                ),
                Transform::default(),
                ToonHairMeshes::matching(|n| n == "hair").with_material(handle.clone()),
                // The face and body in the toon look too, the face taking the fringe's shadow.
                FringeShadowMeshes::all_except(|n| n == "hair", FringeShadow::cel()),
            ))
            .id();
        world.spawn((
            DirectionalLight {
                illuminance: 9_000.0,
                ..default()
            },
            Transform::from_xyz(1.0, 3.0, 2.5).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
        ));
        let outline = look.outline.clone().ok_or("the look has no outline")?;
        world.spawn((
            Camera3d::default(),
            Camera {
                clear_color: ClearColorConfig::Custom(Color::srgb(0.8, 0.85, 0.95)),
                ..default()
            },
            RenderTarget::Image(target.into()),
            Transform::from_xyz(0.0, 1.72, 0.85).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y),
            outline,
        ));
        r.warm_up(|world| {
            let mut dressed = world.query::<&ToonHairMeshesApplied>();
            let mut body = world.query::<&FringeShadowMeshesApplied>();
            dressed.iter(world).any(|d| !d.0.is_empty())
                && body.iter(world).any(|d| !d.0.is_empty())
        })?;
        let set_outline = |r: &mut HeadlessRenderer, on: bool| {
            let world = r.app.world_mut();
            let mut cameras = world.query::<&mut ImageSpaceOutline>();
            for mut o in cameras.iter_mut(world) {
                o.enabled = on;
            }
        };
        let lock_lines = look
            .outline
            .as_ref()
            .is_some_and(|o| o.lock_lines.is_some());
        for (view, yaw) in [
            ("front", 0.0),
            ("side", std::f32::consts::FRAC_PI_2),
            ("back", std::f32::consts::PI),
        ] {
            r.app
                .world_mut()
                .entity_mut(character)
                .insert(Transform::from_rotation(Quat::from_rotation_y(yaw)));
            set_material(&mut r, &handle, &mask_of(&shipped));
            set_outline(&mut r, false);
            let mask = r.capture()?;
            set_material(&mut r, &handle, &shipped);
            let plain = r.capture()?;
            set_outline(&mut r, true);
            let inked = r.capture()?;
            save(&inked, &format!("avatar_{look_name}_{view}"))?;
            let m = measure(&mask, &plain, &inked);
            eprintln!(
                "avatar {look_name} {view}: {} hair px, contrast {:.0}, {} black, boundary inked \
                 {:.0}%, inside inked {:.1}%",
                m.hair,
                m.contrast,
                m.black,
                100.0 * m.boundary_inked,
                100.0 * m.interior_inked
            );
            let inside_most = if lock_lines {
                LOCK_LINES_INSIDE_MOST
            } else {
                OUTLINE_INSIDE_MOST
            };
            if m.hair * 100 < 320 * 240
                || m.black > 0
                || (view != "back" && m.contrast < 10.0)
                || m.boundary_inked < BOUNDARY_INKED_LEAST
                || m.interior_inked > inside_most
            {
                failures.push(format!("{look_name} {view}: {m:?}"));
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("; ").into())
    }
}
