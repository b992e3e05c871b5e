//! The animation loader (`*.hairanim.xml`) on any bytes: no panic; accepted keys are in time
//! order, within the key limits, and every key path it accepts stays inside the asset folder.
#![no_main]

use bevy::asset::AssetPath;
use bevy_cartoon_hair::asset::{MAX_KEY_PATH, MAX_KEYS, parse_animation, resolve_key_path};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_animation("a/f.hairanim.xml", text) {
        Ok(anim) => {
            assert!((1..=MAX_KEYS).contains(&anim.keys.len()));
            assert!(anim.duration.is_finite() && anim.duration > 0.0);
            for w in anim.keys.windows(2) {
                assert!(w[0].time < w[1].time, "{:?}", anim.keys);
            }
            let here = AssetPath::parse("a/f.hairanim.xml");
            for key in &anim.keys {
                assert!(key.time.is_finite() && key.time >= 0.0 && key.time <= anim.duration);
                assert!(key.groom.len() <= MAX_KEY_PATH);
                if let Ok(path) = resolve_key_path(&here, &key.groom) {
                    let p = path.path().to_string_lossy().into_owned();
                    assert!(!path.is_unapproved(), "{:?} -> {p:?}", key.groom);
                    assert!(p.ends_with(".hair.xml"), "{p:?}");
                    assert!(
                        path.path()
                            .components()
                            .all(|c| matches!(c, std::path::Component::Normal(_))),
                        "{:?} -> {p:?}",
                        key.groom
                    );
                    assert!(path.source() == here.source(), "{p:?}");
                }
            }
        }
        Err(e) => common::check_error("a/f.hairanim.xml", text, &e),
    }
});
