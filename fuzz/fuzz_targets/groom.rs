//! The groom loader (`*.hair.xml`) on any bytes: no panic, bounded, and what it accepts obeys
//! every rule of `docs/formats.md`.
#![no_main]

use bevy_cartoon_hair::asset::{
    MAX_COORDINATE, MAX_PARTICLES_PER_STRAND, MIN_SEGMENT_LENGTH, parse_groom_within,
};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    // The first byte picks a particle budget, so the budget's own refusals are explored too.
    let Some((&budget, data)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let budget = 2 + budget as usize * 8;
    match parse_groom_within("f.hair.xml", text, budget) {
        Ok(groom) => {
            assert!(groom.strand_count() >= 1);
            assert!(groom.points.len() <= budget);
            assert_eq!(groom.offsets.first(), Some(&0));
            assert_eq!(*groom.offsets.last().unwrap() as usize, groom.points.len());
            for strand in groom.strands() {
                assert!((2..=MAX_PARTICLES_PER_STRAND).contains(&strand.len()));
                for p in strand {
                    assert!(
                        p.is_finite() && p.abs().max_element() <= MAX_COORDINATE,
                        "{p}"
                    );
                }
                for w in strand.windows(2) {
                    assert!(w[0].distance(w[1]) >= MIN_SEGMENT_LENGTH);
                }
            }
            if let Some(s) = groom.bone_scale {
                assert!(s.is_finite() && s > 0.0);
            }
        }
        Err(e) => common::check_error("f.hair.xml", text, &e),
    }
});
