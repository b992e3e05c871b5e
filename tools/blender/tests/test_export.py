# SPDX-License-Identifier: MIT OR Apache-2.0
"""Tests of the add-on with real Blender (the `bpy` module): export operators, the bone frame
against Blender's glTF exporter, and speed."""

import os
import tempfile
import time
import unittest
import xml.etree.ElementTree as ET

import numpy as np

import helpers
from helpers import make_armature, make_curves, matrix_np, select_only

bpy = None
writer = gather = None


def setUpModule():
    global bpy, writer, gather
    bpy = helpers.bpy_ready()
    from bevy_cartoon_hair_export import gather as g, writer as w

    writer, gather = w, g


def y_up(points):
    return writer.transform_points(writer.Y_UP, points)


class ExportTestCase(unittest.TestCase):
    def setUp(self):
        helpers.bpy_ready()
        self._tmp = tempfile.TemporaryDirectory(prefix="cartoon_hair_test_")
        self.tmp = self._tmp.name

    def tearDown(self):
        self._tmp.cleanup()

    def path(self, name):
        return os.path.join(self.tmp, name)


class CurvesExport(ExportTestCase):
    def test_curves_hair_bone_space(self):
        arm = make_armature()
        counts = [3 + i % 7 for i in range(50)]
        ob, local = make_curves("hair", counts, seed=1)
        ob.location, ob.rotation_euler, ob.scale = (0.1, 0.2, -0.3), (0.3, -0.2, 1.1), (1.2, 1.2, 1.2)
        bpy.context.view_layer.update()
        select_only([ob])
        out = self.path("h.hair.xml")
        res = bpy.ops.export_scene.cartoon_hair(
            filepath=out, armature=arm.name, bone="head", scale=10.0
        )
        self.assertEqual(res, {"FINISHED"})

        root = ET.parse(out).getroot()
        self.assertEqual(root.tag, "groom")
        self.assertEqual(root.get("version"), "1")
        self.assertEqual(root.get("units"), "meters")
        self.assertEqual(float(root.get("scale")), 10.0)
        self.assertEqual(root.get("bone"), "head")
        strands = [np.array(s.text.split(), dtype=np.float64) for s in root.findall("strand")]
        self.assertEqual(len(strands), 50)
        self.assertEqual([len(s) // 3 for s in strands], counts)
        got = np.concatenate(strands).reshape(-1, 3) / 10.0

        # Expected, with mathutils only: rest bone matrix of Blender, then Y-up axes.
        # (tested against the glTF file itself in BoneFrame below)
        arm_w = matrix_np(arm.matrix_world)
        bone = matrix_np(arm.data.bones["head"].matrix_local)
        world = writer.transform_points(matrix_np(ob.matrix_world), local)
        expected = writer.transform_points(np.linalg.inv(arm_w @ bone), world)
        np.testing.assert_allclose(got, expected, atol=1e-5)
        # Root first: the first particle of every strand is the curve's first point.
        offsets = np.concatenate(([0], np.cumsum(counts)[:-1]))
        np.testing.assert_allclose(got[offsets], expected[offsets], atol=1e-5)

    def test_no_armature_object_space(self):
        counts = [4] * 5
        ob, local = make_curves("hair", counts, seed=2)
        ob.location, ob.rotation_euler = (1, 2, 3), (0.4, 0.5, 0.6)
        select_only([ob])
        out = self.path("o.hair.xml")
        bpy.ops.export_scene.cartoon_hair(filepath=out, armature="", scale=2.0)
        pos, c, scale, bone = writer.read_groom(out)
        self.assertEqual(bone, "")
        self.assertEqual(scale, 2.0)
        np.testing.assert_allclose(pos / 2.0, y_up(local), atol=1e-5)

    def test_unknown_bone_is_refused(self):
        arm = make_armature()
        ob, _ = make_curves("hair", [3, 3])
        select_only([ob])
        with self.assertRaisesRegex(RuntimeError, "no bone named 'skull'"):
            bpy.ops.export_scene.cartoon_hair(
                filepath=self.path("x.hair.xml"), armature=arm.name, bone="skull"
            )
        self.assertFalse(os.path.exists(self.path("x.hair.xml")))

    def test_nothing_selected_is_refused(self):
        select_only([])
        with self.assertRaisesRegex(RuntimeError, "no hair objects selected"):
            bpy.ops.export_scene.cartoon_hair(filepath=self.path("x.hair.xml"))


class ParticleHairExport(ExportTestCase):
    def make_particle_hair(self, count=20, steps=5, length=0.3):
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(0.2, -0.1, 1.6))
        m = bpy.context.object
        m.name = "scalp"
        m.rotation_euler = (0.3, 0.0, 0.5)
        m.modifiers.new("hair", "PARTICLE_SYSTEM")
        st = m.particle_systems[0].settings
        st.type = "HAIR"
        st.count = count
        st.hair_length = length
        st.hair_step = steps
        st.use_advanced_hair = True
        bpy.context.view_layer.update()
        return m

    def test_particle_hair(self):
        m = self.make_particle_hair()
        select_only([m])
        out = self.path("p.hair.xml")
        self.assertEqual(bpy.ops.export_scene.cartoon_hair(filepath=out, armature=""), {"FINISHED"})
        pos, counts, scale, bone = writer.read_groom(out)
        self.assertEqual(len(counts), 20)
        self.assertTrue((counts == 6).all())
        # Roots and tips against the evaluated hair cache (world space), brought into the
        # emitter's node frame.
        dg = bpy.context.evaluated_depsgraph_get()
        me = m.evaluated_get(dg)
        ps = me.particle_systems[0]
        to_local = np.linalg.inv(matrix_np(me.matrix_world))
        steps = 2 ** ps.settings.display_step
        roots = np.array([ps.co_hair(me, particle_no=i, step=0) for i in range(20)])
        tips = np.array([ps.co_hair(me, particle_no=i, step=steps) for i in range(20)])
        first = pos[np.arange(20) * 6]
        last = pos[np.arange(20) * 6 + 5]
        np.testing.assert_allclose(first, y_up(writer.transform_points(to_local, roots)), atol=1e-5)
        np.testing.assert_allclose(last, y_up(writer.transform_points(to_local, tips)), atol=1e-5)
        lengths = np.linalg.norm(np.diff(pos.reshape(20, 6, 3), axis=1), axis=2).sum(axis=1)
        np.testing.assert_allclose(lengths, 0.3, rtol=0.05)

    def test_particle_hair_with_bone(self):
        arm = make_armature()
        m = self.make_particle_hair(count=8, steps=3)
        select_only([m])
        out = self.path("pb.hair.xml")
        bpy.ops.export_scene.cartoon_hair(filepath=out, armature=arm.name, bone="head", scale=3.0)
        pos, counts, scale, bone = writer.read_groom(out)
        self.assertEqual((bone, scale, len(counts)), ("head", 3.0, 8))
        # Back to Blender world space through the glTF bone frame: on the sphere's surface.
        frame = gather.frame_matrix(arm, "head")
        world = writer.transform_points(np.linalg.inv(writer.Y_UP) @ frame, pos / 3.0)
        roots = world[np.arange(8) * 4]
        dist = np.linalg.norm(roots - np.array([0.2, -0.1, 1.6]), axis=1)
        np.testing.assert_allclose(dist, 0.1, atol=2e-3)


class CollisionExport(ExportTestCase):
    def test_spheres(self):
        arm = make_armature()
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(0.1, 0.05, 1.65))
        a = bpy.context.object
        a.name, a.scale, a.rotation_euler = "a_skull", (1.5, 1.5, 1.5), (0.3, 0.2, 0.1)
        bpy.ops.mesh.primitive_ico_sphere_add(radius=0.05, location=(0.0, -0.08, 1.55))
        b = bpy.context.object
        b.name = "b_jaw"
        e = helpers.link(bpy.data.objects.new("c_neck", None))
        e.empty_display_type, e.empty_display_size = "SPHERE", 0.04
        e.location, e.scale = (0.0, 0.0, 1.45), (1.0, 2.0, 1.0)
        bpy.context.view_layer.update()
        select_only([a, b, e])
        out = self.path("s.collision.xml")
        res = bpy.ops.export_scene.cartoon_hair_collision(
            filepath=out, armature=arm.name, bone="head", scale=2.0
        )
        self.assertEqual(res, {"FINISHED"})
        root = ET.parse(out).getroot()
        self.assertEqual((root.tag, root.get("version"), root.get("bone")), ("collision", "1", "head"))
        self.assertEqual(float(root.get("scale")), 2.0)
        spheres = root.findall("sphere")
        self.assertEqual(len(spheres), 3)
        xyz = np.array([[float(s.get(k)) for k in "xyz"] for s in spheres]) / 2.0
        r = np.array([float(s.get("r")) for s in spheres]) / 2.0
        np.testing.assert_allclose(r, [0.15, 0.05, 0.08], rtol=1e-4)
        to_bone = np.linalg.inv(matrix_np(arm.matrix_world) @ matrix_np(arm.data.bones["head"].matrix_local))
        centres = np.array([(0.1, 0.05, 1.65), (0.0, -0.08, 1.55), (0.0, 0.0, 1.45)])
        np.testing.assert_allclose(xyz, writer.transform_points(to_bone, centres), atol=1e-5)

    def test_capsules_and_planes(self):
        arm = make_armature()
        # An upper arm: a cylinder 0.3 long, 0.1 wide, turned and placed, with a capsule rigid body.
        bpy.ops.mesh.primitive_cylinder_add(radius=0.05, depth=0.3, location=(0.3, 0.1, 1.3),
                                            rotation=(0.0, 1.2, 0.4))
        cap = bpy.context.object
        cap.name = "a_arm"
        bpy.ops.rigidbody.object_add()
        cap.rigid_body.collision_shape = "CAPSULE"
        # The back: a plane turned to face +Y.
        bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0.0, 0.12, 1.5), rotation=(-1.5708, 0.0, 0.0))
        back = bpy.context.object
        back.name = "b_back"
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(0.0, 0.0, 1.65))
        skull = bpy.context.object
        skull.name = "c_skull"
        bpy.context.view_layer.update()
        select_only([cap, back, skull])
        out = self.path("c.collision.xml")
        res = bpy.ops.export_scene.cartoon_hair_collision(
            filepath=out, armature=arm.name, bone="head", scale=2.0
        )
        self.assertEqual(res, {"FINISHED"})
        root = ET.parse(out).getroot()
        self.assertEqual(len(root.findall("sphere")), 1)
        (c,) = root.findall("capsule")
        (pl,) = root.findall("plane")
        to_bone = np.linalg.inv(matrix_np(arm.matrix_world) @ matrix_np(arm.data.bones["head"].matrix_local))
        # Expected, from Blender's own matrices: the axis is the object's local Z, 0.3 - 2 x 0.05
        # long between the cap centres.
        m = matrix_np(cap.matrix_world)
        z = m[:3, 2] / np.linalg.norm(m[:3, 2])
        ends = np.array([m[:3, 3] - z * 0.1, m[:3, 3] + z * 0.1])
        got = np.array([[float(c.get(k)) for k in ("x0", "y0", "z0")],
                        [float(c.get(k)) for k in ("x1", "y1", "z1")]]) / 2.0
        np.testing.assert_allclose(got, writer.transform_points(to_bone, ends), atol=1e-5)
        self.assertAlmostEqual(float(c.get("r")) / 2.0, 0.05, places=5)
        point = np.array([float(pl.get(k)) for k in "xyz"]) / 2.0
        normal = np.array([float(pl.get(k)) for k in ("nx", "ny", "nz")])
        np.testing.assert_allclose(point, writer.transform_points(to_bone, [(0.0, 0.12, 1.5)])[0], atol=1e-5)
        # The plane's local +Z (turned -90 degrees about X: Blender's +Y), in the bone's frame.
        local_z = matrix_np(back.matrix_world)[:3, 2]
        np.testing.assert_allclose(local_z, [0.0, 1.0, 0.0], atol=1e-5)
        want = to_bone[:3, :3] @ local_z
        np.testing.assert_allclose(normal, want / np.linalg.norm(want), atol=1e-4)
        self.assertAlmostEqual(float(np.linalg.norm(normal)), 1.0, places=5)

    def test_non_sphere_mesh_refused(self):
        # A body or a box selected by mistake must not become its bounding sphere silently.
        arm = make_armature()
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(0.1, 0.05, 1.65))
        sphere = bpy.context.object
        bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.0, 0.0, 1.0))
        cube = bpy.context.object
        cube.name = "Body"
        select_only([sphere, cube])
        out = self.path("bad.collision.xml")
        with self.assertRaisesRegex(RuntimeError, "'Body' is not a sphere"):
            bpy.ops.export_scene.cartoon_hair_collision(filepath=out, armature=arm.name)
        self.assertFalse(os.path.exists(out))
        # A stretched sphere is not a sphere either.
        sphere.scale = (1.0, 1.0, 2.0)
        bpy.context.view_layer.update()
        select_only([sphere])
        with self.assertRaisesRegex(RuntimeError, "is not a sphere"):
            bpy.ops.export_scene.cartoon_hair_collision(filepath=out, armature=arm.name)

    def test_no_spheres_refused(self):
        arm = make_armature()
        select_only([arm])
        with self.assertRaisesRegex(RuntimeError, "no sphere objects selected"):
            bpy.ops.export_scene.cartoon_hair_collision(filepath=self.path("x.collision.xml"))


class HairAnimExport(ExportTestCase):
    def styles(self, counts_per_style):
        obs = []
        for i, (name, counts) in enumerate(counts_per_style):
            ob, _ = make_curves(name, counts, seed=10 + i)
            obs.append(ob)
        return obs

    def test_hairanim(self):
        arm = make_armature()
        counts = [4, 6, 5, 6]
        obs = self.styles([("style_c", counts), ("style_a", counts), ("style_b", counts)])
        select_only(obs)
        out = self.path("anim.hairanim.xml")
        res = bpy.ops.export_scene.cartoon_hair_anim(
            filepath=out, armature=arm.name, bone="head", scale=1.0, seconds_per_key=0.5
        )
        self.assertEqual(res, {"FINISHED"})
        root = ET.parse(out).getroot()
        self.assertEqual((root.tag, root.get("version"), root.get("loop")), ("hairanim", "1", "true"))
        self.assertAlmostEqual(float(root.get("duration")), 1.5)
        keys = root.findall("key")
        self.assertEqual([k.get("groom") for k in keys], [f"style_{c}.hair.xml" for c in "abc"])
        self.assertEqual([float(k.get("time")) for k in keys], [0.0, 0.5, 1.0])
        grooms = [writer.read_groom(self.path(k.get("groom"))) for k in keys]
        for pos, c, scale, bone in grooms:
            self.assertEqual(c.tolist(), counts)
            self.assertEqual(bone, "head")
        self.assertFalse(np.allclose(grooms[0][0], grooms[1][0]))

    def test_hairanim_from_collection(self):
        counts = [3, 3]
        obs = self.styles([("k1", counts), ("k0", counts)])
        coll = bpy.data.collections.new("Styles")
        bpy.context.scene.collection.children.link(coll)
        for o in obs:
            coll.objects.link(o)
        select_only([])
        out = self.path("c.hairanim.xml")
        res = bpy.ops.export_scene.cartoon_hair_anim(
            filepath=out, collection="Styles", seconds_per_key=1.25, loop=False
        )
        self.assertEqual(res, {"FINISHED"})
        root = ET.parse(out).getroot()
        self.assertEqual(root.get("loop"), "false")
        self.assertEqual([k.get("groom") for k in root.findall("key")], ["k0.hair.xml", "k1.hair.xml"])
        # Without an armature every style is in the first style's frame.
        self.assertEqual(writer.read_groom(self.path("k1.hair.xml"))[3], "")

    def test_mismatched_strand_count_refused(self):
        obs = self.styles([("a", [4, 4, 4]), ("b", [4, 4])])
        select_only(obs)
        out = self.path("bad.hairanim.xml")
        with self.assertRaisesRegex(RuntimeError, "'b' has 2 strands but the base style 'a' has 3"):
            bpy.ops.export_scene.cartoon_hair_anim(filepath=out)
        self.assertEqual(os.listdir(self.tmp), [])

    def test_mismatched_particle_count_refused(self):
        obs = self.styles([("a", [4, 4, 4]), ("b", [4, 5, 4])])
        select_only(obs)
        with self.assertRaisesRegex(RuntimeError, "'b', strand 1: 5 particles but the base style 'a' has 4"):
            bpy.ops.export_scene.cartoon_hair_anim(filepath=self.path("bad.hairanim.xml"))
        self.assertEqual(os.listdir(self.tmp), [])


class BoneFrame(ExportTestCase):
    """The add-on's bone frame is the frame of the bone's node in the glTF file: export a
    posed, moved, rotated (and scaled) rig with Blender's glTF exporter, compose the node TRS
    down the hierarchy, compare.  The hair points go into the .glb too (as a point mesh), so
    ``bone_global * (p / scale)`` is checked against where glTF puts them."""

    def check(self, parent_bone=None, **armature_kwargs):
        arm = make_armature(**armature_kwargs)
        counts = [5] * 12
        hair, local = make_curves("hair", counts, seed=3)
        me = bpy.data.meshes.new("probe")
        me.from_pydata([tuple(map(float, p)) for p in local], [], [])
        probe = helpers.link(bpy.data.objects.new("probe", me))
        for ob in (hair, probe):
            ob.location, ob.rotation_euler = (0.05, -0.1, 0.02), (0.2, 0.4, -0.3)
            if parent_bone:
                ob.parent, ob.parent_type, ob.parent_bone = arm, "BONE", parent_bone
        bpy.context.view_layer.update()

        glb = self.path("rig.glb")
        bpy.ops.export_scene.gltf(
            filepath=glb, export_format="GLB", export_yup=True, use_mesh_vertices=True,
            export_animations=False,
        )
        gltf, binary = helpers.read_glb(glb)
        nodes = helpers.node_global_matrices(gltf)
        for bone in ("root", "spine", "head"):
            np.testing.assert_allclose(gather.frame_matrix(arm, bone), nodes[bone], atol=1e-5,
                                       err_msg=bone)

        select_only([hair])
        out = self.path("h.hair.xml")
        bpy.ops.export_scene.cartoon_hair(filepath=out, armature=arm.name, bone="head", scale=4.0)
        pos, _, scale, _ = writer.read_groom(out)
        root = ET.parse(out).getroot()
        frame_scale = writer.uniform_scale(nodes["head"])
        if abs(frame_scale - 1.0) < 1e-6:
            self.assertEqual((root.get("units"), root.get("bone_scale")), ("meters", None))
        else:
            # A scaled rig: the numbers are the bone's own units, and the file says so.
            self.assertEqual(root.get("units"), "bone")
            self.assertAlmostEqual(float(root.get("bone_scale")), frame_scale, places=6)
        game = writer.transform_points(nodes["head"], pos / scale)
        gltf_points = helpers.mesh_world_positions(gltf, binary, "probe")
        self.assertEqual(len(gltf_points), len(game))
        # glTF may reorder vertices: nearest match.
        d = np.linalg.norm(gltf_points[:, None, :] - game[None, :, :], axis=2).min(axis=1)
        self.assertLess(d.max(), 1e-5)
        return nodes

    def test_posed_rotated_armature(self):
        self.check()

    def test_hair_parented_to_posed_bone(self):
        # Hair following a posed bone is exported where it is in the rest pose, like glTF's
        # rest-pose node.
        self.check(parent_bone="head")

    def test_scaled_armature_sideways_bone(self):
        self.check(location=(-1.0, 2.0, 0.0), rotation=(1.2, -0.4, 2.5), scale=(1.3, 1.3, 1.3),
                   head_roll=-2.0)

    def test_mixamo_scaled_armature(self):
        # Mixamo's rigs carry a 0.01 scale on the armature object (bones in centimetres).
        self.check(scale=(0.01, 0.01, 0.01))

    def test_upright_bone_keeps_gltf_axes(self):
        # An upright bone with no roll: its node has glTF's axes (hair authored in the Y-up
        # world needs no rotation).
        arm = bpy.data.armatures.new("A")
        ob = helpers.link(bpy.data.objects.new("A", arm))
        bpy.context.view_layer.objects.active = ob
        bpy.ops.object.mode_set(mode="EDIT")
        b = arm.edit_bones.new("head")
        b.head, b.tail = (0, 0, 1.6), (0, 0, 1.9)
        bpy.ops.object.mode_set(mode="OBJECT")
        f = gather.frame_matrix(ob, "head")
        np.testing.assert_allclose(f[:3, :3], np.eye(3), atol=1e-6)
        np.testing.assert_allclose(f[:3, 3], [0, 1.6, 0], atol=1e-6)


class Speed(ExportTestCase):
    def test_100k_strands(self):
        n, k = 100_000, 6
        cv = bpy.data.hair_curves.new("big")
        cv.add_curves([k] * n)
        rng = np.random.default_rng(0)
        roots = rng.uniform(-0.1, 0.1, (n, 1, 3)).astype(np.float32)
        steps = np.cumsum(rng.uniform(0.005, 0.02, (n, k, 3)), axis=1).astype(np.float32)
        cv.points.foreach_set("position", (roots + steps).ravel())
        ob = helpers.link(bpy.data.objects.new("big", cv))
        arm = make_armature(pose=False)
        select_only([ob])
        out = self.path("big.hair.xml")
        t = time.perf_counter()
        res = bpy.ops.export_scene.cartoon_hair(filepath=out, armature=arm.name, bone="head")
        dt = time.perf_counter() - t
        print(f"\n  100,000 strands x 6 points exported in {dt:.2f} s "
              f"({os.path.getsize(out) / 1e6:.1f} MB)", flush=True)
        self.assertEqual(res, {"FINISHED"})
        self.assertLess(dt, 10.0)
        with open(out, encoding="utf-8") as f:
            text = f.read()
        self.assertEqual(text.count("<strand>"), n)


if __name__ == "__main__":
    unittest.main()
