//! The crate's one integration-test binary (each test binary links all of Bevy, so there is one).
//!
//! It uses its own harness (libtest-mimic) so that render tests can be reported honestly:
//! - with a Vulkan adapter (a GPU, or lavapipe on a CPU-only machine) they run;
//! - without one and with `CI` set they run and fail, saying what to install;
//! - without one and without `CI` they are reported as *ignored*, never as passed.
//!
//! Render tests run one at a time (each starts a renderer); other tests run in parallel.

mod render_smoke;
mod toon_render;

use libtest_mimic::{Arguments, Failed, Trial};
use std::sync::Mutex;

/// A test's body: `Err` with a message fails it.
pub type TestFn = fn() -> Result<(), Failed>;

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
    {
        let test = *test;
        trials.push(
            Trial::test(format!("render::{name}"), move || {
                let _guard = RENDER_LOCK.lock().unwrap_or_else(|p| p.into_inner());
                test()
            })
            .with_ignored_flag(skip_render),
        );
    }
    libtest_mimic::run(&args, trials).exit();
}
