# Renders an mr scene with Blender Cycles, for tests/crosscheck/crosscheck.py
# and bench/cycles_compare.py:
#   blender -b --factory-startup -noaudio -P blender_scene.py -- SPEC.json OUT.exr
# SPEC (JSON):
#   meshes: [{name, path (.obj, .ply, or a .glb/.gltf asset imported with its
#     own materials by Blender's glTF importer, smooth as imported; "flat":
#     true shades its facets flat, "normal_maps": false unlinks its normal
#     maps), role: "real" | "virtual" (default
#     real), world_from_object (4x4, mr's world; optional), albedo [3],
#     specular [3] and roughness (optional: mr's GGX lobe), emission [3]
#     (optional: an emitter of that radiance from both sides instead, a lamp),
#     smooth (optional: shaded with normals interpolated from the faces', default flat)}]
#   environment: a lat-long EXR in mr's (OpenEXR's) convention
#   env_rotation_deg: 90 (Blender's equirectangular lookup is a quarter turn
#     from OpenEXR's: docs/benchmarks.md, "Cross-check against Blender Cycles")
#   camera: {width, height, fx, fy, cx, cy} (a pinhole, mrcal's pixel centres)
#     or {type: "equirect", width, height}: a lat-long panorama about the
#     camera's forward axis, its up the camera's -y (Blender's pixel edges
#     on the image's edges: bench/room_capture.py turns it into mr's map)
#   world_from_cam: 4x4 (mr's camera frame: x right, y down, z forward; mr's
#     world: y up.  Blender's world is z up: (x, y, z) -> (x, -z, y).)
#   spp, max_depth, seed, threads
#   mode: "full" (every mesh), "real" (the real meshes only), "catcher" (the
#     real meshes as shadow catchers, composited over `plate` in Blender's
#     compositor: plate x shadow-catcher pass, the object's pass over it) or
#     "mask" (the virtual objects' coverage: real meshes held out, camera
#     rays only; the image's alpha)
#   plate: the photograph (linear EXR) for "catcher"
#   depth: true (optional): also the depth pass, OUT a multilayer EXR
#     (ViewLayer.Combined.RGBA, ViewLayer.Depth.Z: Cycles' distance along
#     the camera's axis, metres)
#   border: [x0, y0, x1, y1] (optional): render only these pixels (x0 <= x < x1,
#     y0 <= y < y1, mr's pixels, y down); the rest of OUT is zero
# Writes OUT (32-bit float EXR, RGBA) and OUT.json: {"render_seconds": the
# time of bpy.ops.render.render (scene sync, BVH build, sampling,
# compositing), "setup_seconds": scene building and mesh import}.
import json
import math
import sys
import time

import bpy
from mathutils import Matrix

t_start = time.perf_counter()
spec = json.load(open(sys.argv[sys.argv.index("--") + 1]))
out = sys.argv[sys.argv.index("--") + 2]
mode = spec.get("mode", "full")
if mode not in ("full", "real", "catcher", "mask"):
    raise SystemExit("blender_scene.py: unknown mode %r" % mode)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = spec["spp"]
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
depth = 0 if mode == "mask" else spec["max_depth"]
scene.cycles.max_bounces = depth
scene.cycles.diffuse_bounces = depth
scene.cycles.glossy_bounces = depth
scene.cycles.transparent_max_bounces = 0
scene.cycles.sample_clamp_direct = 0
scene.cycles.sample_clamp_indirect = 0
scene.cycles.caustics_reflective = True
scene.cycles.caustics_refractive = True
scene.cycles.blur_glossy = 0.0  # no filter glossy: mr does not blur
scene.cycles.pixel_filter_type = "BOX"  # a one-pixel box, as mr's uniform jitter over the pixel
scene.cycles.filter_width = 1.0
scene.cycles.seed = spec.get("seed", 1)
cam_spec = spec["camera"]
W, H = cam_spec["width"], cam_spec["height"]
scene.render.resolution_x = W
scene.render.resolution_y = H
scene.render.resolution_percentage = 100
scene.render.film_transparent = mode in ("catcher", "mask")
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.color_mode = "RGBA"
scene.render.threads_mode = "FIXED"
scene.render.threads = spec.get("threads", 2)
if "border" in spec:
    x0, y0, x1, y1 = spec["border"]
    scene.render.use_border = True
    scene.render.use_crop_to_border = False
    scene.render.border_min_x, scene.render.border_max_x = x0 / W, x1 / W
    scene.render.border_min_y, scene.render.border_max_y = 1 - y1 / H, 1 - y0 / H

to_blender = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def material(m):
    mat = bpy.data.materials.new(m["name"])
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    surface = nodes["Material Output"].inputs["Surface"]
    if mode == "mask":
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = (1, 1, 1, 1)
        links.new(emit.outputs["Emission"], surface)
        return mat
    if "emission" in m:
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = (*m["emission"], 1.0)
        emit.inputs["Strength"].default_value = 1.0  # a mesh emitter's strength is its radiance
        links.new(emit.outputs["Emission"], surface)
        return mat
    # mr's BSDF (render/bsdf.cpp): albedo / pi + specular x GGX (alpha =
    # roughness^2, no Fresnel), the two lobes added.
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*m["albedo"], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambertian
    spec_rgb = m.get("specular", [0, 0, 0])
    if max(spec_rgb) > 0:
        glossy = nodes.new("ShaderNodeBsdfGlossy")
        glossy.distribution = "GGX"
        glossy.inputs["Color"].default_value = (*spec_rgb, 1.0)
        glossy.inputs["Roughness"].default_value = m.get("roughness", 0.5)
        add = nodes.new("ShaderNodeAddShader")
        links.new(diffuse.outputs["BSDF"], add.inputs[0])
        links.new(glossy.outputs["BSDF"], add.inputs[1])
        links.new(add.outputs["Shader"], surface)
    else:
        links.new(diffuse.outputs["BSDF"], surface)
    return mat


def import_asset(m, role):
    """A glTF asset through Blender's own importer, with its materials as the
    importer makes them (Principled BSDF): the peer's reading of the file.
    Shaded flat, as mr renders assets today (its vertex normals are to come)."""
    # Debian 12's Blender 3.4.1 glTF importer uses numpy.bool, which
    # Debian's NumPy 1.24 no longer has: every import fails without the alias.
    import numpy
    if not hasattr(numpy, "bool"):
        numpy.bool = bool
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=m["path"])
    new = [o for o in bpy.data.objects if o not in before]
    place = to_blender @ Matrix(m.get("world_from_object", Matrix.Identity(4))) @ to_blender.inverted()
    for obj in new:
        if obj.parent is None:
            obj.matrix_world = place @ obj.matrix_world
        if obj.type == "MESH" and m.get("flat", False):
            # Flat facets (mr's shading before shading normals).
            for p in obj.data.polygons:
                p.use_smooth = False
            if obj.data.has_custom_normals:
                obj.data.free_normals_split()
                bpy.context.view_layer.objects.active = obj
                bpy.ops.mesh.customdata_custom_splitnormals_clear()
        if obj.type == "MESH":
            if mode == "mask":
                obj.data.materials.clear()
                obj.data.materials.append(material(m))
            elif not m.get("normal_maps", True):
                # No normal maps (the importer's Normal Map node unlinked
                # from the Principled BSDF).
                for mat in obj.data.materials:
                    for link in list(mat.node_tree.links):
                        if link.to_socket.name == "Normal" and link.to_node.type == "BSDF_PRINCIPLED":
                            mat.node_tree.links.remove(link)


for m in spec["meshes"]:
    role = m.get("role", "real")
    if mode == "real" and role == "virtual":
        continue
    path = m["path"]
    if path.lower().endswith((".glb", ".gltf")):
        import_asset(m, role)
        continue
    # Both importers keep the file's vertices (the OBJ one puts its axis
    # change in the object's matrix, replaced here).
    if path.lower().endswith(".ply"):
        bpy.ops.import_mesh.ply(filepath=path)
    else:
        bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
    obj = bpy.context.selected_objects[0]
    obj.matrix_world = to_blender @ Matrix(m.get("world_from_object", Matrix.Identity(4)))
    for p in obj.data.polygons:
        p.use_smooth = m.get("smooth", False)  # flat shading, as mr's flat meshes
    if obj.data.has_custom_normals:
        # The importer turns the file's normals with its axis change, which the
        # matrix above replaces: a mirror sphere's highlight 2 degrees off.
        # Smooth shading takes the faces' normals instead.
        bpy.context.view_layer.objects.active = obj
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    obj.data.materials.clear()
    obj.data.materials.append(material(m))
    if role == "real" and mode == "catcher":
        obj.is_shadow_catcher = True
    if role == "real" and mode == "mask":
        obj.is_holdout = True

# Environment: Blender's equirectangular u = atan2(d.y, -d.x) / 2pi + 0.5 is
# mr's (OpenEXR's) u = 0.5 - atan2(x, z) / 2pi rotated by a quarter turn.
world = bpy.data.worlds.new("env")
scene.world = world
world.use_nodes = True
nodes = world.node_tree.nodes
if mode == "mask":
    nodes["Background"].inputs["Strength"].default_value = 0.0
else:
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(spec["environment"])
    tex.image.colorspace_settings.name = "Linear"
    tex.interpolation = "Closest"
    coord = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.vector_type = "VECTOR"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(spec.get("env_rotation_deg", 90.0)))
    world.node_tree.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    world.node_tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    world.node_tree.links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])

# The camera: a pinhole whose principal point may leave the centre
# (Blender's shift, in units of the width with a horizontal sensor fit).
cam_data = bpy.data.cameras.new("cam")
if cam_spec.get("type") == "equirect":
    cam_data.type = "PANO"
    cam_data.cycles.panorama_type = "EQUIRECTANGULAR"
else:
    if abs(cam_spec["fx"] - cam_spec["fy"]) > 1e-9 * cam_spec["fx"]:
        raise SystemExit("blender_scene.py: fx != fy (Blender's camera has square pixels)")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 36.0
    cam_data.lens = cam_spec["fx"] * 36.0 / W
    cam_data.shift_x = ((W - 1) / 2 - cam_spec["cx"]) / W
    cam_data.shift_y = (cam_spec["cy"] - (H - 1) / 2) / W
cam_data.clip_start = 1e-3
cam = bpy.data.objects.new("cam", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
flip = Matrix(((1, 0, 0, 0), (0, -1, 0, 0), (0, 0, -1, 0), (0, 0, 0, 1)))  # mr camera -> Blender camera axes
cam.matrix_world = to_blender @ Matrix(spec["world_from_cam"]) @ flip

if mode == "catcher":
    # What a Blender user does: the shadow-catcher pass multiplies the plate,
    # the objects' pass goes over it (Blender manual, "Shadow Catcher").
    bpy.context.view_layer.cycles.use_pass_shadow_catcher = True
    scene.use_nodes = True
    tree = scene.node_tree
    tree.nodes.clear()
    rl = tree.nodes.new("CompositorNodeRLayers")
    plate = tree.nodes.new("CompositorNodeImage")
    plate.image = bpy.data.images.load(spec["plate"])
    plate.image.colorspace_settings.name = "Linear"
    mul = tree.nodes.new("CompositorNodeMixRGB")
    mul.blend_type = "MULTIPLY"
    mul.inputs[0].default_value = 1.0
    tree.links.new(plate.outputs["Image"], mul.inputs[1])
    tree.links.new(rl.outputs["Shadow Catcher"], mul.inputs[2])
    over = tree.nodes.new("CompositorNodeAlphaOver")  # premultiplied: fg + (1 - fg.a) bg
    tree.links.new(mul.outputs["Image"], over.inputs[1])
    tree.links.new(rl.outputs["Image"], over.inputs[2])
    comp = tree.nodes.new("CompositorNodeComposite")
    comp.use_alpha = True
    tree.links.new(over.outputs["Image"], comp.inputs["Image"])

if spec.get("depth", False):
    bpy.context.view_layer.use_pass_z = True
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"

t_setup = time.perf_counter() - t_start
scene.render.filepath = out
t0 = time.perf_counter()
bpy.ops.render.render(write_still=True)
t_render = time.perf_counter() - t0
json.dump({"render_seconds": t_render, "setup_seconds": t_setup}, open(out + ".json", "w"))
