# SPDX-License-Identifier: MIT OR Apache-2.0
"""Write a groom fixture for the Rust loader tests.

    python3 tools/blender/tests/export_fixture.py OUTDIR

Builds, with real Blender (the `bpy` module), a Curves hair object of 50 strands with 3..9
points each on a moved, rotated and posed armature whose `head` bone is tilted and rolled;
exports it with the add-on's exporter at scale 10 to ``OUTDIR/fixture.hair.xml`` and writes
``OUTDIR/fixture.expected.txt``: one line per strand, the positions (x y z per particle, root
first) in metres in the head bone's glTF node frame, i.e. what the loader must produce after
dividing by the scale.  The expected values are computed separately with ``mathutils`` (the
inverse of the bone's rest world matrix, Blender's bone axes; see tools/blender/README.md), not
by the exporter's code.  Also exports a sphere, a capsule rigid body and a plane on the same
bone to ``OUTDIR/fixture.collision.xml`` with ``OUTDIR/fixture.collision.expected.txt`` (one
line per shape: ``sphere x y z r``, ``capsule x0 y0 z0 x1 y1 z1 r``, ``plane x y z nx ny nz``,
computed with ``mathutils``).  Prints ``fixture: N strands, M collision shapes``.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import helpers  # noqa: E402  (sets the import path of the add-on too)

SCALE = 10.0


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    out_dir = os.path.abspath(argv[1])
    os.makedirs(out_dir, exist_ok=True)

    bpy = helpers.bpy_ready()
    from mathutils import Vector

    from bevy_cartoon_hair_export import gather

    arm = helpers.make_armature(location=(0.4, -0.3, 0.1), rotation=(0.25, -0.15, 0.9), head_roll=0.7)
    counts = [3 + (i * 5) % 7 for i in range(50)]  # 3..9, varied
    hair, local = helpers.make_curves("fixture_hair", counts, seed=42, spread=0.08, step=0.025)
    hair.location, hair.rotation_euler = (0.02, 0.01, 0.05), (0.1, -0.2, 0.3)
    bpy.context.view_layer.update()

    path = os.path.join(out_dir, "fixture.hair.xml")
    n = gather.export_hair(path, [hair], armature=arm, bone="head", scale=SCALE)

    to_bone = (arm.matrix_world @ arm.data.bones["head"].matrix_local).inverted()
    hair_world = hair.matrix_world
    lines, i = [], 0
    for c in counts:
        vals = []
        for p in local[i:i + c]:
            q = to_bone @ (hair_world @ Vector(tuple(map(float, p))))
            vals.extend("%.9g" % (v + 0.0) for v in q)
        lines.append(" ".join(vals))
        i += c
    with open(os.path.join(out_dir, "fixture.expected.txt"), "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")

    # Collision shapes on the same bone: a sphere, a capsule rigid body, a plane.
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.09, location=(0.41, -0.28, 0.3))
    sphere = bpy.context.object
    bpy.ops.mesh.primitive_cylinder_add(radius=0.04, depth=0.25, location=(0.5, -0.2, 0.1),
                                        rotation=(0.3, 1.1, 0.2))
    capsule = bpy.context.object
    bpy.ops.rigidbody.object_add()
    capsule.rigid_body.collision_shape = "CAPSULE"
    bpy.ops.mesh.primitive_plane_add(size=0.4, location=(0.4, -0.1, 0.2), rotation=(0.5, 0.2, 0.1))
    plane = bpy.context.object
    bpy.context.view_layer.update()
    shapes = gather.export_collision(os.path.join(out_dir, "fixture.collision.xml"),
                                     [sphere, capsule, plane], armature=arm, bone="head", scale=SCALE)
    # Expected, with mathutils only: Blender's capsule for the cylinder's box is along local Z,
    # ends inset by the radius; a plane's normal is its local Z by the inverse transpose.
    cap_z = capsule.matrix_world.to_3x3().col[2].normalized()
    cap_c = capsule.matrix_world.translation
    half = 0.25 / 2.0 - 0.04
    normal_world = (plane.matrix_world.to_3x3().inverted().transposed() @ Vector((0.0, 0.0, 1.0)))
    normal = (to_bone.to_3x3().inverted().transposed() @ normal_world).normalized()

    def fmt(vs):
        return " ".join("%.9g" % (v + 0.0) for v in vs)

    shape_lines = [
        "sphere " + fmt([*(to_bone @ sphere.matrix_world.translation), 0.09]),
        "capsule " + fmt([*(to_bone @ (cap_c - cap_z * half)), *(to_bone @ (cap_c + cap_z * half)), 0.04]),
        "plane " + fmt([*(to_bone @ plane.matrix_world.translation), *normal]),
    ]
    with open(os.path.join(out_dir, "fixture.collision.expected.txt"), "w", encoding="utf-8",
              newline="\n") as f:
        f.write("\n".join(shape_lines) + "\n")
    print(f"fixture: {n} strands, {shapes} collision shapes", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
