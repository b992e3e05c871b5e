//! The crate's one integration-test binary (each test binary links all of Bevy, so there is one).
//!
//! It uses its own harness (libtest-mimic) so that render tests can be reported honestly:
//! - with a Vulkan adapter (a GPU, or lavapipe on a CPU-only machine) they run;
//! - without one and with `CI` set they run and fail, saying what to install;
//! - without one and without `CI` they are reported as *ignored*, never as passed.
//!
//! Render tests run one at a time (each starts a renderer); other tests run in parallel. Blender
//! tests (the add-on round trip) follow the same rule as render tests when `bpy` is missing.

mod assets;
mod avatar_looks;
mod chain_render;
mod character_render;
mod clip;
mod fringe_render;
mod gpu_fallback_render;
mod gpu_tubes_render;
mod hairstyle_render;
mod half_tube_render;
mod hot_reload;
mod lighting_render;
mod lock_render;
mod look_suite;
mod mass_render;
mod mtoon_rim_render;
mod mtoon_shading_render;
mod outline_render;
mod render_smoke;
mod ring_render;
mod see_through_render;
mod shadow_render;
mod silhouette_render;
mod toon_render;
mod user_mesh_render;
mod vrm_interop_render;
mod vrm_materials_render;
mod vrm_render;

use libtest_mimic::{Arguments, Failed, Trial};
use std::sync::Mutex;

/// A test's body: `Err` with a message fails it.
pub type TestFn = fn() -> Result<(), Failed>;

/// The repository root: `CARGO_MANIFEST_DIR` as the test runs (cargo sets it; a copied test
/// binary run elsewhere is given it), else where the binary was built.
pub fn repo() -> std::path::PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR").map_or_else(
        || env!("CARGO_MANIFEST_DIR").into(),
        std::path::PathBuf::from,
    )
}

/// Serialises render tests: two renderers at once only slow each other down on lavapipe.
static RENDER_LOCK: Mutex<()> = Mutex::new(());

fn main() {
    let args = Arguments::from_args();
    let in_ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty() && v != "false");
    let adapter = bevy_cartoon_hair::headless::find_adapter();
    match (&adapter, in_ci) {
        (Ok(name), _) => eprintln!("render tests use the adapter: {name}"),
        (Err(e), true) => eprintln!("CI is set, so render tests will fail: {e}"),
        (Err(e), false) => eprintln!("render tests are ignored (not run): {e}"),
    }
    let skip_render = adapter.is_err() && !in_ci;

    let mut trials = Vec::new();
    for (name, test) in render_smoke::RENDER_TESTS
        .iter()
        .chain(toon_render::RENDER_TESTS)
        .chain(silhouette_render::RENDER_TESTS)
        .chain(outline_render::RENDER_TESTS)
        .chain(clip::RENDER_TESTS)
        .chain(character_render::RENDER_TESTS)
        .chain(lighting_render::RENDER_TESTS)
        .chain(mass_render::RENDER_TESTS)
        .chain(look_suite::RENDER_TESTS)
        .chain(chain_render::RENDER_TESTS)
        .chain(vrm_render::RENDER_TESTS)
        .chain(vrm_interop_render::RENDER_TESTS)
        .chain(fringe_render::RENDER_TESTS)
        .chain(lock_render::RENDER_TESTS)
        .chain(ring_render::RENDER_TESTS)
        .chain(hairstyle_render::RENDER_TESTS)
        .chain(gpu_tubes_render::RENDER_TESTS)
        .chain(gpu_fallback_render::RENDER_TESTS)
        .chain(see_through_render::RENDER_TESTS)
        .chain(shadow_render::RENDER_TESTS)
        .chain(half_tube_render::RENDER_TESTS)
        .chain(avatar_looks::RENDER_TESTS)
        .chain(user_mesh_render::RENDER_TESTS)
        .chain(vrm_materials_render::RENDER_TESTS)
        .chain(mtoon_shading_render::RENDER_TESTS)
        .chain(mtoon_rim_render::RENDER_TESTS)
    {
        let test = *test;
        trials.push(
            Trial::test(format!("render::{name}"), move || {
                let _guard = RENDER_LOCK
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                test()
            })
            .with_ignored_flag(skip_render),
        );
    }
    for (name, test) in assets::TESTS {
        trials.push(Trial::test(format!("assets::{name}"), *test));
    }
    for (name, test) in hot_reload::TESTS {
        trials.push(Trial::test(format!("assets::{name}"), *test));
    }
    for (name, test) in clip::TESTS {
        trials.push(Trial::test(format!("demo::{name}"), *test));
    }
    // Blender (`bpy` from PyPI, installed by tools/test.sh): like render tests, ignored when
    // missing outside CI, failing in CI.
    let blender = assets::blender_available();
    if !blender {
        eprintln!(
            "Blender tests need `python3 -m pip install bpy==4.5.4`; {}",
            if in_ci {
                "CI is set, so they will fail"
            } else {
                "they are ignored (not run)"
            }
        );
    }
    for (name, test) in assets::BLENDER_TESTS {
        let test = *test;
        trials.push(
            Trial::test(format!("blender::{name}"), move || {
                if !blender {
                    return Err(
                        "Blender's bpy module is not installed: python3 -m pip install bpy==4.5.4"
                            .into(),
                    );
                }
                test()
            })
            .with_ignored_flag(!blender && !in_ci),
        );
    }
    libtest_mimic::run(&args, trials).exit();
}
