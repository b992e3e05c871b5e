//! Tells the crate's tests whether the machine building them has AVX2, so that the tests which
//! compare the AVX2 kernels with the portable ones are reported as not run (ignored) on a CPU
//! without it, never as passed. Changes nothing in the library.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(cartoon_hair_avx2_host)");
    println!("cargo::rerun-if-changed=build.rs");
    let host = std::env::var("HOST").unwrap_or_default();
    let target = std::env::var("TARGET").unwrap_or_default();
    #[cfg(target_arch = "x86_64")]
    if host == target && std::arch::is_x86_feature_detected!("avx2") {
        println!("cargo::rustc-cfg=cartoon_hair_avx2_host");
    }
    let _ = (host, target);
}
