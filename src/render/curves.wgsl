#define_import_path bevy_cartoon_hair::curves

// Depth detail (Barla et al. 2006): D = 1 - log(z / zmin) / log(zmax / zmin), clamped to [0, 1].
fn depth_detail(z: f32, zmin: f32, zmax: f32) -> f32 {
    let lo = max(zmin, 1e-4);
    let hi = max(zmax, lo * 1.0001);
    return clamp(1.0 - log(max(z, lo) / lo) / log(hi / lo), 0.0, 1.0);
}

// Back lighting (contre-jour): |N.V|^r with r >= 0.
fn back_light(n: vec3<f32>, v: vec3<f32>, r: f32) -> f32 {
    return pow(abs(dot(n, v)), max(r, 0.0));
}
