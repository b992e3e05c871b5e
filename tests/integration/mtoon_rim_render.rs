//! A VRM's MToon rim light (`VrmRim`: MToon's parametric rim) on the cel-shaded body and on
//! hair in `ToonHairMeshes`' default look, against MToon's formula evaluated pixel by pixel
//! where the camera's ray meets the sphere.

use bevy::prelude::*;
use bevy_cartoon_hair::asset::{VrmRim, VrmShadeColor, VrmShading};
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::mtoon_cel_band;
use libtest_mimic::Failed;

use crate::mtoon_shading_render::{intensity, linear, lit_sphere, normal_and_view, smoothstep};
use crate::toon_render::{BACKGROUND, save};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "an_mtoon_rim_light_is_added_along_the_silhouette",
        an_mtoon_rim_light_is_added_along_the_silhouette,
    ),
    (
        "an_mtoon_rim_light_is_added_along_the_hairs_silhouette",
        an_mtoon_rim_light_is_added_along_the_hairs_silhouette,
    ),
];

/// The sphere's grey base colour and MToon shade: dark enough that base plus rim stays below
/// white (the frame's 8 bits would clip it). The cel shade tone is the shade over the base, and
/// so is the hair's darkest tone with a band (its band ramp's dark tone times its shade colour).
const BASE: f32 = 0.3;
const SHADE: f32 = 0.1;

/// The hair's shading band: `N.L` from 0.2 to 0.4.
const HAIR_BAND: VrmShading = VrmShading {
    shift: -0.3,
    toony: 0.9,
};

/// The MToon sphere lit from the side, with `rim` on its mesh: cel-shaded skin, or (`hair`)
/// hair in the default look with [`HAIR_BAND`].
fn sphere(rim: Option<VrmRim>, hair: bool) -> Result<CapturedFrame, Failed> {
    lit_sphere(BASE, hair, |mesh| {
        mesh.insert(VrmShadeColor(Color::linear_rgb(SHADE, SHADE, SHADE)));
        if hair {
            mesh.insert(HAIR_BAND);
        }
        if let Some(rim) = rim {
            mesh.insert(rim);
        }
    })
}

/// What the rim adds at pixel `(x, y)` by MToon's formula, per channel: its colour times
/// `pow(saturate(1 - N.V + lift), power)` times `lerp(1, lighting, mix)`, where lighting is
/// what the shading draws a white surface in (white sun: 1 where lit, the shade tone in shade),
/// the turn from shade to lit a smooth step over `turn` (threshold, half width). `None` off the
/// sphere, within 2 pixels of its outline (part background) and where the turn is under way
/// (the prediction of the light there is too steep to judge a rim by).
fn predicted(rim: &VrmRim, turn: (f32, f32), (x, y): (u32, u32), size: u32) -> Option<[f32; 3]> {
    let (n, v) = normal_and_view(x, y, size)?;
    let inside = |dx: i32, dy: i32| {
        normal_and_view(x.checked_add_signed(dx)?, y.checked_add_signed(dy)?, size)
    };
    if [(-2, 0), (2, 0), (0, -2), (0, 2)]
        .iter()
        .any(|&(dx, dy)| inside(dx, dy).is_none())
    {
        return None;
    }
    let (t, soft) = turn;
    let lit = smoothstep(t - soft, t + soft, intensity(x, y, size)?);
    if lit > 0.02 && lit < 0.98 {
        return None;
    }
    let tone = SHADE / BASE + (1.0 - SHADE / BASE) * lit;
    let lighting = 1.0 + (tone - 1.0) * rim.lighting_mix;
    let c = rim.color.to_linear();
    let s = rim.strength(n.dot(v)) * lighting;
    Some([c.red * s, c.green * s, c.blue * s])
}

/// The sphere drawn with each rim, less the sphere drawn without one, against [`predicted`] on
/// every pixel it judges: the largest and mean gap (linear, any channel), the largest rim
/// predicted, and the count of pixels judged.
fn compare(
    plain: &CapturedFrame,
    lit: &CapturedFrame,
    rim: &VrmRim,
    turn: (f32, f32),
) -> (f32, f32, f32, usize) {
    let (mut most, mut sum, mut brightest, mut count) = (0.0f32, 0.0f32, 0.0f32, 0usize);
    for y in 0..lit.height {
        for x in 0..lit.width {
            let (a, b) = (plain.pixel(x, y), lit.pixel(x, y));
            if a == BACKGROUND || b == BACKGROUND {
                continue;
            }
            let Some(want) = predicted(rim, turn, (x, y), lit.width) else {
                continue;
            };
            for c in 0..3 {
                let added = linear(b[c]) - linear(a[c]);
                let gap = (added - want[c]).abs();
                most = most.max(gap);
                sum += gap;
                brightest = brightest.max(want[c]);
            }
            count += 1;
        }
    }
    (most, sum / (3 * count.max(1)) as f32, brightest, count)
}

/// A cel-shaded MToon sphere lit from the side: a rim glowing on its own (lighting mix 0,
/// orange, power 2, lift 0.1) adds MToon's formula on every pixel judged, lit or in shade;
/// a rim fully lit (mix 1, power 4, no lift) adds it times the shade tone (a third) in shade
/// and in full where lit. Each within 0.02 of the formula on every pixel judged (8-bit sRGB
/// steps are up to 0.006 apart in linear at these levels) and 0.004 on average; the brightest
/// predicted rim is over 0.2, so a rim not drawn, or drawn unlit where it should be lit, fails.
fn an_mtoon_rim_light_is_added_along_the_silhouette() -> Result<(), Failed> {
    let plain = FringeShadow::cel();
    rims(false, (plain.cel_threshold, plain.cel_softness))
}

/// The same rims on hair in `ToonHairMeshes`' default look with an MToon band (its two-tone
/// band ramp: what it draws a white strand in is 1 where lit and its shade colour over its
/// base in shade, as on the skin), the turn at the band's.
fn an_mtoon_rim_light_is_added_along_the_hairs_silhouette() -> Result<(), Failed> {
    rims(true, mtoon_cel_band(&HAIR_BAND))
}

/// [`an_mtoon_rim_light_is_added_along_the_silhouette`] on skin or (`hair`) hair turning at
/// `turn`.
fn rims(hair: bool, turn: (f32, f32)) -> Result<(), Failed> {
    let what = if hair { "hair" } else { "skin" };
    let plain = sphere(None, hair)?;
    save(&plain, &format!("mtoon_rim_{what}_none"))?;
    let orange = Color::linear_rgb(0.5, 0.3, 0.1);
    let rims = [
        (
            "glow",
            VrmRim {
                color: orange,
                fresnel_power: 2.0,
                lift: 0.1,
                lighting_mix: 0.0,
            },
        ),
        (
            "lit",
            VrmRim {
                color: orange,
                fresnel_power: 4.0,
                lift: 0.0,
                lighting_mix: 1.0,
            },
        ),
    ];
    let mut wrong = Vec::new();
    let mut report = Vec::new();
    for (name, rim) in rims {
        let frame = sphere(Some(rim), hair)?;
        save(&frame, &format!("mtoon_rim_{what}_{name}"))?;
        let (most, mean, brightest, count) = compare(&plain, &frame, &rim, turn);
        report.push(format!(
            "{name}: {count} pixels, rim within {most:.4} of MToon's formula ({mean:.4} on \
             average), brightest predicted {brightest:.3}"
        ));
        if count < 15_000 || most > 0.02 || mean > 0.004 || brightest < 0.2 {
            wrong.push(format!(
                "{name}: {count} pixels, {most:.4} at most and {mean:.4} on average from the \
                 formula, brightest {brightest:.3}"
            ));
        }
    }
    eprintln!("MToon rim light, {what}:\n{}", report.join("\n"));
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("; ").into())
    }
}
