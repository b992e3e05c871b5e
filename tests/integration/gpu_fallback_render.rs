//! Render tests of the GPU path where it can go wrong on a player's machine: hair is built on the
//! CPU until the passes compile, goes back to the CPU (with an event) when a pass fails or a
//! binding is refused, is built in the frame it comes back into view, writes no NaN vertex from
//! a NaN particle, draws right with several hairs in one vertex slab and with pipelined
//! rendering, and draws its strands nearest the camera first.

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::mesh::allocator::{MeshAllocator, MeshAllocatorSettings};
use bevy::render::render_resource::{BufferDescriptor, BufferUsages, MapMode, PollType};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::mesh::{ComputedHairMesh, HairMeshBuiltOnGpu};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{
    GpuPassState, HairGpuBuildFailed, HairGpuMeshSupport, HairGpuPasses, HairMeshBuilder,
};
use libtest_mimic::Failed;

use crate::gpu_tubes_render::differing;
use crate::mass_render::spawn_still_hair;
use crate::ring_render::spikes;
use crate::toon_render::{BACKGROUND, ramps, save};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "gpu_hair_is_built_on_the_cpu_until_its_passes_compile",
        gpu_hair_is_built_on_the_cpu_until_its_passes_compile,
    ),
    (
        "a_failing_gpu_pass_puts_hair_back_on_the_cpu",
        a_failing_gpu_pass_puts_hair_back_on_the_cpu,
    ),
    (
        "a_refused_binding_puts_hair_back_on_the_cpu",
        a_refused_binding_puts_hair_back_on_the_cpu,
    ),
    (
        "a_hair_back_in_view_is_built_in_that_frame",
        a_hair_back_in_view_is_built_in_that_frame,
    ),
    (
        "a_gpu_hair_changing_its_tubes_in_view_is_drawn_every_frame",
        a_gpu_hair_changing_its_tubes_in_view_is_drawn_every_frame,
    ),
    (
        "a_nan_particle_makes_no_nan_vertex_on_the_gpu",
        a_nan_particle_makes_no_nan_vertex_on_the_gpu,
    ),
    (
        "hairs_of_several_sizes_share_the_vertex_slab",
        hairs_of_several_sizes_share_the_vertex_slab,
    ),
    (
        "gpu_hair_draws_with_pipelined_rendering",
        gpu_hair_draws_with_pipelined_rendering,
    ),
    (
        "gpu_hair_is_drawn_nearest_strand_first",
        gpu_hair_is_drawn_nearest_strand_first,
    ),
];

/// The hair plugins, a light and a camera looking at the origin from the front.
fn scene(pipelined_rendering: bool) -> Result<(HeadlessRenderer, Entity), Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings {
        pipelined_rendering,
        ..default()
    })?;
    r.app.add_plugins(CartoonHairPlugins);
    r.app.init_resource::<Failures>().add_observer(
        |failed: On<HairGpuBuildFailed>, mut all: ResMut<Failures>| {
            all.0.push((failed.entity, failed.reason.clone()));
        },
    );
    let target = r.target();
    let world = r.app.world_mut();
    world.spawn((
        DirectionalLight {
            illuminance: 5_000.0,
            ..default()
        },
        Transform::from_xyz(0.3, 0.8, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
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
            front(),
        ))
        .id();
    Ok((r, camera))
}

fn front() -> Transform {
    Transform::from_xyz(0.0, 0.3, 3.0).looking_at(Vec3::ZERO, Vec3::Y)
}

/// Every [`HairGpuBuildFailed`] seen, with its hair and reason.
#[derive(Resource, Default)]
struct Failures(Vec<(Entity, String)>);

/// Spiky hair (every `step`th of the 240 spikes), held still.
fn spawn_spikes(r: &mut HeadlessRenderer, step: usize, transform: Transform) -> Entity {
    let ramp = ramps(r).three_tone;
    let strands = spikes().into_iter().step_by(step).collect();
    let hair = spawn_still_hair(
        r.app.world_mut(),
        strands,
        ToonHairMaterial { ramp, ..default() },
        HairMeshSettings {
            radius: 0.03,
            taper: QuadraticCurve::new(-1.5, 0.5, 1.0),
            mass_normals: 0.8,
            ..default()
        },
    );
    // Closed tubes, so the GPU's picture is the CPU's to the pixel; half tubes have a test of
    // their own (`half_tube_render`).
    r.app.world_mut().entity_mut(hair).insert((
        transform,
        bevy_cartoon_hair::mesh::HairLod {
            half_tubes: false,
            ..default()
        },
    ));
    hair
}

/// `hair` is off the GPU, with exactly one [`HairGpuBuildFailed`], for it, whose reason says
/// `why`.
fn back_on_the_cpu(r: &HeadlessRenderer, hair: Entity, why: &str) -> Result<(), Failed> {
    let failures = &r.app.world().resource::<Failures>().0;
    eprintln!("events: {failures:?}");
    match failures.as_slice() {
        [(e, reason)] if *e == hair && reason.contains(why) => {}
        _ => {
            return Err(
                format!("expected one event for the hair saying {why:?}: {failures:?}").into(),
            );
        }
    }
    if on_gpu(r, hair) {
        return Err("the hair is still marked GPU-built".into());
    }
    Ok(())
}

fn on_gpu(r: &HeadlessRenderer, hair: Entity) -> bool {
    r.app.world().entity(hair).contains::<HairMeshBuiltOnGpu>()
}

/// One frame captured without waiting on pipelines (a failed one is what these tests make).
fn next_frame(r: &mut HeadlessRenderer) -> Result<CapturedFrame, Failed> {
    let mut frame = None;
    r.capture_sequence(1, |_, f| frame = Some(f))?;
    frame.ok_or_else(|| "no frame arrived".into())
}

/// The picture of `r`'s scene with every hair built on the CPU, then the builder set back.
fn cpu_reference(r: &mut HeadlessRenderer) -> Result<CapturedFrame, Failed> {
    let builder = *r.app.world().resource::<HairMeshBuilder>();
    r.app.insert_resource(HairMeshBuilder::Cpu);
    for _ in 0..3 {
        r.update();
    }
    let frame = next_frame(r)?;
    r.app.insert_resource(builder);
    Ok(frame)
}

/// `a` and `b` differ in under 1% of `a`'s hair pixels by more than 3 levels.
fn same_picture(a: &CapturedFrame, b: &CapturedFrame, what: &str) -> Result<(), Failed> {
    let hair_px = a.count(|p| p != BACKGROUND);
    let diff = differing(a, b, 3);
    eprintln!("{what}: {diff} of {hair_px} hair px differ");
    if hair_px < 500 || diff * 100 > hair_px {
        return Err(format!("{what}: {diff} of {hair_px} hair px differ").into());
    }
    Ok(())
}

/// From its first frame, frame by frame: a hair is marked GPU-built only in a frame that starts
/// with the GPU passes compiled (the CPU builds it before that, so it is never left without
/// vertices), and it does move to the GPU once they have.
fn gpu_hair_is_built_on_the_cpu_until_its_passes_compile() -> Result<(), Failed> {
    let (mut r, _) = scene(false)?;
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    let mut compiling_frames = 0;
    for frame in 0..600 {
        let before = r
            .app
            .world()
            .get_resource::<HairGpuPasses>()
            .map(HairGpuPasses::state)
            .unwrap_or_default();
        r.update();
        let gpu = on_gpu(&r, hair);
        if gpu && before != GpuPassState::Ready {
            return Err(format!(
                "frame {frame}: the hair is built on the GPU while its passes are {before:?}"
            )
            .into());
        }
        if before == GpuPassState::Compiling {
            compiling_frames += 1;
            // The CPU built its vertices meanwhile: the mesh is not the blank it was made as.
            let world = r.app.world();
            if let Some(computed) = world.get::<ComputedHairMesh>(hair)
                && let Some(mesh) = world.resource::<Assets<Mesh>>().get(&computed.mesh)
                && let Some(positions) = mesh
                    .attribute(Mesh::ATTRIBUTE_POSITION)
                    .and_then(|a| a.as_float3())
                && frame > 2
                && positions.iter().all(|p| *p == positions[0])
            {
                return Err(
                    format!("frame {frame}: the CPU left the hair's vertices blank").into(),
                );
            }
        }
        if let GpuPassState::Failed(e) = &before {
            return Err(format!("a GPU pass failed: {e}").into());
        }
        if gpu {
            eprintln!("on the GPU from frame {frame}, after {compiling_frames} compiling frames");
            return Ok(());
        }
    }
    Err("the hair never moved to the GPU".into())
}

/// A hair on the GPU whose tube pass then fails (its shader replaced by one that does not
/// compile, as a driver that rejects it would): the hair goes back to the CPU with a
/// [`HairGpuBuildFailed`] naming it and the pass, and keeps moving: turned afterwards, it is
/// drawn as the CPU draws it, not frozen where it was.
fn a_failing_gpu_pass_puts_hair_back_on_the_cpu() -> Result<(), Failed> {
    let (mut r, _) = scene(false)?;
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    let before = r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU to begin with".into());
    }
    let path = "embedded://bevy_cartoon_hair/render/gpu/tubes.wesl";
    let handle: Handle<Shader> = r.app.world().resource::<AssetServer>().load(path);
    r.app
        .world_mut()
        .resource_mut::<Assets<Shader>>()
        .insert(&handle, Shader::from_wesl("fn build( {", path))?;
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(Transform::from_rotation(Quat::from_rotation_y(0.8)));
    for _ in 0..10 {
        r.update();
    }
    let after = next_frame(&mut r)?;
    save(&after, "gpu_pass_failed")?;
    back_on_the_cpu(&r, hair, "hair_gpu_tubes")?;
    let cpu = cpu_reference(&mut r)?;
    same_picture(
        &cpu,
        &after,
        "turned after the pass failed, against the CPU",
    )?;
    let moved = differing(&before, &after, 3);
    if moved * 10 < before.count(|p| p != BACKGROUND) {
        return Err(format!("the turned hair changed only {moved} px: frozen").into());
    }
    Ok(())
}

/// A hair on the GPU when the binding limit drops below its mesh (a game lowering
/// `HairGpuMeshSupport::max_binding_bytes`, as a smaller device would have it): back on the CPU
/// with an event naming the hair and the binding, and still moving.
fn a_refused_binding_puts_hair_back_on_the_cpu() -> Result<(), Failed> {
    let (mut r, _) = scene(false)?;
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU to begin with".into());
    }
    r.app
        .world_mut()
        .resource_mut::<HairGpuMeshSupport>()
        .max_binding_bytes = 4096;
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(Transform::from_rotation(Quat::from_rotation_y(-0.7)));
    let after = r.capture()?;
    back_on_the_cpu(&r, hair, "binds as storage")?;
    let cpu = cpu_reference(&mut r)?;
    same_picture(
        &cpu,
        &after,
        "turned after the binding was refused, against the CPU",
    )
}

/// A GPU-built hair leaves the view (the camera turns away), turns while no camera sees it, and
/// the frame the camera turns back draws it turned, as the CPU draws it, not where it left.
fn a_hair_back_in_view_is_built_in_that_frame() -> Result<(), Failed> {
    use bevy::time::TimeUpdateStrategy;
    use std::time::Duration;
    let (mut r, camera) = scene(false)?;
    // Every frame steps 1/60 s, whatever the machine's frame rate, so the hair is in the same
    // place on a fast GPU as on a CPU rasteriser.
    r.app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f32(
            1.0 / 60.0,
        )));
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    let left = r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU".into());
    }
    let away = Transform::from_xyz(0.0, 0.3, 3.0).looking_at(Vec3::new(0.0, 0.3, 10.0), Vec3::Y);
    r.app.world_mut().entity_mut(camera).insert(away);
    for _ in 0..3 {
        r.update();
    }
    let built = r.app.world().resource::<HairGpuPasses>().dispatches();
    if built.tubes.invocations > 0 {
        return Err(format!("the hair out of view is still built on the GPU: {built:?}").into());
    }
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(Transform::from_rotation(Quat::from_rotation_y(0.9)));
    for _ in 0..3 {
        r.update();
    }
    r.app.world_mut().entity_mut(camera).insert(front());
    let back = next_frame(&mut r)?;
    save(&back, "gpu_back_in_view")?;
    // The CPU's picture of the particles that frame drew: time stands still while it is built.
    r.app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let cpu = cpu_reference(&mut r)?;
    same_picture(&cpu, &back, "the first frame back in view, against the CPU")?;
    if differing(&left, &back, 3) * 10 < left.count(|p| p != BACKGROUND) {
        return Err("the first frame back in view shows the hair where it left".into());
    }
    Ok(())
}

/// A GPU-built hair whose tubes change resolution while it is in view (what a level-of-detail
/// switch does) is drawn in every frame, the frame of the change included (built on the CPU
/// then), and ends as the CPU draws it.
fn a_gpu_hair_changing_its_tubes_in_view_is_drawn_every_frame() -> Result<(), Failed> {
    use bevy::time::TimeUpdateStrategy;
    use std::time::Duration;
    let (mut r, _) = scene(false)?;
    r.app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f32(
            1.0 / 60.0,
        )));
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU".into());
    }
    for sides in [5, 8, 3] {
        r.app
            .world_mut()
            .get_mut::<HairMeshSettings>(hair)
            .ok_or("the hair has no mesh settings")?
            .shape_resolution = sides;
        let mut frames = Vec::new();
        r.capture_sequence(3, |_, f| frames.push(f))?;
        for (k, f) in frames.iter().enumerate() {
            let px = f.count(|p| p != BACKGROUND);
            eprintln!("{sides} sides, frame {k}: {px} hair px");
            if px < 500 {
                save(f, &format!("gpu_tubes_change_{sides}_{k}"))?;
                return Err(format!("{sides} sides, frame {k} of the change: {px} hair px").into());
            }
        }
        if !on_gpu(&r, hair) {
            return Err(format!("{sides} sides: the hair left the GPU").into());
        }
    }
    r.app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let gpu = next_frame(&mut r)?;
    let cpu = cpu_reference(&mut r)?;
    same_picture(&cpu, &gpu, "after the changes, against the CPU")
}

/// Particles that are NaN or infinite reach the tube pass (written into the strands after the
/// simulation, as a broken solver or a game writing them would leave them): every float the
/// pass writes into the hair's vertices is finite.
fn a_nan_particle_makes_no_nan_vertex_on_the_gpu() -> Result<(), Failed> {
    let (mut r, _) = scene(false)?;
    readable_slabs(&mut r);
    let hair = spawn_spikes(&mut r, 4, Transform::IDENTITY);
    r.app.add_systems(
        PostUpdate,
        (|mut strands: Query<&mut StrandParticles>| {
            for (i, mut particles) in strands.iter_mut().enumerate() {
                let n = particles.positions.len();
                match i % 3 {
                    0 => particles.positions[n / 2] = Vec3::new(f32::NAN, 0.0, 0.0),
                    1 => particles.positions[n - 1] = Vec3::new(0.0, f32::INFINITY, 0.0),
                    _ => particles.positions[1] = Vec3::splat(f32::NAN),
                }
            }
        })
        .after(HairSystems::Simulate)
        .before(HairSystems::BuildMesh),
    );
    r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU".into());
    }
    next_frame(&mut r)?;
    let mesh = r
        .app
        .world()
        .get::<ComputedHairMesh>(hair)
        .ok_or("no hair mesh")?
        .mesh
        .id();
    let floats = read_vertices(&r, mesh)?;
    let bad = floats.iter().filter(|f| !f.is_finite()).count();
    eprintln!("{} floats read back, {bad} not finite", floats.len());
    if floats.is_empty() || bad > 0 {
        return Err(format!("{bad} of {} vertex floats are not finite", floats.len()).into());
    }
    Ok(())
}

/// The hair's strands are drawn nearest the camera first, and the picture is the CPU's: its
/// index buffer, read back from the GPU, holds each strand's block of indices once, untouched
/// but for the strand it names, in the order of each strand's nearest particle's distance from
/// the camera. Seen from behind, a frame later, the order is that view's.
fn gpu_hair_is_drawn_nearest_strand_first() -> Result<(), Failed> {
    use bevy::time::TimeUpdateStrategy;
    let (mut r, camera) = scene(false)?;
    r.app.insert_resource(TimeUpdateStrategy::ManualDuration(
        std::time::Duration::ZERO,
    ));
    readable_slabs(&mut r);
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    let front_view = r.capture()?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU".into());
    }
    let front = drawing_order(&r, hair, front().translation)?;
    let cpu = cpu_reference(&mut r)?;
    same_picture(&cpu, &front_view, "drawn nearest first, against the CPU")?;
    let behind = Transform::from_xyz(0.2, 0.3, -3.0).looking_at(Vec3::ZERO, Vec3::Y);
    r.app.world_mut().entity_mut(camera).insert(behind);
    for _ in 0..3 {
        r.update();
    }
    if !on_gpu(&r, hair) {
        return Err("the hair went off the GPU".into());
    }
    let back = drawing_order(&r, hair, behind.translation)?;
    let identity: Vec<u32> = (0..front.len() as u32).collect();
    eprintln!(
        "{} strands; first drawn from the front {:?}, from behind {:?}",
        front.len(),
        &front[..4],
        &back[..4]
    );
    if front == identity || back == identity || front == back {
        return Err("the drawing order is the groom's, or the same from both sides".into());
    }
    Ok(())
}

/// The strands of `hair` in the order its index buffer on the GPU draws them, checked to be
/// each strand once, each block its strand's pattern, nearest `eye` first.
fn drawing_order(r: &HeadlessRenderer, hair: Entity, eye: Vec3) -> Result<Vec<u32>, Failed> {
    let world = r.app.world();
    let computed = world.get::<ComputedHairMesh>(hair).ok_or("no hair mesh")?;
    let (per, pattern) = (
        computed.topology.vertex_count() as u32,
        &computed.topology.indices,
    );
    let render = r.app.sub_app(RenderApp).world();
    let slice = render
        .resource::<MeshAllocator>()
        .mesh_index_slice(&computed.mesh.id())
        .ok_or("the hair mesh has no index slice")?;
    let bytes = read_slab(
        r,
        slice.buffer,
        u64::from(slice.range.start) * 4,
        u64::from(slice.range.end - slice.range.start) * 4,
    )?;
    let indices: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if indices.len() != pattern.len() * computed.strands {
        return Err(format!("{} indices read back", indices.len()).into());
    }
    let mut order = Vec::with_capacity(computed.strands);
    for (k, block) in indices.chunks_exact(pattern.len()).enumerate() {
        let strand = block[0] / per;
        if block
            .iter()
            .zip(pattern)
            .any(|(i, p)| *i != p + strand * per)
        {
            return Err(format!("index block {k} is not one strand's pattern").into());
        }
        order.push(strand);
    }
    let mut seen = vec![false; computed.strands];
    for &s in &order {
        match seen.get_mut(s as usize) {
            Some(seen @ false) => *seen = true,
            _ => return Err(format!("strand {s} drawn twice or out of range").into()),
        }
    }
    // Each strand's nearest particle, by its place in the mesh (the groom's index).
    let mut nearest = vec![f32::INFINITY; computed.strands];
    let list = world
        .get::<bevy_cartoon_hair::sim::HairStrands>(hair)
        .ok_or("no strands")?;
    for e in list.iter() {
        let strand = world
            .get::<bevy_cartoon_hair::sim::Strand>(e)
            .ok_or("no strand")?;
        let particles = world.get::<StrandParticles>(e).ok_or("no particles")?;
        nearest[strand.index as usize] = particles
            .positions
            .iter()
            .map(|p| p.distance(eye))
            .fold(f32::INFINITY, f32::min);
    }
    for pair in order.windows(2) {
        let (a, b) = (nearest[pair[0] as usize], nearest[pair[1] as usize]);
        if a > b {
            return Err(format!(
                "strand {} ({a} m from the eye) is drawn before strand {} ({b} m)",
                pair[0], pair[1]
            )
            .into());
        }
    }
    Ok(order)
}

/// The floats of `mesh`'s vertices in its vertex slab, read back from the GPU.
fn read_vertices(r: &HeadlessRenderer, mesh: AssetId<Mesh>) -> Result<Vec<f32>, Failed> {
    let stride = r
        .app
        .world()
        .resource::<Assets<Mesh>>()
        .get(mesh)
        .ok_or("no mesh asset")?
        .get_vertex_size();
    let slice = r
        .app
        .sub_app(RenderApp)
        .world()
        .resource::<MeshAllocator>()
        .mesh_vertex_slice(&mesh)
        .ok_or("the hair mesh is not in a slab")?;
    let offset = u64::from(slice.range.start) * stride;
    let size = u64::from(slice.range.end - slice.range.start) * stride;
    Ok(read_slab(r, slice.buffer, offset, size)?
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// Makes the mesh slabs created from now on readable (`COPY_SRC`), after the first frame.
fn readable_slabs(r: &mut HeadlessRenderer) {
    r.update();
    r.app
        .sub_app_mut(RenderApp)
        .world_mut()
        .resource_mut::<MeshAllocatorSettings>()
        .extra_buffer_usages |= BufferUsages::COPY_SRC;
}

/// `size` bytes of `buffer` (a mesh slab, `COPY_SRC`) from `offset`, read back from the GPU.
fn read_slab(
    r: &HeadlessRenderer,
    buffer: &bevy::render::render_resource::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<u8>, Failed> {
    let world = r.app.sub_app(RenderApp).world();
    let device = world.resource::<RenderDevice>();
    let queue = world.resource::<RenderQueue>();
    let read = device.create_buffer(&BufferDescriptor {
        label: Some("hair slab readback"),
        size,
        usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&default());
    encoder.copy_buffer_to_buffer(buffer, offset, &read, 0, size);
    queue.submit([encoder.finish()]);
    read.slice(..).map_async(MapMode::Read, |_| {});
    device
        .poll(PollType::wait_indefinitely())
        .map_err(|e| format!("{e:?}"))?;
    let data = read
        .slice(..)
        .get_mapped_range()
        .map_err(|e| format!("{e:?}"))?;
    Ok(data.to_vec())
}

/// Three hairs of 24, 60 and 120 strands side by side, built on the GPU into one shared vertex
/// slab (one of them not at its start, so its pass binds from an aligned offset), drawn as the
/// CPU draws them; then the middle one despawned and one of 80 strands spawned in its place, and
/// again drawn as the CPU draws them.
fn hairs_of_several_sizes_share_the_vertex_slab() -> Result<(), Failed> {
    let (mut r, _) = scene(false)?;
    let at = |x: f32| Transform::from_xyz(x, 0.0, 0.0).with_scale(Vec3::splat(0.45));
    let mut hairs = vec![
        spawn_spikes(&mut r, 10, at(-0.8)),
        spawn_spikes(&mut r, 4, at(0.0)),
        spawn_spikes(&mut r, 2, at(0.8)),
    ];
    for round in 0..2 {
        let gpu = r.capture()?;
        save(&gpu, &format!("gpu_shared_slab_{round}"))?;
        for &hair in &hairs {
            if !on_gpu(&r, hair) {
                return Err(format!("round {round}: hair {hair} is not built on the GPU").into());
            }
        }
        let slices: Vec<_> = hairs
            .iter()
            .map(|&h| {
                let mesh = r.app.world().get::<ComputedHairMesh>(h)?.mesh.id();
                let world = r.app.sub_app(RenderApp).world();
                let slice = world.resource::<MeshAllocator>().mesh_vertex_slice(&mesh)?;
                Some((slice.buffer.id(), slice.range.start))
            })
            .collect::<Option<_>>()
            .ok_or("a hair mesh has no slab")?;
        let shared = slices
            .iter()
            .any(|(b, start)| *start > 0 && slices.iter().filter(|(o, _)| o == b).count() > 1);
        eprintln!("round {round}: slabs and first vertices {slices:?}");
        if !shared {
            return Err(format!("no two hair meshes share a slab: {slices:?}").into());
        }
        // One dispatch a slab, however many hairs it holds, and an invocation a strand.
        let mut slabs: Vec<_> = slices.iter().map(|(b, _)| *b).collect();
        slabs.sort();
        slabs.dedup();
        let strands: usize = hairs
            .iter()
            .filter_map(|&h| r.app.world().get::<ComputedHairMesh>(h))
            .map(|c| c.strands)
            .sum();
        let built = r.app.world().resource::<HairGpuPasses>().dispatches();
        eprintln!(
            "round {round}: {strands} strands in {} slabs: {built:?}",
            slabs.len()
        );
        if built.tubes.dispatches as usize != slabs.len()
            || built.tubes.invocations as usize != strands
        {
            return Err(format!(
                "round {round}: {} hairs of {strands} strands in {} slabs took {built:?}",
                hairs.len(),
                slabs.len()
            )
            .into());
        }
        let cpu = cpu_reference(&mut r)?;
        save(&cpu, &format!("gpu_shared_slab_{round}_cpu"))?;
        same_picture(&cpu, &gpu, &format!("round {round}, GPU against CPU"))?;
        if round == 0 {
            r.app.world_mut().entity_mut(hairs[1]).despawn();
            hairs[1] = spawn_spikes(&mut r, 3, at(0.0));
        }
    }
    Ok(())
}

/// With a render thread, as in a game (pipelined rendering, each frame drawn one update late),
/// spiky hair is built on the GPU and drawn as the CPU draws it.
fn gpu_hair_draws_with_pipelined_rendering() -> Result<(), Failed> {
    let (mut r, _) = scene(true)?;
    let hair = spawn_spikes(&mut r, 2, Transform::IDENTITY);
    let gpu = r.capture()?;
    save(&gpu, "gpu_pipelined")?;
    if !on_gpu(&r, hair) {
        return Err("the hair was not built on the GPU".into());
    }
    let cpu = cpu_reference(&mut r)?;
    save(&cpu, "gpu_pipelined_cpu")?;
    same_picture(&cpu, &gpu, "pipelined rendering, GPU against CPU")
}
