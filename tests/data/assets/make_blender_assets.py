# Writes the Blender-exported test assets of tests/geometry/asset_test.cpp:
# the same small scene exported by Blender's own glTF exporter (io_scene_gltf2)
# as .glb and as .gltf with its .bin and images (and opaque.glb: the cube and
# the sphere alone), and by its OBJ exporter with an MTL, so that mr's readers are tested on files another program wrote.
#   blender -b --factory-startup --python tests/data/assets/make_blender_assets.py -- OUT_DIR
# The scene: a 1 m cube "painted" (a 16x16 checker base colour texture, a
# metallic-roughness texture, a normal map, metallic 0), a UV sphere of gold
# (metallic 1, roughness 0.3, smooth shading) at x = 2, and a glass slab
# (transmission 1, ior 1.45) at x = -2, rotated 90 degrees about z and scaled
# 2 in y (a node transform the reader must apply).
import os
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
os.makedirs(out, exist_ok=True)
bpy.ops.wm.read_factory_settings(use_empty=True)


def image(name, pixels_fn, size=16):
    img = bpy.data.images.new(name, size, size, alpha=False)
    px = []
    for y in range(size):
        for x in range(size):
            px += list(pixels_fn(x, y)) + [1.0]
    img.pixels = px
    img.filepath_raw = os.path.join(out, name + ".png")
    img.file_format = "PNG"
    img.save()
    return img


checker = image("checker", lambda x, y: (0.8, 0.2, 0.1) if (x // 4 + y // 4) % 2 else (0.1, 0.3, 0.8))
metal_rough = image("metal_rough", lambda x, y: (0.0, 0.25 + 0.5 * (x / 15), 0.0))
# A normal map tilting the normal towards +x on the left half (tangent space, +Y up).
normal = image("normal", lambda x, y: (0.5 + (0.3 if x < 8 else 0.0), 0.5, 0.95))


def principled(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    return m, m.node_tree.nodes["Principled BSDF"], m.node_tree


painted, p, tree = principled("painted")
t = tree.nodes.new("ShaderNodeTexImage")
t.image = checker
tree.links.new(t.outputs["Color"], p.inputs["Base Color"])
mr_tex = tree.nodes.new("ShaderNodeTexImage")
mr_tex.image = metal_rough
mr_tex.image.colorspace_settings.name = "Non-Color"
sep = tree.nodes.new("ShaderNodeSeparateColor")
tree.links.new(mr_tex.outputs["Color"], sep.inputs["Color"])
tree.links.new(sep.outputs["Green"], p.inputs["Roughness"])
tree.links.new(sep.outputs["Blue"], p.inputs["Metallic"])
n_tex = tree.nodes.new("ShaderNodeTexImage")
n_tex.image = normal
n_tex.image.colorspace_settings.name = "Non-Color"
nmap = tree.nodes.new("ShaderNodeNormalMap")
tree.links.new(n_tex.outputs["Color"], nmap.inputs["Color"])
tree.links.new(nmap.outputs["Normal"], p.inputs["Normal"])

gold, p, _ = principled("gold")
p.inputs["Base Color"].default_value = (1.0, 0.766, 0.336, 1.0)
p.inputs["Metallic"].default_value = 1.0
p.inputs["Roughness"].default_value = 0.3

glass, p, _ = principled("glass")
p.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
p.inputs["Transmission"].default_value = 1.0
p.inputs["IOR"].default_value = 1.45
p.inputs["Roughness"].default_value = 0.0

bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
cube = bpy.context.object
cube.name = "cube"
cube.data.materials.append(painted)

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, segments=16, ring_count=8, location=(2, 0, 0.5))
sphere = bpy.context.object
sphere.name = "sphere"
sphere.data.materials.append(gold)
bpy.ops.object.shade_smooth()

bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-2, 0, 0.5), rotation=(0, 0, 1.5707963267948966))
slab = bpy.context.object
slab.name = "slab"
slab.scale = (0.1, 2.0, 1.0)
slab.data.materials.append(glass)

bpy.ops.export_scene.gltf(filepath=os.path.join(out, "blender.glb"), export_format="GLB")
bpy.ops.export_scene.gltf(filepath=os.path.join(out, "blender.gltf"), export_format="GLTF_SEPARATE")
# The opaque parts alone (the cube and the sphere): what mr renders today
# (transmission is to come), for bench/asset_compare.py.
bpy.ops.object.select_all(action="DESELECT")
cube.select_set(True)
sphere.select_set(True)
bpy.ops.export_scene.gltf(filepath=os.path.join(out, "opaque.glb"), export_format="GLB", use_selection=True)
bpy.ops.wm.obj_export(filepath=os.path.join(out, "blender.obj"), path_mode="RELATIVE", export_triangulated_mesh=False)
