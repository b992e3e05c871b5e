//! VRM characters (`assets/chain_hair/*.vrm`, written by `tools/blender/write_vrm_fixtures.py`
//! from the Blender-authored modelled-hair character) loaded through Bevy's glTF loader: their
//! spring bones simulated by the hair solver with their own colliders and groups, their hair
//! mesh skinned to the result and drawn in the toon look, in a fast head turn.

use std::time::Duration;

use bevy::mesh::VertexAttributeValues;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{ToonHairMeshes, ToonHairMeshesApplied, ToonRamps};
use bevy_cartoon_hair::sim::{BoneChainHairs, HairCollidesOnly, VrmSpringChains, VrmSpringsFailed};
use libtest_mimic::Failed;

use crate::chain_render::joints_in_head;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "a_vrm_character_swings_its_hair_mesh_on_its_springs_in_the_toon_look",
        a_vrm_character_swings_its_hair_mesh_on_its_springs_in_the_toon_look,
    ),
    (
        "a_vrm_0_character_gets_its_bone_groups_and_converted_colliders",
        a_vrm_0_character_gets_its_bone_groups_and_converted_colliders,
    ),
    (
        "a_vrm_with_broken_spring_json_shows_the_character_and_says_where",
        a_vrm_with_broken_spring_json_shows_the_character_and_says_where,
    ),
    (
        "a_vrm_that_does_not_load_is_an_event_naming_it",
        a_vrm_that_does_not_load_is_an_event_naming_it,
    ),
];

/// The toon hair colour: a red-brown, in its ramp's tones.
const HAIR: Color = Color::srgb(0.55, 0.22, 0.1);

fn is_hair([r, g, b, _]: [u8; 4]) -> bool {
    let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
    r > 30.0 && g < 0.6 * r && b < 0.45 * r && g > 0.05 * r
}

/// A fast head turn on the neck over 0.6 s: tilting 46 degrees toward the right shoulder and
/// nodding 29 degrees, and back, so the locks hang into the face, cheek and neck.
fn head_turn(t: f32) -> Quat {
    let s = (std::f32::consts::PI * t / 0.6).sin();
    Quat::from_rotation_z(-0.8 * s) * Quat::from_rotation_x(0.5 * s)
}

/// One run's frames and measures.
struct Run {
    rest: CapturedFrame,
    shaken: CapturedFrame,
    after: CapturedFrame,
    springs: usize,
    colliders: usize,
    /// Per spring, how many colliders it sees.
    seen: Vec<usize>,
    swing: f32,
    back: f32,
    /// The deepest a skinned hair-lock vertex went into a body collider beyond where it rested.
    deeper: f32,
    /// Hair-lock vertices measured.
    vertices: usize,
    /// Head-space centres of the colliders on the head, in file order.
    head_centres: Vec<Vec3>,
    /// The size of the file's thumbnail texture as decoded (JPEG in the VRM 1.0 file, PNG in
    /// the VRM 0.x file): Bevy fails the whole file when it cannot decode a texture.
    thumbnail: Option<UVec2>,
}

/// Loads `file`, settles 1.5 s, turns the head fast on the neck for 0.6 s, settles 3 s. With
/// `colliders` false every spring's collider list is emptied after the build.
fn run(file: &'static str, colliders: bool) -> Result<Run, Failed> {
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
    let ramp = world.resource::<ToonRamps>().three_tone.clone();
    let shading = ToonShading {
        base_color: HAIR,
        ..default()
    };
    let material = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(ToonHairMaterial::new(shading, ramp));
    let assets = world.resource::<AssetServer>().clone();
    // Held from the start: a texture no material uses is freed once the file has loaded.
    let thumbnail_handle: Handle<Image> = assets.load(GltfAssetLabel::Texture(0).from_asset(file));
    world.spawn((
        WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset(file))),
        ToonHairMeshes::matching(|n| n == "hair").with_material(material),
    ));
    crate::chain_render::stage(world, target);
    renderer.warm_up(|world| {
        let mut springs = world.query::<&VrmSpringChains>();
        let Some(built) = springs.iter(world).next().cloned() else {
            return false;
        };
        let mut dressed = world.query::<&ToonHairMeshesApplied>();
        !built.springs.is_empty()
            && dressed.iter(world).next().is_some()
            && built.springs.iter().all(|s| {
                world
                    .get::<BoneChainHairs>(*s)
                    .is_some_and(|h| !h.0.is_empty())
            })
    })?;
    let world = renderer.app.world_mut();
    let thumbnail = world
        .resource::<Assets<Image>>()
        .get(&thumbnail_handle)
        .map(Image::size);
    let built = world
        .query::<&VrmSpringChains>()
        .iter(world)
        .next()
        .cloned()
        .ok_or("no VRM springs")?;
    let mut hairs = Vec::new();
    for s in &built.springs {
        hairs.extend(world.get::<BoneChainHairs>(*s).unwrap().0.clone());
    }
    let seen: Vec<usize> = hairs
        .iter()
        .map(|h| {
            world
                .get::<HairCollidesOnly>(*h)
                .map_or(usize::MAX, |o| o.0.len())
        })
        .collect();
    if !colliders {
        for h in &hairs {
            world.entity_mut(*h).insert(HairCollidesOnly(Vec::new()));
        }
    }
    let named = |world: &mut World, name: &str| {
        world
            .query::<(Entity, &Name)>()
            .iter(world)
            .find(|(_, n)| n.as_str() == name)
            .map(|(e, _)| e)
    };
    let head = named(world, "head").ok_or("the character has no head bone")?;
    let head_centres: Vec<Vec3> = built
        .colliders
        .iter()
        .filter(|c| {
            world
                .get::<ChildOf>(**c)
                .is_some_and(|p| p.parent() == head)
        })
        .filter_map(|c| world.get::<HairCollider>(*c))
        .filter_map(|c| c.spheres.first().map(|s| s.center))
        .collect();
    let joints: Vec<Entity> = world
        .query::<(Entity, &Name)>()
        .iter(world)
        .filter(|(_, n)| n.as_str().starts_with("hair_"))
        .map(|(e, _)| e)
        .collect();
    let skin = hair_skin(world)?;
    let head_rest = world.get::<Transform>(head).unwrap().rotation;
    let in_head = |world: &World| joints_in_head(world, head, &joints);
    for _ in 0..45 {
        renderer.update_by(1.0 / 30.0);
    }
    let rest_joints = in_head(renderer.app.world());
    let rest_depth = skin.depths(renderer.app.world(), &built.colliders);
    let rest = renderer.capture()?;
    let mut swing = 0.0f32;
    let mut deeper = 0.0f32;
    let mut shaken = None;
    for f in 0..18 {
        let t = (f + 1) as f32 / 30.0;
        renderer
            .app
            .world_mut()
            .get_mut::<Transform>(head)
            .unwrap()
            .rotation = head_rest * head_turn(t);
        renderer.update_by(1.0 / 30.0);
        let world = renderer.app.world();
        swing = swing.max(farthest(&in_head(world), &rest_joints));
        for (now, then) in skin.depths(world, &built.colliders).iter().zip(&rest_depth) {
            deeper = deeper.max(now - then);
        }
        // Mid-turn, the head tilted furthest.
        if f == 8 {
            shaken = Some(renderer.capture()?);
        }
    }
    let shaken = shaken.ok_or("no mid-turn frame")?;
    renderer
        .app
        .world_mut()
        .get_mut::<Transform>(head)
        .unwrap()
        .rotation = head_rest;
    for _ in 0..90 {
        renderer.update_by(1.0 / 30.0);
    }
    let back = farthest(&in_head(renderer.app.world()), &rest_joints);
    let after = renderer.capture()?;
    Ok(Run {
        rest,
        shaken,
        after,
        springs: built.springs.len(),
        colliders: built.colliders.len(),
        seen,
        swing,
        back,
        deeper,
        vertices: skin.vertices.len(),
        head_centres,
        thumbnail,
    })
}

fn farthest(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f32::max)
}

/// The hair mesh's lock vertices (those weighted to a hair bone), skinned on the CPU as Bevy's
/// vertex shader does.
struct HairSkin {
    joints: Vec<Entity>,
    bind: Vec<Mat4>,
    /// Position, joint indices, weights.
    vertices: Vec<(Vec3, [u16; 4], [f32; 4])>,
}

fn hair_skin(world: &mut World) -> Result<HairSkin, Failed> {
    let mut q = world.query::<(&Mesh3d, &SkinnedMesh, &bevy::gltf::GltfMaterialName)>();
    let (mesh, skinned) = q
        .iter(world)
        .find(|(_, _, m)| m.0 == "hair")
        .map(|(m, s, _)| (m.0.clone(), s.clone()))
        .ok_or("no skinned mesh with the material \"hair\"")?;
    let meshes = world.resource::<Assets<Mesh>>();
    let mesh = meshes
        .get(&mesh)
        .ok_or("the hair mesh is not in the main world")?;
    let bind = world
        .resource::<Assets<SkinnedMeshInverseBindposes>>()
        .get(&skinned.inverse_bindposes)
        .ok_or("no inverse bind poses")?
        .to_vec();
    let (
        Some(VertexAttributeValues::Float32x3(positions)),
        Some(VertexAttributeValues::Uint16x4(indices)),
        Some(VertexAttributeValues::Float32x4(weights)),
    ) = (
        mesh.attribute(Mesh::ATTRIBUTE_POSITION),
        mesh.attribute(Mesh::ATTRIBUTE_JOINT_INDEX),
        mesh.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT),
    )
    else {
        return Err("the hair mesh lacks positions or joint attributes".into());
    };
    let hair_bone: Vec<bool> = skinned
        .joints
        .iter()
        .map(|j| {
            world
                .get::<Name>(*j)
                .is_some_and(|n| n.as_str().starts_with("hair_"))
        })
        .collect();
    let vertices = positions
        .iter()
        .zip(indices)
        .zip(weights)
        .filter(|((_, i), w)| {
            (0..4).any(|k| w[k] > 0.0 && hair_bone.get(i[k] as usize).copied().unwrap_or(false))
        })
        .map(|((p, i), w)| (Vec3::from(*p), *i, *w))
        .collect();
    Ok(HairSkin {
        joints: skinned.joints.clone(),
        bind,
        vertices,
    })
}

impl HairSkin {
    /// Each vertex's deepest penetration into the spheres and capsules of `colliders` (0
    /// outside): the head and body. (The plane behind the neck is only the ponytail's.)
    fn depths(&self, world: &World, colliders: &[Entity]) -> Vec<f32> {
        let matrices: Vec<Mat4> = self
            .joints
            .iter()
            .zip(&self.bind)
            .map(|(j, b)| world.get::<GlobalTransform>(*j).unwrap().to_matrix() * *b)
            .collect();
        let shapes: Vec<(Affine3A, &HairCollider)> = colliders
            .iter()
            .filter_map(|c| {
                Some((
                    world.get::<GlobalTransform>(*c)?.affine(),
                    world.get::<HairCollider>(*c)?,
                ))
            })
            .filter(|(_, c)| c.mode == HairColliderMode::Outside)
            .collect();
        self.vertices
            .iter()
            .map(|(p, i, w)| {
                let mut v = Vec3::ZERO;
                for k in 0..4 {
                    v += w[k] * matrices[i[k] as usize].transform_point3(*p);
                }
                let mut depth = 0.0f32;
                for (pose, c) in &shapes {
                    let local = pose.inverse().transform_point3(v);
                    for s in &c.spheres {
                        depth = depth.max(s.radius - local.distance(s.center));
                    }
                    for s in &c.capsules {
                        let ab = s.b - s.a;
                        let t = ((local - s.a).dot(ab) / ab.length_squared().max(1e-12))
                            .clamp(0.0, 1.0);
                        depth = depth.max(s.radius - local.distance(s.a + ab * t));
                    }
                }
                depth
            })
            .collect()
    }
}

use bevy::math::Affine3A;

/// The share of hair pixels in the frame's three most common hair colours: a toon ramp draws
/// hair in a few flat tones (measured 0.76 here), PBR shading in a gradient (0.035 for the same
/// mesh in its glTF material).
fn flat_share(frame: &CapturedFrame) -> f32 {
    let mut count = std::collections::HashMap::new();
    let mut hair = 0usize;
    for y in 0..frame.height {
        for x in 0..frame.width {
            let p = frame.pixel(x, y);
            if is_hair(p) {
                *count.entry(p).or_insert(0usize) += 1;
                hair += 1;
            }
        }
    }
    let mut counts: Vec<usize> = count.into_values().collect();
    counts.sort_unstable_by(|a, b| b.cmp(a));
    counts.iter().take(3).sum::<usize>() as f32 / hair.max(1) as f32
}

fn save(run: &Run, prefix: &str) -> Result<(), Failed> {
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        let dir = std::path::Path::new(&dir);
        run.rest.save_png(dir.join(format!("{prefix}_rest.png")))?;
        run.shaken
            .save_png(dir.join(format!("{prefix}_shaken.png")))?;
        run.after
            .save_png(dir.join(format!("{prefix}_after.png")))?;
    }
    Ok(())
}

fn a_vrm_character_swings_its_hair_mesh_on_its_springs_in_the_toon_look() -> Result<(), Failed> {
    let with = run("chain_hair/chain_hair.vrm", true)?;
    let without = run("chain_hair/chain_hair.vrm", false)?;
    save(&with, "vrm")?;
    save(&without, "vrm_no_colliders")?;
    let hair = with.rest.count(is_hair);
    let flat = flat_share(&with.rest);
    println!(
        "VRM 1.0: {} springs, {} colliders, colliders seen per spring {:?}; joints swung {:.4} m \
         and came back within {:.2e} m; {} lock vertices went at most {:.4} m deeper into the \
         body colliders than at rest ({:.4} m without colliders); {hair} hair pixels, {flat:.3} of them in 3 tones",
        with.springs,
        with.colliders,
        with.seen,
        with.swing,
        with.back,
        with.vertices,
        with.deeper,
        without.deeper
    );
    // The file's thumbnail is a JPEG texture: decoded, not a failed load.
    if with.thumbnail != Some(UVec2::splat(128)) {
        return Err(format!("the JPEG thumbnail decoded as {:?}", with.thumbnail).into());
    }
    if (with.springs, with.colliders) != (13, 8) {
        return Err(format!(
            "{} springs and {} colliders, not 13 and 8",
            with.springs, with.colliders
        )
        .into());
    }
    // Bangs see the head group (5 spheres); side locks and the back mass also the body (7); the
    // ponytail also the plane behind the neck (8).
    let mut seen = with.seen.clone();
    seen.sort_unstable();
    if seen != [5, 5, 5, 5, 5, 7, 7, 7, 7, 7, 7, 7, 8] {
        return Err(format!("colliders per spring {:?}", with.seen).into());
    }
    if with.swing < 0.01 {
        return Err(format!("the springs swung only {} m", with.swing).into());
    }
    if with.back > 0.002 {
        return Err(format!(
            "the joints rest {} m from their bind pose after the turn",
            with.back
        )
        .into());
    }
    // Stated bound: no lock vertex 1 cm deeper into the head or body than it rests (the locks
    // are up to 7 cm wide around their bones, which the colliders keep out).
    if with.deeper > 0.01 {
        return Err(format!("a hair vertex went {} m into the body", with.deeper).into());
    }
    if without.deeper < with.deeper + 0.005 {
        return Err(format!(
            "without colliders the hair went only {} m in (with: {} m): the test shows nothing",
            without.deeper, with.deeper
        )
        .into());
    }
    if hair < 500 {
        return Err(format!("only {hair} hair pixels").into());
    }
    if flat < 0.5 {
        return Err(
            format!("only {flat} of the hair in its 3 main tones: not the toon look").into(),
        );
    }
    Ok(())
}

fn a_vrm_0_character_gets_its_bone_groups_and_converted_colliders() -> Result<(), Failed> {
    let old = run("chain_hair/chain_hair_vrm0.vrm", true)?;
    save(&old, "vrm0")?;
    println!(
        "VRM 0.x: {} bone groups, {} colliders, per hair {:?}; swung {:.4} m, back within {:.2e} m; \
         head collider centres {:?}",
        old.springs, old.colliders, old.seen, old.swing, old.back, old.head_centres
    );
    // Four groups (bangs, sides, back mass, ponytail); 5 head spheres, 4 neck and 5 shoulder
    // spheres.
    // Its thumbnail is a PNG texture.
    if old.thumbnail != Some(UVec2::splat(128)) {
        return Err(format!("the PNG thumbnail decoded as {:?}", old.thumbnail).into());
    }
    if (old.springs, old.colliders) != (4, 14) {
        return Err(format!("{} groups and {} colliders", old.springs, old.colliders).into());
    }
    // Offsets were written in Unity's space (z negated): read back, they are the head
    // collision's centres again.
    let expected = [
        Vec3::new(0.0, 0.09, -0.01),
        Vec3::new(0.0, 0.075, -0.035),
        Vec3::new(0.0, 0.045, 0.035),
        Vec3::new(0.0, -0.005, 0.03),
        Vec3::new(0.0, -0.07, 0.0),
    ];
    if old.head_centres.len() != 5
        || old
            .head_centres
            .iter()
            .zip(&expected)
            .any(|(a, b)| a.distance(*b) > 1e-6)
    {
        return Err(format!("head collider centres {:?}", old.head_centres).into());
    }
    if old.swing < 0.01 || old.back > 0.002 {
        return Err(format!("swing {} m, back {} m", old.swing, old.back).into());
    }
    Ok(())
}

/// The VRM 1.0 character with its first joint's `dragForce` 0.4 written as 4.0 (same length, so
/// the binary glTF stays valid): outside VRM's `[0, 1]`.
fn a_vrm_with_broken_spring_json_shows_the_character_and_says_where() -> Result<(), Failed> {
    let dir = std::env::temp_dir().join(format!("hair_broken_vrm_{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let good = std::fs::read(crate::repo().join("assets/chain_hair/chain_hair.vrm"))?;
    let (from, to) = (
        b"\"dragForce\":0.4".as_slice(),
        b"\"dragForce\":4.0".as_slice(),
    );
    let at = good
        .windows(from.len())
        .position(|w| w == from)
        .ok_or("the fixture has no dragForce 0.4")?;
    let mut broken = good.clone();
    broken[at..at + to.len()].copy_from_slice(to);
    std::fs::write(dir.join("broken.vrm"), &broken)?;

    #[derive(Resource, Default)]
    struct Reports(Vec<String>);
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width: 64,
        height: 64,
        asset_folder: Some(dir.display().to_string()),
        ..default()
    })?;
    let target = renderer.target();
    let app = &mut renderer.app;
    app.add_plugins(CartoonHairPlugins)
        .init_resource::<Reports>()
        .add_observer(|e: On<VrmSpringsFailed>, mut r: ResMut<Reports>| {
            r.0.push(format!("{} | {}", e.file, e.error));
        });
    let world = app.world_mut();
    let assets = world.resource::<AssetServer>().clone();
    world.spawn(WorldAssetRoot(
        assets.load(GltfAssetLabel::Scene(0).from_asset("broken.vrm")),
    ));
    crate::chain_render::stage(world, target);
    renderer.warm_up(|world| {
        world
            .query::<&VrmSpringChains>()
            .iter(world)
            .next()
            .is_some()
    })?;
    for _ in 0..10 {
        renderer.update();
    }
    let world = renderer.app.world_mut();
    let reports = world.resource::<Reports>().0.clone();
    let head = world
        .query::<&Name>()
        .iter(world)
        .any(|n| n.as_str() == "head");
    let springs: usize = world
        .query::<&VrmSpringChains>()
        .iter(world)
        .map(|c| c.springs.len() + c.colliders.len())
        .sum();
    let strands = world
        .query::<&bevy_cartoon_hair::sim::StrandOf>()
        .iter(world)
        .count();
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "broken VRM: {reports:?}; head bone spawned: {head}; springs and colliders: {springs}"
    );
    let expected = "broken.vrm: extensions.VRMC_springBone.springs[0].joints[0].dragForce: 4 is \
                    outside [0, 1]";
    if reports.len() != 1 || !reports[0].contains(expected) {
        return Err(format!("reports {reports:?}, expected one containing {expected:?}").into());
    }
    if !head || springs != 0 || strands != 0 {
        return Err(format!("head {head}, springs {springs}, strands {strands}").into());
    }
    Ok(())
}

/// A `.vrm` that does not load is a `VrmSpringsFailed` on the scene root that waits for it,
/// naming the file and the loader's reason: a truncated file, and the VRM 1.0 test avatar with
/// its thumbnail declared WebP (a format the crate's Bevy features do not decode: Bevy fails the
/// whole file), whose event says which image features to add.
fn a_vrm_that_does_not_load_is_an_event_naming_it() -> Result<(), Failed> {
    let dir = std::env::temp_dir().join(format!("hair_bad_vrm_{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    // A glTF binary header that promises more than the file holds.
    std::fs::write(dir.join("bad.vrm"), b"glTF\x02\x00\x00\x00\xff\xff\x00\x00")?;
    // The same length, so the JSON chunk keeps its size.
    let avatar = std::fs::read(crate::repo().join("assets/chain_hair/chain_hair.vrm"))?;
    let (from, to) = (&b"\"image/jpeg\""[..], &b"\"image/webp\""[..]);
    let at = avatar
        .windows(from.len())
        .position(|w| w == from)
        .ok_or("the VRM 1.0 test avatar has no JPEG texture")?;
    let mut webp = avatar.clone();
    webp[at..at + to.len()].copy_from_slice(to);
    std::fs::write(dir.join("webp.vrm"), webp)?;
    let mut r = HeadlessRenderer::new(CaptureSettings {
        asset_folder: Some(dir.display().to_string()),
        ..default()
    })?;
    r.app.add_plugins(CartoonHairPlugins);
    #[derive(Resource, Default)]
    struct Seen(Vec<(Entity, String, String)>);
    r.app.init_resource::<Seen>().add_observer(
        |e: On<VrmSpringsFailed>, mut seen: ResMut<Seen>| {
            seen.0.push((e.entity, e.file.clone(), e.error.clone()));
        },
    );
    let world = r.app.world_mut();
    let assets = world.resource::<AssetServer>().clone();
    let mut roots = Vec::new();
    for file in ["bad.vrm", "webp.vrm"] {
        roots.push(
            world
                .spawn(WorldAssetRoot(
                    assets.load(GltfAssetLabel::Scene(0).from_asset(file)),
                ))
                .id(),
        );
    }
    for _ in 0..400 {
        r.update();
        if r.app.world().resource::<Seen>().0.len() >= 2 {
            break;
        }
    }
    let mut seen = r.app.world().resource::<Seen>().0.clone();
    std::fs::remove_dir_all(&dir).ok();
    seen.sort_by(|a, b| a.1.cmp(&b.1));
    eprintln!("{seen:?}");
    match seen.as_slice() {
        [(a, bad, bad_error), (b, webp, webp_error)]
            if *a == roots[0]
                && bad == "bad.vrm"
                && bad_error.contains("did not load")
                && !bad_error.contains("image features")
                && *b == roots[1]
                && webp == "webp.vrm"
                && webp_error.contains("did not load")
                && webp_error.contains("image features") =>
        {
            Ok(())
        }
        _ => Err(format!(
            "expected one event on each root, naming bad.vrm and webp.vrm (with the image \
             features): {seen:?}"
        )
        .into()),
    }
}
