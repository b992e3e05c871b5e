//! The collision loader (`*.collision.xml`) on any bytes: no panic, and every shape it accepts
//! is finite, within range and has a positive radius or a unit normal.
#![no_main]

use bevy_cartoon_hair::asset::{MAX_COORDINATE, MAX_SHAPES, parse_collision};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn near(p: bevy::math::Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= MAX_COORDINATE
}

fn radius(r: f32) -> bool {
    r.is_finite() && r > 0.0 && r <= MAX_COORDINATE
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_collision("f.collision.xml", text) {
        Ok(c) => {
            let shapes = c.spheres.len() + c.capsules.len() + c.planes.len();
            assert!((1..=MAX_SHAPES).contains(&shapes), "{shapes} shapes");
            for s in &c.spheres {
                assert!(near(s.center) && radius(s.radius), "{s:?}");
            }
            for s in &c.capsules {
                assert!(near(s.a) && near(s.b) && radius(s.radius), "{s:?}");
            }
            for s in &c.planes {
                assert!(near(s.point), "{s:?}");
                assert!((s.normal.length() - 1.0).abs() < 1e-4, "{s:?}");
            }
        }
        Err(e) => common::check_error("f.collision.xml", text, &e),
    }
});
