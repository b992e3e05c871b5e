# SPDX-License-Identifier: MIT OR Apache-2.0
"""Tests of the pure-numpy writer (no Blender needed)."""

import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

import numpy as np

import helpers  # noqa: F401  (import path)
from bevy_cartoon_hair_export import writer
from bevy_cartoon_hair_export.writer import ExportError


class Writer(unittest.TestCase):
    def test_import_has_no_bpy_side_effect(self):
        # The package and its writer import without bpy (checked in a fresh interpreter, as
        # other tests of this process load bpy).
        code = (
            "import sys; sys.path.insert(0, sys.argv[1]);"
            "from bevy_cartoon_hair_export import writer;"
            "assert 'bpy' not in sys.modules, 'bpy imported'"
        )
        subprocess.run([sys.executable, "-c", code, helpers.BLENDER_TOOLS], check=True)

    def test_groom_round_trip(self):
        rng = np.random.default_rng(0)
        counts = np.array([2, 7, 3, 256])
        pos = np.cumsum(rng.normal(size=(counts.sum(), 3)), axis=0) * 123.456
        text = writer.groom_xml(pos, counts, scale=7.5, bone='he"ad')
        root = ET.fromstring(text.encode("utf-8"))
        self.assertEqual(root.get("bone"), 'he"ad')
        self.assertEqual(root.get("scale"), "7.5")
        strands = [np.array(s.text.split(), float) for s in root.findall("strand")]
        self.assertEqual([len(s) // 3 for s in strands], counts.tolist())
        np.testing.assert_allclose(np.concatenate(strands).reshape(-1, 3), pos, rtol=1e-8)

    def test_no_negative_zero(self):
        text = writer.groom_xml([[0.0, -0.0, 1.0], [-0.0, 1.0, 0.0]], [2])
        self.assertNotIn("-0 ", text)
        self.assertIn("<strand>0 0 1  0 1 0</strand>", text)

    def test_rules(self):
        with self.assertRaisesRegex(ExportError, "strand 1 has 1 particles"):
            writer.groom_xml(np.arange(9.0).reshape(3, 3), [2, 1])
        with self.assertRaisesRegex(ExportError, "strand 0: segment 1-2"):
            writer.groom_xml([[0, 0, 0], [0, 0, 1], [0, 0, 1]], [3])
        # A zero-length step across two strands is fine.
        writer.groom_xml([[0, 0, 0], [0, 0, 1], [0, 0, 1], [0, 0, 2]], [2, 2])
        with self.assertRaisesRegex(ExportError, "not finite"):
            writer.groom_xml([[0, 0, 0], [0, np.nan, 1]], [2])
        with self.assertRaisesRegex(ExportError, "scale"):
            writer.groom_xml([[0, 0, 0], [0, 0, 1]], [2], scale=0.0)
        with self.assertRaisesRegex(ExportError, "radius"):
            writer.collision_xml([[0, 0, 0]], [0.0])
        with self.assertRaisesRegex(ExportError, "strictly increasing"):
            writer.hairanim_xml([(0.0, "a.hair.xml"), (0.0, "b.hair.xml")])
        with self.assertRaisesRegex(ExportError, "duration"):
            writer.hairanim_xml([(0.0, "a.hair.xml"), (1.0, "b.hair.xml")], duration=1.0)

    def test_hairanim_text(self):
        text = writer.hairanim_xml([(0.0, "a.hair.xml"), (0.8, "b.hair.xml")], loop=True, duration=1.6)
        root = ET.fromstring(text.encode())
        self.assertEqual((root.get("version"), root.get("loop"), root.get("duration")), ("1", "true", "1.6"))
        self.assertEqual([(k.get("time"), k.get("groom")) for k in root], [("0", "a.hair.xml"), ("0.8", "b.hair.xml")])

    def test_frames(self):
        # Y-up conversion (x, y, z) -> (x, z, -y).
        np.testing.assert_allclose(writer.transform_points(writer.Y_UP, [[1, 2, 3]]), [[1, 3, -2]])
        # An upright bone (Blender bone axes X, Z->Y...) has glTF's axes.
        bone = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 1.6], [0, 0, 0, 1.0]])
        f = writer.bone_node_matrix(np.eye(4), bone)
        np.testing.assert_allclose(f[:3, :3], np.eye(3), atol=1e-12)
        np.testing.assert_allclose(f[:3, 3], [0, 1.6, 0])
        m = writer.blender_to_frame(f)
        np.testing.assert_allclose(writer.transform_points(m, [[0.1, -0.2, 1.7]]), [[0.1, 0.1, 0.2]], atol=1e-12)


if __name__ == "__main__":
    unittest.main()
