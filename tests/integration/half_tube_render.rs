//! Render tests of half tubes (`mesh::tube::TubeTopology::facing`): round tubes built on the
//! GPU for the one camera that sees them draw half the triangles and the picture the CPU's
//! closed tubes draw; strands a few pixels wide draw as ribbons
//! (`mesh::tube::TubeTopology::ribbon`) with the closed tubes' outline.

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_cartoon_hair::headless::HeadlessRenderer;
use bevy_cartoon_hair::mesh::{ComputedHairMesh, HairLodLevel, HairTubesFacing};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::HairMeshBuilder;
use libtest_mimic::Failed;

use crate::gpu_tubes_render::differing;
use crate::mass_render::spawn_still_hair;
use crate::ring_render::spikes;
use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "half_tubes_draw_the_closed_tubes_picture_from_half_the_triangles",
        half_tubes_draw_the_closed_tubes_picture_from_half_the_triangles,
    ),
    (
        "thin_strands_draw_as_ribbons_with_the_tubes_outline",
        thin_strands_draw_as_ribbons_with_the_tubes_outline,
    ),
];

/// The hair's tube topology: whether it is a half tube, and its triangles.
fn tubes(r: &HeadlessRenderer, hair: Entity) -> Result<(bool, usize, Option<Vec3>), Failed> {
    let world = r.app.world();
    let computed = world
        .get::<ComputedHairMesh>(hair)
        .ok_or("the hair has no mesh")?;
    let facing = world
        .get::<HairTubesFacing>(hair)
        .ok_or("no HairTubesFacing")?;
    Ok((
        computed.topology.is_facing(),
        computed.topology.triangle_count() * computed.strands,
        facing.0,
    ))
}

/// The 240 spikes, round and tapered, `radius` thick at the root, held still in the scene's light
/// 3 m from the camera, built on the CPU to start with.
fn lit_spikes(radius: f32) -> Result<(HeadlessRenderer, Entity), Failed> {
    let mut r = scene(Vec3::new(0.3, 0.8, 1.0), Vec3::new(0.0, 0.3, 3.0))?;
    let ramp = ramps(&r).three_tone;
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let hair = spawn_still_hair(
        r.app.world_mut(),
        spikes(),
        ToonHairMaterial { ramp, ..default() },
        HairMeshSettings {
            radius,
            taper: QuadraticCurve::new(-0.4, -0.5, 1.0),
            ..default()
        },
    );
    Ok((r, hair))
}

/// 240 round, tapered strands lit by the scene's light, drawn with closed tubes built on the
/// CPU, then on the GPU as half tubes facing the camera: half the triangles, and the pictures
/// differ in under 1.5% of the hair's pixels by more than 3 levels (the closed tube's front
/// faces, judged from each ring's centre). The same after the head turns and with the camera
/// moved round to the side; out of view the hair keeps its half tubes and is drawn in the
/// first frame back. A second camera seeing the hair gives it closed tubes again.
fn half_tubes_draw_the_closed_tubes_picture_from_half_the_triangles() -> Result<(), Failed> {
    let (mut r, hair) = lit_spikes(0.03)?;
    let compare = |r: &mut HeadlessRenderer, name: &str| -> Result<(), Failed> {
        r.app.insert_resource(HairMeshBuilder::Cpu);
        let cpu = r.capture()?;
        let (cpu_facing, cpu_triangles, _) = tubes(r, hair)?;
        r.app.insert_resource(HairMeshBuilder::Gpu);
        let gpu = r.capture()?;
        let (gpu_facing, gpu_triangles, eye) = tubes(r, hair)?;
        save(&cpu, &format!("half_tubes_{name}_cpu"))?;
        save(&gpu, &format!("half_tubes_{name}_gpu"))?;
        let hair_px = cpu.count(|p| p != BACKGROUND);
        let diff = differing(&cpu, &gpu, 3);
        eprintln!(
            "{name}: {hair_px} hair px, {diff} differ by more than 3 levels; triangles: closed \
             {cpu_triangles}, half {gpu_triangles}; facing {eye:?}"
        );
        if cpu_facing || !gpu_facing || eye.is_none() {
            return Err(format!(
                "{name}: half tubes on the CPU {cpu_facing}, on the GPU {gpu_facing}"
            )
            .into());
        }
        if 2 * gpu_triangles != cpu_triangles {
            return Err(format!(
                "{name}: {gpu_triangles} half-tube triangles for {cpu_triangles} closed"
            )
            .into());
        }
        if hair_px < 2_000 || diff * 200 > 3 * hair_px {
            return Err(format!("{name}: {diff} of {hair_px} hair px differ").into());
        }
        Ok(())
    };
    compare(&mut r, "front")?;
    let world = r.app.world_mut();
    world
        .entity_mut(hair)
        .insert(Transform::from_rotation(Quat::from_rotation_y(0.7)));
    compare(&mut r, "turned")?;
    let world = r.app.world_mut();
    let mut cameras = world.query_filtered::<&mut Transform, With<Camera3d>>();
    for mut t in cameras.iter_mut(world) {
        *t = Transform::from_xyz(2.6, 0.8, 1.2).looking_at(Vec3::ZERO, Vec3::Y);
    }
    compare(&mut r, "side")?;
    // Out of view and back: the hair keeps its half tubes while no camera sees it and is drawn
    // in the first frame back.
    let seen_px = r.capture()?.count(|p| p != BACKGROUND);
    let world = r.app.world_mut();
    let mut cameras = world.query_filtered::<&mut Transform, With<Camera3d>>();
    for mut t in cameras.iter_mut(world) {
        *t = Transform::from_xyz(2.6, 0.8, 1.2).looking_at(Vec3::new(10.0, 0.8, 6.0), Vec3::Y);
    }
    for _ in 0..3 {
        r.update();
    }
    let (away_facing, _, _) = tubes(&r, hair)?;
    let world = r.app.world_mut();
    let mut cameras = world.query_filtered::<&mut Transform, With<Camera3d>>();
    for mut t in cameras.iter_mut(world) {
        *t = Transform::from_xyz(2.6, 0.8, 1.2).looking_at(Vec3::ZERO, Vec3::Y);
    }
    r.update();
    let back = r.capture()?;
    let back_px = back.count(|p| p != BACKGROUND);
    eprintln!(
        "out of view: half tubes {away_facing}; back in view: {back_px} hair px of {seen_px}"
    );
    if !away_facing || back_px * 100 < seen_px * 97 {
        return Err(format!(
            "out of view half tubes {away_facing}; back in view {back_px} px of {seen_px}"
        )
        .into());
    }
    // A second camera that sees the hair: closed tubes, whoever looks.
    let target = r.target();
    r.app.world_mut().spawn((
        Camera3d::default(),
        Camera {
            order: 1,
            ..default()
        },
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.0, 0.3, -3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    r.capture()?;
    let (facing, _, eye) = tubes(&r, hair)?;
    if facing || eye.is_some() {
        return Err("two cameras see the hair, yet its tubes are half tubes".into());
    }
    Ok(())
}

/// The 240 spikes with strands about 2.5 px wide on screen: built on the GPU they are ribbons,
/// two triangles a segment, and cover the pixels the CPU's closed tubes cover (the two hair
/// masks differ in under 6% of their union, single pixels along the edges), their mean colour
/// within 12 levels of the tubes'. With `ribbon_pixels` 0 the GPU draws half tubes again.
fn thin_strands_draw_as_ribbons_with_the_tubes_outline() -> Result<(), Failed> {
    let (mut r, hair) = lit_spikes(0.009)?;
    let cpu = r.capture()?;
    let (_, cpu_triangles, _) = tubes(&r, hair)?;
    r.app.insert_resource(HairMeshBuilder::Gpu);
    let gpu = r.capture()?;
    let (_, gpu_triangles, _) = tubes(&r, hair)?;
    let world = r.app.world();
    let ribbon = world
        .get::<ComputedHairMesh>(hair)
        .is_some_and(|c| c.topology.is_ribbon());
    let width = world
        .get::<HairLodLevel>(hair)
        .map_or(0.0, |l| l.strand_pixels);
    save(&cpu, "ribbons_cpu_tubes")?;
    save(&gpu, "ribbons_gpu")?;
    let hair_px = |f: &bevy_cartoon_hair::headless::CapturedFrame| {
        f.rgba
            .chunks(4)
            .map(|p| p[..3] != BACKGROUND[..3])
            .collect::<Vec<bool>>()
    };
    let (a, b) = (hair_px(&cpu), hair_px(&gpu));
    let union = a.iter().zip(&b).filter(|(x, y)| **x || **y).count();
    let either = a.iter().zip(&b).filter(|(x, y)| **x != **y).count();
    let mean = |f: &bevy_cartoon_hair::headless::CapturedFrame, mask: &[bool]| {
        let (mut sum, mut n) = ([0.0f64; 3], 0usize);
        for (p, _) in f.rgba.chunks(4).zip(mask).filter(|(_, m)| **m) {
            for c in 0..3 {
                sum[c] += f64::from(p[c]);
            }
            n += 1;
        }
        sum.map(|s| s / n.max(1) as f64)
    };
    let (mc, mg) = (mean(&cpu, &a), mean(&gpu, &b));
    let colour = (0..3).map(|c| (mc[c] - mg[c]).abs()).fold(0.0, f64::max);
    eprintln!(
        "strands {width:.1} px wide; ribbons {ribbon}; triangles: closed {cpu_triangles}, \
         ribbons {gpu_triangles}; hair px {} / {}, {either} of {union} differ; mean colour \
         {mc:.0?} / {mg:.0?}",
        a.iter().filter(|x| **x).count(),
        b.iter().filter(|x| **x).count(),
    );
    if !ribbon || !(1.0..3.0).contains(&width) {
        return Err(format!("strands {width} px wide, ribbons {ribbon}").into());
    }
    let rings = world
        .get::<ComputedHairMesh>(hair)
        .map_or(0, |c| c.topology.rings());
    if gpu_triangles != 240 * 2 * (rings - 1) || gpu_triangles * 3 > cpu_triangles {
        return Err(
            format!("{gpu_triangles} ribbon triangles against {cpu_triangles} closed").into(),
        );
    }
    if union < 2_000 || either * 100 > 6 * union || colour > 12.0 {
        return Err(format!(
            "{either} of {union} hair px differ, mean colour {colour:.1} levels apart"
        )
        .into());
    }
    r.app.world_mut().entity_mut(hair).insert(HairLod {
        ribbon_pixels: 0.0,
        ..default()
    });
    r.capture()?;
    let (facing, _, _) = tubes(&r, hair)?;
    let ribbon = r
        .app
        .world()
        .get::<ComputedHairMesh>(hair)
        .is_some_and(|c| c.topology.is_ribbon());
    if !facing || ribbon {
        return Err(format!("ribbon_pixels 0: half tubes {facing}, ribbons {ribbon}").into());
    }
    Ok(())
}
