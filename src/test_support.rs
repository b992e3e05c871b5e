//! What several test modules share.

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::math::Vec3;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;

/// An app with the hair assets and simulation and no render app, stepping `1 / fps` seconds
/// of time per update.
pub(crate) fn sim_app(fps: f64) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        crate::asset::HairAssetPlugin,
        crate::schedule::HairSchedulePlugin,
        crate::sim::HairSimulationPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / fps,
    )));
    app
}

/// A small deterministic generator (xorshift) for random test inputs.
pub(crate) struct Rng(pub u64);

impl Rng {
    /// Uniform in `[0, 1)`.
    pub(crate) fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[-1, 1)`.
    pub(crate) fn next(&mut self) -> f32 {
        self.unit() * 2.0 - 1.0
    }

    /// Each coordinate uniform in `[-scale, scale)`.
    pub(crate) fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// Spiky strands of `particles` particles on the upper half of a head of radius `head` at the
/// origin, spread evenly (golden angle): each leaves the scalp 2 mm out along its normal, runs
/// `length` outward and curls `curl` sideways at the tip.
pub(crate) fn spiky_strands(
    strands: usize,
    particles: usize,
    head: f32,
    length: f32,
    curl: f32,
) -> Vec<Vec<Vec3>> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..strands)
        .map(|i| {
            let y = 1.0 - (i as f32 + 0.5) / strands as f32;
            let r = (1.0 - y * y).sqrt();
            let a = golden * i as f32;
            let n = Vec3::new(r * a.cos(), y, r * a.sin()).normalize();
            let side = n.any_orthonormal_vector();
            (0..particles)
                .map(|k| {
                    let t = k as f32 / (particles - 1) as f32;
                    n * (head + 0.002 + length * t) + side * (curl * t * t)
                })
                .collect()
        })
        .collect()
}

/// The scene of a character whose file does not exist (`characters/missing.glb`), asked of
/// `app`'s asset server: it fails to load a few updates later.
pub(crate) fn missing_scene(app: &mut App) -> bevy::world_serialization::WorldAssetRoot {
    app.init_asset::<bevy::world_serialization::WorldAsset>();
    let scene = app
        .world()
        .resource::<AssetServer>()
        .load(bevy::gltf::GltfAssetLabel::Scene(0).from_asset("characters/missing.glb"));
    bevy::world_serialization::WorldAssetRoot(scene)
}

/// Updates `app` until `done` holds, at most 500 times, 2 ms apart (the asset server loads on
/// threads of its own).
pub(crate) fn update_until(app: &mut App, done: impl Fn(&App) -> bool) {
    for _ in 0..500 {
        app.update();
        if done(app) {
            return;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}
