# SPDX-License-Identifier: MIT OR Apache-2.0
"""Checks of the modelled-hair test character (assets/chain_hair/, made by
tools/blender/author_chain_hair.py). No Blender needed.

Its hair is a mesh skinned to chains of bones under ``head``: the chains the crate's
``HairBoneChains::matching(.., |n| n.starts_with("hair_"))`` finds must be there, each a line
of single children, with the hair mesh weighted to them."""

import os
import unittest

import numpy as np

import helpers

GLB = os.path.join(helpers.REPO, "assets", "chain_hair", "chain_hair.glb")
CHAINS = {"hair_bang_0": 3, "hair_bang_4": 3, "hair_side_L": 5, "hair_side_R": 5, "hair_back_0": 5,
          "hair_back_4": 5, "hair_tail": 7}


class ChainHairAssets(unittest.TestCase):
    def setUp(self):
        self.gltf, _ = helpers.read_glb(GLB)
        self.names = [n.get("name") for n in self.gltf["nodes"]]

    def node(self, name):
        return self.gltf["nodes"][self.names.index(name)]

    def test_chains_hang_from_the_head_one_child_at_a_time(self):
        head = self.node("head")
        starts = {self.names[c] for c in head.get("children", []) if self.names[c].startswith("hair_")}
        self.assertEqual(len(starts), 13, starts)
        for chain, bones in CHAINS.items():
            self.assertIn(f"{chain}_0", starts)
            for k in range(bones):
                node = self.node(f"{chain}_{k}")
                kids = [self.names[c] for c in node.get("children", [])]
                self.assertEqual(kids, [f"{chain}_{k + 1}"] if k + 1 < bones else [], chain)

    def test_joints_are_apart_and_under_the_skin(self):
        world = helpers.node_global_matrices(self.gltf)
        skin = self.gltf["skins"][0]
        joint_names = {self.names[j] for j in skin["joints"]}
        for chain, bones in CHAINS.items():
            points = [world[f"{chain}_{k}"][:3, 3] for k in range(bones)]
            gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
            self.assertGreater(gaps.min(), 0.01, chain)
            for k in range(bones):
                self.assertIn(f"{chain}_{k}", joint_names)
