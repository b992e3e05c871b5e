//! Unit tests of the solver's passes that reach into a batch: the sphere pass lane by lane,
//! the stretch limit row by row.

use super::*;

/// The sphere pass, lane by lane: a particle inside goes onto the sphere grown by its lane's
/// margin along the line from the centre, one at the centre straight up, one outside or on
/// the surface keeps its bits; previous positions and the other particles are left alone.
#[test]
fn sphere_pass_pushes_each_lane_alone() {
    let chain: Vec<Vec3> = (0..8)
        .map(|k| Vec3::new(0.0, -0.1 * k as f32, 0.0))
        .collect();
    let chains = [chain.as_slice(); 4];
    let margins = [0.0, 0.0, 0.0, 0.1];
    let mut batch = Batch::new(&[0, 1, 2, 3], &chains, &[], &margins);
    batch.reset(&Affine3A::IDENTITY);
    let (centre, radius) = (Vec3A::new(1.0, 2.0, 3.0), 0.5);
    // Particle 2, the second free one.
    let node = 5;
    let placed = [
        // Inside, off the centre.
        Vec3::new(1.1, 2.05, 2.9),
        // At the centre.
        Vec3::new(1.0, 2.0, 3.0),
        // Outside.
        Vec3::new(1.0, 2.7, 3.0),
        // On the sphere, inside the sphere grown by the lane's margin of 0.1.
        Vec3::new(1.0, 2.0, 3.5),
    ];
    for (l, p) in placed.iter().enumerate() {
        batch.set_particle(l, 2, *p);
    }
    let before = batch.clone();
    batch.collide_spheres(&[(centre, radius)], &[], 0.0);
    let pushed = |l: usize| get3(&batch.nodes[node].x, l);
    // Along the line from the centre, at the grown radius.
    let d = placed[0] - Vec3::from(centre);
    assert!(((pushed(0) - Vec3::from(centre)).length() - radius).abs() < 1e-6);
    assert!(
        (pushed(0) - Vec3::from(centre))
            .normalize()
            .dot(d.normalize())
            > 1.0 - 1e-6
    );
    assert_eq!(pushed(1), Vec3::new(1.0, 2.5, 3.0));
    assert_eq!(
        pushed(2).to_array().map(f32::to_bits),
        placed[2].to_array().map(f32::to_bits)
    );
    assert!(((pushed(3) - Vec3::from(centre)).length() - 0.6).abs() < 1e-6);
    assert!((pushed(3) - Vec3::new(1.0, 2.0, 3.6)).length() < 1e-6);
    for (k, (a, b)) in batch.nodes.iter().zip(&before.nodes).enumerate() {
        assert_eq!(a.p, b.p, "node {k}'s previous position moved");
        if k != node {
            assert_eq!(a.x, b.x, "node {k} moved");
        }
    }
}

/// The stretch limit looks at a row's lengths squared first: a batch at rest is clearly
/// within and reports nothing moved (so the collisions after the limits are skipped); a lane
/// stretched past the limit is pulled back onto it, reported, and the other lanes keep
/// their places.
#[test]
fn stretch_limit_pulls_only_what_is_past_it_and_says_so() {
    let chain: Vec<Vec3> = (0..8)
        .map(|k| Vec3::new(0.0, -0.1 * k as f32, 0.0))
        .collect();
    let mut points = Vec::new();
    build_chain(&chain, 0.5, None, &mut points);
    let chains = [points.as_slice(); 4];
    let mut batch = Batch::new(&[0, 1, 2, 3], &chains, &[], &[0.0; 4]);
    batch.reset(&Affine3A::IDENTITY);
    let at_rest = batch.clone();
    assert!(
        !batch.limit_stretch(1.1, false),
        "a batch at rest was pulled"
    );
    for (a, b) in batch.nodes.iter().zip(&at_rest.nodes) {
        assert_eq!((a.x, a.p), (b.x, b.p));
    }
    // Lane 1's last particle half again as far from the one before as at rest.
    let last = batch.nodes.len() - 1;
    let (before, tip) = (
        get3(&batch.nodes[last - 2].x, 1),
        get3(&batch.nodes[last].x, 1),
    );
    set3(&mut batch.nodes[last].x, 1, before + (tip - before) * 1.5);
    let stretched = batch.clone();
    assert!(
        batch.limit_stretch(1.1, false),
        "a stretched lane was not pulled"
    );
    let rest = batch.nodes[last].rest[1][1];
    let now = get3(&batch.nodes[last].x, 1).distance(get3(&batch.nodes[last - 2].x, 1));
    assert!(now <= 1.1 * rest * (1.0 + 1e-5), "{now} past 1.1 x {rest}");
    assert!(now > 1.05 * rest, "{now}: pulled further than the limit");
    for (k, (a, b)) in batch.nodes.iter().zip(&stretched.nodes).enumerate() {
        for l in [0, 2, 3] {
            assert_eq!(get3(&a.x, l), get3(&b.x, l), "lane {l} node {k} moved");
        }
    }
}

/// A bone chain's frame of four 240 Hz substeps at rest under the identity bone: stiff edges,
/// bending springs of `bend` (`inf` = loose), no torsion, no anchors, `gravity` in m/s^2.
fn particles_only_frame(nodes: usize, bend: f32, gravity: Vec3) -> StepInput {
    let h = 1.0 / 240.0;
    StepInput {
        h,
        bones: vec![Affine3A::IDENTITY; 4],
        gravity_h2: gravity * h * h,
        damping: 0.98,
        alpha: [0.0, bend, f32::INFINITY],
        anchor_factor: vec![0.0; nodes],
        style_limit: f32::INFINITY,
        max_stretch: f32::INFINITY,
        particles_only: true,
        ..Default::default()
    }
}

/// One lane's batch of `points` (build_chain's structure), at rest under the identity bone.
fn one_chain(points: &[Vec3]) -> Batch {
    let mut nodes = Vec::new();
    build_chain(points, 0.5, None, &mut nodes);
    let mut batch = Batch::new(&[0], &[nodes.as_slice()], &[], &[0.0]);
    batch.reset(&Affine3A::IDENTITY);
    batch
}

/// Bone chains' particles alone: the bending springs between every other particle hold a
/// styled bend under gravity (without them the arm hangs down), and each structural node ends
/// the frame at its styled offset from the middle of its segment, at rest.
#[test]
fn particles_only_bending_springs_hold_a_bend_and_the_structure_follows() {
    // Down two segments, then out along +X two: a right angle at particle 2.
    let points = [
        Vec3::ZERO,
        Vec3::new(0.0, -0.1, 0.0),
        Vec3::new(0.0, -0.2, 0.0),
        Vec3::new(0.1, -0.2, 0.0),
        Vec3::new(0.2, -0.2, 0.0),
    ];
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let angle_at_2 = |bend: f32| {
        let mut batch = one_chain(&points);
        let input = particles_only_frame(batch.nodes.len(), bend, gravity);
        for _ in 0..60 {
            batch.step_with(&input, &input.anchor_factor);
        }
        let p = |i| batch.particle(0, i);
        let turn = (p(2) - p(1)).angle_between(p(3) - p(2)).to_degrees();
        (turn, batch)
    };
    let (held, batch) = angle_at_2(0.0);
    let (loose, _) = angle_at_2(f32::INFINITY);
    println!(
        "particles only, styled 90 degree bend after 1 s of gravity: {held} held, {loose} loose"
    );
    assert!(
        (held - 90.0).abs() < 10.0,
        "stiff bending springs let the bend go to {held}"
    );
    assert!(loose < 45.0, "loose, the arm should hang: {loose} degrees");
    // The structure: placed once a frame from the particles.
    for k in (PINNED + 1..batch.nodes.len() - 1).step_by(2) {
        let (x, before, after) = (
            get3(&batch.nodes[k].x, 0),
            get3(&batch.nodes[k - 1].x, 0),
            get3(&batch.nodes[k + 1].x, 0),
        );
        let styled = get3(&batch.local[k], 0)
            - 0.5 * (get3(&batch.local[k - 1], 0) + get3(&batch.local[k + 1], 0));
        assert!(
            (x - (0.5 * (before + after) + styled)).length() < 1e-5,
            "structural node {k} at {x}"
        );
        assert_eq!(
            batch.nodes[k].x, batch.nodes[k].p,
            "structural node {k} moving"
        );
    }
}

/// A bone chain's first bone, loose (no bending springs), swings freely whichever way gravity
/// pulls it, as a VRM joint of no stiffness does: nothing pins it to a cone about a structural
/// point.
#[test]
fn particles_only_a_loose_first_bone_swings_every_way() {
    let points: Vec<Vec3> = (0..4)
        .map(|k| Vec3::new(0.0, -0.1 * k as f32, 0.0))
        .collect();
    for side in [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z] {
        let mut batch = one_chain(&points);
        let input = particles_only_frame(batch.nodes.len(), f32::INFINITY, side * 9.81);
        for _ in 0..120 {
            batch.step_with(&input, &input.anchor_factor);
        }
        let first = batch.particle(0, 1) - batch.particle(0, 0);
        let swung = first.angle_between(Vec3::NEG_Y).to_degrees();
        let toward = first.normalize().dot(side);
        assert!(
            swung > 80.0 && toward > 0.95,
            "gravity along {side}: the first bone swung {swung} degrees, {toward} along it"
        );
    }
}
