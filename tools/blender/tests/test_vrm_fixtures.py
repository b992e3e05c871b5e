# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the VRM test characters (assets/chain_hair/*.vrm, written by
tools/blender/write_vrm_fixtures.py from chain_hair.glb). No Blender needed.

The files must be what the script writes now (so a stale fixture fails here), keep the glb's
binary chunk byte for byte, and carry spring-bone JSON that follows the VRM rules the crate
enforces: joints each the parent of the next, no joint in two springs, indices in range,
VRM 0.x offsets in Unity's space."""

import os
import sys
import tempfile
import unittest

import helpers

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import write_vrm_fixtures  # noqa: E402

FOLDER = os.path.join(helpers.REPO, "assets", "chain_hair")


class VrmFixtures(unittest.TestCase):
    def test_the_committed_files_are_what_the_script_writes(self):
        with tempfile.TemporaryDirectory() as out:
            for name in ("chain_hair.glb",):
                with open(os.path.join(FOLDER, name), "rb") as src, open(os.path.join(out, name), "wb") as dst:
                    dst.write(src.read())
            write_vrm_fixtures.main(out)
            for name in ("chain_hair.vrm", "chain_hair_vrm0.vrm"):
                with open(os.path.join(out, name), "rb") as a, open(os.path.join(FOLDER, name), "rb") as b:
                    self.assertEqual(a.read(), b.read(), f"{name} is stale: run write_vrm_fixtures.py")

    def test_binary_chunk_is_the_glb_s(self):
        _, glb_rest = write_vrm_fixtures.read_glb(os.path.join(FOLDER, "chain_hair.glb"))
        for name in ("chain_hair.vrm", "chain_hair_vrm0.vrm"):
            _, rest = write_vrm_fixtures.read_glb(os.path.join(FOLDER, name))
            self.assertEqual(rest, glb_rest, name)

    def test_vrm_1_springs_follow_the_rules(self):
        doc, _ = write_vrm_fixtures.read_glb(os.path.join(FOLDER, "chain_hair.vrm"))
        ext = doc["extensions"]["VRMC_springBone"]
        nodes = doc["nodes"]
        parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
        self.assertEqual(len(ext["springs"]), 13)
        self.assertEqual(len(ext["colliders"]), 8)
        owner = {}
        for s, spring in enumerate(ext["springs"]):
            joints = [j["node"] for j in spring["joints"]]
            for a, b in zip(joints, joints[1:]):
                self.assertEqual(parent[b], a, spring["name"])
            for j in joints:
                self.assertNotIn(j, owner, "a joint in two springs")
                owner[j] = s
            # The tail is an added, childless `_end` node.
            self.assertTrue(nodes[joints[-1]]["name"].endswith("_end"))
            self.assertNotIn("children", nodes[joints[-1]])
            for g in spring["colliderGroups"]:
                self.assertLess(g, len(ext["colliderGroups"]))
            stiff = [j["stiffness"] for j in spring["joints"][:-1]]
            self.assertEqual(stiff, sorted(stiff, reverse=True), "stiffer at the root")
        for group in ext["colliderGroups"]:
            for c in group["colliders"]:
                self.assertLess(c, len(ext["colliders"]))
        plane = ext["colliders"][7]["extensions"]["VRMC_springBone_extended_collider"]["shape"]
        self.assertEqual(plane["plane"]["normal"], [0.0, 0.0, -1.0])

    def test_vrm_0_offsets_are_in_unity_space(self):
        doc, _ = write_vrm_fixtures.read_glb(os.path.join(FOLDER, "chain_hair_vrm0.vrm"))
        sec = doc["extensions"]["VRM"]["secondaryAnimation"]
        head = sec["colliderGroups"][0]
        self.assertEqual(doc["nodes"][head["node"]]["name"], "head")
        for collider, (centre, radius) in zip(head["colliders"], write_vrm_fixtures.HEAD_SPHERES):
            offset = collider["offset"]
            self.assertEqual((offset["x"], offset["y"], offset["z"]), (centre[0], centre[1], -centre[2]))
            self.assertEqual(collider["radius"], radius)
        self.assertEqual([g["comment"] for g in sec["boneGroups"]], ["bangs", "sides", "back", "tail"])
        self.assertIn("stiffiness", sec["boneGroups"][0], "VRM 0.x spells it so")


if __name__ == "__main__":
    unittest.main()
