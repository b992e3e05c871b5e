# SPDX-License-Identifier: MIT OR Apache-2.0
"""The add-on builds as a Blender extension (blender_manifest.toml valid), installs from the
zip and its operator runs.  In a subprocess with a throw-away user folder, so nothing is
installed for the real user."""

import glob
import os
import subprocess
import sys
import tempfile
import unittest

import helpers

INSTALL_SCRIPT = r"""
import glob, sys
import bpy
import addon_utils
import numpy as np
zip_path, out = sys.argv[1], sys.argv[2]
bpy.ops.wm.read_factory_settings(use_empty=True)
assert bpy.ops.extensions.package_install_files(
    filepath=zip_path, repo="user_default", enable_on_install=True) == {"FINISHED"}
mods = [m for m in bpy.context.preferences.addons.keys() if m.endswith("bevy_cartoon_hair_export")]
assert mods == ["bl_ext.user_default.bevy_cartoon_hair_export"], mods
cv = bpy.data.hair_curves.new("h")
cv.add_curves([3])
cv.points.foreach_set("position", np.arange(9, dtype=np.float32))
ob = bpy.data.objects.new("h", cv)
bpy.context.scene.collection.objects.link(ob)
ob.select_set(True)
assert bpy.ops.export_scene.cartoon_hair(filepath=out, armature="") == {"FINISHED"}
for m in mods:
    addon_utils.disable(m)  # leave no callbacks registered: a bpy process would hang on exit
print("installed-ok")
"""


class Extension(unittest.TestCase):
    def test_build_and_install(self):
        import bpy

        scripts = bpy.utils.system_resource("SCRIPTS")
        cli = os.path.join(scripts, "addons_core", "bl_pkg", "cli", "blender_ext.py")
        if not os.path.isfile(cli):
            self.skipTest("Blender's extension CLI (blender_ext.py) not found")
        src = os.path.join(helpers.BLENDER_TOOLS, "bevy_cartoon_hair_export")
        with tempfile.TemporaryDirectory(prefix="cartoon_hair_ext_") as tmp:
            build = subprocess.run(
                [sys.executable, cli, "build", "--source-dir", src, "--output-dir", tmp],
                capture_output=True, text=True, timeout=60,
            )
            self.assertEqual(build.returncode, 0, build.stdout + build.stderr)
            zips = glob.glob(os.path.join(tmp, "bevy_cartoon_hair_export-*.zip"))
            self.assertEqual(len(zips), 1, build.stdout)
            out = os.path.join(tmp, "x.hair.xml")
            env = dict(os.environ, BLENDER_USER_RESOURCES=os.path.join(tmp, "user"))
            run = subprocess.run(
                [sys.executable, "-c", INSTALL_SCRIPT, zips[0], out],
                capture_output=True, text=True, timeout=90, env=env,
            )
            self.assertIn("installed-ok", run.stdout, run.stdout[-2000:] + run.stderr[-2000:])
            self.assertTrue(os.path.isfile(out))


if __name__ == "__main__":
    unittest.main()
