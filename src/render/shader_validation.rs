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
    compose_with(&[], name, source, defs, &[])
}

/// Like [`compose_and_validate`], with extra library modules (e.g. Bevy's own) and value defs.
pub(crate) fn compose_with(
    extra_modules: &[(String, String)],
    name: &str,
    source: &str,
    defs: &[&str],
    values: &[(&str, ShaderDefValue)],
) -> Result<naga::Module, String> {
    let mut composer = Composer::default().with_capabilities(Capabilities::all());
    let mut shader_defs: HashMap<String, ShaderDefValue> = defs
        .iter()
        .map(|d| (d.to_string(), ShaderDefValue::Bool(true)))
        .collect();
    for (k, v) in values {
        shader_defs.insert(k.to_string(), *v);
    }
    // Bevy's modules import each other; add them in dependency order by retrying.
    let mut pending: Vec<&(String, String)> = extra_modules.iter().collect();
    let mut last_error = String::new();
    while !pending.is_empty() {
        let before = pending.len();
        pending.retain(|(path, src)| {
            let added = composer.add_composable_module(ComposableModuleDescriptor {
                source: src,
                file_path: path,
                language: ShaderLanguage::Wgsl,
                shader_defs: shader_defs.clone(),
                ..Default::default()
            });
            match added {
                Ok(_) => false,
                Err(e) => {
                    last_error = format!("{path}: {}", e.emit_to_string(&composer));
                    true
                }
            }
        });
        if pending.len() == before {
            // What is left does not compose; the entry point will say if it needed it.
            let _ = &last_error;
            break;
        }
    }
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
#import bevy_cartoon_hair::curves::{depth_detail, back_light}
@fragment
fn main(@location(0) x: f32) -> @location(0) vec4<f32> {
    let n = vec3<f32>(0.0, 0.0, 1.0);
    return vec4<f32>(depth_detail(x, 1.0, 10.0), back_light(n, n, 2.0), 0.0, 1.0);
}
"#;
    let module = compose_and_validate("library_entry", entry, &[]).unwrap();
    assert_eq!(module.entry_points.len(), 1);
    assert!(
        module.functions.len() >= 2,
        "library functions were not composed in"
    );
}

#[test]
fn broken_wgsl_is_reported_with_its_name() {
    let err = compose_and_validate("broken.wgsl", "fn main( {", &[]).unwrap_err();
    assert!(err.contains("broken.wgsl"), "{err}");
}

/// Every WGSL file Bevy's plugins embedded (its PBR modules included), read through the asset
/// server's `embedded` source of an app with rendering disabled: no GPU needed.
fn bevy_shader_sources() -> Vec<(String, String)> {
    use bevy::prelude::*;
    use bevy::render::RenderPlugin;
    use bevy::render::settings::WgpuSettings;
    use std::path::{Path, PathBuf};

    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(RenderPlugin {
                render_creation: WgpuSettings {
                    backends: None,
                    ..default()
                }
                .into(),
                ..default()
            })
            .set(WindowPlugin {
                primary_window: None,
                ..default()
            })
            .disable::<bevy::winit::WinitPlugin>()
            .disable::<bevy::log::LogPlugin>(),
    );
    let server = app.world().resource::<AssetServer>().clone();
    let source = server
        .get_source(bevy::asset::io::AssetSourceId::Name("embedded".into()))
        .expect("the embedded asset source");
    let reader = source.reader();
    let mut out = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(dir) = stack.pop() {
        let Ok(mut entries) = bevy::tasks::block_on(reader.read_directory(&dir)) else {
            continue;
        };
        while let Some(path) = bevy::tasks::block_on(futures_lite_next(&mut entries)) {
            if bevy::tasks::block_on(reader.is_directory(&path)).unwrap_or(false) {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                let mut bytes = Vec::new();
                let Ok(mut file) = bevy::tasks::block_on(reader.read(&path)) else {
                    continue;
                };
                if bevy::tasks::block_on(file.read_to_end(&mut bytes)).is_ok() {
                    let name = Path::new("embedded").join(&path).display().to_string();
                    out.push((name, String::from_utf8_lossy(&bytes).into_owned()));
                }
            }
        }
    }
    out
}

async fn futures_lite_next(
    stream: &mut Box<bevy::asset::io::PathStream>,
) -> Option<std::path::PathBuf> {
    use bevy::tasks::futures_lite::StreamExt;
    stream.next().await
}

/// The value defs Bevy gives a mesh material's shaders, from Bevy's own constants; the one that
/// depends on the device (`AVAILABLE_STORAGE_BUFFER_BINDINGS`) as on a device with wgpu's
/// default limits. (`PER_OBJECT_BUFFER_BATCH_SIZE` is set only where storage buffers are
/// missing, as on WebGL: not the variant that runs here.)
fn bevy_value_defs() -> Vec<(&'static str, ShaderDefValue)> {
    let uint = |v: usize| ShaderDefValue::UInt(v as u32);
    vec![
        (
            "MAX_DIRECTIONAL_LIGHTS",
            uint(bevy::pbr::MAX_DIRECTIONAL_LIGHTS),
        ),
        (
            "MAX_CASCADES_PER_LIGHT",
            uint(bevy::pbr::MAX_CASCADES_PER_LIGHT),
        ),
        ("MAX_RECT_LIGHTS", uint(bevy::pbr::MAX_RECT_LIGHTS)),
        (
            "MATERIAL_BIND_GROUP",
            uint(bevy::pbr::MATERIAL_BIND_GROUP_INDEX),
        ),
        (
            "AVAILABLE_STORAGE_BUFFER_BINDINGS",
            ShaderDefValue::UInt(
                bevy::render::settings::WgpuLimits::default().max_storage_buffers_per_shader_stage,
            ),
        ),
    ]
}

/// The defs Bevy's mesh pipeline sets for a mesh's vertex attributes (as in `bevy_pbr`'s
/// `MeshPipeline::specialize`), so validation sees the variant the mesh really gets.
fn mesh_pipeline_vertex_defs(mesh: &bevy::mesh::Mesh) -> Vec<&'static str> {
    use bevy::mesh::Mesh;
    let mut defs = vec!["MESH_PIPELINE", "VERTEX_OUTPUT_INSTANCE_INDEX"];
    for (attribute, names) in [
        (Mesh::ATTRIBUTE_POSITION, &["VERTEX_POSITIONS"][..]),
        (Mesh::ATTRIBUTE_NORMAL, &["VERTEX_NORMALS"]),
        (Mesh::ATTRIBUTE_UV_0, &["VERTEX_UVS", "VERTEX_UVS_A"]),
        (Mesh::ATTRIBUTE_UV_1, &["VERTEX_UVS", "VERTEX_UVS_B"]),
        (Mesh::ATTRIBUTE_TANGENT, &["VERTEX_TANGENTS"]),
        (Mesh::ATTRIBUTE_COLOR, &["VERTEX_COLORS"]),
    ] {
        if mesh.contains_attribute(attribute) {
            for name in names {
                if !defs.contains(name) {
                    defs.push(name);
                }
            }
        }
    }
    defs
}

#[test]
fn every_toon_material_variant_composes_and_validates() {
    use super::{MATERIAL_SHADERS, ToonHairMaterialKey};
    let bevy_modules = bevy_shader_sources();
    assert!(
        bevy_modules
            .iter()
            .any(|(_, s)| s.contains("bevy_pbr::mesh_view_bindings")),
        "Bevy's PBR shaders were not found among {} embedded files",
        bevy_modules.len()
    );
    let values = bevy_value_defs();
    // The vertex defs of the mesh the material really draws: the crate's hair mesh.
    let hair_mesh = crate::mesh::new_hair_mesh(&crate::mesh::tube::TubeTopology::new(4, 4), 2);
    let vertex_defs = mesh_pipeline_vertex_defs(&hair_mesh);
    assert!(
        vertex_defs.contains(&"VERTEX_UVS_B"),
        "the hair mesh carries a second UV set: {vertex_defs:?}"
    );
    assert!(
        vertex_defs.contains(&"VERTEX_TANGENTS"),
        "the hair mesh carries strand directions as tangents: {vertex_defs:?}"
    );
    let (name, source) = MATERIAL_SHADERS[0];
    let variants = ToonHairMaterialKey::all();
    // The hair mesh, a mesh without tangents (the angel ring's fallback path), and one with
    // positions and normals only (a scalp drawn with the hair's material).
    let no_tangents: Vec<&str> = vertex_defs
        .iter()
        .copied()
        .filter(|d| *d != "VERTEX_TANGENTS")
        .collect();
    let bare: Vec<&str> = vertex_defs
        .iter()
        .copied()
        .filter(|d| !d.starts_with("VERTEX_UVS") && *d != "VERTEX_TANGENTS")
        .collect();
    // Every variant on the hair mesh; on the other two layouts, the variants that differ in
    // what they read from the vertex (the angel ring's direction, hatching's UVs), each with
    // and without the scene's lights and the specular layer.
    let layout_dependent = |k: &ToonHairMaterialKey| {
        let d = k.shader_defs();
        !d.iter()
            .any(|d| d.starts_with("RAMP_") || *d == "BLINN_SPECULAR" || *d == "BACK_LIGHT")
    };
    let jobs: Vec<(&ToonHairMaterialKey, &Vec<&str>)> = variants
        .iter()
        .flat_map(|key| {
            let layouts: Vec<&Vec<&str>> = if layout_dependent(key) {
                vec![&vertex_defs, &no_tangents, &bare]
            } else {
                vec![&vertex_defs]
            };
            layouts.into_iter().map(move |v| (key, v))
        })
        .collect();
    let checked = jobs.len();
    // Composing is the slow part: spread it over the machine's threads.
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    std::thread::scope(|scope| {
        for part in jobs.chunks(checked.div_ceil(threads)) {
            let (bevy_modules, values) = (&bevy_modules, &values);
            scope.spawn(move || {
                for &(key, vertex) in part {
                    let mut defs = key.shader_defs();
                    defs.extend(vertex);
                    let module = compose_with(bevy_modules, name, source, &defs, values)
                        .unwrap_or_else(|e| panic!("variant {key:?} {vertex:?}: {e}"));
                    assert!(
                        module.entry_points.iter().any(|e| e.name == "fragment"),
                        "variant {key:?} lost its entry point"
                    );
                }
            });
        }
    });
    assert_eq!(variants.len(), 384);
    assert_eq!(checked, 384 + 2 * 24);
}

#[test]
fn every_outline_variant_composes_and_validates() {
    use super::PASS_SHADERS;
    use super::outline::OutlinePipelineKey;
    let bevy_modules = bevy_shader_sources();
    let (name, source) = PASS_SHADERS
        .iter()
        .find(|(n, _)| *n == "outline.wgsl")
        .expect("outline.wgsl is listed");
    let variants = OutlinePipelineKey::all();
    for key in &variants {
        let defs = key.shader_defs();
        let module = compose_with(&bevy_modules, name, source, &defs, &[])
            .unwrap_or_else(|e| panic!("variant {key:?}: {e}"));
        for entry in ["detect", "dilate_x", "composite"] {
            assert!(
                module.entry_points.iter().any(|e| e.name == entry),
                "variant {key:?} lost its entry point {entry}"
            );
        }
        // The detection pass reads exactly the prepass textures its defs name.
        let globals: Vec<_> = module
            .global_variables
            .iter()
            .filter_map(|(_, g)| g.name.clone())
            .collect();
        assert_eq!(
            globals.iter().any(|n| n == "depth_texture"),
            key.source.uses_depth(),
            "variant {key:?}: {globals:?}"
        );
        assert_eq!(
            globals.iter().any(|n| n == "normal_texture"),
            key.source.uses_normals(),
            "variant {key:?}: {globals:?}"
        );
    }
    assert_eq!(variants.len(), 8);
}

#[test]
fn every_hair_prepass_variant_composes_and_validates() {
    use super::MATERIAL_SHADERS;
    let bevy_modules = bevy_shader_sources();
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "hair_prepass.wgsl")
        .expect("hair_prepass.wgsl is listed");
    let hair_mesh = crate::mesh::new_hair_mesh(&crate::mesh::tube::TubeTopology::new(4, 4), 2);
    let mut checked = 0;
    // As Bevy's prepass pipeline sets them: which targets the view has, and whether a
    // directional shadow emulates unclipped depth.
    for normals in [false, true] {
        for motion in [false, true] {
            for unclipped in [false, true] {
                // With no target and no depth to write, Bevy runs no prepass fragment.
                if !(normals || motion || unclipped) {
                    continue;
                }
                let mut defs = mesh_pipeline_vertex_defs(&hair_mesh);
                defs.retain(|d| *d != "MESH_PIPELINE");
                defs.extend(["PREPASS_PIPELINE", "PREPASS_FRAGMENT"]);
                if normals {
                    defs.extend(["NORMAL_PREPASS", "NORMAL_PREPASS_OR_DEFERRED_PREPASS"]);
                }
                if motion {
                    defs.push("MOTION_VECTOR_PREPASS");
                }
                if unclipped {
                    defs.push("UNCLIPPED_DEPTH_ORTHO_EMULATION");
                }
                let module = compose_with(&bevy_modules, name, source, &defs, &values)
                    .unwrap_or_else(|e| panic!("defs {defs:?}: {e}"));
                assert!(
                    module.entry_points.iter().any(|e| e.name == "fragment"),
                    "defs {defs:?}: no fragment entry point"
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 7);
}

#[test]
fn every_stroke_material_variant_composes_and_validates() {
    use super::MATERIAL_SHADERS;
    let bevy_modules = bevy_shader_sources();
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "stroke.wgsl")
        .expect("stroke.wgsl is listed");
    // The vertex defs of the mesh strokes are drawn on.
    let strokes = crate::mesh::StripBuffers::empty_mesh(true);
    let vertex = mesh_pipeline_vertex_defs(&strokes);
    assert!(
        vertex.contains(&"VERTEX_COLORS") && vertex.contains(&"VERTEX_UVS_A"),
        "stroke meshes carry colours and UVs: {vertex:?}"
    );
    let mut checked = 0;
    // Whether the view has a normal prepass (the mass scope's hair mask), with and without MSAA.
    for normals in [false, true] {
        for multisampled in [false, true] {
            let mut defs = vertex.clone();
            if normals {
                defs.push("NORMAL_PREPASS");
            }
            if multisampled {
                defs.push("MULTISAMPLED");
            }
            let module = compose_with(&bevy_modules, name, source, &defs, &values)
                .unwrap_or_else(|e| panic!("stroke {defs:?}: {e}"));
            let reads_mask = module
                .global_variables
                .iter()
                // naga_oil decorates imported names.
                .any(|(_, g)| {
                    g.name
                        .as_deref()
                        .is_some_and(|n| n.contains("normal_prepass_texture"))
                });
            assert_eq!(reads_mask, normals, "stroke {defs:?}");
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
}
