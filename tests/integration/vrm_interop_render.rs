//! Beside bevy_vrm1: a game loads its avatar with bevy_vrm1 (for MToon, expressions, look-at),
//! switches bevy_vrm1's spring bones off and lets this crate's solver drive the same joints.
//! The hair must move exactly as it does when this crate loads the file alone.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::asset::VrmLoaderPlugin;
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::sim::{BoneChainHairs, VrmSpringChains};
use bevy_vrm1::prelude::{Initialized, SpringRoot, VrmHandle, VrmPlugin, VrmSystemSets};
use libtest_mimic::Failed;

use crate::chain_render::joints_in_head;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "an_avatar_bevy_vrm1_loads_swings_its_hair_on_this_crates_solver",
    an_avatar_bevy_vrm1_loads_swings_its_hair_on_this_crates_solver,
)];

const FILE: &str = "chain_hair/chain_hair.vrm";

/// What one run saw.
struct Trace {
    /// Springs this crate built from the file.
    springs: usize,
    /// bevy_vrm1's spring roots on the avatar (0 when it is not added).
    their_springs: usize,
    /// Per frame of the shake and settle: every hair joint's position in the head's space,
    /// joints in name order.
    frames: Vec<Vec<Vec3>>,
}

/// Loads the VRM 1.0 test avatar, with bevy_vrm1 (its springs switched off) or with this crate
/// alone, turns the head fast for 0.6 s at 60 Hz and lets it settle for 1 s.
fn run(with_bevy_vrm1: bool) -> Result<Trace, Failed> {
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width: 64,
        height: 64,
        max_frames: 3_000,
        ..default()
    })?;
    let app = &mut renderer.app;
    if with_bevy_vrm1 {
        // The VRM guide's recipe. bevy_vrm1 opens `.vrm` files (its loader keeps what it reads
        // back); this crate's handler still reads the springs as the file loads. bevy_vrm1's
        // spring solver is switched off, and the hair steps after its constraints and
        // expressions have posed the head, as VRM's update order has springs last.
        app.add_plugins(CartoonHairPlugins.build().disable::<VrmLoaderPlugin>())
            .add_plugins(VrmPlugin)
            .configure_sets(PostUpdate, VrmSystemSets::SpringBone.run_if(|| false))
            .configure_sets(
                PostUpdate,
                HairSystems::Attach.after(VrmSystemSets::PropagateAfterExpressions),
            );
    } else {
        app.add_plugins(CartoonHairPlugins);
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let world = app.world_mut();
    let assets = world.resource::<AssetServer>().clone();
    let avatar = if with_bevy_vrm1 {
        world.spawn(VrmHandle(assets.load(FILE))).id()
    } else {
        world
            .spawn(WorldAssetRoot(
                assets.load(GltfAssetLabel::Scene(0).from_asset(FILE)),
            ))
            .id()
    };
    renderer.warm_up(|world| {
        let mut springs = world.query::<&VrmSpringChains>();
        let Some(built) = springs.iter(world).next().cloned() else {
            return false;
        };
        let initialised = !with_bevy_vrm1 || world.get::<Initialized>(avatar).is_some();
        initialised
            && !built.springs.is_empty()
            && built.springs.iter().all(|s| {
                world
                    .get::<BoneChainHairs>(*s)
                    .is_some_and(|h| !h.0.is_empty())
            })
    })?;
    let world = renderer.app.world_mut();
    let springs = world
        .query::<&VrmSpringChains>()
        .iter(world)
        .next()
        .map_or(0, |b| b.springs.len());
    let their_springs = world.query::<&SpringRoot>().iter(world).count();
    let mut named: Vec<(String, Entity)> = world
        .query::<(Entity, &Name)>()
        .iter(world)
        .map(|(e, n)| (n.as_str().to_owned(), e))
        .collect();
    named.sort();
    let head = named
        .iter()
        .find(|(n, _)| n == "head")
        .map(|(_, e)| *e)
        .ok_or("the avatar has no head bone")?;
    let joints: Vec<Entity> = named
        .iter()
        .filter(|(n, _)| n.starts_with("hair_"))
        .map(|(_, e)| *e)
        .collect();
    let head_rest = world.get::<Transform>(head).ok_or("head")?.rotation;
    let in_head = |world: &World| joints_in_head(world, head, &joints);
    for _ in 0..30 {
        renderer.update_by(1.0 / 60.0);
    }
    let mut frames = Vec::new();
    for f in 0..96 {
        let t = (f + 1) as f32 / 60.0;
        let turn = if t < 0.6 {
            let s = (std::f32::consts::PI * t / 0.6).sin();
            Quat::from_rotation_z(-0.8 * s) * Quat::from_rotation_x(0.5 * s)
        } else {
            Quat::IDENTITY
        };
        renderer
            .app
            .world_mut()
            .get_mut::<Transform>(head)
            .unwrap()
            .rotation = head_rest * turn;
        renderer.update_by(1.0 / 60.0);
        frames.push(in_head(renderer.app.world()));
    }
    Ok(Trace {
        springs,
        their_springs,
        frames,
    })
}

fn an_avatar_bevy_vrm1_loads_swings_its_hair_on_this_crates_solver() -> Result<(), Failed> {
    let alone = run(false)?;
    let beside = run(true)?;
    // How far the hair swings (against the first frame), and how far the two runs part.
    let mut swing = 0.0f32;
    let mut apart = 0.0f32;
    for (a, b) in alone.frames.iter().zip(&beside.frames) {
        for ((p, q), rest) in a.iter().zip(b).zip(&alone.frames[0]) {
            swing = swing.max(p.distance(*rest));
            apart = apart.max(p.distance(*q));
        }
    }
    let joints = alone.frames.first().map_or(0, Vec::len);
    println!(
        "alone: {} springs; beside bevy_vrm1: {} springs ({} of bevy_vrm1's spring roots, \
         switched off); {joints} hair joints over {} frames: swung up to {swing:.4} m, the two \
         runs at most {apart:.2e} m apart",
        alone.springs,
        beside.springs,
        beside.their_springs,
        alone.frames.len()
    );
    if alone.springs != 13 || beside.springs != 13 {
        return Err(format!(
            "springs built: {} alone, {} beside bevy_vrm1 (the file has 13)",
            alone.springs, beside.springs
        )
        .into());
    }
    // bevy_vrm1 read the same springs (so its solver would run, were it not switched off).
    if beside.their_springs != 13 {
        return Err(format!("bevy_vrm1 found {} spring roots", beside.their_springs).into());
    }
    if alone.frames.len() != beside.frames.len() || joints == 0 {
        return Err("the runs recorded different joints".into());
    }
    if swing < 0.01 {
        return Err(format!("the hair swung only {swing} m: nothing to compare").into());
    }
    // The same solver on the same input: the same poses. (With bevy_vrm1's spring set left
    // on, its solver also turns the joints and they part by 0.8 mm.)
    if apart > 1e-5 {
        return Err(format!(
            "beside bevy_vrm1 the hair joints part from this crate's own run by {apart} m"
        )
        .into());
    }
    Ok(())
}
