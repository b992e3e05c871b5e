use super::*;
use bevy::prelude::*;

fn err(result: Result<impl std::fmt::Debug, HairAssetError>) -> HairAssetError {
    result.expect_err("bad input must be refused")
}

const GOOD: &str = r#"<?xml version="1.0"?>
<groom version="1" units="meters" scale="10" bone="head">
  <strand>0 0 0  0 1 0  0 2 0</strand>
  <strand>1 0 0  1 1 0</strand>
</groom>"#;

#[test]
fn groom_reads_strands_and_divides_by_scale() {
    let g = parse_groom("g.hair.xml", GOOD).unwrap();
    assert_eq!(g.bone, "head");
    assert_eq!(g.strand_count(), 2);
    assert_eq!(
        g.strand(0),
        &[
            Vec3::ZERO,
            Vec3::new(0.0, 0.1, 0.0),
            Vec3::new(0.0, 0.2, 0.0)
        ]
    );
    assert_eq!(g.strand(1).len(), 2);
    assert_eq!(g.offsets, vec![0, 3, 5]);
}

#[test]
fn malformed_xml_names_file_line_and_column() {
    let e = err(parse_groom(
        "bad.hair.xml",
        "<groom version=\"1\">\n  <strand>0 0 0</grom>",
    ));
    assert_eq!(e.file.as_deref(), Some("bad.hair.xml"));
    assert_eq!(e.line, 2);
    assert!(e.column > 1, "{e}");
    assert!(e.to_string().starts_with("bad.hair.xml:2:"), "{e}");
    assert!(e.message.contains("</grom> closes <strand>"), "{e}");
}

#[test]
fn nan_and_infinite_numbers_are_located() {
    let text = "<groom version=\"1\">\n<strand>0 0 0\n 0 NaN 1</strand></groom>";
    let e = err(parse_groom("n.hair.xml", text));
    assert_eq!((e.line, e.column), (3, 4), "{e}");
    assert!(
        e.message.contains("strand 0, particle 1") && e.message.contains("NaN"),
        "{e}"
    );
    let e = err(parse_groom(
        "i.hair.xml",
        "<groom version=\"1\"><strand>0 0 0 0 inf 1</strand></groom>",
    ));
    assert!(e.message.contains("infinite"), "{e}");
    let e = err(parse_groom(
        "x.hair.xml",
        "<groom version=\"1\"><strand>0 0 0 0 abc 1</strand></groom>",
    ));
    assert!(e.message.contains("not a number"), "{e}");
}

#[test]
fn missing_and_non_numeric_attributes_are_refused() {
    let e = err(parse_groom(
        "v.hair.xml",
        "<groom><strand>0 0 0 0 1 0</strand></groom>",
    ));
    assert!(e.message.contains("version"), "{e}");
    let e = err(parse_groom(
        "v.hair.xml",
        "<groom version=\"7\"><strand>0 0 0 0 1 0</strand></groom>",
    ));
    assert!(e.message.contains("unsupported format version"), "{e}");
    let e = err(parse_groom(
        "s.hair.xml",
        "<groom version=\"1\" scale=\"big\"><strand>0 0 0 0 1 0</strand></groom>",
    ));
    assert!(
        e.message.contains("scale") && e.message.contains("not a number"),
        "{e}"
    );
    let e = err(parse_groom(
        "s.hair.xml",
        "<groom version=\"1\" scale=\"0\"><strand>0 0 0 0 1 0</strand></groom>",
    ));
    assert!(e.message.contains("scale must lie between"), "{e}");
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\">\n<sphere x=\"0\" y=\"0\" r=\"1\"/></collision>",
    ));
    assert!(
        e.message.contains("missing the attribute `z`") && e.line == 2,
        "{e}"
    );
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\"><sphere x=\"0\" y=\"0\" z=\"q\" r=\"1\"/></collision>",
    ));
    assert!(e.message.contains("`z`"), "{e}");
    let e = err(parse_groom("r.hair.xml", "<hair version=\"1\"/>"));
    assert!(e.message.contains("expected a <groom>"), "{e}");
}

#[test]
fn degenerate_strands_are_refused() {
    let e = err(parse_groom(
        "one.hair.xml",
        "<groom version=\"1\"><strand>0 0 0</strand></groom>",
    ));
    assert!(e.message.contains("at least 2"), "{e}");
    let e = err(parse_groom(
        "empty.hair.xml",
        "<groom version=\"1\"><strand></strand></groom>",
    ));
    assert!(e.message.contains("at least 2"), "{e}");
    let e = err(parse_groom(
        "none.hair.xml",
        "<groom version=\"1\"></groom>",
    ));
    assert!(e.message.contains("no <strand>"), "{e}");
    let e = err(parse_groom(
        "odd.hair.xml",
        "<groom version=\"1\"><strand>0 0 0 1 1</strand></groom>",
    ));
    assert!(e.message.contains("multiple of 3"), "{e}");
    let e = err(parse_groom(
        "zero.hair.xml",
        "<groom version=\"1\">\n<strand>0 0 0 0 1 0 0 1 0</strand></groom>",
    ));
    assert!(
        e.message.contains("particles 1 and 2 coincide") && e.line == 2,
        "{e}"
    );
}

#[test]
fn counts_above_the_limits_are_refused() {
    let mut long = String::from("<groom version=\"1\"><strand>");
    for i in 0..=MAX_PARTICLES_PER_STRAND {
        long.push_str(&format!("0 {i} 0 "));
    }
    long.push_str("</strand></groom>");
    let e = err(parse_groom("long.hair.xml", &long));
    assert!(e.message.contains("more than 256 particles"), "{e}");
    // Many strands: refused at the limit without reading the rest.
    let strand = "<strand>0 0 0 0 1 0</strand>";
    let many = format!(
        "<groom version=\"1\">{}</groom>",
        strand.repeat(MAX_STRANDS + 1)
    );
    let e = err(parse_groom("many.hair.xml", &many));
    let says = format!("more than {MAX_STRANDS} strands");
    assert!(e.message.contains(&says), "{e}");
    // Shapes of every kind count together toward the limit.
    let pair = "<sphere x=\"0\" y=\"0\" z=\"0\" r=\"1\"/>\
                <capsule x0=\"0\" y0=\"0\" z0=\"0\" x1=\"0\" y1=\"1\" z1=\"0\" r=\"1\"/>";
    let shapes =
        pair.repeat(MAX_SHAPES / 2) + "<plane x=\"0\" y=\"0\" z=\"0\" nx=\"0\" ny=\"1\" nz=\"0\"/>";
    let e = err(parse_collision(
        "c.collision.xml",
        &format!("<collision version=\"1\">{shapes}</collision>"),
    ));
    assert!(e.message.contains("more than 4096 shapes"), "{e}");
}

#[test]
fn collision_reads_spheres_and_refuses_bad_radii() {
    let c = parse_collision(
        "c.collision.xml",
        "<collision version=\"1\" scale=\"2\" bone=\"head\"><sphere x=\"0\" y=\"2\" z=\"0\" r=\"0.5\"/></collision>",
    )
    .unwrap();
    assert_eq!(c.bone, "head");
    assert_eq!(
        c.spheres,
        vec![CollisionSphere {
            center: Vec3::new(0.0, 1.0, 0.0),
            radius: 0.25
        }]
    );
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\"><sphere x=\"0\" y=\"0\" z=\"0\" r=\"-1\"/></collision>",
    ));
    assert!(e.message.contains("radius must be greater than 0"), "{e}");
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\"/>",
    ));
    assert!(e.message.contains("no <sphere>"), "{e}");
}

#[test]
fn collision_reads_capsules_and_planes_and_refuses_bad_ones() {
    let c = parse_collision(
        "c.collision.xml",
        "<collision version=\"1\" scale=\"2\" bone=\"head\">\n\
         <capsule x0=\"0\" y0=\"2\" z0=\"0\" x1=\"2\" y1=\"2\" z1=\"0\" r=\"0.5\"/>\n\
         <plane x=\"0\" y=\"-2\" z=\"0\" nx=\"0\" ny=\"3\" nz=\"0\"/>\n\
         </collision>",
    )
    .unwrap();
    assert!(c.spheres.is_empty());
    assert_eq!(
        c.capsules,
        vec![CollisionCapsule {
            a: Vec3::new(0.0, 1.0, 0.0),
            b: Vec3::new(1.0, 1.0, 0.0),
            radius: 0.25
        }]
    );
    assert_eq!(
        c.planes,
        vec![CollisionPlane {
            point: Vec3::new(0.0, -1.0, 0.0),
            normal: Vec3::Y,
        }]
    );
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\">\n<capsule x0=\"0\" y0=\"0\" z0=\"0\" x1=\"0\" y1=\"0\" z1=\"0\" r=\"0\"/></collision>",
    ));
    assert!(
        e.message
            .contains("capsule 0: radius must be greater than 0")
            && e.line == 2,
        "{e}"
    );
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\">\n\n<plane x=\"0\" y=\"0\" z=\"0\" nx=\"0\" ny=\"0\" nz=\"0\"/></collision>",
    ));
    assert!(
        e.message.contains("plane 0: the normal") && e.line == 3,
        "{e}"
    );
    // A missing coordinate names the attribute.
    let e = err(parse_collision(
        "c.collision.xml",
        "<collision version=\"1\"><capsule x0=\"0\" y0=\"0\" z0=\"0\" x1=\"0\" y1=\"1\" r=\"1\"/></collision>",
    ));
    assert!(e.message.contains("z1"), "{e}");
}

#[test]
fn animation_description_checks_times() {
    let d = parse_animation(
        "a.hairanim.xml",
        "<hairanim version=\"1\"><key time=\"0\" groom=\"a.hair.xml\"/><key time=\"0.5\" groom=\"b.hair.xml\"/></hairanim>",
    )
    .unwrap();
    assert_eq!(d.keys.len(), 2);
    assert!(d.looping);
    assert_eq!(d.duration, 1.0);
    let e = err(parse_animation(
        "a.hairanim.xml",
        "<hairanim version=\"1\"><key time=\"1\" groom=\"a\"/>\n<key time=\"1\" groom=\"b\"/></hairanim>",
    ));
    assert!(e.message.contains("must increase") && e.line == 2, "{e}");
    let e = err(parse_animation(
        "a.hairanim.xml",
        "<hairanim version=\"1\"><key time=\"0\"/></hairanim>",
    ));
    assert!(e.message.contains("groom"), "{e}");
    let e = err(parse_animation(
        "a.hairanim.xml",
        "<hairanim version=\"1\" duration=\"0.1\"><key time=\"0\" groom=\"a\"/><key time=\"1\" groom=\"b\"/></hairanim>",
    ));
    assert!(e.message.contains("duration"), "{e}");
    let e = err(parse_animation(
        "a.hairanim.xml",
        "<hairanim version=\"1\"></hairanim>",
    ));
    assert!(e.message.contains("no <key>"), "{e}");
}

fn pose(offset: f32, lens: &[usize]) -> HairGroom {
    HairGroom::from_strands(
        "head",
        lens.iter()
            .map(|&n| (0..n).map(|i| Vec3::new(offset, i as f32, 0.0)).collect()),
    )
    .unwrap()
}

#[test]
fn mismatched_keyframes_are_refused_not_crashed() {
    let keys = vec![
        HairKeyframe {
            time: 0.0,
            pose: pose(0.0, &[3, 4]),
        },
        HairKeyframe {
            time: 1.0,
            pose: pose(1.0, &[3, 5]),
        },
    ];
    let e = err(HairAnimation::new(keys, true, 2.0));
    assert!(
        e.message
            .contains("strand 1 has 5 particles, the base groom has 4"),
        "{e}"
    );
    let keys = vec![
        HairKeyframe {
            time: 0.0,
            pose: pose(0.0, &[3, 4]),
        },
        HairKeyframe {
            time: 1.0,
            pose: pose(1.0, &[3]),
        },
    ];
    let e = err(HairAnimation::new(keys, true, 2.0));
    assert!(e.message.contains("has 1 strands"), "{e}");
}

#[test]
fn spline_passes_through_keys_and_is_smooth() {
    let keys: Vec<_> = [0.0, 1.0, 3.0, 4.0]
        .iter()
        .enumerate()
        .map(|(i, &t)| HairKeyframe {
            time: t,
            pose: pose(i as f32 * i as f32, &[2]),
        })
        .collect();
    for looping in [true, false] {
        let anim = HairAnimation::new(keys.clone(), looping, 5.0).unwrap();
        let mut out = [Vec3::ZERO; 2];
        for (i, k) in anim.keys.iter().enumerate() {
            anim.sample(k.time, &mut out);
            assert!((out[0].x - (i * i) as f32).abs() < 1e-5, "key {i}: {out:?}");
        }
        // Weights sum to one everywhere, and the curve is continuous at a key.
        let mut w = [(0, 0.0); 4];
        for step in 0..100 {
            let t = step as f32 * 0.07;
            let n = anim.weights(t, &mut w);
            let sum: f32 = w[..n].iter().map(|(_, w)| w).sum();
            assert!((sum - 1.0).abs() < 1e-5, "t={t}: {w:?}");
        }
        let (mut a, mut b) = ([Vec3::ZERO; 2], [Vec3::ZERO; 2]);
        anim.sample(1.0 - 1e-3, &mut a);
        anim.sample(1.0 + 1e-3, &mut b);
        assert!((a[0].x - b[0].x).abs() < 0.02, "jump at a key: {a:?} {b:?}");
        // Not linear: halfway between keys 1 (x=1) and 2 (x=4) the spline differs from 2.5.
        anim.sample(2.0, &mut a);
        assert!((a[0].x - 2.5).abs() > 0.01, "{a:?}");
    }
    // Looping wraps smoothly back to key 0 by the end of the period.
    let anim = HairAnimation::new(keys.clone(), true, 5.0).unwrap();
    let mut out = [Vec3::ZERO; 2];
    anim.sample(5.0 - 1e-4, &mut out);
    assert!(out[0].x.abs() < 0.01, "{out:?}");
    // Without looping, the last key holds.
    let anim = HairAnimation::new(keys, false, 5.0).unwrap();
    anim.sample(100.0, &mut out);
    assert!((out[0].x - 9.0).abs() < 1e-5);
}
