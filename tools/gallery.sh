#!/usr/bin/env bash
# Regenerates the README's gallery in docs/images/: every shipped look on every hairstyle of the
# ninja, front, side and back (from the look suite's frames), and a head-shake clip per
# hairstyle (from the example's headless recorder), on whatever Vulkan adapter exists (lavapipe
# on a CPU-only machine). Needs Python 3 with Pillow. Takes about 15 minutes on 2 cores once
# built.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/toolchain.sh
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/bevy_cartoon_hair/target}"
frames="$(mktemp -d)"
trap 'rm -rf "$frames"' EXIT

# The look suite writes look_<look>[_<hairstyle>]_<view>.png.
mkdir -p "$frames/looks"
CI=true HAIR_LOOK_SUITE_ALL=1 HAIR_TEST_PNG_DIR="$frames/looks" "${CARGO[@]}" test "${CARGO_BUILD_FLAGS[@]}" \
  --all-features --test integration -- look_suite

# A head shake per hairstyle: 48 frames at 1/30 s from 2.9 s into the idle animation's loop
# (the quick shake is at 3.0-3.5 s), seen from the face's left.
"${CARGO[@]}" build "${CARGO_BUILD_FLAGS[@]}" --all-features --example ninja_head
example="$CARGO_TARGET_DIR/debug/examples/ninja_head"
for style in spiky long bangs twin_tails; do
  look=clean_anime
  [ "$style" = spiky ] || look=anime_locks
  BEVY_ASSET_ROOT="$PWD" "$example" --headless --hairstyle "$style" --preset "$look" \
    --frames 135 --size 320x240 --out "$frames/clip_$style"
done

python3 - "$frames" <<'EOF'
import glob, os, sys
from PIL import Image

frames = sys.argv[1]
out = "docs/images"
looks = ["thesis", "clean_anime", "sketch", "anime_locks"]
views = ["front", "side", "back"]
tile = (180, 135)


def sheet(style):
    suffix = "" if style == "spiky" else f"_{style}"
    img = Image.new("RGB", (tile[0] * len(views), tile[1] * len(looks)), "white")
    for row, look in enumerate(looks):
        for col, view in enumerate(views):
            frame = Image.open(f"{frames}/looks/look_{look}{suffix}_{view}.png").convert("RGB")
            # The look suite's 320x240 frames, the character's top half.
            img.paste(frame.crop((40, 0, 280, 180)).resize(tile, Image.LANCZOS),
                      (col * tile[0], row * tile[1]))
    return img


sheet("spiky").save(f"{out}/looks.png")
for style in ["long", "bangs", "twin_tails"]:
    sheet(style).save(f"{out}/looks_{style}.png")
for style in ["spiky", "long", "bangs", "twin_tails"]:
    paths = sorted(glob.glob(f"{frames}/clip_{style}/frame_*.png"))[87:135]
    clip = [Image.open(p).convert("RGB").quantize(64) for p in paths]
    name = "head_shake.gif" if style == "spiky" else f"head_shake_{style}.gif"
    clip[0].save(f"{out}/{name}", save_all=True, append_images=clip[1:], duration=33, loop=0)
print("gallery written to", out)
EOF
