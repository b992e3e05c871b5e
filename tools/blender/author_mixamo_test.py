# SPDX-License-Identifier: MIT OR Apache-2.0
"""Author a test character with Mixamo's conventions, and its hair, with Blender (`bpy`).

    python3 tools/blender/author_mixamo_test.py [--out assets/mixamo_test]

Our ninja is unit-scale with plain bone names. Characters from Mixamo (and many FBX rigs) are
not: the armature object carries a 0.01 scale, its bones and the body are in centimetres, and
bones are named ``mixamorig:Hips``, ``mixamorig:Spine``, ``mixamorig:Neck``,
``mixamorig:Head``. This script builds the ninja's body and idle animation, converts the rig to
those conventions (keeping every vertex and bone where it is in the world), and exports with the
add-on exactly as a user would:

* ``mixamo.glb``           - the skinned character and its looping ``idle`` animation
* ``mixamo.hair.xml``      - the groom on ``mixamorig:Head``: ``units="bone"``,
                             ``bone_scale="0.01"``, numbers in centimetres
* ``mixamo.collision.xml`` - head collision spheres on ``mixamorig:Head``, also in centimetres

The hair and spheres are the ninja's, so a render of the two characters should look alike.
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import bpy  # noqa: E402
from mathutils import Matrix  # noqa: E402

import author_ninja as ninja  # noqa: E402
from bevy_cartoon_hair_export import gather  # noqa: E402

RIG_SCALE = 0.01
NAMES = {
    "root": "mixamorig:Hips",
    "spine": "mixamorig:Spine",
    "neck": "mixamorig:Neck",
    "head": "mixamorig:Head",
}
HEAD = NAMES["head"]


def to_mixamo(rig, body, action):
    """Rename the bones and move the rig to centimetres under a 0.01 object scale; nothing moves
    in the world."""
    for old, new in NAMES.items():
        rig.data.bones[old].name = new  # Blender renames vertex groups and F-curve paths too
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    # Read every bone first: moving a parent's tail moves its connected child's head.
    ends = {b.name: (b.head / RIG_SCALE, b.tail / RIG_SCALE) for b in rig.data.edit_bones}
    for b in rig.data.edit_bones:
        b.head, b.tail = ends[b.name]
    bpy.ops.object.mode_set(mode="OBJECT")
    rig.scale = (RIG_SCALE,) * 3
    body.data.transform(Matrix.Scale(1.0 / RIG_SCALE, 4))
    for fc in ninja._fcurves(rig, action):
        if fc.data_path.endswith("location"):
            for k in fc.keyframe_points:
                k.co[1] /= RIG_SCALE
                k.handle_left[1] /= RIG_SCALE
                k.handle_right[1] /= RIG_SCALE
    bpy.context.view_layer.update()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(REPO, "assets", "mixamo_test"))
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(ninja.SEED)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"

    rig = ninja.make_armature()
    rig.name = rig.data.name = "Armature"
    mb = ninja.build_character()
    body = bpy.data.objects.new("Body", mb.build("Body"))
    scene.collection.objects.link(body)
    for m in ninja.make_materials():
        body.data.materials.append(m)
    groups = {name: body.vertex_groups.new(name=name) for name, *_ in ninja.BONES}
    for i, w in enumerate(mb.weights):
        for bone, value in w.items():
            if value > 0.0:
                groups[bone].add([i], value, "REPLACE")
    body.parent = rig
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    action = ninja.make_idle(rig)
    to_mixamo(rig, body, action)
    missing = [g.name for g in body.vertex_groups if g.name not in rig.data.bones]
    assert not missing, f"vertex groups not renamed with their bones: {missing}"
    paths = {fc.data_path for fc in ninja._fcurves(rig, action)}
    assert all("mixamorig:" in p for p in paths), f"F-curves not renamed: {sorted(paths)}"

    # Hair and spheres: the ninja's, placed in the world, then parented to the scaled head bone.
    base, _roots = ninja.make_groom(rng)
    hair = ninja.curves_object("hair", base)
    ninja.parent_to_bone(hair, rig, HEAD)
    spheres = []
    for name, c, r in ninja.COLLISION_SPHERES:
        e = bpy.data.objects.new(name, None)
        e.empty_display_type, e.empty_display_size = "SPHERE", r
        e.location = c
        scene.collection.objects.link(e)
        spheres.append(e)
    bpy.context.view_layer.update()
    for e in spheres:
        ninja.parent_to_bone(e, rig, HEAD)

    scene.frame_set(0)
    n = gather.export_hair(os.path.join(out, "mixamo.hair.xml"), [hair], rig, HEAD, 1.0)
    ns = gather.export_collision(os.path.join(out, "mixamo.collision.xml"), spheres, rig, HEAD, 1.0)
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (rig, body))
    bpy.context.view_layer.objects.active = rig
    glb = os.path.join(out, "mixamo.glb")
    ninja.export_glb(glb)
    print(f"mixamo test character: {n} strands, {ns} spheres on {HEAD!r}, rig scale {RIG_SCALE};"
          f" glb {os.path.getsize(glb)} bytes; written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
