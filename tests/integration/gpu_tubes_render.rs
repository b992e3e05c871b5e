//! Render tests of strand tubes built on the GPU (`render::GpuTubesPlugin`): the same frame
//! drawn from CPU-built and GPU-built tubes, and the GPU path really drawing.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::mesh::{
    ComputedHairMesh, HairMeshBuiltOnGpu, HairStrandSections, LockSection,
};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{HairGpuMeshSupport, HairMeshBuilder};
use libtest_mimic::Failed;

use crate::mass_render::spawn_still_hair;
use crate::ring_render::spikes;
use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "gpu_built_tubes_draw_what_the_cpu_builds",
    gpu_built_tubes_draw_what_the_cpu_builds,
)];

/// Pixels whose colour differs by more than `tolerance` in a channel.
fn differing(a: &CapturedFrame, b: &CapturedFrame, tolerance: u8) -> usize {
    a.rgba
        .chunks(4)
        .zip(b.rgba.chunks(4))
        .filter(|(p, q)| {
            p.iter()
                .zip(q.iter())
                .any(|(x, y)| x.abs_diff(*y) > tolerance)
        })
        .count()
}

/// Spiky hair with mass normals, a taper to a point and three kinds of section (rhombus by
/// default, triangles and ribbons on some strands), lit by the scene's light: drawn with its
/// tubes built on the CPU and then on the GPU, the two pictures differ in under 1% of the hair's
/// pixels by more than 3 levels (float rounding where a toon band's edge falls). While the GPU
/// builds, the CPU leaves the mesh's vertices alone, yet turning and shrinking the head (a rig
/// scaled to 0.7) turns and shrinks the drawn hair. Back on the CPU, the picture is the CPU's
/// again.
fn gpu_built_tubes_draw_what_the_cpu_builds() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.3, 0.8, 1.0), Vec3::new(0.0, 0.3, 3.0))?;
    let ramp = ramps(&r).three_tone;
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let hair = spawn_still_hair(
        r.app.world_mut(),
        spikes(),
        ToonHairMaterial { ramp, ..default() },
        HairMeshSettings {
            radius: 0.03,
            taper: QuadraticCurve::new(-1.5, 0.5, 1.0),
            section: LockSection::Rhombus,
            section_aspect: 0.5,
            mass_normals: 0.8,
            ..default()
        },
    );
    let mut sections = vec![LockSection::Rhombus; 240];
    for (i, s) in sections.iter_mut().enumerate() {
        *s = [
            LockSection::Triangle,
            LockSection::Ribbon,
            LockSection::Rhombus,
        ][i % 3];
    }
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(HairStrandSections(sections));
    let cpu = r.capture()?;
    save(&cpu, "gpu_tubes_cpu")?;
    let support = r.app.world().resource::<HairGpuMeshSupport>().clone();
    if !support.supported {
        return Err(format!(
            "the adapter cannot build tubes on the GPU: {:?}",
            support.reason
        )
        .into());
    }
    r.app.insert_resource(HairMeshBuilder::Gpu);
    let gpu = r.capture()?;
    save(&gpu, "gpu_tubes_gpu")?;
    if !r.app.world().entity(hair).contains::<HairMeshBuiltOnGpu>() {
        return Err("HairMeshBuilder::Gpu left the hair on the CPU".into());
    }
    let hair_px = cpu.count(|p| p != BACKGROUND);
    let diff = differing(&cpu, &gpu, 3);
    eprintln!(
        "{hair_px} hair px; {diff} px differ by more than 3 levels between CPU and GPU tubes"
    );
    if hair_px < 2_000 || diff * 100 > hair_px {
        return Err(
            format!("{diff} of {hair_px} hair pixels differ between CPU and GPU tubes").into(),
        );
    }
    // The CPU no longer writes the vertices: the main world's mesh keeps the CPU's last ones,
    // while the picture follows the head.
    let positions =
        |r: &mut bevy_cartoon_hair::headless::HeadlessRenderer| -> Result<Vec<[f32; 3]>, Failed> {
            let world = r.app.world();
            let computed = world.get::<ComputedHairMesh>(hair).ok_or("no hair mesh")?;
            let mesh = world
                .resource::<Assets<Mesh>>()
                .get(&computed.mesh)
                .ok_or("no mesh asset")?;
            Ok(mesh
                .attribute(Mesh::ATTRIBUTE_POSITION)
                .and_then(|a| a.as_float3())
                .ok_or("no positions")?
                .to_vec())
        };
    let before = positions(&mut r)?;
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(Transform::from_rotation(Quat::from_rotation_y(0.6)).with_scale(Vec3::splat(0.7)));
    let turned = r.capture()?;
    save(&turned, "gpu_tubes_gpu_turned")?;
    let after = positions(&mut r)?;
    let moved = differing(&gpu, &turned, 3);
    eprintln!(
        "turned and scaled on the GPU: {moved} px changed; the main world's vertices {}",
        if before == after {
            "unchanged"
        } else {
            "changed"
        }
    );
    if before != after {
        return Err("the CPU rewrote the vertices of a GPU-built hair".into());
    }
    if moved * 10 < hair_px {
        return Err(
            format!("turning the head changed only {moved} px of the GPU-built hair").into(),
        );
    }
    // Back to the CPU: it draws the turned, scaled hair as the GPU did.
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let back = r.capture()?;
    save(&back, "gpu_tubes_cpu_turned")?;
    let diff_back = differing(&turned, &back, 3);
    eprintln!("turned and scaled, CPU against GPU: {diff_back} px differ");
    if diff_back * 100 > hair_px {
        return Err(format!("turned, {diff_back} px differ between GPU and CPU tubes").into());
    }
    Ok(())
}
