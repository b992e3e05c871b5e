# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the ninja's extra hairstyles (assets/ninja/ninja_{long,bangs,twin_tails}.hair.xml,
made by tools/blender/author_hairstyles.py). Only the reproduction test needs Blender (`bpy`)."""

import filecmp
import os
import sys
import tempfile
import unittest
import xml.etree.ElementTree as ET

import numpy as np

import helpers
from bevy_cartoon_hair_export import writer

NINJA = os.path.join(helpers.REPO, "assets", "ninja")
HEAD_BONE_Y = 1.6  # the head bone's node in the rest pose; groom positions are relative to it

# The body in head-bone space (glTF axes: y up, z toward the face), as `src/demo.rs` gives the
# simulation: shoulders, chest and back on the spine; the head's spheres are in its collision
# file.
BODY_CAPSULES = [
    ((-0.195, 1.395, 0.0), (0.195, 1.395, 0.0), 0.06),
    ((-0.09, 1.32, 0.0), (0.09, 1.32, 0.0), 0.115),
    ((-0.06, 1.20, 0.0), (0.06, 1.20, 0.0), 0.11),
]


def strands_of(name):
    pos, counts, scale, bone = writer.read_groom(os.path.join(NINJA, name))
    writer.check_groom(pos, counts, scale)
    return np.split(pos, np.cumsum(counts)[:-1]), scale, bone


def capsule_distance(p, a, b, r):
    a, b = np.array(a), np.array(b)
    a[1] -= HEAD_BONE_Y
    b[1] -= HEAD_BONE_Y
    ab = b - a
    t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1) - r


class HairstyleAssets(unittest.TestCase):
    def check_outside_body(self, strands):
        non_roots = np.concatenate([s[1:] for s in strands])
        spheres = ET.parse(os.path.join(NINJA, "ninja.collision.xml")).getroot().findall("sphere")
        for s in spheres:
            c = np.array([float(s.get(k)) for k in "xyz"])
            self.assertGreater(np.linalg.norm(non_roots - c, axis=1).min(), float(s.get("r")))
        for a, b, r in BODY_CAPSULES:
            self.assertGreater(capsule_distance(non_roots, a, b, r).min(), 0.0)

    def test_long_hair_falls_past_the_shoulders(self):
        strands, scale, bone = strands_of("ninja_long.hair.xml")
        self.assertEqual((scale, bone), (1.0, "head"))
        self.assertTrue(100 <= len(strands) <= 400, len(strands))
        lengths = [np.linalg.norm(np.diff(s, axis=0), axis=1).sum() for s in strands]
        self.assertGreater(min(lengths), 0.5)
        tips = np.array([s[-1] for s in strands])
        # Most tips below the shoulders (1.395 m), some down the back (z < 0).
        self.assertGreater((tips[:, 1] + HEAD_BONE_Y < 1.35).mean(), 0.8)
        self.assertGreater((tips[:, 2] < -0.05).mean(), 0.3)
        self.check_outside_body(strands)

    def test_bangs_fall_over_the_forehead(self):
        strands, _, _ = strands_of("ninja_bangs.hair.xml")
        tips = np.array([s[-1] for s in strands])
        # Tips in front of the face (z > 0.08) and at eye height or below the headband.
        front = tips[tips[:, 2] > 0.08]
        self.assertGreater(len(front), 10)
        self.assertLess(np.median(front[:, 1]) + HEAD_BONE_Y, 1.70)
        self.check_outside_body(strands)

    def test_twin_tails_hang_from_two_ties(self):
        strands, _, _ = strands_of("ninja_twin_tails.hair.xml")
        tips = np.array([s[-1] for s in strands])
        left, right = tips[tips[:, 0] < 0], tips[tips[:, 0] > 0]
        self.assertGreater(min(len(left), len(right)), 30)
        # Two bundles: tips well out to each side and below the ears.
        for side in (left, right):
            self.assertGreater(np.abs(side[:, 0]).min(), 0.1)
            self.assertLess(side[:, 1].max() + HEAD_BONE_Y, 1.6)
        self.check_outside_body(strands)

    def test_the_script_reproduces_the_shipped_files(self):
        sys.path.insert(0, os.path.join(helpers.REPO, "tools", "blender"))
        import author_hairstyles

        with tempfile.TemporaryDirectory() as out:
            self.assertEqual(author_hairstyles.main(["--out", out]), 0)
            for name, _ in author_hairstyles.STYLES:
                self.assertTrue(
                    filecmp.cmp(os.path.join(out, f"{name}.hair.xml"),
                                os.path.join(NINJA, f"{name}.hair.xml"), shallow=False),
                    f"{name}.hair.xml differs from what the script writes",
                )


if __name__ == "__main__":
    unittest.main()
