"""Writes the modelled-hair test character as VRM files: the glTF that author_chain_hair.py
exported from Blender, with VRM spring-bone extension JSON added.

    python3 tools/blender/write_vrm_fixtures.py [assets/chain_hair]

writes, next to chain_hair.glb:

- chain_hair.vrm: VRM 1.0 (VRMC_springBone with VRMC_springBone_extended_collider, and a
  minimal VRMC_vrm meta). Each chain's leaf bone gets an `_end` child node, as VRM exporters add,
  so every modelled bone turns (the last joint of a VRM 1.0 spring is only a tail).
- chain_hair_vrm0.vrm: VRM 0.x (`extensions.VRM.secondaryAnimation`), collider offsets written in
  Unity's left-handed space (z negated), as UniVRM 0.x writes them.

Both describe the same colliders: five head spheres (the ninja's head collision), a neck capsule
(a string of spheres in VRM 0.x, which has only spheres), a capsule across the shoulders and, in
VRM 1.0, a plane behind the neck that only the ponytail collides with.

Each file carries the character's thumbnail as a texture, as VRM exporters write it (its meta
names it): JPEG in the VRM 1.0 file, PNG in the VRM 0.x file, both rendered by
render_vrm_thumbnail.py. A game's Bevy build must decode both to load the files at all.

The binary chunk (meshes, skin, animation) is the glb's, copied as is, with the thumbnail's bytes
appended.
"""

import json
import os
import struct
import sys

# Head collision spheres in the head bone's space (assets/ninja/ninja.collision.xml).
HEAD_SPHERES = [
    ((0.0, 0.09, -0.01), 0.1),
    ((0.0, 0.075, -0.035), 0.085),
    ((0.0, 0.045, 0.035), 0.08),
    ((0.0, -0.005, 0.03), 0.062),
    ((0.0, -0.07, 0.0), 0.055),
]
# Neck: a capsule up the neck bone; shoulders: a capsule across the top of the spine bone.
NECK = ((0.0, 0.0, 0.0), (0.0, 0.16, 0.0), 0.055)
SHOULDERS = ((-0.17, 0.44, -0.01), (0.17, 0.44, -0.01), 0.07)
# A plane behind the neck (spine space), for the ponytail only: it stays behind it (normal
# toward -z) instead of swinging through the neck.
BACK_PLANE = ((0.0, 0.5, -0.09), (0.0, 0.0, -1.0))

# (spring name, chain roots, joint parameters per joint from the root, groups)
SPRINGS = [
    ("bangs", ["hair_bang_%d_0" % i for i in range(5)],
     dict(stiffness=1.5, gravityPower=0.05, dragForce=0.4, hitRadius=0.008), ["head"]),
    ("sides", ["hair_side_L_0", "hair_side_R_0"],
     dict(stiffness=0.8, gravityPower=0.2, dragForce=0.4, hitRadius=0.01), ["head", "body"]),
    ("back", ["hair_back_%d_0" % i for i in range(5)],
     dict(stiffness=1.0, gravityPower=0.2, dragForce=0.4, hitRadius=0.012), ["head", "body"]),
    ("tail", ["hair_tail_0"],
     dict(stiffness=0.6, gravityPower=0.3, dragForce=0.3, hitRadius=0.015), ["head", "body", "back"]),
]


def read_glb(path):
    with open(path, "rb") as f:
        data = f.read()
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2 or length != len(data):
        raise SystemExit("%s: not a binary glTF 2.0 file" % path)
    json_len, json_type = struct.unpack_from("<II", data, 12)
    if json_type != 0x4E4F534A:
        raise SystemExit("%s: the first chunk is not JSON" % path)
    doc = json.loads(data[20:20 + json_len])
    rest = data[20 + json_len:]
    return doc, rest


def write_glb(path, doc, rest):
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    header = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + len(rest))
    with open(path, "wb") as f:
        f.write(header + struct.pack("<II", len(text), 0x4E4F534A) + text + rest)


def add_thumbnail(doc, rest, path, mime):
    """Appends the image at `path` to the binary chunk as a texture; returns (image index,
    texture index, the new binary chunk)."""
    length, kind = struct.unpack_from("<II", rest, 0)
    data = rest[8:8 + length]
    with open(path, "rb") as f:
        image = f.read()
    offset = len(data)
    data += image + b"\0" * (-len(image) % 4)
    doc["buffers"][0]["byteLength"] = len(data)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": offset, "byteLength": len(image)})
    doc.setdefault("images", []).append(
        {"name": "thumbnail", "bufferView": len(doc["bufferViews"]) - 1, "mimeType": mime})
    doc.setdefault("samplers", []).append({"magFilter": 9729, "minFilter": 9729})
    doc.setdefault("textures", []).append(
        {"source": len(doc["images"]) - 1, "sampler": len(doc["samplers"]) - 1})
    return len(doc["images"]) - 1, len(doc["textures"]) - 1, struct.pack("<II", len(data), kind) + data


def node_index(doc):
    return {n.get("name"): i for i, n in enumerate(doc["nodes"])}


def chain(doc, root):
    """The joints from `root` down its first children, as node indices."""
    by_name = node_index(doc)
    out = [by_name[root]]
    while doc["nodes"][out[-1]].get("children"):
        out.append(doc["nodes"][out[-1]]["children"][0])
    return out


def add_end(doc, leaf):
    """An empty child past `leaf`, along its bone, as VRM exporters add; returns its index."""
    t = doc["nodes"][leaf].get("translation", [0.0, 0.05, 0.0])
    length = max(sum(c * c for c in t) ** 0.5, 1e-6)
    end = {"name": doc["nodes"][leaf]["name"] + "_end",
           "translation": [c / length * 0.04 for c in t]}
    doc["nodes"].append(end)
    doc["nodes"][leaf].setdefault("children", []).append(len(doc["nodes"]) - 1)
    return len(doc["nodes"]) - 1


def vrm1(doc, thumbnail):
    ids = node_index(doc)
    head, neck, spine = ids["head"], ids["neck"], ids["spine"]
    colliders = [{"node": head, "shape": {"sphere": {"offset": list(c), "radius": r}}}
                 for c, r in HEAD_SPHERES]
    colliders.append({"node": neck, "shape": {"capsule": {
        "offset": list(NECK[0]), "tail": list(NECK[1]), "radius": NECK[2]}}})
    colliders.append({"node": spine, "shape": {"capsule": {
        "offset": list(SHOULDERS[0]), "tail": list(SHOULDERS[1]), "radius": SHOULDERS[2]}}})
    point, normal = BACK_PLANE
    colliders.append({
        "node": spine,
        # The fallback for readers without the extension: a huge sphere behind the plane.
        "shape": {"sphere": {"offset": [point[0], point[1], point[2] + 1000.0], "radius": 1000.0}},
        "extensions": {"VRMC_springBone_extended_collider": {
            "specVersion": "1.0", "shape": {"plane": {"offset": list(point), "normal": list(normal)}}}},
    })
    groups = [{"name": "head", "colliders": list(range(5))},
              {"name": "body", "colliders": [5, 6]},
              {"name": "back", "colliders": [7]}]
    group_index = {g["name"]: i for i, g in enumerate(groups)}
    springs = []
    for name, roots, params, group_names in SPRINGS:
        for root in roots:
            joints = chain(doc, root)
            joints.append(add_end(doc, joints[-1]))
            n = len(joints)
            spec = []
            for k, node in enumerate(joints):
                joint = {"node": node}
                if k < n - 1:
                    joint.update(params)
                    joint["gravityDir"] = [0.0, -1.0, 0.0]
                    # Stiffer at the root, looser toward the tip, as authors tune long hair.
                    joint["stiffness"] = round(params["stiffness"] * (1.0 - 0.4 * k / max(n - 2, 1)), 4)
                spec.append(joint)
            springs.append({"name": root, "joints": spec, "center": head,
                            "colliderGroups": [group_index[g] for g in group_names]})
    doc.setdefault("extensions", {})["VRMC_springBone"] = {
        "specVersion": "1.0", "colliders": colliders, "colliderGroups": groups, "springs": springs}
    doc["extensions"]["VRMC_vrm"] = {
        "specVersion": "1.0",
        "meta": {"name": "chain_hair", "version": "1", "authors": ["bevy_cartoon_hair"],
                 "licenseUrl": "https://vrm.dev/licenses/1.0/", "thumbnailImage": thumbnail},
        "humanoid": {"humanBones": {"hips": {"node": ids["root"]}, "spine": {"node": spine},
                                    "neck": {"node": neck}, "head": {"node": head}}},
    }
    used = doc.setdefault("extensionsUsed", [])
    used += [e for e in ("VRMC_vrm", "VRMC_springBone", "VRMC_springBone_extended_collider")
             if e not in used]
    return doc


def unity(v):
    """glTF -> the Unity space VRM 0.x writes collider offsets in."""
    return {"x": v[0], "y": v[1], "z": -v[2]}


def vrm0(doc, thumbnail):
    ids = node_index(doc)
    head, neck, spine = ids["head"], ids["neck"], ids["spine"]
    (a, b, r) = NECK
    neck_spheres = [[a[i] + (b[i] - a[i]) * t / 3.0 for i in range(3)] for t in range(4)]
    (sa, sb, sr) = SHOULDERS
    shoulder_spheres = [[sa[i] + (sb[i] - sa[i]) * t / 4.0 for i in range(3)] for t in range(5)]
    collider_groups = [
        {"node": head, "colliders": [{"offset": unity(c), "radius": rad} for c, rad in HEAD_SPHERES]},
        {"node": neck, "colliders": [{"offset": unity(c), "radius": r} for c in neck_spheres]},
        {"node": spine, "colliders": [{"offset": unity(c), "radius": sr} for c in shoulder_spheres]},
    ]
    group_of = {"head": [0], "body": [1, 2]}
    bone_groups = []
    for name, roots, params, group_names in SPRINGS:
        bone_groups.append({
            "comment": name,
            "stiffiness": params["stiffness"],
            "gravityPower": params["gravityPower"],
            "gravityDir": {"x": 0.0, "y": -1.0, "z": 0.0},
            "dragForce": params["dragForce"],
            "center": -1,
            "hitRadius": params["hitRadius"],
            "bones": [ids[r] for r in roots],
            "colliderGroups": [g for n in group_names for g in group_of.get(n, [])],
        })
    doc.setdefault("extensions", {})["VRM"] = {
        "exporterVersion": "bevy_cartoon_hair write_vrm_fixtures.py",
        "specVersion": "0.0",
        "meta": {"title": "chain_hair", "version": "1", "author": "bevy_cartoon_hair",
                 "texture": thumbnail},
        "secondaryAnimation": {"boneGroups": bone_groups, "colliderGroups": collider_groups},
    }
    used = doc.setdefault("extensionsUsed", [])
    if "VRM" not in used:
        used.append("VRM")
    return doc


def main(folder):
    source = os.path.join(folder, "chain_hair.glb")
    doc, rest = read_glb(source)
    one = json.loads(json.dumps(doc))
    image, _, one_rest = add_thumbnail(one, rest, os.path.join(folder, "thumbnail.jpg"), "image/jpeg")
    write_glb(os.path.join(folder, "chain_hair.vrm"), vrm1(one, image), one_rest)
    zero = json.loads(json.dumps(doc))
    _, texture, zero_rest = add_thumbnail(zero, rest, os.path.join(folder, "thumbnail.png"), "image/png")
    write_glb(os.path.join(folder, "chain_hair_vrm0.vrm"), vrm0(zero, texture), zero_rest)


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "..", "assets", "chain_hair"))
