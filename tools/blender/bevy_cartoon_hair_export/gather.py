# SPDX-License-Identifier: MIT OR Apache-2.0
"""The Blender side of the exporter: reads hair, spheres and bones from ``bpy`` data and writes
the files with :mod:`.writer`.  These functions are what the operators call; scripts can call
them directly::

    from bevy_cartoon_hair_export import gather
    gather.export_hair("out/ninja.hair.xml", [hair_obj], armature=arm, bone="head", scale=1.0)

Positions are taken with the armatures in their REST position (``Armature.pose_position`` is
switched to ``'REST'`` while reading and restored afterwards), so hair parented or skinned to a
posed rig is exported where it sits in the rest pose - the frame of the bone's glTF node.
"""

import contextlib
import os

import bpy
import numpy as np

from . import writer
from .writer import ExportError


# --------------------------------------------------------------------------------------------
# Frames


def _np_matrix(m):
    return np.array([list(row) for row in m], dtype=np.float64)


def frame_matrix(armature=None, bone="", reference=None, depsgraph=None):
    """Global glTF-space matrix of the frame the file's positions are in.

    With an ``armature`` object: the rest frame of the node the glTF exporter writes for
    ``bone`` (see :func:`writer.bone_node_matrix`).  Without: the node frame of ``reference``
    (an object; identity if ``None``), i.e. the object's local space with Y up.
    """
    if armature is not None:
        if armature.type != "ARMATURE":
            raise ExportError(f"'{armature.name}' is not an armature")
        b = armature.data.bones.get(bone)
        if b is None:
            raise ExportError(
                f"armature '{armature.name}' has no bone named '{bone}'"
                f" (bones: {', '.join(sorted(x.name for x in armature.data.bones)) or 'none'})"
            )
        arm = armature.evaluated_get(depsgraph) if depsgraph is not None else armature
        return writer.bone_node_matrix(_np_matrix(arm.matrix_world), _np_matrix(b.matrix_local))
    if reference is None:
        return np.eye(4)
    ref = reference.evaluated_get(depsgraph) if depsgraph is not None else reference
    return writer.object_node_matrix(_np_matrix(ref.matrix_world))


@contextlib.contextmanager
def rest_pose(context=None):
    """Put every armature in its rest position while the block runs; yields a depsgraph."""
    context = context or bpy.context
    changed = []
    for arm in bpy.data.armatures:
        if arm.pose_position != "REST":
            changed.append((arm, arm.pose_position))
            arm.pose_position = "REST"
    try:
        if changed:
            context.view_layer.update()
        yield context.evaluated_depsgraph_get()
    finally:
        for arm, pos in changed:
            arm.pose_position = pos
        if changed:
            context.view_layer.update()


# --------------------------------------------------------------------------------------------
# Hair


def is_hair_object(obj):
    """A Curves object, or a mesh with at least one hair particle system."""
    if obj.type == "CURVES":
        return True
    return obj.type == "MESH" and any(ps.settings.type == "HAIR" for ps in obj.particle_systems)


def object_strands(obj, depsgraph):
    """Strands of one hair object in Blender WORLD space: ``(positions (N,3) float64, counts)``.

    Curves objects give every curve (evaluated geometry, so modifiers apply); meshes give the
    guide hairs (``hair_keys``) of each of their HAIR particle systems, in order (children are
    generated at run time by the plugin, not exported).
    """
    ob = obj.evaluated_get(depsgraph)
    world = _np_matrix(ob.matrix_world)
    if obj.type == "CURVES":
        curves = ob.data
        n_points, n_curves = len(curves.points), len(curves.curves)
        pos = np.empty(n_points * 3, dtype=np.float32)
        if n_points:
            curves.points.foreach_get("position", pos)
        offsets = np.empty(n_curves + 1, dtype=np.int32)
        curves.curve_offset_data.foreach_get("value", offsets)
        counts = np.diff(offsets).astype(np.int64)
        return writer.transform_points(world, pos.reshape(-1, 3)), counts
    if obj.type == "MESH":
        chunks, counts = [], []
        for ps in ob.particle_systems:
            if ps.settings.type != "HAIR":
                continue
            for p in ps.particles:
                keys = p.hair_keys
                k = len(keys)
                buf = np.empty(k * 3, dtype=np.float32)
                if k:
                    keys.foreach_get("co", buf)  # object space of the emitter
                chunks.append(buf)
                counts.append(k)
        if not chunks:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        pos = np.concatenate(chunks).reshape(-1, 3)
        return writer.transform_points(world, pos), np.array(counts, dtype=np.int64)
    raise ExportError(f"'{obj.name}' is not a hair object (Curves or mesh with particle hair)")


def hair_objects(objects):
    """The hair objects among ``objects``, sorted by name."""
    return sorted((o for o in objects if is_hair_object(o)), key=lambda o: o.name)


def groom_data(objects, armature=None, bone="head", scale=1.0, context=None, reference=None):
    """Positions (the file's numbers, multiplied by ``scale``), counts and the bone name written
    to the file, for all strands of ``objects`` (sorted by name, concatenated).

    Without an armature, positions are in the node frame of ``reference`` (default: the active
    object if it is among ``objects``, else the first by name)."""
    objs = hair_objects(objects)
    if not objs:
        raise ExportError("no hair objects selected (Curves hair or meshes with particle hair)")
    if reference is None:
        reference = _reference(objs, context)
    with rest_pose(context) as dg:
        frame = frame_matrix(armature, bone, reference=reference, depsgraph=dg)
        to_frame = writer.blender_to_frame(frame)
        pos_parts, count_parts = [], []
        for o in objs:
            p, c = object_strands(o, dg)
            pos_parts.append(writer.transform_points(to_frame, p))
            count_parts.append(c)
    positions = np.concatenate(pos_parts) * float(scale)
    counts = np.concatenate(count_parts)
    return positions, counts, (bone if armature is not None else "")


def _reference(objs, context):
    """Without an armature, positions are in the node frame of the active object if it is one
    of the exported ones, else of the first (by name)."""
    context = context or bpy.context
    active = getattr(context, "active_object", None)
    return active if active in objs else objs[0]


def frame_scale(armature=None, bone="head", reference=None, context=None):
    """Metres one unit of the file's frame is in Blender (the bone's uniform world scale in the
    rest pose): 0.01 on a Mixamo rig, whose armature object carries that scale."""
    with rest_pose(context) as dg:
        return writer.uniform_scale(
            frame_matrix(armature, bone, reference=reference, depsgraph=dg)
        )


def export_hair(filepath, objects, armature=None, bone="head", scale=1.0, context=None):
    """Write ``objects``' strands to a ``*.hair.xml``.  Returns the number of strands."""
    positions, counts, bone_name = groom_data(objects, armature, bone, scale, context)
    units = frame_scale(armature, bone, _reference(hair_objects(objects), context), context)
    writer.write_text(
        filepath, writer.groom_xml(positions, counts, scale, bone_name, bone_scale=units)
    )
    return len(counts)


# --------------------------------------------------------------------------------------------
# Collision shapes: spheres, capsules, planes


def is_capsule_object(obj):
    """A capsule: any object whose rigid body collision shape is Capsule (Physics > Rigid Body >
    Collisions > Shape), sized as Blender sizes it: along the local Z axis, radius half the
    larger of the X and Y extents."""
    rb = getattr(obj, "rigid_body", None)
    return rb is not None and rb.collision_shape == "CAPSULE"


def _mesh_points(obj, depsgraph):
    """World-space vertices of mesh ``obj`` (modifiers applied)."""
    ob = obj.evaluated_get(depsgraph)
    world = _np_matrix(ob.matrix_world)
    mesh = ob.to_mesh()
    try:
        co = np.zeros(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", co)
    finally:
        ob.to_mesh_clear()
    return writer.transform_points(world, co.reshape(-1, 3)), co.reshape(-1, 3)


def _flat_axis(obj, depsgraph):
    """The local axis (0, 1 or 2) along which mesh ``obj`` has no thickness (a plane), or
    ``None``."""
    if obj.type != "MESH":
        return None
    _, local = _mesh_points(obj, depsgraph)
    if len(local) < 3:
        return None
    ext = local.max(axis=0) - local.min(axis=0)
    axis = int(np.argmin(ext))
    return axis if ext[axis] <= 1e-6 * max(float(ext.max()), 1e-9) else None


def collision_kind(obj, depsgraph=None):
    """``"capsule"``, ``"plane"``, ``"sphere"`` or ``None`` (not a collision object)."""
    if is_capsule_object(obj):
        return "capsule"
    if obj.type == "EMPTY" and obj.empty_display_type == "SPHERE":
        return "sphere"
    if obj.type == "MESH":
        dg = depsgraph or bpy.context.evaluated_depsgraph_get()
        return "plane" if _flat_axis(obj, dg) is not None else "sphere"
    return None


def is_collision_object(obj):
    """Whether ``obj`` can be exported as a collision shape (sphere, capsule or plane)."""
    return is_capsule_object(obj) or obj.type == "MESH" or (
        obj.type == "EMPTY" and obj.empty_display_type == "SPHERE")


def check_sphere_mesh(obj, depsgraph, tolerance=0.1):
    """Raise :class:`ExportError` unless mesh ``obj`` is (close to) a sphere in world space: its
    vertices all lie within ``tolerance`` (relative) of one radius around the box centre, and the
    box is as wide as that sphere on every axis.  A body,
    a cube or a stretched ellipsoid is refused, not silently turned into its bounding sphere."""
    pts, _ = _mesh_points(obj, depsgraph)
    if len(pts) < 4:
        raise ExportError(f"'{obj.name}' has {len(pts)} vertices; a collision sphere needs a "
                          "sphere mesh (UV or ico sphere) or an empty shown as a sphere")
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    dist = np.linalg.norm(pts - (lo + hi) / 2.0, axis=1)
    r = float(dist.max())
    ext = hi - lo
    # On a sphere every vertex is one radius from the centre AND the box is the sphere's: a
    # cube's corners are equidistant too, but its box is narrower than twice their distance.
    if r <= 0.0 or float(dist.min()) < (1.0 - tolerance) * r or ext.min() < 2.0 * r * (1.0 - tolerance):
        raise ExportError(
            f"'{obj.name}' is not a sphere (world size {ext[0]:.3g} x {ext[1]:.3g} x "
            f"{ext[2]:.3g} m, vertices {dist.min():.3g} to {r:.3g} m from its centre); collision "
            "files hold spheres, capsules (an object whose rigid body shape is Capsule) and "
            "planes (a flat mesh): select only those"
        )


def object_sphere(obj, depsgraph):
    """``(centre (3,), radius)`` of a sphere object in Blender world space.

    Mesh: the centre of its bounding box, radius half the largest world-space extent of the box
    (local extent times the world length of that axis).  Empty: its origin, radius
    ``empty_display_size`` times the largest world scale."""
    ob = obj.evaluated_get(depsgraph)
    world = _np_matrix(ob.matrix_world)
    axis_scale = np.linalg.norm(world[:3, :3], axis=0)
    if obj.type == "EMPTY":
        return world[:3, 3].copy(), float(obj.empty_display_size * axis_scale.max())
    box = np.array([tuple(c) for c in ob.bound_box], dtype=np.float64)
    lo, hi = box.min(axis=0), box.max(axis=0)
    centre = writer.transform_points(world, ((lo + hi) / 2.0)[None, :])[0]
    return centre, float(((hi - lo) * axis_scale).max() / 2.0)


def object_capsule(obj, depsgraph):
    """``(a (3,), b (3,), radius)`` of a capsule object in Blender world space: its bounding
    box's centre, the local Z axis, radius half the larger world X or Y extent, ends inset by the
    radius from the box's Z faces (Blender's own capsule for the box).  An empty's box is its
    display size."""
    ob = obj.evaluated_get(depsgraph)
    world = _np_matrix(ob.matrix_world)
    axis_scale = np.linalg.norm(world[:3, :3], axis=0)
    if obj.type == "EMPTY":
        s = float(obj.empty_display_size)
        lo, hi = np.full(3, -s), np.full(3, s)
    else:
        box = np.array([tuple(c) for c in ob.bound_box], dtype=np.float64)
        lo, hi = box.min(axis=0), box.max(axis=0)
    ext = (hi - lo) * axis_scale
    radius = float(max(ext[0], ext[1]) / 2.0)
    half = max(float(ext[2]) / 2.0 - radius, 0.0)
    centre = writer.transform_points(world, ((lo + hi) / 2.0)[None, :])[0]
    z = world[:3, 2] / max(float(axis_scale[2]), 1e-12)
    if radius <= 0.0:
        raise ExportError(f"capsule '{obj.name}' has no width (radius 0)")
    return centre - z * half, centre + z * half, radius


def object_plane(obj, depsgraph):
    """``(point (3,), normal (3,))`` of a flat mesh in Blender world space: its bounding box's
    centre and the normal of its flat local axis (the side it points to is the free side)."""
    axis = _flat_axis(obj, depsgraph)
    ob = obj.evaluated_get(depsgraph)
    world = _np_matrix(ob.matrix_world)
    box = np.array([tuple(c) for c in ob.bound_box], dtype=np.float64)
    lo, hi = box.min(axis=0), box.max(axis=0)
    centre = writer.transform_points(world, ((lo + hi) / 2.0)[None, :])[0]
    local = np.zeros(3)
    local[axis] = 1.0
    # Normals go by the inverse transpose.
    n = np.linalg.inv(world[:3, :3]).T @ local
    return centre, n / np.linalg.norm(n)


def collision_data(objects, armature=None, bone="head", scale=1.0, context=None):
    """The shapes of ``objects`` in the bone's frame, times ``scale``:
    ``(centres, radii, bone_name, capsules, planes)``."""
    objs = sorted((o for o in objects if is_collision_object(o)), key=lambda o: o.name)
    if not objs:
        raise ExportError("no sphere objects selected (sphere meshes or empties shown as spheres, "
                          "capsule rigid bodies, flat meshes for planes)")
    with rest_pose(context) as dg:
        ref = _reference(objs, context)
        frame = frame_matrix(armature, bone, reference=ref, depsgraph=dg)
        to_frame = writer.blender_to_frame(frame)
        kinds = [collision_kind(o, dg) for o in objs]
        for o, k in zip(objs, kinds):
            if k == "sphere" and o.type == "MESH":
                check_sphere_mesh(o, dg)
        spheres = [object_sphere(o, dg) for o, k in zip(objs, kinds) if k == "sphere"]
        capsules = [object_capsule(o, dg) for o, k in zip(objs, kinds) if k == "capsule"]
        planes = [object_plane(o, dg) for o, k in zip(objs, kinds) if k == "plane"]
    s = float(scale)
    # A radius in the frame: world radius over the frame's (uniform) scale.
    unit = writer.uniform_scale(frame)
    centres = writer.transform_points(to_frame, np.array([c for c, _ in spheres]).reshape(-1, 3))
    radii = np.array([r for _, r in spheres], dtype=np.float64) / unit
    caps = [
        (writer.transform_points(to_frame, a[None, :])[0] * s,
         writer.transform_points(to_frame, b[None, :])[0] * s, r / unit * s)
        for a, b, r in capsules
    ]
    # Directions: the rotation part of the frame change (it is rigid but for a uniform scale).
    rot = to_frame[:3, :3]
    pls = [
        (writer.transform_points(to_frame, p[None, :])[0] * s,
         np.linalg.inv(rot).T @ n / np.linalg.norm(np.linalg.inv(rot).T @ n))
        for p, n in planes
    ]
    return centres * s, radii * s, (bone if armature is not None else ""), caps, pls


def export_collision(filepath, objects, armature=None, bone="head", scale=1.0, context=None):
    """Write the collision shapes among ``objects`` (sphere meshes and empties, capsule rigid
    bodies, flat meshes as planes) to a ``*.collision.xml``.  Returns the number of shapes."""
    centres, radii, bone_name, capsules, planes = collision_data(
        objects, armature, bone, scale, context)
    objs = sorted((o for o in objects if is_collision_object(o)), key=lambda o: o.name)
    units = frame_scale(armature, bone, _reference(objs, context), context)
    writer.write_text(
        filepath,
        writer.collision_xml(centres, radii, scale, bone_name, bone_scale=units,
                             capsules=capsules, planes=planes),
    )
    return len(radii) + len(capsules) + len(planes)


# --------------------------------------------------------------------------------------------
# Hair animation


def style_file_names(objects):
    """One ``<object name>.hair.xml`` per style (names cleaned for file systems, made unique)."""
    names, seen = [], set()
    for o in objects:
        base = bpy.path.clean_name(o.name) or "style"
        name, i = base, 1
        while name.lower() in seen:
            i += 1
            name = f"{base}_{i}"
        seen.add(name.lower())
        names.append(name + ".hair.xml")
    return names


def export_hairanim(
    filepath,
    styles,
    armature=None,
    bone="head",
    scale=1.0,
    seconds_per_key=1.0,
    loop=True,
    context=None,
):
    """Write a ``*.hairanim.xml`` and one ``*.hair.xml`` per style next to it.

    ``styles``: hair objects, in key order (the first is the base).  Key ``i`` is at
    ``i * seconds_per_key``; the loop period is ``len(styles) * seconds_per_key``.  Every style
    must have the same strand and particle counts (checked before anything is written).
    Without an armature all styles are written in the node frame of the first style.
    Returns the groom file paths written.
    """
    styles = list(styles)
    if not styles:
        raise ExportError("no hair styles: select hair objects or choose a collection")
    for o in styles:
        if not is_hair_object(o):
            raise ExportError(f"'{o.name}' is not a hair object")
    if not seconds_per_key > 0.0:
        raise ExportError("seconds per key must be > 0")
    data = []
    for o in styles:
        positions, counts, bone_name = groom_data(
            [o], armature, bone, scale, context, reference=styles[0]
        )
        data.append((o.name, positions, counts))
    writer.check_same_topology([(name, counts) for name, _, counts in data])
    units = frame_scale(armature, bone, styles[0], context)
    texts = [writer.groom_xml(p, c, scale, bone_name, bone_scale=units) for _, p, c in data]
    directory = os.path.dirname(os.path.abspath(filepath))
    names = style_file_names(styles)
    keys = [(i * seconds_per_key, n) for i, n in enumerate(names)]
    anim = writer.hairanim_xml(keys, loop=loop, duration=len(styles) * seconds_per_key)
    paths = []
    for n, text in zip(names, texts):
        path = os.path.join(directory, n)
        writer.write_text(path, text)
        paths.append(path)
    writer.write_text(filepath, anim)
    return paths
