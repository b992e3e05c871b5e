#!/usr/bin/env bash
# Runs the ninja-head example in a window. Installs what is missing first; without a display
# (a server, CI) the window opens on a virtual X display (xvfb-run). Builds with every feature,
# as tools/test.sh does, so the two share one build.
# Extra arguments go to the example.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/toolchain.sh
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  tools/system-deps.sh mesa-vulkan-drivers libvulkan1 xvfb
  exec xvfb-run -a -s "-screen 0 1280x720x24" "${CARGO[@]}" run "${CARGO_BUILD_FLAGS[@]}" \
    --all-features --example ninja_head -- "$@"
fi
tools/system-deps.sh mesa-vulkan-drivers libvulkan1
exec "${CARGO[@]}" run "${CARGO_BUILD_FLAGS[@]}" --all-features --example ninja_head -- "$@"
