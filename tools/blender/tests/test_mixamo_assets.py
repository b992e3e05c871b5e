# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the Mixamo-convention test character (assets/mixamo_test/, made by
tools/blender/author_mixamo_test.py) against the ninja it was converted from. No Blender needed.

The two characters are the same in the world; only the rig's conventions differ (0.01 armature
scale, centimetre bones and body, ``mixamorig:`` names). So the add-on's export on the scaled rig
must be the ninja's numbers times 100, labelled ``units="bone"`` with ``bone_scale="0.01"``, and
the glTF head node must place them where the ninja's head node places the ninja's."""

import os
import unittest
import xml.etree.ElementTree as ET

import numpy as np

import helpers
from bevy_cartoon_hair_export import writer

MIXAMO = os.path.join(helpers.REPO, "assets", "mixamo_test")
NINJA = os.path.join(helpers.REPO, "assets", "ninja")
HEAD = "mixamorig:Head"


class MixamoAssets(unittest.TestCase):
    def test_groom_is_the_ninjas_in_centimetres(self):
        path = os.path.join(MIXAMO, "mixamo.hair.xml")
        root = ET.parse(path).getroot()
        self.assertEqual((root.get("units"), root.get("bone")), ("bone", HEAD))
        self.assertAlmostEqual(float(root.get("bone_scale")), 0.01, places=7)
        pos, counts, scale, _ = writer.read_groom(path)
        ninja_pos, ninja_counts, _, _ = writer.read_groom(os.path.join(NINJA, "ninja.hair.xml"))
        self.assertEqual(counts.tolist(), ninja_counts.tolist())
        np.testing.assert_allclose(pos * float(root.get("bone_scale")) / scale, ninja_pos,
                                   atol=2e-6)

    def test_collision_is_the_ninjas_in_centimetres(self):
        def spheres(path):
            root = ET.parse(path).getroot()
            s = np.array([[float(e.get(k)) for k in "xyzr"] for e in root.findall("sphere")])
            return root, s

        root, mix = spheres(os.path.join(MIXAMO, "mixamo.collision.xml"))
        _, nin = spheres(os.path.join(NINJA, "ninja.collision.xml"))
        self.assertEqual((root.get("units"), root.get("bone")), ("bone", HEAD))
        np.testing.assert_allclose(mix * 0.01, nin, atol=2e-6)

    def test_glb_has_mixamo_conventions_and_the_same_world(self):
        gltf, binary = helpers.read_glb(os.path.join(MIXAMO, "mixamo.glb"))
        names = [n.get("name") for n in gltf["nodes"]]
        for bone in ("mixamorig:Hips", "mixamorig:Spine", "mixamorig:Neck", HEAD):
            self.assertIn(bone, names)
        armature = gltf["nodes"][names.index("Armature")]
        np.testing.assert_allclose(armature["scale"], [0.01, 0.01, 0.01], rtol=1e-6)
        world = helpers.node_global_matrices(gltf)
        ninja_gltf, _ = helpers.read_glb(os.path.join(NINJA, "ninja.glb"))
        ninja_world = helpers.node_global_matrices(ninja_gltf)
        # The head node: at the ninja's head, scaled 0.01.
        np.testing.assert_allclose(world[HEAD][:3, 3], ninja_world["head"][:3, 3], atol=1e-5)
        np.testing.assert_allclose(world[HEAD][:3, :3], 0.01 * ninja_world["head"][:3, :3],
                                   atol=1e-7)
        # The hair in the world: the same as the ninja's.
        pos, _, scale, _ = writer.read_groom(os.path.join(MIXAMO, "mixamo.hair.xml"))
        ninja_pos, _, _, _ = writer.read_groom(os.path.join(NINJA, "ninja.hair.xml"))
        np.testing.assert_allclose(
            writer.transform_points(world[HEAD], pos / scale),
            writer.transform_points(ninja_world["head"], ninja_pos),
            atol=1e-5,
        )
        # The skinned body in the rest pose (joint world x inverse bind x vertex, as a game
        # skins it): about 1.8 m tall in the world, like the ninja.
        mesh_node = next(n for n in gltf["nodes"] if "mesh" in n)
        skin = gltf["skins"][mesh_node["skin"]]
        hips = names.index("mixamorig:Hips")
        inverse_bind = helpers.read_accessor(gltf, binary, skin["inverseBindMatrices"])
        bind = inverse_bind.reshape(-1, 4, 4)[skin["joints"].index(hips)].T  # column-major
        top = 0.0
        for prim in gltf["meshes"][mesh_node["mesh"]]["primitives"]:
            v = helpers.read_accessor(gltf, binary, prim["attributes"]["POSITION"])
            top = max(top, float(writer.transform_points(world["mixamorig:Hips"] @ bind, v)[:, 1].max()))
        self.assertAlmostEqual(top, 1.8, delta=0.05)
        anims = [a["name"] for a in gltf.get("animations", [])]
        self.assertIn("idle", anims)
