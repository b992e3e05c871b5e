//! A character's own hair mesh in the toon look (`ToonHairMeshes`), on a square sheet: modelled
//! as a single sheet (its glTF material double-sided) it is drawn from both sides, each lit as
//! the side it shows; painted (a base colour texture) it keeps its paint under the ramp.

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{ToonHairMeshes, ToonHairMeshesApplied};
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
];

/// A 1 m square sheet facing `+z` in `gltf` (its material as a glTF file gives it), dressed by
/// a `ToonHairMeshes` (with `material`, or the default), seen from `side` (+1 in front, -1
/// behind) at 3 m with the light over the viewer's shoulder.
fn sheet_view(
    side: f32,
    gltf: impl FnOnce(&mut World) -> StandardMaterial,
    material: Option<ToonHairMaterial>,
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
    if let Some(mut m) = material {
        m.ramp = world.resource::<ToonRamps>().three_tone.clone();
        dress = dress.with_material(world.resource_mut::<Assets<ToonHairMaterial>>().add(m));
    }
    let root = world
        .spawn((Transform::default(), Visibility::default(), dress))
        .id();
    world.spawn((
        Name::new("hair"),
        Mesh3d(sheet),
        MeshMaterial3d(gltf_material),
        Transform::default(),
        ChildOf(root),
    ));
    r.warm_up(|world| {
        let mut dressed = world.query::<&ToonHairMeshesApplied>();
        dressed.iter(world).any(|d| !d.0.is_empty())
    })?;
    Ok(r.capture()?)
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
/// side both times. With a material of the user's that is not double-sided, its back is not
/// drawn at all (and a warning says so).
fn a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind() -> Result<(), Failed> {
    let sides = |_: &mut World| StandardMaterial {
        base_color: Color::srgb(0.95, 0.55, 0.15),
        double_sided: true,
        cull_mode: None,
        ..default()
    };
    let front = sheet_view(1.0, sides, None)?;
    let back = sheet_view(-1.0, sides, None)?;
    let single = sheet_view(-1.0, sides, Some(ToonHairMaterial::default()))?;
    save(&front, "double_sided_front")?;
    save(&back, "double_sided_back")?;
    save(&single, "double_sided_back_single_sided_material")?;
    let (front, back, single) = (drawn(&front), drawn(&back), drawn(&single));
    eprintln!(
        "sheet pixels (count, mean luma): front {front:?}, behind {back:?}, behind with a \
         single-sided material {single:?}"
    );
    let alike = front.0 > 1_000
        && back.0.abs_diff(front.0) * 50 < front.0
        && (back.1 - front.1).abs() < 0.05 * front.1;
    if !alike || single.0 != 0 {
        return Err(
            format!("front {front:?}, behind {back:?}, behind single-sided {single:?}").into(),
        );
    }
    Ok(())
}

/// A sheet painted red on its left half and blue on its right (a 4 x 1 texture, its glTF base
/// colour white), dressed with the default material: under the toon ramp the left quarter of
/// its pixels stays red (red over twice blue) and the right quarter blue (blue over twice red).
/// The default material before took no texture: one colour all over.
fn a_painted_sheet_keeps_its_paint_under_the_toon_ramp() -> Result<(), Failed> {
    let red = [230u8, 40, 30, 255];
    let blue = [30u8, 60, 230, 255];
    let paint = Image::new(
        Extent3d {
            width: 4,
            height: 1,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        [red, red, blue, blue].concat(),
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    );
    let frame = sheet_view(
        1.0,
        |world| StandardMaterial {
            base_color_texture: Some(world.resource_mut::<Assets<Image>>().add(paint)),
            ..default()
        },
        None,
    )?;
    save(&frame, "painted_sheet")?;
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
    let (left, right) = (
        share(lo..lo + quarter, true),
        share(hi + 1 - quarter..hi + 1, false),
    );
    eprintln!("painted sheet: red in its left quarter {left:?}, blue in its right {right:?}");
    if sheet.len() < 1_000 || left.0 * 10 < left.1 * 9 || right.0 * 10 < right.1 * 9 {
        return Err(format!("red on the left {left:?}, blue on the right {right:?}").into());
    }
    Ok(())
}
