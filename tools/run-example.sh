#!/usr/bin/env bash
# Runs the ninja-head example in a window. Installs what is missing first; without a display
# (a server, CI) the window opens on a virtual X display (xvfb-run).
# Extra arguments go to the example.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  tools/system-deps.sh mesa-vulkan-drivers libvulkan1 xvfb
  exec xvfb-run -a -s "-screen 0 1280x720x24" cargo run --features ui,demo --example ninja_head -- "$@"
fi
tools/system-deps.sh mesa-vulkan-drivers libvulkan1
exec cargo run --features ui,demo --example ninja_head -- "$@"
