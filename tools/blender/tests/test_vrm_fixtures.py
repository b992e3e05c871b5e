# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the VRM test characters (assets/chain_hair/*.vrm, written by
tools/blender/write_vrm_fixtures.py from chain_hair.glb). No Blender needed.

The files must be what the script writes now (so a stale fixture fails here), keep the glb's
binary chunk byte for byte (the thumbnail appended), carry their thumbnail (JPEG in VRM 1.0, PNG
in VRM 0.x), and carry spring-bone JSON that follows the VRM rules the crate
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
            for name in ("chain_hair.glb", "thumbnail.jpg", "thumbnail.png"):
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
            self.assertEqual(rest[8:len(glb_rest)], glb_rest[8:], name)

    def test_thumbnails_are_a_jpeg_and_a_png_texture_the_meta_names(self):
        magic = {"image/jpeg": b"\xff\xd8\xff", "image/png": b"\x89PNG\r\n\x1a\n"}
        for name, mime in (("chain_hair.vrm", "image/jpeg"), ("chain_hair_vrm0.vrm", "image/png")):
            doc, rest = write_vrm_fixtures.read_glb(os.path.join(FOLDER, name))
            if name == "chain_hair.vrm":
                image = doc["extensions"]["VRMC_vrm"]["meta"]["thumbnailImage"]
            else:
                image = doc["textures"][doc["extensions"]["VRM"]["meta"]["texture"]]["source"]
            self.assertEqual(doc["images"][image]["mimeType"], mime, name)
            self.assertIn(image, [t["source"] for t in doc["textures"]], "Bevy loads textures")
            view = doc["bufferViews"][doc["images"][image]["bufferView"]]
            data = rest[8 + view["byteOffset"]:8 + view["byteOffset"] + view["byteLength"]]
            self.assertTrue(data.startswith(magic[mime]), name)
            self.assertEqual(doc["buffers"][0]["byteLength"], len(rest) - 8, name)

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
