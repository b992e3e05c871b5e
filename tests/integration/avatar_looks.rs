//! The modelled-hair avatar (`assets/chain_hair/chain_hair.glb`, thick locks on bone chains) in
//! the shipped looks that ink a modelled mesh (the image-space outline: clean_anime and
//! anime_locks; thesis and sketch ink with strokes built from strands), from the front, the side
//! and the back, measured as the look suite measures the ninja.

use std::time::Duration;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{
    FringeShadow, FringeShadowMeshes, FringeShadowMeshesApplied, StrandUvs, ToonHairMeshes,
    ToonHairMeshesApplied, ToonRamps,
};
use libtest_mimic::Failed;

use crate::look_suite::{
    BOUNDARY_INKED_LEAST, LOCK_LINES_INSIDE_MOST, OUTLINE_INSIDE_MOST, mask_of, measure,
    set_material,
};
use crate::toon_render::save;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "the_avatar_in_the_outlined_looks_from_three_views",
        the_avatar_in_the_outlined_looks_from_three_views,
    ),
    (
        "mass_normals_shade_the_avatars_hair_as_one_shape",
        mass_normals_shade_the_avatars_hair_as_one_shape,
    ),
    (
        "a_ponytail_given_its_own_mass_shape_shades_as_its_own",
        a_ponytail_given_its_own_mass_shape_shades_as_its_own,
    ),
    (
        "height_uvs_colour_the_avatars_tips_from_the_top_down",
        height_uvs_colour_the_avatars_tips_from_the_top_down,
    ),
    (
        "the_avatars_modelled_locks_get_lines_between_them",
        the_avatars_modelled_locks_get_lines_between_them,
    ),
];

/// Each look: the avatar's hair mesh in the look's material, the camera with its outline; the
/// character turned to face the camera, its left and its back. In every view the hair covers
/// at least 1% of the frame and has no black pixel (NaN shading); from the front and the side
/// its tones differ (luma p90 - p10 at least 10); the outline inks at least 85% of the hair's
/// boundary and at most 2% of its inside (15% with lines between locks).
fn the_avatar_in_the_outlined_looks_from_three_views() -> Result<(), Failed> {
    let mut failures = Vec::new();
    for look_name in ["clean_anime", "anime_locks"] {
        let look = HairPreset::look(look_name).ok_or("a shipped look")??;
        let outline = look.outline.clone().ok_or("the look has no outline")?;
        let (mut r, character, handle, shipped) = avatar_scene(
            (320, 240),
            &look,
            Some(outline),
            ToonHairMeshes::matching(|n| n == "hair"),
        )?;
        let lock_lines = look
            .outline
            .as_ref()
            .is_some_and(|o| o.lock_lines.is_some());
        for (view, yaw) in [
            ("front", 0.0),
            ("side", std::f32::consts::FRAC_PI_2),
            ("back", std::f32::consts::PI),
        ] {
            let [mask, plain, inked] = three_captures(&mut r, character, yaw, &handle, &shipped)?;
            save(&inked, &format!("avatar_{look_name}_{view}"))?;
            let m = measure(&mask, &plain, &inked);
            eprintln!(
                "avatar {look_name} {view}: {} hair px, contrast {:.0}, {} black, boundary inked \
                 {:.0}%, inside inked {:.1}%",
                m.hair,
                m.contrast,
                m.black,
                100.0 * m.boundary_inked,
                100.0 * m.interior_inked
            );
            let inside_most = if lock_lines {
                LOCK_LINES_INSIDE_MOST
            } else {
                OUTLINE_INSIDE_MOST
            };
            if m.hair * 100 < 320 * 240
                || m.black > 0
                || (view != "back" && m.contrast < 10.0)
                || m.boundary_inked < BOUNDARY_INKED_LEAST
                || m.interior_inked > inside_most
            {
                failures.push(format!("{look_name} {view}: {m:?}"));
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("; ").into())
    }
}

/// The avatar in the anime_locks look (lines between locks) from the side and the back: with each
/// modelled piece of its hair a lock of its own (`locks_by_piece`), the lines ink more of the
/// hair's inside in each view than without (the mesh carries no lock ids of its own, so all its
/// locks are one and the inside takes no line), and no more than the look suite allows lines
/// between locks; the boundary stays inked.
fn the_avatars_modelled_locks_get_lines_between_them() -> Result<(), Failed> {
    let look = HairPreset::look("anime_locks").ok_or("a shipped look")??;
    let outline = look.outline.clone().ok_or("the look has no outline")?;
    if outline.lock_lines.is_none() {
        return Err("anime_locks draws no lines between locks".into());
    }
    let mut inside = Vec::new();
    for by_piece in [false, true] {
        let mut hair = ToonHairMeshes::matching(|n| n == "hair");
        if by_piece {
            hair = hair.with_locks_by_piece();
        }
        let (mut r, character, handle, shipped) =
            avatar_scene((320, 240), &look, Some(outline.clone()), hair)?;
        for (view, yaw) in [
            ("side", std::f32::consts::FRAC_PI_2),
            ("back", std::f32::consts::PI),
        ] {
            let captures = three_captures(&mut r, character, yaw, &handle, &shipped)?;
            save(
                &captures[2],
                &format!(
                    "avatar_locks_{}_{view}",
                    if by_piece { "by_piece" } else { "one" }
                ),
            )?;
            let m = measure(&captures[0], &captures[1], &captures[2]);
            inside.push((by_piece, view, m.interior_inked, m.boundary_inked));
        }
    }
    eprintln!("avatar hair inked inside, on the boundary (locks by piece, view): {inside:?}");
    // Lines one pixel wide at this size: more ink inside in each view, 1% of the inside more
    // over both.
    let more: f32 = (0..2).map(|v| inside[v + 2].2 - inside[v].2).sum();
    let ok = more > 0.01
        && (0..2).all(|v| {
            let (one, pieces) = (inside[v], inside[v + 2]);
            pieces.2 > one.2
                && pieces.2 <= LOCK_LINES_INSIDE_MOST
                && pieces.3 >= BOUNDARY_INKED_LEAST
        });
    if !ok {
        return Err(format!("{inside:?}").into());
    }
    Ok(())
}

/// The character turned by `yaw`, captured three times as the look suite measures a look: its hair
/// in the mask material without the outline, in the shipped material without, and with it.
fn three_captures(
    r: &mut HeadlessRenderer,
    character: Entity,
    yaw: f32,
    handle: &Handle<ToonHairMaterial>,
    shipped: &ToonHairMaterial,
) -> Result<[CapturedFrame; 3], Failed> {
    r.app
        .world_mut()
        .entity_mut(character)
        .insert(Transform::from_rotation(Quat::from_rotation_y(yaw)));
    let mut captures = Vec::new();
    for (material, outline_on) in [
        (mask_of(shipped), false),
        (shipped.clone(), false),
        (shipped.clone(), true),
    ] {
        set_material(r, handle, &material);
        let world = r.app.world_mut();
        let mut cameras = world.query::<&mut ImageSpaceOutline>();
        for mut o in cameras.iter_mut(world) {
            o.enabled = outline_on;
        }
        captures.push(r.capture()?);
    }
    let [mask, plain, inked] = <[CapturedFrame; 3]>::try_from(captures)
        .map_err(|c| format!("{} captures, not 3", c.len()))?;
    Ok([mask, plain, inked])
}

/// The avatar in `look`'s material (`hair` selecting its hair mesh), lit from above in front,
/// before a camera at head height with `outline`, warmed up until its meshes are dressed, in
/// frames of `size`: the renderer, the character, the hair material's handle and the material
/// as shipped.
fn avatar_scene(
    (width, height): (u32, u32),
    look: &HairPreset,
    outline: Option<ImageSpaceOutline>,
    hair: ToonHairMeshes,
) -> Result<
    (
        HeadlessRenderer,
        Entity,
        Handle<ToonHairMaterial>,
        ToonHairMaterial,
    ),
    Failed,
> {
    let mut r = HeadlessRenderer::new(CaptureSettings {
        width,
        height,
        max_frames: 3_000,
        ..default()
    })?;
    let target = r.target();
    r.app
        .add_plugins(CartoonHairPlugins)
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let world = r.app.world_mut();
    let ramps = world.resource::<ToonRamps>().clone();
    let mut shipped = ToonHairMaterial::default();
    look.material.apply(&mut shipped, &ramps);
    let handle = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(shipped.clone());
    let assets = world.resource::<AssetServer>().clone();
    let character = world
        .spawn((
            WorldAssetRoot(
                assets.load(GltfAssetLabel::Scene(0).from_asset("chain_hair/chain_hair.glb")),
            ),
            Transform::default(),
            hair.with_material(handle.clone()),
            // The face and body in the toon look too, the face taking the fringe's shadow.
            FringeShadowMeshes::all_except(|n| n == "hair", FringeShadow::cel()),
        ))
        .id();
    world.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            ..default()
        },
        Transform::from_xyz(1.0, 3.0, 2.5).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
    ));
    let mut camera = world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.8, 0.85, 0.95)),
            ..default()
        },
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.0, 1.72, 0.85).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y),
    ));
    if let Some(outline) = outline {
        camera.insert(outline);
    }
    warm_up_dressed(&mut r)?;
    Ok((r, character, handle, shipped))
}

/// Runs frames until the avatar's hair and body are dressed.
fn warm_up_dressed(r: &mut HeadlessRenderer) -> Result<(), Failed> {
    r.warm_up(|world| {
        let mut dressed = world.query::<&ToonHairMeshesApplied>();
        let mut body = world.query::<&FringeShadowMeshesApplied>();
        dressed.iter(world).any(|d| !d.0.is_empty()) && body.iter(world).any(|d| !d.0.is_empty())
    })?;
    Ok(())
}

/// `ToonHairMeshes::mass_normals`: the avatar's hair is faceted (rhombic locks on a low-poly
/// cap), and in the three-tone `clean_anime` look every facet is a band of its own. With the
/// normals of its bounds' ellipsoid the hair is shaded as one shape: from the back and the side,
/// the tone edges inside the hair (neighbouring pixels 3 px or more inside the hair whose luma
/// differs by more than 6) fall to under half.
fn mass_normals_shade_the_avatars_hair_as_one_shape() -> Result<(), Failed> {
    let look = HairPreset::look("clean_anime").ok_or("a shipped look")??;
    let (mut r, character, handle, shipped) = avatar_scene(
        (320, 240),
        &look,
        None,
        ToonHairMeshes::matching(|n| n == "hair"),
    )?;
    let mut edges = [[0usize; 2]; 2];
    for (i, amount) in [0.0f32, 1.0].into_iter().enumerate() {
        if amount > 0.0 {
            r.app
                .world_mut()
                .entity_mut(character)
                .insert(
                    ToonHairMeshes::matching(|n| n == "hair")
                        .with_material(handle.clone())
                        .with_mass_normals(amount),
                )
                .remove::<ToonHairMeshesApplied>();
            warm_up_dressed(&mut r)?;
        }
        for (v, yaw) in [std::f32::consts::PI, std::f32::consts::FRAC_PI_2]
            .into_iter()
            .enumerate()
        {
            r.app
                .world_mut()
                .entity_mut(character)
                .insert(Transform::from_rotation(Quat::from_rotation_y(yaw)));
            set_material(&mut r, &handle, &mask_of(&shipped));
            let mask = r.capture()?;
            set_material(&mut r, &handle, &shipped);
            let plain = r.capture()?;
            save(&plain, &format!("avatar_mass_normals_{amount}_{v}"))?;
            edges[i][v] = tone_edges(&mask, &plain);
        }
    }
    eprintln!(
        "tone edges inside the avatar's hair (back, side): own normals {:?}, mass normals {:?}",
        edges[0], edges[1]
    );
    for v in 0..2 {
        if edges[0][v] < 100 || edges[1][v] * 2 >= edges[0][v] {
            return Err(format!(
                "tone edges with the mesh's own normals {:?}, with mass normals {:?}",
                edges[0], edges[1]
            )
            .into());
        }
    }
    Ok(())
}

/// Neighbouring pixel pairs (right and down) at least 3 px inside the mask's hair (pure green)
/// whose luma in `plain` differs by more than 6.
fn tone_edges(mask: &CapturedFrame, plain: &CapturedFrame) -> usize {
    let (w, h) = (mask.width as i32, mask.height as i32);
    let green = |x: i32, y: i32| is_green(mask.pixel(x as u32, y as u32));
    let inside = |x: i32, y: i32| {
        (-3..=3).all(|dy| {
            (-3..=3).all(|dx| {
                let (a, b) = (x + dx, y + dy);
                a >= 0 && b >= 0 && a < w && b < h && green(a, b)
            })
        })
    };
    let luma = |x: i32, y: i32| {
        let [r, g, b, _] = plain.pixel(x as u32, y as u32);
        0.2126 * f32::from(r) + 0.7152 * f32::from(g) + 0.0722 * f32::from(b)
    };
    let mut edges = 0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            if !inside(x, y) {
                continue;
            }
            for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                if inside(nx, ny) && (luma(x, y) - luma(nx, ny)).abs() > 6.0 {
                    edges += 1;
                }
            }
        }
    }
    edges
}

/// The avatar's hair mesh is a cap with locks and a ponytail hanging 25 cm down the back. One
/// ellipsoid around all of it (the mesh's bounds) gives the ponytail normals pointing down and
/// back from the bounds' centre, so seen from the side it falls into the shadow tones as one
/// dark stroke. With an ellipsoid of its own beside the head's (mesh space, Y-up: the numbers of
/// the avatar's authoring script), it shades as a shape of its own: from the side, lit from above
/// in front, the upper half of its side facing the camera takes the lit tone. Measured over the
/// ponytail's pixels (the hair's pixels within 4 px of its lower bones projected to the
/// screen).
fn a_ponytail_given_its_own_mass_shape_shades_as_its_own() -> Result<(), Failed> {
    let look = HairPreset::look("clean_anime").ok_or("a shipped look")??;
    let (mut r, character, handle, shipped) = avatar_scene(
        (640, 480),
        &look,
        None,
        ToonHairMeshes::matching(|n| n == "hair"),
    )?;
    let head = HairMassShape::Ellipsoid {
        centre: Vec3::new(0.0, 1.686, -0.004),
        half_extents: Vec3::new(0.125, 0.145, 0.135),
    };
    let ponytail = HairMassShape::Ellipsoid {
        centre: Vec3::new(0.0, 1.60, -0.19),
        half_extents: Vec3::new(0.035, 0.12, 0.05),
    };
    let mut lit = Vec::new();
    for (name, shapes) in [
        ("bounds", vec![]),
        ("head_and_ponytail", vec![head, ponytail]),
    ] {
        let (mask, plain) = redress(
            &mut r,
            (character, &handle, &shipped),
            ToonHairMeshes::matching(|n| n == "hair")
                .with_mass_normals(1.0)
                .with_mass_shapes(shapes),
            std::f32::consts::FRAC_PI_2,
        )?;
        save(&plain, &format!("avatar_mass_shapes_{name}"))?;
        let pixels = ponytail_pixels(&mut r, &mask)?;
        let luma = |(x, y): (u32, u32)| {
            let [r, g, b, _] = plain.pixel(x, y);
            0.2126 * f32::from(r) + 0.7152 * f32::from(g) + 0.0722 * f32::from(b)
        };
        // The lit tone: within 8 of the brightest luma anywhere in the hair.
        let brightest = (0..plain.height)
            .flat_map(|y| (0..plain.width).map(move |x| (x, y)))
            .filter(|&(x, y)| is_green(mask.pixel(x, y)))
            .map(luma)
            .fold(0.0f32, f32::max);
        let in_light = pixels
            .iter()
            .filter(|&&p| luma(p) > brightest - 8.0)
            .count();
        eprintln!(
            "ponytail from the side, mass shapes {name}: {} pixels, {in_light} in the lit tone \
             (hair's brightest luma {brightest:.0})",
            pixels.len()
        );
        lit.push((pixels.len(), in_light));
    }
    let (bounds, own) = (lit[0], lit[1]);
    if bounds.0 < 100 || own.0 < 100 {
        return Err(format!("too few ponytail pixels: {bounds:?}, {own:?}").into());
    }
    // Fractions lit: with the bounds' ellipsoid under a tenth; with its own shape at least 30%
    // (its upper half: lower down its own shape's normals turn down, away from the light).
    let share = |(all, lit): (usize, usize)| lit as f32 / all as f32;
    if share(bounds) >= 0.1 || share(own) < 0.3 {
        return Err(format!(
            "ponytail pixels in the lit tone: bounds {bounds:?}, its own shape {own:?}"
        )
        .into());
    }
    Ok(())
}

/// Dresses the avatar again with `dress` (in the material behind `handle`), turned by `yaw`, and
/// captures its mask (the hair in flat green) and its look as `shipped`.
fn redress(
    r: &mut HeadlessRenderer,
    (character, handle, shipped): (Entity, &Handle<ToonHairMaterial>, &ToonHairMaterial),
    dress: ToonHairMeshes,
    yaw: f32,
) -> Result<(CapturedFrame, CapturedFrame), Failed> {
    r.app
        .world_mut()
        .entity_mut(character)
        .insert((
            dress.with_material(handle.clone()),
            Transform::from_rotation(Quat::from_rotation_y(yaw)),
        ))
        .remove::<ToonHairMeshesApplied>();
    warm_up_dressed(r)?;
    set_material(r, handle, &mask_of(shipped));
    let mask = r.capture()?;
    set_material(r, handle, shipped);
    Ok((mask, r.capture()?))
}

fn is_green([r, g, b, _]: [u8; 4]) -> bool {
    g > 40 && u32::from(r) * 3 < u32::from(g) && u32::from(b) * 3 < u32::from(g)
}

/// The hair pixels of `mask` within 4 px of the ponytail's bones (`hair_tail_2` to the last,
/// clear of the head) projected by the camera.
fn ponytail_pixels(
    r: &mut HeadlessRenderer,
    mask: &CapturedFrame,
) -> Result<Vec<(u32, u32)>, Failed> {
    let world = r.app.world_mut();
    let mut cameras = world.query::<(&Camera, &GlobalTransform)>();
    let (camera, eye) = cameras.single(world)?;
    let (camera, eye) = (camera.clone(), *eye);
    let mut bones = world.query::<(&Name, &GlobalTransform)>();
    let mut joints: Vec<(usize, Vec2)> = bones
        .iter(world)
        .filter_map(|(name, at)| {
            let k = name
                .as_str()
                .strip_prefix("hair_tail_")?
                .parse::<usize>()
                .ok()?;
            let p = camera.world_to_viewport(&eye, at.translation()).ok()?;
            (k >= 2).then_some((k, p))
        })
        .collect();
    joints.sort_by_key(|(k, _)| *k);
    if joints.len() < 3 {
        return Err(format!("found {} ponytail joints on screen", joints.len()).into());
    }
    let near = |q: Vec2| {
        joints.windows(2).any(|w| {
            let (a, b) = (w[0].1, w[1].1);
            let t = ((q - a).dot(b - a) / (b - a).length_squared().max(1e-6)).clamp(0.0, 1.0);
            q.distance(a + (b - a) * t) <= 4.0
        })
    };
    Ok((0..mask.height)
        .flat_map(|y| (0..mask.width).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            is_green(mask.pixel(x, y)) && near(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
        })
        .collect())
}

/// Coloured tips on the avatar, whose hair mesh has no UVs: with its own (none) the toon
/// material has no way along the strands and no hair pixel takes the tip colour; with
/// `StrandUvs::Height` the tips blend from halfway down the mesh, so from the back the lowest
/// third of the hair's rows is mostly toward the tip colour (blue at least half of red, which
/// the orange hair's tones never reach) and the top third has none of it.
fn height_uvs_colour_the_avatars_tips_from_the_top_down() -> Result<(), Failed> {
    let mut look = HairPreset::look("clean_anime").ok_or("a shipped look")??;
    look.material.shading.tip_color = Color::srgb(0.1, 0.3, 0.9);
    look.material.shading.tip_start = 0.5;
    look.material.shading.tip_strength = 1.0;
    // The ring and the highlight, which UVs also switch on, are pale: left out, so only the
    // tips shift the colour toward blue.
    look.material.shading.angel_ring = 0.0;
    look.material.shading.specular_strength = 0.0;
    let (mut r, character, handle, shipped) = avatar_scene(
        (320, 240),
        &look,
        None,
        ToonHairMeshes::matching(|n| n == "hair"),
    )?;
    let mut thirds = Vec::new();
    for uvs in [StrandUvs::Mesh, StrandUvs::Height] {
        let (mask, plain) = redress(
            &mut r,
            (character, &handle, &shipped),
            ToonHairMeshes::matching(|n| n == "hair").with_strand_uvs(uvs),
            std::f32::consts::PI,
        )?;
        save(&plain, &format!("avatar_tips_{uvs:?}"))?;
        let hair: Vec<(u32, u32)> = (0..mask.height)
            .flat_map(|y| (0..mask.width).map(move |x| (x, y)))
            .filter(|&(x, y)| is_green(mask.pixel(x, y)))
            .collect();
        let (top, bottom) = hair
            .iter()
            .fold((u32::MAX, 0), |(t, b), &(_, y)| (t.min(y), b.max(y)));
        let third = (bottom - top + 1) as f32 / 3.0;
        // Toward the tip colour: blue at least half of red (the orange hair's tones are at
        // most a fifth; the Oklab blend reaches half about a third of the way to the tip).
        let tipped = |rows: std::ops::Range<f32>| {
            let inside: Vec<_> = hair
                .iter()
                .filter(|&&(_, y)| rows.contains(&((y - top) as f32)))
                .collect();
            let blue = inside
                .iter()
                .filter(|&&&(x, y)| {
                    let [r, _, b, _] = plain.pixel(x, y);
                    u32::from(b) * 2 > u32::from(r)
                })
                .count();
            (blue, inside.len())
        };
        let (upper, lower) = (tipped(0.0..third), tipped(2.0 * third..3.0 * third + 1.0));
        eprintln!(
            "tip-coloured hair pixels from the back, {uvs:?} UVs: top third {upper:?}, bottom third \
             {lower:?} (blue, all)"
        );
        thirds.push((upper, lower));
    }
    let ((own_top, own_bottom), (top, bottom)) = (thirds[0], thirds[1]);
    if own_top.0 + own_bottom.0 > 0 || top.0 > 0 || bottom.0 * 2 < bottom.1 || bottom.1 < 100 {
        return Err(format!(
            "tip-coloured pixels (blue, all), top and bottom thirds: own UVs {own_top:?} \
             {own_bottom:?}, height UVs {top:?} {bottom:?}"
        )
        .into());
    }
    Ok(())
}
