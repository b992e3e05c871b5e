# SPDX-License-Identifier: MIT OR Apache-2.0
"""Author the bundled ninja-head character and its hair, reproducibly, with Blender (`bpy`).

    python3 tools/blender/author_ninja.py [--out assets/ninja] [--blend ninja.blend]

Writes to the output folder (default: assets/ninja next to this repository's tools/):

* ``ninja.glb``            - the skinned character (armature root/spine/neck/head) and its
                             looping ``idle`` animation (breathing, head turns, a quick shake)
* ``ninja.hair.xml``       - the spiky groom, in the space of bone ``head``, scale 1
* ``ninja_wind.hair.xml``, ``ninja_flip.hair.xml`` - keyframe styles derived from it
* ``ninja.hairanim.xml``   - the looping hair animation through the three styles
* ``ninja.collision.xml``  - head/neck collision spheres on bone ``head``

Everything is generated from a fixed random seed in an empty factory scene, so running it again
gives the same files.  Conventions (Blender -> glTF/Bevy): Blender is Z-up and the character
faces Blender's -Y; the glTF export is "+Y Up", so the character stands on y=0, is about 1.8 m
tall and FACES +Z in glTF/Bevy (a camera at +Z looking along -Z sees the face).  All bones
point straight up with zero roll, so the ``head`` node has glTF's axes; its rest translation is
(0, 1.6, 0).
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

from bevy_cartoon_hair_export import gather  # noqa: E402

SEED = 20240607
FPS = 30
IDLE_FRAMES = 120  # 4 s; frame 120 == frame 0 for a seamless loop

# Head ellipsoid (Blender space, metres).
HEAD_C = np.array([0.0, 0.0, 1.68])
HEAD_R = np.array([0.105, 0.115, 0.125])  # x (width), y (depth), z (height)

# Bones (Blender space): all straight up (+Z), zero roll.
BONES = [  # name, head z, tail z, parent
    ("root", 0.0, 0.9, None),
    ("spine", 0.9, 1.42, "root"),
    ("neck", 1.42, 1.60, "spine"),
    ("head", 1.60, 1.86, "neck"),
]

MATERIALS = [  # name, base colour (linear), roughness, metallic
    ("skin", (0.80, 0.52, 0.36), 0.6, 0.0),
    ("navy", (0.015, 0.022, 0.075), 0.8, 0.0),
    ("headband", (0.60, 0.025, 0.03), 0.7, 0.0),
    ("dark", (0.01, 0.01, 0.012), 0.5, 0.0),
    ("metal", (0.55, 0.57, 0.60), 0.35, 1.0),
    # The hair's own shadow tone (its colour, srgb(0.98, 0.62, 0.12), at the ramp's dark band),
    # so the scalp that shows between spiky locks reads as hair, not skin.
    ("scalp", (0.43, 0.15, 0.006), 0.8, 0.0),
    # The eyes: the dark of the feet, a material of their own so a game can find them by name
    # (to draw them through the fringe).
    ("eyes", (0.01, 0.01, 0.012), 0.5, 0.0),
]
M_SKIN, M_NAVY, M_RED, M_DARK, M_METAL, M_SCALP, M_EYES = range(7)


# ============================================================================================
# Mesh building (numpy; one mesh, one material index per face, bone weights per vertex)


class MeshBuilder:
    def __init__(self):
        self.verts, self.faces, self.mats, self.smooth, self.weights = [], [], [], [], []

    def add(self, verts, faces, material, weights, smooth=True):
        """``weights``: a bone name, or a function ``(vertex) -> {bone: weight}``."""
        base = len(self.verts)
        for v in np.asarray(verts, dtype=np.float64):
            self.verts.append(tuple(float(x) for x in v))
            self.weights.append({weights: 1.0} if isinstance(weights, str) else weights(v))
        for f in faces:
            self.faces.append(tuple(base + i for i in f))
            self.mats.append(material)
            self.smooth.append(smooth)

    def triangles(self):
        return sum(len(f) - 2 for f in self.faces)

    def build(self, name):
        me = bpy.data.meshes.new(name)
        me.from_pydata(self.verts, [], self.faces)
        me.polygons.foreach_set("material_index", self.mats)
        me.polygons.foreach_set("use_smooth", self.smooth)
        me.validate()
        me.update()
        return me


def ring_faces(n_rings, n, closed=True):
    """Quads joining ``n_rings`` consecutive rings of ``n`` vertices (outward normals when the
    rings go up and the ring points go counter-clockwise seen from above)."""
    faces = []
    for j in range(n_rings - 1):
        for i in range(n if closed else n - 1):
            a, b = j * n + i, j * n + (i + 1) % n
            faces.append((a, b, b + n, a + n))
    return faces


def ellipsoid(center, radii, nu=32, nv=16, theta=(0.0, math.pi)):
    """UV ellipsoid; ``theta`` the polar range from +Z (a partial range leaves an open edge)."""
    center, radii = np.asarray(center, dtype=np.float64), np.asarray(radii, dtype=np.float64)
    t0, t1 = theta
    top, bottom = t0 <= 1e-9, t1 >= math.pi - 1e-9
    thetas = np.linspace(t0, t1, nv + 1)
    inner = thetas[(1 if top else 0):(nv if bottom else nv + 1)]
    phis = np.linspace(0.0, 2 * math.pi, nu, endpoint=False)
    # Rings from the bottom up, so ring_faces gives outward normals.
    rings = []
    for t in inner[::-1]:
        rings.append(np.stack([np.sin(t) * np.cos(phis), np.sin(t) * np.sin(phis),
                               np.full(nu, np.cos(t))], axis=1))
    verts = list(np.concatenate(rings) * radii + center)
    faces = ring_faces(len(rings), nu)
    n_ring_verts = len(verts)
    if bottom:
        verts.append(center + [0.0, 0.0, -radii[2]])
        p = len(verts) - 1
        faces += [(p, (i + 1) % nu, i) for i in range(nu)]
    if top:
        verts.append(center + [0.0, 0.0, radii[2]])
        p = len(verts) - 1
        last = n_ring_verts - nu
        faces += [(p, last + i, last + (i + 1) % nu) for i in range(nu)]
    return np.array(verts), faces


def hood(center, radii, nu, nv):
    """A partial ellipsoid from the bottom pole up to a top edge whose height depends on the
    azimuth: under the eyes at the front (-Y), under the headband at the sides and back."""
    center, radii = np.asarray(center, dtype=np.float64), np.asarray(radii, dtype=np.float64)
    phis = np.linspace(0.0, 2 * math.pi, nu, endpoint=False)
    z_top = np.array([-0.03 + 0.028 * smoothstep((math.sin(p) + 0.3) / 0.8) for p in phis])
    theta_top = np.arccos(np.clip(z_top / radii[2], -1.0, 1.0))
    rings = []
    for k in range(1, nv + 1):  # bottom-up; k == nv is the top edge
        t = math.pi - (k / nv) * (math.pi - theta_top)
        rings.append(np.stack([np.sin(t) * np.cos(phis), np.sin(t) * np.sin(phis), np.cos(t)], axis=1))
    verts = list(np.concatenate(rings) * radii + center)
    faces = ring_faces(len(rings), nu)
    verts.append(center + [0.0, 0.0, -radii[2]])
    p = len(verts) - 1
    faces += [(p, (i + 1) % nu, i) for i in range(nu)]
    return np.array(verts), faces


def tube(path, radii, n=16, cap_start=True, cap_end=True, side_ref=(0.0, 1.0, 0.0)):
    """A loft of elliptic rings along ``path`` (points), ``radii`` a list of (r_u, r_v)."""
    path = np.asarray(path, dtype=np.float64)
    radii = np.asarray(radii, dtype=np.float64)
    alphas = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    verts = []
    for k, c in enumerate(path):
        t = path[min(k + 1, len(path) - 1)] - path[max(k - 1, 0)]
        t /= np.linalg.norm(t)
        u = np.cross(side_ref, t)
        u /= np.linalg.norm(u)
        v = np.cross(t, u)
        for a in alphas:
            verts.append(c + radii[k][0] * math.cos(a) * u + radii[k][1] * math.sin(a) * v)
    faces = ring_faces(len(path), n)
    if cap_start:
        verts.append(path[0])
        p = len(verts) - 1
        faces += [(p, (i + 1) % n, i) for i in range(n)]
    if cap_end:
        verts.append(path[-1])
        p = len(verts) - 1
        last = (len(path) - 1) * n
        faces += [(p, last + i, last + (i + 1) % n) for i in range(n)]
    return np.array(verts), faces


def box(center, size, axes=np.eye(3)):
    hx, hy, hz = np.asarray(size) / 2.0
    corners = np.array([[x, y, z] for z in (-hz, hz) for y in (-hy, hy) for x in (-hx, hx)])
    verts = corners @ np.asarray(axes).T + center
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return verts, faces


def smoothstep(x):
    x = min(1.0, max(0.0, x))
    return x * x * (3 - 2 * x)


def chain_weights(v, blend=0.05):
    """Skin weights along the upright chain root/spine/neck/head by height, blended at joints."""
    z = v[2]
    names = [b[0] for b in BONES]
    joints = [b[1] for b in BONES[1:]]
    for k, zj in enumerate(joints):
        if abs(z - zj) < blend:
            s = smoothstep((z - zj + blend) / (2 * blend))
            return {names[k]: 1.0 - s, names[k + 1]: s}
    return {names[sum(z > zj for zj in joints)]: 1.0}


def band_center_z(y):
    """Height (relative to the head centre) of the tilted headband: higher at the front."""
    return 0.02 + 0.015 * (-y / HEAD_R[1])


def head_surface(phi, z_rel, offset=0.0):
    """Point on the head ellipsoid at azimuth ``phi`` and height ``z_rel``, pushed ``offset``
    outwards along the horizontal direction."""
    s = math.sqrt(max(0.0, 1.0 - (z_rel / HEAD_R[2]) ** 2))
    x, y = HEAD_R[0] * s * math.cos(phi), HEAD_R[1] * s * math.sin(phi)
    d = np.array([x / HEAD_R[0] ** 2, y / HEAD_R[1] ** 2, 0.0])
    d /= np.linalg.norm(d)
    return HEAD_C + np.array([x, y, z_rel]) + d * offset


def build_character(knot=True):
    """The ninja's body, head, hood, eyes and headband. ``knot``: the headband's knot and its two
    tails at the back of the head (a character with a back mass of hair leaves them out: they
    would pierce it)."""
    mb = MeshBuilder()
    # --- head, face
    v, f = ellipsoid(HEAD_C, HEAD_R, 32, 18)
    # Above the headband the head is scalp (hair-coloured); below it, skin.
    def above_band(face):
        c = np.mean([v[i] for i in face], axis=0) - HEAD_C
        return c[2] > band_center_z(c[1]) + 0.006
    mb.add(v, [face for face in f if not above_band(face)], M_SKIN, "head")
    mb.add(v, [face for face in f if above_band(face)], M_SCALP, "head")
    # Hood/mask: covers the lower face, and the back and sides of the head up under the
    # headband, leaving the eyes free (open at the top edge).
    v, f = hood(HEAD_C + [0, -0.002, 0], HEAD_R * [1.04, 1.05, 1.03], 32, 18)
    mb.add(v, f, M_NAVY, "head")
    # Eyes: flattened dark ellipsoids on the face (front is -Y).
    for sx in (-1.0, 1.0):
        c = HEAD_C + [sx * 0.038, -HEAD_R[1] * 0.93, 0.004]
        v, f = ellipsoid(c, [0.016, 0.008, 0.011], 12, 6)
        mb.add(v, f, M_EYES, "head")
    # Headband: a tilted closed band around the forehead, a metal plate at the front, a knot
    # and two tails at the back.
    n = 48
    sections = []
    for i in range(n):
        phi = 2 * math.pi * i / n
        y_dir = HEAD_R[1] * math.sin(phi)
        zc = band_center_z(y_dir)
        sections.append([head_surface(phi, zc - 0.017, 0.003), head_surface(phi, zc - 0.017, 0.013),
                         head_surface(phi, zc + 0.017, 0.013), head_surface(phi, zc + 0.017, 0.003)])
    verts = np.array([p for s in sections for p in s])
    faces = []
    for i in range(n):
        a, b = 4 * i, 4 * ((i + 1) % n)
        for k in range(4):
            k2 = (k + 1) % 4
            faces.append((a + k, b + k, b + k2, a + k2))
    mb.add(verts, faces, M_RED, "head")
    front_z = band_center_z(-HEAD_R[1])
    plate_c = head_surface(-math.pi / 2, front_z, 0.016)
    v, f = box(plate_c, (0.075, 0.006, 0.03))
    mb.add(v, f, M_METAL, "head", smooth=False)
    if knot:
        back_z = band_center_z(HEAD_R[1])
        knot_c = head_surface(math.pi / 2, back_z, 0.018)
        v, f = ellipsoid(knot_c, [0.02, 0.014, 0.016], 10, 6)
        mb.add(v, f, M_RED, "head")
        for sx in (-1.0, 1.0):
            pts = [knot_c + [sx * (0.008 + 0.03 * t), 0.012 + 0.07 * t, -0.22 * t + 0.04 * t * t]
                   for t in np.linspace(0.0, 1.0, 7)]
            verts, faces = [], []
            for k, p in enumerate(pts):
                w = 0.016 * (1.0 - 0.3 * k / 6)
                verts += [p + [-w, 0, 0], p + [w, 0, 0]]
                if k:
                    a = 2 * (k - 1)
                    faces.append((a, a + 1, a + 3, a + 2))
            mb.add(verts, faces, M_RED, "head")
    # --- neck, torso, belt
    v, f = tube([[0, 0, 1.44], [0, 0, 1.53], [0, 0, 1.62]], [[0.052, 0.05], [0.05, 0.048], [0.05, 0.048]],
                16, cap_start=False, cap_end=False)
    mb.add(v, f, M_NAVY, chain_weights)
    z = [0.84, 0.92, 1.02, 1.14, 1.27, 1.37, 1.43, 1.47, 1.49]
    r = [[0.15, 0.10], [0.165, 0.11], [0.15, 0.10], [0.165, 0.105], [0.195, 0.115], [0.20, 0.115],
         [0.17, 0.10], [0.10, 0.075], [0.055, 0.05]]
    v, f = tube([[0, 0, zz] for zz in z], r, 24, cap_start=True, cap_end=True)
    mb.add(v, f, M_NAVY, chain_weights)
    v, f = tube([[0, 0, 0.975], [0, 0, 1.0], [0, 0, 1.03]], [[0.166, 0.111], [0.168, 0.113], [0.164, 0.110]],
                24, cap_start=False, cap_end=False)
    mb.add(v, f, M_RED, chain_weights)
    # --- legs and feet
    for sx in (-1.0, 1.0):
        v, f = tube([[sx * 0.09, 0, 0.9], [sx * 0.095, 0, 0.5], [sx * 0.1, 0, 0.08]],
                    [[0.075, 0.075], [0.058, 0.058], [0.045, 0.045]], 14)
        mb.add(v, f, M_NAVY, "root")
        v, f = ellipsoid([sx * 0.1, -0.04, 0.045], [0.05, 0.105, 0.045], 14, 8)
        mb.add(v, f, M_DARK, "root")
    # --- arms, shoulders, hands
    for sx in (-1.0, 1.0):
        v, f = tube([[sx * 0.2, 0, 1.39], [sx * 0.25, 0, 1.12], [sx * 0.285, 0, 0.88]],
                    [[0.052, 0.052], [0.044, 0.044], [0.037, 0.037]], 14, cap_start=False)
        mb.add(v, f, M_NAVY, "spine")
        v, f = ellipsoid([sx * 0.195, 0, 1.395], [0.06, 0.058, 0.055], 14, 8)
        mb.add(v, f, M_NAVY, "spine")
        v, f = ellipsoid([sx * 0.295, 0, 0.83], [0.032, 0.028, 0.055], 12, 8)
        mb.add(v, f, M_SKIN, "spine")
    return mb


def make_materials():
    mats = []
    for name, colour, rough, metal in MATERIALS:
        m = bpy.data.materials.new(name)
        m.use_nodes = True
        bsdf = m.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
        bsdf.inputs["Roughness"].default_value = rough
        bsdf.inputs["Metallic"].default_value = metal
        m.diffuse_color = (*colour, 1.0)
        m.use_backface_culling = name != "headband"  # the band's tails are single sheets
        mats.append(m)
    return mats


def make_armature():
    arm = bpy.data.armatures.new("ninja_rig")
    ob = bpy.data.objects.new("ninja_rig", arm)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    for name, z0, z1, parent in BONES:
        b = arm.edit_bones.new(name)
        b.head, b.tail, b.roll = (0.0, 0.0, z0), (0.0, 0.0, z1), 0.0
        if parent:
            b.parent = arm.edit_bones[parent]
            b.use_connect = True
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in ob.pose.bones:
        pb.rotation_mode = "QUATERNION"
    return ob


# ============================================================================================
# Idle animation


def ease(a, b, t0, t1, t):
    return a + (b - a) * smoothstep((t - t0) / (t1 - t0))


def idle_pose(t):
    """(root z offset, spine pitch, neck yaw, head yaw, head pitch) in metres / radians at
    time ``t`` seconds (0..4, periodic)."""
    breath = math.sin(2 * math.pi * t / 2.0)  # two breaths per loop
    yaw = 0.0  # slow look left, then right, then back (degrees)
    if t < 1.0:
        yaw = ease(0.0, 35.0, 0.35, 1.0, t)
    elif t < 2.2:
        yaw = ease(35.0, -35.0, 1.4, 2.2, t)
    elif t < 3.0:
        yaw = ease(-35.0, 0.0, 2.55, 2.95, t)
    shake = 0.0  # quick head shake: +-25 degrees at 4 Hz for 0.5 s (ends at 0 by construction)
    if 3.0 <= t <= 3.5:
        shake = 25.0 * math.sin(2 * math.pi * 4.0 * (t - 3.0))
    nod = 4.0 * math.sin(2 * math.pi * t / 4.0) ** 2  # a slight look down and back
    return (
        0.004 * breath,
        math.radians(1.5 * breath),
        math.radians(0.3 * yaw),
        math.radians(0.7 * yaw + shake),
        math.radians(nod),
    )


def quat_axis_angle(axis, angle):
    from mathutils import Quaternion

    return Quaternion(axis, angle)


def make_idle(rig):
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start, scene.frame_end = 0, IDLE_FRAMES
    rig.animation_data_create()
    action = bpy.data.actions.new("idle")
    rig.animation_data.action = action
    pb = rig.pose.bones
    for frame in range(IDLE_FRAMES + 1):
        t = (frame % IDLE_FRAMES) / FPS
        dz, pitch, neck_yaw, head_yaw, head_pitch = idle_pose(t)
        # Bones point up (local +Y = world +Z, local X = world X): yaw is about local Y, pitch
        # (nodding) about local X.
        pb["root"].location = (0.0, dz, 0.0)
        pb["spine"].rotation_quaternion = quat_axis_angle((1, 0, 0), pitch)
        pb["neck"].rotation_quaternion = quat_axis_angle((0, 1, 0), neck_yaw)
        pb["head"].rotation_quaternion = quat_axis_angle((0, 1, 0), head_yaw) @ quat_axis_angle(
            (1, 0, 0), head_pitch
        )
        pb["root"].keyframe_insert("location", frame=frame, group="root")
        for name in ("spine", "neck", "head"):
            pb[name].keyframe_insert("rotation_quaternion", frame=frame, group=name)
    action.use_frame_range = True
    action.frame_start, action.frame_end = 0, IDLE_FRAMES
    action.use_cyclic = True
    for fc in _fcurves(rig, action):
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"
    return action


def _fcurves(rig, action):
    """F-curves of the action (Blender 4.4+ slotted actions, or the legacy list)."""
    try:
        from bpy_extras import anim_utils

        bag = anim_utils.action_get_channelbag_for_slot(action, rig.animation_data.action_slot)
        if bag is not None:
            return list(bag.fcurves)
    except (ImportError, AttributeError):
        pass
    return list(getattr(action, "fcurves", []))


# ============================================================================================
# Hair


def fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def ellipsoid_normal(p):
    n = (p - HEAD_C) / HEAD_R ** 2
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def on_surface(p):
    q = (p - HEAD_C) / HEAD_R
    return HEAD_C + q / np.linalg.norm(q, axis=-1, keepdims=True) * HEAD_R


def push_out(strand, margin=0.006):
    """Keep particles 1.. outside the head ellipsoid grown by ``margin``."""
    out = strand.copy()
    for i in range(1, len(out)):
        d = out[i] - HEAD_C
        grown = HEAD_R + margin * (1.0 + i / len(out))
        k = np.linalg.norm(d / grown)
        if k < 1.0:
            out[i] = HEAD_C + d / k
    return out


def make_groom(rng, points=7):
    """Spiky clumps on the scalp above the headband.  Returns ``(S, points, 3)`` (Blender world)."""
    dirs = fibonacci_sphere(520)
    roots = HEAD_C + dirs * HEAD_R
    keep = (roots[:, 2] - HEAD_C[2]) > np.array([band_center_z(y) for y in roots[:, 1] - HEAD_C[1]]) + 0.03
    roots = roots[keep]
    roots = on_surface(roots + rng.normal(scale=0.004, size=roots.shape))
    # Clump seeds: farthest point sampling from the crown.
    k = 17
    seeds = [int(np.argmax(roots[:, 2]))]
    d = np.linalg.norm(roots - roots[seeds[0]], axis=1)
    for _ in range(k - 1):
        seeds.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(roots - roots[seeds[-1]], axis=1))
    seed_pts = roots[seeds]
    clump = np.argmin(np.linalg.norm(roots[:, None] - seed_pts[None], axis=2), axis=1)
    up, back = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    clump_dir, clump_len = [], []
    for c in range(k):
        n = ellipsoid_normal(seed_pts[c])
        front = (seed_pts[c][1] - HEAD_C[1]) < -0.03
        if front:  # fringe spikes: up and forward
            v = n + 0.9 * up - 0.15 * back
        else:  # everything else: out, up and swept back
            v = n + 0.35 * up + 0.8 * back
        v = v + rng.normal(scale=0.15, size=3)
        v /= np.linalg.norm(v)
        if v @ n < 0.35:  # keep spikes pointing away from the head
            v = v + (0.35 - v @ n) * n
            v /= np.linalg.norm(v)
        clump_dir.append(v)
        clump_len.append(rng.uniform(0.12, 0.21) * (0.85 if front else 1.0))
    strands = []
    t = np.linspace(0.0, 1.0, points)[:, None]
    for i, r in enumerate(roots):
        c = clump[i]
        length = clump_len[c] * rng.uniform(0.85, 1.0)
        n = ellipsoid_normal(r)
        tip = seed_pts[c] + clump_dir[c] * length + (r - seed_pts[c]) * 0.3
        tip = tip + rng.normal(scale=0.006, size=3)
        p1 = r + n * 0.35 * length
        p2 = tip - clump_dir[c] * 0.35 * length + back * 0.015
        bez = ((1 - t) ** 3) * r + 3 * ((1 - t) ** 2) * t * p1 + 3 * (1 - t) * t * t * p2 + t ** 3 * tip
        strands.append(push_out(bez))
    return np.array(strands), roots


def restyle(strands, bend, strength):
    """A keyframe style: each segment's direction bent towards ``bend(root, tip_dir)`` more and
    more towards the tip; segment lengths are kept (then particles are pushed out of the head)."""
    out = []
    for s in strands:
        seg = np.diff(s, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        dirs = seg / lengths[:, None]
        target = bend(s[0], dirs[-1])
        w = strength * (np.arange(1, len(s)) / (len(s) - 1.0))[:, None] ** 1.5
        nd = dirs + w * target
        nd /= np.linalg.norm(nd, axis=1, keepdims=True)
        out.append(push_out(np.vstack([s[:1], s[0] + np.cumsum(nd * lengths[:, None], axis=0)])))
    return np.array(out)


def curves_object(name, strands):
    cv = bpy.data.hair_curves.new(name)
    cv.add_curves([len(s) for s in strands])
    cv.points.foreach_set("position", np.asarray(strands, dtype=np.float32).ravel())
    ob = bpy.data.objects.new(name, cv)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def parent_to_bone(ob, rig, bone):
    """Parent ``ob`` to ``bone`` keeping its place in the REST pose."""
    bpy.context.view_layer.update()
    world = ob.matrix_world.copy()
    rig.data.pose_position = "REST"
    ob.parent, ob.parent_type, ob.parent_bone = rig, "BONE", bone
    bpy.context.view_layer.update()
    ob.matrix_world = world
    rig.data.pose_position = "POSE"
    bpy.context.view_layer.update()


# ============================================================================================


COLLISION_SPHERES = [  # name, centre (Blender world), radius
    ("col_0_cranium", (0.0, 0.01, 1.69), 0.10),
    ("col_1_back", (0.0, 0.035, 1.675), 0.085),
    ("col_2_face", (0.0, -0.035, 1.645), 0.08),
    ("col_3_jaw", (0.0, -0.03, 1.595), 0.062),
    ("col_4_neck", (0.0, 0.0, 1.53), 0.055),
]


def export_glb(path):
    """Export the selected rig and body as the bundled characters are: glTF binary, "+Y Up", the
    rest-pose armature, every action sampled, skins and materials, nothing else."""
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        use_selection=True,
        export_yup=True,
        export_apply=False,
        export_animations=True,
        export_animation_mode="ACTIONS",
        export_frame_range=False,
        export_force_sampling=True,
        export_optimize_animation_size=True,
        export_skins=True,
        export_all_influences=False,
        export_def_bones=False,
        export_rest_position_armature=True,
        export_materials="EXPORT",
        export_texcoords=False,
        export_normals=True,
        export_cameras=False,
        export_lights=False,
        export_extras=False,
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(REPO, "assets", "ninja"))
    parser.add_argument("--blend", default=None, help="also save the scene as this .blend")
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(SEED)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"

    # --- character
    rig = make_armature()
    mb = build_character()
    body = bpy.data.objects.new("ninja_body", mb.build("ninja_body"))
    scene.collection.objects.link(body)
    for m in make_materials():
        body.data.materials.append(m)
    groups = {name: body.vertex_groups.new(name=name) for name, *_ in BONES}
    for i, w in enumerate(mb.weights):
        for bone, value in w.items():
            if value > 0.0:
                groups[bone].add([i], value, "REPLACE")
    body.parent = rig
    mod = body.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    make_idle(rig)

    # --- hair: base groom and two keyframe styles, parented to the head bone
    base, _roots = make_groom(rng)
    wind_dir = np.array([0.35, 1.0, 0.1])
    wind_dir /= np.linalg.norm(wind_dir)
    wind = restyle(base, lambda root, tip: wind_dir, 2.2)
    flip = restyle(base, lambda root, tip: np.array([0.0, 0.0, 1.0]) + 0.3 * ellipsoid_normal(root), 2.2)
    styles = [curves_object(name, s) for name, s in
              (("ninja", base), ("ninja_wind", wind), ("ninja_flip", flip))]
    for ob in styles:
        parent_to_bone(ob, rig, "head")
    styles[1].hide_set(True)
    styles[2].hide_set(True)

    # --- collision spheres (empties shown as spheres), parented to the head bone
    spheres = []
    for name, c, r in COLLISION_SPHERES:
        e = bpy.data.objects.new(name, None)
        e.empty_display_type, e.empty_display_size = "SPHERE", r
        e.location = c
        scene.collection.objects.link(e)
        spheres.append(e)
    bpy.context.view_layer.update()
    for e in spheres:
        parent_to_bone(e, rig, "head")
    check_hair(base, wind, flip)

    # --- export
    scene.frame_set(0)
    n = gather.export_hair(os.path.join(out, "ninja.hair.xml"), [styles[0]], rig, "head", 1.0)
    gather.export_hairanim(os.path.join(out, "ninja.hairanim.xml"), styles, rig, "head", 1.0,
                           seconds_per_key=0.8, loop=True)
    ns = gather.export_collision(os.path.join(out, "ninja.collision.xml"), spheres, rig, "head", 1.0)
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (rig, body))
    bpy.context.view_layer.objects.active = rig
    glb = os.path.join(out, "ninja.glb")
    export_glb(glb)
    if args.blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.blend), compress=True)
    lengths = np.linalg.norm(np.diff(base, axis=1), axis=2).sum(axis=1)
    print(f"ninja: {mb.triangles()} triangles, {len(mb.verts)} vertices; glb {os.path.getsize(glb)} bytes")
    print(f"ninja: {n} strands x {base.shape[1]} points, lengths {lengths.min():.3f}..{lengths.max():.3f} m;"
          f" {ns} collision spheres; written to {out}")
    return 0


def check_hair(*styles):
    """Sanity checks of the generated hair: lengths, no particle (but roots) inside a collision
    sphere."""
    base = styles[0]
    lengths = np.linalg.norm(np.diff(base, axis=1), axis=2).sum(axis=1)
    assert 100 <= len(base) <= 200, f"{len(base)} strands"
    assert lengths.min() >= 0.08 and lengths.max() <= 0.25, (lengths.min(), lengths.max())
    for s in styles:
        pts = s[:, 1:].reshape(-1, 3)
        for _, c, r in COLLISION_SPHERES:
            d = np.linalg.norm(pts - np.array(c), axis=1)
            assert d.min() > r, f"hair particle inside collision sphere ({d.min():.4f} < {r})"


if __name__ == "__main__":
    sys.exit(main())
