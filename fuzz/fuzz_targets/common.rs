//! What every loader target checks of an error: it is located in the file it was given.

use bevy_cartoon_hair::asset::HairAssetError;

/// The error names `file`, and its line and column lie inside `text` (0 means the whole file).
pub fn check_error(file: &str, text: &str, e: &HairAssetError) {
    assert_eq!(e.file.as_deref(), Some(file), "{e}");
    assert!(!e.message.is_empty(), "an error without words: {e:?}");
    let lines = text.split('\n').count() as u32;
    assert!(
        e.line <= lines,
        "line {} of a {lines}-line file: {e}",
        e.line
    );
    if e.line > 0 {
        let line = text.split('\n').nth(e.line as usize - 1).unwrap_or("");
        let columns = line.chars().count() as u32 + 1;
        assert!(
            e.column >= 1 && e.column <= columns,
            "column {} of a {columns}-column line: {e}",
            e.column
        );
    }
    assert!(e.to_string().starts_with(file), "{e}");
}
