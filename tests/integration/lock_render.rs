//! Render tests of the lock cross-sections (`LockSection`, `HairStrandSections`): the shapes
//! the mesh is built with, per hair and per strand, and how they lie on the hair's mass.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::mesh::{ComputedHairMesh, HairStrandSections, LockSection};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{HairMeshBuilder, LockLines};
use libtest_mimic::Failed;

use crate::mass_render::spawn_still_hair;
use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "locks_take_their_section_per_hair_and_per_strand",
        locks_take_their_section_per_hair_and_per_strand,
    ),
    (
        "lock_lines_ink_a_lock_over_another_not_a_fold",
        lock_lines_ink_a_lock_over_another_not_a_fold,
    ),
    (
        "lock_lines_in_the_hairs_colour_keep_the_outline_ink",
        lock_lines_in_the_hairs_colour_keep_the_outline_ink,
    ),
    (
        "the_mass_outline_in_the_hairs_colour_leaves_other_outlines_inked",
        the_mass_outline_in_the_hairs_colour_leaves_other_outlines_inked,
    ),
];

/// Magenta: neither the orange hair nor the black background.
const INK: Color = Color::srgb(1.0, 0.0, 1.0);

fn ink_count(frame: &CapturedFrame) -> usize {
    frame.count(|p| p[0] > 200 && p[1] < 60 && p[2] > 200)
}

/// One still hair of `strands` in the two-tone ramp, drawn with `mesh`, no strokes.
fn spawn_locks(
    r: &mut HeadlessRenderer,
    strands: Vec<Vec<Vec3>>,
    mesh: HairMeshSettings,
) -> Entity {
    let ramp = ramps(r).two_tone;
    spawn_still_hair(
        r.app.world_mut(),
        strands,
        ToonHairMaterial { ramp, ..default() },
        mesh,
    )
}

/// Ink pixels of `strands` seen from 3 m with a magenta mass outline (no dilation), with each
/// of `lines` as its lock lines; the frames are saved as `name_{i}`.
fn lock_ink(
    name: &str,
    strands: Vec<Vec<Vec3>>,
    lines: &[Option<LockLines>],
) -> Result<Vec<usize>, Failed> {
    Ok(lock_frames(name, strands, lines)?
        .iter()
        .map(ink_count)
        .collect())
}

/// The frames [`lock_ink`] counts.
fn lock_frames(
    name: &str,
    strands: Vec<Vec<Vec3>>,
    lines: &[Option<LockLines>],
) -> Result<Vec<CapturedFrame>, Failed> {
    let mut r = scene(Vec3::new(0.3, 1.0, 1.0), Vec3::new(0.0, 0.0, 3.0))?;
    spawn_locks(
        &mut r,
        strands,
        HairMeshSettings {
            radius: 0.06,
            taper: QuadraticCurve::constant(1.0),
            hair_resolution: 32,
            shape_resolution: 12,
            mass_normals: 0.0,
            ..default()
        },
    );
    let world = r.app.world_mut();
    let camera = world
        .query_filtered::<Entity, With<Camera3d>>()
        .single(world)?;
    let mut frames = Vec::new();
    for (i, lock_lines) in lines.iter().enumerate() {
        r.app
            .world_mut()
            .entity_mut(camera)
            .insert(ImageSpaceOutline {
                color: INK,
                dilation_x: 0,
                dilation_y: 0,
                lock_lines: *lock_lines,
                ..default()
            });
        let frame = r.capture()?;
        save(&frame, &format!("{name}_{i}"))?;
        frames.push(frame);
    }
    Ok(frames)
}

/// `n + 1` points from `a` to `b`.
fn line(a: Vec3, b: Vec3, n: usize) -> Vec<Vec3> {
    (0..=n).map(|i| a.lerp(b, i as f32 / n as f32)).collect()
}

/// Two locks (strands 0 and 1, two lock ids) crossing, one 0.3 m in front of the other: with
/// lock lines the front lock's edges are inked where the other shows behind them, on top of the
/// mass outline. One strand folded back behind itself (one id) gets none. Lines fade out with
/// the view distance: faded out by 2 m, a lock 3 m away has none.
fn lock_lines_ink_a_lock_over_another_not_a_fold() -> Result<(), Failed> {
    let on = Some(LockLines::default());
    let faded = Some(LockLines {
        fade: Vec2::new(1.0, 2.0),
        ..default()
    });
    let crossed = lock_ink("lock_lines_crossing", crossing(), &[None, on, faded])?;
    // One strand curling once around (15 degrees a segment), coming 0.3 m nearer the camera on
    // the way, so that its end passes in front of its start.
    let fold: Vec<Vec3> = (0..=30)
        .map(|i| {
            let t = i as f32 / 24.0 * std::f32::consts::TAU;
            Vec3::new(-0.4 * t.sin(), -0.4 * t.cos() + 0.01 * t, 0.3 * t / 7.9)
        })
        .collect();
    let folded = lock_ink("lock_lines_fold", vec![fold], &[None, on])?;
    eprintln!(
        "crossing locks: {} ink px without lock lines, {} with, {} faded; a fold: {} without, {} with",
        crossed[0], crossed[1], crossed[2], folded[0], folded[1]
    );
    // The front lock's two edges across the other's width (0.12 m at 3 m: about 10 px each).
    if crossed[1] < crossed[0] + 12 {
        return Err(format!(
            "lock lines added {} ink px where two locks cross",
            crossed[1] as i64 - crossed[0] as i64
        )
        .into());
    }
    if crossed[2] != crossed[0] {
        return Err(format!(
            "faded out, lock lines still drew {} px",
            crossed[2] as i64 - crossed[0] as i64
        )
        .into());
    }
    if folded[1] != folded[0] {
        return Err(format!(
            "a lock folded over itself got {} px of lock lines",
            folded[1] as i64 - folded[0] as i64
        )
        .into());
    }
    Ok(())
}

/// Two locks (strands 0 and 1, two lock ids) crossing, the horizontal one 0.3 m in front.
fn crossing() -> Vec<Vec<Vec3>> {
    vec![
        line(Vec3::new(-0.8, 0.0, 0.3), Vec3::new(0.8, 0.0, 0.3), 8),
        line(Vec3::new(0.0, -0.8, 0.0), Vec3::new(0.0, 0.8, 0.0), 8),
    ]
}

/// `LockLines::hair_tint`: the crossing locks with magenta lock lines, then with lines in the
/// hair's colour. The mass outline stays magenta to the pixel; every pixel the lock lines
/// inked magenta is then in the orange lock's hue (red above green above blue) and darker than
/// the lock beside it in the frame without lines.
fn lock_lines_in_the_hairs_colour_keep_the_outline_ink() -> Result<(), Failed> {
    let tinted = Some(LockLines {
        hair_tint: Some(Color::srgb(0.5, 0.35, 0.35)),
        ..default()
    });
    let frames = lock_frames(
        "lock_lines_tinted",
        crossing(),
        &[None, Some(LockLines::default()), tinted],
    )?;
    let magenta = |p: [u8; 4]| p[0] > 200 && p[1] < 60 && p[2] > 200;
    let luma =
        |p: [u8; 4]| 0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]);
    let (mut outline, mut outline_kept, mut lines, mut in_hue, mut darker) = (0, 0, 0, 0, 0);
    for y in 0..frames[0].height {
        for x in 0..frames[0].width {
            let [plain, inked, tinted] = [0, 1, 2].map(|i| frames[i].pixel(x, y));
            if magenta(plain) {
                outline += 1;
                outline_kept += usize::from(magenta(tinted));
            } else if magenta(inked) {
                lines += 1;
                in_hue += usize::from(tinted[0] > tinted[1] && tinted[1] > tinted[2]);
                darker += usize::from(luma(tinted) < luma(plain) - 20.0);
            }
        }
    }
    eprintln!(
        "tinted lock lines: outline {outline_kept} of {outline} px still magenta; {lines} line px, \
         {in_hue} in the lock's hue, {darker} darker than the lock"
    );
    if outline < 100 || outline_kept != outline {
        return Err(format!("the outline kept its ink on {outline_kept} of {outline} px").into());
    }
    if lines < 12 || in_hue != lines || darker != lines {
        return Err(format!(
            "of {lines} lock line px, {in_hue} are in the lock's hue and {darker} darker than it"
        )
        .into());
    }
    Ok(())
}

/// `ImageSpaceOutline::hair_tint`: two orange locks side by side (left) and a grey box that is
/// not hair (right), with a magenta mass outline (dilation 1), then with the outline in the
/// hair's colour, then the same with MSAA. Every pixel the plain outline inks magenta around
/// the locks is then in the locks' hue (red above green above blue) and darker than the locks'
/// own lit colour, and no pixel there is magenta; the box's outline keeps its magenta to the
/// pixel.
fn the_mass_outline_in_the_hairs_colour_leaves_other_outlines_inked() -> Result<(), Failed> {
    let mut frames = Vec::new();
    for (tint, msaa) in [
        (None, Msaa::Off),
        (Some(Color::srgb(0.45, 0.3, 0.3)), Msaa::Off),
        (Some(Color::srgb(0.45, 0.3, 0.3)), Msaa::Sample4),
    ] {
        let mut r = scene(Vec3::new(0.3, 1.0, 1.0), Vec3::new(0.0, 0.0, 3.0))?;
        spawn_locks(
            &mut r,
            vec![
                line(Vec3::new(-0.75, 0.6, 0.0), Vec3::new(-0.75, -0.6, 0.0), 8),
                line(Vec3::new(-0.45, 0.6, 0.0), Vec3::new(-0.45, -0.6, 0.0), 8),
            ],
            HairMeshSettings {
                radius: 0.1,
                taper: QuadraticCurve::constant(1.0),
                mass_normals: 0.0,
                ..default()
            },
        );
        let world = r.app.world_mut();
        let cube = world
            .resource_mut::<Assets<Mesh>>()
            .add(Cuboid::new(0.5, 0.8, 0.5));
        let grey = world
            .resource_mut::<Assets<StandardMaterial>>()
            .add(StandardMaterial {
                base_color: Color::srgb(0.5, 0.5, 0.5),
                unlit: true,
                ..default()
            });
        world.spawn((
            Mesh3d(cube),
            MeshMaterial3d(grey),
            Transform::from_xyz(0.6, 0.0, 0.0),
        ));
        let camera = world
            .query_filtered::<Entity, With<Camera3d>>()
            .single(world)?;
        world.entity_mut(camera).insert((
            ImageSpaceOutline {
                color: INK,
                hair_tint: tint,
                ..default()
            },
            msaa,
        ));
        let frame = r.capture()?;
        save(
            &frame,
            &format!("mass_outline_hair_colour_{}", frames.len()),
        )?;
        frames.push(frame);
    }
    let magenta = |p: [u8; 4]| p[0] > 200 && p[1] < 60 && p[2] > 200;
    let luma =
        |p: [u8; 4]| 0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]);
    let orange = |p: [u8; 4]| p[0] > p[1] && p[1] > p[2];
    let half = frames[0].width / 2;
    // The locks' own lit colour: the brightest orange of the plain frame.
    let mut lit = 0.0f32;
    for y in 0..frames[0].height {
        for x in 0..half {
            let p = frames[0].pixel(x, y);
            if orange(p) && !magenta(p) {
                lit = lit.max(luma(p));
            }
        }
    }
    let mut report = Vec::new();
    let mut wrong = Vec::new();
    for (i, frame) in frames.iter().enumerate().skip(1) {
        let (mut hair_line, mut in_hue, mut darker, mut still_magenta) = (0, 0, 0, 0);
        let (mut box_line, mut box_kept) = (0, 0);
        for y in 0..frame.height {
            for x in 0..frame.width {
                let (plain, tinted) = (frames[0].pixel(x, y), frame.pixel(x, y));
                if x < half {
                    still_magenta += usize::from(magenta(tinted));
                    if magenta(plain) {
                        hair_line += 1;
                        in_hue += usize::from(orange(tinted));
                        darker += usize::from(luma(tinted) < lit - 40.0);
                    }
                } else if magenta(plain) {
                    box_line += 1;
                    box_kept += usize::from(tinted == plain || magenta(tinted));
                }
            }
        }
        report.push(format!(
            "frame {i}: {hair_line} line px around the locks, {in_hue} in their hue, {darker} \
             darker than their lit {lit:.0}, {still_magenta} magenta; the box's {box_line} line \
             px, {box_kept} magenta"
        ));
        // With MSAA the ink's edge pixels blend with what is under them: the hue is checked
        // where the plain frame (no MSAA) inks, which is where the line's core lies.
        let need = if i == 1 {
            hair_line
        } else {
            hair_line * 9 / 10
        };
        if hair_line < 200 || in_hue < need || darker < need || (i == 1 && still_magenta > 0) {
            wrong.push(format!("frame {i}: around the locks"));
        }
        let box_need = if i == 1 { box_line } else { box_line * 9 / 10 };
        if box_line < 200 || box_kept < box_need {
            wrong.push(format!("frame {i}: the box's outline"));
        }
    }
    eprintln!("mass outline in the hair's colour: {}", report.join("; "));
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(format!("{}: {}", wrong.join(", "), report.join("; ")).into())
    }
}

/// The ring of `sides` vertices half way along strand `strand` of the hair's mesh.
fn middle_ring(positions: &[[f32; 3]], computed: &ComputedHairMesh, strand: usize) -> Vec<Vec3> {
    let per = computed.vertices_per_strand();
    let sides = computed.topology.sides();
    let ring = computed.topology.rings() / 2;
    let start = strand * per + ring * sides;
    positions[start..start + sides]
        .iter()
        .map(|p| Vec3::from_array(*p))
        .collect()
}

/// Corners of a closed polygon: vertices where the outline turns by more than 10 degrees.
fn corners(ring: &[Vec3]) -> usize {
    let n = ring.len();
    (0..n)
        .filter(|&i| {
            let a = (ring[i] - ring[(i + n - 1) % n]).normalize();
            let b = (ring[(i + 1) % n] - ring[i]).normalize();
            a.dot(b) < 10f32.to_radians().cos()
        })
        .count()
}

/// Two vertical strands side by side in one hair, roots at `x = -0.5` and `+0.5`: the hair is a
/// flat ribbon (thickness 0.3 of its width), the first strand a triangle by
/// `HairStrandSections`. The locks lie on the mass, so their thin side faces out of the groom's
/// centre (along X) and their width runs along Z; the shape resolution of 8 becomes 12 so both
/// the triangle's and the ribbon's corners get vertices. Seen from the front (down Z), both are
/// narrow; the picture is saved.
fn locks_take_their_section_per_hair_and_per_strand() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.3, 1.0, 1.0), Vec3::new(0.0, 0.0, 3.0))?;
    // The CPU's tubes, read back here (gpu_tubes_render compares the GPU's with them).
    r.app.insert_resource(HairMeshBuilder::Cpu);
    let strands: Vec<Vec<Vec3>> = [-0.5f32, 0.5]
        .iter()
        .map(|&x| {
            (0..6)
                .map(|i| Vec3::new(x, -0.5 + i as f32 * 0.2, 0.0))
                .collect()
        })
        .collect();
    let radius = 0.1;
    let hair = spawn_locks(
        &mut r,
        strands,
        HairMeshSettings {
            radius,
            taper: QuadraticCurve::constant(1.0),
            shape_resolution: 8,
            section: LockSection::Ribbon,
            section_aspect: 0.3,
            mass_normals: 0.0,
            ..default()
        },
    );
    r.app
        .world_mut()
        .entity_mut(hair)
        .insert(HairStrandSections(vec![LockSection::Triangle]));
    let frame = r.capture()?;
    save(&frame, "locks_front")?;
    let world = r.app.world();
    let computed = world
        .get::<ComputedHairMesh>(hair)
        .ok_or("the hair has no mesh")?
        .clone();
    let mesh = world
        .resource::<Assets<Mesh>>()
        .get(&computed.mesh)
        .ok_or("the hair's mesh is missing")?;
    let positions = mesh
        .attribute(Mesh::ATTRIBUTE_POSITION)
        .and_then(|a| a.as_float3())
        .ok_or("the hair's mesh has no positions")?;
    let sides = computed.topology.sides();
    eprintln!("{sides} sides a ring");
    if sides != 12 {
        return Err(format!(
            "shape resolution 8 with triangles and ribbons gave {sides} sides, not 12"
        )
        .into());
    }
    let triangle = middle_ring(positions, &computed, 0);
    let ribbon = middle_ring(positions, &computed, 1);
    let extent = |ring: &[Vec3], axis: Vec3| {
        let d: Vec<f32> = ring.iter().map(|p| p.dot(axis)).collect();
        d.iter().copied().fold(f32::MIN, f32::max) - d.iter().copied().fold(f32::MAX, f32::min)
    };
    let (thin, wide) = (extent(&ribbon, Vec3::X), extent(&ribbon, Vec3::Z));
    let centre = |ring: &[Vec3]| ring.iter().sum::<Vec3>() / ring.len() as f32;
    eprintln!(
        "ribbon: {} corners, {thin:.4} thick (X) x {wide:.4} wide (Z); triangle: {} corners, \
         ridge {:.4} out, base {:.4} in",
        corners(&ribbon),
        corners(&triangle),
        triangle
            .iter()
            .map(|p| -(p.x - -0.5))
            .fold(f32::MIN, f32::max),
        triangle.iter().map(|p| p.x - -0.5).fold(f32::MIN, f32::max),
    );
    if corners(&ribbon) != 4
        || (wide - 2.0 * radius).abs() > 1e-3
        || (thin - 0.6 * radius).abs() > 1e-3
    {
        return Err(format!(
            "the ribbon is {} corners, {thin} thick along X and {wide} wide along Z \
             (expected 4, {} and {})",
            corners(&ribbon),
            0.6 * radius,
            2.0 * radius
        )
        .into());
    }
    // The left strand's way out of the groom's centre is -X: the ridge points there, the base
    // lies toward the centre.
    let ridge = triangle.iter().map(|p| -0.5 - p.x).fold(f32::MIN, f32::max);
    let base = triangle.iter().map(|p| p.x + 0.5).fold(f32::MIN, f32::max);
    if corners(&triangle) != 3
        || (ridge - 0.3 * radius).abs() > 1e-3
        || (base - 0.15 * radius).abs() > 1e-3
    {
        return Err(format!(
            "the triangle has {} corners, its ridge {ridge} out and base {base} in",
            corners(&triangle)
        )
        .into());
    }
    if (centre(&ribbon).xz() - Vec2::new(0.5, 0.0)).length() > 1e-3 {
        return Err(format!("the ribbon's ring is centred at {}", centre(&ribbon)).into());
    }
    // Seen from the front both locks show their thin side: a few pixels wide, not the tube's
    // diameter.
    let row = frame.height / 2;
    let runs: Vec<u32> = [0..frame.width / 2, frame.width / 2..frame.width]
        .into_iter()
        .map(|xs| xs.filter(|&x| frame.pixel(x, row) != BACKGROUND).count() as u32)
        .collect();
    let diameter_px = {
        // The camera's vertical field of view is Bevy's default, 45 degrees, at distance 3.
        let focal = frame.height as f32 * 0.5 / (std::f32::consts::FRAC_PI_8).tan();
        2.0 * radius * focal / 3.0
    };
    eprintln!("widths on screen {runs:?} px; a round tube would be {diameter_px:.1} px");
    if runs.iter().any(|&w| w == 0 || w as f32 > 0.6 * diameter_px) {
        return Err(format!(
            "the locks are {runs:?} px wide seen edge on; a tube is {diameter_px:.1}"
        )
        .into());
    }
    Ok(())
}
