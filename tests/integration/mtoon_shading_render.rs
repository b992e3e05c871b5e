//! Where a VRM's MToon mesh turns from shade to lit: its shading band (`VrmShading`, MToon's
//! shading shift and toony factors) drawn by the cel-shaded body's turn and by the hair's default
//! toon look, against what the renderer's own light model predicts pixel by pixel.

use bevy::prelude::*;
use bevy_cartoon_hair::asset::{VrmShadeColor, VrmShading};
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{FringeShadowMeshesApplied, ToonHairMeshesApplied, mtoon_cel_band};
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "an_mtoon_shading_band_places_the_cel_terminator",
        an_mtoon_shading_band_places_the_cel_terminator,
    ),
    (
        "an_mtoon_shading_band_places_the_hairs_terminator",
        an_mtoon_shading_band_places_the_hairs_terminator,
    ),
    (
        "where_no_light_reaches_the_shade_is_drawn_not_black",
        where_no_light_reaches_the_shade_is_drawn_not_black,
    ),
];

/// The sphere's radius, the camera's distance from its centre.
const RADIUS: f32 = 0.45;
const EYE: f32 = 1.6;
/// The sun's illuminance: full light for the cel shading and the toon look alike.
const SUN_LUX: f32 = 10_000.0;
/// The base colour (linear grey level); the skin's MToon shade, and the hair's (the band ramp's
/// dark tone, half the lit one, times the base colour, so the hair's shade tint is neutral and
/// its colour the ramp times the base).
const BASE: f32 = 0.8;
const SHADE: f32 = 0.2;
const HAIR_SHADE: f32 = 0.5 * BASE;

/// A sphere at the origin, its mesh carrying an MToon shade colour and `band`: skin cel shaded
/// by `FringeShadowMeshes`, or (`hair`) hair in `ToonHairMeshes`' default look; lit by a sun of
/// full light along -X (so `N.L` is the normal's x), seen from +Z, no ambient light.
fn sphere(band: Option<VrmShading>, hair: bool) -> Result<CapturedFrame, Failed> {
    let shade = if hair { HAIR_SHADE } else { SHADE };
    lit_sphere(BASE, hair, |mesh| {
        mesh.insert(VrmShadeColor(Color::linear_rgb(shade, shade, shade)));
        if let Some(band) = band {
            mesh.insert(band);
        }
    })
}

/// The sphere of [`sphere`] in a grey `base` colour, its mesh given what `dress` inserts.
pub(crate) fn lit_sphere(
    base: f32,
    hair: bool,
    dress: impl FnOnce(&mut EntityWorldMut),
) -> Result<CapturedFrame, Failed> {
    let mut r = scene(Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, EYE))?;
    let world = r.app.world_mut();
    for mut sun in world.query::<&mut DirectionalLight>().iter_mut(world) {
        sun.illuminance = SUN_LUX;
    }
    world.insert_resource(GlobalAmbientLight {
        brightness: 0.0,
        ..default()
    });
    let ball = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(RADIUS).mesh().uv(128, 64));
    let skin = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::linear_rgb(base, base, base),
            ..default()
        });
    let root = world
        .spawn((Transform::default(), Visibility::default()))
        .id();
    if hair {
        world
            .entity_mut(root)
            .insert(ToonHairMeshes::matching(|_| true));
    } else {
        world
            .entity_mut(root)
            .insert(FringeShadowMeshes::all_except(
                |_| false,
                FringeShadow {
                    full_light_lux: SUN_LUX,
                    ..FringeShadow::cel()
                },
            ));
    }
    let mut mesh = world.spawn((
        Name::new("skin"),
        Mesh3d(ball),
        MeshMaterial3d(skin),
        ChildOf(root),
    ));
    dress(&mut mesh);
    r.warm_up(|world| {
        let hair = world.query::<&ToonHairMeshesApplied>().iter(world).count();
        let skin = world
            .query::<&FringeShadowMeshesApplied>()
            .iter(world)
            .count();
        hair + skin == 1
    })?;
    Ok(r.capture()?)
}

fn schlick(f90: f32, cos: f32) -> f32 {
    1.0 + (f90 - 1.0) * (1.0 - cos).powi(5)
}

/// Where the camera's ray through pixel `(x, y)` of a `size` x `size` frame (vertical field of
/// view 45 degrees) meets the sphere: the unit normal there and the unit direction to the
/// camera. `None` off the sphere.
pub(crate) fn normal_and_view(x: u32, y: u32, size: u32) -> Option<(Vec3, Vec3)> {
    let t = (std::f32::consts::FRAC_PI_4 * 0.5).tan();
    let half = size as f32 * 0.5;
    let ndc = Vec2::new((x as f32 + 0.5) / half - 1.0, 1.0 - (y as f32 + 0.5) / half);
    let d = Vec3::new(ndc.x * t, ndc.y * t, -1.0).normalize();
    let o = Vec3::new(0.0, 0.0, EYE);
    // |o + s d|^2 = R^2, the nearer root.
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - RADIUS * RADIUS);
    if disc < 0.0 {
        return None;
    }
    let s = -b - disc.sqrt();
    Some(((o + s * d) / RADIUS, -d))
}

/// The light cel shading measures at pixel `(x, y)` of the 256x256 frame, as a share of full
/// light: Bevy's diffuse light on a white surface of roughness 1 where the camera's ray meets
/// the sphere ([`normal_and_view`]; Burley's, `N.L` times two Schlick terms), under the sun of
/// full light. `None` off the sphere.
pub(crate) fn intensity(x: u32, y: u32, size: u32) -> Option<f32> {
    let (n, v) = normal_and_view(x, y, size)?;
    let l = Vec3::X;
    let h = (l + v).normalize();
    let n_l = n.dot(l).clamp(0.0, 1.0);
    let n_v = n.dot(v).max(1e-4);
    let f90 = 0.5 + 2.0 * h.dot(l).powi(2);
    Some(schlick(f90, n_l) * schlick(f90, n_v) * n_l)
}

pub(crate) fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

pub(crate) fn linear(byte: u8) -> f32 {
    Color::srgb_u8(byte, byte, byte).to_linear().red
}

/// Over the rows 60 to 196 (every fourth), in each row the column where the drawn colour is
/// halfway from shade to lit, and where the prediction (a smooth step from `threshold -
/// softness` to `threshold + softness` over [`intensity`]) is: the mean and largest gap in
/// pixels, and the largest gap between drawn and predicted share of lit over the sphere's
/// pixels. Rows without a crossing in both are skipped; the count of rows compared is returned.
fn compare(
    frame: &CapturedFrame,
    (threshold, softness): (f32, f32),
    shade: f32,
) -> (f32, f32, f32, usize) {
    let (mut sum, mut most, mut share, mut rows) = (0.0f32, 0.0f32, 0.0f32, 0);
    for y in (60..=196).step_by(4) {
        let (mut drawn_at, mut predicted_at) = (None, None);
        let (mut last_drawn, mut last_predicted) = (None::<f32>, None::<f32>);
        for x in 0..frame.width {
            let p = frame.pixel(x, y);
            let Some(light) = intensity(x, y, frame.width) else {
                continue;
            };
            if p == BACKGROUND {
                continue;
            }
            // A pixel on the rim is part background; judge the sphere's inside.
            if intensity(x.saturating_sub(2), y, frame.width).is_none()
                || intensity(x + 2, y, frame.width).is_none()
            {
                continue;
            }
            let drawn = ((linear(p[1]) - shade) / (BASE - shade)).clamp(0.0, 1.0);
            let predicted = smoothstep(threshold - softness, threshold + softness, light);
            share = share.max((drawn - predicted).abs());
            // The first crossing of one half, left to right (shade on the left), interpolated.
            if drawn_at.is_none()
                && let Some(before) = last_drawn.filter(|&b| b < 0.5 && drawn >= 0.5)
            {
                drawn_at = Some(x as f32 - 1.0 + (0.5 - before) / (drawn - before));
            }
            if predicted_at.is_none()
                && let Some(before) = last_predicted.filter(|&b| b < 0.5 && predicted >= 0.5)
            {
                predicted_at = Some(x as f32 - 1.0 + (0.5 - before) / (predicted - before));
            }
            last_drawn = Some(drawn);
            last_predicted = Some(predicted);
        }
        if let (Some(a), Some(b)) = (drawn_at, predicted_at) {
            let gap = (a - b).abs();
            sum += gap;
            most = most.max(gap);
            rows += 1;
        }
    }
    (sum / rows.max(1) as f32, most, share, rows)
}

/// A sphere lit from the side, its mesh an MToon one (`hair`: in the hair's default look, else
/// cel-shaded skin): with a shading band (shift -0.5, toony 0.9: `N.L` 0.4 to 0.6; and VRM 0.x's
/// defaults: 0 to 0.1) the terminator lies where the renderer's light model puts that band's
/// middle, within half a pixel on every row compared, and the turn is as soft as the band says
/// (the drawn share of lit within `share_within` of the prediction on every pixel inside the
/// sphere); without a band it lies at the look's own turn (`plain`), 10 and more pixels from
/// where the first band would put it.
fn terminators(hair: bool, plain: (f32, f32), share_within: f32) -> Result<(), Failed> {
    let wide = VrmShading {
        shift: -0.5,
        toony: 0.9,
    };
    let vroid = VrmShading::from_v0(0.0, 0.9);
    let what = if hair { "hair" } else { "cel" };
    let shade = if hair { HAIR_SHADE } else { SHADE };
    let mut wrong = Vec::new();
    let mut report = Vec::new();
    for (name, band) in [
        ("wide", Some(wide)),
        ("vrm0_default", Some(vroid)),
        ("none", None),
    ] {
        let name = format!("mtoon_{what}_band_{name}");
        let frame = sphere(band, hair)?;
        save(&frame, &name)?;
        let turn = band.map_or(plain, |b| mtoon_cel_band(&b));
        let (mean, most, share, rows) = compare(&frame, turn, shade);
        // Where the wide band would put the terminator, for the unbanded sphere.
        let (other_mean, ..) = compare(&frame, mtoon_cel_band(&wide), shade);
        report.push(format!(
            "{name}: threshold {:.3} softness {:.3}: {rows} rows, terminator {mean:.2} px from \
             the prediction on average, {most:.2} at most; lit share within {share:.3}; \
             {other_mean:.1} px from the wide band's",
            turn.0, turn.1
        ));
        if rows < 25 {
            wrong.push(format!("{name}: only {rows} rows compared"));
        }
        // The three-tone ramp's middle tone is neither shade nor lit: where the hair wears it,
        // only how far its terminator lies from the band's is judged.
        let two_tones = band.is_some() || !hair;
        if two_tones && (most > 0.5 || share > share_within) {
            wrong.push(format!(
                "{name}: terminator {most:.2} px from the prediction, lit share {share:.3} off"
            ));
        }
        if band.is_none() && other_mean < 10.0 {
            wrong.push(format!(
                "{name}: the unbanded terminator is only {other_mean:.1} px from the wide band's"
            ));
        }
    }
    eprintln!("MToon shading bands, {what}:\n{}", report.join("\n"));
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("; ").into())
    }
}

/// Cel-shaded skin ([`terminators`]): without a band, the `FringeShadow`'s threshold 0.3.
fn an_mtoon_shading_band_places_the_cel_terminator() -> Result<(), Failed> {
    let plain = FringeShadow::cel();
    terminators(false, (plain.cel_threshold, plain.cel_softness), 0.05)
}

/// Hair in `ToonHairMeshes`' default look ([`terminators`]): with a band it wears the band's
/// ramp; without one the three-tone ramp, whose first turn (from its darkest tone to the
/// middle one) is at 0.15 of full light, drawn where the nearest texel of the 64 changes: at
/// 10/64 (its middle tone is neither shade nor lit, so there only the distance from the wide
/// band's terminator is judged).
fn an_mtoon_shading_band_places_the_hairs_terminator() -> Result<(), Failed> {
    terminators(true, (10.0 / 64.0, 0.001), 0.05)
}

/// The sphere's far side, turned away from the sun with no ambient light, receives no light at
/// all: cel-shaded skin draws its MToon shade there (base colour times cel shade: the shade
/// colour, 0.2), and hair in the default look with a band its band ramp's dark tone times its
/// shade (0.4), both in the sun's hue (white), as MToon draws its shade colour times the light's
/// colour; not black. Every pixel with `N.L < -0.1`, away from the outline, within 0.01 (linear)
/// of it.
fn where_no_light_reaches_the_shade_is_drawn_not_black() -> Result<(), Failed> {
    let wide = VrmShading {
        shift: -0.5,
        toony: 0.9,
    };
    let mut wrong = Vec::new();
    let mut report = Vec::new();
    for (name, band, hair, shade) in [
        ("skin", None, false, SHADE),
        ("hair", Some(wide), true, HAIR_SHADE),
    ] {
        let frame = sphere(band, hair)?;
        let (mut most, mut count) = (0.0f32, 0usize);
        for y in 0..frame.height {
            for x in 0..frame.width {
                let far = |x: u32| normal_and_view(x, y, frame.width).map(|(n, _)| n.x < -0.1);
                if far(x) != Some(true)
                    || far(x.saturating_sub(2)) != Some(true)
                    || far(x + 2) != Some(true)
                    || normal_and_view(x, y.saturating_sub(2), frame.width).is_none()
                    || normal_and_view(x, y + 2, frame.width).is_none()
                {
                    continue;
                }
                for &channel in &frame.pixel(x, y)[..3] {
                    most = most.max((linear(channel) - shade).abs());
                }
                count += 1;
            }
        }
        report.push(format!(
            "{name}: {count} pixels with no light, within {most:.4} of the shade {shade}"
        ));
        if count < 5_000 || most > 0.01 {
            wrong.push(format!(
                "{name}: {count} pixels, {most:.4} from the shade {shade}"
            ));
        }
    }
    eprintln!("Where no light reaches:\n{}", report.join("\n"));
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("; ").into())
    }
}
