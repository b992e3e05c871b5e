//! Compiles the crate's WESL through Bevy's own shader cache (the WESL compiler and import
//! resolution every pipeline uses, against Bevy's embedded modules) and validates the result with
//! naga, no GPU needed.

use bevy::asset::AssetId;
use bevy::asset::uuid::Uuid;
use bevy::shader::{
    Shader, ShaderCache, ShaderCacheError, ShaderCacheSource, ShaderDefVal, ValidateShader,
};
use naga::valid::{Capabilities, ValidationFlags, Validator};
use std::sync::Arc;

use super::SHADER_LIBRARY;

/// Where the crate's shaders are embedded: `embedded://bevy_cartoon_hair/render/<file>`.
const EMBEDDED_DIR: &str = "embedded://bevy_cartoon_hair/render/";

/// Parses the WGSL the cache composed and validates it with every capability.
fn parse_and_validate(
    _device: &(),
    source: ShaderCacheSource,
    _validate: &ValidateShader,
) -> Result<naga::Module, ShaderCacheError> {
    let ShaderCacheSource::Wgsl(wgsl) = source else {
        return Err(ShaderCacheError::CreateShaderModule(
            "expected WGSL from the WESL compiler".into(),
        ));
    };
    let module = naga::front::wgsl::parse_str(&wgsl)
        .map_err(|e| ShaderCacheError::CreateShaderModule(e.emit_to_string(&wgsl)))?;
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .map_err(|e| ShaderCacheError::CreateShaderModule(e.emit_to_string(&wgsl)))?;
    Ok(module)
}

/// A shader cache holding Bevy's modules (if given) and the crate's library.
pub(crate) struct ShaderCompiler {
    cache: ShaderCache<naga::Module, ()>,
    next_id: u128,
}

impl ShaderCompiler {
    /// A cache with `extra_modules` (`(embedded path, source)`, e.g. Bevy's own) and the crate's
    /// library modules.
    pub(crate) fn new(extra_modules: &[(String, String)]) -> Self {
        let mut compiler = Self {
            cache: ShaderCache::new((), parse_and_validate),
            next_id: 1,
        };
        for (path, source) in extra_modules {
            compiler.add(Shader::from_wesl(source.clone(), path.clone()));
        }
        for (file, source) in SHADER_LIBRARY {
            compiler.add(Shader::from_wesl(*source, format!("{EMBEDDED_DIR}{file}")));
        }
        compiler
    }

    fn add(&mut self, shader: Shader) -> AssetId<Shader> {
        let id = AssetId::Uuid {
            uuid: Uuid::from_u128(self.next_id),
        };
        self.next_id += 1;
        self.cache.set_shader(id, shader);
        id
    }

    /// Compiles `source` (an entry-point shader of the crate, `name` its file) with `defs` set as
    /// flags and `values` as `constants::NAME`, and validates the result. Returns a readable
    /// error naming the shader and the defs.
    pub(crate) fn compile(
        &mut self,
        name: &str,
        source: &'static str,
        defs: &[&str],
        values: &[ShaderDefVal],
    ) -> Result<Arc<naga::Module>, String> {
        let id = self.add(Shader::from_wesl(source, format!("{EMBEDDED_DIR}{name}")));
        let mut all: Vec<ShaderDefVal> = defs
            .iter()
            .map(|d| ShaderDefVal::Bool(d.to_string().into(), true))
            .collect();
        all.extend(values.iter().cloned());
        self.cache.get(0, id, &all).map_err(|e| match e {
            ShaderCacheError::ShaderImportNotYetAvailable => {
                format!("{name} {defs:?}: an import names a module that is not registered")
            }
            e => format!("{name} {defs:?}: {e}"),
        })
    }
}

/// Compiles `source` against the crate's library alone (see [`ShaderCompiler::compile`]).
pub(crate) fn compose_and_validate(
    name: &str,
    source: &'static str,
    defs: &[&str],
) -> Result<Arc<naga::Module>, String> {
    ShaderCompiler::new(&[]).compile(name, source, defs, &[])
}

#[test]
fn library_modules_compose_and_validate() {
    let entry = r#"
import bevy_cartoon_hair::render::curves::{depth_detail, back_light};
@fragment
fn main(@location(0) x: f32) -> @location(0) vec4<f32> {
    let n = vec3<f32>(0.0, 0.0, 1.0);
    return vec4<f32>(depth_detail(x, 1.0, 10.0), back_light(n, n, 2.0), 0.0, 1.0);
}
"#;
    let module = compose_and_validate("library_entry.wesl", entry, &[]).unwrap();
    assert_eq!(module.entry_points.len(), 1);
    assert!(
        module.functions.len() >= 2,
        "library functions were not composed in"
    );
}

#[test]
fn broken_wgsl_is_reported_with_its_name() {
    let err = compose_and_validate("broken.wesl", "fn main( {", &[]).unwrap_err();
    assert!(err.contains("broken.wesl"), "{err}");
}

#[test]
fn a_missing_import_is_reported() {
    let entry = "import bevy_cartoon_hair::render::nowhere::f;\n@fragment fn main() -> @location(0) vec4<f32> { return vec4<f32>(f()); }";
    let err = compose_and_validate("lost_import.wesl", entry, &[]).unwrap_err();
    assert!(err.contains("lost_import.wesl"), "{err}");
}

/// Every WESL file Bevy's plugins embedded (its PBR modules included), read through the asset
/// server's embedded source, as `(embedded://path, source)`.
fn bevy_shader_sources() -> Vec<(String, String)> {
    use bevy::prelude::*;
    use bevy::render::RenderPlugin;
    use bevy::render::settings::WgpuSettings;
    use std::path::PathBuf;

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
    // Some modules are embedded in `finish` (the mesh bindings, whose defs depend on the
    // device's limits).
    app.finish();
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
            } else if path.extension().is_some_and(|e| e == "wesl") {
                let mut bytes = Vec::new();
                let Ok(mut file) = bevy::tasks::block_on(reader.read(&path)) else {
                    continue;
                };
                if bevy::tasks::block_on(file.read_to_end(&mut bytes)).is_ok() {
                    let name = format!("embedded://{}", path.display());
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
fn bevy_value_defs() -> Vec<ShaderDefVal> {
    let uint = |name: &'static str, v: usize| ShaderDefVal::UInt(name.into(), v as u32);
    let storage =
        bevy::render::settings::WgpuLimits::default().max_storage_buffers_per_shader_stage;
    vec![
        uint("MAX_DIRECTIONAL_LIGHTS", bevy::pbr::MAX_DIRECTIONAL_LIGHTS),
        uint("MAX_CASCADES_PER_LIGHT", bevy::pbr::MAX_CASCADES_PER_LIGHT),
        uint("MAX_RECT_LIGHTS", bevy::pbr::MAX_RECT_LIGHTS),
        uint("MATERIAL_BIND_GROUP", bevy::pbr::MATERIAL_BIND_GROUP_INDEX),
        ShaderDefVal::UInt("AVAILABLE_STORAGE_BUFFER_BINDINGS".into(), storage),
        // As Bevy's pipeline cache bakes the comparisons into flags.
        ShaderDefVal::Bool(
            "AVAILABLE_STORAGE_BUFFER_BINDINGS__GE_3".into(),
            storage >= 3,
        ),
        ShaderDefVal::Bool(
            "AVAILABLE_STORAGE_BUFFER_BINDINGS__GE_6".into(),
            storage >= 6,
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
            .any(|(p, _)| p.ends_with("bevy_pbr/render/mesh_view_bindings.wesl")),
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
                let mut compiler = ShaderCompiler::new(bevy_modules);
                for &(key, vertex) in part {
                    let mut defs = key.shader_defs();
                    defs.extend(vertex);
                    let module = compiler
                        .compile(name, source, &defs, values)
                        .unwrap_or_else(|e| panic!("variant {key:?} {vertex:?}: {e}"));
                    assert!(
                        module.entry_points.iter().any(|e| e.name == "fragment"),
                        "variant {key:?} lost its entry point"
                    );
                }
            });
        }
    });
    assert_eq!(variants.len(), 2304);
    assert_eq!(checked, 2304 + 2 * 144);
    // A cut-out's main pass under MSAA (alpha to coverage), on the hair mesh.
    let mut compiler = ShaderCompiler::new(&bevy_modules);
    let mut coverage = 0;
    for key in variants
        .iter()
        .filter(|k| k.shader_defs().contains(&"ALPHA_MASK"))
    {
        let mut defs = key.shader_defs();
        defs.extend(&vertex_defs);
        defs.push("CUT_COVERAGE");
        let module = compiler
            .compile(name, source, &defs, &values)
            .unwrap_or_else(|e| panic!("variant {key:?} with alpha to coverage: {e}"));
        assert!(module.entry_points.iter().any(|e| e.name == "fragment"));
        coverage += 1;
    }
    assert_eq!(coverage, 768);
}

#[test]
fn the_gpu_tube_stroke_and_highlight_passes_compose_and_validate() {
    use super::PASS_SHADERS;
    // Each pass's bindings are the ones render/gpu lays out: the batch header first; the tube
    // pass then its hairs, strands and points, the vertex slab and the ring frames it writes;
    // the stroke pass its jobs, the strands, points and frames, the stroke slab, and (6, 7) the
    // stroke meshes' indices and the batch's draws; the highlight pass its jobs, the frames and
    // the highlight slab, and the same 6 and 7; the shadow pass its jobs, the frames and the
    // ribbon slab.
    let defs = super::gpu::shader_defs();
    for (file, bindings) in [
        ("gpu/tubes.wesl", &[0u32, 1, 2, 3, 4, 5][..]),
        ("gpu/strokes.wesl", &[0, 1, 2, 3, 4, 5, 6, 7][..]),
        ("gpu/highlights.wesl", &[0, 1, 2, 3, 6, 7][..]),
        ("gpu/shadows.wesl", &[0, 1, 2, 3][..]),
    ] {
        let (name, source) = PASS_SHADERS
            .iter()
            .find(|(n, _)| *n == file)
            .unwrap_or_else(|| panic!("{file} is listed"));
        let module = ShaderCompiler::new(&[])
            .compile(name, source, &[], &defs)
            .unwrap_or_else(|e| panic!("{e}"));
        let entry = module
            .entry_points
            .iter()
            .find(|e| e.name == "build")
            .expect("the build entry point");
        assert_eq!(entry.stage, naga::ShaderStage::Compute);
        assert_eq!(entry.workgroup_size, [64, 1, 1]);
        let mut found: Vec<u32> = module
            .global_variables
            .iter()
            .filter_map(|(_, g)| g.binding.as_ref().map(|b| b.binding))
            .collect();
        found.sort_unstable();
        assert_eq!(found, bindings, "{file}");
        // Without the constants from Rust the passes do not compile: none is copied by hand.
        assert!(
            ShaderCompiler::new(&[])
                .compile(name, source, &[], &[])
                .is_err(),
            "{file} compiled without the shader defs"
        );
    }
}

#[test]
fn every_outline_variant_composes_and_validates() {
    use super::PASS_SHADERS;
    use super::outline::OutlinePipelineKey;
    let mut compiler = ShaderCompiler::new(&bevy_shader_sources());
    let (name, source) = PASS_SHADERS
        .iter()
        .find(|(n, _)| *n == "outline.wesl")
        .expect("outline.wesl is listed");
    let variants = OutlinePipelineKey::all();
    for key in &variants {
        let defs = key.shader_defs();
        let module = compiler
            .compile(name, source, &defs, &[])
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
    let mut compiler = ShaderCompiler::new(&bevy_shader_sources());
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "hair_prepass.wesl")
        .expect("hair_prepass.wesl is listed");
    let hair_mesh = crate::mesh::new_hair_mesh(&crate::mesh::tube::TubeTopology::new(4, 4), 2);
    let mut vertex = mesh_pipeline_vertex_defs(&hair_mesh);
    vertex.retain(|d| *d != "MESH_PIPELINE");
    // A user's mesh with positions and normals only: a cut-out there reads the base alpha.
    let bare: Vec<&str> = vertex
        .iter()
        .copied()
        .filter(|d| !d.starts_with("VERTEX_UVS") && *d != "VERTEX_TANGENTS")
        .collect();
    let mut checked = 0;
    let mut depth_only = 0;
    // As Bevy's prepass pipeline sets them: which targets the view has, and whether a
    // directional shadow emulates unclipped depth; and the material's defs that the prepass
    // reads: double-sided, cut out (which Bevy's pipeline sees as MAY_DISCARD), painted.
    for bits in 0..64u32 {
        let [
            normals,
            motion,
            unclipped,
            double_sided,
            alpha_mask,
            painted,
        ] = std::array::from_fn(|i| bits & (1 << i) != 0);
        let fragment = normals || motion || unclipped;
        // With no target and no depth to write, Bevy runs a prepass fragment only for a
        // material that may discard: the depth-only entry.
        if !fragment && !alpha_mask {
            continue;
        }
        let layouts = if alpha_mask {
            vec![&vertex, &bare]
        } else {
            vec![&vertex]
        };
        for layout in layouts {
            let mut defs = layout.clone();
            defs.push("PREPASS_PIPELINE");
            if fragment {
                defs.push("PREPASS_FRAGMENT");
            } else {
                depth_only += 1;
            }
            if normals {
                defs.extend(["NORMAL_PREPASS", "NORMAL_PREPASS_OR_DEFERRED_PREPASS"]);
            }
            if motion {
                defs.push("MOTION_VECTOR_PREPASS");
            }
            if unclipped {
                defs.push("UNCLIPPED_DEPTH_ORTHO_EMULATION");
            }
            if double_sided {
                defs.push("DOUBLE_SIDED");
            }
            if alpha_mask {
                defs.extend(["ALPHA_MASK", "MAY_DISCARD"]);
            }
            if painted {
                defs.push("BASE_COLOR_TEXTURE");
            }
            let module = compiler
                .compile(name, source, &defs, &values)
                .unwrap_or_else(|e| panic!("defs {defs:?}: {e}"));
            assert!(
                module.entry_points.iter().any(|e| e.name == "fragment"),
                "defs {defs:?}: no fragment entry point"
            );
            checked += 1;
        }
    }
    // A solid material: 28 prepasses on the hair mesh. A cut-out: 32 on each of two layouts,
    // 4 of them depth-only.
    assert_eq!((checked, depth_only), (28 + 2 * 32, 8));
}

#[test]
fn every_stroke_material_variant_composes_and_validates() {
    use super::MATERIAL_SHADERS;
    let mut compiler = ShaderCompiler::new(&bevy_shader_sources());
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "stroke.wesl")
        .expect("stroke.wesl is listed");
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
            let module = compiler
                .compile(name, source, &defs, &values)
                .unwrap_or_else(|e| panic!("stroke {defs:?}: {e}"));
            let reads_mask = module
                .global_variables
                .iter()
                // The WESL compiler decorates imported names.
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

#[test]
fn every_fringe_shadow_variant_composes_and_validates() {
    use super::MATERIAL_SHADERS;
    let mut compiler = ShaderCompiler::new(&bevy_shader_sources());
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "fringe_shadow.wesl")
        .expect("fringe_shadow.wesl is listed");
    // A face: positions, normals and UVs (Bevy's sphere has them all).
    let face = bevy::prelude::Mesh::from(bevy::prelude::Sphere::new(0.1));
    let vertex = mesh_pipeline_vertex_defs(&face);
    let mut checked = 0;
    for normals in [false, true] {
        for depth in [false, true] {
            for multisampled in [false, true] {
                let mut defs = vertex.clone();
                if normals {
                    defs.push("NORMAL_PREPASS");
                }
                if depth {
                    defs.push("DEPTH_PREPASS");
                }
                if multisampled {
                    defs.push("MULTISAMPLED");
                }
                let module = compiler
                    .compile(name, source, &defs, &values)
                    .unwrap_or_else(|e| panic!("fringe shadow {defs:?}: {e}"));
                let reads = |texture: &str| {
                    module
                        .global_variables
                        .iter()
                        .any(|(_, g)| g.name.as_deref().is_some_and(|n| n.contains(texture)))
                };
                assert_eq!(reads("normal_prepass_texture"), normals, "{defs:?}");
                assert_eq!(reads("depth_prepass_texture"), normals && depth, "{defs:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 8);
}

#[test]
fn every_see_through_variant_composes_and_validates() {
    use super::MATERIAL_SHADERS;
    let mut compiler = ShaderCompiler::new(&bevy_shader_sources());
    let values = bevy_value_defs();
    let (name, source) = MATERIAL_SHADERS
        .iter()
        .find(|(n, _)| *n == "see_through.wesl")
        .expect("see_through.wesl is listed");
    let eye = bevy::prelude::Mesh::from(bevy::prelude::Sphere::new(0.01));
    let mut checked = 0;
    for uvs in [false, true] {
        for prepasses in [false, true] {
            for multisampled in [false, true] {
                for projection in [
                    "VIEW_PROJECTION_PERSPECTIVE",
                    "VIEW_PROJECTION_ORTHOGRAPHIC",
                ] {
                    let mut defs = mesh_pipeline_vertex_defs(&eye);
                    if !uvs {
                        defs.retain(|d| *d != "VERTEX_UVS_A" && *d != "VERTEX_UVS");
                    }
                    if prepasses {
                        defs.extend(["NORMAL_PREPASS", "DEPTH_PREPASS"]);
                    }
                    if multisampled {
                        defs.push("MULTISAMPLED");
                    }
                    defs.push(projection);
                    let module = compiler
                        .compile(name, source, &defs, &values)
                        .unwrap_or_else(|e| panic!("see through {defs:?}: {e}"));
                    let reads = |texture: &str| {
                        module
                            .global_variables
                            .iter()
                            .any(|(_, g)| g.name.as_deref().is_some_and(|n| n.contains(texture)))
                    };
                    assert_eq!(reads("normal_prepass_texture"), prepasses, "{defs:?}");
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 16);
}
