//! A VRM's MToon rim light (`VrmRim`: MToon's parametric rim) on the cel-shaded body, against
//! MToon's formula evaluated pixel by pixel where the camera's ray meets the sphere.

use bevy::prelude::*;
use bevy_cartoon_hair::asset::{VrmRim, VrmShadeColor};
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use libtest_mimic::Failed;

use crate::mtoon_shading_render::{intensity, linear, lit_sphere, normal_and_view, smoothstep};
use crate::toon_render::{BACKGROUND, save};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "an_mtoon_rim_light_is_added_along_the_silhouette",
    an_mtoon_rim_light_is_added_along_the_silhouette,
)];

/// The sphere's grey base colour and MToon shade: dark enough that base plus rim stays below
/// white (the frame's 8 bits would clip it). The cel shade tone is the shade over the base.
const BASE: f32 = 0.3;
const SHADE: f32 = 0.1;

/// The cel-shaded MToon sphere lit from the side, with `rim` on its mesh.
fn sphere(rim: Option<VrmRim>) -> Result<CapturedFrame, Failed> {
    lit_sphere(BASE, false, |mesh| {
        mesh.insert(VrmShadeColor(Color::linear_rgb(SHADE, SHADE, SHADE)));
        if let Some(rim) = rim {
            mesh.insert(rim);
        }
    })
}

/// What the rim adds at pixel `(x, y)` by MToon's formula, per channel: its colour times
/// `pow(saturate(1 - N.V + lift), power)` times `lerp(1, lighting, mix)`, where lighting is
/// what cel shading draws a white surface in (white sun: 1 where lit, the shade tone in
/// shade). `None` off the sphere, within 2 pixels of its outline (part background) and where
/// the turn from shade to lit is under way (the prediction of the light there is too steep to
/// judge a rim by).
fn predicted(rim: &VrmRim, x: u32, y: u32, size: u32) -> Option<[f32; 3]> {
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
    let plain = FringeShadow::cel();
    let (t, soft) = (plain.cel_threshold, plain.cel_softness);
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
fn compare(plain: &CapturedFrame, lit: &CapturedFrame, rim: &VrmRim) -> (f32, f32, f32, usize) {
    let (mut most, mut sum, mut brightest, mut count) = (0.0f32, 0.0f32, 0.0f32, 0usize);
    for y in 0..lit.height {
        for x in 0..lit.width {
            let (a, b) = (plain.pixel(x, y), lit.pixel(x, y));
            if a == BACKGROUND || b == BACKGROUND {
                continue;
            }
            let Some(want) = predicted(rim, x, y, lit.width) else {
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
    let plain = sphere(None)?;
    save(&plain, "mtoon_rim_none")?;
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
        let frame = sphere(Some(rim))?;
        save(&frame, &format!("mtoon_rim_{name}"))?;
        let (most, mean, brightest, count) = compare(&plain, &frame, &rim);
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
    eprintln!("MToon rim light:\n{}", report.join("\n"));
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("; ").into())
    }
}
