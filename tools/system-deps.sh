#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages the crate needs at run and test time, if any are missing:
#   mesa-vulkan-drivers libvulkan1 : a Vulkan adapter (lavapipe renders on the CPU when no GPU)
#   xvfb                           : a virtual display, to open a window on a machine without one
# Building needs no system headers: Bevy's audio and gamepad features are off, X11 is dlopen'ed.
# Usage: tools/system-deps.sh [package...]   (default: all of the above)
set -euo pipefail
wanted=("$@")
[ ${#wanted[@]} -gt 0 ] || wanted=(mesa-vulkan-drivers libvulkan1 xvfb)
missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if ! command -v apt-get >/dev/null; then
  echo "Please install the equivalents of: ${missing[*]} (no apt-get on this machine)" >&2
  exit 1
fi
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "Installing ${missing[*]} ..." >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
