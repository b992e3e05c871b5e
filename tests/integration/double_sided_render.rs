//! A character's hair modelled as single sheets (its glTF material double-sided) in the toon
//! look: `ToonHairMeshes` draws such a mesh from both sides, each lit as the side it shows.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{ToonHairMeshes, ToonHairMeshesApplied};
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind",
    a_double_sided_sheet_of_hair_shows_and_is_lit_from_behind,
)];

/// A 1 m square sheet facing `+z` (its glTF-like material double-sided), dressed by a
/// `ToonHairMeshes` (with `material`, or the default), seen from `side` (+1 in front, -1
/// behind) at 3 m with the light over the viewer's shoulder.
fn sheet_view(side: f32, material: Option<ToonHairMaterial>) -> Result<CapturedFrame, Failed> {
    let eye = Vec3::new(0.0, 0.0, 3.0 * side);
    let mut r = scene(Vec3::new(0.8, 1.5, 3.0 * side), eye)?;
    let world = r.app.world_mut();
    let sheet = world
        .resource_mut::<Assets<Mesh>>()
        .add(Rectangle::new(1.0, 1.0));
    let gltf_material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            double_sided: true,
            cull_mode: None,
            ..default()
        });
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
    let front = sheet_view(1.0, None)?;
    let back = sheet_view(-1.0, None)?;
    let single = sheet_view(-1.0, Some(ToonHairMaterial::default()))?;
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
