# mr's shot in Blender: imports the glTF scene mr-export wrote and sets up
# what glTF cannot carry (docs/formats.md, "mr-export"; docs/conventions.md,
# "glTF export"):
#   - the camera's lens from the calibrated model's pinhole core (focal
#     length, pixel aspect, principal point as lens shift), the render's
#     resolution, frame rate and range;
#   - the room marked as a shadow catcher (Cycles);
#   - the environment map as the world, turned as mr's world turns it;
#   - the lights at mr's radiometric strengths (glTF's are photometric);
#   - assets (glTF, OBJ) imported from their own files onto their nodes;
#   - the plate as the camera's background and the compositor's backdrop.
# Run headless:
#   blender -b --python SHOT-blender.py -- SHOT.glb [--blend OUT.blend]
#          [--project POINTS.json OUT.json] [--describe OUT.json]
#          [--seed N] [--render FRAME SAMPLES OUT.exr] [--composite FRAME SAMPLES OUT.png]
# --render: frame FRAME of the room rendered whole by Cycles (no shadow
# catcher, no plate; mr's path-tracing settings), for comparing with
# mr-render's real layer.  --composite: frame FRAME as the artist gets it,
# the render over the plate through the compositor.
# --project: for each camera key, the pixel (mrcal's convention: (0, 0) the
# centre of the top-left pixel) at which Blender's camera sees each point
# of POINTS.json ({"points": [[x, y, z], ...]} in glTF coordinates); the
# check that Blender's camera is mr's (tests/cli).
import json
import math
import os
import struct
import sys

import bpy
import mathutils

# Debian 12's Blender 3.4.1 glTF importer uses numpy.bool, which Debian's
# NumPy 1.24 no longer has: every import fails without the alias.
import numpy

if not hasattr(numpy, "bool"):
    numpy.bool = bool


def read_gltf_json(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != 0x4E4F534A:
            raise SystemExit("mr_shot: %s: the first chunk is not JSON" % path)
        return json.loads(data[20:20 + length].decode("utf-8"))
    return json.loads(data.decode("utf-8"))


def gltf_to_blender(v):
    # Blender's glTF importer: glTF's +y up becomes Blender's +z up.
    return mathutils.Vector((v[0], -v[2], v[1]))


def setup_camera(scene, cam_obj, extras, render):
    # Blender's view (sensor fit horizontal): the image's width spans
    # sensor_width / lens at unit distance, its height that times
    # (pixel_aspect_y / pixel_aspect_x) h / w, and the lens shift moves the
    # window by shift x the width, in both directions.  So the lens is
    # fx sensor / w, the pixel aspect x / y is fy / fx, and the principal
    # point's offset from the image's centre is the shift (mr-export writes
    # it in extras: blender_shift).
    cam = cam_obj.data
    c = extras["camera"]
    w, h = c["width"], c["height"]
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    if not c.get("perspective", False):
        print("mr_shot: %s" % c.get("no_perspective", "no perspective camera"))
        return
    fx, fy = c["fx"], c["fy"]
    if fy >= fx:
        scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = fy / fx, 1.0
    else:
        scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = 1.0, fx / fy
    cam.type = "PERSP"
    cam.sensor_fit = "HORIZONTAL"
    cam.sensor_width = 36.0
    cam.lens = fx * cam.sensor_width / w
    cam.shift_x, cam.shift_y = c["blender_shift"]
    cam.clip_start = 0.01
    cam.clip_end = 1e4


def emptied(node_tree):
    # The node tree with every node removed, for a set-up from scratch.
    for n in list(node_tree.nodes):
        node_tree.nodes.remove(n)
    return node_tree


def blender_convention_map(img):
    # mr's lat-long map (OpenEXR's: pixel centres on both edges, each pixel
    # the radiance of the directions nearest it) resampled k times finer into
    # Blender's equirectangular convention (pixel edges on the image's edges)
    # in the texture frame of setup_world, so that Cycles sees mr's radiance
    # function to 1/k of a pixel.  Blender's texture (x, y, z) is the map's
    # (z, x, y).
    W, H = img.size
    k = max(1, min(8, 4096 // max(W, 1)))
    src = numpy.array(img.pixels[:], dtype=numpy.float32).reshape(H, W, 4)[::-1]  # row 0 the top
    Wb, Hb = k * W, k * H
    u = (numpy.arange(Wb) + 0.5) / Wb
    v = 1 - (numpy.arange(Hb) + 0.5) / Hb  # Blender's v = 1 is the top
    phi, theta = (0.5 - u) * 2 * numpy.pi, (v - 0.5) * numpy.pi
    ct = numpy.cos(theta)[:, None]
    xt, yt, zt = ct * numpy.cos(phi)[None, :], ct * numpy.sin(phi)[None, :], numpy.sin(theta)[:, None] + 0 * phi[None, :]
    xm, ym, zm = yt, zt, xt
    lat, lon = numpy.arcsin(numpy.clip(ym, -1, 1)), numpy.arctan2(xm, zm)
    px = numpy.clip(numpy.rint((0.5 - lon / (2 * numpy.pi)) * (W - 1)), 0, W - 1).astype(int)
    py = numpy.clip(numpy.rint((0.5 - lat / numpy.pi) * (H - 1)), 0, H - 1).astype(int)
    out = src[py, px][::-1]  # back to Blender's bottom-up rows
    b = bpy.data.images.new(img.name + ".blender", Wb, Hb, alpha=True, float_buffer=True)
    b.pixels.foreach_set(numpy.ascontiguousarray(out, dtype=numpy.float32).ravel())
    b.pack()
    return b


def setup_world(scene, extras, base):
    env = extras.get("environment")
    if not env:
        return
    world = scene.world or bpy.data.worlds.new("mr")
    scene.world = world
    world.use_nodes = True
    nt = emptied(world.node_tree)
    coord = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    bg = nt.nodes.new("ShaderNodeBackground")
    out = nt.nodes.new("ShaderNodeOutputWorld")
    path = os.path.join(base, env["file"])
    if env.get("per_frame"):
        print("mr_shot: the environment changes per frame; frame %d's map is the world" % extras["render"]["frame_begin"])
        path = path % extras["render"]["frame_begin"]
    scene["mr_world_image"] = os.path.basename(path)
    tex.image = blender_convention_map(bpy.data.images.load(path))
    tex.image.colorspace_settings.name = "Non-Color"  # linear radiance, as written
    tex.interpolation = "Closest"
    bg.inputs["Strength"].default_value = env.get("scale", 1.0)
    # A Blender world direction d (z up) -> glTF (x, z, -y) -> mr's map frame
    # (map_from_gltf) -> Blender's equirectangular frame.  Blender reads
    # column u = 1/2 - atan2(y, x) / 2 pi at elevation asin(z); mr's map
    # (OpenEXR's) u = 1/2 - atan2(x, z) / 2 pi at latitude asin(y): the
    # map's (x, y, z) is Blender's texture (z, x, y), a rotation.
    g = mathutils.Matrix(env["gltf_from_map"])
    to_gltf = mathutils.Matrix(((1, 0, 0), (0, 0, 1), (0, -1, 0)))
    to_tex = mathutils.Matrix(((0, 0, 1), (1, 0, 0), (0, 1, 0)))
    m = to_tex @ g.transposed() @ to_gltf
    mapping.vector_type = "VECTOR"
    mapping.inputs["Rotation"].default_value = m.to_euler("XYZ")
    nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])


def setup_lights(doc, nodes_by_index):
    # mr's radiometric values (extras) as Blender's: a point or spot of
    # intensity I (W/sr) is 4 pi I watts in Cycles; a sun of irradiance E
    # (W/m^2) has strength E; an area light of radiance L over area A is
    # 4 L A watts (make_area_lights).
    for i, node in enumerate(doc.get("nodes", [])):
        info = node.get("extras", {}).get("mr", {})
        obj = nodes_by_index.get(i)
        t = info.get("type")
        if obj is None or t not in ("point", "spot", "distant"):
            continue
        light = obj.data if obj.type == "LIGHT" else next((c.data for c in obj.children if c.type == "LIGHT"), None)
        if light is None:
            continue
        v = info["intensity_w_sr"] if t != "distant" else info["irradiance_w_m2"]
        peak = max(v)
        light.color = [x / peak for x in v] if peak > 0 else [1, 1, 1]
        if t == "distant":
            light.energy = peak
            light.angle = 2 * math.radians(info.get("angular_radius_deg", 0))
        else:
            light.energy = 4 * math.pi * peak
            light.shadow_soft_size = 0
        if t == "spot":
            # mr: smoothstep in cos from the cone to falloff_start; Cycles:
            # smoothstep over spot_blend x (1 - cos(half the size)) inside the
            # cone (Cycles 3.4 also weighs a spot by the cosine off its axis).
            cone, start = math.radians(info["cone_deg"]), math.radians(info["falloff_start_deg"])
            light.spot_size = 2 * cone
            light.spot_blend = (math.cos(start) - math.cos(cone)) / (1 - math.cos(cone))


def make_area_lights(doc, nodes_by_index):
    for i, node in enumerate(doc.get("nodes", [])):
        mr = node.get("extras", {}).get("mr", {})
        if mr.get("type") != "area":
            continue
        light = bpy.data.lights.new(node.get("name", "area"), type="AREA")
        light.shape = "RECTANGLE" if mr["shape"] == "rect" else "DISK"
        light.size, light.size_y = mr["width"], mr["height"]
        L = mr["radiance"]
        peak = max(L)
        light.color = [x / peak for x in L] if peak > 0 else [1, 1, 1]
        # Cycles' area light of power P has radiance P / (4 A) (measured
        # against mr's: tests/crosscheck/shot_roundtrip.py).
        light.energy = 4 * peak * (mr["width"] * mr["height"] if mr["shape"] == "rect"
                                   else math.pi * mr["width"] ** 2 / 4)
        target = nodes_by_index.get(i)
        if target is not None:
            target.name = target.name + ".node"  # the light takes the node's name
        obj = bpy.data.objects.new(node.get("name", "area"), light)
        bpy.context.scene.collection.objects.link(obj)
        if target is not None:
            # The importer turns an empty's axes with the world (glTF's local
            # -z is the empty's Blender +y); a light shines along its -z.
            obj.matrix_world = target.matrix_world @ mathutils.Matrix.Rotation(math.radians(90), 4, "X")


def import_assets(doc, base, nodes_by_index):
    for i, node in enumerate(doc.get("nodes", [])):
        asset = node.get("extras", {}).get("mr", {}).get("asset")
        if not asset:
            continue
        before = set(bpy.data.objects)
        path = os.path.join(base, asset)
        if path.lower().endswith((".glb", ".gltf")):
            bpy.ops.import_scene.gltf(filepath=path)
        elif path.lower().endswith(".obj"):
            bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
        else:
            print("mr_shot: %s: not an asset Blender imports here" % path)
            continue
        parent = nodes_by_index.get(i)
        for obj in set(bpy.data.objects) - before:
            if obj.parent is None and parent is not None:
                obj.parent = parent


def mr_materials(doc, nodes_by_index):
    # mr's own BSDF where a mesh carries mr's material (extras): Lambert
    # albedo / pi (the vertex colours where the albedo is theirs) plus
    # specular x GGX of alpha = roughness^2, no Fresnel (render/bsdf.cpp),
    # instead of the importer's Principled BSDF, whose diffuse is not
    # Lambert's: so that Cycles renders what mr renders.  An emitter's
    # radiance as an emission shader beside it.
    for i, node in enumerate(doc.get("nodes", [])):
        obj = nodes_by_index.get(i)
        if obj is None or obj.type != "MESH" or "mesh" not in node:
            continue
        prim = doc["meshes"][node["mesh"]]["primitives"][0]
        if "material" not in prim:
            continue
        m = doc["materials"][prim["material"]].get("extras", {}).get("mr")
        if not m:
            continue
        mat = bpy.data.materials.new(node.get("name", "mr") + ".mr")
        mat.use_nodes = True
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        for n in list(nodes):
            if n.type != "OUTPUT_MATERIAL":
                nodes.remove(n)
        out = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
        diffuse = nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*m["albedo"], 1.0)
        diffuse.inputs["Roughness"].default_value = 0.0
        colours = obj.data.color_attributes if hasattr(obj.data, "color_attributes") else []
        if m.get("albedo_from_vertex_colors") and len(colours) > 0:
            attr = nodes.new("ShaderNodeAttribute")
            attr.attribute_name = colours[0].name
            links.new(attr.outputs["Color"], diffuse.inputs["Color"])
        shader = diffuse
        if max(m.get("specular", [0, 0, 0])) > 0:
            glossy = nodes.new("ShaderNodeBsdfGlossy")
            glossy.distribution = "GGX"
            glossy.inputs["Color"].default_value = (*m["specular"], 1.0)
            glossy.inputs["Roughness"].default_value = m.get("roughness", 0.5)
            add = nodes.new("ShaderNodeAddShader")
            links.new(diffuse.outputs["BSDF"], add.inputs[0])
            links.new(glossy.outputs["BSDF"], add.inputs[1])
            shader = add
        if max(m.get("emission", [0, 0, 0])) > 0:
            emit = nodes.new("ShaderNodeEmission")
            emit.inputs["Color"].default_value = (*m["emission"], 1.0)
            emit.inputs["Strength"].default_value = 1.0  # a surface's strength is its radiance
            add = nodes.new("ShaderNodeAddShader")
            links.new(shader.outputs[0], add.inputs[0])
            links.new(emit.outputs["Emission"], add.inputs[1])
            shader = add
        links.new(shader.outputs[0], out.inputs["Surface"])
        obj.data.materials.clear()
        obj.data.materials.append(mat)


def render_frame(scene, frame, samples, out_path):
    # The room rendered whole (no shadow catcher, no plate), as mr-render's
    # real layer: mr's pt settings where Cycles has them (no clamping, no
    # filter glossy, a one-pixel box filter, 8 bounces).
    for o in scene.objects:
        if o.type == "MESH":
            o.is_shadow_catcher = False
    scene.render.film_transparent = False
    scene.use_nodes = False
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = 8
    c.sample_clamp_direct = c.sample_clamp_indirect = 0
    c.blur_glossy = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    write_render(scene, frame, out_path, "OPEN_EXR", "32", "RGBA")


def write_render(scene, frame, out_path, file_format, depth, mode):
    # Renders frame `frame` through the Standard view and writes it.
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = file_format
    scene.render.image_settings.color_depth = depth
    scene.render.image_settings.color_mode = mode
    scene.frame_set(frame)
    scene.render.filepath = os.path.abspath(out_path)
    bpy.ops.render.render(write_still=True)


def composite_frame(scene, frame, samples, out_path, stmaps):
    # The shot as the artist gets it: the objects and the room's shadow
    # catcher rendered by Cycles over the plate in the compositor (8-bit,
    # the Standard view: the plate's linear values through sRGB).  With
    # ST-maps the compositor's output is the render's (overscanned) size,
    # the lens's image at the overscan's offset: cropped to it.
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_denoising = False
    write_render(scene, frame, out_path, "PNG", "8", "RGB")
    if not stmaps:
        return
    img = bpy.data.images.load(os.path.abspath(out_path))
    W, H = img.size
    w, h = stmaps["lens_width"], stmaps["lens_height"]
    left, top = stmaps["overscan_left"], stmaps["overscan_top"]
    px = numpy.array(img.pixels[:], dtype=numpy.float32).reshape(H, W, 4)
    crop = px[H - top - h:H - top, left:left + w]  # Blender's rows run bottom-up
    out = bpy.data.images.new("composite", w, h, alpha=False)
    out.pixels.foreach_set(numpy.ascontiguousarray(crop).ravel())
    out.filepath_raw = os.path.abspath(out_path)
    out.file_format = "PNG"
    out.save()


def setup_plate(scene, cam_obj, extras, base):
    plate = extras.get("plate")
    if not plate or cam_obj is None:
        return
    first = os.path.join(base, plate["frames"] % plate["first_frame"]) if "%" in plate["frames"] else os.path.join(base, plate["frames"])
    if not os.path.exists(first):
        print("mr_shot: the plate %s is not there; no background" % first)
        return
    img = bpy.data.images.load(first)
    if "%" in plate["frames"]:
        img.source = "SEQUENCE"
    if plate["transfer"] == "linear":
        img.colorspace_settings.name = "Linear"
    cam = cam_obj.data
    cam.show_background_images = True
    bg = cam.background_images.new()
    bg.image = img
    bg.image_user.frame_start = scene.frame_start
    bg.image_user.frame_duration = scene.frame_end - scene.frame_start + 1
    # Blender shows file number (frame - frame_start + 1 + frame_offset).
    bg.image_user.frame_offset = plate["first_frame"] - 1
    # The compositor: the render (film transparent: the shadow catcher's
    # shadows and the objects) over the plate.
    scene.render.film_transparent = True
    scene.use_nodes = True
    nt = emptied(scene.node_tree)
    rl = nt.nodes.new("CompositorNodeRLayers")
    im = nt.nodes.new("CompositorNodeImage")
    im.image = img
    im.frame_duration = bg.image_user.frame_duration
    im.frame_offset = bg.image_user.frame_offset
    over = nt.nodes.new("CompositorNodeAlphaOver")
    comp = nt.nodes.new("CompositorNodeComposite")
    nt.links.new(im.outputs["Image"], over.inputs[1])
    render_out = rl.outputs["Image"]
    gains = plate.get("gains")
    if gains and gains["frame"]:
        # The render in the plate's units: times the frame's gain per channel
        # (mr-eval plate), keyed on each frame, as mr-render scales it.
        mul = nt.nodes.new("CompositorNodeMixRGB")
        mul.blend_type = "MULTIPLY"
        mul.use_alpha = False
        mul.inputs["Fac"].default_value = 1.0
        for f, g in zip(gains["frame"], gains["gain"]):
            mul.inputs[2].default_value = (g[0], g[1], g[2], 1.0)
            mul.inputs[2].keyframe_insert("default_value", frame=f)
        nt.links.new(render_out, mul.inputs[1])
        render_out = mul.outputs["Image"]
    st = extras.get("camera", {}).get("stmaps")
    if st:
        # The render is through the undistorted pinhole: redistorted to the
        # lens's image by the ST-map before it goes over the plate.
        stmap = nt.nodes.new("CompositorNodeImage")
        stmap.image = bpy.data.images.load(os.path.join(base, st["redistort"]))
        stmap.image.colorspace_settings.name = "Non-Color"
        mapuv = nt.nodes.new("CompositorNodeMapUV")
        nt.links.new(render_out, mapuv.inputs["Image"])
        nt.links.new(stmap.outputs["Image"], mapuv.inputs["UV"])
        render_out = mapuv.outputs["Image"]
    nt.links.new(render_out, over.inputs[2])
    nt.links.new(over.outputs["Image"], comp.inputs["Image"])


def main(argv):
    if not argv:
        raise SystemExit("usage: blender -b --python SHOT-blender.py -- SHOT.glb [--blend OUT.blend] "
                         "[--project POINTS.json OUT.json] [--describe OUT.json] [--seed N] [--render FRAME SAMPLES OUT.exr] "
                         "[--composite FRAME SAMPLES OUT.png]")
    path = os.path.abspath(argv[0])
    base = os.path.dirname(path)
    doc = read_gltf_json(path)
    extras = dict(doc["scenes"][doc.get("scene", 0)]["extras"]["mr"])
    render = extras["render"]
    # The camera node's extras: the calibrated model and Blender's shift.
    for node in doc.get("nodes", []):
        if "lensmodel" in node.get("extras", {}).get("mr", {}):
            extras["camera"] = node["extras"]["mr"]
    # An empty scene, then the glTF.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.render.fps = int(round(render["fps"]))
    scene.render.fps_base = scene.render.fps / render["fps"]
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=path)
    imported = [o for o in bpy.data.objects if o not in before]
    # glTF node index -> Blender object, by name (the importer keeps names).
    by_name = {o.name: o for o in imported}
    nodes_by_index = {i: by_name.get(n.get("name")) for i, n in enumerate(doc.get("nodes", []))}
    cam_obj = next((o for o in imported if o.name == "camera" or (o.type == "CAMERA")), None)
    if cam_obj is not None and cam_obj.type == "CAMERA":
        scene.camera = cam_obj
        setup_camera(scene, cam_obj, extras, render)
    # The importer puts a key at time t on frame t fps: Blender's frame k is
    # the shot's frame frame_begin + k.
    scene.frame_start = 0
    scene.frame_end = render["frame_end"] - render["frame_begin"] - 1
    for i, node in enumerate(doc.get("nodes", [])):
        obj = nodes_by_index.get(i)
        if obj is not None and node.get("extras", {}).get("mr", {}).get("role") == "room":
            obj.is_shadow_catcher = True
    setup_world(scene, extras, base)
    mr_materials(doc, nodes_by_index)
    setup_lights(doc, nodes_by_index)
    make_area_lights(doc, nodes_by_index)
    import_assets(doc, base, nodes_by_index)
    setup_plate(scene, cam_obj, extras, base)
    i = 1
    while i < len(argv):
        if argv[i] == "--blend":
            bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(argv[i + 1]))
            i += 2
        elif argv[i] == "--project":
            project(scene, cam_obj, argv[i + 1], argv[i + 2])
            i += 3
        elif argv[i] == "--describe":
            describe(scene, argv[i + 1])
            i += 2
        elif argv[i] == "--seed":
            scene.cycles.seed = int(argv[i + 1])
            i += 2
        elif argv[i] == "--composite":
            st = extras.get("camera", {}).get("stmaps")
            if st:
                st = dict(st, lens_width=extras["camera"]["lens_width"], lens_height=extras["camera"]["lens_height"])
            composite_frame(scene, int(argv[i + 1]), int(argv[i + 2]), argv[i + 3], st)
            i += 4
        elif argv[i] == "--render":
            render_frame(scene, int(argv[i + 1]), int(argv[i + 2]), argv[i + 3])
            i += 4
        else:
            raise SystemExit("mr_shot: unknown option %s" % argv[i])


def describe(scene, out_path):
    # What the shot became in Blender, for tests/crosscheck/shot_roundtrip.py.
    world_image = None
    if scene.world and scene.world.use_nodes:
        for n in scene.world.node_tree.nodes:
            if n.type == "TEX_ENVIRONMENT" and n.image:
                world_image = scene.get("mr_world_image")
    d = {"resolution": [scene.render.resolution_x, scene.render.resolution_y],
         "pixel_aspect": [scene.render.pixel_aspect_x, scene.render.pixel_aspect_y],
         "frame_start": scene.frame_start, "frame_end": scene.frame_end,
         "fps": scene.render.fps / scene.render.fps_base,
         "shadow_catchers": sorted(o.name for o in scene.objects if o.type == "MESH" and o.is_shadow_catcher),
         "world_image": world_image,
         "lights": {o.name: o.data.energy for o in scene.objects if o.type == "LIGHT"}}
    with open(out_path, "w") as f:
        json.dump(d, f, indent=1)


def project(scene, cam_obj, points_path, out_path):
    from bpy_extras.object_utils import world_to_camera_view
    pts = [gltf_to_blender(p) for p in json.load(open(points_path))["points"]]
    w, h = scene.render.resolution_x, scene.render.resolution_y
    frames = []
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        px = []
        for p in pts:
            v = world_to_camera_view(scene, cam_obj, p)
            px.append([v.x * w - 0.5, (1 - v.y) * h - 0.5, v.z])
        frames.append(px)
    with open(out_path, "w") as f:
        json.dump({"frames": frames}, f)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
