#!/usr/bin/env python3
"""Writes examples/gltf/spot.glb: Spot the cow (Keenan Crane, public domain) as a glTF 2.0
binary with the full metallic-roughness material and KHR_lights_punctual, for weft's glTF
example and tests. Standard library only.

  python3 tools/make_spot_glb.py [--help] [out.glb]

What it puts in the file (everything embedded, images in GLB buffer views):
- the mesh of assets/meshes/spot/spot_triangulated.obj, one vertex per (position, uv, normal)
  corner; OBJ's v is flipped into glTF's convention (v = 0 the image's top row);
- baseColorTexture: assets/meshes/spot/spot_texture.png, as is;
- metallicRoughnessTexture: 64x64, rough hide (G 0.75) with glossy patches (G 0.3), not metal;
- normalTexture: 64x64 of small round bumps (tangent space, +Y the image's top), scale 1;
- occlusionTexture on TEXCOORD_1 (a copy of TEXCOORD_0): 64x64, darker towards the texture's
  lower edge;
- a camera, a warm point light (range 6) and a cool spot light (inner 15, outer 30 degrees),
  placed by nodes.
"""
import json
import math
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def png_rgb(width, height, pixel):
    """An 8-bit RGB PNG of pixel(x, y) -> (r, g, b) in 0..255, rows top first."""
    rows = bytearray()
    for y in range(height):
        rows.append(0)
        for x in range(width):
            rows.extend(bytes(pixel(x, y)))
    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(bytes(rows), 9)) + chunk(b"IEND", b"")


def code(c):
    return max(0, min(255, int(round((c * 0.5 + 0.5) * 255))))


def bumps(x, y, size=64, cells=8):
    """Tangent-space normal of a field of round bumps, x right, y up the image."""
    cell = size / cells
    u = ((x + 0.5) % cell) / cell * 2 - 1
    v = -(((y + 0.5) % cell) / cell * 2 - 1)  # image rows grow downwards; +Y is up
    r2 = u * u + v * v
    if r2 >= 0.6:
        return (128, 128, 255)
    nx, ny = u * 0.8, v * 0.8
    nz = math.sqrt(max(1 - nx * nx - ny * ny, 0))
    return (code(nx), code(ny), code(nz))


def roughness(x, y):
    glossy = ((x // 16) + (y // 16)) % 3 == 0
    return (0, int(255 * (0.3 if glossy else 0.75)), 0)


def occlusion(x, y):
    a = int(255 * (1.0 - 0.5 * (y / 63.0) ** 2))
    return (a, a, a)


def read_obj(path):
    pos, uv, nrm, corners = [], [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                pos.append(tuple(map(float, w[1:4])))
            elif w[0] == "vt":
                uv.append(tuple(map(float, w[1:3])))
            elif w[0] == "vn":
                nrm.append(tuple(map(float, w[1:4])))
            elif w[0] == "f":
                face = []
                for c in w[1:]:
                    parts = (c.split("/") + ["", ""])[:3]
                    face.append(tuple(int(p) - 1 if p else -1 for p in parts))
                for i in range(1, len(face) - 1):
                    corners.append((face[0], face[i], face[i + 1]))
    return pos, uv, nrm, corners


def look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """The glTF node rotation (x, y, z, w) whose -Z axis points from eye to target."""
    def norm(v):
        length = math.sqrt(sum(x * x for x in v))
        return [x / length for x in v]
    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    f = norm([target[i] - eye[i] for i in range(3)])
    r = norm(cross(f, up))
    u = cross(r, f)
    m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]  # columns x, y, z
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0:
        s = math.sqrt(trace + 1.0) * 2
        return [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1.0 + m[i][i] - m[j][j] - m[k][k]) * 2
    q = [0.0, 0.0, 0.0, (m[k][j] - m[j][k]) / s]
    q[i] = 0.25 * s
    q[j] = (m[j][i] + m[i][j]) / s
    q[k] = (m[k][i] + m[i][k]) / s
    return q


def main():
    if "--help" in sys.argv or "-h" in sys.argv:
        print(__doc__)
        return 0
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "examples", "gltf", "spot.glb")
    pos, uv, nrm, triangles = read_obj(os.path.join(ROOT, "assets", "meshes", "spot", "spot_triangulated.obj"))
    # Smooth normals when the OBJ has none: area-weighted face normals summed per position.
    if not nrm:
        acc = [[0.0, 0.0, 0.0] for _ in pos]
        for tri in triangles:
            a, b, c = (pos[t[0]] for t in tri)
            e1 = [b[i] - a[i] for i in range(3)]
            e2 = [c[i] - a[i] for i in range(3)]
            n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
            for t in tri:
                for i in range(3):
                    acc[t[0]][i] += n[i]
        nrm = []
        for n in acc:
            length = math.sqrt(sum(x * x for x in n)) or 1.0
            nrm.append(tuple(x / length for x in n))
        triangles = [tuple((t[0], t[1], t[0]) for t in tri) for tri in triangles]
    index_of, vertices, indices = {}, [], []
    for tri in triangles:
        for (p, t, n) in tri:
            key = (p, t, n)
            if key not in index_of:
                index_of[key] = len(vertices)
                u, v = uv[t] if t >= 0 else (0.0, 0.0)
                vertices.append((pos[p], nrm[n] if n >= 0 else (0.0, 1.0, 0.0), (u, 1.0 - v)))  # glTF: v = 0 at the top
            indices.append(index_of[key])
    lo = [min(v[0][i] for v in vertices) for i in range(3)]
    hi = [max(v[0][i] for v in vertices) for i in range(3)]

    bin_data = bytearray()
    views, accessors = [], []

    def add_view(data, target=None):
        while len(bin_data) % 4:
            bin_data.append(0)
        view = {"buffer": 0, "byteOffset": len(bin_data), "byteLength": len(data)}
        if target:
            view["target"] = target
        bin_data.extend(data)
        views.append(view)
        return len(views) - 1

    def add_accessor(data, count, kind, component=5126, **extra):
        accessors.append(dict(bufferView=add_view(data, 34962 if kind != "SCALAR" else 34963), componentType=component,
                              count=count, type=kind, **extra))
        return len(accessors) - 1

    position = add_accessor(b"".join(struct.pack("<3f", *v[0]) for v in vertices), len(vertices), "VEC3", min=lo, max=hi)
    normal = add_accessor(b"".join(struct.pack("<3f", *v[1]) for v in vertices), len(vertices), "VEC3")
    texcoord = add_accessor(b"".join(struct.pack("<2f", *v[2]) for v in vertices), len(vertices), "VEC2")
    texcoord1 = add_accessor(b"".join(struct.pack("<2f", *v[2]) for v in vertices), len(vertices), "VEC2")
    index_type, index_fmt = (5123, "<H") if len(vertices) < 65536 else (5125, "<I")
    index = add_accessor(b"".join(struct.pack(index_fmt, i) for i in indices), len(indices), "SCALAR", component=index_type)

    with open(os.path.join(ROOT, "assets", "meshes", "spot", "spot_texture.png"), "rb") as f:
        images = [f.read(), png_rgb(64, 64, roughness), png_rgb(64, 64, bumps), png_rgb(64, 64, occlusion)]
    image_entries = [{"bufferView": add_view(png), "mimeType": "image/png"} for png in images]
    names = ["spot_texture", "metallic_roughness", "normal_bumps", "occlusion"]
    for entry, name in zip(image_entries, names):
        entry["name"] = name

    centre = [(lo[i] + hi[i]) / 2 for i in range(3)]
    # Spot faces -Z: the camera sees her face three-quarter on, the spot light comes from
    # above on her right, the point light from the camera's side.
    camera = [centre[0] + 1.7, centre[1] + 0.8, centre[2] - 2.6]
    spot = [centre[0] - 1.6, centre[1] + 1.8, centre[2] - 1.0]
    doc = {
        "asset": {"version": "2.0", "generator": "weft tools/make_spot_glb.py",
                  "copyright": "Spot by Keenan Crane, released into the public domain"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "spot", "mesh": 0},
            {"name": "camera", "camera": 0, "translation": camera, "rotation": look_at(camera, centre)},
            {"name": "warm point", "translation": [1.4, 1.2, -1.3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "cool spot", "translation": spot, "rotation": look_at(spot, centre),
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05, "zfar": 50}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "warm point", "type": "point", "color": [1.0, 0.85, 0.7], "intensity": 5.0, "range": 6.0},
            {"name": "cool spot", "type": "spot", "color": [0.7, 0.8, 1.0], "intensity": 8.0,
             "spot": {"innerConeAngle": 0.2618, "outerConeAngle": 0.5236}},
        ]}},
        "meshes": [{"name": "spot", "primitives": [{
            "attributes": {"POSITION": position, "NORMAL": normal, "TEXCOORD_0": texcoord, "TEXCOORD_1": texcoord1},
            "indices": index, "material": 0}]}],
        "materials": [{
            "name": "spot",
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1},
                                     "metallicFactor": 1.0, "roughnessFactor": 1.0},
            "normalTexture": {"index": 2, "scale": 1.0},
            "occlusionTexture": {"index": 3, "texCoord": 1, "strength": 1.0},
        }],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "textures": [{"source": i, "sampler": 0} for i in range(4)],
        "images": image_entries,
        "bufferViews": views,
        "accessors": accessors,
        "buffers": [{"byteLength": 0}],
    }
    while len(bin_data) % 4:
        bin_data.append(0)
    doc["buffers"][0]["byteLength"] = len(bin_data)
    text = json.dumps(doc, separators=(",", ":")).encode()
    while len(text) % 4:
        text += b" "
    glb = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(bin_data))
    glb += struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(bin_data), 0x004E4942) + bytes(bin_data)
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "wb") as f:
        f.write(glb)
    print(f"wrote {out}: {len(vertices)} vertices, {len(indices) // 3} triangles, {len(glb)} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
