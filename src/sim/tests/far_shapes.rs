//! A batch skips a collider none of its particles is near ([`ParticleSpan`]), and still meets
//! one a push moved a particle into.

use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use super::super::solver::{Contact, ContactShape, LANES, StepInput};
use super::random_strands;
use crate::test_support::Rng;

/// Two lanes of four particles hung far below and to the left; lane 0's last particle set
/// beside two spheres: inside the first, with the second just above it and out of reach of every
/// particle when the substep's contacts begin. The first pushes the particle up into the
/// second, which must push it out again though the batch was far from it at first.
#[test]
fn a_particle_pushed_toward_a_shape_the_batch_was_far_from_is_kept_out_of_it() {
    let far = Affine3A::from_translation(Vec3::new(-5.0, -5.0, 0.0));
    let mut batch = random_strands(&mut Rng(7), 4, 2, 0);
    batch.reset(&far);
    let start = Vec3::new(1.0, -0.008, 0.0);
    batch.set_particle(0, 3, start);
    let contact = |centre: Vec3, radius: f32| {
        Contact::new(
            ContactShape::Sphere {
                centre: centre.into(),
                radius,
            },
            false,
            Vec3A::ZERO,
            0.01,
        )
    };
    let (below, above) = (
        contact(Vec3::new(1.0, -0.018, 0.0), 0.02),
        contact(Vec3::new(1.0, 0.035, 0.0), 0.03),
    );
    // What the test is about: every particle is below the upper sphere's reach at first, and
    // the lower sphere's push (out to its radius plus the lanes' 5 mm margin) lands inside it.
    let margin = 0.005;
    batch.margin = [margin; LANES];
    assert!(batch.particle_span().apart(above.reach.0, above.reach.1));
    assert!(!batch.particle_span().apart(below.reach.0, below.reach.1));
    let pushed = -0.018 + 0.02 + margin;
    assert!(
        0.035 - pushed < 0.03,
        "the push ends inside the upper sphere"
    );
    // One substep against the two spheres alone: no springs, no gravity, no limits.
    let input = StepInput {
        h: 1.0 / 240.0,
        bones: vec![far],
        contacts: vec![below, above],
        contact_count: 2,
        alpha: [f32::INFINITY; 3],
        style_limit: f32::INFINITY,
        ..default()
    };
    batch.step(&input);
    let p = batch.particle(0, 3);
    let from_above = p.distance(Vec3::new(1.0, 0.035, 0.0));
    assert!(
        from_above >= 0.03 + margin - 1e-5,
        "the particle ended {from_above} m from the upper sphere's centre (radius 0.03, margin \
         {margin}): pushed into it and left there ({p})"
    );
    // It was pushed up and back down, not sideways; the other lane never came near.
    assert!((p.x - 1.0).abs() < 1e-6 && p.z.abs() < 1e-6, "{p}");
    assert!(p.y < pushed - 1e-4, "the upper sphere pushed it down: {p}");
    assert!(batch.particle(1, 3).distance(Vec3::new(-5.0, -5.0, 0.0)) < 0.5);
}

/// The same for segment collision: a segment lifted off one sphere into a second that the whole
/// batch was out of reach of is still kept off the second.
#[test]
fn a_segment_lifted_toward_a_shape_the_batch_was_far_from_is_kept_off_it() {
    let mut batch = random_strands(&mut Rng(11), 4, 2, 0);
    batch.reset(&Affine3A::from_translation(Vec3::new(-5.0, -5.0, 0.0)));
    let margin = 0.005;
    batch.margin = [margin; LANES];
    // Lane 0 along a line 2 cm above the first sphere's centre: its last segment, 6 cm long,
    // dips 5 mm into the sphere's reach with both ends outside it.
    for (i, x) in [-0.3, -0.2, -0.03, 0.03].into_iter().enumerate() {
        batch.set_particle(0, i, Vec3::new(x, 0.02, 0.0));
    }
    let (low, high) = (Vec3::ZERO, Vec3::new(0.0, 0.048, 0.0));
    // The upper sphere's reach (radius 2 cm and the margin) starts above every particle; the
    // segment lifted out of the lower one's reach (to 2.5 cm) dips into it.
    let reach = 0.02 + margin;
    assert!(
        batch
            .particle_span()
            .apart(Vec3A::from(high) - reach, Vec3A::from(high) + reach)
    );
    assert!(high.y - (low.y + reach) < reach);
    let input = StepInput {
        spheres: vec![(low.into(), 0.02), (high.into(), 0.02)],
        sphere_count: 2,
        ..default()
    };
    let mut span = batch.particle_span();
    batch.collide_segments(&input, 0, &mut span);
    let (a, b) = (batch.particle(0, 2), batch.particle(0, 3));
    // Both ends moved alike: the segment's middle is nearest the spheres' centres.
    let middle = (a + b) / 2.0;
    assert!(middle.x.abs() < 1e-6 && (a.y - b.y).abs() < 1e-6, "{a} {b}");
    assert!(
        middle.distance(high) >= reach - 1e-5,
        "the segment ended {} m from the upper sphere's centre (reach {reach}): lifted into it \
         and left there ({a} - {b})",
        middle.distance(high)
    );
    assert!(
        middle.y < low.y + reach - 1e-4,
        "the upper sphere pushed it down: {middle}"
    );
}
