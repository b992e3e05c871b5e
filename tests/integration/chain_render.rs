//! Hair modelled as a mesh on hair-bone chains (`assets/chain_hair/`, made by
//! `tools/blender/author_chain_hair.py`): with `HairBoneChains` the solver moves the bones and
//! Bevy's skinning bends the user's own hair mesh. Rendered headless in a head shake, beside the
//! same character without chains (its hair rigid on the head).

use std::time::Duration;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::asset::CollisionSphere;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::sim::BoneChainHairs;
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "a_modelled_hair_mesh_swings_on_simulated_bone_chains",
    a_modelled_hair_mesh_swings_on_simulated_bone_chains,
)];

/// The hair material's red-brown, in any light.
fn is_hair([r, g, b, _]: [u8; 4]) -> bool {
    let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
    r > 40.0 && g < 0.6 * r && b < 0.45 * r && g > 0.05 * r
}

/// Frames of one run, and the hair joints' largest distance from where they rested.
struct Run {
    rest: CapturedFrame,
    shaken: CapturedFrame,
    after: CapturedFrame,
    swing: f32,
    back: f32,
}

fn head_yaw(t: f32) -> Quat {
    Quat::from_rotation_y(0.9 * (std::f32::consts::TAU * 1.5 * t).sin())
}

/// A sun and a camera rendering into `target`, close on the modelled-hair character's head.
pub fn stage(world: &mut World, target: Handle<Image>) {
    world.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            ..default()
        },
        Transform::from_xyz(1.0, 3.0, 2.5).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.0, 1.75, 0.75).looking_at(Vec3::new(0.0, 1.62, 0.0), Vec3::Y),
    ));
}

fn run(chains: bool) -> Result<Run, Failed> {
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width: 320,
        height: 240,
        max_frames: 3_000,
        ..default()
    })?;
    let target = renderer.target();
    let app = &mut renderer.app;
    app.add_plugins(CartoonHairPlugins)
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let world = app.world_mut();
    let assets = world.resource::<AssetServer>().clone();
    let character = world
        .spawn(WorldAssetRoot(assets.load(
            GltfAssetLabel::Scene(0).from_asset("chain_hair/chain_hair.glb"),
        )))
        .id();
    if chains {
        world.spawn((
            HairBoneChains::matching(character, |n| n.starts_with("hair_")),
            HairSimSettings {
                bend_stiffness: 0.4,
                ..default()
            },
        ));
    }
    world.spawn((
        HairCollider {
            spheres: vec![CollisionSphere {
                center: Vec3::new(0.0, 0.09, -0.01),
                radius: 0.1,
            }],
            ..default()
        },
        AttachToBone::named(character, "head"),
    ));
    stage(world, target);
    renderer.warm_up(|world| {
        let mut names = world.query::<&Name>();
        let loaded = names.iter(world).any(|n| n.as_str() == "hair_tail_0");
        let mut built = world.query::<&BoneChainHairs>();
        loaded && (!chains || built.iter(world).any(|b| !b.0.is_empty()))
    })?;
    let joints: Vec<Entity> = {
        let world = renderer.app.world_mut();
        let mut names = world.query::<(Entity, &Name)>();
        names
            .iter(world)
            .filter(|(_, n)| n.as_str().starts_with("hair_"))
            .map(|(e, _)| e)
            .collect()
    };
    let head = {
        let world = renderer.app.world_mut();
        let mut names = world.query::<(Entity, &Name)>();
        names
            .iter(world)
            .find(|(_, n)| n.as_str() == "head")
            .map(|(e, _)| e)
            .ok_or("the character has no head bone")?
    };
    let in_head = |world: &World| joints_in_head(world, head, &joints);
    // Settle for 1.5 s, still.
    for _ in 0..45 {
        renderer.update_by(1.0 / 30.0);
    }
    let rest_joints = in_head(renderer.app.world());
    let rest = renderer.capture()?;
    // Shake the head for 0.6 s and capture mid-swing.
    let mut swing = 0.0f32;
    for f in 0..18 {
        let t = (f + 1) as f32 / 30.0;
        renderer
            .app
            .world_mut()
            .get_mut::<Transform>(character)
            .unwrap()
            .rotation = head_yaw(t);
        renderer.update_by(1.0 / 30.0);
        let now = in_head(renderer.app.world());
        swing = swing.max(
            now.iter()
                .zip(&rest_joints)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0, f32::max),
        );
    }
    let shaken = renderer.capture()?;
    // Still again for 3 s.
    renderer
        .app
        .world_mut()
        .get_mut::<Transform>(character)
        .unwrap()
        .rotation = Quat::IDENTITY;
    for _ in 0..90 {
        renderer.update_by(1.0 / 30.0);
    }
    let back = in_head(renderer.app.world())
        .iter()
        .zip(&rest_joints)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    let after = renderer.capture()?;
    Ok(Run {
        rest,
        shaken,
        after,
        swing,
        back,
    })
}

/// Pixels where exactly one of the two frames shows hair.
fn hair_moved(a: &CapturedFrame, b: &CapturedFrame) -> usize {
    let mut n = 0;
    for y in 0..a.height {
        for x in 0..a.width {
            if is_hair(a.pixel(x, y)) != is_hair(b.pixel(x, y)) {
                n += 1;
            }
        }
    }
    n
}

fn a_modelled_hair_mesh_swings_on_simulated_bone_chains() -> Result<(), Failed> {
    let simulated = run(true)?;
    let rigid = run(false)?;
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        let dir = std::path::Path::new(&dir);
        simulated.rest.save_png(dir.join("chain_hair_rest.png"))?;
        simulated
            .shaken
            .save_png(dir.join("chain_hair_shaken.png"))?;
        simulated.after.save_png(dir.join("chain_hair_after.png"))?;
        rigid
            .shaken
            .save_png(dir.join("chain_hair_rigid_shaken.png"))?;
    }
    let hair = simulated.rest.count(is_hair);
    let swung = hair_moved(&simulated.shaken, &rigid.shaken);
    let settled = hair_moved(&simulated.after, &simulated.rest);
    let rigid_back = hair_moved(&rigid.after, &rigid.rest);
    println!(
        "chain hair: {hair} hair pixels at rest; mid-shake {swung} differ from the rigid hair; \
         after settling {settled} differ from rest (rigid: {rigid_back}); joints swung {:.4} m \
         and came back within {:.2e} m (rigid: {:.1e} m, {:.1e} m)",
        simulated.swing, simulated.back, rigid.swing, rigid.back
    );
    if hair < 500 {
        return Err(format!("only {hair} hair pixels: the camera does not see the hair").into());
    }
    if rigid.swing > 1e-4 {
        return Err(format!("without chains the hair bones moved {} m", rigid.swing).into());
    }
    if simulated.swing < 0.01 {
        return Err(format!("the chains swung only {} m in the shake", simulated.swing).into());
    }
    // The same pose rendered twice differs in no pixel (see `rigid_back`): 100 is motion.
    if swung < 100 {
        return Err(format!(
            "mid-shake only {swung} pixels differ from the rigid hair: the mesh does not follow \
             the simulated bones"
        )
        .into());
    }
    if simulated.back > 0.002 {
        return Err(format!(
            "the joints rest {} m from where they rested before the shake",
            simulated.back
        )
        .into());
    }
    if settled > 50 + rigid_back {
        return Err(format!("after settling {settled} hair pixels differ from rest").into());
    }
    Ok(())
}

/// Where `joints` are in the head's space (each joint's world position under the head's
/// inverse world transform).
pub fn joints_in_head(world: &World, head: Entity, joints: &[Entity]) -> Vec<Vec3> {
    let h = world
        .get::<GlobalTransform>(head)
        .expect("the head has a GlobalTransform")
        .affine()
        .inverse();
    joints
        .iter()
        .map(|j| {
            let p = world
                .get::<GlobalTransform>(*j)
                .expect("a joint has a GlobalTransform")
                .translation();
            h.transform_point3(p)
        })
        .collect()
}
