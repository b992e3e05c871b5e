# SPDX-License-Identifier: MIT OR Apache-2.0
"""Operators (File > Export), the scene settings and the "Cartoon Hair" sidebar panel."""

import bpy
from bpy.props import BoolProperty, FloatProperty, PointerProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from . import gather
from .writer import ExportError


# --------------------------------------------------------------------------------------------
# Search callbacks for the name properties


def _search_armatures(self, context, edit_text):
    return sorted(o.name for o in bpy.data.objects if o.type == "ARMATURE")


def _search_bones(self, context, edit_text):
    arm = bpy.data.objects.get(getattr(self, "armature", "") or "")
    if arm is None or arm.type != "ARMATURE":
        return []
    return sorted(b.name for b in arm.data.bones)


def _search_collections(self, context, edit_text):
    return sorted(c.name for c in bpy.data.collections)


def _poll_armature(self, obj):
    return obj.type == "ARMATURE"


# --------------------------------------------------------------------------------------------
# Scene settings (what the panel edits and the operators start from)


class CartoonHairSettings(bpy.types.PropertyGroup):
    armature: PointerProperty(
        name="Armature",
        type=bpy.types.Object,
        poll=_poll_armature,
        description="Armature whose bone the positions are relative to; empty: object space",
    )
    bone: StringProperty(
        name="Bone", default="head", description="Bone the hair / collision shape is attached to"
    )
    scale: FloatProperty(
        name="Scale",
        default=1.0,
        min=1e-6,
        soft_max=1000.0,
        description="Factor every length is multiplied by (written as 'scale'; loaders divide by it)",
    )
    seconds_per_key: FloatProperty(
        name="Seconds per Key", default=0.8, min=1e-3, description="Time between hair style keys"
    )
    loop: BoolProperty(name="Loop", default=True, description="The hair animation loops")
    collection: PointerProperty(
        name="Styles Collection",
        type=bpy.types.Collection,
        description="Hair styles for the animation (its hair objects, by name); empty: selection",
    )


# --------------------------------------------------------------------------------------------
# Operators


class _Common:
    scale: FloatProperty(
        name="Scale",
        default=1.0,
        min=1e-6,
        soft_max=1000.0,
        description="Factor every length is multiplied by (written as 'scale')",
    )
    armature: StringProperty(
        name="Armature",
        default="",
        search=_search_armatures,
        description="Armature object of the bone; empty: positions in object space, bone=\"\"",
    )
    bone: StringProperty(
        name="Bone", default="head", search=_search_bones, description="Bone name written to the file"
    )

    _settings_props = ("scale", "armature", "bone")

    def _from_settings(self, context):
        s = getattr(context.scene, "cartoon_hair", None)
        if s is None:
            return
        for name in self._settings_props:
            if self.properties.is_property_set(name):
                continue
            value = getattr(s, name)
            if isinstance(value, bpy.types.ID):
                value = value.name
            elif value is None:
                value = ""
            setattr(self, name, value)

    def invoke(self, context, event):
        self._from_settings(context)
        return ExportHelper.invoke(self, context, event)

    def _armature(self):
        if not self.armature:
            return None
        arm = bpy.data.objects.get(self.armature)
        if arm is None:
            raise ExportError(f"no object named '{self.armature}'")
        if arm.type != "ARMATURE":
            raise ExportError(f"'{self.armature}' is not an armature")
        return arm

    def draw_common(self, layout):
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(self, "scale")
        layout.prop(self, "armature", icon="ARMATURE_DATA")
        row = layout.row()
        row.enabled = bool(self.armature)
        row.prop(self, "bone", icon="BONE_DATA")

    def draw(self, context):
        self.draw_common(self.layout)

    def _run(self, fn):
        try:
            return fn()
        except ExportError as e:
            self.report({"ERROR"}, str(e))
            return None


class EXPORT_SCENE_OT_cartoon_hair(_Common, bpy.types.Operator, ExportHelper):
    """Export the selected hair (Curves objects, particle hair) as a bevy_cartoon_hair groom"""

    bl_idname = "export_scene.cartoon_hair"
    bl_label = "Export Cartoon Hair"
    bl_options = {"PRESET"}

    filename_ext = ".hair.xml"
    filter_glob: StringProperty(default="*.hair.xml", options={"HIDDEN"})

    def execute(self, context):
        n = self._run(
            lambda: gather.export_hair(
                self.filepath, context.selected_objects, self._armature(), self.bone, self.scale, context
            )
        )
        if n is None:
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {n} strands to {self.filepath}")
        return {"FINISHED"}


class EXPORT_SCENE_OT_cartoon_hair_collision(_Common, bpy.types.Operator, ExportHelper):
    """Export the selected collision shapes (sphere meshes and empties, capsule rigid bodies,
    flat meshes as planes) as a bevy_cartoon_hair collision file"""

    bl_idname = "export_scene.cartoon_hair_collision"
    bl_label = "Export Cartoon Hair Collision"
    bl_options = {"PRESET"}

    filename_ext = ".collision.xml"
    filter_glob: StringProperty(default="*.collision.xml", options={"HIDDEN"})

    def execute(self, context):
        n = self._run(
            lambda: gather.export_collision(
                self.filepath, context.selected_objects, self._armature(), self.bone, self.scale, context
            )
        )
        if n is None:
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {n} collision shapes to {self.filepath}")
        return {"FINISHED"}


class EXPORT_SCENE_OT_cartoon_hair_anim(_Common, bpy.types.Operator, ExportHelper):
    """Export hair styles as a bevy_cartoon_hair hair animation: one groom per style (the
    selected hair objects or a collection's, by name) and a .hairanim.xml listing them"""

    bl_idname = "export_scene.cartoon_hair_anim"
    bl_label = "Export Cartoon Hair Animation"
    bl_options = {"PRESET"}

    filename_ext = ".hairanim.xml"
    filter_glob: StringProperty(default="*.hairanim.xml", options={"HIDDEN"})

    seconds_per_key: FloatProperty(
        name="Seconds per Key", default=0.8, min=1e-3, description="Time between style keys"
    )
    loop: BoolProperty(name="Loop", default=True, description="The animation loops")
    collection: StringProperty(
        name="Collection",
        default="",
        search=_search_collections,
        description="Take the styles from this collection's hair objects; empty: the selection",
    )

    _settings_props = ("scale", "armature", "bone", "seconds_per_key", "loop", "collection")

    def draw(self, context):
        layout = self.layout
        self.draw_common(layout)
        layout.prop(self, "seconds_per_key")
        layout.prop(self, "loop")
        layout.prop(self, "collection", icon="OUTLINER_COLLECTION")

    def styles(self, context):
        if self.collection:
            coll = bpy.data.collections.get(self.collection)
            if coll is None:
                raise ExportError(f"no collection named '{self.collection}'")
            return gather.hair_objects(coll.all_objects)
        return gather.hair_objects(context.selected_objects)

    def execute(self, context):
        paths = self._run(
            lambda: gather.export_hairanim(
                self.filepath,
                self.styles(context),
                self._armature(),
                self.bone,
                self.scale,
                self.seconds_per_key,
                self.loop,
                context,
            )
        )
        if paths is None:
            return {"CANCELLED"}
        self.report({"INFO"}, f"Exported {len(paths)} hair styles and {self.filepath}")
        return {"FINISHED"}


# --------------------------------------------------------------------------------------------
# Panel and menu


class VIEW3D_PT_cartoon_hair(bpy.types.Panel):
    bl_label = "Cartoon Hair Export"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Cartoon Hair"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.cartoon_hair
        col = layout.column()
        col.prop(s, "armature")
        sub = col.column()
        sub.enabled = s.armature is not None
        if s.armature is not None:
            sub.prop_search(s, "bone", s.armature.data, "bones")
        else:
            sub.prop(s, "bone")
        col.prop(s, "scale")

        hair = gather.hair_objects(context.selected_objects)
        spheres = [o for o in context.selected_objects if gather.is_collision_object(o)]
        layout.separator()
        col = layout.column()
        col.label(text=f"Selected: {len(hair)} hair, {len(spheres)} collision objects")
        col.operator(EXPORT_SCENE_OT_cartoon_hair.bl_idname, text="Export Hair", icon="CURVES")
        col.operator(
            EXPORT_SCENE_OT_cartoon_hair_collision.bl_idname,
            text="Export Collision Shapes",
            icon="MESH_UVSPHERE",
        )
        layout.separator()
        col = layout.column(heading="Animation")
        col.prop(s, "collection")
        col.prop(s, "seconds_per_key")
        col.prop(s, "loop")
        col.operator(
            EXPORT_SCENE_OT_cartoon_hair_anim.bl_idname, text="Export Hair Animation", icon="ANIM"
        )


def menu_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_cartoon_hair.bl_idname, text="Cartoon Hair (.hair.xml)")
    self.layout.operator(
        EXPORT_SCENE_OT_cartoon_hair_collision.bl_idname,
        text="Cartoon Hair Collision (.collision.xml)",
    )
    self.layout.operator(
        EXPORT_SCENE_OT_cartoon_hair_anim.bl_idname, text="Cartoon Hair Animation (.hairanim.xml)"
    )


classes = (
    CartoonHairSettings,
    EXPORT_SCENE_OT_cartoon_hair,
    EXPORT_SCENE_OT_cartoon_hair_collision,
    EXPORT_SCENE_OT_cartoon_hair_anim,
    VIEW3D_PT_cartoon_hair,
)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.cartoon_hair = PointerProperty(type=CartoonHairSettings)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    del bpy.types.Scene.cartoon_hair
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
