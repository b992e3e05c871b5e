// Image-space silhouette edges (thesis 4.3.7; Redmond et al., Shin et al.): Sobel on a buffer in
// which objects are flat (the depth and normal prepass, never the lit colour, so toon bands are
// not edges), a threshold, dilation in x then y, and the ink composited over the frame.
//
// Three fullscreen passes, one entry point each (see outline.rs):
//   detect     prepass depth/normals -> edge mask (R8, 1 = edge)
//   dilate_x   edge mask -> mask dilated by dilation_x pixels horizontally
//   composite  dilates that by dilation_y pixels vertically and mixes the ink over the frame
//
// Shader defs (selected by the view's key, one pipeline each):
//   EDGE_DEPTH     Sobel on the prepass depth, relative to the nearest surface around
//   EDGE_NORMALS   Sobel on the prepass world normals
//   EDGE_MASS      (with both) the mass's outline: Sobel on the hair mask (normal alpha 0 on
//                  hair, hair_prepass.wgsl) and on coverage (depth > 0), plus the relative depth
//                  step; the normals only draw inner lines above inner_threshold
//   MULTISAMPLED   the prepass textures are multisampled (MSAA on); sample 0 is read

#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

struct ImageSpaceOutline {
    // Linear RGB ink; alpha is its opacity.
    color: vec4<f32>,
    threshold: f32,
    dilation_x: u32,
    dilation_y: u32,
    inner_threshold: f32,
};

// Each pass binds only what its entry point uses; bindings are numbered apart so that the passes
// share one module.
@group(0) @binding(0) var<uniform> outline: ImageSpaceOutline;

#ifdef EDGE_DEPTH
#ifdef MULTISAMPLED
@group(0) @binding(1) var depth_texture: texture_depth_multisampled_2d;
#else
@group(0) @binding(1) var depth_texture: texture_depth_2d;
#endif
#endif

#ifdef EDGE_NORMALS
#ifdef MULTISAMPLED
@group(0) @binding(2) var normal_texture: texture_multisampled_2d<f32>;
#else
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
#endif
#endif

@group(0) @binding(3) var edge_mask: texture_2d<f32>;
@group(0) @binding(4) var dilated_mask: texture_2d<f32>;
@group(0) @binding(5) var screen_texture: texture_2d<f32>;

// The dilation loops never run longer than this (matches MAX_OUTLINE_DILATION in outline.rs).
const MAX_DILATION: u32 = 32u;

fn pixel(in: FullscreenVertexOutput) -> vec2<i32> {
    return vec2<i32>(floor(in.position.xy));
}

#ifdef EDGE_DEPTH
// Reverse-Z depth: 1 at the near plane, 0 for the background (infinitely far).
fn load_depth(p: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(depth_texture));
    // Sample 0 when multisampled, mip 0 otherwise.
    return textureLoad(depth_texture, clamp(p, vec2<i32>(0), size - 1), 0);
}
#endif

#ifdef EDGE_NORMALS
// World normal, or zero where nothing was drawn (the prepass clears to black).
fn load_normal(p: vec2<i32>) -> vec3<f32> {
    let size = vec2<i32>(textureDimensions(normal_texture));
    let encoded = textureLoad(normal_texture, clamp(p, vec2<i32>(0), size - 1), 0).xyz;
    if dot(encoded, encoded) < 1e-4 {
        return vec3<f32>(0.0);
    }
    return encoded * 2.0 - 1.0;
}

// 1 where hair was drawn: the hair's prepass writes alpha 0, everything else (and the clear) 1.
fn load_hair(p: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(normal_texture));
    let alpha = textureLoad(normal_texture, clamp(p, vec2<i32>(0), size - 1), 0).a;
    return select(0.0, 1.0, alpha < 0.5);
}
#endif

// Sobel (both kernels) on the flat buffer, magnitude sqrt(gx^2 + gy^2) summed over its channels,
// thresholded. The kernels are scaled by 1/4, so a step of height 1 gives a magnitude of 1.
@fragment
fn detect(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let p = pixel(in);
    var depth_gx = 0.0;
    var depth_gy = 0.0;
    var nearest = 0.0;
    var normal_gx = vec3<f32>(0.0);
    var normal_gy = vec3<f32>(0.0);
    var mask_g = vec4<f32>(0.0);
    for (var j = -1; j <= 1; j += 1) {
        for (var i = -1; i <= 1; i += 1) {
            // Gx = [-1 0 1; -2 0 2; -1 0 1], Gy its transpose.
            let wx = f32(i) * f32(2 - abs(j));
            let wy = f32(j) * f32(2 - abs(i));
            let q = p + vec2<i32>(i, j);
#ifdef EDGE_DEPTH
            let d = load_depth(q);
            depth_gx += wx * d;
            depth_gy += wy * d;
            nearest = max(nearest, d);
#endif
#ifdef EDGE_NORMALS
            let n = load_normal(q);
            normal_gx += wx * n;
            normal_gy += wy * n;
#endif
#ifdef EDGE_MASS
            // (hair, covered) stepped in x and y.
            let covered = select(0.0, 1.0, d > 0.0);
            let hair = load_hair(q) * covered;
            mask_g += vec4<f32>(wx * hair, wy * hair, wx * covered, wy * covered);
#endif
        }
    }
    var magnitude2 = 0.0;
#ifdef EDGE_DEPTH
    // Reverse-Z depth is 1/distance up to a constant: divided by the nearest surface's, a jump to
    // the background gives 1 and a strand in front of another at 1.2x its distance gives 1/6,
    // whatever the distance to the camera. Nothing around: no edge.
    let scale = select(0.0, 1.0 / nearest, nearest > 0.0);
    magnitude2 += (depth_gx * depth_gx + depth_gy * depth_gy) * scale * scale;
#endif
#ifdef EDGE_MASS
    // A step of the hair mask or of coverage is an edge at any threshold below 1; the normals
    // only give inner lines, against their own threshold.
    let mask_magnitude = 0.25 * length(mask_g);
    let inner = 0.25 * sqrt(dot(normal_gx, normal_gx) + dot(normal_gy, normal_gy));
    let mass_edge = mask_magnitude > 0.5 || inner > outline.inner_threshold;
#else
#ifdef EDGE_NORMALS
    magnitude2 += dot(normal_gx, normal_gx) + dot(normal_gy, normal_gy);
#endif
    let mass_edge = false;
#endif
    let magnitude = 0.25 * sqrt(magnitude2);
    let edge = select(0.0, 1.0, mass_edge || magnitude > outline.threshold);
    return vec4<f32>(edge, 0.0, 0.0, 1.0);
}

// Maximum of `mask` over `radius` pixels either side of `p` along `axis`.
fn dilate(mask: texture_2d<f32>, p: vec2<i32>, axis: vec2<i32>, radius: u32) -> f32 {
    let size = vec2<i32>(textureDimensions(mask));
    let r = i32(min(radius, MAX_DILATION));
    var edge = 0.0;
    for (var k = -r; k <= r; k += 1) {
        let q = clamp(p + axis * k, vec2<i32>(0), size - 1);
        edge = max(edge, textureLoad(mask, q, 0).r);
        if edge >= 1.0 {
            break;
        }
    }
    return edge;
}

// A pixel becomes edge if an edge lies within dilation_x pixels horizontally.
@fragment
fn dilate_x(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let edge = dilate(edge_mask, pixel(in), vec2<i32>(1, 0), outline.dilation_x);
    return vec4<f32>(edge, 0.0, 0.0, 1.0);
}

// ... and within dilation_y pixels vertically of that; then the ink goes over the frame.
@fragment
fn composite(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let p = pixel(in);
    let edge = dilate(dilated_mask, p, vec2<i32>(0, 1), outline.dilation_y);
    let scene = textureLoad(screen_texture, p, 0);
    return vec4<f32>(mix(scene.rgb, outline.color.rgb, edge * outline.color.a), scene.a);
}
