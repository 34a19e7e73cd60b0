# Blender Cycles' Principled BSDF in a white furnace (the peer's own energy
# balance, for docs/benchmarks.md): a smooth-shaded sphere of base colour 1
# under a uniform white world, 64 bounces; prints the mean radiance over the
# sphere (1 where the material conserves energy).
#   blender -b --factory-startup -noaudio -P bench/cycles_furnace.py -- METALLIC ROUGHNESS
import os
import sys
import tempfile

import bpy
import numpy as np
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.render.engine = "CYCLES"
sc.cycles.device = "CPU"
sc.cycles.samples = 256
sc.cycles.use_denoising = False
sc.cycles.max_bounces = 64
sc.cycles.diffuse_bounces = 64
sc.cycles.glossy_bounces = 64
sc.render.resolution_x = sc.render.resolution_y = 32
sc.view_settings.view_transform = "Standard"
w = bpy.data.worlds.new("w"); w.use_nodes = True
w.node_tree.nodes["Background"].inputs[0].default_value = (1, 1, 1, 1)
sc.world = w
bpy.ops.mesh.primitive_uv_sphere_add(radius=1, segments=64, ring_count=32)
bpy.ops.object.shade_smooth()
ob = bpy.context.object
m = bpy.data.materials.new("m"); m.use_nodes = True
p = m.node_tree.nodes["Principled BSDF"]
p.inputs["Base Color"].default_value = (1, 1, 1, 1)
p.inputs["Metallic"].default_value = float(sys.argv[-2])
p.inputs["Roughness"].default_value = float(sys.argv[-1])
ob.data.materials.append(m)
bpy.ops.object.camera_add(location=(0, -6, 0), rotation=(1.5707963, 0, 0))
sc.camera = bpy.context.object
sc.camera.data.lens = 200
sc.render.image_settings.file_format = "OPEN_EXR"
out = os.path.join(tempfile.mkdtemp(), "out.exr")
sc.render.filepath = out
bpy.ops.render.render(write_still=True)
img = bpy.data.images.load(out)
px = np.array(img.pixels[:]).reshape(32, 32, 4)
print("FURNACE metallic %s roughness %s: centre mean %.4f, sphere mean %.4f" % (sys.argv[-2], sys.argv[-1], px[12:20, 12:20, 1].mean(), px[4:28, 4:28, 1].mean()))
