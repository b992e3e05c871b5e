//! The WGSL structs the passes read against the Rust ones that fill them: each pass shader is
//! compiled with the shader defs the pipelines get, and naga's layout of every struct (size,
//! member offsets) must match what encase writes for the Rust record.

use bevy::prelude::*;
use bevy::render::render_resource::ShaderType;
use bevy::render::render_resource::encase::internal::WriteInto;
use bevy::render::render_resource::encase::{ShaderSize, StorageBuffer};

use super::highlights::GpuHighlightRecord;
use super::shadows::GpuShadowRecord;
use super::strokes::GpuStrokeRecord;
use super::toolbox::{GpuBatch, shader_defs};
use super::tubes::{GpuStrand, GpuTubeHair};
use crate::render::PASS_SHADERS;
use crate::render::shader_validation::ShaderCompiler;

/// `value`'s bytes as encase writes it into a storage buffer.
fn bytes<T: ShaderType + ShaderSize + WriteInto>(value: &T) -> Vec<u8> {
    let mut buffer = StorageBuffer::new(Vec::new());
    buffer.write(value).expect("encase writes the record");
    buffer.into_inner()
}

fn word(bytes: &[u8], offset: usize) -> u32 {
    u32::from_le_bytes(bytes[offset..offset + 4].try_into().expect("4 bytes"))
}

/// Checks the struct named `name` (or ending in `_name`, as WESL mangles imported items) in the
/// compiled `shader` against `value`: same size, and each member (but padding) at an offset
/// where `value`'s bytes hold `expected[member]`, the member's first word.
fn check<T: ShaderType + ShaderSize + WriteInto>(
    shader: &str,
    name: &str,
    value: &T,
    expected: &[(&str, u32)],
) {
    let (file, source) = PASS_SHADERS
        .iter()
        .find(|(n, _)| *n == shader)
        .unwrap_or_else(|| panic!("{shader} is listed"));
    let module = ShaderCompiler::new(&[])
        .compile(file, source, &[], &shader_defs())
        .unwrap_or_else(|e| panic!("{e}"));
    let (members, span) = module
        .types
        .iter()
        .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
            (Some(n), naga::TypeInner::Struct { members, span })
                if n == name || n.ends_with(&format!("_{name}")) =>
            {
                Some((members.clone(), *span))
            }
            _ => None,
        })
        .unwrap_or_else(|| panic!("{shader} has no struct {name}"));
    let encoded = bytes(value);
    assert_eq!(
        u64::from(span),
        T::SHADER_SIZE.get(),
        "{shader}'s {name} is {span} bytes, the Rust record {}",
        T::SHADER_SIZE
    );
    let mut seen = 0;
    for member in &members {
        let member_name = member.name.as_deref().unwrap_or_default();
        if member_name.starts_with("pad") {
            continue;
        }
        let want = expected
            .iter()
            .find(|(n, _)| *n == member_name)
            .unwrap_or_else(|| panic!("{shader}'s {name}.{member_name} has no Rust field"))
            .1;
        let got = word(&encoded, member.offset as usize);
        assert_eq!(
            got, want,
            "{shader}'s {name}.{member_name} at offset {} reads another Rust field",
            member.offset
        );
        seen += 1;
    }
    assert_eq!(seen, expected.len(), "{shader}'s {name} lacks a Rust field");
}

/// Distinct markers: `u(i)` a u32 field's value, `f(i)` a vector field's first component.
fn u(i: u32) -> u32 {
    1000 + i
}

fn f(i: u32) -> Vec4 {
    Vec4::splat(i as f32 + 0.5)
}

fn fw(i: u32) -> u32 {
    (i as f32 + 0.5).to_bits()
}

#[test]
fn the_tube_pass_reads_the_rust_records_where_they_are_written() {
    let hair = GpuTubeHair {
        vertex_base: u(0),
        stride: u(1),
        position_offset: u(2),
        normal_offset: u(3),
        tangent_offset: u(4),
        rings: u(5),
        sides: u(6),
        strands: u(7),
        shape: f(8),
        mass_centre: f(9),
        metric_x: f(10),
        metric_y: f(11),
        metric_z: f(12),
        up: f(13),
        eye: f(14),
        first_strand: u(15),
        frame_base: u(16),
        closed_sides: u(17),
        pad: 0,
    };
    let names = [
        "vertex_base",
        "stride",
        "position_offset",
        "normal_offset",
        "tangent_offset",
        "rings",
        "sides",
        "strands",
    ];
    let mut expected: Vec<(&str, u32)> = names
        .iter()
        .enumerate()
        .map(|(i, n)| (*n, u(i as u32)))
        .collect();
    for (i, n) in [
        "shape",
        "mass_centre",
        "metric_x",
        "metric_y",
        "metric_z",
        "up",
        "eye",
    ]
    .into_iter()
    .enumerate()
    {
        expected.push((n, fw(8 + i as u32)));
    }
    expected.extend([
        ("first_strand", u(15)),
        ("frame_base", u(16)),
        ("closed_sides", u(17)),
    ]);
    check("gpu/tubes.wesl", "Hair", &hair, &expected);

    let strand = GpuStrand {
        reference_direction: f(0),
        reference_normal: f(1),
        first: u(2),
        count: u(3),
        section: u(4),
        hair: u(5),
    };
    let expected = [
        ("reference_direction", fw(0)),
        ("reference_normal", fw(1)),
        ("first", u(2)),
        ("count", u(3)),
        ("section", u(4)),
        ("hair", u(5)),
    ];
    check("gpu/tubes.wesl", "Strand", &strand, &expected);
    check("gpu/strokes.wesl", "Strand", &strand, &expected);

    let batch = GpuBatch {
        invocations: u(0),
        records: u(1),
        pad: UVec2::ZERO,
    };
    let expected = [("invocations", u(0)), ("records", u(1))];
    for shader in [
        "gpu/tubes.wesl",
        "gpu/strokes.wesl",
        "gpu/highlights.wesl",
        "gpu/shadows.wesl",
    ] {
        check(shader, "Batch", &batch, &expected);
    }
}

#[test]
fn the_stroke_highlight_and_shadow_passes_read_the_rust_records_where_they_are_written() {
    let stroke = GpuStrokeRecord {
        view_proj: Mat4::from_cols(f(0), f(100), f(101), f(102)),
        unproject_x: f(1),
        unproject_y: f(2),
        viewer: f(3),
        screen: f(4),
        width: f(5),
        fade: f(6),
        color: f(7),
        vertex_base: u(8),
        stride: u(9),
        position_offset: u(10),
        uv_offset: u(11),
        color_offset: u(12),
        rings: u(13),
        sides: u(14),
        strands: u(15),
        first_strand: u(16),
        frame_base: u(17),
        first_invocation: u(18),
        index_base: u(19),
        draw: u(20),
        pad: UVec2::ZERO,
    };
    let vectors = [
        "view_proj",
        "unproject_x",
        "unproject_y",
        "viewer",
        "screen",
        "width",
        "fade",
        "color",
    ];
    let words = [
        "vertex_base",
        "stride",
        "position_offset",
        "uv_offset",
        "color_offset",
        "rings",
        "sides",
        "strands",
        "first_strand",
        "frame_base",
        "first_invocation",
        "index_base",
        "draw",
    ];
    let expected: Vec<(&str, u32)> = vectors
        .iter()
        .enumerate()
        .map(|(i, n)| (*n, fw(i as u32)))
        .chain(words.iter().enumerate().map(|(i, n)| (*n, u(8 + i as u32))))
        .collect();
    check("gpu/strokes.wesl", "Job", &stroke, &expected);

    let highlight = GpuHighlightRecord {
        eye: f(0),
        to_light: f(1),
        settings: f(2),
        vertex_base: u(3),
        stride: u(4),
        position_offset: u(5),
        uv_offset: u(6),
        rings: u(7),
        strands: u(8),
        frame_base: u(9),
        first_invocation: u(10),
        index_base: u(11),
        draw: u(12),
        pad: UVec2::ZERO,
    };
    let expected = [
        ("eye", fw(0)),
        ("to_light", fw(1)),
        ("settings", fw(2)),
        ("vertex_base", u(3)),
        ("stride", u(4)),
        ("position_offset", u(5)),
        ("uv_offset", u(6)),
        ("rings", u(7)),
        ("strands", u(8)),
        ("frame_base", u(9)),
        ("first_invocation", u(10)),
        ("index_base", u(11)),
        ("draw", u(12)),
    ];
    check("gpu/highlights.wesl", "Job", &highlight, &expected);

    let shadow = GpuShadowRecord {
        light: f(0),
        vertex_base: u(1),
        stride: u(2),
        position_offset: u(3),
        pad: 0,
        rings: u(5),
        strands: u(6),
        frame_base: u(7),
        first_invocation: u(8),
    };
    let expected = [
        ("light", fw(0)),
        ("vertex_base", u(1)),
        ("stride", u(2)),
        ("position_offset", u(3)),
        ("rings", u(5)),
        ("strands", u(6)),
        ("frame_base", u(7)),
        ("first_invocation", u(8)),
    ];
    check("gpu/shadows.wesl", "Job", &shadow, &expected);
}
