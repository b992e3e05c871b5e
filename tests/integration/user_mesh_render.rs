//! A character's own hair mesh in the toon look (`ToonHairMeshes`), on a square sheet: modelled
//! as a single sheet (its glTF material double-sided) it is drawn from both sides, each lit as
//! the side it shows; painted (a base colour texture) it keeps its paint under the ramp; cut out
//! (its glTF material's alpha mask) it leaves holes in its colour, its depth and its shadow.

use bevy::asset::RenderAssetUsages;
use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{HairPaint, ToonHairMeshes, ToonHairMeshesApplied};
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind",
        a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind,
    ),
    (
        "a_painted_sheet_keeps_its_paint_under_the_toon_ramp",
        a_painted_sheet_keeps_its_paint_under_the_toon_ramp,
    ),
    (
        "a_cut_out_card_leaves_holes_in_its_colour_depth_and_shadow",
        a_cut_out_card_leaves_holes_in_its_colour_depth_and_shadow,
    ),
    (
        "a_cut_out_cards_cut_edge_is_anti_aliased_under_msaa",
        a_cut_out_cards_cut_edge_is_anti_aliased_under_msaa,
    ),
];

/// A 1 m square sheet facing `+z` in `gltf` (its material as a glTF file gives it), dressed by
/// a `ToonHairMeshes` (with `material` in its paint, or the default), seen from `side` (+1 in
/// front, -1 behind) at 3 m with the light over the viewer's shoulder.
fn sheet_view(
    side: f32,
    gltf: impl FnOnce(&mut World) -> StandardMaterial,
    material: Option<(ToonHairMaterial, HairPaint)>,
) -> Result<CapturedFrame, Failed> {
    let eye = Vec3::new(0.0, 0.0, 3.0 * side);
    let mut r = scene(Vec3::new(0.8, 1.5, 3.0 * side), eye)?;
    let world = r.app.world_mut();
    let sheet = world
        .resource_mut::<Assets<Mesh>>()
        .add(Rectangle::new(1.0, 1.0));
    let gltf = gltf(world);
    let gltf_material = world.resource_mut::<Assets<StandardMaterial>>().add(gltf);
    let mut dress = ToonHairMeshes::matching(|n| n == "hair");
    if let Some((mut m, paint)) = material {
        m.ramp = world.resource::<ToonRamps>().three_tone.clone();
        dress = dress
            .with_material(world.resource_mut::<Assets<ToonHairMaterial>>().add(m))
            .with_paint(paint);
    }
    dress_and_capture(r, sheet, gltf_material, dress)
}

/// A character of one mesh called "hair" at the origin, in `gltf` (its glTF material), under a
/// root that `dress`es it; captured once it is dressed.
fn dress_and_capture(
    mut r: HeadlessRenderer,
    mesh: Handle<Mesh>,
    gltf: Handle<StandardMaterial>,
    dress: ToonHairMeshes,
) -> Result<CapturedFrame, Failed> {
    let world = r.app.world_mut();
    let root = world
        .spawn((Transform::default(), Visibility::default(), dress))
        .id();
    world.spawn((
        Name::new("hair"),
        Mesh3d(mesh),
        MeshMaterial3d(gltf),
        Transform::default(),
        ChildOf(root),
    ));
    r.warm_up(|world| {
        let mut dressed = world.query::<&ToonHairMeshesApplied>();
        dressed.iter(world).any(|d| !d.0.is_empty())
    })?;
    Ok(r.capture()?)
}

/// A 4 x 1 sRGB texture: `left` on its left half, `right` on its right.
fn halves(left: [u8; 4], right: [u8; 4]) -> Image {
    Image::new(
        Extent3d {
            width: 4,
            height: 1,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        [left, left, right, right].concat(),
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    )
}

/// The drawn pixels of `frame` and their mean luma.
fn drawn(frame: &CapturedFrame) -> (usize, f32) {
    let mut n = 0;
    let mut sum = 0.0;
    for y in 0..frame.height {
        for x in 0..frame.width {
            let p = frame.pixel(x, y);
            if p != BACKGROUND {
                n += 1;
                sum +=
                    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]);
            }
        }
    }
    (n, if n > 0 { sum / n as f32 } else { 0.0 })
}

/// With the default material, a sheet whose glTF material is double-sided is drawn from behind
/// as from the front: as many pixels, in the same (lit) tone, the light being on the viewer's
/// side both times; so it is with a material of the user's, which keeps the glTF material's
/// sides. With the user's material as it is (`HairPaint::Material`), not double-sided, its back
/// is not drawn at all (and a warning says so).
fn a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind() -> Result<(), Failed> {
    let sides = |_: &mut World| StandardMaterial {
        base_color: Color::srgb(0.95, 0.55, 0.15),
        double_sided: true,
        cull_mode: None,
        ..default()
    };
    let front = sheet_view(1.0, sides, None)?;
    let back = sheet_view(-1.0, sides, None)?;
    let look = sheet_view(
        -1.0,
        sides,
        Some((ToonHairMaterial::default(), HairPaint::Gltf)),
    )?;
    let single = sheet_view(
        -1.0,
        sides,
        Some((ToonHairMaterial::default(), HairPaint::Material)),
    )?;
    save(&front, "double_sided_front")?;
    save(&back, "double_sided_back")?;
    save(&single, "double_sided_back_single_sided_material")?;
    let (front, back, look, single) = (drawn(&front), drawn(&back), drawn(&look), drawn(&single));
    eprintln!(
        "sheet pixels (count, mean luma): front {front:?}, behind {back:?}, behind with a look \
         of the user's {look:?}, behind with a single-sided material as it is {single:?}"
    );
    let alike = |back: (usize, f32)| {
        front.0 > 1_000
            && back.0.abs_diff(front.0) * 50 < front.0
            && (back.1 - front.1).abs() < 0.05 * front.1
    };
    if !alike(back) || !alike(look) || single.0 != 0 {
        return Err(format!(
            "front {front:?}, behind {back:?}, look {look:?}, behind single-sided {single:?}"
        )
        .into());
    }
    Ok(())
}

/// A sheet painted red on its left half and blue on its right (a 4 x 1 texture, its glTF base
/// colour white), dressed with the default material: under the toon ramp the left quarter of
/// its pixels stays red (red over twice blue) and the right quarter blue (blue over twice red).
/// So it does under a green look of the user's, which keeps the glTF material's paint; with the
/// look as it is (`HairPaint::Material`) the sheet is green. The default material before took
/// no texture: one colour all over.
fn a_painted_sheet_keeps_its_paint_under_the_toon_ramp() -> Result<(), Failed> {
    let paint = halves([230, 40, 30, 255], [30, 60, 230, 255]);
    let gltf = |world: &mut World| StandardMaterial {
        base_color_texture: Some(world.resource_mut::<Assets<Image>>().add(paint.clone())),
        ..default()
    };
    let green = ToonHairMaterial {
        shading: ToonShading {
            base_color: Color::srgb(0.1, 0.8, 0.1),
            ..default()
        },
        ..default()
    };
    let mut quarters = Vec::new();
    for (name, material) in [
        ("painted_sheet", None),
        (
            "painted_sheet_under_a_look",
            Some((green.clone(), HairPaint::Gltf)),
        ),
        (
            "painted_sheet_recoloured",
            Some((green, HairPaint::Material)),
        ),
    ] {
        let frame = sheet_view(1.0, gltf, material)?;
        save(&frame, name)?;
        quarters.push(paint_quarters(&frame));
    }
    eprintln!(
        "painted sheet, (red in its left quarter, blue in its right) of (pixels): default \
         material {:?}, a look of the user's {:?}, the look as it is {:?}",
        quarters[0], quarters[1], quarters[2]
    );
    let kept = |((red, n), (blue, m)): ((usize, usize), (usize, usize))| {
        n >= 1_000 && red * 10 >= n * 9 && blue * 10 >= m * 9
    };
    let ((red, _), (blue, _)) = quarters[2];
    if !kept(quarters[0]) || !kept(quarters[1]) || red + blue > 0 {
        return Err(format!("{quarters:?}").into());
    }
    Ok(())
}

/// Of a painted sheet's pixels: (red, all) in its left quarter and (blue, all) in its right.
fn paint_quarters(frame: &CapturedFrame) -> ((usize, usize), (usize, usize)) {
    let mut sheet: Vec<(u32, u32)> = Vec::new();
    for y in 0..frame.height {
        for x in 0..frame.width {
            if frame.pixel(x, y) != BACKGROUND {
                sheet.push((x, y));
            }
        }
    }
    let (lo, hi) = sheet
        .iter()
        .fold((u32::MAX, 0), |(lo, hi), &(x, _)| (lo.min(x), hi.max(x)));
    let quarter = (hi - lo + 1) / 4;
    let share = |cols: std::ops::Range<u32>, red_side: bool| {
        let inside: Vec<_> = sheet.iter().filter(|(x, _)| cols.contains(x)).collect();
        let painted = inside
            .iter()
            .filter(|&&&(x, y)| {
                let [r, _, b, _] = frame.pixel(x, y);
                let (r, b) = (u32::from(r), u32::from(b));
                if red_side { r > 2 * b } else { b > 2 * r }
            })
            .count();
        (painted, inside.len())
    };
    (
        share(lo..lo + quarter, true),
        share(hi + 1 - quarter..hi + 1, false),
    )
}

/// A 1 m hair card at the origin facing the camera (3 m away, with depth and normal prepasses),
/// painted red on its left half and transparent (alpha 0, red too) on its right, its glTF
/// material cut out at `mask` (opaque with `None`); a grey wall 0.5 m behind it, and a sun just
/// above the camera casting shadows, so the card's shadow falls on the wall right behind it,
/// a little lower.
fn card_view(mask: Option<f32>) -> Result<CapturedFrame, Failed> {
    card_view_with(mask, Msaa::Off, 0.0, None)
}

/// [`card_view`] with the camera's `msaa`, the card turned by `tilt` radians in its plane, and
/// a mass outline in `ink` if given.
fn card_view_with(
    mask: Option<f32>,
    msaa: Msaa,
    tilt: f32,
    ink: Option<Color>,
) -> Result<CapturedFrame, Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, 0.0, 3.0))?;
    let world = r.app.world_mut();
    let mut sun = world.query::<&mut DirectionalLight>();
    for mut light in sun.iter_mut(world) {
        light.shadow_maps_enabled = true;
        light.illuminance = 3_000.0;
    }
    let mut cameras = world.query_filtered::<Entity, With<Camera3d>>();
    for camera in cameras.iter(world).collect::<Vec<_>>() {
        world
            .entity_mut(camera)
            .insert((DepthPrepass, NormalPrepass, msaa));
        if let Some(color) = ink {
            world
                .entity_mut(camera)
                .insert(ImageSpaceOutline { color, ..default() });
        }
    }
    let wall = world
        .resource_mut::<Assets<Mesh>>()
        .add(Rectangle::new(4.0, 4.0));
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::srgb(0.6, 0.6, 0.6),
            perceptual_roughness: 1.0,
            ..default()
        });
    world.spawn((
        Mesh3d(wall),
        MeshMaterial3d(grey),
        Transform::from_xyz(0.0, 0.0, -0.5),
    ));
    let paint = halves([230, 40, 30, 255], [230, 40, 30, 0]);
    let paint = world.resource_mut::<Assets<Image>>().add(paint);
    let gltf = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color_texture: Some(paint),
            alpha_mode: mask.map_or(AlphaMode::Opaque, AlphaMode::Mask),
            ..default()
        });
    let card = world
        .resource_mut::<Assets<Mesh>>()
        .add(Mesh::from(Rectangle::new(1.0, 1.0)).rotated_by(Quat::from_rotation_z(tilt)));
    dress_and_capture(r, card, gltf, ToonHairMeshes::matching(|n| n == "hair"))
}

/// The card's red pixels and their bounds `(x0, y0, x1, y1)`, inclusive.
fn red_pixels(frame: &CapturedFrame) -> (usize, [u32; 4]) {
    let mut n = 0;
    let mut b = [u32::MAX, u32::MAX, 0, 0];
    for y in 0..frame.height {
        for x in 0..frame.width {
            let [r, g, bl, _] = frame.pixel(x, y).map(u32::from);
            if r > 2 * g && r > 2 * bl && r > 40 {
                n += 1;
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
        }
    }
    (n, b)
}

/// Red pixels and mean luma in the box `[x0, x1) x [y0, y1)`.
fn region(frame: &CapturedFrame, [x0, y0, x1, y1]: [u32; 4]) -> (usize, f32) {
    let (mut red, mut sum, mut n) = (0, 0.0, 0);
    for y in y0..y1 {
        for x in x0..x1 {
            let [r, g, b, _] = frame.pixel(x, y).map(u32::from);
            red += usize::from(r > 2 * g && r > 2 * b && r > 40);
            sum += 0.2126 * r as f32 + 0.7152 * g as f32 + 0.0722 * b as f32;
            n += 1;
        }
    }
    (red, sum / n.max(1) as f32)
}

/// A hair card cut out by its glTF material's alpha (`MASK`), dressed with the default
/// material: its transparent right half is not drawn, and through it the wall shows lit, as
/// bright as the wall beside the card. So the cut reaches the colour, the depth prepass (a
/// prepass depth there would hide the wall) and the shadow map (the card's right half would
/// shade the wall behind it). Drawn opaque, the right half is red.
fn a_cut_out_card_leaves_holes_in_its_colour_depth_and_shadow() -> Result<(), Failed> {
    let solid = card_view(None)?;
    let cut = card_view(Some(0.5))?;
    save(&solid, "cut_out_card_opaque")?;
    save(&cut, "cut_out_card")?;
    let (whole, [x0, y0, x1, y1]) = red_pixels(&solid);
    if whole < 1_000 {
        return Err(format!("the opaque card drew {whole} red pixels").into());
    }
    let (w, h) = (x1 + 1 - x0, y1 + 1 - y0);
    // The card's right quarter, its middle half of rows; the same box just right of the card.
    let hole = [x1 + 1 - w / 4, y0 + h / 4, x1 + 1, y1 + 1 - h / 4];
    let beside = [x1 + 1 + w / 8, hole[1], x1 + 1 + w / 8 + w / 4, hole[3]];
    let left = [x0, hole[1], x0 + w / 4, hole[3]];
    let (solid_hole, cut_hole, cut_beside, cut_left) = (
        region(&solid, hole),
        region(&cut, hole),
        region(&cut, beside),
        region(&cut, left),
    );
    let area = (w / 4 * (hole[3] - hole[1])) as usize;
    eprintln!(
        "cut-out card ({w} x {h} px): right quarter opaque {solid_hole:?}, cut {cut_hole:?}; \
         the wall beside it {cut_beside:?}; the left quarter cut {cut_left:?} (red, mean luma; \
         {area} px a box)"
    );
    let shows_wall = cut_hole.0 == 0
        && cut_beside.1 > 20.0
        && (cut_hole.1 - cut_beside.1).abs() < 0.1 * cut_beside.1;
    if solid_hole.0 * 10 < area * 9 || cut_left.0 * 10 < area * 9 || !shows_wall {
        return Err(format!(
            "right quarter opaque {solid_hole:?}, cut {cut_hole:?}; beside {cut_beside:?}; \
             left quarter cut {cut_left:?} of {area}"
        )
        .into());
    }
    Ok(())
}

/// The cut-out card of [`card_view`] turned 0.3 rad in its plane, so its cut edge (the right
/// edge of its red half) runs slanted across the pixels. Under MSAA (4 samples) the cut edge is
/// anti-aliased by alpha to coverage: along it, pixels neither the card's red nor the wall's
/// grey (within 6 of 255), at least one every second row. Without MSAA none: every pixel is
/// the card or the wall (a stair-stepped edge). Counted in the middle half of the red half's
/// rows, from its middle column to past the cut edge, where the card's own edges (anti-aliased
/// by MSAA whatever the material) do not reach. Outlined under MSAA, the card has its mass
/// outline (read from the prepass, which must still draw it).
fn a_cut_out_cards_cut_edge_is_anti_aliased_under_msaa() -> Result<(), Failed> {
    let mut counts = Vec::new();
    for (name, msaa) in [
        ("cut_edge_msaa", Msaa::Sample4),
        ("cut_edge_no_msaa", Msaa::Off),
    ] {
        let frame = card_view_with(Some(0.5), msaa, 0.3, None)?;
        save(&frame, name)?;
        let (red, [x0, y0, x1, y1]) = red_pixels(&frame);
        let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
        let middle = x0 + w / 2;
        // The card's and the wall's own colours: the most frequent of each in the region.
        let region: Vec<[i32; 3]> = (y0 + h / 4..y1.saturating_sub(h / 4))
            .flat_map(|y| (middle..x1 + 5).map(move |x| (x, y)))
            .map(|(x, y)| {
                let [r, g, b, _] = frame.pixel(x, y).map(i32::from);
                [r, g, b]
            })
            .collect();
        let mode = |keep: &dyn Fn(&[i32; 3]) -> bool| {
            let mut counts: Vec<([i32; 3], usize)> = Vec::new();
            for p in region.iter().filter(|p| keep(p)) {
                match counts.iter_mut().find(|(c, _)| c == p) {
                    Some((_, n)) => *n += 1,
                    None => counts.push((*p, 1)),
                }
            }
            counts.into_iter().max_by_key(|(_, n)| *n).map(|(c, _)| c)
        };
        let card = mode(&|[r, g, b]| *r > 2 * g && *r > 2 * b).unwrap_or([255, 0, 0]);
        let wall = mode(&|[r, g, b]| (r - g).abs() < 12 && (g - b).abs() < 12).unwrap_or([0; 3]);
        let near = |p: &[i32; 3], c: [i32; 3]| (0..3).all(|k| (p[k] - c[k]).abs() <= 6);
        let rows = (y0 + h / 4..y1.saturating_sub(h / 4)).count();
        let blends = region
            .iter()
            .filter(|p| !near(p, card) && !near(p, wall))
            .count();
        counts.push((red, rows, blends));
    }
    eprintln!(
        "cut edge (card pixels, rows, blended pixels): MSAA {:?}, none {:?}",
        counts[0], counts[1]
    );
    let ((red_msaa, rows, blended), (red_off, _, hard)) = (counts[0], counts[1]);
    if red_msaa < 1_000 || red_off < 1_000 || blended * 2 < rows || hard > 0 {
        return Err(format!("MSAA {:?}, none {:?}", counts[0], counts[1]).into());
    }
    // The prepass still draws the card (it cuts at the cut-off, never by coverage, which would
    // take the hair mask in its alpha for coverage and draw nothing): its mass outline, read
    // from the prepass, is there under MSAA.
    let frame = card_view_with(
        Some(0.5),
        Msaa::Sample4,
        0.3,
        Some(Color::srgb(1.0, 0.0, 1.0)),
    )?;
    save(&frame, "cut_edge_msaa_outlined")?;
    let ink = frame.count(|[r, g, b, _]| r > 200 && g < 60 && b > 200);
    eprintln!("cut edge under MSAA, outlined: {ink} ink pixels");
    if ink < 200 {
        return Err(format!("{ink} ink pixels around the card: its prepass is not drawn").into());
    }
    Ok(())
}
