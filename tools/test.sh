#!/usr/bin/env bash
# Runs every test of the crate: Rust unit and integration tests (render tests on whatever Vulkan
# adapter exists; lavapipe on a CPU-only machine) and doc tests.
# Installs the system packages it needs first. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/system-deps.sh mesa-vulkan-drivers libvulkan1
cargo test --all-features "$@"
