# SPDX-License-Identifier: MIT OR Apache-2.0
"""Shared helpers of the Blender-side tests: import path, scene building, .glb reading."""

import json
import math
import os
import struct
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
BLENDER_TOOLS = os.path.dirname(HERE)
REPO = os.path.dirname(os.path.dirname(BLENDER_TOOLS))
if BLENDER_TOOLS not in sys.path:
    sys.path.insert(0, BLENDER_TOOLS)


def bpy_ready():
    """Import bpy, reset to an empty factory scene and register the add-on (once).

    The add-on is unregistered again at interpreter exit: a `bpy` module process that exits
    with Python callbacks still appended to Blender menus hangs on shutdown."""
    import atexit

    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Scene, "cartoon_hair") or not hasattr(
        bpy.types, "EXPORT_SCENE_OT_cartoon_hair"
    ):
        import bevy_cartoon_hair_export

        try:
            bevy_cartoon_hair_export.unregister()
        except Exception:
            pass
        bevy_cartoon_hair_export.register()
        atexit.register(_unregister)
    return bpy


def _unregister():
    import bevy_cartoon_hair_export

    try:
        bevy_cartoon_hair_export.unregister()
    except Exception:
        pass


def link(obj):
    import bpy

    bpy.context.scene.collection.objects.link(obj)
    return obj


def select_only(objs, active=None):
    import bpy

    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = active or (objs[0] if objs else None)


def make_armature(name="Armature", location=(0.3, -0.2, 0.5), rotation=(0.2, 0.1, 0.7),
                  scale=(1.0, 1.0, 1.0), head_roll=0.6, pose=True):
    """An armature root -> spine -> head with a tilted, rolled `head` bone, the object moved
    and rotated, and (``pose``) the bones posed away from rest."""
    import bpy
    from mathutils import Quaternion

    arm = bpy.data.armatures.new(name)
    ob = link(bpy.data.objects.new(name, arm))
    ob.location, ob.rotation_euler, ob.scale = location, rotation, scale
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    r = arm.edit_bones.new("root")
    r.head, r.tail = (0, 0, 0), (0, 0.1, 0.3)
    s = arm.edit_bones.new("spine")
    s.head, s.tail, s.parent, s.roll = (0, 0.1, 0.3), (0.05, 0.0, 1.2), r, -0.3
    h = arm.edit_bones.new("head")
    h.head, h.tail, h.parent, h.roll = (0.1, 0, 1.5), (0.2, 0.1, 1.8), s, head_roll
    bpy.ops.object.mode_set(mode="OBJECT")
    if pose:
        ob.pose.bones["head"].rotation_quaternion = Quaternion((1, 0, 0), 0.5)
        ob.pose.bones["spine"].rotation_quaternion = Quaternion((0, 0, 1), -0.4)
        ob.pose.bones["spine"].location = (0.05, 0.02, 0.0)
    return ob


def make_curves(name, counts, seed=0, spread=0.1, step=0.02, origin=(0.0, 0.0, 1.6)):
    """A Curves object with one strand per entry of ``counts`` (random roots and directions);
    returns ``(object, local positions (N,3) float32)``."""
    import bpy

    rng = np.random.default_rng(seed)
    cv = bpy.data.hair_curves.new(name)
    cv.add_curves([int(c) for c in counts])
    parts = []
    for c in counts:
        root = np.asarray(origin) + rng.uniform(-spread, spread, 3)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        steps = (d + rng.normal(scale=0.3, size=(c, 3))) * step
        steps[0] = 0.0
        parts.append(root + np.cumsum(steps, axis=0))
    pos = np.concatenate(parts).astype(np.float32)
    cv.points.foreach_set("position", pos.ravel())
    ob = link(bpy.data.objects.new(name, cv))
    return ob, pos


def matrix_np(m):
    return np.array([list(r) for r in m], dtype=np.float64)


# --------------------------------------------------------------------------------------------
# glTF


def read_glb(path):
    """``(json dict, binary chunk bytes)`` of a .glb file."""
    with open(path, "rb") as f:
        data = f.read()
    magic, version, _length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2, "not a glTF 2 binary"
    chunk_len, chunk_type = struct.unpack_from("<I4s", data, 12)
    assert chunk_type == b"JSON"
    gltf = json.loads(data[20:20 + chunk_len].decode("utf-8"))
    off = 20 + chunk_len
    binary = b""
    if off + 8 <= len(data):
        bin_len, bin_type = struct.unpack_from("<I4s", data, off)
        if bin_type == b"BIN\x00":
            binary = data[off + 8:off + 8 + bin_len]
    return gltf, binary


def read_glb_json(path):
    return read_glb(path)[0]


_COMPONENTS = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_accessor(gltf, binary, index):
    """The data of accessor ``index`` as a ``(count, width)`` array (tightly packed views)."""
    acc = gltf["accessors"][index]
    view = gltf["bufferViews"][acc["bufferView"]]
    dtype = _COMPONENTS[acc["componentType"]]
    width = _WIDTH[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride")
    item = np.dtype(dtype).itemsize * width
    assert stride in (None, item), "interleaved buffer views not supported"
    n = acc["count"] * width
    return np.frombuffer(binary, dtype=dtype, count=n, offset=start).reshape(-1, width)


def mesh_world_positions(gltf, binary, node_name):
    """All vertex positions of the mesh of node ``node_name``, in glTF world space."""
    world = node_global_matrices(gltf)[node_name]
    node = next(n for n in gltf["nodes"] if n.get("name") == node_name)
    mesh = gltf["meshes"][node["mesh"]]
    pts = [read_accessor(gltf, binary, p["attributes"]["POSITION"]) for p in mesh["primitives"]]
    p = np.concatenate(pts).astype(np.float64)
    return p @ world[:3, :3].T + world[:3, 3]


def node_local_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    t = node.get("translation", [0.0, 0.0, 0.0])
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    s = node.get("scale", [1.0, 1.0, 1.0])
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(s)[None, :]
    m[:3, 3] = t
    return m


def node_global_matrices(gltf):
    """Global matrix of every node, composing TRS down the hierarchy: ``{name: matrix}``."""
    nodes = gltf["nodes"]
    parent = {}
    for i, n in enumerate(nodes):
        for c in n.get("children", []):
            parent[c] = i
    cache = {}

    def world(i):
        if i not in cache:
            local = node_local_matrix(nodes[i])
            cache[i] = world(parent[i]) @ local if i in parent else local
        return cache[i]

    return {nodes[i].get("name", str(i)): world(i) for i in range(len(nodes))}


def rotation_angle(a, b):
    """Angle (radians) between the rotation parts of two matrices."""
    ra = a[:3, :3] / np.linalg.norm(a[:3, :3], axis=0)
    rb = b[:3, :3] / np.linalg.norm(b[:3, :3], axis=0)
    c = (np.trace(ra.T @ rb) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))
