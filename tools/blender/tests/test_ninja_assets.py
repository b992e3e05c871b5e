# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the bundled ninja assets (assets/ninja/, made by tools/blender/author_ninja.py).
No Blender needed."""

import os
import unittest
import xml.etree.ElementTree as ET

import numpy as np

import helpers
from bevy_cartoon_hair_export import writer

NINJA = os.path.join(helpers.REPO, "assets", "ninja")


def ninja(name):
    return os.path.join(NINJA, name)


class NinjaAssets(unittest.TestCase):
    def test_files_exist(self):
        for name in ("ninja.glb", "ninja.hair.xml", "ninja_wind.hair.xml", "ninja_flip.hair.xml",
                     "ninja.hairanim.xml", "ninja.collision.xml", "README.md"):
            self.assertTrue(os.path.isfile(ninja(name)), name)

    def test_groom(self):
        pos, counts, scale, bone = writer.read_groom(ninja("ninja.hair.xml"))
        self.assertEqual((scale, bone), (1.0, "head"))
        self.assertTrue(100 <= len(counts) <= 200, len(counts))
        self.assertTrue(((counts >= 6) & (counts <= 8)).all())
        writer.check_groom(pos, counts, scale)
        strands = np.split(pos, np.cumsum(counts)[:-1])
        lengths = np.array([np.linalg.norm(np.diff(s, axis=0), axis=1).sum() for s in strands])
        self.assertGreaterEqual(lengths.min(), 0.08)
        self.assertLessEqual(lengths.max(), 0.25)
        roots = np.array([s[0] for s in strands])
        tips = np.array([s[-1] for s in strands])
        # Head bone at the base of the skull, head centre ~8 cm above it: roots on the upper
        # scalp, tips further out than roots.
        self.assertGreater(roots[:, 1].min(), 0.08)
        centre = np.array([0.0, 0.08, 0.0])
        self.assertTrue((np.linalg.norm(tips - centre, axis=1) > np.linalg.norm(roots - centre, axis=1) + 0.05).all())

    def test_keyframes_match_base(self):
        anim = ET.parse(ninja("ninja.hairanim.xml")).getroot()
        self.assertEqual((anim.tag, anim.get("version"), anim.get("loop")), ("hairanim", "1", "true"))
        keys = anim.findall("key")
        self.assertEqual(keys[0].get("groom"), "ninja.hair.xml")
        self.assertGreaterEqual(len(keys), 3)
        times = [float(k.get("time")) for k in keys]
        self.assertEqual(times[0], 0.0)
        self.assertTrue(all(b > a for a, b in zip(times, times[1:])))
        self.assertGreater(float(anim.get("duration")), times[-1])
        base_pos, base_counts, _, _ = writer.read_groom(ninja("ninja.hair.xml"))
        for k in keys[1:]:
            pos, counts, scale, bone = writer.read_groom(ninja(k.get("groom")))
            self.assertEqual(counts.tolist(), base_counts.tolist(), k.get("groom"))
            self.assertEqual((scale, bone), (1.0, "head"))
            writer.check_groom(pos, counts, scale)
            np.testing.assert_allclose(pos[np.r_[0, np.cumsum(counts)[:-1]]],
                                       base_pos[np.r_[0, np.cumsum(counts)[:-1]]], atol=1e-6)
            self.assertGreater(np.abs(pos - base_pos).max(), 0.03, "a style should differ")

    def test_collision(self):
        root = ET.parse(ninja("ninja.collision.xml")).getroot()
        self.assertEqual((root.tag, root.get("version"), root.get("bone")), ("collision", "1", "head"))
        spheres = root.findall("sphere")
        self.assertTrue(3 <= len(spheres) <= 6)
        for s in spheres:
            self.assertGreater(float(s.get("r")), 0.0)
        # No hair particle but the roots inside a sphere.
        pos, counts, _, _ = writer.read_groom(ninja("ninja.hair.xml"))
        non_roots = np.delete(pos, np.r_[0, np.cumsum(counts)[:-1]], axis=0)
        for s in spheres:
            c = np.array([float(s.get(k)) for k in "xyz"])
            self.assertGreater(np.linalg.norm(non_roots - c, axis=1).min(), float(s.get("r")))

    def test_glb(self):
        self.assertLess(os.path.getsize(ninja("ninja.glb")), 2 * 1024 * 1024)
        gltf, binary = helpers.read_glb(ninja("ninja.glb"))
        names = [n.get("name") for n in gltf["nodes"]]
        for bone in ("root", "spine", "neck", "head"):
            self.assertIn(bone, names)
        head = names.index("head")
        world = helpers.node_global_matrices(gltf)
        # Head bone: upright at (0, 1.6, 0), glTF axes.
        np.testing.assert_allclose(world["head"][:3, 3], [0.0, 1.6, 0.0], atol=1e-4)
        np.testing.assert_allclose(world["head"][:3, :3], np.eye(3), atol=1e-5)
        self.assertIn(head, gltf["skins"][0]["joints"])
        anims = {a["name"]: a for a in gltf.get("animations", [])}
        self.assertIn("idle", anims)
        idle = anims["idle"]
        head_channels = [c for c in idle["channels"] if c["target"].get("node") == head]
        self.assertIn("rotation", [c["target"]["path"] for c in head_channels])
        rot = next(c for c in head_channels if c["target"]["path"] == "rotation")
        sampler = idle["samplers"][rot["sampler"]]
        t = helpers.read_accessor(gltf, binary, sampler["input"]).ravel()
        self.assertAlmostEqual(float(t.min()), 0.0, places=4)
        self.assertAlmostEqual(float(t.max()), 4.0, places=3)

        q = helpers.read_accessor(gltf, binary, sampler["output"])
        np.testing.assert_allclose(np.abs(q[0]), np.abs(q[-1]), atol=1e-4)  # loops
        self.assertGreater(np.abs(q - q[0]).max(), 0.1)  # the head actually turns
        # Size and facing: about 1.8 m tall, the face (eyes, headband plate) towards +Z.
        mesh_node = next(n for n in gltf["nodes"] if "mesh" in n)
        all_pts = helpers.mesh_world_positions(gltf, binary, mesh_node["name"])
        self.assertAlmostEqual(float(all_pts[:, 1].max()), 1.8, delta=0.05)
        self.assertAlmostEqual(float(all_pts[:, 1].min()), 0.0, delta=0.02)
        mesh = gltf["meshes"][mesh_node["mesh"]]
        materials = [m["name"] for m in gltf["materials"]]
        tris = 0
        for p in mesh["primitives"]:
            tris += gltf["accessors"][p["indices"]]["count"] // 3
            if materials[p["material"]] == "metal":
                plate = helpers.read_accessor(gltf, binary, p["attributes"]["POSITION"])
                self.assertGreater(float(plate[:, 2].min()), 0.1)
        self.assertLess(tris, 20000)

    def test_scalp_is_hair_coloured(self):
        """Between the locks the scalp shows: it is the hair's shadow tone, not skin (the top of
        the head is drawn with the scalp material)."""
        gltf, binary = helpers.read_glb(ninja("ninja.glb"))
        materials = [m.get("name") for m in gltf["materials"]]
        self.assertIn("scalp", materials)
        scalp = materials.index("scalp")
        colour = gltf["materials"][scalp]["pbrMetallicRoughness"]["baseColorFactor"][:3]
        # Orange-brown like the hair (red > green > blue), not the skin's pink.
        self.assertGreater(colour[0], 2.0 * colour[1])
        self.assertGreater(colour[1], 5.0 * colour[2])
        # The highest vertex of the character mesh belongs to a scalp primitive.
        top = {}
        for mesh in gltf["meshes"]:
            for prim in mesh["primitives"]:
                pos = helpers.read_accessor(gltf, binary, prim["attributes"]["POSITION"])
                top[prim.get("material")] = float(pos[:, 1].max())
        self.assertEqual(max(top, key=top.get), scalp, top)


if __name__ == "__main__":
    unittest.main()
