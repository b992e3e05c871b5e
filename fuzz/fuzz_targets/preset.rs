//! The preset reader (RON, every earlier format migrated) on any text: no panic, errors say
//! where, and an accepted preset writes out as RON that reads back to the same preset.
#![no_main]

use bevy_cartoon_hair::preset::{HairPreset, HairPresetError};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match HairPreset::from_ron_migrating(text) {
        Ok((preset, _)) => {
            let written = preset.to_ron().expect("an accepted preset writes out");
            let again = HairPreset::from_ron(&written).expect("what it wrote reads back");
            assert_eq!(
                format!("{preset:?}"),
                format!("{again:?}"),
                "a round trip changed the preset"
            );
        }
        Err(HairPresetError::Parse {
            line,
            column,
            message,
            ..
        }) => {
            assert!(!message.is_empty());
            assert!(
                line >= 1 && line <= text.split('\n').count(),
                "line {line}: {message}"
            );
            assert!(column >= 1, "column {column}: {message}");
        }
        Err(_) => {}
    }
});
