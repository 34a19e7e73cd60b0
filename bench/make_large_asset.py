# A large real asset for bench/asset_read.cpp (issue 38: the reader chosen by
# measured correctness and speed on real files; texture memory measured at
# 4k): the Stanford dragon (../shared/data/meshes/dragon_vrip_res3.ply,
# 47,794 triangles) subdivided twice in Blender (about 1.15 M triangles),
# uv-unwrapped, split into three materials by x, each with a 4096 x 4096
# base colour, metallic-roughness and normal texture (nine 4k PNGs), written
# by Blender's own exporters as .glb, .gltf with its .bin and images, and
# OBJ with its MTL.
#   blender -b --factory-startup --python bench/make_large_asset.py -- DRAGON.ply OUT_DIR
import os
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
ply, out = args[0], args[1]
os.makedirs(out, exist_ok=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
N = 4096


def image(name, rgb, non_color):
    """rgb: (N, N, 3) floats in [0, 1], row 0 at the bottom (Blender's)."""
    img = bpy.data.images.new(name, N, N, alpha=False)
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    px = np.ones((N, N, 4), dtype=np.float32)
    px[:, :, :3] = rgb
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = os.path.join(out, name + ".png")
    img.file_format = "PNG"
    img.save()
    return img


y, x = np.mgrid[0:N, 0:N].astype(np.float32) / N
rng = np.random.default_rng(38)


def pattern(k):
    f = 6 + 5 * k
    s = 0.5 + 0.5 * np.sin(2 * np.pi * f * x) * np.cos(2 * np.pi * (f + 3) * y)
    return np.clip(s + 0.03 * rng.standard_normal((N, N)).astype(np.float32), 0, 1)


materials = []
for k, tint in enumerate([(0.8, 0.3, 0.2), (0.2, 0.6, 0.3), (0.3, 0.4, 0.9)]):
    s = pattern(k)
    base = image(f"base{k}", np.stack([s * tint[0], s * tint[1], s * tint[2]], -1), False)
    mr = image(f"mr{k}", np.stack([np.zeros_like(s), 0.2 + 0.6 * s, (s > 0.7).astype(np.float32)], -1), True)
    gx, gy = np.gradient(s)
    nrm = np.stack([0.5 - 20 * gx, 0.5 - 20 * gy, np.ones_like(s)], -1)
    nrm[:, :, :2] = np.clip(nrm[:, :, :2], 0, 1)
    normal = image(f"normal{k}", nrm, True)
    m = bpy.data.materials.new(f"dragon{k}")
    m.use_nodes = True
    tree = m.node_tree
    p = tree.nodes["Principled BSDF"]
    t = tree.nodes.new("ShaderNodeTexImage")
    t.image = base
    tree.links.new(t.outputs["Color"], p.inputs["Base Color"])
    t = tree.nodes.new("ShaderNodeTexImage")
    t.image = mr
    sep = tree.nodes.new("ShaderNodeSeparateColor")
    tree.links.new(t.outputs["Color"], sep.inputs["Color"])
    tree.links.new(sep.outputs["Green"], p.inputs["Roughness"])
    tree.links.new(sep.outputs["Blue"], p.inputs["Metallic"])
    t = tree.nodes.new("ShaderNodeTexImage")
    t.image = normal
    nm = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(t.outputs["Color"], nm.inputs["Color"])
    tree.links.new(nm.outputs["Normal"], p.inputs["Normal"])
    materials.append(m)

bpy.ops.import_mesh.ply(filepath=ply)
obj = bpy.context.selected_objects[0]
obj.name = "dragon"
bpy.context.view_layer.objects.active = obj
for m in materials:
    obj.data.materials.append(m)
xs = [v.co.x for v in obj.data.vertices]
lo, hi = min(xs), max(xs)
for poly in obj.data.polygons:
    c = obj.data.vertices[poly.vertices[0]].co.x
    poly.material_index = min(2, int(3 * (c - lo) / (hi - lo + 1e-9)))
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.select_all(action="SELECT")
bpy.ops.uv.smart_project()
bpy.ops.object.mode_set(mode="OBJECT")
sub = obj.modifiers.new("subdivide", "SUBSURF")
sub.levels = 2
sub.render_levels = 2
bpy.ops.object.modifier_apply(modifier="subdivide")
bpy.ops.object.shade_smooth()
bpy.ops.object.modifier_add(type="TRIANGULATE")
bpy.ops.object.modifier_apply(modifier="Triangulate")
print("triangles", len(obj.data.polygons))

bpy.ops.export_scene.gltf(filepath=os.path.join(out, "dragon.glb"), export_format="GLB")
bpy.ops.export_scene.gltf(filepath=os.path.join(out, "dragon.gltf"), export_format="GLTF_SEPARATE")
bpy.ops.wm.obj_export(filepath=os.path.join(out, "dragon.obj"), path_mode="RELATIVE")
