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
use crate::silhouette_render::{
    fold_strand, is_ink, scene as silhouette_scene, spawn as spawn_stroked,
};
use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "gpu_built_tubes_draw_what_the_cpu_builds",
        gpu_built_tubes_draw_what_the_cpu_builds,
    ),
    (
        "gpu_built_strokes_ink_where_the_cpus_do",
        gpu_built_strokes_ink_where_the_cpus_do,
    ),
    (
        "gpu_built_strokes_draw_only_the_quads_that_ink",
        gpu_built_strokes_draw_only_the_quads_that_ink,
    ),
    (
        "stroke_meshes_with_nothing_in_them_are_hidden_never_empty",
        stroke_meshes_with_nothing_in_them_are_hidden_never_empty,
    ),
    (
        "strokes_of_several_hairs_drawn_by_count_keep_every_strands_place",
        strokes_of_several_hairs_drawn_by_count_keep_every_strands_place,
    ),
    (
        "gpu_built_highlights_shine_where_the_cpus_do",
        gpu_built_highlights_shine_where_the_cpus_do,
    ),
    (
        "gpu_built_highlights_draw_only_the_quads_that_shine",
        gpu_built_highlights_draw_only_the_quads_that_shine,
    ),
];

/// Pixels whose colour differs by more than `tolerance` in a channel.
pub(crate) fn differing(a: &CapturedFrame, b: &CapturedFrame, tolerance: u8) -> usize {
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

/// Of the pixels where `a` has ink, the share with ink of `b` within `reach` pixels.
fn ink_covered(a: &CapturedFrame, b: &CapturedFrame, reach: i32) -> (usize, f32) {
    covered(a, b, reach, is_ink)
}

/// Of the pixels of `a` that are `wanted`, the share with a wanted pixel of `b` within `reach`
/// pixels.
fn covered(
    a: &CapturedFrame,
    b: &CapturedFrame,
    reach: i32,
    is_ink: fn([u8; 4]) -> bool,
) -> (usize, f32) {
    let (w, h) = (a.width as i32, a.height as i32);
    let (mut ink, mut covered) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            if !is_ink(a.pixel(x as u32, y as u32)) {
                continue;
            }
            ink += 1;
            let near = (-reach..=reach).any(|dy| {
                (-reach..=reach).any(|dx| {
                    let (px, py) = (x + dx, y + dy);
                    px >= 0 && py >= 0 && px < w && py < h && is_ink(b.pixel(px as u32, py as u32))
                })
            });
            covered += usize::from(near);
        }
    }
    (ink, covered as f32 / ink.max(1) as f32)
}

/// The same frame's strokes from the CPU (silhouette edges of the tube mesh, chained) and from
/// the GPU (each ring's two contour points, swept into strips): a strand that folds back behind
/// itself, every strand's outline and then the mass's, and a hair of 240 spiky strands (then
/// turned and shrunk to 0.7 at run time). The GPU
/// hands the strokes to the GPU (`GpuStrokeJobs`), and each picture's ink lies within 2 px of
/// the other's: the two differ where the CPU outlines the root's cap (the GPU's strips stop at
/// the last ring) and by up to a pixel along the sides (a contour interpolated between two
/// ring sides against the mesh edge nearest to it).
fn gpu_built_strokes_ink_where_the_cpus_do() -> Result<(), Failed> {
    use bevy_cartoon_hair::silhouette::GpuStrokeJobs;
    let mut r = silhouette_scene()?;
    let hair = spawn_stroked(&mut r, fold_strand(), 0.22);
    let compare = |r: &mut bevy_cartoon_hair::headless::HeadlessRenderer,
                   name: &str,
                   hair: Entity|
     -> Result<(), Failed> {
        r.app.insert_resource(HairMeshBuilder::Cpu);
        let cpu = r.capture()?;
        save(&cpu, &format!("gpu_strokes_{name}_cpu"))?;
        r.app.insert_resource(HairMeshBuilder::Gpu);
        let gpu = r.capture()?;
        save(&gpu, &format!("gpu_strokes_{name}_gpu"))?;
        let jobs = r
            .app
            .world()
            .get::<GpuStrokeJobs>(hair)
            .map_or(0, |j| j.0.len());
        if !r.app.world().entity(hair).contains::<HairMeshBuiltOnGpu>() || jobs != 1 {
            return Err(format!("{name}: the GPU was given {jobs} stroke jobs, not 1").into());
        }
        let (cpu_ink, cpu_covered) = ink_covered(&cpu, &gpu, 2);
        let (gpu_ink, gpu_covered) = ink_covered(&gpu, &cpu, 2);
        eprintln!(
            "{name}: CPU {cpu_ink} ink px ({:.1}% near GPU ink), GPU {gpu_ink} ({:.1}% near CPU \
             ink)",
            100.0 * cpu_covered,
            100.0 * gpu_covered
        );
        if cpu_ink < 300
            || !(0.8..1.25).contains(&(gpu_ink as f32 / cpu_ink as f32))
            || cpu_covered < 0.9
            || gpu_covered < 0.9
        {
            return Err(format!(
                "{name}: CPU {cpu_ink} ink px, {cpu_covered:.3} near the GPU's; GPU {gpu_ink}, \
                 {gpu_covered:.3} near the CPU's"
            )
            .into());
        }
        Ok(())
    };
    compare(&mut r, "fold_strands", hair)?;
    r.app
        .world_mut()
        .get_mut::<SilhouetteSettings>(hair)
        .ok_or("the hair is gone")?
        .scope = StrokeScope::Mass;
    compare(&mut r, "fold_mass", hair)?;
    r.app.world_mut().despawn(hair);
    // Spiky hair with the default strokes (the mass's outline), rhombic locks to a point.
    let spiky = spawn_still_hair(
        r.app.world_mut(),
        spikes(),
        ToonHairMaterial::default(),
        HairMeshSettings {
            radius: 0.03,
            taper: QuadraticCurve::new(-1.5, 0.5, 1.0),
            section: LockSection::Rhombus,
            section_aspect: 0.5,
            ..default()
        },
    );
    r.app
        .world_mut()
        .entity_mut(spiky)
        .insert(SilhouetteSettings {
            color: Color::BLACK,
            ..default()
        });
    compare(&mut r, "spiky_mass", spiky)?;
    // The head turned and shrunk at run time (a rig scaled to 0.7).
    r.app
        .world_mut()
        .entity_mut(spiky)
        .insert(Transform::from_rotation(Quat::from_rotation_y(0.6)).with_scale(Vec3::splat(0.7)));
    compare(&mut r, "spiky_mass_turned", spiky)
}

/// The mean over a few frames of the render diagnostic `path` (Bevy's pipeline statistics,
/// which arrive a few frames late: read once they have settled).
fn settled_diagnostic(
    r: &mut bevy_cartoon_hair::headless::HeadlessRenderer,
    path: &str,
) -> Result<f64, Failed> {
    for _ in 0..6 {
        r.update();
    }
    let mut sum = 0.0;
    for _ in 0..3 {
        r.update();
        let store = r
            .app
            .world()
            .resource::<bevy::diagnostic::DiagnosticsStore>();
        sum += store
            .get_measurement(&bevy::diagnostic::DiagnosticPath::new(path.to_string()))
            .map(|m| m.value)
            .ok_or_else(|| format!("no {path} measured"))?;
    }
    Ok(sum / 3.0)
}

/// A still hair of `strands` 3 cm thick with every strand's outline in black.
fn spawn_outlined(world: &mut World, strands: Vec<Vec<Vec3>>) -> Entity {
    let hair = spawn_still_hair(
        world,
        strands,
        ToonHairMaterial::default(),
        HairMeshSettings {
            radius: 0.03,
            ..default()
        },
    );
    world.entity_mut(hair).insert(SilhouetteSettings {
        color: Color::BLACK,
        scope: StrokeScope::Strands,
        ..default()
    });
    hair
}

/// Every strand's outline of a hair of 240 spiky strands, seen from the front (many strands
/// end on, many rim edges no silhouette): the GPU's stroke mesh holds a quad for every ring
/// segment of both contours and every rim edge, but the main pass draws only the triangles of
/// the quads that ink (the stroke pass counts them into an indirect draw), as many as the
/// CPU's strokes within a factor of 1.5, and the picture is the same as when every quad was
/// drawn (the strokes' ink within 2 px of the CPU's). With `HairCompactQuads` on; switched off
/// again, the whole mesh is drawn and the picture is the same to the bit (the live triangles
/// are drawn in the mesh's order).
fn gpu_built_strokes_draw_only_the_quads_that_ink() -> Result<(), Failed> {
    const TRANSPARENT: &str = "render/main_transparent_pass_3d/clipper_invocations";
    let mut r = silhouette_scene()?;
    r.app
        .add_plugins(bevy::render::diagnostic::RenderDiagnosticsPlugin)
        .insert_resource(bevy_cartoon_hair::render::HairCompactQuads(true));
    let hair = spawn_outlined(r.app.world_mut(), spikes());
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let cpu = r.capture()?;
    let cpu_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    r.app.insert_resource(HairMeshBuilder::Gpu);
    let gpu = r.capture()?;
    save(&gpu, "gpu_strokes_live_quads")?;
    let gpu_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    if !r.app.world().entity(hair).contains::<HairMeshBuiltOnGpu>() {
        return Err("the hair was not built on the GPU".into());
    }
    let gpu_mesh = mesh_triangles(
        &mut r,
        hair,
        |of: &bevy_cartoon_hair::silhouette::HairStrokesOf| of.0,
    );
    let (cpu_ink, cpu_covered) = ink_covered(&cpu, &gpu, 2);
    let (gpu_ink, gpu_covered) = ink_covered(&gpu, &cpu, 2);
    eprintln!(
        "strokes drawn: CPU {cpu_drawn:.0} triangles; GPU {gpu_drawn:.0} of its mesh's \
         {gpu_mesh}; ink: CPU {cpu_ink} px ({:.1}% near the GPU's), GPU {gpu_ink} px ({:.1}% \
         near the CPU's)",
        100.0 * cpu_covered,
        100.0 * gpu_covered
    );
    if gpu_mesh == 0 || cpu_drawn < 1000.0 {
        return Err(format!("{gpu_mesh} GPU stroke triangles, {cpu_drawn} CPU").into());
    }
    if gpu_drawn >= 0.9 * gpu_mesh as f64 {
        return Err(format!(
            "the GPU's strokes drew {gpu_drawn} of their mesh's {gpu_mesh} triangles: the \
             collapsed quads were drawn too"
        )
        .into());
    }
    if !(cpu_drawn / 1.5..=cpu_drawn * 1.5).contains(&gpu_drawn) {
        return Err(
            format!("the GPU's strokes drew {gpu_drawn} triangles, the CPU's {cpu_drawn}").into(),
        );
    }
    if cpu_ink < 300 || cpu_covered < 0.9 || gpu_covered < 0.9 {
        return Err(format!(
            "CPU {cpu_ink} ink px, {cpu_covered:.3} near the GPU's; GPU {gpu_ink}, \
             {gpu_covered:.3} near the CPU's"
        )
        .into());
    }
    // Switched off, the mesh is drawn whole again, its triangles put back in place.
    r.app
        .insert_resource(bevy_cartoon_hair::render::HairCompactQuads(false));
    let whole = r.capture()?;
    let whole_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    let (whole_ink, whole_covered) = ink_covered(&whole, &cpu, 2);
    // The live triangles keep the whole mesh's order (strand after strand), so overlapping
    // strokes blend as they did: the same picture to the bit.
    let reordered = differing(&gpu, &whole, 0);
    eprintln!(
        "switched off: {whole_drawn:.0} triangles drawn, {whole_ink} ink px, {reordered} px \
         differ from the compacted draw"
    );
    if (whole_drawn - gpu_mesh as f64).abs() > 0.5 || whole_covered < 0.9 {
        return Err(format!(
            "switched off, the strokes drew {whole_drawn} of {gpu_mesh} triangles, \
             {whole_covered:.3} of their ink near the CPU's"
        )
        .into());
    }
    if reordered > 0 {
        return Err(format!(
            "drawn by count, the strokes differ from the whole mesh in {reordered} pixels: \
             their triangles are not in the groom's order"
        )
        .into());
    }
    Ok(())
}

/// The 240 spiky strands as three hairs of 100, 100 and 40 strands in one batch (their jobs
/// begin inside the pass's workgroups of 64, so a strand's place among its mesh's triangles
/// sums its job's strands in earlier workgroups and in its own): drawn by count, in one
/// compaction dispatch, they draw under 90% of their meshes' triangles and the same picture to
/// the bit as their whole meshes.
fn strokes_of_several_hairs_drawn_by_count_keep_every_strands_place() -> Result<(), Failed> {
    use bevy_cartoon_hair::render::{HairCompactQuads, HairGpuPasses};
    const TRANSPARENT: &str = "render/main_transparent_pass_3d/clipper_invocations";
    let mut r = silhouette_scene()?;
    r.app
        .add_plugins(bevy::render::diagnostic::RenderDiagnosticsPlugin)
        .insert_resource(HairCompactQuads(true))
        .insert_resource(HairMeshBuilder::Gpu);
    let all = spikes();
    let three: Vec<Entity> = [0..100, 100..200, 200..240]
        .into_iter()
        .map(|range| spawn_outlined(r.app.world_mut(), all[range].to_vec()))
        .collect();
    let by_count = r.capture()?;
    save(&by_count, "gpu_strokes_three_hairs_by_count")?;
    let three_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    let built = r.app.world().resource::<HairGpuPasses>().dispatches();
    if let Some(&hair) = three
        .iter()
        .find(|&&h| !r.app.world().entity(h).contains::<HairMeshBuiltOnGpu>())
    {
        return Err(format!("hair {hair} was not built on the GPU").into());
    }
    r.app.insert_resource(HairCompactQuads(false));
    let whole = r.capture()?;
    let whole_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    let apart = differing(&by_count, &whole, 0);
    eprintln!(
        "three hairs: {three_drawn:.0} stroke triangles drawn by count ({} compaction \
         dispatches, {} strands), {whole_drawn:.0} whole; {apart} px apart",
        built.compact.dispatches, built.compact.invocations
    );
    if three_drawn < 1000.0 || three_drawn >= 0.9 * whole_drawn {
        return Err(format!("{three_drawn} triangles by count of {whole_drawn}").into());
    }
    if (built.compact.dispatches, built.compact.invocations) != (1, 240) {
        return Err(format!(
            "{} compaction dispatches of {} strands, not one of 240",
            built.compact.dispatches, built.compact.invocations
        )
        .into());
    }
    if apart > 0 {
        return Err(format!(
            "drawn by count, the three hairs' strokes differ from their whole meshes in {apart} \
             pixels"
        )
        .into());
    }
    Ok(())
}

/// A hair of 240 spiky strands with specular quads, lit from above and in front.
fn highlighted_spikes() -> Result<(bevy_cartoon_hair::headless::HeadlessRenderer, Entity), Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 1.0), Vec3::new(0.0, 0.3, 3.0))?;
    let ramp = ramps(&r).three_tone;
    let hair = spawn_still_hair(
        r.app.world_mut(),
        spikes(),
        ToonHairMaterial::new(
            ToonShading {
                base_color: Color::srgb(0.4, 0.1, 0.1),
                ..default()
            },
            ramp,
        ),
        HairMeshSettings {
            radius: 0.06,
            ..default()
        },
    );
    r.app.world_mut().entity_mut(hair).insert(SpecularQuads {
        enabled: true,
        threshold: 0.3,
        width: 1.0,
        ..default()
    });
    Ok((r, hair))
}

/// Triangles in the meshes of `hair`'s entities of kind `of` (its stroke or highlight
/// meshes) that are not hidden (a stroke mesh with nothing in it is), as the main world made
/// them.
fn mesh_triangles<C: Component>(
    r: &mut bevy_cartoon_hair::headless::HeadlessRenderer,
    hair: Entity,
    owner: impl Fn(&C) -> Entity,
) -> usize {
    let world = r.app.world_mut();
    let mut parts = world.query::<(&C, &Mesh3d, &Visibility)>();
    let meshes: Vec<Handle<Mesh>> = parts
        .iter(world)
        .filter(|(of, _, shown)| owner(of) == hair && **shown != Visibility::Hidden)
        .map(|(_, m, _)| m.0.clone())
        .collect();
    let assets = world.resource::<Assets<Mesh>>();
    meshes
        .iter()
        .filter_map(|m| assets.get(m))
        .map(|m| m.indices().map_or(0, |i| i.len() / 3))
        .sum()
}

/// The specular quads of the hair of [`highlighted_spikes`] (which draws no strokes, so the
/// transparent pass draws only them): built on the CPU, their mesh holds the runs that shine;
/// built on the GPU, it holds a quad for every ring segment of every strand, but the main pass
/// draws only the triangles of the quads that shine: under half the mesh, and within 10% of
/// the CPU's (both find the runs ring by ring).
fn gpu_built_highlights_draw_only_the_quads_that_shine() -> Result<(), Failed> {
    use bevy_cartoon_hair::mesh::highlights::HairHighlightsOf;
    const TRANSPARENT: &str = "render/main_transparent_pass_3d/clipper_invocations";
    let (mut r, hair) = highlighted_spikes()?;
    r.app
        .add_plugins(bevy::render::diagnostic::RenderDiagnosticsPlugin)
        .insert_resource(bevy_cartoon_hair::render::HairCompactQuads(true));
    r.app.insert_resource(HairMeshBuilder::Gpu);
    let gpu = r.capture()?;
    save(&gpu, "gpu_highlights_live_quads")?;
    let gpu_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    let gpu_mesh = mesh_triangles(&mut r, hair, |of: &HairHighlightsOf| of.0);
    r.app.insert_resource(HairMeshBuilder::Cpu);
    r.capture()?;
    let cpu_drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
    let cpu_mesh = mesh_triangles(&mut r, hair, |of: &HairHighlightsOf| of.0);
    eprintln!(
        "specular quads: CPU mesh {cpu_mesh} triangles, {cpu_drawn:.0} drawn; GPU mesh \
         {gpu_mesh}, {gpu_drawn:.0} drawn"
    );
    if cpu_mesh == 0 || (cpu_drawn - cpu_mesh as f64).abs() > 0.5 {
        return Err(format!(
            "the CPU's quads: {cpu_drawn} triangles drawn of a mesh of {cpu_mesh}: the \
             transparent pass draws something else"
        )
        .into());
    }
    if !(gpu_drawn > 0.0 && gpu_drawn <= 0.5 * gpu_mesh as f64)
        || (gpu_drawn - cpu_drawn).abs() > 0.1 * cpu_drawn
    {
        return Err(format!(
            "the specular quads drew {gpu_drawn} of their mesh's {gpu_mesh} triangles (the \
             CPU's {cpu_drawn}): the quads that do not shine were drawn too"
        )
        .into());
    }
    Ok(())
}

/// Specular quads of a hair of 240 spiky strands, lit from above and in front, as it is and
/// turned and shrunk to 0.7 at run time, from the CPU
/// (24 samples a strand) and from the GPU (a sample a ring, from the tube pass's frames): the
/// highlight covers as many pixels within a factor of 1.5, and each picture's highlight pixels
/// lie within 3 px of the other's (the samples fall at other places along the strands).
fn gpu_built_highlights_shine_where_the_cpus_do() -> Result<(), Failed> {
    use bevy_cartoon_hair::mesh::highlights::GpuHighlightJob;
    let (mut r, hair) = highlighted_spikes()?;
    let white = |p: [u8; 4]| p[..3].iter().all(|c| *c > 200);
    for (name, turned) in [("", false), ("_turned", true)] {
        if turned {
            // The head turned and shrunk at run time (a rig scaled to 0.7): the strips sit on
            // the shrunk tubes' surface on both paths.
            r.app.world_mut().entity_mut(hair).insert(
                Transform::from_rotation(Quat::from_rotation_y(0.6)).with_scale(Vec3::splat(0.7)),
            );
        }
        r.app.insert_resource(HairMeshBuilder::Cpu);
        let cpu = r.capture()?;
        save(&cpu, &format!("gpu_highlights{name}_cpu"))?;
        r.app.insert_resource(HairMeshBuilder::Gpu);
        let gpu = r.capture()?;
        save(&gpu, &format!("gpu_highlights{name}_gpu"))?;
        let on_gpu = r
            .app
            .world()
            .get::<GpuHighlightJob>(hair)
            .is_some_and(|j| j.0.is_some());
        if !on_gpu {
            return Err("the GPU was given no highlight job".into());
        }
        let (cpu_px, cpu_near) = covered(&cpu, &gpu, 3, white);
        let (gpu_px, gpu_near) = covered(&gpu, &cpu, 3, white);
        eprintln!(
            "highlights{name}: CPU {cpu_px} px ({:.1}% near the GPU's), GPU {gpu_px} px ({:.1}% \
             near the CPU's)",
            100.0 * cpu_near,
            100.0 * gpu_near
        );
        let ratio = gpu_px as f32 / cpu_px.max(1) as f32;
        // The shrunk hair shows less highlight.
        let least = if turned { 40 } else { 150 };
        if cpu_px < least || !(0.67..1.5).contains(&ratio) || cpu_near < 0.8 || gpu_near < 0.8 {
            return Err(format!(
                "highlights{name}: CPU {cpu_px} px ({cpu_near:.3} near), GPU {gpu_px} \
                 ({gpu_near:.3})"
            )
            .into());
        }
    }
    Ok(())
}

/// `hair`'s stroke meshes: how many are shown and how many hidden, and how many have no
/// vertices (Bevy warns each time it uploads one).
fn stroke_meshes(
    r: &mut bevy_cartoon_hair::headless::HeadlessRenderer,
    hair: Entity,
) -> (usize, usize, usize) {
    let world = r.app.world_mut();
    let mut parts = world.query::<(
        &bevy_cartoon_hair::silhouette::HairStrokesOf,
        &Mesh3d,
        &Visibility,
    )>();
    let parts: Vec<(Handle<Mesh>, bool)> = parts
        .iter(world)
        .filter(|(of, ..)| of.0 == hair)
        .map(|(_, m, v)| (m.0.clone(), *v == Visibility::Hidden))
        .collect();
    let assets = world.resource::<Assets<Mesh>>();
    let empty = parts
        .iter()
        .filter(|(m, _)| assets.get(m).is_none_or(|m| m.count_vertices() == 0))
        .count();
    let hidden = parts.iter().filter(|(_, h)| *h).count();
    (parts.len() - hidden, hidden, empty)
}

/// A hair's strokes are built in blocks, a mesh each; a mesh with no stroke in it (every block
/// but the first while the GPU builds the strokes) holds one triangle of no area, so Bevy never
/// uploads a mesh without vertices (it warns each time), and its entity is hidden, so it costs
/// no draw call. Built on the CPU again, every block is shown and drawn again.
fn stroke_meshes_with_nothing_in_them_are_hidden_never_empty() -> Result<(), Failed> {
    const TRANSPARENT: &str = "render/main_transparent_pass_3d/clipper_invocations";
    let mut r = silhouette_scene()?;
    r.app
        .add_plugins(bevy::render::diagnostic::RenderDiagnosticsPlugin)
        .insert_resource(bevy_cartoon_hair::render::HairCompactQuads(false));
    let hair = spawn_outlined(r.app.world_mut(), spikes());
    let mut seen = Vec::new();
    for (name, builder) in [
        ("CPU", HairMeshBuilder::Cpu),
        ("GPU", HairMeshBuilder::Gpu),
        ("CPU again", HairMeshBuilder::Cpu),
    ] {
        r.app.insert_resource(builder);
        r.capture()?;
        let drawn = settled_diagnostic(&mut r, TRANSPARENT)?;
        let (shown, hidden, empty) = stroke_meshes(&mut r, hair);
        eprintln!(
            "{name}: {shown} stroke meshes shown, {hidden} hidden, {empty} without vertices; \
             {drawn:.0} triangles drawn"
        );
        seen.push((shown, hidden, empty, drawn));
    }
    let blocks = bevy_cartoon_hair::silhouette::strokes::STROKE_BLOCKS;
    let [cpu, gpu, again] = [seen[0], seen[1], seen[2]];
    if seen.iter().any(|s| s.2 > 0) {
        return Err(format!("a stroke mesh without vertices: {seen:?}").into());
    }
    if (cpu.0, cpu.1) != (blocks, 0) || (again.0, again.1) != (blocks, 0) {
        return Err(format!("built on the CPU, not every block is shown: {seen:?}").into());
    }
    if (gpu.0, gpu.1) != (1, blocks - 1) {
        return Err(format!("built on the GPU, the empty blocks are not hidden: {seen:?}").into());
    }
    if again.3 != cpu.3 {
        return Err(format!(
            "built on the CPU again, {} triangles drawn, {} the first time",
            again.3, cpu.3
        )
        .into());
    }
    Ok(())
}
