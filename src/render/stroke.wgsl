// HairStrokeMaterial: object-space silhouette strokes, the stroke texture times the vertex
// colour (stroke colour, E-curve fade in alpha).
//
// With the mass scope (settings.x = 1) and a normal prepass on the view, a stroke pixel is kept
// only near the edge of the hair mass: where something that is not hair (the background, the
// face, a prop) lies within the stroke's own width plus settings.y pixels. The hair's prepass
// marks hair with alpha 0 in the normal target (hair_prepass.wgsl); strokes do not draw in the
// prepass. So a strand's outline shows where the strand is the hair's outer edge and nowhere
// inside the hair. Without a normal prepass every stroke is drawn.

#import bevy_pbr::forward_io::VertexOutput
#ifdef NORMAL_PREPASS
#import bevy_pbr::mesh_view_bindings::normal_prepass_texture
#endif

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var stroke_texture: texture_2d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var stroke_sampler: sampler;
// x: 1 for the mass scope, 0 for every strand; y: extra reach (pixels) beyond the stroke width
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var<uniform> settings: vec4<f32>;

#ifdef NORMAL_PREPASS
// Whether pixel p is hair in the prepass; pixels off the screen are not.
fn is_hair(p: vec2<i32>) -> bool {
    let size = vec2<i32>(textureDimensions(normal_prepass_texture));
    if any(p < vec2<i32>(0)) || any(p >= size) {
        return false;
    }
    return textureLoad(normal_prepass_texture, p, 0).a < 0.5;
}
#endif

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    var color = textureSample(stroke_texture, stroke_sampler, in.uv);
#ifdef VERTEX_COLORS
    color *= in.color;
#endif
    // The strip's v runs 0 to 1 across it: its width on screen, in pixels.
    let width = 1.0 / max(fwidth(in.uv.y), 1e-3);
#ifdef NORMAL_PREPASS
    if settings.x > 0.5 {
        let reach = min(width, 64.0) + settings.y;
        let centre = vec2<i32>(floor(in.position.xy));
        var outside = !is_hair(centre);
        // Eight directions at the full reach and at half of it.
        for (var i = 0; i < 8; i++) {
            let a = f32(i) * 0.7853982;
            let d = vec2<f32>(cos(a), sin(a));
            outside = outside || !is_hair(centre + vec2<i32>(round(d * reach)))
                || !is_hair(centre + vec2<i32>(round(d * reach * 0.5)));
        }
        if !outside {
            discard;
        }
    }
#endif
    return color;
}
