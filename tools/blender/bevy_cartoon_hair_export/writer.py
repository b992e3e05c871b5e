# SPDX-License-Identifier: MIT OR Apache-2.0
"""Pure-Python (numpy) part of the exporter: coordinate frames, validation and XML text.

Nothing here imports ``bpy``, so scripts and tests can use it without Blender::

    from bevy_cartoon_hair_export import writer

The formats are specified in ``docs/formats.md``.  Conventions used throughout:

* ``positions``: ``(N, 3)`` float array of all particles of all strands, strand after strand,
  root first.
* ``counts``: ``(S,)`` int array, particles per strand (``counts.sum() == N``).
* Matrices are 4x4 numpy arrays acting on column vectors (``m @ [x, y, z, 1]``), like
  ``mathutils.Matrix``.
"""

import math
import os
import tempfile

import numpy as np

FORMAT_VERSION = 1

#: Blender Z-up -> glTF/Bevy Y-up: ``(x, y, z) -> (x, z, -y)``.  The same matrix Blender's glTF
#: exporter calls ``axis_basis_change`` when "+Y Up" is on.
Y_UP = np.array(
    [[1.0, 0.0, 0.0, 0.0],
     [0.0, 0.0, 1.0, 0.0],
     [0.0, -1.0, 0.0, 0.0],
     [0.0, 0.0, 0.0, 1.0]]
)

# Limits from docs/formats.md.
MAX_STRANDS = 1_000_000
MIN_PARTICLES, MAX_PARTICLES = 2, 256
MAX_GROOM_PARTICLES = 2_000_000
MIN_SEGMENT = 1e-6
MAX_SHAPES = 4096
MAX_KEYS = 256


class ExportError(ValueError):
    """An input that cannot be exported; the message is meant for the user."""


# --------------------------------------------------------------------------------------------
# Frames


def bone_node_matrix(armature_world, bone_matrix_local):
    """Global rest matrix, in glTF space, of the node Blender's glTF exporter writes for a bone.

    ``armature_world`` is the armature object's ``matrix_world`` and ``bone_matrix_local`` the
    bone's ``Bone.matrix_local`` (its rest matrix in armature space), both in Blender space.

    The exporter (``io_scene_gltf2``, "+Y Up") gives the bone node the Blender-space world matrix
    ``A @ B @ Y_UP`` and writes every node's local TRS conjugated by ``Y_UP``, so the composed
    glTF global matrix is ``Y_UP @ (A @ B @ Y_UP) @ Y_UP^-1 = Y_UP @ A @ B``: the bone keeps
    Blender's bone axes (+Y along the bone), seen from the Y-up world.
    Verified against exported .glb files by ``tests/test_export.py``.
    """
    return Y_UP @ np.asarray(armature_world, dtype=np.float64) @ np.asarray(
        bone_matrix_local, dtype=np.float64
    )


def object_node_matrix(object_world):
    """Global matrix, in glTF space, of the node the glTF exporter writes for an object.

    Objects are written as ``Y_UP @ M @ Y_UP^-1``; the node's local frame is the object's local
    frame with axes converted to Y-up.
    """
    m = np.asarray(object_world, dtype=np.float64)
    return Y_UP @ m @ np.linalg.inv(Y_UP)


def blender_to_frame(frame_matrix):
    """Matrix taking Blender world-space points into the frame whose glTF global matrix is
    ``frame_matrix`` (the file's coordinates before multiplying by ``scale``)."""
    return np.linalg.inv(np.asarray(frame_matrix, dtype=np.float64)) @ Y_UP


def transform_points(matrix, points):
    """Apply a 4x4 matrix to ``(N, 3)`` points; returns float64 ``(N, 3)``."""
    m = np.asarray(matrix, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return p @ m[:3, :3].T + m[:3, 3]


def uniform_scale(matrix):
    """Mean linear scale of a 4x4 matrix (cube root of the 3x3 determinant's magnitude)."""
    det = abs(float(np.linalg.det(np.asarray(matrix, dtype=np.float64)[:3, :3])))
    return det ** (1.0 / 3.0) if det > 0.0 else 1.0


# --------------------------------------------------------------------------------------------
# Validation


def _check_scale(scale):
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0.0):
        raise ExportError(f"scale must be finite and > 0, got {scale!r}")


def check_groom(positions, counts, scale=1.0):
    """Raise :class:`ExportError` if the strands break a rule of docs/formats.md.

    ``positions`` are the file's numbers (already multiplied by ``scale``)."""
    _check_scale(scale)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64).reshape(-1)
    n = len(counts)
    if n == 0:
        raise ExportError("no hair strands to export (select Curves hair or particle hair objects)")
    if n > MAX_STRANDS:
        raise ExportError(f"{n} strands; a groom may have at most {MAX_STRANDS}")
    if int(counts.sum()) != len(positions):
        raise ExportError(f"internal error: {len(positions)} points but counts sum to {counts.sum()}")
    if len(positions) > MAX_GROOM_PARTICLES:
        raise ExportError(f"{len(positions)} particles; a groom may have at most {MAX_GROOM_PARTICLES}")
    bad = np.flatnonzero((counts < MIN_PARTICLES) | (counts > MAX_PARTICLES))
    if len(bad):
        i = int(bad[0])
        raise ExportError(
            f"strand {i} has {counts[i]} particles; strands need {MIN_PARTICLES}..={MAX_PARTICLES}"
            f" ({len(bad)} strand(s) out of range)"
        )
    finite = np.isfinite(positions).all(axis=1)
    if not finite.all():
        p = int(np.flatnonzero(~finite)[0])
        s, k = _locate(counts, p)
        raise ExportError(f"strand {s}, particle {k}: coordinate is not finite")
    # Segment lengths, in metres (the loader divides by scale), skipping strand boundaries.
    seg = np.linalg.norm(np.diff(positions, axis=0), axis=1) / scale
    starts = np.cumsum(counts)[:-1] - 1  # index of the segment crossing into the next strand
    ok = seg > MIN_SEGMENT
    ok[starts] = True
    if not ok.all():
        p = int(np.flatnonzero(~ok)[0])
        s, k = _locate(counts, p)
        raise ExportError(
            f"strand {s}: segment {k}-{k + 1} is {seg[p]:.3g} m long (zero-length segments are"
            " not allowed)"
        )


def _locate(counts, point_index):
    offsets = np.concatenate(([0], np.cumsum(counts)))
    s = int(np.searchsorted(offsets, point_index, side="right") - 1)
    return s, int(point_index - offsets[s])


def check_same_topology(styles):
    """``styles``: list of ``(name, counts)``.  Raise :class:`ExportError` unless every style has
    the same number of strands and particles per strand as the first."""
    if not styles:
        raise ExportError("no hair styles to export")
    base_name, base = styles[0]
    base = np.asarray(base)
    for name, counts in styles[1:]:
        counts = np.asarray(counts)
        if len(counts) != len(base):
            raise ExportError(
                f"hair style '{name}' has {len(counts)} strands but the base style '{base_name}'"
                f" has {len(base)}; all styles must be derived from the same base groom"
            )
        diff = np.flatnonzero(counts != base)
        if len(diff):
            i = int(diff[0])
            raise ExportError(
                f"hair style '{name}', strand {i}: {counts[i]} particles but the base style"
                f" '{base_name}' has {base[i]}; all styles must be derived from the same base"
                " groom"
            )


# --------------------------------------------------------------------------------------------
# XML text


def _attr(value):
    return (
        str(value)
        .replace("&", "&amp;")
        .replace('"', "&quot;")
        .replace("<", "&lt;")
        .replace(">", "&gt;")
    )


def fmt_float(x):
    """A float with 9 significant digits (round-trips float32; exact to ~1e-9 relative)."""
    s = "%.9g" % x
    return "0" if s == "-0" else s


def units_attributes(bone_scale=1.0):
    """``units``: ``meters`` when one unit of the bone's frame is a metre in Blender; on a scaled
    rig (Mixamo's armature carries 0.01) the numbers are in the bone's own units, so the file says
    ``units="bone"`` and ``bone_scale``, the metres one unit was in Blender.  The game scales the
    hair by the bone's world scale, so either way it comes out as it looked in Blender."""
    bone_scale = float(bone_scale)
    if not (np.isfinite(bone_scale) and bone_scale > 0.0):
        raise ExportError(f"the bone's frame has scale {bone_scale}; it must be finite and > 0")
    if abs(bone_scale - 1.0) <= 1e-6:
        return 'units="meters"'
    return f'units="bone" bone_scale="{fmt_float(bone_scale)}"'


def _header(root, scale, bone, bone_scale=1.0):
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n'
        f'<{root} version="{FORMAT_VERSION}" {units_attributes(bone_scale)}'
        f' scale="{fmt_float(scale)}" bone="{_attr(bone)}">\n'
    )


def groom_xml(positions, counts, scale=1.0, bone="", check=True, bone_scale=1.0):
    """The text of a ``*.hair.xml`` file.

    ``positions`` are the file's numbers, already multiplied by ``scale``.  Formatting is
    vectorised per strand length (one ``%`` per strand), about 0.5 s per million particles.
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64).reshape(-1)
    if check:
        check_groom(positions, counts, scale)
    flat = (positions.ravel() + 0.0).tolist()  # + 0.0: a copy, and -0.0 becomes 0.0
    formats = {}
    parts = [_header("groom", scale, bone, bone_scale)]
    append = parts.append
    off = 0
    for c in counts.tolist():
        f = formats.get(c)
        if f is None:
            f = formats[c] = "  <strand>" + "  ".join(["%.9g %.9g %.9g"] * c) + "</strand>\n"
        n = 3 * c
        append(f % tuple(flat[off:off + n]))
        off += n
    append("</groom>\n")
    return "".join(parts)


def collision_xml(centers, radii, scale=1.0, bone="", bone_scale=1.0, capsules=(), planes=()):
    """The text of a ``*.collision.xml`` file; ``centers``/``radii`` (spheres) and the points
    and radii of ``capsules`` (``(a (3,), b (3,), radius)``) and ``planes`` (``(point (3,),
    normal (3,))``) already multiplied by ``scale`` (normals are directions: not scaled)."""
    _check_scale(scale)
    centers = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    radii = np.asarray(radii, dtype=np.float64).reshape(-1)
    capsules = [(np.asarray(a, dtype=np.float64).reshape(3), np.asarray(b, dtype=np.float64).reshape(3),
                 float(r)) for a, b, r in capsules]
    planes = [(np.asarray(p, dtype=np.float64).reshape(3), np.asarray(n, dtype=np.float64).reshape(3))
              for p, n in planes]
    total = len(centers) + len(capsules) + len(planes)
    if total == 0:
        raise ExportError("no collision shapes to export (select sphere meshes, sphere empties, "
                          "capsule rigid bodies or planes)")
    if total > MAX_SHAPES:
        raise ExportError(f"{total} shapes; a collision file may have at most {MAX_SHAPES}")
    if len(radii) != len(centers):
        raise ExportError("internal error: one radius per sphere needed")
    if not (np.isfinite(centers).all() and np.isfinite(radii).all()):
        raise ExportError("a sphere has a non-finite centre or radius")
    if (radii <= 0.0).any():
        i = int(np.flatnonzero(radii <= 0.0)[0])
        raise ExportError(f"sphere {i} has radius {radii[i]}; radii must be > 0")
    for i, (a, b, r) in enumerate(capsules):
        if not (np.isfinite(a).all() and np.isfinite(b).all() and math.isfinite(r)):
            raise ExportError(f"capsule {i} has a non-finite end or radius")
        if r <= 0.0:
            raise ExportError(f"capsule {i} has radius {r}; radii must be > 0")
    for i, (pt, n) in enumerate(planes):
        if not (np.isfinite(pt).all() and np.isfinite(n).all()) or np.linalg.norm(n) <= 1e-9:
            raise ExportError(f"plane {i} has a non-finite point or a zero normal")
    parts = [_header("collision", scale, bone, bone_scale)]
    for (x, y, z), r in zip(centers.tolist(), radii.tolist()):
        parts.append(
            f'  <sphere x="{fmt_float(x)}" y="{fmt_float(y)}" z="{fmt_float(z)}"'
            f' r="{fmt_float(r)}"/>\n'
        )
    for a, b, r in capsules:
        parts.append(
            "  <capsule "
            + " ".join(f'{k}="{fmt_float(v)}"' for k, v in zip(("x0", "y0", "z0"), a.tolist()))
            + " "
            + " ".join(f'{k}="{fmt_float(v)}"' for k, v in zip(("x1", "y1", "z1"), b.tolist()))
            + f' r="{fmt_float(r)}"/>\n'
        )
    for pt, n in planes:
        n = n / np.linalg.norm(n)
        parts.append(
            "  <plane "
            + " ".join(f'{k}="{fmt_float(v)}"' for k, v in zip("xyz", pt.tolist()))
            + " "
            + " ".join(f'{k}="{fmt_float(v)}"' for k, v in zip(("nx", "ny", "nz"), n.tolist()))
            + "/>\n"
        )
    parts.append("</collision>\n")
    return "".join(parts)


def hairanim_xml(keys, loop=True, duration=None):
    """The text of a ``*.hairanim.xml`` file.  ``keys``: list of ``(time_seconds, groom_path)``
    with paths relative to the .hairanim.xml (forward slashes)."""
    if not keys:
        raise ExportError("a hair animation needs at least one key")
    if len(keys) > MAX_KEYS:
        raise ExportError(f"{len(keys)} keys; a hair animation may have at most {MAX_KEYS}")
    times = [float(t) for t, _ in keys]
    if not all(math.isfinite(t) and t >= 0.0 for t in times):
        raise ExportError("key times must be finite and >= 0")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise ExportError("key times must be strictly increasing")
    attrs = f'version="{FORMAT_VERSION}" loop="{"true" if loop else "false"}"'
    if duration is not None:
        duration = float(duration)
        if not (math.isfinite(duration) and duration > times[-1]):
            raise ExportError(
                f"duration {duration} must be greater than the last key's time {times[-1]}"
            )
        attrs += f' duration="{fmt_float(duration)}"'
    parts = ['<?xml version="1.0" encoding="utf-8"?>\n', f"<hairanim {attrs}>\n"]
    for t, path in keys:
        parts.append(f'  <key time="{fmt_float(t)}" groom="{_attr(path)}"/>\n')
    parts.append("</hairanim>\n")
    return "".join(parts)


def write_text(path, text):
    """Write ``text`` (UTF-8, ``\\n`` line ends) atomically: to a temporary file, then rename."""
    path = os.path.abspath(path)
    directory = os.path.dirname(path)
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".xml", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual mode
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


# --------------------------------------------------------------------------------------------
# Reading back (tests, tools)


def read_groom(path):
    """Parse a ``*.hair.xml``: returns ``(positions (N,3), counts (S,), scale, bone)`` with the
    file's numbers (not divided by scale)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    if root.tag != "groom" or root.get("version") != "1":
        raise ValueError(f"{path}: not a version 1 groom")
    strands = [np.array((s.text or "").split(), dtype=np.float64) for s in root.iter("strand")]
    counts = np.array([len(s) // 3 for s in strands], dtype=np.int64)
    positions = np.concatenate(strands).reshape(-1, 3) if strands else np.zeros((0, 3))
    return positions, counts, float(root.get("scale", "1")), root.get("bone", "")
