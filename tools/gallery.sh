#!/usr/bin/env bash
# Regenerates the pictures in docs/: from the look suite's frames at 1280x720, a picture per
# hairstyle for the README (docs/images/hero_*.png), every shipped look on every hairstyle of the
# ninja from the front, the side and the back (docs/images/gallery/, listed in docs/gallery.md)
# and the sheets docs/looks.md shows; and a head-shake clip per hairstyle (from the example's
# headless recorder). Renders on whatever Vulkan adapter exists (lavapipe on a CPU-only
# machine). Installs Pillow for Python 3 if it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/toolchain.sh
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/bevy_cartoon_hair/target}"
# Pillow assembles the pictures: installed first, not found after the renders.
if ! python3 -c "import PIL" >/dev/null 2>&1; then
  echo "Installing Pillow ..." >&2
  python3 -m pip install --quiet --disable-pip-version-check pillow
fi
frames="$(mktemp -d)"
trap 'rm -rf "$frames"' EXIT

# The look suite writes look_<look>[_<hairstyle>]_<view>.png.
mkdir -p "$frames/looks"
CI=true HAIR_LOOK_SUITE_ALL=1 HAIR_LOOK_SUITE_SIZE=1280x720 HAIR_TEST_PNG_DIR="$frames/looks" \
  "${CARGO[@]}" test "${CARGO_BUILD_FLAGS[@]}" \
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
styles = ["spiky", "long", "bangs", "twin_tails"]
views = ["front", "side", "back"]
# The look each hairstyle is shown in first (as the clips are).
hero_look = {"spiky": "clean_anime", "long": "anime_locks", "bangs": "anime_locks",
             "twin_tails": "anime_locks"}
tile = (180, 135)


def frame(look, style, view):
    suffix = "" if style == "spiky" else f"_{style}"
    return Image.open(f"{frames}/looks/look_{look}{suffix}_{view}.png").convert("RGB")


def small(img):
    """The picture with at most 256 colours (a toon frame has few): a fraction of the bytes."""
    return img.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)


def sheet(style):
    img = Image.new("RGB", (tile[0] * len(views), tile[1] * len(looks)), "white")
    for row, look in enumerate(looks):
        for col, view in enumerate(views):
            # The character's top half: the frame's 4:3 middle, its upper three quarters.
            f = frame(look, style, view)
            w, h = f.size
            left = (w - h * 4 // 3) // 2
            box = (left + h // 6, 0, left + h * 4 // 3 - h // 6, h * 3 // 4)
            img.paste(f.crop(box).resize(tile, Image.LANCZOS), (col * tile[0], row * tile[1]))
    return img


sheet("spiky").save(f"{out}/looks.png")
for style in ["long", "bangs", "twin_tails"]:
    sheet(style).save(f"{out}/looks_{style}.png")
for style in styles:
    small(frame(hero_look[style], style, "front")).save(f"{out}/hero_{style}.png", optimize=True)
os.makedirs(f"{out}/gallery", exist_ok=True)
for old in glob.glob(f"{out}/gallery/*.png"):
    os.remove(old)
lines = [
    "# Gallery",
    "",
    "Every shipped look (`HairPreset::look`) on every hairstyle of the ninja, from the front, the",
    "side and the back, as the look suite renders them at 1280x720 (stored at 640x360). Made by",
    "`tools/gallery.sh` on lavapipe (Mesa's Vulkan driver on the CPU), MSAA 4. What still looks",
    "wrong is listed in [Looks](looks.md).",
    "",
]
for style in styles:
    title = style.replace("_", " ").capitalize()
    lines += [f"## {title}", "", "| look | " + " | ".join(views) + " |",
              "|---|" + "---|" * len(views)]
    for look in looks:
        cells = []
        for view in views:
            name = f"{look}_{style}_{view}.png"
            picture = frame(look, style, view).resize((640, 360), Image.LANCZOS)
            small(picture).save(f"{out}/gallery/{name}", optimize=True)
            cells.append(f"![{look}, {title.lower()}, {view}](images/gallery/{name})")
        lines.append(f"| `{look}` | " + " | ".join(cells) + " |")
    lines.append("")
with open("docs/gallery.md", "w") as f:
    f.write("\n".join(lines))
for style in styles:
    paths = sorted(glob.glob(f"{frames}/clip_{style}/frame_*.png"))[87:135]
    clip = [Image.open(p).convert("RGB").quantize(64) for p in paths]
    name = "head_shake.gif" if style == "spiky" else f"head_shake_{style}.gif"
    clip[0].save(f"{out}/{name}", save_all=True, append_images=clip[1:], duration=33, loop=0)
EOF
