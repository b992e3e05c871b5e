//! Render tests of the image-space outline (`ImageSpaceOutline`), on a thick toon-shaded strand
//! whose ramp puts shading bands across its face.

use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use libtest_mimic::Failed;

use crate::mass_render::spawn_still_hair;
use crate::toon_render::{BACKGROUND, distinct_shades, ramps, save, scene, spawn_strand};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "outline_inks_silhouette_not_toon_bands",
        outline_inks_silhouette_not_toon_bands,
    ),
    ("outline_off_draws_no_ink", outline_off_draws_no_ink),
    (
        "outline_toggles_off_and_on_repeatedly",
        outline_toggles_off_and_on_repeatedly,
    ),
    (
        "outline_wider_dilation_draws_wider_ink",
        wider_dilation_draws_wider_ink,
    ),
    (
        "outline_sees_hair_in_depth_and_normal_prepasses",
        hair_is_in_depth_and_normal_prepasses,
    ),
    (
        "outline_is_anti_aliased_with_msaa",
        outline_is_anti_aliased_with_msaa,
    ),
    (
        "outline_mass_inks_the_hair_not_its_strands",
        mass_outline_inks_the_hair_not_its_strands,
    ),
    (
        "outline_runs_around_thin_tips_without_filling_them",
        outline_runs_around_thin_tips_without_filling_them,
    ),
];

/// Magenta: neither the orange hair, the grey sphere nor the black background.
const INK: Color = Color::srgb(1.0, 0.0, 1.0);

fn is_ink(p: [u8; 4]) -> bool {
    p[0] > 240 && p[1] < 15 && p[2] > 240
}

/// Hair pixels farther than this from the silhouette are "the middle of the strand".
const INTERIOR: u32 = 6;

/// The toon-bands scene (light above-front, three-tone ramp, a thick horizontal strand), the
/// camera carrying `outline`; with `sphere`, a grey sphere (the "character") above the strand.
fn outline_scene(outline: ImageSpaceOutline, sphere: bool) -> Result<HeadlessRenderer, Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
    let ramp = ramps(&r).three_tone;
    spawn_strand(
        &mut r,
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        0.4,
        ToonHairMaterial { ramp, ..default() },
    );
    let world = r.app.world_mut();
    if sphere {
        let mesh = world
            .resource_mut::<Assets<Mesh>>()
            .add(Sphere::new(0.25).mesh().uv(32, 16));
        let material = world
            .resource_mut::<Assets<StandardMaterial>>()
            .add(Color::srgb(0.6, 0.6, 0.6));
        world.spawn((
            Mesh3d(mesh),
            MeshMaterial3d(material),
            Transform::from_xyz(0.0, 0.85, 0.0),
        ));
    }
    let camera = camera(&mut r)?;
    r.app.world_mut().entity_mut(camera).insert(outline);
    Ok(r)
}

fn camera(r: &mut HeadlessRenderer) -> Result<Entity, Failed> {
    let world = r.app.world_mut();
    Ok(world
        .query_filtered::<Entity, With<Camera3d>>()
        .single(world)?)
}

fn edit_outline(r: &mut HeadlessRenderer, mut edit: impl FnMut(&mut ImageSpaceOutline)) {
    let world = r.app.world_mut();
    let mut q = world.query::<&mut ImageSpaceOutline>();
    for mut outline in q.iter_mut(world) {
        edit(&mut outline);
    }
}

fn magenta(edit: impl FnOnce(&mut ImageSpaceOutline)) -> ImageSpaceOutline {
    let mut o = ImageSpaceOutline {
        color: INK,
        ..default()
    };
    edit(&mut o);
    o
}

/// Chessboard distance of every pixel to the silhouette of `reference` (object pixels touching
/// the background), by breadth-first search; `u32::MAX` where there is no object at all.
fn silhouette_distance(reference: &CapturedFrame) -> (Vec<bool>, Vec<u32>) {
    distance_from_edge(reference, |p| p != BACKGROUND)
}

/// Chessboard distance of every pixel of the kind `is_object` picks to the nearest pixel of
/// another kind (0 on the object's edge); `u32::MAX` elsewhere.
fn distance_from_edge(
    reference: &CapturedFrame,
    is_object: impl Fn([u8; 4]) -> bool,
) -> (Vec<bool>, Vec<u32>) {
    let (w, h) = (reference.width as i32, reference.height as i32);
    let object: Vec<bool> = (0..w * h)
        .map(|i| is_object(reference.pixel((i % w) as u32, (i / w) as u32)))
        .collect();
    let at = |x: i32, y: i32| -> bool {
        x < 0 || y < 0 || x >= w || y >= h || object[(y * w + x) as usize]
    };
    let mut dist = vec![u32::MAX; (w * h) as usize];
    let mut queue = std::collections::VecDeque::new();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let touches = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .any(|(dx, dy)| !at(x + dx, y + dy));
            if object[i] && touches {
                dist[i] = 0;
                queue.push_back((x, y));
            }
        }
    }
    while let Some((x, y)) = queue.pop_front() {
        let d = dist[(y * w + x) as usize];
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if dist[j] == u32::MAX {
                    dist[j] = d + 1;
                    queue.push_back((nx, ny));
                }
            }
        }
    }
    (object, dist)
}

/// What an outlined frame shows against an un-outlined reference of the same scene.
#[derive(Debug)]
struct InkStats {
    /// Ink pixels.
    ink: usize,
    /// Share of silhouette pixels with ink within 1 px.
    coverage: f32,
    /// Largest distance of an ink pixel from the silhouette.
    farthest: u32,
    /// Ink pixels among the object's interior (farther than `INTERIOR` from the silhouette).
    interior_ink: usize,
    /// Interior pixels.
    interior: usize,
    /// Interior pixels whose colour changed by more than 2 per channel.
    interior_changed: usize,
}

fn ink_stats(reference: &CapturedFrame, outlined: &CapturedFrame) -> InkStats {
    let (object, dist) = silhouette_distance(reference);
    let (w, h) = (outlined.width as i32, outlined.height as i32);
    let ink_at = |x: i32, y: i32| {
        x >= 0 && y >= 0 && x < w && y < h && is_ink(outlined.pixel(x as u32, y as u32))
    };
    let mut s = InkStats {
        ink: 0,
        coverage: 0.0,
        farthest: 0,
        interior_ink: 0,
        interior: 0,
        interior_changed: 0,
    };
    let (mut silhouette, mut covered) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let ink = ink_at(x, y);
            if ink {
                s.ink += 1;
                s.farthest = s.farthest.max(dist[i]);
            }
            if dist[i] == 0 {
                silhouette += 1;
                if (-1..=1).any(|dy| (-1..=1).any(|dx| ink_at(x + dx, y + dy))) {
                    covered += 1;
                }
            }
            if object[i] && dist[i] > INTERIOR {
                s.interior += 1;
                s.interior_ink += usize::from(ink);
                let (a, b) = (
                    reference.pixel(x as u32, y as u32),
                    outlined.pixel(x as u32, y as u32),
                );
                if (0..3).any(|c| (i32::from(a[c]) - i32::from(b[c])).abs() > 2) {
                    s.interior_changed += 1;
                }
            }
        }
    }
    s.coverage = covered as f32 / f32::max(silhouette as f32, 1.0);
    s
}

/// Ink surrounds the silhouette and stays off the interior, across the toon bands.
fn check_silhouette_ink(stats: &InkStats, max_distance: u32, what: &str) -> Result<(), Failed> {
    if stats.coverage < 0.95 || stats.ink < 500 {
        return Err(format!("{what}: silhouette not surrounded by ink: {stats:?}").into());
    }
    if stats.farthest > max_distance {
        return Err(format!(
            "{what}: ink {} px from the silhouette: {stats:?}",
            stats.farthest
        )
        .into());
    }
    if stats.interior < 2000 || stats.interior_ink > 0 || stats.interior_changed > 0 {
        return Err(format!("{what}: ink or changes inside the object: {stats:?}").into());
    }
    Ok(())
}

fn ink_count(frame: &CapturedFrame) -> usize {
    frame.count(is_ink)
}

/// With the outline on, ink surrounds the strand's and the sphere's silhouettes (every silhouette
/// pixel has ink within 1 px, no ink farther than 4 px from it) and none lies in the middle of the
/// strand's face, although the toon ramp puts two or more shading bands there.
fn outline_inks_silhouette_not_toon_bands() -> Result<(), Failed> {
    let mut r = outline_scene(magenta(|o| o.enabled = false), true)?;
    let reference = r.capture()?;
    save(&reference, "outline_reference")?;
    edit_outline(&mut r, |o| o.enabled = true);
    let outlined = r.capture()?;
    save(&outlined, "outline_on")?;

    let (object, dist) = silhouette_distance(&reference);
    let face: Vec<[u8; 4]> = (0..object.len())
        .filter(|&i| object[i] && dist[i] > INTERIOR)
        .map(|i| reference.pixel(i as u32 % reference.width, i as u32 / reference.width))
        .collect();
    let bands = distinct_shades(&face, 3, 0.01);
    if bands.len() < 2 {
        return Err(format!("the strand shows no toon bands to ignore: {bands:?}").into());
    }
    if ink_count(&reference) != 0 {
        return Err("ink in the reference frame".into());
    }
    let stats = ink_stats(&reference, &outlined);
    eprintln!("outline on: {stats:?}, {} bands", bands.len());
    // Sobel marks one pixel each side of a step, dilation 1 one more, normals at the rim one more.
    check_silhouette_ink(&stats, 4, "mass (the default)")
}

/// A disabled outline draws nothing and adds no prepass to the camera.
fn outline_off_draws_no_ink() -> Result<(), Failed> {
    let mut r = outline_scene(magenta(|o| o.enabled = false), true)?;
    let frame = r.capture()?;
    save(&frame, "outline_off")?;
    let hair = frame.count(|p| p != BACKGROUND);
    if hair < 5000 {
        return Err(format!("only {hair} object pixels rendered").into());
    }
    let ink = ink_count(&frame);
    if ink != 0 {
        return Err(format!("{ink} ink pixels with the outline off").into());
    }
    let camera = camera(&mut r)?;
    let camera = r.app.world().entity(camera);
    if camera.contains::<DepthPrepass>() || camera.contains::<NormalPrepass>() {
        return Err("a disabled outline left prepasses on the camera".into());
    }
    Ok(())
}

/// On, off, on, off, on in one app (with MSAA, so the multisampled prepass variant runs), several
/// frames each: every "on" shows the same ink, every "off" none, and the prepasses follow.
fn outline_toggles_off_and_on_repeatedly() -> Result<(), Failed> {
    let mut r = outline_scene(magenta(|_| {}), true)?;
    let camera = camera(&mut r)?;
    r.app.world_mut().entity_mut(camera).insert(Msaa::Sample4);
    let mut first_on = None;
    for (step, enabled) in [true, false, true, false, true].into_iter().enumerate() {
        edit_outline(&mut r, |o| o.enabled = enabled);
        let frame = r.capture()?;
        save(&frame, &format!("outline_toggle_{step}"))?;
        let ink = ink_count(&frame);
        let entity = r.app.world().entity(camera);
        let prepasses = entity.contains::<DepthPrepass>() && entity.contains::<NormalPrepass>();
        let none = !entity.contains::<DepthPrepass>() && !entity.contains::<NormalPrepass>();
        eprintln!("step {step}: enabled {enabled}, {ink} ink pixels");
        if enabled {
            let first = *first_on.get_or_insert(ink);
            if ink < 500 || ink.abs_diff(first) > first / 20 {
                return Err(
                    format!("step {step}: on, but {ink} ink pixels (first: {first})").into(),
                );
            }
            if !prepasses {
                return Err(format!("step {step}: on, but the prepasses are missing").into());
            }
        } else {
            if ink != 0 {
                return Err(format!("step {step}: off, but {ink} ink pixels").into());
            }
            if !none {
                return Err(format!("step {step}: off, but prepasses are still on").into());
            }
        }
    }
    Ok(())
}

/// Length of the first run of ink met walking from `(x, y)` by `(dx, dy)`.
fn ink_run(frame: &CapturedFrame, (mut x, mut y): (i32, i32), (dx, dy): (i32, i32)) -> u32 {
    let inside =
        |x: i32, y: i32| x >= 0 && y >= 0 && x < frame.width as i32 && y < frame.height as i32;
    while inside(x, y) && !is_ink(frame.pixel(x as u32, y as u32)) {
        (x, y) = (x + dx, y + dy);
    }
    let mut run = 0;
    while inside(x, y) && is_ink(frame.pixel(x as u32, y as u32)) {
        run += 1;
        (x, y) = (x + dx, y + dy);
    }
    run
}

/// Thicker dilation draws wider ink, each axis on its own: the strand's horizontal top edge widens
/// with Y Dilation, its vertical left end with X Dilation.
fn wider_dilation_draws_wider_ink() -> Result<(), Failed> {
    let mut r = outline_scene(magenta(|_| {}), false)?;
    let mut results = Vec::new();
    for (dx, dy) in [(1, 1), (3, 3), (3, 0), (0, 3)] {
        edit_outline(&mut r, |o| (o.dilation_x, o.dilation_y) = (dx, dy));
        let frame = r.capture()?;
        save(&frame, &format!("outline_dilation_{dx}_{dy}"))?;
        let (w, h) = (frame.width as i32, frame.height as i32);
        // Down the centre column onto the top edge; along the centre row onto the left end.
        let vertical = ink_run(&frame, (w / 2, 0), (0, 1));
        let horizontal = ink_run(&frame, (0, h / 2), (1, 0));
        let ink = ink_count(&frame);
        eprintln!(
            "dilation ({dx}, {dy}): {ink} ink pixels, top edge {vertical} px, left end {horizontal} px"
        );
        results.push((ink, vertical, horizontal));
    }
    let [(ink1, v1, h1), (ink3, v3, h3), (_, v_x, h_x), (_, v_y, h_y)] = results[..] else {
        unreachable!()
    };
    let fail = |m: String| -> Result<(), Failed> { Err(format!("{m}: {results:?}").into()) };
    if ink3 as f32 <= 1.5 * ink1 as f32 || v3 < v1 + 3 || h3 < h1 + 3 {
        return fail("dilation 3 is not wider than 1".into());
    }
    // Each extra pixel of dilation widens the line by two (one each side).
    if v_y < v_x + 4 || h_x < h_y + 4 {
        return fail("X and Y dilation do not widen their own axis".into());
    }
    Ok(())
}

/// The hair material draws into both prepasses: with edges from depth alone, and from normals
/// alone, the strand's silhouette is still inked all round.
fn hair_is_in_depth_and_normal_prepasses() -> Result<(), Failed> {
    let mut r = outline_scene(magenta(|o| o.enabled = false), false)?;
    let reference = r.capture()?;
    for source in [OutlineSource::Depth, OutlineSource::Normals] {
        edit_outline(&mut r, |o| {
            o.enabled = true;
            o.source = source;
        });
        let frame = r.capture()?;
        save(&frame, &format!("outline_source_{source:?}"))?;
        let camera = camera(&mut r)?;
        let camera = r.app.world().entity(camera);
        if camera.contains::<DepthPrepass>() != source.uses_depth()
            || camera.contains::<NormalPrepass>() != source.uses_normals()
        {
            return Err(format!("{source:?}: the camera's prepasses do not match").into());
        }
        let stats = ink_stats(&reference, &frame);
        eprintln!("{source:?}: {stats:?}");
        check_silhouette_ink(&stats, 4, &format!("{source:?}"))?;
    }
    Ok(())
}

/// Orange toon hair, not the grey box, the black background or magenta ink.
fn is_hair(p: [u8; 4]) -> bool {
    i32::from(p[0]) - i32::from(p[2]) > 40 && !is_ink(p)
}

/// Ink on the edge of the hair and inside it: (fraction of the hair's edge pixels with ink within
/// 1 px, fraction of the pixels deeper than [`INTERIOR`] inside the hair that are ink).
fn hair_ink(reference: &CapturedFrame, outlined: &CapturedFrame) -> (f32, f32, usize) {
    let (_, dist) = distance_from_edge(reference, is_hair);
    let (w, h) = (outlined.width as i32, outlined.height as i32);
    let ink_at = |x: i32, y: i32| {
        x >= 0 && y >= 0 && x < w && y < h && is_ink(outlined.pixel(x as u32, y as u32))
    };
    let (mut edge, mut edge_inked, mut inside, mut inside_ink) = (0, 0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            match dist[(y * w + x) as usize] {
                0 => {
                    edge += 1;
                    if (-1..=1).any(|dy| (-1..=1).any(|dx| ink_at(x + dx, y + dy))) {
                        edge_inked += 1;
                    }
                }
                d if d != u32::MAX && d > INTERIOR => {
                    inside += 1;
                    inside_ink += usize::from(ink_at(x, y));
                }
                _ => {}
            }
        }
    }
    (
        edge_inked as f32 / f32::max(edge as f32, 1.0),
        inside_ink as f32 / f32::max(inside as f32, 1.0),
        inside,
    )
}

/// A mass of seven overlapping strands lying on a grey box (a head): the default outline
/// ([`OutlineSource::Mass`]) inks nearly all of the mass's edge, the edge against the box
/// included although the depth barely steps there, and almost nothing inside it; Sobel on depth
/// and normals inks the strands inside; depth alone misses the edge against the box; inner
/// lines come back with `inner_threshold`.
fn mass_outline_inks_the_hair_not_its_strands() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.3, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
    let ramp = ramps(&r).three_tone;
    for i in 0..7 {
        let y = -0.55 + 0.17 * i as f32;
        let z = if i % 2 == 0 { 0.0 } else { -0.04 };
        spawn_strand(
            &mut r,
            Vec3::new(-0.9, y, z),
            Vec3::new(0.9, y + 0.1, z),
            0.12,
            ToonHairMaterial {
                ramp: ramp.clone(),
                ..default()
            },
        );
    }
    let world = r.app.world_mut();
    let mesh = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(2.6, 0.7, 0.2).mesh());
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(Color::srgb(0.6, 0.6, 0.6));
    // Its front face 0.04 behind the back strands: a depth step of 1.03x at 3 m.
    world.spawn((
        Mesh3d(mesh),
        MeshMaterial3d(material),
        Transform::from_xyz(0.0, 0.45, -0.26),
    ));
    let camera = camera(&mut r)?;
    r.app
        .world_mut()
        .entity_mut(camera)
        .insert(magenta(|o| o.enabled = false));
    let reference = r.capture()?;
    save(&reference, "outline_mass_reference")?;
    let hair = reference.count(is_hair);
    if hair < 5000 {
        return Err(format!("only {hair} hair pixels").into());
    }
    let mut measured = Vec::new();
    for (source, inner) in [
        (OutlineSource::Mass, None),
        (OutlineSource::DepthAndNormals, None),
        (OutlineSource::Depth, None),
        (OutlineSource::Mass, Some(0.3)),
    ] {
        edit_outline(&mut r, |o| {
            o.enabled = true;
            o.source = source;
            o.inner_threshold = inner;
        });
        let frame = r.capture()?;
        save(
            &frame,
            &format!("outline_mass_{source:?}_{}", inner.unwrap_or(0.0)),
        )?;
        let (edge, inside, n) = hair_ink(&reference, &frame);
        eprintln!(
            "{source:?} inner {inner:?}: {:.1}% of the hair's edge inked, {:.1}% of {n} inside pixels ink",
            edge * 100.0,
            inside * 100.0
        );
        measured.push((edge, inside));
    }
    let [mass, depth_normals, depth, inner] = measured[..] else {
        unreachable!()
    };
    let fail = |m: &str| -> Result<(), Failed> { Err(format!("{m}: {measured:?}").into()) };
    if mass.0 < 0.9 || mass.1 > 0.05 {
        return fail("the mass outline does not ink the edge and spare the inside");
    }
    if depth_normals.1 < 2.0 * mass.1 + 0.02 {
        return fail("depth and normals should ink the strands inside the mass");
    }
    if depth.0 > mass.0 - 0.10 {
        return fail("depth alone should miss the edge against the box");
    }
    if inner.1 < mass.1 + 0.05 || inner.0 < mass.0 - 0.02 {
        return fail("inner lines did not come back with inner_threshold");
    }
    Ok(())
}

/// The outer edge of the top outline in column `x`, in pixels from the top: the background
/// pixels above it count whole, the ink's partly covered pixels by the share not inked (the ink
/// is magenta over black, so its blue channel is its coverage). `None` if no full ink is met.
fn top_ink_edge(frame: &CapturedFrame, x: u32) -> Option<f32> {
    let mut edge = 0.0;
    for y in 0..frame.height {
        let coverage = f32::from(frame.pixel(x, y)[2]) / 255.0;
        if coverage >= 0.95 {
            return Some(edge);
        }
        edge += 1.0 - coverage;
    }
    None
}

/// Root mean square distance of the points `(x, edge)` from their least-squares line.
fn line_residual(points: &[(f32, f32)]) -> f32 {
    let n = points.len() as f32;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    let slope = sxy / sxx;
    let sum: f32 = points
        .iter()
        .map(|(x, y)| (y - (my + slope * (x - mx))).powi(2))
        .sum();
    (sum / n).sqrt()
}

/// With MSAA the outline's ink covers each pixel by the share of its samples that are inked, so
/// a slanted edge runs straight instead of in stair steps: on a strand tilted by about 7 degrees,
/// the top outline's edge (read with sub-pixel coverage) lies closer to a straight line than
/// without MSAA, and the ink has partly covered pixels.
fn outline_is_anti_aliased_with_msaa() -> Result<(), Failed> {
    let mut residuals = Vec::new();
    for msaa in [Msaa::Off, Msaa::Sample4] {
        let mut r = scene(Vec3::new(0.0, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
        let ramp = ramps(&r).three_tone;
        spawn_strand(
            &mut r,
            Vec3::new(-1.0, -0.12, 0.0),
            Vec3::new(1.0, 0.12, 0.0),
            0.3,
            ToonHairMaterial { ramp, ..default() },
        );
        let camera = camera(&mut r)?;
        r.app
            .world_mut()
            .entity_mut(camera)
            .insert((magenta(|_| {}), msaa));
        let frame = r.capture()?;
        save(&frame, &format!("outline_aa_{msaa:?}"))?;
        let (w, _) = (frame.width, frame.height);
        let points: Vec<(f32, f32)> = (w / 4..w * 3 / 4)
            .filter_map(|x| top_ink_edge(&frame, x).map(|e| (x as f32, e)))
            .collect();
        let partial = frame.count(|p| p[0] == p[2] && p[1] < 15 && p[2] > 20 && p[2] < 235);
        let residual = line_residual(&points);
        eprintln!(
            "{msaa:?}: {} columns, edge residual {residual:.3} px, {partial} partly inked pixels",
            points.len()
        );
        if points.len() < (w / 2 - 4) as usize {
            return Err(format!(
                "{msaa:?}: the top outline was found in {} columns",
                points.len()
            )
            .into());
        }
        residuals.push((residual, partial));
    }
    let [(hard, hard_partial), (smooth, smooth_partial)] = residuals[..] else {
        unreachable!()
    };
    if hard_partial != 0 {
        return Err(format!("without MSAA {hard_partial} ink pixels are partly covered").into());
    }
    if smooth_partial < 20 || smooth > 0.6 * hard {
        return Err(format!(
            "with MSAA the edge is off a straight line by {smooth:.3} px (without: {hard:.3}), \
             {smooth_partial} partly inked pixels"
        )
        .into());
    }
    Ok(())
}

/// Five locks hanging side by side, each narrowing from 12 px to a point, with the default mass
/// outline (dilation 1): in the rows where a lock is 3 to 6 px wide, the lock keeps pixels of its
/// own colour inside its inked edge (the dilation would fill it: a solid sliver), and ink lies
/// within 2 px outside it on both sides (the line follows the point).
fn outline_runs_around_thin_tips_without_filling_them() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.3, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
    let ramp = ramps(&r).three_tone;
    let locks = (0..5)
        .map(|i| {
            let x = -0.6 + 0.3 * i as f32;
            (0..6)
                .map(|k| Vec3::new(x, 0.9 - 0.36 * k as f32, 0.0))
                .collect()
        })
        .collect();
    spawn_still_hair(
        r.app.world_mut(),
        locks,
        ToonHairMaterial { ramp, ..default() },
        HairMeshSettings {
            radius: 0.06,
            taper: QuadraticCurve::new(0.0, -1.0, 1.0),
            hair_resolution: 24,
            shape_resolution: 16,
            mass_normals: 0.0,
            ..default()
        },
    );
    let camera = camera(&mut r)?;
    r.app
        .world_mut()
        .entity_mut(camera)
        .insert(magenta(|o| o.enabled = false));
    let reference = r.capture()?;
    edit_outline(&mut r, |o| o.enabled = true);
    let outlined = r.capture()?;
    save(&reference, "outline_tips_reference")?;
    save(&outlined, "outline_tips")?;
    let (w, h) = (reference.width as i32, reference.height as i32);
    let hair_at = |x: i32, y: i32| x >= 0 && x < w && is_hair(reference.pixel(x as u32, y as u32));
    let ink_at = |x: i32, y: i32| x >= 0 && x < w && is_ink(outlined.pixel(x as u32, y as u32));
    let (mut rows, mut cored, mut lined) = (0, 0, 0);
    for y in 0..h {
        let mut x = 0;
        while x < w {
            if !hair_at(x, y) {
                x += 1;
                continue;
            }
            let start = x;
            while x < w && hair_at(x, y) {
                x += 1;
            }
            let (first, last) = (start, x - 1);
            if !(3..=6).contains(&(x - start)) || first == 0 || x >= w {
                continue;
            }
            rows += 1;
            if (first..=last).any(|c| is_hair(outlined.pixel(c as u32, y as u32))) {
                cored += 1;
            }
            let left = (first - 2..first).any(|c| ink_at(c, y));
            let right = (last + 1..=last + 2).any(|c| ink_at(c, y));
            if left && right {
                lined += 1;
            }
        }
    }
    eprintln!(
        "thin tips: {rows} lock rows 3-6 px wide; {cored} keep their colour inside the ink, \
         {lined} have ink outside on both sides"
    );
    if rows < 40 {
        return Err(format!("only {rows} rows where a lock is 3-6 px wide").into());
    }
    if cored * 10 < rows * 8 || lined * 10 < rows * 8 {
        return Err(format!(
            "of {rows} thin rows, {cored} keep the lock's colour and {lined} are lined outside"
        )
        .into());
    }
    Ok(())
}
