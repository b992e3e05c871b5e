//! A character nobody here styled for: the Mixamo-convention test character (0.01 armature
//! scale, centimetre bones, `mixamorig:` names; `assets/mixamo_test/`) wears the ninja's hair,
//! exported with the add-on onto `mixamorig:Head`. Rendered headless beside the unit-scale ninja
//! it was converted from, the two must look alike: the hair sits on the head at its size.

use std::time::Duration;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::mesh::ComputedHairMesh;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::sim::{BoneSearch, HairAssetFailed, StrandOf};
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "mixamo_character_wears_its_hair",
    mixamo_character_wears_its_hair,
)];

/// What one render gave.
struct Worn {
    frame: CapturedFrame,
    /// Each strand's length in the world, metres.
    lengths: Vec<f32>,
    /// The farthest particle from the head bone's origin, metres.
    reach: f32,
}

/// The orange of the material below, in any toon tone (as in `clip.rs`).
fn is_hair([r, g, b, _]: [u8; 4]) -> bool {
    let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
    r > 90.0 && g > 0.35 * r && g < 0.85 * r && b < 0.5 * g
}

/// Failed hair assets, collected by an observer.
#[derive(Resource, Default)]
struct Failures(Vec<String>);

fn wear(glb: &str, bone: &str, groom: &str, collision: &str) -> Result<Worn, Failed> {
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width: 320,
        height: 240,
        max_frames: 3_000,
        ..default()
    })?;
    let target = renderer.target();
    let app = &mut renderer.app;
    app.add_plugins(CartoonHairPlugins)
        .init_resource::<Failures>()
        .add_observer(|e: On<HairAssetFailed>, mut f: ResMut<Failures>| {
            f.0.push(format!("{} {}", e.path, e.error));
        })
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let world = app.world_mut();
    let assets = world.resource::<AssetServer>().clone();
    let material = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(ToonHairMaterial {
            shading: ToonShading {
                base_color: Color::srgb(0.98, 0.62, 0.12),
                ..default()
            },
            ..default()
        });
    let character = world
        .spawn(WorldAssetRoot(
            assets.load(GltfAssetLabel::Scene(0).from_asset(glb.to_string())),
        ))
        .id();
    let hair = world
        .spawn((
            Hair {
                groom: assets.load(groom.to_string()),
                animation: None,
                collision: Some(assets.load(collision.to_string())),
            },
            HairMaterial(material),
            AttachToBone::named(character, bone),
        ))
        .id();
    world.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            ..default()
        },
        Transform::from_xyz(1.5, 3.0, 2.0).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.35, 1.85, 0.75).looking_at(Vec3::new(0.0, 1.7, 0.0), Vec3::Y),
    ));
    renderer.warm_up(|world| {
        let mut meshes = world.query::<&ComputedHairMesh>();
        meshes.iter(world).next().is_some()
    })?;
    // Let the hair settle under gravity for one second.
    renderer
        .app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f32(
            1.0 / 30.0,
        )));
    for _ in 0..30 {
        renderer.update();
    }
    let frame = renderer.capture()?;
    let world = renderer.app.world_mut();
    let failures = &world.resource::<Failures>().0;
    if !failures.is_empty() {
        return Err(format!("{glb}: hair assets failed: {failures:?}").into());
    }
    let Some(BoneSearch::Found(head)) = world.get::<BoneSearch>(hair).copied() else {
        return Err(format!("{glb}: the bone {bone:?} was not found").into());
    };
    let head_at = world
        .get::<GlobalTransform>(head)
        .ok_or("the head has no transform")?
        .translation();
    let mut strands = world.query::<(&StrandOf, &StrandParticles)>();
    let mut lengths = Vec::new();
    let mut reach: f32 = 0.0;
    for (_, particles) in strands.iter(world).filter(|(of, _)| of.0 == hair) {
        let p = &particles.positions;
        lengths.push(p.windows(2).map(|w| w[0].distance(w[1])).sum());
        reach = p.iter().map(|q| q.distance(head_at)).fold(reach, f32::max);
    }
    Ok(Worn {
        frame,
        lengths,
        reach,
    })
}

fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len().max(1) as f32
}

/// The Mixamo-convention character wears the ninja's hair exactly as the ninja does: the same
/// strand lengths in metres (not 65 times longer, as before the fix), within reach of the head,
/// and the same hair pixels in the picture.
fn mixamo_character_wears_its_hair() -> Result<(), Failed> {
    let mixamo = wear(
        "mixamo_test/mixamo.glb",
        "mixamorig:Head",
        "mixamo_test/mixamo.hair.xml",
        "mixamo_test/mixamo.collision.xml",
    )?;
    let ninja = wear(
        "ninja/ninja.glb",
        "head",
        "ninja/ninja.hair.xml",
        "ninja/ninja.collision.xml",
    )?;
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        let dir = std::path::Path::new(&dir);
        mixamo.frame.save_png(dir.join("mixamo_character.png"))?;
        ninja
            .frame
            .save_png(dir.join("mixamo_reference_ninja.png"))?;
    }
    let (m, n) = (mean(&mixamo.lengths), mean(&ninja.lengths));
    println!(
        "mixamo: {} strands, mean length {m:.4} m (ninja {n:.4} m), reach {:.3} m (ninja {:.3} m)",
        mixamo.lengths.len(),
        mixamo.reach,
        ninja.reach
    );
    if mixamo.lengths.len() != ninja.lengths.len() || (m / n - 1.0).abs() > 0.01 {
        return Err(format!("strands differ: mean {m} m vs the ninja's {n} m").into());
    }
    // Strands of up to 0.21 m on a head whose bone sits at the base of the skull.
    if mixamo.reach > 0.45 || (mixamo.reach / ninja.reach - 1.0).abs() > 0.01 {
        return Err(format!(
            "a particle is {} m from the head bone (the ninja's farthest: {} m)",
            mixamo.reach, ninja.reach
        )
        .into());
    }
    // The hair pixels of the two pictures: intersection over union.
    let mask = |f: &CapturedFrame| -> Vec<bool> {
        f.rgba
            .chunks_exact(4)
            .map(|p| is_hair([p[0], p[1], p[2], p[3]]))
            .collect()
    };
    let (a, b) = (mask(&mixamo.frame), mask(&ninja.frame));
    let both = a.iter().zip(&b).filter(|(x, y)| **x && **y).count();
    let either = a.iter().zip(&b).filter(|(x, y)| **x || **y).count();
    let hair_pixels = a.iter().filter(|x| **x).count();
    let iou = both as f32 / either.max(1) as f32;
    println!("mixamo hair pixels {hair_pixels}, overlap with the ninja's: IoU {iou:.3}");
    if hair_pixels < 320 * 240 / 50 {
        return Err(format!("only {hair_pixels} hair pixels on the Mixamo character").into());
    }
    if iou < 0.9 {
        return Err(
            format!("the Mixamo character's hair differs from the ninja's: IoU {iou}").into(),
        );
    }
    Ok(())
}
