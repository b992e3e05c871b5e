//! Writing the frame out: each hair's strands written by the thread that stepped it, and by the
//! pass after the step when its strand list is not the strands as they were built.

use bevy::prelude::*;

use super::*;

/// Checks every strand of `hair` holds the particles its solver state holds now; returns how
/// many particles it compared.
fn particles_checked(app: &App, hair: Entity) -> usize {
    let world = app.world();
    let computed = world.get::<ComputedHair>(hair).unwrap();
    let mut checked = 0;
    for e in world.get::<HairStrands>(hair).unwrap().iter() {
        let s = world.get::<Strand>(e).unwrap().index as usize;
        let particles = &world.get::<StrandParticles>(e).unwrap().positions;
        assert_eq!(
            particles.len(),
            6,
            "strand {s} of {hair} has all its particles"
        );
        for (i, p) in particles.iter().enumerate() {
            assert_eq!(
                *p,
                computed.particle(s, i),
                "strand {s} particle {i} of {hair} is this frame's"
            );
            checked += 1;
        }
    }
    checked
}

fn written_early(app: &App, hair: Entity) -> bool {
    app.world()
        .get::<ComputedHair>(hair)
        .unwrap()
        .strands_written
}

#[test]
fn strands_are_written_by_their_hairs_thread_or_after_the_step() {
    let mut h = Harness::new(spiky_groom(12, 6), HairSimSettings::default(), 60.0);
    // A second hair on the same bone: beside another, each hair is stepped and written whole on
    // one thread (a hair alone shares its batches out over the threads).
    let groom = h.app.world().get::<Hair>(h.hair).unwrap().groom.clone();
    let other = h
        .app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings::default(),
            ChildOf(h.bone),
        ))
        .id();
    let shake = |h: &mut Harness, frames: std::ops::Range<i32>| {
        for f in frames {
            let mut bone = h.app.world_mut().get_mut::<Transform>(h.bone).unwrap();
            bone.translation.x = 0.2 * (f as f32 * 0.3).sin();
            bone.rotation = Quat::from_rotation_y(0.5 * (f as f32 * 0.2).sin());
            h.update();
        }
    };
    shake(&mut h, 0..20);
    for hair in [h.hair, other] {
        assert!(written_early(&h.app, hair), "{hair} written by the step");
        assert_eq!(particles_checked(&h.app, hair), 12 * 6);
    }
    // One strand of the first hair despawned: its list is no longer its strands as built, so
    // the step leaves them to the pass after it, which writes every one left, every frame.
    let gone = h
        .app
        .world()
        .get::<HairStrands>(h.hair)
        .unwrap()
        .iter()
        .next();
    h.app.world_mut().entity_mut(gone.unwrap()).despawn();
    shake(&mut h, 20..40);
    assert!(!written_early(&h.app, h.hair));
    assert!(written_early(&h.app, other));
    assert_eq!(particles_checked(&h.app, h.hair), 11 * 6);
    assert_eq!(particles_checked(&h.app, other), 12 * 6);
}
