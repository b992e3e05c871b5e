//! What the bench files share: the strands, the plugins, the camera and the heads of hair.
#![allow(dead_code, reason = "each bench file uses part of it")]

use bevy::prelude::*;

/// `strands` strands of `particles` particles on a head of radius 0.1, spread over its top.
pub fn strands(strands: usize, particles: usize) -> Vec<Vec<Vec3>> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..strands)
        .map(|i| {
            let y = 1.0 - (i as f32 + 0.5) / strands as f32;
            let r = (1.0 - y * y).sqrt();
            let a = golden * i as f32;
            let n = Vec3::new(r * a.cos(), y, r * a.sin());
            let side = n.any_orthonormal_vector();
            (0..particles)
                .map(|k| {
                    let t = k as f32 / (particles - 1) as f32;
                    n * (0.102 + 0.15 * t) + side * (0.03 * t * t)
                })
                .collect()
        })
        .collect()
}

/// Minimal plugins with every core in the compute pool: Bevy's default on a 2-core machine keeps
/// one thread each for IO and async work and leaves compute (where systems and `par_iter` run)
/// a single thread. Every bench app gets the same setting.
pub fn minimal_plugins() -> bevy::app::PluginGroupBuilder {
    MinimalPlugins.set(bevy_cartoon_hair::compute_on_every_core())
}

/// Adds the GPU building of tubes, strokes and quads as on any desktop adapter: there is no
/// render device here, so its support is declared. The CPU then does what it does for a
/// GPU-built hair (gathering the passes' inputs); the passes themselves do not run.
pub fn gpu_path(app: &mut App) {
    use bevy_cartoon_hair::render::{
        GpuPassState, GpuTubesPlugin, HairGpuMeshSupport, HairGpuPasses,
    };
    app.add_plugins(GpuTubesPlugin)
        .insert_resource(HairGpuMeshSupport {
            supported: true,
            reason: None,
            max_binding_bytes: u64::MAX,
            binding_alignment: 256,
        });
    app.world()
        .resource::<HairGpuPasses>()
        .set_state(GpuPassState::Ready);
}

/// A camera at `eye` looking at `target`, 1280x720, its projection and frustum set by hand (the
/// bench app has no camera or render plugins to do it).
pub fn bench_camera(world: &mut World, eye: Vec3, target: Vec3) {
    use bevy::camera::primitives::Frustum;
    use bevy::camera::{CameraProjection, RenderTargetInfo};
    let transform = Transform::from_translation(eye).looking_at(target, Vec3::Y);
    let projection = PerspectiveProjection {
        aspect_ratio: 16.0 / 9.0,
        ..default()
    };
    let clip_from_view = projection.get_clip_from_view();
    let global = GlobalTransform::from(transform);
    let projection = Projection::Perspective(projection);
    let frustum: Frustum = projection.compute_frustum(&global);
    let mut camera = Camera::default();
    camera.computed.clip_from_view = clip_from_view;
    camera.computed.target_info = Some(RenderTargetInfo {
        physical_size: UVec2::new(1280, 720),
        scale_factor: 1.0,
    });
    world.spawn((
        Camera3d::default(),
        camera,
        projection,
        transform,
        global,
        frustum,
    ));
}

/// One head of hair for [`frame_app`]: where its bone is, its strands and particles, its tube
/// rings and sides.
#[derive(Clone, Copy)]
pub struct Head {
    pub at: Vec3,
    pub strands: usize,
    pub particles: usize,
    pub rings: u32,
    pub sides: u32,
}

/// W1, the thesis default: 100 x 6 strands, 8 rings x 8 sides, 1 m in front of the camera.
pub fn w1() -> Vec<Head> {
    vec![Head {
        at: Vec3::new(0.0, -0.1, -1.0),
        strands: 100,
        particles: 6,
        rings: 8,
        sides: 8,
    }]
}

/// W6, a crowd: 16 heads of 160 x 7 at 16 x 8, from 2 m to 24.5 m away, the odd ones behind the
/// camera.
pub fn w6() -> Vec<Head> {
    (0..16)
        .map(|i| {
            let d = 2.0 + 1.5 * i as f32;
            let side = if i % 2 == 0 { -1.0 } else { 1.0 };
            Head {
                at: Vec3::new(0.3 * (i % 4) as f32 - 0.45, -0.2, side * d),
                strands: 160,
                particles: 7,
                rings: 16,
                sides: 8,
            }
        })
        .collect()
}

/// W2: 10,000 x 16 strands on one hair at 16 x 8.
pub fn w2() -> Vec<Head> {
    vec![Head {
        at: Vec3::new(0.0, -0.1, -1.0),
        strands: 10_000,
        particles: 16,
        rings: 16,
        sides: 8,
    }]
}

/// Spawns `head`'s hair (its strands, default simulation, its tube resolution) on a bone of its
/// own; returns the hair entity, for the caller's other settings.
pub fn spawn_head(world: &mut World, head: &Head) -> Entity {
    spawn_head_with(world, head, strands(head.strands, head.particles))
}

/// [`spawn_head`] with the given strands in place of [`strands`]'s.
pub fn spawn_head_with(world: &mut World, head: &Head, strands: Vec<Vec<Vec3>>) -> Entity {
    use bevy_cartoon_hair::asset::HairGroom;
    use bevy_cartoon_hair::mesh::HairMeshSettings;
    use bevy_cartoon_hair::sim::{Hair, HairSimSettings};
    let groom = HairGroom::from_strands("head", strands).unwrap();
    let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
    let bone = world.spawn(Transform::from_translation(head.at)).id();
    world
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings::default(),
            HairMeshSettings {
                hair_resolution: head.rings,
                shape_resolution: head.sides,
                ..default()
            },
            ChildOf(bone),
        ))
        .id()
}
