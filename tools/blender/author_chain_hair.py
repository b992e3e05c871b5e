# SPDX-License-Identifier: MIT OR Apache-2.0
"""Author a test character whose hair is a modelled mesh on hair-bone chains, with Blender.

    python3 tools/blender/author_chain_hair.py [--out assets/chain_hair]

Most anime characters (VRoid and other VRM avatars, many Blender and MMD characters) bring their
hair this way: locks modelled as a mesh, skinned to chains of bones under the head. This builds
the ninja's body, rig and idle animation (its quick head shake included), adds hair bones under
``head`` and a hair mesh skinned to them, and exports the glTF a user would:

* ``chain_hair.glb`` - the character, its hair mesh and the ``idle`` animation. Hair bones:
  ``hair_bang_0..4_k`` (five bangs over the forehead, 3 bones each), ``hair_side_L_k`` and
  ``hair_side_R_k`` (locks beside the face, 5 bones), ``hair_back_0..4_k`` (the back mass, five
  locks from the crown to the nape, 5 bones each), ``hair_tail_k`` (a ponytail, 7 bones).
  Every hair bone's name starts with ``hair_``; none is animated.

The hair mesh is a cap over the scalp and thick locks as an anime avatar's are: each lock a
closed tube of rhombic section (its thickness a third of its width) whose width swells below
the root and narrows to a point, wide enough that neighbouring locks overlap. Each lock's
vertices are weighted to the two nearest bones of its chain.
"""

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import bpy  # noqa: E402

import author_ninja as ninja  # noqa: E402

HAIR_COLOUR = (0.45, 0.08, 0.02)


def bangs():
    """Five bangs from the hairline over the forehead (Blender space; the face looks along -Y)."""
    chains = []
    c = ninja.HEAD_C
    for i in range(5):
        x = (i - 2) * 0.03
        top = c + [x, -0.085, 0.075]
        path = [top, top + [0.0, -0.03, -0.028], top + [x * 0.2, -0.038, -0.058], top + [x * 0.3, -0.041, -0.086]]
        chains.append((f"hair_bang_{i}", path, 0.042))
    return chains


def side_locks():
    chains = []
    c = ninja.HEAD_C
    for side, sx in (("L", 1.0), ("R", -1.0)):
        top = c + [sx * 0.1, -0.03, 0.04]
        path = [top + [sx * 0.012 * k, -0.004 * k, -0.05 * k] for k in range(6)]
        chains.append((f"hair_side_{side}", path, 0.04))
    return chains


def back_mass():
    """Five wide locks from the back of the crown down to the nape, hugging the head: each path
    point 1.2 cm outside the head's ellipsoid at its height (at least 8.5 cm from its axis, clear
    of the neck)."""
    chains = []
    c = ninja.HEAD_C
    rx, ry, rz = ninja.HEAD_R
    for i in range(5):
        phi = math.radians(-64.0 + 32.0 * i)
        d = np.array([math.sin(phi), math.cos(phi), 0.0])
        # The head's radius in direction d at its equator.
        r_eq = 1.0 / math.sqrt((d[0] / rx) ** 2 + (d[1] / ry) ** 2)
        path = []
        for k in range(6):
            z = 0.07 - 0.046 * k
            r = r_eq * math.sqrt(max(0.0, 1.0 - (z / rz) ** 2))
            path.append(c + d * max(r + 0.012, 0.085) + [0.0, 0.0, z])
        chains.append((f"hair_back_{i}", path, 0.08))
    return chains


def ponytail():
    c = ninja.HEAD_C
    top = c + [0.0, 0.11, 0.05]
    path = [top]
    for k in range(1, 8):
        path.append(top + [0.0, 0.035 + 0.012 * k, -0.045 * k + 0.002 * k * k])
    return [("hair_tail", path, 0.05)]


def chains():
    return bangs() + side_locks() + back_mass() + ponytail()


def add_hair_bones(rig):
    """Every chain's bones under ``head``: bone k runs from path point k to k + 1."""
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    eb = rig.data.edit_bones
    for name, path, _ in chains():
        parent = eb["head"]
        for k in range(len(path) - 1):
            b = eb.new(f"{name}_{k}")
            b.head, b.tail = tuple(path[k]), tuple(path[k + 1])
            b.roll = 0.0
            b.parent = parent
            b.use_connect = k > 0
            parent = b
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in rig.pose.bones:
        pb.rotation_mode = "QUATERNION"


def width_curve(s, keep=2.2):
    """A lock's width at ``s`` (0 at the root, 1 at the tip) over its root width: swelling a
    little below the root, then narrowing to a point (later for a larger ``keep``)."""
    return (1.0 - s ** keep) * (0.85 + 0.6 * s * (1.0 - s))


def lock(mb, name, path, width, material, thickness=0.34, per_bone=6):
    """A thick lock along ``path``: a closed tube of rhombic section, its width across the way
    out of the head ``width * width_curve``, its thickness ``thickness`` times that, ending in a
    point; each vertex weighted to the bones of the two path segments around it. Faces wind
    outward."""
    path = np.asarray(path, dtype=np.float64)
    n_bones = len(path) - 1
    samples = per_bone * n_bones + 1
    verts, faces, weights, axis = [], [], [], []
    for j in range(samples):
        s = j / (samples - 1) * n_bones  # position along the chain, in bones
        k = min(int(s), n_bones - 1)
        f = s - k
        p = path[k] * (1 - f) + path[k + 1] * f
        t = path[k + 1] - path[k]
        t /= np.linalg.norm(t)
        out = p - ninja.HEAD_C
        out -= t * np.dot(out, t)
        out /= max(np.linalg.norm(out), 1e-9)
        side = np.cross(t, out)
        side /= max(np.linalg.norm(side), 1e-9)
        # Long locks keep their width further down before the point.
        keep = 3.5 if n_bones >= 5 else 2.2
        w = width * width_curve(j / (samples - 1), keep) * 0.5 + 5e-5
        h = w * thickness
        # Lifted off the skull by half its thickness, so the inner edge lies on the cap.
        centre = p + out * (h + 0.002)
        here = f"{name}_{k}"
        blend = max(0.0, f - 0.7) / 0.3 if k + 1 < n_bones else 0.0
        wt = {here: 1.0 - 0.5 * blend}
        if blend > 0.0:
            wt[f"{name}_{k + 1}"] = 0.5 * blend
        for corner in (side * w, out * h, -side * w, -out * h):
            verts.append(centre + corner)
            weights.append(dict(wt))
        axis.append(centre)
        if j:
            a, b = 4 * (j - 1), 4 * j
            for c in range(4):
                faces.append([a + c, a + (c + 1) % 4, b + (c + 1) % 4, b + c])
    faces.append([3, 2, 1, 0])  # the root's cap
    # Wind every face outward: its normal away from the lock's axis.
    v = np.array(verts)
    out_faces = []
    for face in faces:
        q = v[face]
        n = np.cross(q[1] - q[0], q[-1] - q[0])
        ring = min(face) // 4
        if len(face) == 4 and face != [3, 2, 1, 0]:
            away = q.mean(axis=0) - axis[ring]
        else:
            away = -(path[1] - path[0])
        out_faces.append(list(reversed(face)) if np.dot(n, away) < 0.0 else face)
    mb.add(v, out_faces, material, lambda _v, it=iter(weights): next(it), smooth=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(REPO, "assets", "chain_hair"))
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    rig = ninja.make_armature()
    add_hair_bones(rig)
    # No headband knot or tails: they would pierce the back mass.
    mb = ninja.build_character(knot=False)
    hair_material = len(ninja.MATERIALS)
    # A cap over the scalp, on the head bone.
    v, f = ninja.ellipsoid(ninja.HEAD_C + [0.0, 0.004, 0.006], ninja.HEAD_R * 1.06, 28, 14, theta=(0.0, 1.25))
    mb.add(v, f, hair_material, "head")
    for name, path, width in chains():
        lock(mb, name, path, width, hair_material)
    body = bpy.data.objects.new("chain_hair_body", mb.build("chain_hair_body"))
    scene.collection.objects.link(body)
    for m in ninja.make_materials():
        body.data.materials.append(m)
    hair = bpy.data.materials.new("hair")
    hair.use_nodes = True
    hair.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*HAIR_COLOUR, 1.0)
    hair.diffuse_color = (*HAIR_COLOUR, 1.0)
    hair.use_backface_culling = False
    body.data.materials.append(hair)
    groups = {}
    for i, w in enumerate(mb.weights):
        for bone, value in w.items():
            if value > 0.0:
                if bone not in groups:
                    groups[bone] = body.vertex_groups.new(name=bone)
                groups[bone].add([i], value, "REPLACE")
    body.parent = rig
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    ninja.make_idle(rig)

    scene.frame_set(0)
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (rig, body))
    bpy.context.view_layer.objects.active = rig
    glb = os.path.join(out, "chain_hair.glb")
    ninja.export_glb(glb)
    n_bones = sum(len(p) - 1 for _, p, _ in chains())
    print(f"chain_hair: {len(chains())} chains, {n_bones} hair bones, {mb.triangles()} triangles; "
          f"glb {os.path.getsize(glb)} bytes, written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
