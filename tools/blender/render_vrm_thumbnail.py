# SPDX-License-Identifier: MIT OR Apache-2.0
"""Render the modelled-hair test character's head as the thumbnail its VRM files carry.

    python3 tools/blender/render_vrm_thumbnail.py [assets/chain_hair]

Imports ``chain_hair.glb`` into an empty scene, renders the head from the front with Cycles on
the CPU (a few samples, so it takes seconds) and saves it as ``thumbnail.jpg`` (what the VRM 1.0
file embeds: many VRM files carry JPEG textures) and ``thumbnail.png`` (the VRM 0.x file's).
``write_vrm_fixtures.py`` embeds them as they are, so the VRM files do not change unless this
script is run again.
"""

import os
import sys

import bpy

SIZE = 128


def main(folder):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.join(folder, "chain_hair.glb"))
    scene = bpy.context.scene
    head = next(o for o in scene.objects if o.type == "ARMATURE").pose.bones["head"]
    rig = next(o for o in scene.objects if o.type == "ARMATURE")
    centre = rig.matrix_world @ head.head
    centre.z += 0.08
    cam_data = bpy.data.cameras.new("thumbnail")
    cam_data.lens = 85
    cam = bpy.data.objects.new("thumbnail", cam_data)
    scene.collection.objects.link(cam)
    # Blender is z-up; the character faces -y.
    cam.location = (centre.x + 0.25, centre.y - 1.3, centre.z + 0.12)
    direction = centre - cam.location
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    light_data = bpy.data.lights.new("key", "SUN")
    light_data.energy = 3.0
    light = bpy.data.objects.new("key", light_data)
    light.rotation_euler = (0.9, 0.0, 0.5)
    scene.collection.objects.link(light)
    world = bpy.data.worlds.new("thumbnail")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs[0].default_value = (0.55, 0.62, 0.75, 1.0)
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x = SIZE
    scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.render.image_settings.color_mode = "RGB"
    for fmt, name, extra in (("JPEG", "thumbnail.jpg", {"quality": 85}), ("PNG", "thumbnail.png", {"compression": 90})):
        scene.render.image_settings.file_format = fmt
        for k, v in extra.items():
            setattr(scene.render.image_settings, k, v)
        scene.render.filepath = os.path.join(folder, name)
        bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    main(os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "..", "assets", "chain_hair")))
