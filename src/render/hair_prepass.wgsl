// The hair's own prepass fragment: Bevy's default prepass (prepass.wgsl) with one change, the
// normal target's alpha is 0 on hair. Bevy clears that target to opaque black and every other
// opaque material writes alpha 1, so the alpha is a hair mask the image-space outline reads
// (OutlineSource::Mass): where it steps, hair meets something else.

#import bevy_pbr::prepass_io::{VertexOutput, FragmentOutput}

#ifdef MOTION_VECTOR_PREPASS
#import bevy_pbr::{prepass_bindings, mesh_view_bindings::view}
#endif

// The normal target's alpha on hair (Rgb10a2: two bits, so 0 or 1 read back exactly).
const HAIR_MASK_ALPHA: f32 = 0.0;

#ifdef PREPASS_FRAGMENT
@fragment
fn fragment(in: VertexOutput) -> FragmentOutput {
    var out: FragmentOutput;

#ifdef NORMAL_PREPASS
    out.normal = vec4(in.world_normal * 0.5 + vec3(0.5), HAIR_MASK_ALPHA);
#endif

#ifdef UNCLIPPED_DEPTH_ORTHO_EMULATION
    out.frag_depth = in.unclipped_depth;
#endif

#ifdef MOTION_VECTOR_PREPASS
    let clip_position_t = view.unjittered_clip_from_world * in.world_position;
    let clip_position = clip_position_t.xy / clip_position_t.w;
    let previous_clip_position_t =
        prepass_bindings::previous_view_uniforms.clip_from_world * in.previous_world_position;
    let previous_clip_position = previous_clip_position_t.xy / previous_clip_position_t.w;
    out.motion_vector = (clip_position - previous_clip_position) * vec2(0.5, -0.5);
#endif

    return out;
}
#endif
