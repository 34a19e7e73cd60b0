#!/usr/bin/python3
"""Writes the main job's showcase asset, a glTF 2.0 binary (.glb) generated
here (no third-party file): a painted base with base-colour,
metallic-roughness and normal textures, a polished metal sphere and a solid
glass sphere with a faint green absorption, all resting on y = 0, about
0.3 m wide.  Standard library only; the same bytes every run.

  examples/synthetic/make_asset.py OUT.glb
"""
import json
import math
import struct
import sys
import zlib


def png(width, height, rgb):
    """An 8-bit RGB PNG of `rgb` (a function (x, y) -> (r, g, b) in 0..255)."""
    raw = b"".join(b"\0" + bytes(c for x in range(width) for c in rgb(x, y)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def box(sx, sy, sz):
    """A box [-sx/2, sx/2] x [0, sy] x [-sz/2, sz/2]: 24 vertices (flat faces), uvs per face."""
    pos, nrm, uv, idx = [], [], [], []
    faces = [((1, 0, 0), (0, 0, -1), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 1, 0), (1, 0, 0), (0, 0, -1)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (-1, 0, 0), (0, 1, 0))]
    half = (sx / 2, sy / 2, sz / 2)
    for n, u, v in faces:
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = [n[k] * half[k] + a * u[k] * half[k] + b * v[k] * half[k] for k in range(3)]
            p[1] += sy / 2
            pos.append(p)
            nrm.append(list(n))
            uv.append([(a + 1) / 2, 1 - (b + 1) / 2])  # glTF: v down the image
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, uv, idx


def sphere(r, cx, cy, cz, n=32):
    pos, nrm, uv, idx = [], [], [], []
    for i in range(n + 1):
        th = math.pi * i / n
        for j in range(2 * n + 1):
            ph = math.pi * j / n
            d = (math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph))
            pos.append([cx + r * d[0], cy + r * d[1], cz + r * d[2]])
            nrm.append(list(d))
            uv.append([j / (2 * n), i / n])
    w = 2 * n + 1
    for i in range(n):
        for j in range(2 * n):
            a, b = i * w + j, i * w + j + 1
            c, d = a + w, b + w
            if i > 0:
                idx += [a, c, b]
            if i < n - 1:
                idx += [b, c, d]
    return pos, nrm, uv, idx


def main():
    out = sys.argv[1]
    blob = bytearray()
    views, accessors = [], []

    def add_view(data, target=None):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        if target:
            views[-1]["target"] = target
        blob.extend(data)
        return len(views) - 1

    def add_floats(rows, kind):
        data = b"".join(struct.pack("<%df" % len(r), *r) for r in rows)
        acc = {"bufferView": add_view(data, 34962), "componentType": 5126, "count": len(rows), "type": kind}
        if kind == "VEC3":
            acc["min"] = [min(r[k] for r in rows) for k in range(3)]
            acc["max"] = [max(r[k] for r in rows) for k in range(3)]
        accessors.append(acc)
        return len(accessors) - 1

    def add_mesh(name, geom, material):
        pos, nrm, uv, idx = geom
        attrs = {"POSITION": add_floats(pos, "VEC3"), "NORMAL": add_floats(nrm, "VEC3"),
                 "TEXCOORD_0": add_floats(uv, "VEC2")}
        accessors.append({"bufferView": add_view(struct.pack("<%dI" % len(idx), *idx), 34963),
                          "componentType": 5125, "count": len(idx), "type": "SCALAR"})
        return {"name": name, "primitives": [{"attributes": attrs, "indices": len(accessors) - 1,
                                              "material": material}]}

    # Textures: a two-tone tile pattern, roughness rising across the base
    # (metallic 0: a painted wood), and a normal map of grooves between the
    # tiles (tangent space, +Y up).
    size = 64
    base_colour = png(size, size, lambda x, y: (200, 120, 60) if (x // 16 + y // 16) % 2 else (70, 110, 170))
    metal_rough = png(size, size, lambda x, y: (0, 60 + 2 * x, 0))

    def groove(x, y):
        dx = 0.5 if x % 16 == 0 else (-0.5 if x % 16 == 15 else 0.0)
        dy = 0.5 if y % 16 == 15 else (-0.5 if y % 16 == 0 else 0.0)
        n = (dx, dy, 1.0)
        length = math.sqrt(sum(c * c for c in n))
        return tuple(int(round(255 * (c / length + 1) / 2)) for c in n)

    normal = png(size, size, groove)
    images = [{"name": name, "bufferView": add_view(data), "mimeType": "image/png"}
              for name, data in (("tiles", base_colour), ("metal_rough", metal_rough), ("grooves", normal))]
    materials = [
        {"name": "painted", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                     "metallicRoughnessTexture": {"index": 1},
                                                     "metallicFactor": 1.0, "roughnessFactor": 1.0},
         "normalTexture": {"index": 2, "scale": 1.0}},
        {"name": "steel", "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.93, 0.88, 1.0],
                                                   "metallicFactor": 1.0, "roughnessFactor": 0.15}},
        {"name": "glass", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                                                   "metallicFactor": 0.0, "roughnessFactor": 0.0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                        "KHR_materials_ior": {"ior": 1.5},
                        "KHR_materials_volume": {"thicknessFactor": 0.14, "attenuationDistance": 0.2,
                                                 "attenuationColor": [0.8, 0.95, 0.85]}}},
    ]
    meshes = [add_mesh("base", box(0.3, 0.03, 0.18), 0),
              add_mesh("metal", sphere(0.055, -0.07, 0.085, 0.0), 1),
              add_mesh("glass", sphere(0.07, 0.075, 0.1, 0.0), 2)]
    gltf = {
        "asset": {"version": "2.0", "generator": "mr examples/synthetic/make_asset.py"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"],
        "scene": 0,
        "scenes": [{"name": "showcase", "nodes": [0]}],
        "nodes": [{"name": "showcase", "children": [1, 2, 3]},
                  {"name": "base", "mesh": 0}, {"name": "metal", "mesh": 1}, {"name": "glass", "mesh": 2}],
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": i, "sampler": 0} for i in range(3)],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": images,
        "buffers": [{"byteLength": 0}],
        "bufferViews": views,
        "accessors": accessors,
    }
    while len(blob) % 4:
        blob.append(0)
    gltf["buffers"][0]["byteLength"] = len(blob)
    js = json.dumps(gltf, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + bytes(blob)
    data = struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body
    tmp = out + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    import os
    os.replace(tmp, out)


if __name__ == "__main__":
    main()
