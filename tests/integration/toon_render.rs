//! Render tests of strand meshes drawn with `ToonHairMaterial` (lavapipe on CPU-only machines).

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_cartoon_hair::asset::HairGroom;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::HatchingMode;
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "toon_bands_no_more_than_ramp_tones",
        toon_bands_no_more_than_ramp_tones,
    ),
    (
        "depth_detail_far_strand_lighter",
        depth_detail_far_strand_lighter,
    ),
    (
        "blinn_specular_peaks_where_n_dot_h_is_highest",
        blinn_specular_peaks_where_n_dot_h_is_highest,
    ),
    (
        "hatching_puts_more_ink_in_darker_regions",
        hatching_puts_more_ink_in_darker_regions,
    ),
    (
        "specular_quads_show_on_the_lit_side",
        specular_quads_show_on_the_lit_side,
    ),
    (
        "specular_quads_with_nothing_to_show_are_hidden_never_empty",
        specular_quads_with_nothing_to_show_are_hidden_never_empty,
    ),
    (
        "depth_detail_back_light_and_specular_ramp_combine",
        depth_detail_back_light_and_specular_ramp_combine,
    ),
];

pub(crate) const BACKGROUND: [u8; 4] = [0, 0, 0, 255];

/// A renderer with the hair plugins, a light, and a camera at `eye` looking at the origin.
pub(crate) fn scene(light_dir: Vec3, eye: Vec3) -> Result<HeadlessRenderer, Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings::default())?;
    r.app.add_plugins(CartoonHairPlugins);
    let target = r.target();
    let world = r.app.world_mut();
    world.spawn((
        DirectionalLight {
            illuminance: 5_000.0,
            ..default()
        },
        Transform::from_translation(light_dir).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::BLACK),
            ..default()
        },
        // Tonemapping would blend the hard toon bands into new shades.
        bevy::core_pipeline::tonemapping::Tonemapping::Linear,
        Msaa::Off,
        RenderTarget::Image(target.into()),
        Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    Ok(r)
}

/// A straight strand from `a` to `b`, held still (no gravity, anchors rigid), drawn thick with
/// `material`.
pub(crate) fn spawn_strand(
    r: &mut HeadlessRenderer,
    a: Vec3,
    b: Vec3,
    radius: f32,
    material: ToonHairMaterial,
) {
    let world = r.app.world_mut();
    let points: Vec<Vec3> = (0..6).map(|i| a.lerp(b, i as f32 / 5.0)).collect();
    let groom = HairGroom::from_strands("", [points]).unwrap();
    let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
    let material = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(material);
    world.spawn((
        Hair { groom, ..default() },
        HairSimSettings {
            gravity: Vec3::ZERO,
            anchor_stiffness: QuadraticCurve::constant(1.0),
            ..default()
        },
        HairMeshSettings {
            radius,
            taper: QuadraticCurve::constant(1.0),
            hair_resolution: 24,
            shape_resolution: 32,
            // The strand's own normals: these tests look at one tube.
            mass_normals: 0.0,
            ..default()
        },
        HairMaterial(material),
        // These tests look at the material alone.
        SilhouetteSettings {
            enabled: false,
            ..default()
        },
    ));
}

pub(crate) fn ramps(r: &HeadlessRenderer) -> ToonRamps {
    r.app.world().resource::<ToonRamps>().clone()
}

/// Hair pixels (not background) that are not next to the background (edges blend).
fn interior(frame: &CapturedFrame, x0: u32, x1: u32) -> Vec<[u8; 4]> {
    let mut v = Vec::new();
    for y in 1..frame.height - 1 {
        for x in x0.max(1)..x1.min(frame.width - 1) {
            let p = frame.pixel(x, y);
            let solid = [(0i32, 0i32), (1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .all(|(dx, dy)| {
                    frame.pixel((x as i32 + dx) as u32, (y as i32 + dy) as u32) != BACKGROUND
                });
            if solid && p != BACKGROUND {
                v.push(p);
            }
        }
    }
    v
}

/// Distinct colours, merging those within `tolerance` per channel; clusters with fewer than
/// `min_share` of the pixels are ignored.
pub(crate) fn distinct_shades(
    pixels: &[[u8; 4]],
    tolerance: i32,
    min_share: f32,
) -> Vec<([u8; 4], usize)> {
    let mut clusters: Vec<([u8; 4], usize)> = Vec::new();
    for p in pixels {
        match clusters
            .iter_mut()
            .find(|(c, _)| (0..3).all(|i| (i32::from(c[i]) - i32::from(p[i])).abs() <= tolerance))
        {
            Some(c) => c.1 += 1,
            None => clusters.push((*p, 1)),
        }
    }
    clusters.retain(|(_, n)| *n as f32 >= min_share * pixels.len() as f32);
    clusters
}

fn luminance(p: [u8; 4]) -> f32 {
    0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2])
}

pub(crate) fn save(frame: &CapturedFrame, name: &str) -> Result<(), Failed> {
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        frame.save_png(std::path::Path::new(&dir).join(format!("{name}.png")))?;
    }
    Ok(())
}

/// A thick strand lit from one side shows the three-tone ramp's bands and no other shades.
fn toon_bands_no_more_than_ramp_tones() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
    let ramp = ramps(&r).three_tone;
    spawn_strand(
        &mut r,
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        0.4,
        ToonHairMaterial { ramp, ..default() },
    );
    let frame = r.capture()?;
    save(&frame, "toon_bands")?;
    let pixels = interior(&frame, 0, frame.width);
    if pixels.len() < 2000 {
        return Err(format!("only {} hair pixels rendered", pixels.len()).into());
    }
    let shades = distinct_shades(&pixels, 3, 0.0);
    let big = distinct_shades(&pixels, 3, 0.01);
    // The ramp has three tones; with the light above-front, at least two are visible.
    if shades.len() > 3 || big.len() < 2 {
        return Err(format!("expected 2-3 shades, found {}: {shades:?}", shades.len()).into());
    }
    Ok(())
}

/// For a camera at z = 4: a strand from `near.0` to `near.1` of radius `near.2` about 1 m away
/// (the left half of the frame), and an upright one 9 m away on the right, scaled up to look
/// about as large; both drawn with `material`.
fn spawn_near_and_far(
    r: &mut HeadlessRenderer,
    near: (Vec3, Vec3, f32),
    material: ToonHairMaterial,
) {
    spawn_strand(r, near.0, near.1, near.2, material.clone());
    spawn_strand(
        r,
        Vec3::new(2.0, -3.0, -5.0),
        Vec3::new(2.0, 3.0, -5.0),
        0.6,
        material,
    );
}

/// Depth detail: a far strand is washed out (lighter on average) compared with a near one.
fn depth_detail_far_strand_lighter() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(1.0, 0.2, 0.3), Vec3::new(0.0, 0.0, 4.0))?;
    let ramp = ramps(&r).depth;
    let material = ToonHairMaterial::new(
        ToonShading {
            ramp_mode: RampMode::Depth,
            z_min: 3.0,
            z_scale: 3.0,
            ..default()
        },
        ramp,
    );
    // Near (left, upright) and far.
    spawn_near_and_far(
        &mut r,
        (Vec3::new(-0.2, -0.3, 3.0), Vec3::new(-0.2, 0.3, 3.0), 0.06),
        material,
    );
    let frame = r.capture()?;
    save(&frame, "depth_detail")?;
    let (w, _) = (frame.width, frame.height);
    let near = interior(&frame, 0, w / 2);
    let far = interior(&frame, w / 2, w);
    if near.len() < 200 || far.len() < 200 {
        return Err(format!(
            "strands not both visible: {} near, {} far pixels",
            near.len(),
            far.len()
        )
        .into());
    }
    let mean = |v: &[[u8; 4]]| v.iter().map(|p| luminance(*p)).sum::<f32>() / v.len() as f32;
    let (n, f) = (mean(&near), mean(&far));
    if f <= n + 5.0 {
        return Err(format!("far strand is not lighter: near {n:.1}, far {f:.1}").into());
    }
    Ok(())
}

/// Depth detail (the main ramp's y), the back light rim and the specular ramp
/// layer at once. Against the same scene with depth detail alone: the far strand is still
/// lighter than the near one, the near strand gains a drawn highlight (near-white pixels the
/// depth-only frame lacks) on its lit side, and the rim brightens its edges.
fn depth_detail_back_light_and_specular_ramp_combine() -> Result<(), Failed> {
    let render = |layers: bool| -> Result<CapturedFrame, Failed> {
        let mut r = scene(Vec3::new(0.3, 1.0, 1.0), Vec3::new(0.0, 0.0, 4.0))?;
        let ramp = ramps(&r).depth;
        let material = ToonHairMaterial::new(
            ToonShading {
                base_color: Color::srgb(0.9, 0.45, 0.3),
                ramp_mode: RampMode::Depth,
                z_min: 3.0,
                z_scale: 3.0,
                back_light_strength: if layers { 0.6 } else { 0.0 },
                specular_ramp: if layers { 1.0 } else { 0.0 },
                specular_color: Color::WHITE,
                shininess: 6.0,
                ..default()
            },
            ramp,
        );
        // Near (left, lying across) and far.
        spawn_near_and_far(
            &mut r,
            (Vec3::new(-0.38, 0.0, 3.0), Vec3::new(-0.04, 0.0, 3.0), 0.08),
            material,
        );
        Ok(r.capture()?)
    };
    let plain = render(false)?;
    let layered = render(true)?;
    save(&layered, "ramps_combine")?;
    let w = layered.width;
    let (near, far) = (interior(&layered, 0, w / 2), interior(&layered, w / 2, w));
    // Depth detail at each strand's middle, where it faces the camera (no rim there) and is
    // lit alike: the far one is lighter.
    let middle = |f: &CapturedFrame, x0: u32, x1: u32| -> Option<f32> {
        let px: Vec<(u32, u32)> = (0..f.height)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| f.pixel(x, y) != BACKGROUND)
            .collect();
        let n = px.len().max(1) as u64;
        let cx = (px.iter().map(|p| u64::from(p.0)).sum::<u64>() / n) as u32;
        let cy = (px.iter().map(|p| u64::from(p.1)).sum::<u64>() / n) as u32;
        (!px.is_empty()).then(|| luminance(f.pixel(cx, cy)))
    };
    let centres = |f: &CapturedFrame| middle(f, 0, w / 2).zip(middle(f, w / 2, w));
    let (n, f) = centres(&layered).ok_or("a strand is missing")?;
    let (pn, pf) = centres(&plain).ok_or("a strand is missing")?;
    // Drawn highlight: near-white where the depth-only frame was not.
    let mut highlight = 0;
    let mut highlight_y = 0u64;
    // Rim: the near strand's top and bottom edge pixels, brighter than without the layers.
    let (mut rim_gain, mut rim_px) = (0.0f32, 0);
    for x in 0..w / 2 {
        let column: Vec<u32> = (0..layered.height)
            .filter(|&y| layered.pixel(x, y) != BACKGROUND)
            .collect();
        for &y in &column {
            let (a, b) = (layered.pixel(x, y), plain.pixel(x, y));
            if a[0] > 230 && a[1] > 230 && a[2] > 230 && luminance(b) < 200.0 {
                highlight += 1;
                highlight_y += u64::from(y);
            }
        }
        if let (Some(&top), Some(&bottom)) = (column.first(), column.last())
            && bottom > top + 4
        {
            for y in [top + 1, bottom - 1] {
                rim_gain += luminance(layered.pixel(x, y)) - luminance(plain.pixel(x, y));
                rim_px += 1;
            }
        }
    }
    eprintln!(
        "near {n:.1} far {f:.1} (depth only: {pn:.1} {pf:.1}); {highlight} highlight px; rim gain \
         {:.1} luma over {rim_px} px",
        rim_gain / rim_px.max(1) as f32
    );
    if near.len() < 200 || far.len() < 200 {
        return Err(format!("strands missing: {} near, {} far px", near.len(), far.len()).into());
    }
    if f <= n + 5.0 {
        return Err(
            format!("depth detail lost with the layers on: near {n:.1}, far {f:.1}").into(),
        );
    }
    if highlight < 20 {
        return Err(format!("no drawn highlight: {highlight} px").into());
    }
    // The light is above: the highlight sits in the upper half of the frame.
    let mean_y = highlight_y as f32 / highlight as f32;
    if mean_y >= layered.height as f32 / 2.0 {
        return Err(format!("highlight below the middle (row {mean_y:.0})").into());
    }
    if rim_gain / (rim_px.max(1) as f32) < 5.0 {
        return Err(format!(
            "no back light rim: {:.1} luma",
            rim_gain / rim_px.max(1) as f32
        )
        .into());
    }
    Ok(())
}

/// Blinn specular: the brightest hair pixels sit where N.H is highest on a horizontal tube, above
/// its axis toward the light.
fn blinn_specular_peaks_where_n_dot_h_is_highest() -> Result<(), Failed> {
    let light = Vec3::new(0.0, 1.0, 1.0);
    let eye = Vec3::new(0.0, 0.0, 3.0);
    let mut r = scene(light, eye)?;
    let ramp = ramps(&r).three_tone;
    let radius = 0.5;
    spawn_strand(
        &mut r,
        Vec3::new(-1.2, 0.0, 0.0),
        Vec3::new(1.2, 0.0, 0.0),
        radius,
        ToonHairMaterial::new(
            ToonShading {
                base_color: Color::srgb(0.4, 0.1, 0.1),
                specular_strength: 1.0,
                shininess: 80.0,
                ..default()
            },
            ramp,
        ),
    );
    let frame = r.capture()?;
    save(&frame, "blinn_specular")?;
    // Brightest row along the centre column.
    let x = frame.width / 2;
    let (mut best_y, mut best) = (0, -1.0f32);
    let mut top = None;
    let mut bottom = 0;
    for y in 0..frame.height {
        let p = frame.pixel(x, y);
        if p == BACKGROUND {
            continue;
        }
        top.get_or_insert(y);
        bottom = y;
        let l = luminance(p);
        if l > best {
            best = l;
            best_y = y;
        }
    }
    let top = top.ok_or("no hair in the centre column")?;
    // Where N = H: H halfway between the light and view directions (22.5 degrees above the view
    // axis); project the surface point at that normal onto the screen.
    let h = (light.normalize() + eye.normalize()).normalize();
    let centre = (top + bottom) as f32 / 2.0;
    let half = (bottom - top) as f32 / 2.0;
    let expected = centre - half * h.y / (h.y * h.y + h.z * h.z).sqrt();
    if (best_y as f32 - expected).abs() > 0.2 * half + 2.0 {
        return Err(format!(
            "highlight at row {best_y}, expected near {expected:.0} (tube rows {top}..{bottom})"
        )
        .into());
    }
    if best < 200.0 {
        return Err(format!("no bright highlight (peak luminance {best})").into());
    }
    Ok(())
}

/// Hatching, screen and surface: the shadowed half of a tube carries more ink (dark pixels
/// relative to the shade underneath) than the lit half.
fn hatching_puts_more_ink_in_darker_regions() -> Result<(), Failed> {
    use bevy_cartoon_hair::hatching::{StrokeImage, TamSettings, generate, tonal_art_map_image};
    let settings = TamSettings {
        tones: 6,
        resolution: 128,
        mip_levels: 3,
        strokes_per_tone: 60,
        candidates: 4,
        stroke_width_px: 2.0,
        ..default()
    };
    let map = generate(&StrokeImage::default(), &settings, |_, _| {})?;
    for mode in [HatchingMode::Screen, HatchingMode::Surface] {
        // Light from above: the top of the tube is lit, the bottom in shadow.
        let mut r = scene(Vec3::new(0.0, 1.0, 0.15), Vec3::new(0.0, 0.0, 3.0))?;
        let world = r.app.world_mut();
        let tam = world
            .resource_mut::<Assets<Image>>()
            .add(tonal_art_map_image(&map));
        // A flat ramp, so every shade difference comes from the hatching.
        let flat =
            world
                .resource_mut::<Assets<Image>>()
                .add(bevy_cartoon_hair::render::ramp_image(|x, _| {
                    (if x < 0.3 { 0.85 } else { 1.0 }, 0.0)
                }));
        spawn_strand(
            &mut r,
            Vec3::new(-1.2, 0.0, 0.0),
            Vec3::new(1.2, 0.0, 0.0),
            0.6,
            ToonHairMaterial {
                shading: ToonShading {
                    base_color: Color::WHITE,
                    hatching: mode,
                    hatch_scale: 0.5,
                    // The scene's light is the full light: its lit side gets the lightest tones.
                    full_light_lux: 5_000.0,
                    ..default()
                },
                ramp: flat,
                tonal_art_map: Some(tam),
                specular_ramp_texture: None,
                ..default()
            },
        );
        let frame = r.capture()?;
        save(&frame, &format!("hatching_{mode:?}"))?;
        let x0 = frame.width / 4;
        let x1 = 3 * frame.width / 4;
        let (mut rows, mut top, mut bottom) = (Vec::new(), None, 0);
        for y in 0..frame.height {
            if frame.pixel(frame.width / 2, y) != BACKGROUND {
                top.get_or_insert(y);
                bottom = y;
            }
        }
        let top = top.ok_or("no hair rendered")?;
        let mid = (top + bottom) / 2;
        // Ink = mean darkness relative to the flat shade underneath (0.85 or 1.0 of white).
        let ink = |y0: u32, y1: u32| {
            let mut n = 0.0;
            let mut sum = 0.0;
            for y in y0..y1 {
                for x in x0..x1 {
                    n += 1.0;
                    sum += 1.0 - luminance(frame.pixel(x, y)) / 255.0;
                }
            }
            sum / f32::max(n, 1.0)
        };
        let lit = ink(top + 2, mid - 2);
        let shadow = ink(mid + 2, bottom - 1);
        rows.push((lit, shadow));
        // The flat ramp alone adds at most 0.15 of darkness to the shadow half.
        if shadow <= lit + 0.2 {
            return Err(
                format!("{mode:?}: shadow ink {shadow:.3} not above lit ink {lit:.3}").into(),
            );
        }
    }
    Ok(())
}

/// Specular sampling quads: with them on, near-white highlight pixels appear on the tube where
/// N.H is highest (above its axis, toward the light); with them off there are none.
fn specular_quads_show_on_the_lit_side() -> Result<(), Failed> {
    let light = Vec3::new(0.0, 1.0, 1.0);
    let mut counts = Vec::new();
    for enabled in [false, true] {
        let mut r = scene(light, Vec3::new(0.0, 0.0, 3.0))?;
        let ramp = ramps(&r).three_tone;
        spawn_strand(
            &mut r,
            Vec3::new(-1.2, 0.0, 0.0),
            Vec3::new(1.2, 0.0, 0.0),
            0.4,
            ToonHairMaterial::new(
                ToonShading {
                    base_color: Color::srgb(0.4, 0.1, 0.1),
                    ..default()
                },
                ramp,
            ),
        );
        let mut q = r.app.world_mut().query_filtered::<Entity, With<Hair>>();
        let hair = q.single(r.app.world()).map_err(|e| e.to_string())?;
        r.app.world_mut().entity_mut(hair).insert(SpecularQuads {
            enabled,
            threshold: 0.5,
            ..default()
        });
        let frame = r.capture()?;
        save(&frame, &format!("specular_quads_{enabled}"))?;
        let white: Vec<u32> = (0..frame.height)
            .flat_map(|y| (0..frame.width).map(move |x| (x, y)))
            .filter(|&(x, y)| frame.pixel(x, y)[..3].iter().all(|c| *c > 200))
            .map(|(_, y)| y)
            .collect();
        counts.push(white.len());
        if enabled {
            if white.len() < 200 {
                return Err(format!("only {} highlight pixels", white.len()).into());
            }
            let mean_y = white.iter().sum::<u32>() as f32 / white.len() as f32;
            // The tube's axis is the image centre row; the highlight sits above it.
            if mean_y >= frame.height as f32 / 2.0 {
                return Err(format!("highlight at row {mean_y}, not above the axis").into());
            }
        } else if !white.is_empty() {
            return Err(format!("{} white pixels with quads off", white.len()).into());
        }
    }
    println!("specular quads: white pixels off/on = {counts:?}");
    Ok(())
}

/// Specular quads built on the CPU with the light behind the strand find nothing that shines:
/// their mesh holds one triangle of no area (Bevy warns each time it uploads a mesh without
/// vertices) and their entity is hidden (no draw call); lit from the front they are shown, and
/// hidden again when the light goes back behind.
fn specular_quads_with_nothing_to_show_are_hidden_never_empty() -> Result<(), Failed> {
    use bevy_cartoon_hair::mesh::highlights::HairHighlightsOf;
    use bevy_cartoon_hair::render::HairMeshBuilder;
    let mut r = scene(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 3.0))?;
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let ramp = ramps(&r).three_tone;
    spawn_strand(
        &mut r,
        Vec3::new(-1.2, 0.0, 0.0),
        Vec3::new(1.2, 0.0, 0.0),
        0.4,
        ToonHairMaterial::new(ToonShading::default(), ramp),
    );
    let mut q = r.app.world_mut().query_filtered::<Entity, With<Hair>>();
    let hair = q.single(r.app.world()).map_err(|e| e.to_string())?;
    r.app.world_mut().entity_mut(hair).insert(SpecularQuads {
        enabled: true,
        threshold: 0.5,
        ..default()
    });
    // (shown, triangles, vertices) of the hair's highlight mesh.
    let state = |r: &mut HeadlessRenderer| -> Result<(bool, usize, usize), Failed> {
        let world = r.app.world_mut();
        let mut parts = world.query::<(&HairHighlightsOf, &Mesh3d, &Visibility)>();
        let (_, mesh, shown) = parts
            .iter(world)
            .find(|(of, ..)| of.0 == hair)
            .ok_or("the hair has no highlight entity")?;
        let mesh = world
            .resource::<Assets<Mesh>>()
            .get(&mesh.0)
            .ok_or("no highlight mesh")?;
        Ok((
            *shown != Visibility::Hidden,
            mesh.indices().map_or(0, |i| i.len() / 3),
            mesh.count_vertices(),
        ))
    };
    let light = |r: &mut HeadlessRenderer, toward: Vec3| {
        let world = r.app.world_mut();
        let mut lights = world.query_filtered::<&mut Transform, With<DirectionalLight>>();
        for mut t in lights.iter_mut(world) {
            *t = Transform::from_translation(toward).looking_at(Vec3::ZERO, Vec3::Y);
        }
    };
    let mut seen = Vec::new();
    for (name, toward) in [
        ("behind", Vec3::new(0.0, 0.0, -1.0)),
        ("front", Vec3::new(0.0, 1.0, 1.0)),
        ("behind again", Vec3::new(0.0, 0.0, -1.0)),
    ] {
        light(&mut r, toward);
        r.capture()?;
        let now = state(&mut r)?;
        eprintln!("lit from {name}: (shown, triangles, vertices) {now:?}");
        seen.push(now);
    }
    let ok = |(shown, triangles, vertices): (bool, usize, usize), lit: bool| {
        vertices > 0 && shown == lit && (if lit { triangles > 2 } else { triangles == 1 })
    };
    if !(ok(seen[0], false) && ok(seen[1], true) && ok(seen[2], false)) {
        return Err(format!(
            "expected hidden with one triangle when lit from behind, shown with quads from the \
             front: {seen:?}"
        )
        .into());
    }
    Ok(())
}
