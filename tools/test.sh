#!/usr/bin/env bash
# Runs every test of the crate:
#  - the Blender add-on's tests (real Blender: the `bpy` 4.5 LTS module from PyPI, headless);
#  - Rust unit and integration tests: simulation, assets (the Blender -> Rust round trip among
#    them), render tests on whatever Vulkan adapter exists (lavapipe on a CPU-only machine);
#  - doc tests.
# Installs what it needs first (Mesa's Vulkan driver; bpy for Python 3.11). Builds with every
# feature, as tools/run-example.sh does, so the two share one build.
# Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/toolchain.sh
tools/system-deps.sh mesa-vulkan-drivers libvulkan1
# Mesa's Vulkan loader warns on every device creation when this is unset (CI, containers).
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  XDG_RUNTIME_DIR="$(mktemp -d)"
  export XDG_RUNTIME_DIR
fi
if ! python3 -c "import bpy" >/dev/null 2>&1; then
  echo "Installing Blender as a Python module (bpy 4.5.4) ..." >&2
  python3 -m pip install --quiet --disable-pip-version-check bpy==4.5.4
fi
python3 -m unittest discover -s tools/blender/tests
"${CARGO[@]}" test "${CARGO_BUILD_FLAGS[@]}" --all-features "$@"
