//! Render tests of what a hair casts into the shadow maps (`mesh::HairShadowCaster`): the
//! ribbons' shadow falls where the tubes' does, on the CPU and GPU paths, with fewer triangles
//! sent to the cascades than the hair draws in the main pass.

use bevy::camera::RenderTarget;
use bevy::camera::visibility::CascadesVisibleEntities;
use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::mesh::shadow::HairShadowMeshOf;
use bevy_cartoon_hair::mesh::{ComputedHairMesh, HairMeshBuiltOnGpu, HairMeshOf, HairShadowCaster};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::HairMeshBuilder;
use libtest_mimic::Failed;

use crate::mass_render::spawn_still_hair;
use crate::toon_render::{ramps, save};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "shadow_ribbons_cast_the_tubes_shadow_from_fewer_triangles",
    shadow_ribbons_cast_the_tubes_shadow_from_fewer_triangles,
)];

/// A grey ground under nine strands lying across the view, a sun casting shadows from above
/// and to the side, the camera looking down at both.
fn shadow_scene() -> Result<(HeadlessRenderer, Entity, Entity), Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings::default())?;
    r.app.add_plugins(CartoonHairPlugins);
    let target = r.target();
    let ramp = ramps(&r).three_tone;
    let world = r.app.world_mut();
    world.spawn((
        DirectionalLight {
            illuminance: 3_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(0.8, 2.0, 0.4).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let camera = world
        .spawn((
            Camera3d::default(),
            Camera {
                clear_color: ClearColorConfig::Custom(Color::BLACK),
                ..default()
            },
            bevy::core_pipeline::tonemapping::Tonemapping::Linear,
            Msaa::Off,
            RenderTarget::Image(target.into()),
            Transform::from_xyz(0.0, 2.0, 1.4).looking_at(Vec3::new(0.0, -0.4, 0.0), Vec3::Y),
        ))
        .id();
    let ground = world
        .resource_mut::<Assets<Mesh>>()
        .add(Plane3d::default().mesh().size(6.0, 6.0));
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::srgb(0.5, 0.5, 0.5),
            perceptual_roughness: 1.0,
            ..default()
        });
    world.spawn((
        Mesh3d(ground),
        MeshMaterial3d(grey),
        Transform::from_xyz(0.0, -0.5, 0.0),
    ));
    // Strands across the view, some bent, 6 cm thick at the root and thinning to the tip.
    let strands: Vec<Vec<Vec3>> = (0..9)
        .map(|i| {
            let z = -0.5 + 0.12 * i as f32;
            (0..8)
                .map(|k| {
                    let t = k as f32 / 7.0;
                    Vec3::new(-0.7 + 1.4 * t, 0.1 * (t * 3.0 + i as f32).sin(), z)
                })
                .collect()
        })
        .collect();
    let hair = spawn_still_hair(
        world,
        strands,
        ToonHairMaterial { ramp, ..default() },
        HairMeshSettings {
            radius: 0.03,
            taper: QuadraticCurve::new(0.0, -0.6, 1.0),
            ..default()
        },
    );
    Ok((r, hair, camera))
}

/// Ground pixels the hair's shadow darkens: darker than in `open` (no shadow cast) by more
/// than 12 levels of luma, and not hair (the same in both).
fn shadow_mask(open: &CapturedFrame, shaded: &CapturedFrame) -> Vec<bool> {
    let luma =
        |p: &[u8]| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]);
    open.rgba
        .chunks_exact(4)
        .zip(shaded.rgba.chunks_exact(4))
        .map(|(a, b)| luma(a) - luma(b) > 12.0)
        .collect()
}

/// Pixels in both masks over pixels in either.
fn overlap(a: &[bool], b: &[bool]) -> f32 {
    let both = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let either = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    both as f32 / either.max(1) as f32
}

/// Triangles of the hair's meshes Bevy's cascade culling sends into the sun's cascades for
/// `camera` (meshes marked `NotShadowCaster` send none), summed over the cascades; and the
/// triangles of its tube mesh, which the main pass draws.
fn hair_triangles(
    r: &mut HeadlessRenderer,
    hair: Entity,
    camera: Entity,
) -> Result<(usize, usize), Failed> {
    let world = r.app.world_mut();
    let tube = world
        .get::<ComputedHairMesh>(hair)
        .ok_or("the hair has no mesh")?
        .entity;
    let triangles = |world: &World, e: Entity| -> usize {
        world
            .get::<Mesh3d>(e)
            .and_then(|m| world.resource::<Assets<Mesh>>().get(&m.0))
            .and_then(|m| m.indices().map(|i| i.len() / 3))
            .unwrap_or(0)
    };
    let mut cascades = world.query::<&CascadesVisibleEntities>();
    let mut cast = 0;
    for visible in cascades.iter(world) {
        for cascade in visible.entities.get(&camera).into_iter().flatten() {
            for &e in &cascade.entities {
                let ours = world.get::<HairMeshOf>(e).is_some_and(|o| o.0 == hair)
                    || world
                        .get::<HairShadowMeshOf>(e)
                        .is_some_and(|o| o.0 == hair);
                if ours && !world.entity(e).contains::<NotShadowCaster>() {
                    cast += triangles(world, e);
                }
            }
        }
    }
    Ok((cast, triangles(world, tube)))
}

/// The sun's shadow of nine bent, tapered strands on the ground: with the ribbons (the
/// default), built on the CPU and on the GPU, it covers the pixels the tubes' own shadow covers
/// (at least 90% of the pixels either darkens are darkened by both), with at most the triangles
/// the main pass draws sent into the cascades; the tubes send theirs into every cascade that
/// holds them. Casting nothing darkens no pixel.
fn shadow_ribbons_cast_the_tubes_shadow_from_fewer_triangles() -> Result<(), Failed> {
    let (mut r, hair, camera) = shadow_scene()?;
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let shot = |r: &mut HeadlessRenderer, caster: HairShadowCaster, name: &str| {
        r.app.world_mut().entity_mut(hair).insert(caster);
        // A frame for the caster to change hands, then the picture.
        r.update();
        let frame = r.capture()?;
        save(&frame, name)?;
        let counts = hair_triangles(r, hair, camera)?;
        Ok::<_, Failed>((frame, counts))
    };
    let (open, (off_cast, _)) = shot(&mut r, HairShadowCaster::Off, "shadow_off")?;
    let (tubes, (tube_cast, main)) = shot(&mut r, HairShadowCaster::Tubes, "shadow_tubes")?;
    let (cpu, (cpu_cast, _)) = shot(&mut r, HairShadowCaster::Ribbons, "shadow_ribbons_cpu")?;
    // On the GPU the tubes are half tubes: the shadow is measured against the GPU's own
    // picture without it.
    r.app.insert_resource(HairMeshBuilder::Gpu);
    let (gpu_open, _) = shot(&mut r, HairShadowCaster::Off, "shadow_off_gpu")?;
    let (gpu, (gpu_cast, _)) = shot(&mut r, HairShadowCaster::Ribbons, "shadow_ribbons_gpu")?;
    if !r.app.world().entity(hair).contains::<HairMeshBuiltOnGpu>() {
        return Err("HairMeshBuilder::Gpu left the hair on the CPU".into());
    }
    let tube_mask = shadow_mask(&open, &tubes);
    let shadow_px = tube_mask.iter().filter(|m| **m).count();
    let cpu_overlap = overlap(&tube_mask, &shadow_mask(&open, &cpu));
    let gpu_overlap = overlap(&tube_mask, &shadow_mask(&gpu_open, &gpu));
    eprintln!(
        "tubes' shadow {shadow_px} px; ribbons' overlap: CPU {cpu_overlap:.3}, GPU \
         {gpu_overlap:.3}; triangles cast: off {off_cast}, tubes {tube_cast}, ribbons {cpu_cast} \
         (CPU) {gpu_cast} (GPU); main pass {main}"
    );
    if shadow_px < 500 {
        return Err(format!("the tubes' shadow darkens only {shadow_px} px").into());
    }
    if cpu_overlap < 0.9 || gpu_overlap < 0.9 {
        return Err(format!(
            "the ribbons' shadow is not the tubes': overlap {cpu_overlap:.3} (CPU), \
             {gpu_overlap:.3} (GPU)"
        )
        .into());
    }
    // The cameras never draw the ribbons: they are in the cascades, not in the camera's view.
    let world = r.app.world_mut();
    let ribbons: Vec<Entity> = world
        .query_filtered::<Entity, With<HairShadowMeshOf>>()
        .iter(world)
        .collect();
    let seen = world
        .get::<bevy::camera::visibility::VisibleEntities>(camera)
        .ok_or("the camera has no visible entities")?
        .entities
        .values()
        .flatten()
        .filter(|e| ribbons.contains(e))
        .count();
    if ribbons.len() != 1 || seen != 0 {
        return Err(format!(
            "{} ribbon meshes, {seen} in the camera's visible entities",
            ribbons.len()
        )
        .into());
    }
    if off_cast != 0 || tube_cast <= main {
        return Err(format!(
            "cast {off_cast} triangles with the shadow off, {tube_cast} from the tubes \
             (main pass {main})"
        )
        .into());
    }
    if cpu_cast == 0 || cpu_cast > main || gpu_cast > main {
        return Err(format!(
            "the ribbons cast {cpu_cast} (CPU) and {gpu_cast} (GPU) triangles against the main \
             pass's {main}"
        )
        .into());
    }
    Ok(())
}
