//! Composes the crate's WGSL with naga_oil and validates it with naga, no GPU needed.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use naga_oil::compose::{
    ComposableModuleDescriptor, Composer, NagaModuleDescriptor, ShaderDefValue, ShaderLanguage,
};
use std::collections::HashMap;

use super::SHADER_LIBRARY;

/// Composes `source` (an entry-point shader) against the crate's library with `defs` set, and
/// validates the result. Returns a readable error naming the shader and the defs.
pub(crate) fn compose_and_validate(
    name: &str,
    source: &str,
    defs: &[&str],
) -> Result<naga::Module, String> {
    let mut composer = Composer::default().with_capabilities(Capabilities::all());
    for (path, src) in SHADER_LIBRARY {
        let added = composer.add_composable_module(ComposableModuleDescriptor {
            source: src,
            file_path: path,
            language: ShaderLanguage::Wgsl,
            ..Default::default()
        });
        if let Err(e) = added {
            return Err(format!("{path}: {}", e.emit_to_string(&composer)));
        }
    }
    let shader_defs: HashMap<String, ShaderDefValue> = defs
        .iter()
        .map(|d| (d.to_string(), ShaderDefValue::Bool(true)))
        .collect();
    let module = composer
        .make_naga_module(NagaModuleDescriptor {
            source,
            file_path: name,
            shader_defs,
            ..Default::default()
        })
        .map_err(|e| format!("{name} {defs:?}: {}", e.emit_to_string(&composer)))?;
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .map_err(|e| format!("{name} {defs:?}: {e:?}"))?;
    Ok(module)
}

#[test]
fn library_modules_compose_and_validate() {
    // A tiny entry point that calls every library function, so none is dead-code eliminated.
    let entry = r#"
#import bevy_cartoon_hair::curves::{quadratic, depth_detail, back_light}
@fragment
fn main(@location(0) x: f32) -> @location(0) vec4<f32> {
    let n = vec3<f32>(0.0, 0.0, 1.0);
    return vec4<f32>(quadratic(vec3<f32>(1.0, 2.0, 3.0), x), depth_detail(x, 1.0, 10.0),
        back_light(n, n, 2.0), 1.0);
}
"#;
    let module = compose_and_validate("library_entry", entry, &[]).unwrap();
    assert_eq!(module.entry_points.len(), 1);
    assert!(
        module.functions.len() >= 3,
        "library functions were not composed in"
    );
}

#[test]
fn broken_wgsl_is_reported_with_its_name() {
    let err = compose_and_validate("broken.wgsl", "fn main( {", &[]).unwrap_err();
    assert!(err.contains("broken.wgsl"), "{err}");
}
