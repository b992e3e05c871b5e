# SPDX-License-Identifier: MIT OR Apache-2.0
"""Author three more hairstyles for the bundled ninja, reproducibly, with Blender (`bpy`).

    python3 tools/blender/author_hairstyles.py [--out assets/ninja] [--blend hairstyles.blend]

Writes to the output folder (default: assets/ninja):

* ``ninja_long.hair.xml``       - long straight hair falling over the shoulders and down the back
* ``ninja_bangs.hair.xml``      - a bob to the jaw with bangs over the eyes
* ``ninja_twin_tails.hair.xml`` - the scalp's hair gathered into two long tails at the sides

Each is a Blender Curves hair object on the ninja's own armature (built by
``author_ninja.make_armature``), exported by the add-on in the space of bone ``head``, scale 1.
The strands are draped from their roots: each segment bends toward the ground and is pushed out
of the head, neck, shoulders, chest and back (the shapes below, which the example gives the
simulation as colliders), so the rest pose lies on the body as hair would. Same seed, same files.
"""

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bpy  # noqa: E402

import author_ninja as ninja  # noqa: E402
from bevy_cartoon_hair_export import gather  # noqa: E402

SEED = 20261125
DOWN = np.array([0.0, 0.0, -1.0])
FRONT = np.array([0.0, -1.0, 0.0])  # the ninja faces Blender's -Y

# The body the hair drapes over (Blender space, metres): capsules (a, b, radius), the neck as a
# vertical capsule. The shoulders, chest and back match the colliders `src/demo.rs` puts on the
# ninja's `spine` bone; the head is the ellipsoid of `author_ninja`.
BODY_CAPSULES = [
    ((0.0, 0.0, 1.44), (0.0, 0.0, 1.60), 0.055),  # neck
    ((-0.195, 0.0, 1.395), (0.195, 0.0, 1.395), 0.06),  # shoulders
    ((-0.09, 0.0, 1.32), (0.09, 0.0, 1.32), 0.115),  # upper chest and back
    ((-0.06, 0.0, 1.20), (0.06, 0.0, 1.20), 0.11),  # chest and back
]
# How far outside the body a draped particle is put (the simulation's margin is 5-15 mm).
MARGIN = 0.016
# Kept clear while draping only (not colliders): the headband's knot and tails at the back of the
# head, as a capsule, so hair falls over them; and the face, a box in front of the head that
# hair is pushed out of sideways, so long hair frames the face instead of covering it.
KNOT_TAILS = ((0.0, 0.125, 1.695), (0.0, 0.19, 1.53), 0.035)
FACE = (0.075, -0.03, 1.50, 1.74)  # half width, back face (y), bottom and top (z)


def unit(v):
    return v / np.linalg.norm(v)


def push_out(p, margin=MARGIN, face=False):
    """``p`` moved out of the head ellipsoid and every body capsule grown by ``margin`` (and,
    with ``face``, out of the face's box, sideways)."""
    p = np.array(p, dtype=float)
    for _ in range(3):
        if face:
            half, back, low, high = FACE
            if abs(p[0]) < half + margin and p[1] < back and low < p[2] < high:
                p[0] = (half + margin) * (1.0 if p[0] >= 0.0 else -1.0)
        d = p - ninja.HEAD_C
        grown = ninja.HEAD_R + margin
        k = np.linalg.norm(d / grown)
        if k < 1.0:
            p = ninja.HEAD_C + d / max(k, 1e-6)
        for a, b, r in BODY_CAPSULES + [KNOT_TAILS]:
            a, b = np.array(a), np.array(b)
            ab = b - a
            t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
            c = a + t * ab
            off = p - c
            dist = np.linalg.norm(off)
            if dist < r + margin:
                n = off / dist if dist > 1e-9 else FRONT
                p = c + n * (r + margin)
    return p


def drape(root, direction, segment, count, pull=0.35, steer=None, face=False):
    """A strand of ``count`` particles from ``root``: each segment turns ``pull`` of the way to
    the ground (and toward ``steer``, if given) and is pushed out of the body (and the face,
    with ``face``), its length kept."""
    pts = [np.array(root, dtype=float)]
    d = unit(np.array(direction, dtype=float))
    for i in range(1, count):
        d = unit(d + pull * DOWN + (steer if steer is not None else 0.0))
        p = push_out(pts[-1] + d * segment, face=face)
        p = pts[-1] + unit(p - pts[-1]) * segment
        p = push_out(p, face=face)
        d = unit(p - pts[-1])
        pts.append(p)
    return np.array(pts)


def meridian(n):
    """Down the scalp at a point of normal ``n``: the way a comb runs from the crown."""
    up = -DOWN
    m = n * (n @ up) - up
    length = np.linalg.norm(m)
    return m / length if length > 1e-6 else -FRONT


def scalp_roots(n, rng, above=0.03, jitter=0.003):
    """Roots on the head above the headband (as the ninja's spikes), ``n`` tried."""
    dirs = ninja.fibonacci_sphere(n)
    roots = ninja.HEAD_C + dirs * ninja.HEAD_R
    rel = roots - ninja.HEAD_C
    keep = rel[:, 2] > np.array([ninja.band_center_z(y) for y in rel[:, 1]]) + above
    roots = roots[keep]
    return ninja.on_surface(roots + rng.normal(scale=jitter, size=roots.shape))


def long_straight(rng):
    """Long straight hair: every strand falls from the scalp over the shoulders and down the
    back; the hairline's strands part at the front and fall beside the face."""
    strands = []
    for r in scalp_roots(460, rng):
        n = ninja.ellipsoid_normal(r)
        rel = r - ninja.HEAD_C
        side = np.array([np.sign(rel[0]) or 1.0, 0.0, 0.0])
        # Away from the face: the front half of the scalp parts to the sides and back.
        front = min(1.0, max(0.0, 0.3 - rel[1] / ninja.HEAD_R[1]))
        direction = meridian(n) + 0.25 * n + 1.5 * front * side
        steer = 0.05 * side * (0.3 + 2.0 * front) + 0.03 * -FRONT
        length = rng.uniform(0.55, 0.65)
        strands.append(drape(r, direction, length / 13, 14, pull=0.6, steer=steer, face=True))
    return strands


def bangs(rng):
    """A bob to the jaw, and bangs: the front of the scalp falls forward over the forehead to
    the eyes."""
    strands = []
    for r in scalp_roots(400, rng):
        n = ninja.ellipsoid_normal(r)
        rel = r - ninja.HEAD_C
        front = -rel[1] / ninja.HEAD_R[1]
        if front > 0.15:
            # Bangs: forward and down over the forehead, tips at the eyes.
            length = rng.uniform(0.13, 0.16)
            direction = meridian(n) + 0.3 * n + 0.6 * FRONT
            strands.append(drape(r, direction, length / 7, 8, pull=0.6, steer=0.05 * FRONT))
        else:
            side = np.array([np.sign(rel[0]) or 1.0, 0.0, 0.0])
            length = rng.uniform(0.20, 0.24)
            direction = meridian(n) + 0.25 * n
            strands.append(drape(r, direction, length / 9, 10, pull=0.6, steer=0.02 * side))
    return strands


def twin_tails(rng):
    """Twin tails: the scalp's hair combed to two ties above the ears (a bundle each), then
    falling from the ties, flaring out a little."""
    strands = []
    ties = [ninja.HEAD_C + np.array([sx * 0.125, 0.035, 0.055]) for sx in (-1.0, 1.0)]
    for r in scalp_roots(360, rng):
        rel = r - ninja.HEAD_C
        sx = 1.0 if rel[0] >= 0.0 else -1.0
        tie = ties[1 if sx > 0 else 0]
        # Along the scalp to the tie: 4 particles, each pushed out onto the hair's layer.
        comb = [r]
        for t in (0.33, 0.66, 1.0):
            p = r + (tie - r) * t
            comb.append(push_out(p, margin=0.008 + 0.01 * t))
        comb = np.array(comb)
        # Spread in the bundle: where on the scalp the strand came from.
        spread = 0.25 * unit(np.array([0.0, rel[1], rel[2] - 0.05]) + 1e-6)
        direction = np.array([sx * 0.7, 0.1, 0.1]) + spread
        length = rng.uniform(0.34, 0.42)
        tail = drape(comb[-1], direction, length / 10, 11, pull=0.5, steer=np.array([sx * 0.02, 0.0, 0.0]))
        strands.append(np.vstack([comb, tail[1:]]))
    return strands


STYLES = [
    ("ninja_long", long_straight),
    ("ninja_bangs", bangs),
    ("ninja_twin_tails", twin_tails),
]


def check(name, strands):
    """Every particle but the root outside the head and body shapes; counts and lengths sane."""
    assert 100 <= len(strands) <= 400, f"{name}: {len(strands)} strands"
    for s in strands:
        assert 6 <= len(s) <= 16, f"{name}: {len(s)} particles"
        for p in s[1:]:
            d = (p - ninja.HEAD_C) / (ninja.HEAD_R + 0.004)
            assert np.linalg.norm(d) >= 1.0 - 1e-6, f"{name}: particle {p} inside the head"
            for a, b, r in BODY_CAPSULES:
                a, b = np.array(a), np.array(b)
                t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
                assert np.linalg.norm(p - (a + t * (b - a))) >= r + 0.004, f"{name}: {p} inside the body"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(ninja.REPO, "assets", "ninja"))
    parser.add_argument("--blend", default=None, help="also save the scene as this .blend")
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(SEED)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.unit_settings.system = "METRIC"
    rig = ninja.make_armature()
    for name, make in STYLES:
        strands = make(rng)
        check(name, strands)
        # Blender's Curves hold one point count per curve; strands of a style may differ.
        cv = bpy.data.hair_curves.new(name)
        cv.add_curves([len(s) for s in strands])
        cv.points.foreach_set("position", np.concatenate(strands).astype(np.float32).ravel())
        ob = bpy.data.objects.new(name, cv)
        bpy.context.scene.collection.objects.link(ob)
        ninja.parent_to_bone(ob, rig, "head")
        n = gather.export_hair(os.path.join(out, f"{name}.hair.xml"), [ob], rig, "head", 1.0)
        lengths = [np.linalg.norm(np.diff(s, axis=0), axis=1).sum() for s in strands]
        lowest = min(s[:, 2].min() for s in strands)
        print(f"{name}: {n} strands, {sum(len(s) for s in strands)} particles, lengths "
              f"{min(lengths):.3f}..{max(lengths):.3f} m, lowest tip {lowest:.3f} m")
    if args.blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.blend), compress=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
