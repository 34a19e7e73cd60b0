# Renders the cross-check scene with Blender Cycles (run by crosscheck.py):
#   blender -b --factory-startup -P blender_scene.py -- SPEC.json OUT.exr
# SPEC names the OBJ meshes, their albedos, the lat-long environment map, the
# pinhole camera (fx, width, height) and mr's world_from_cam (4x4, mr's camera
# frame: x right, y down, z forward; mr's world: y up).  Blender's world is
# z up: OBJ import maps (x, y, z) -> (x, -z, y), and so does this script.
import json
import math
import sys

import bpy
from mathutils import Matrix

spec = json.load(open(sys.argv[sys.argv.index("--") + 1]))
out = sys.argv[sys.argv.index("--") + 2]

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = spec["spp"]
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
scene.cycles.max_bounces = spec["max_depth"]
scene.cycles.diffuse_bounces = spec["max_depth"]
scene.cycles.glossy_bounces = spec["max_depth"]
scene.cycles.sample_clamp_direct = 0
scene.cycles.sample_clamp_indirect = 0
scene.cycles.pixel_filter_type = "BOX"  # a one-pixel box, as mr's uniform jitter over the pixel
scene.cycles.filter_width = 1.0
scene.cycles.seed = 1
scene.render.resolution_x = spec["width"]
scene.render.resolution_y = spec["height"]
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.threads_mode = "FIXED"
scene.render.threads = 2

to_blender = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))

for m in spec["meshes"]:
    bpy.ops.wm.obj_import(filepath=m["obj"], forward_axis="NEGATIVE_Z", up_axis="Y")
    obj = bpy.context.selected_objects[0]
    mat = bpy.data.materials.new(m["name"])
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    mat.node_tree.nodes.remove(bsdf)
    diffuse = mat.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*m["albedo"], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambertian
    mat.node_tree.links.new(diffuse.outputs["BSDF"], mat.node_tree.nodes["Material Output"].inputs["Surface"])
    obj.data.materials.clear()
    obj.data.materials.append(mat)

# Environment: Blender's equirectangular u = atan2(d.y, -d.x) / 2pi + 0.5 is
# mr's (OpenEXR's) u = 0.5 - atan2(x, z) / 2pi rotated by a quarter turn.
world = bpy.data.worlds.new("env")
scene.world = world
world.use_nodes = True
nodes = world.node_tree.nodes
tex = nodes.new("ShaderNodeTexEnvironment")
tex.image = bpy.data.images.load(spec["environment"])
tex.image.colorspace_settings.name = "Linear"
tex.interpolation = "Closest"
coord = nodes.new("ShaderNodeTexCoord")
mapping = nodes.new("ShaderNodeMapping")
mapping.vector_type = "VECTOR"
mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(spec["env_rotation_deg"]))
world.node_tree.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
world.node_tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
world.node_tree.links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])

cam_data = bpy.data.cameras.new("cam")
cam_data.sensor_fit = "HORIZONTAL"
cam_data.sensor_width = 36.0
cam_data.lens = spec["fx"] * 36.0 / spec["width"]
cam_data.clip_start = 1e-3
cam = bpy.data.objects.new("cam", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
world_from_cam = Matrix(spec["world_from_cam"])
flip = Matrix(((1, 0, 0, 0), (0, -1, 0, 0), (0, 0, -1, 0), (0, 0, 0, 1)))  # mr camera -> Blender camera axes
cam.matrix_world = to_blender @ world_from_cam @ flip

scene.render.filepath = out
bpy.ops.render.render(write_still=True)
