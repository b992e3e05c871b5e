// ToonHairMaterial: cartoon shading from a ramp texture (Lake et al. 2000), extended to 2D
// "X-Toon" ramps (Barla et al. 2006), plus Blinn specular, back lighting and hatching.
//
// Shader defs (selected by the material key, one pipeline each):
//   RAMP_DEPTH | RAMP_BACK_LIGHT | RAMP_SPECULAR  the ramp's y axis (none: constant, a 1D ramp)
//   BLINN_SPECULAR                                 add (N.H)^shininess on top
//   BACK_LIGHT                                     add a rim: strength * (1 - |N.V|^r)
//   SCENE_LIGHTS                                   the ramp's x from every Bevy light (colour,
//                                                  intensity, shadows, ambient), not N.L
//   HATCHING                                       ink from a tonal art map, on the strand's
//                                                  surface, or on the screen with HATCH_SCREEN
//   ANGEL_RING                                     a highlight band across the hair where the
//                                                  strands run across the half vector
//   SPECULAR_LAYER                                 add the highlight drawn in a second ramp
//                                                  (y = (N.H)^shininess), whatever the first
//                                                  ramp's y axis is

#import bevy_pbr::{forward_io::VertexOutput, mesh_view_bindings::{view, lights}}
#import bevy_cartoon_hair::curves::{depth_detail, back_light}
#ifdef SCENE_LIGHTS
#import bevy_pbr::{pbr_types, pbr_functions, mesh_types::MESH_FLAGS_SHADOW_RECEIVER_BIT}
#endif

struct ToonHairUniform {
    base_color: vec4<f32>,
    specular_color: vec4<f32>,
    back_light_color: vec4<f32>,
    // x: z_min, y: z_scale, z: back light exponent r, w: shininess
    params: vec4<f32>,
    // x: specular strength, y: back light strength, z: hatching scale, w: ramp y when constant
    params2: vec4<f32>,
    // x: illuminance (lux) at the right end of the ramp (SCENE_LIGHTS), y: angel ring teeth
    // spacing (m), z: angel ring profile (0 even, 1 tapered, 2 zig-zag, 3 soft), w: specular
    // layer strength (SPECULAR_LAYER)
    params3: vec4<f32>,
    // rgb: angel ring colour, a: its opacity
    angel_ring_color: vec4<f32>,
    // x: band width, y: Kajiya-Kay exponent, z: shift along the normal
    angel_ring: vec4<f32>,
};

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<uniform> material: ToonHairUniform;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var ramp_texture: texture_2d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var ramp_sampler: sampler;
#ifdef HATCHING
@group(#{MATERIAL_BIND_GROUP}) @binding(3) var tam_texture: texture_2d_array<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(4) var tam_sampler: sampler;

// Ink from the tonal art map for a light level in [0, 1]: the two nearest tones are blended so
// there is no visible switch between layers (Praun et al.).
fn hatch(uv: vec2<f32>, light: f32) -> f32 {
    let tones = f32(textureNumLayers(tam_texture));
    // Light 1 -> lightest tone (0); light 0 -> darkest (tones - 1).
    let t = clamp((1.0 - light) * (tones - 1.0), 0.0, tones - 1.0);
    let lo = floor(t);
    let hi = min(lo + 1.0, tones - 1.0);
    let a = textureSample(tam_texture, tam_sampler, uv, i32(lo)).r;
    let b = textureSample(tam_texture, tam_sampler, uv, i32(hi)).r;
    return mix(a, b, t - lo);
}
#endif
#ifdef SPECULAR_LAYER
@group(#{MATERIAL_BIND_GROUP}) @binding(5) var specular_ramp_texture: texture_2d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(6) var specular_ramp_sampler: sampler;
#endif

#ifdef ANGEL_RING
// Opacity of the angel ring at a point with normal n, strand direction t (unit, root to tip),
// toward-light l and toward-eye v: Kajiya-Kay sin(T, H)^p on the shifted tangent, cut into a
// band by the profile.
fn angel_ring(n: vec3<f32>, t: vec3<f32>, l: vec3<f32>, v: vec3<f32>, p: vec3<f32>) -> f32 {
    let h = normalize(l + v);
    let shifted = normalize(t + n * material.angel_ring.z);
    let t_dot_h = dot(shifted, h);
    let kk = pow(sqrt(max(1.0 - t_dot_h * t_dot_h, 0.0)), material.angel_ring.y);
    var width = material.angel_ring.x;
    let profile = material.params3.z;
    if profile > 0.5 {
        // Tapered: thinner where the hair turns away from the view.
        width *= smoothstep(0.0, 0.8, dot(n, v));
    }
    if profile > 1.5 && profile < 2.5 {
        // Zig-zag: saw teeth along the strands, a world-space distance apart across them.
        let across = normalize(cross(t, v) + vec3<f32>(1e-6, 0.0, 0.0));
        let s = dot(p, across) / max(material.params3.y, 1e-4);
        width *= 0.35 + 0.65 * abs(fract(s) * 2.0 - 1.0);
    }
    let edge = 1.0 - width;
    var band = smoothstep(edge, edge + 0.02, kk);
    if profile > 2.5 {
        band = smoothstep(edge, 1.0, kk);
    }
    // Only where the light reaches the hair.
    return band * smoothstep(-0.05, 0.25, dot(n, l));
}
#endif

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    let n = normalize(in.world_normal);
#ifdef ANGEL_RING
#ifdef VERTEX_TANGENTS
    // The hair mesh's tangent is the strand's direction, root to tip.
    var strand = in.world_tangent.xyz;
#else
#ifdef VERTEX_UVS_A
    // Another mesh: where uv.y grows, from screen derivatives (in uniform control flow).
    var strand = dpdx(in.world_position.xyz) * dpdx(in.uv.y)
        + dpdy(in.world_position.xyz) * dpdy(in.uv.y);
#else
    // A mesh without UVs has no strand direction: no ring.
    var strand = vec3<f32>(0.0);
#endif
#endif
#endif
    let to_eye = view.world_position - in.world_position.xyz;
    // Toward the viewer: the camera's axis for an orthographic projection.
    let orthographic = view.clip_from_view[3].w == 1.0;
    var v = normalize(to_eye);
    if orthographic {
        v = normalize(vec3<f32>(view.clip_from_world[0].z, view.clip_from_world[1].z,
            view.clip_from_world[2].z));
    }
    var l = normalize(vec3<f32>(0.3, 1.0, 0.5));
    if lights.n_directional_lights > 0u {
        l = normalize(lights.directional_lights[0].direction_to_light);
    }
    var intensity = max(dot(n, l), 0.0);
    var tint = vec3<f32>(1.0);
#ifdef SCENE_LIGHTS
    // The light reaching this point from every light Bevy gives a PBR material (colour,
    // intensity, shadows, ambient and environment light), measured on a white, rough,
    // non-metallic surface. A white Lambert surface under E lux gives E * exposure / pi.
    var probe = pbr_types::pbr_input_new();
    probe.material.base_color = vec4<f32>(1.0);
    probe.material.perceptual_roughness = 1.0;
    probe.material.metallic = 0.0;
    probe.material.reflectance = vec3<f32>(0.0);
    probe.frag_coord = in.position;
    probe.world_position = in.world_position;
    probe.world_normal = n;
    probe.is_orthographic = orthographic;
    probe.N = n;
    probe.V = v;
    // Hair always receives shadows (the head's, the bangs', its own).
    probe.flags = MESH_FLAGS_SHADOW_RECEIVER_BIT;
    let light_in = pbr_functions::apply_pbr_lighting(probe).rgb;
    let luminance = dot(light_in, vec3<f32>(0.2126, 0.7152, 0.0722));
    intensity = clamp(luminance * 3.14159265 / (view.exposure * material.params3.x), 0.0, 1.0);
    // The light's hue, at the brightness the ramp gives.
    tint = light_in / max(luminance, 1e-6);
#endif
    let h = normalize(l + v);
    let n_dot_h = max(dot(n, h), 0.0);
    let shininess = max(material.params.w, 1.0);

    var y = material.params2.w;
#ifdef RAMP_DEPTH
    // Distance from the eye (not depth along the view axis, so detail does not change as the
    // head turns in view); D = 1 at z_min, 0 at z_min * z_scale.
    let z_min = max(material.params.x, 1e-3);
    y = depth_detail(length(to_eye), z_min, z_min * max(material.params.y, 1.0001));
#endif
#ifdef RAMP_BACK_LIGHT
    y = back_light(n, v, material.params.z);
#endif
#ifdef RAMP_SPECULAR
    y = pow(n_dot_h, shininess);
#endif
    // Row 0 of the texture is y = 0 at the bottom: flip for texture space.
    let ramp = textureSample(ramp_texture, ramp_sampler, vec2<f32>(intensity, 1.0 - clamp(y, 0.0, 1.0)));
    // RGB multiplies the hair colour; 1 - alpha adds the specular colour (drawn highlights).
    var color = material.base_color.rgb * ramp.rgb * tint
        + material.specular_color.rgb * (1.0 - ramp.a);

#ifdef SPECULAR_LAYER
    // Drawn highlights from their own ramp, on top of any main ramp (depth detail included).
    let drawn = textureSample(specular_ramp_texture, specular_ramp_sampler,
        vec2<f32>(intensity, 1.0 - clamp(pow(n_dot_h, shininess), 0.0, 1.0)));
    color += material.specular_color.rgb * tint * material.params3.w * (1.0 - drawn.a);
#endif
#ifdef BLINN_SPECULAR
    color += material.specular_color.rgb * material.params2.x * pow(n_dot_h, shininess)
        * step(0.0, dot(n, l));
#endif
#ifdef BACK_LIGHT
    // A rim where the hair turns away from the view, strongest against the light (contre-jour:
    // the light behind the hair, facing the viewer) and a quarter as strong lit from the front;
    // in the light's hue.
    let against_light = max(-dot(l, v), 0.0);
    color += material.back_light_color.rgb * tint * material.params2.y
        * (1.0 - back_light(n, v, material.params.z)) * (0.25 + 0.75 * against_light);
#endif

#ifdef ANGEL_RING
    strand -= n * dot(n, strand);
    if dot(strand, strand) > 1e-20 {
        let ring = angel_ring(n, normalize(strand), l, v, in.world_position.xyz)
            * material.angel_ring_color.a;
        color = mix(color, material.angel_ring_color.rgb * tint, ring * step(0.05, intensity));
    }
#endif

#ifdef HATCHING
    // Tone from the light intensity (thesis 4.3.8), so darker regions get denser strokes.
    let light = intensity;
    let scale = max(material.params2.z, 1e-3);
#ifdef HATCH_SCREEN
    // Lake et al.: projected on the screen (strokes stay put as hair moves).
    let uv = in.position.xy / (256.0 * scale);
#else
#ifdef VERTEX_UVS_A
    // Praun et al.: on the strand's surface, coherent as hair moves. Strokes run along the
    // strand (texture x = v along it, texture y = u around it).
    var around = in.uv.x;
#ifdef VERTEX_UVS_B
    // Seamless u (Tarini 2012): uv_b.x is u + 0.5 wrapped; use whichever varies less here.
    if fwidth(in.uv_b.x) < fwidth(in.uv.x) {
        around = in.uv_b.x - 0.5;
    }
#endif
    let uv = vec2<f32>(in.uv.y * 2.0, around) / scale;
#else
    // A mesh without UVs (a scalp, a prop) hatches on the screen.
    let uv = in.position.xy / (256.0 * scale);
#endif
#endif
    color *= hatch(uv, light);
#endif
    return vec4<f32>(color, material.base_color.a);
}
