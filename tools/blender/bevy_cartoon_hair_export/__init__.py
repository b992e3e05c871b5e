# SPDX-License-Identifier: MIT OR Apache-2.0
"""bevy_cartoon_hair export: Blender add-on (extension) writing the XML formats of
``docs/formats.md`` - grooms (``*.hair.xml``), collision spheres (``*.collision.xml``) and hair
animations (``*.hairanim.xml``).

Modules:

* :mod:`.writer` - pure numpy: frames, validation, XML text.  Importing it (or this package)
  does not import ``bpy``.
* :mod:`.gather` - reads Blender data and writes files (the functions the operators wrap).
* :mod:`.ui` - operators (File > Export), scene settings, the "Cartoon Hair" sidebar panel.
"""

# Legacy add-on metadata (ignored by the 4.2+ extension system, which reads
# blender_manifest.toml); lets the folder also be installed as a plain add-on.
bl_info = {
    "name": "bevy_cartoon_hair Export",
    "author": "bevy_cartoon_hair contributors",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "File > Export > Cartoon Hair; View3D > Sidebar > Cartoon Hair",
    "description": "Export hair grooms, collision spheres and hair animations for bevy_cartoon_hair",
    "category": "Import-Export",
}


def register():
    from . import ui

    ui.register()


def unregister():
    from . import ui

    ui.unregister()
