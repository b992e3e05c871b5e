//! Render tests of the anime look of a whole hair: hair-mass normals
//! (`HairMeshSettings::mass_normals`: a curtain of strands lit from the side shades as one shape
//! instead of one band per strand) and the angel ring (`ToonShading::angel_ring`).

use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{AngelRingProfile, ToonLighting};
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, ramps, save, scene, spawn_strand};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "mass_normals_merge_the_strands_shadows",
        mass_normals_merge_the_strands_shadows,
    ),
    (
        "angel_ring_crosses_the_hair_and_follows_the_light",
        angel_ring_crosses_the_hair_and_follows_the_light,
    ),
    (
        "hair_meshes_have_particle_bounds_and_are_culled_off_screen",
        hair_meshes_have_particle_bounds_and_are_culled_off_screen,
    ),
    (
        "back_light_rim_is_strongest_against_the_light",
        back_light_rim_is_strongest_against_the_light,
    ),
    (
        "back_light_hair_tint_takes_the_hairs_colour",
        back_light_hair_tint_takes_the_hairs_colour,
    ),
    (
        "tips_blend_toward_the_tip_colour",
        tips_blend_toward_the_tip_colour,
    ),
    (
        "tips_blend_evenly_in_lightness",
        tips_blend_evenly_in_lightness,
    ),
    (
        "shade_color_tints_only_the_shadowed_tones",
        shade_color_tints_only_the_shadowed_tones,
    ),
];

/// One hair of `strands`, held still (no gravity, anchors rigid), drawn with `material` and
/// `mesh`, without strokes.
pub(crate) fn spawn_still_hair(
    world: &mut World,
    strands: Vec<Vec<Vec3>>,
    material: ToonHairMaterial,
    mesh: HairMeshSettings,
) -> Entity {
    let groom = HairGroom::from_strands("", strands).unwrap();
    let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
    let material = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(material);
    world
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings {
                gravity: Vec3::ZERO,
                anchor_stiffness: QuadraticCurve::constant(1.0),
                ..default()
            },
            mesh,
            HairMaterial(material),
            SilhouetteSettings {
                enabled: false,
                ..default()
            },
        ))
        .id()
}

/// Nine vertical strands side by side in one hair, held still, each `radius` thick.
fn spawn_curtain(r: &mut HeadlessRenderer, mass_normals: f32) -> Entity {
    let ramp = ramps(r).three_tone;
    let strands: Vec<Vec<Vec3>> = (0..9)
        .map(|i| {
            let x = -0.48 + 0.12 * i as f32;
            let z = if i % 2 == 0 { 0.0 } else { -0.03 };
            (0..6)
                .map(|k| Vec3::new(x, 0.6 - 0.24 * k as f32, z))
                .collect()
        })
        .collect();
    // The thesis's lighting (no shadow maps): the strands would also shadow each other, which
    // is not what this measures.
    let shading = ToonShading {
        lighting: ToonLighting::FirstDirectional,
        specular_strength: 0.0,
        ..default()
    };
    spawn_still_hair(
        r.app.world_mut(),
        strands,
        ToonHairMaterial::new(shading, ramp),
        HairMeshSettings {
            radius: 0.08,
            taper: QuadraticCurve::constant(1.0),
            hair_resolution: 24,
            shape_resolution: 24,
            mass_normals,
            ..default()
        },
    )
}

fn luma(p: [u8; 4]) -> f32 {
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

/// The darkest tone's pixels: hair pixels nearer the darkest luma than the middle of the range.
fn shadow_mask(frame: &CapturedFrame) -> (Vec<bool>, usize) {
    let lumas: Vec<Option<f32>> = (0..frame.width * frame.height)
        .map(|i| {
            let p = frame.pixel(i % frame.width, i / frame.width);
            (p != BACKGROUND).then(|| luma(p))
        })
        .collect();
    let (lo, hi) = lumas
        .iter()
        .flatten()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    let cut = lo + 0.25 * (hi - lo);
    let mask: Vec<bool> = lumas.iter().map(|l| l.is_some_and(|l| l < cut)).collect();
    let hair = lumas.iter().flatten().count();
    (mask, hair)
}

/// Connected (4-neighbour) regions of `mask` of at least `min_size` pixels, largest first.
fn regions(mask: &[bool], width: usize, min_size: usize) -> Vec<usize> {
    let mut seen = vec![false; mask.len()];
    let mut sizes = Vec::new();
    for start in 0..mask.len() {
        if !mask[start] || seen[start] {
            continue;
        }
        let mut stack = vec![start];
        seen[start] = true;
        let mut size = 0;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % width, i / width);
            let mut visit = |j: usize| {
                if mask[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < width {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - width);
            }
            if i + width < mask.len() {
                visit(i + width);
            }
        }
        if size >= min_size {
            sizes.push(size);
        }
    }
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    sizes
}

/// Lit from the right, the curtain's shadow tone with each strand's own normals (blend 0) is one
/// band down the left side of every strand (9 regions of equal size); with the default blend and
/// with 1 it is at most half as many regions, the two largest holding 80% of it, on the left of
/// the whole curtain.
fn mass_normals_merge_the_strands_shadows() -> Result<(), Failed> {
    let mut counts = Vec::new();
    for blend in [0.0, HairMeshSettings::default().mass_normals, 1.0] {
        let mut r = scene(Vec3::new(1.0, 0.2, 0.5), Vec3::new(0.0, 0.0, 3.0))?;
        spawn_curtain(&mut r, blend);
        let frame = r.capture()?;
        save(&frame, &format!("mass_normals_{blend}"))?;
        let (mask, hair) = shadow_mask(&frame);
        let found = regions(&mask, frame.width as usize, 20);
        let shadow: usize = mask.iter().filter(|m| **m).count();
        // Where the shadow lies: the mean x of its pixels, relative to the image's width.
        let mean_x = mask
            .iter()
            .enumerate()
            .filter(|(_, m)| **m)
            .map(|(i, _)| (i % frame.width as usize) as f32)
            .sum::<f32>()
            / shadow.max(1) as f32
            / frame.width as f32;
        eprintln!(
            "blend {blend}: {} shadow regions {found:?}, {shadow} of {hair} hair pixels, mean x {mean_x:.2}",
            found.len()
        );
        if hair < 5000 || shadow < hair / 20 {
            return Err(format!("blend {blend}: {hair} hair pixels, {shadow} in shadow").into());
        }
        // The share of the shadow in its two largest regions.
        let two: usize = found.iter().take(2).sum();
        counts.push((found.len(), two as f32 / shadow as f32, mean_x));
    }
    let fail = |m: &str| -> Result<(), Failed> { Err(format!("{m}: {counts:?}").into()) };
    let [own, default, full] = counts[..] else {
        unreachable!()
    };
    if own.0 < 9 || own.1 > 0.4 {
        return fail("own normals: expected one shadow band per strand");
    }
    for (blend, (n, two, mean_x)) in [("default", default), ("1", full)] {
        if n > own.0 / 2 || two < 0.8 || mean_x > 0.45 {
            return fail(&format!(
                "blend {blend}: expected a few large shadow regions on the left"
            ));
        }
    }
    Ok(())
}

/// Cyan: a ring colour no lit orange hair has.
pub(crate) const RING: Color = Color::srgb(0.0, 1.0, 1.0);

pub(crate) fn is_ring(p: [u8; 4]) -> bool {
    p[0] < 60 && p[1] > 150 && p[2] > 150
}

/// 72 strands around a head of radius 0.5 at the origin, 2 cm off the scalp, each falling from
/// `from` degrees off the pole to `to` degrees, `particles` particles each.
pub(crate) fn falling_strands(from: f32, to: f32, particles: usize) -> Vec<Vec<Vec3>> {
    (0..72)
        .map(|i| {
            let around = std::f32::consts::TAU * i as f32 / 72.0;
            (0..particles)
                .map(|k| {
                    let polar =
                        (from + (to - from) * k as f32 / (particles - 1) as f32).to_radians();
                    Vec3::new(
                        polar.sin() * around.sin(),
                        polar.cos(),
                        polar.sin() * around.cos(),
                    ) * 0.52
                })
                .collect()
        })
        .collect()
}

/// A bob: 72 strands from around the crown of a head (radius 0.5 at the origin) down its sides
/// to below the equator, 2 cm off the scalp, in one hair.
fn spawn_bob(r: &mut HeadlessRenderer, profile: AngelRingProfile) {
    let ramp = ramps(r).three_tone;
    // From 15 degrees off the pole to 20 degrees below the equator.
    let strands = falling_strands(15.0, 110.0, 8);
    let shading = ToonShading {
        lighting: ToonLighting::FirstDirectional,
        angel_ring: 1.0,
        angel_ring_color: RING,
        angel_ring_profile: profile,
        ..default()
    };
    spawn_still_hair(
        r.app.world_mut(),
        strands,
        ToonHairMaterial::new(shading, ramp),
        HairMeshSettings {
            radius: 0.035,
            taper: QuadraticCurve::constant(1.0),
            hair_resolution: 24,
            shape_resolution: 12,
            ..default()
        },
    );
}

/// Ring pixels: (count, mean y, leftmost x, rightmost x).
fn ring_stats(frame: &CapturedFrame) -> (usize, f32, u32, u32) {
    let (mut n, mut sum_y, mut lo, mut hi) = (0, 0.0, u32::MAX, 0);
    for y in 0..frame.height {
        for x in 0..frame.width {
            if is_ring(frame.pixel(x, y)) {
                n += 1;
                sum_y += y as f32;
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    (n, sum_y / n.max(1) as f32, lo, hi)
}

/// On a bob seen from the front and lit from the front, the angel ring is a band across the
/// hair (it spans most of the hair's width) at one height; with the light raised it moves up
/// the head, with the light lowered down, as a highlight of the view and the light does. Every
/// profile draws it; the zig-zag's edge is longer than the even band's.
fn angel_ring_crosses_the_hair_and_follows_the_light() -> Result<(), Failed> {
    let mut found = Vec::new();
    for (profile, light) in [
        (AngelRingProfile::ZigZag, Vec3::new(0.0, 0.3, 1.0)),
        (AngelRingProfile::ZigZag, Vec3::new(0.0, 1.2, 1.0)),
        (AngelRingProfile::ZigZag, Vec3::new(0.0, -0.2, 1.0)),
        (AngelRingProfile::Even, Vec3::new(0.0, 0.3, 1.0)),
        (AngelRingProfile::Soft, Vec3::new(0.0, 0.3, 1.0)),
    ] {
        let mut r = scene(light, Vec3::new(0.0, 0.0, 3.0))?;
        spawn_bob(&mut r, profile);
        let frame = r.capture()?;
        save(&frame, &format!("angel_ring_{profile:?}_{:.1}", light.y))?;
        let hair = frame.count(|p| p != BACKGROUND);
        let (n, mean_y, lo, hi) = ring_stats(&frame);
        // Ring pixels with a non-ring 4-neighbour: the length of the band's edge.
        let edge = (1..frame.height - 1)
            .flat_map(|y| (1..frame.width - 1).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                is_ring(frame.pixel(x, y))
                    && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                        .iter()
                        .any(|&(a, b)| !is_ring(frame.pixel(a, b)))
            })
            .count();
        eprintln!(
            "{profile:?}, light y {:.1}: {n} ring pixels of {hair} hair, mean y {mean_y:.1}, x {lo}..{hi}, edge {edge}",
            light.y
        );
        found.push((n, mean_y, hi.saturating_sub(lo), edge, hair));
    }
    let fail = |m: &str| -> Result<(), Failed> { Err(format!("{m}: {found:?}").into()) };
    let (n, y, span, zig_edge, hair) = found[0];
    if n < hair / 50 || n > hair / 3 {
        return fail("the ring is not a band over part of the hair");
    }
    // The bob is about 110 px wide at this distance; the band crosses most of it.
    if span < 60 {
        return fail("the ring does not cross the hair");
    }
    let (up, down) = (found[1].1, found[2].1);
    if !(up < y - 5.0 && down > y + 5.0) {
        return fail("the ring does not follow the light up and down the head");
    }
    let (even_n, even_edge) = (found[3].0, found[3].3);
    if even_n < hair / 50 || found[4].0 < hair / 100 {
        return fail("the even or soft profile draws no ring");
    }
    if zig_edge as f32 / (n as f32) <= even_edge as f32 / (even_n as f32) {
        return fail("the zig-zag's edge is no longer than the even band's");
    }
    Ok(())
}

/// Hair meshes carry bounds from their particles (no `NoFrustumCulling`), so Bevy culls a hair
/// no camera sees: two curtains, one in view and one 20 m to the side; the first is visible and
/// drawn, the second is not visible; every particle lies inside its mesh's bounds, and the bounds
/// follow the hair when it moves.
fn hair_meshes_have_particle_bounds_and_are_culled_off_screen() -> Result<(), Failed> {
    use bevy::camera::primitives::Aabb;
    use bevy::camera::visibility::{NoFrustumCulling, ViewVisibility};
    use bevy_cartoon_hair::mesh::{ComputedHairMesh, HairCulling, HairCullingStats, HairMeshOf};
    use bevy_cartoon_hair::sim::{StrandOf, StrandParticles};

    let mut r = scene(Vec3::new(1.0, 0.2, 0.5), Vec3::new(0.0, 0.0, 3.0))?;
    // The CPU's meshes are read back below. Bounds and culling come from the particles, whoever
    // builds the vertices.
    r.app
        .insert_resource(bevy_cartoon_hair::render::HairMeshBuilder::Cpu);
    let seen = spawn_curtain(&mut r, 0.0);
    let hidden = spawn_curtain(&mut r, 0.0);
    r.app
        .world_mut()
        .entity_mut(hidden)
        .insert(Transform::from_xyz(20.0, 0.0, 0.0));
    let frame = r.capture()?;
    let drawn = frame.count(|p| p != BACKGROUND);
    let check = |r: &mut HeadlessRenderer| -> Result<(bool, bool), Failed> {
        let world = r.app.world_mut();
        let mut result = Vec::new();
        for hair in [seen, hidden] {
            let mesh = world
                .get::<ComputedHairMesh>(hair)
                .ok_or("no hair mesh")?
                .entity;
            let e = world.entity(mesh);
            if e.contains::<NoFrustumCulling>() || !e.contains::<HairMeshOf>() {
                return Err("the hair mesh opts out of culling".into());
            }
            let aabb = *e.get::<Aabb>().ok_or("the hair mesh has no bounds")?;
            let visible = e.get::<ViewVisibility>().is_some_and(|v| v.get());
            let (lo, hi) = (aabb.min(), aabb.max());
            let mut q = world.query::<(&StrandOf, &StrandParticles)>();
            let mut particles = 0;
            for (strand, p) in q.iter(world) {
                if strand.0 != hair {
                    continue;
                }
                for x in &p.positions {
                    particles += 1;
                    let x = bevy::math::Vec3A::from(*x);
                    if x.cmplt(lo).any() || x.cmpgt(hi).any() {
                        return Err(format!("particle {x} outside the bounds {lo}..{hi}").into());
                    }
                }
            }
            if particles < 50 {
                return Err(format!("only {particles} particles found").into());
            }
            result.push(visible);
        }
        Ok((result[0], result[1]))
    };
    let (a, b) = check(&mut r)?;
    eprintln!("in view: visible {a}, {drawn} pixels drawn; 20 m aside: visible {b}");
    if !a || b || drawn < 5000 {
        return Err(format!("visible in view {a}, aside {b}, {drawn} pixels drawn").into());
    }
    // Swap them: the bounds follow, and so does the culling.
    r.app
        .world_mut()
        .entity_mut(hidden)
        .insert(Transform::IDENTITY);
    r.app
        .world_mut()
        .entity_mut(seen)
        .insert(Transform::from_xyz(-20.0, 0.0, 0.0));
    r.capture()?;
    let (a, b) = check(&mut r)?;
    if a || !b {
        return Err(format!("after the swap: visible {a} (moved aside), {b} (moved in)").into());
    }
    // The hair no camera sees keeps its last mesh (culled: not rebuilt), while its bounds
    // follow its particles; the hair that came into view was rebuilt in that same frame.
    let centre_x = |r: &mut HeadlessRenderer, hair: Entity| -> Result<f32, Failed> {
        let world = r.app.world();
        let handle = world
            .get::<ComputedHairMesh>(hair)
            .ok_or("no hair mesh")?
            .mesh
            .clone();
        let mesh = world
            .resource::<Assets<Mesh>>()
            .get(&handle)
            .ok_or("the mesh asset is gone")?;
        let p = mesh
            .attribute(Mesh::ATTRIBUTE_POSITION)
            .and_then(|a| a.as_float3())
            .ok_or("no positions")?;
        Ok(p.iter().map(|v| v[0]).sum::<f32>() / p.len().max(1) as f32)
    };
    let (aside, came_in) = (centre_x(&mut r, seen)?, centre_x(&mut r, hidden)?);
    let stats = *r.app.world().resource::<HairCullingStats>();
    eprintln!(
        "after the swap: the culled hair's mesh is centred at x = {aside:.2} (its particles near \
         -20), the one that came in at x = {came_in:.2}; culled {} of {}",
        stats.culled, stats.hairs
    );
    if aside.abs() > 2.0 || came_in.abs() > 2.0 || stats.culled != 1 || stats.hairs != 2 {
        return Err(format!(
            "culled mesh at x {aside}, rebuilt mesh at x {came_in}, stats {stats:?}"
        )
        .into());
    }
    // With culling off, the hair aside is rebuilt where its particles are.
    r.app.world_mut().entity_mut(seen).insert(HairCulling {
        enabled: false,
        ..default()
    });
    r.capture()?;
    let rebuilt = centre_x(&mut r, seen)?;
    if (rebuilt + 20.0).abs() > 2.0 {
        return Err(format!("with culling off the mesh is at x {rebuilt}, not near -20").into());
    }
    Ok(())
}

/// A frame of one horizontal strand from x = -1 (its root) to 1, `radius` thick, shaded with
/// `shading` under the first directional light from `light`, seen from z = 3; saved as `name`.
fn capture_strand(
    light: Vec3,
    radius: f32,
    shading: ToonShading,
    name: &str,
) -> Result<CapturedFrame, Failed> {
    let mut r = scene(light, Vec3::new(0.0, 0.0, 3.0))?;
    let ramp = ramps(&r).three_tone;
    let shading = ToonShading {
        lighting: ToonLighting::FirstDirectional,
        ..shading
    };
    spawn_strand(
        &mut r,
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        radius,
        ToonHairMaterial::new(shading, ramp),
    );
    let frame = r.capture()?;
    save(&frame, name)?;
    Ok(frame)
}

/// The additive back light (contre-jour) uses the light: a cyan rim on a strand is brighter lit
/// from behind (the light facing the viewer) than lit from the front.
fn back_light_rim_is_strongest_against_the_light() -> Result<(), Failed> {
    // Blue summed over the frame with the rim and without: the rim's own share.
    let blue = |light: Vec3, strength: f32, name: &str| -> Result<f32, Failed> {
        let shading = ToonShading {
            back_light_strength: strength,
            back_light_color: Color::srgb(0.0, 0.8, 0.8),
            ..default()
        };
        let frame = capture_strand(
            light,
            0.4,
            shading,
            &format!("back_light_{name}_{strength}"),
        )?;
        Ok((0..frame.height)
            .flat_map(|y| (0..frame.width).map(move |x| (x, y)))
            .map(|(x, y)| f32::from(frame.pixel(x, y)[2]))
            .sum())
    };
    let mut rim = Vec::new();
    for (name, light) in [
        ("front", Vec3::new(0.0, 0.3, 1.0)),
        ("behind", Vec3::new(0.0, 0.3, -1.0)),
    ] {
        let added = blue(light, 1.0, name)? - blue(light, 0.0, name)?;
        eprintln!("back light, lit from the {name}: the rim adds {added:.0} to the blue sum");
        rim.push(added);
    }
    if rim[0] <= 0.0 || rim[1] < 2.0 * rim[0] {
        return Err(format!("the rim lit from behind is not twice the front's: {rim:?}").into());
    }
    Ok(())
}

/// `back_light_hair_tint` multiplies the rim by the hair's colour: a white rim on green hair
/// brightens red, green and blue alike at tint 0, and mostly green at tint 1, for any green.
fn back_light_hair_tint_takes_the_hairs_colour() -> Result<(), Failed> {
    // Red, green and blue summed over the frame, lit from behind.
    let sums = |base: Color, strength: f32, tint: f32| -> Result<[f32; 3], Failed> {
        let shading = ToonShading {
            base_color: base,
            back_light_strength: strength,
            back_light_color: Color::WHITE,
            back_light_hair_tint: tint,
            ..default()
        };
        let light = Vec3::new(0.0, 0.3, -1.0);
        let frame = capture_strand(
            light,
            0.4,
            shading,
            &format!("back_light_tint_{tint}_{strength}"),
        )?;
        let mut sum = [0.0; 3];
        for y in 0..frame.height {
            for x in 0..frame.width {
                let p = frame.pixel(x, y);
                for (c, s) in sum.iter_mut().enumerate() {
                    *s += f32::from(p[c]);
                }
            }
        }
        Ok(sum)
    };
    // What the rim adds to each channel.
    let rim = |base: Color, tint: f32| -> Result<[f32; 3], Failed> {
        let (with, without) = (sums(base, 0.5, tint)?, sums(base, 0.0, tint)?);
        Ok([0, 1, 2].map(|c| with[c] - without[c]))
    };
    let green = Color::srgb(0.15, 0.45, 0.15);
    let white_rim = rim(green, 0.0)?;
    let hair_rim = rim(green, 1.0)?;
    eprintln!("rim added (red, green, blue): tint 0 {white_rim:?}, tint 1 {hair_rim:?}");
    // A white rim brightens blue about as much as green; the hair's green rim (8.8 times more
    // green than blue in linear light; less in the frame's sRGB, which lifts the darker channel
    // more) brightens green at least twice as much as blue, and is dimmer overall (times a
    // colour below 1).
    if white_rim[2] <= 0.0 || white_rim[1] > 2.0 * white_rim[2] {
        return Err(format!("a white rim does not add to every channel: {white_rim:?}").into());
    }
    if hair_rim[1] <= 0.0 || hair_rim[1] < 2.0 * hair_rim[2] || hair_rim[1] < 2.0 * hair_rim[0] {
        return Err(format!("the tinted rim is not the hair's green: {hair_rim:?}").into());
    }
    if hair_rim[1] >= white_rim[1] {
        return Err(format!(
            "the tinted rim adds as much green as the white one: {hair_rim:?} vs {white_rim:?}"
        )
        .into());
    }
    Ok(())
}

/// `tip_color`: an orange strand (root on the left) whose tips blend toward blue from halfway
/// along it: the root third keeps the colour it has without the blend, the tip third turns blue,
/// and the blue grows toward the tip.
fn tips_blend_toward_the_tip_colour() -> Result<(), Failed> {
    // Mean red and blue of the strand's pixels in six columns of equal width, root to tip.
    let columns = |strength: f32| -> Result<Vec<[f32; 2]>, Failed> {
        let shading = ToonShading {
            tip_color: Color::srgb(0.1, 0.3, 0.9),
            tip_start: 0.5,
            tip_strength: strength,
            ..default()
        };
        let light = Vec3::new(0.0, 0.3, 1.0);
        let frame = capture_strand(light, 0.15, shading, &format!("tip_color_{strength}"))?;
        Ok(strand_columns(&frame)
            .iter()
            .map(|[r, _, b]| [*r, *b])
            .collect())
    };
    let plain = columns(0.0)?;
    let tipped = columns(1.0)?;
    eprintln!("mean (red, blue) root to tip: without {plain:.0?}; with {tipped:.0?}");
    if plain.len() != 6 || plain.iter().any(|[r, b]| r <= b) {
        return Err(format!("the plain strand is not orange along its length: {plain:?}").into());
    }
    for c in 0..2 {
        let ([r0, b0], [r1, b1]) = (plain[c], tipped[c]);
        if (r0 - r1).abs() > 6.0 || (b0 - b1).abs() > 6.0 {
            return Err(format!("the root third changed colour: {plain:?} vs {tipped:?}").into());
        }
    }
    let [r5, b5] = tipped[5];
    if b5 <= r5 || !(tipped[3][1] < tipped[4][1] && tipped[4][1] < tipped[5][1]) {
        return Err(format!("the tips do not turn blue toward the tip: {tipped:?}").into());
    }
    Ok(())
}

/// Mean red, green and blue (8-bit sRGB) of a captured strand's pixels (all but the background)
/// in six columns of equal width, left (the root) to right.
fn strand_columns(frame: &CapturedFrame) -> Vec<[f32; 3]> {
    let hair: Vec<(u32, [u8; 4])> = (0..frame.height)
        .flat_map(|y| (0..frame.width).map(move |x| (x, y)))
        .map(|(x, y)| (x, frame.pixel(x, y)))
        .filter(|(_, p)| *p != BACKGROUND)
        .collect();
    let (lo, hi) = hair
        .iter()
        .fold((u32::MAX, 0), |(lo, hi), (x, _)| (lo.min(*x), hi.max(*x)));
    let width = (hi + 1 - lo.min(hi)) as f32;
    let mut sums = [[0.0f32; 4]; 6];
    for (x, p) in &hair {
        let c = (((x - lo) as f32 / width) * 6.0).min(5.0) as usize;
        for i in 0..3 {
            sums[c][i] += f32::from(p[i]);
        }
        sums[c][3] += 1.0;
    }
    sums.iter()
        .map(|[r, g, b, n]| [r / n.max(1.0), g / n.max(1.0), b / n.max(1.0)])
        .collect()
}

/// A dark brown strand whose tips blend to pale blonde from its root (an ombre): the lightness
/// climbs evenly along it, as a painted gradient does. Between the root and tip columns, the
/// middle two reach 30-60% of the way in luma; blended in linear light the pale colour takes
/// over early (68% of the way by the middle).
fn tips_blend_evenly_in_lightness() -> Result<(), Failed> {
    let shading = ToonShading {
        base_color: Color::srgb(0.1, 0.06, 0.04),
        tip_color: Color::srgb(1.0, 0.93, 0.78),
        tip_start: 0.0,
        tip_strength: 1.0,
        ..default()
    };
    let frame = capture_strand(Vec3::new(0.0, 0.3, 1.0), 0.15, shading, "tip_ombre")?;
    let luma: Vec<f32> = strand_columns(&frame)
        .iter()
        .map(|[r, g, b]| 0.2126 * r + 0.7152 * g + 0.0722 * b)
        .collect();
    let middle = ((luma[2] + luma[3]) / 2.0 - luma[0]) / (luma[5] - luma[0]);
    eprintln!(
        "ombre luma root to tip {luma:.0?}: the middle {:.0}% of the way",
        100.0 * middle
    );
    if luma.windows(2).any(|w| w[1] <= w[0]) || luma[5] - luma[0] < 60.0 {
        return Err(format!("the strand does not lighten toward its tip: {luma:?}").into());
    }
    if !(0.3..=0.6).contains(&middle) {
        return Err(format!(
            "the middle of the blend is {:.0}% of the way from root to tip in luma, not 30-60%: \
             {luma:?}",
            100.0 * middle
        )
        .into());
    }
    Ok(())
}

/// `shade_color`: an orange strand lit from above shows the three-tone ramp's lit, middle and
/// dark tones across it. With a violet shade colour, every pixel of the lit tone is as it was
/// (within 2 levels), and the darkest tone's pixels gain blue and lose green against red (by
/// at least 25% and 15%: hue-shifted shadows), the middle tone's by less.
fn shade_color_tints_only_the_shadowed_tones() -> Result<(), Failed> {
    let light = Vec3::new(0.0, 1.0, 0.25);
    let capture = |shade_color: Color, name: &str| {
        let shading = ToonShading {
            shade_color,
            ..default()
        };
        capture_strand(light, 0.3, shading, name)
    };
    let plain = capture(Color::WHITE, "shade_color_off")?;
    let shaded = capture(Color::srgb(0.6, 0.4, 1.0), "shade_color_violet")?;
    // Each hair pixel by its tone without the shade colour (luma: lit, middle, dark), and by
    // what share its blue-to-red and green-to-red ratios moved with it.
    let luma =
        |p: [u8; 4]| 0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]);
    let mut pixels: Vec<(f32, [u8; 4], [u8; 4])> = Vec::new();
    for y in 0..plain.height {
        for x in 0..plain.width {
            let (a, b) = (plain.pixel(x, y), shaded.pixel(x, y));
            if a != BACKGROUND {
                pixels.push((luma(a), a, b));
            }
        }
    }
    let brightest = pixels.iter().map(|p| p.0).fold(0.0, f32::max);
    let darkest = pixels.iter().map(|p| p.0).fold(f32::MAX, f32::min);
    let (mut lit, mut lit_moved, mut dark, mut middle) = (0, 0, Vec::new(), Vec::new());
    for (l, a, b) in &pixels {
        let ratio = |p: &[u8; 4], c: usize| f32::from(p[c]) / f32::from(p[0]).max(1.0);
        let shift = [
            ratio(b, 2) / ratio(a, 2).max(1e-3) - 1.0,
            ratio(b, 1) / ratio(a, 1).max(1e-3) - 1.0,
        ];
        if *l >= brightest - 3.0 {
            lit += 1;
            if (0..3).any(|c| a[c].abs_diff(b[c]) > 2) {
                lit_moved += 1;
            }
        } else if *l <= darkest + 3.0 {
            dark.push(shift);
        } else if *l > darkest + 20.0 && *l < brightest - 20.0 {
            middle.push(shift);
        }
    }
    let mean = |v: &[[f32; 2]]| {
        let n = v.len().max(1) as f32;
        v.iter()
            .fold([0.0, 0.0], |s, d| [s[0] + d[0] / n, s[1] + d[1] / n])
    };
    let (dark_shift, middle_shift) = (mean(&dark), mean(&middle));
    eprintln!(
        "shade colour: {lit} lit pixels ({lit_moved} changed); blue/red and green/red moved by \
         {dark_shift:.3?} over {} dark pixels, {middle_shift:.3?} over {} middle ones",
        dark.len(),
        middle.len()
    );
    if lit < 50 || dark.len() < 50 || middle.len() < 50 {
        return Err(format!(
            "the strand does not show three tones: {lit} lit, {} middle, {} dark pixels",
            middle.len(),
            dark.len()
        )
        .into());
    }
    if lit_moved * 50 > lit {
        return Err(format!("the shade colour changed {lit_moved} of {lit} lit pixels").into());
    }
    if dark_shift[0] < 0.25 || dark_shift[1] > -0.15 {
        return Err(format!("the dark tone did not turn violet: {dark_shift:?}").into());
    }
    if !(middle_shift[0] > 0.0 && middle_shift[0] < dark_shift[0]) {
        return Err(format!(
            "the middle tone's shift {middle_shift:?} is not between none and the dark tone's \
             {dark_shift:?}"
        )
        .into());
    }
    Ok(())
}
