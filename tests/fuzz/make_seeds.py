#!/usr/bin/env python3
"""Writes the text and simple binary seeds of tests/fuzz/corpus (small, valid and a few
edge cases each). Seeds from weft's own writers (.exr, .jpg, .wssdf, .wbtf, .btfraw,
checkpoints, the skin LUT cache) are made by the commands in tests/fuzz/README.md.
Run from the repository root: python3 tests/fuzz/make_seeds.py"""
import base64, os, struct, zlib

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")

def put(folder, name, data):
    d = os.path.join(root, folder)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)

# ---- meshes ----
put("obj", "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
    "f 1/1/1 2/2/1 3/3/1 4/4/1\n")
put("obj", "tri_negative.obj", "# comment\no tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n")
put("obj", "two_groups.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\ng a\nf 1 2 3\ng b\nusemtl m\nf 1//1 3//1 4//1\nvn 1 0 0\n")
put("ply", "tri_ascii.ply", "ply\nformat ascii 1.0\ncomment x\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\n"
    "property list uchar int vertex_indices\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n")
verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
for endian, fmt in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
    header = ("ply\nformat %s 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
              "property float s\nproperty float t\nelement face 2\nproperty list uchar uint vertex_indices\nend_header\n" % endian)
    body = b"".join(struct.pack(fmt + "5f", *v, v[0], v[1]) for v in verts)
    body += struct.pack(fmt + "B3I", 3, 0, 1, 2) + struct.pack(fmt + "B3I", 3, 0, 2, 3)
    put("ply", "quad_%s.ply" % endian, header.encode() + body)
put("off", "tri.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
put("off", "quad_comments.off", "OFF # a quad\n# counts\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
put("off", "colored.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n")
put("stl", "tri_ascii.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
    "endloop\nendfacet\nendsolid t\n")
tri = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
put("stl", "tri_binary.stl", b"\0" * 80 + struct.pack("<I", 2) + tri + tri)

# ---- glTF ----
def quad_buffer():
    b = b"".join(struct.pack("<3f", *v) for v in verts)
    b += b"".join(struct.pack("<3f", 0, 0, 1) for _ in verts)
    b += b"".join(struct.pack("<2f", v[0], v[1]) for v in verts)
    b += struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    return b

def gltf_json(uri, extra=""):
    return ('{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 2]}],'
            ' "nodes": [{"name": "p", "translation": [1, 0, 0], "children": [1]},'
            ' {"mesh": 0, "rotation": [0, 0.7071, 0, 0.7071], "scale": [2, 2, 2]},'
            ' {"camera": 0, "translation": [0, 0, 5], "extensions": {"KHR_lights_punctual": {"light": 0}}}],'
            ' "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],'
            ' "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.25, 1], "metallicFactor": 0.5}, "emissiveFactor": [0, 0, 0]}],'
            ' "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100}}],'
            ' "extensionsUsed": ["KHR_lights_punctual"],'
            ' "extensions": {"KHR_lights_punctual": {"lights": [{"type": "spot", "intensity": 5, "spot": {"outerConeAngle": 0.6}}]}},'
            ' "buffers": [{"byteLength": 140%s}],'
            ' "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 128, "byteStride": 0},'
            ' {"buffer": 0, "byteOffset": 128, "byteLength": 12}],'
            ' "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},'
            ' {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},'
            ' {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC2"},'
            ' {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]%s}') % (uri, extra)

data_uri = ', "uri": "data:application/octet-stream;base64,' + base64.b64encode(quad_buffer()).decode() + '"'
put("gltf", "quad.gltf", gltf_json(data_uri))
put("gltf", "quad_strip.gltf", gltf_json(data_uri).replace('"material": 0}', '"material": 0, "mode": 5}'))
put("gltf", "quad_external.gltf", gltf_json(', "uri": "quad.bin"'))
put("gltf", "no_scene.gltf", gltf_json(data_uri).replace('"scene": 0, "scenes": [{"nodes": [0, 2]}],', ''))
j = gltf_json("").encode()
j += b" " * (-len(j) % 4)
binbuf = quad_buffer()
binbuf += b"\0" * (-len(binbuf) % 4)
glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(j) + 8 + len(binbuf))
glb += struct.pack("<I4s", len(j), b"JSON") + j + struct.pack("<I4s", len(binbuf), b"BIN\0") + binbuf
put("glb", "quad.glb", glb)

# ---- scene files ----
put("scene_json", "sphere.json", '{"version": 1, "output": {"width": 32, "height": 24},'
    ' "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40},'
    ' "environment": {"color": [0.2, 0.2, 0.2], "intensity": 1},'
    ' "lights": [{"type": "directional", "direction": [0, -1, 0], "intensity": 3},'
    ' {"type": "spot", "position": [0, 2, 0], "inner_cone": 10, "outer_cone": 30}],'
    ' "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 8},'
    ' "ring": {"primitive": "torus", "major_radius": 1, "minor_radius": 0.2, "segments": 8, "sides": 4},'
    ' "floor": {"primitive": "plane", "size": 2, "subdivisions": 2}, "box": {"primitive": "cube"}},'
    ' "materials": {"m": {"type": "standard", "base_color": [1, 0, 0], "roughness": 0.5},'
    ' "skin": {"type": "skin"}, "fur": {"type": "fur"}},'
    ' "objects": [{"name": "ball", "mesh": "ball", "material": "m",'
    ' "transform": {"translation": [0, 1, 0], "rotation_degrees": [0, 45, 0], "scale": 2}},'
    ' {"mesh": "floor", "transform": {"quaternion": [0, 0, 0, 1], "scale": [1, 2, 1]}}]}')
put("scene_json", "broken.json", '{"version": 1, "camera": {"fov_y": 3}, "objects": [{"mesh": "nope"}]')

# ---- images ----
def png(width, height, color_type, bit_depth, rows, palette=None):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff)
    raw = b"".join(b"\0" + r for r in rows)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0))
    if palette:
        out += chunk(b"PLTE", palette)
    return out + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
put("png", "rgba_4x3.png", png(4, 3, 6, 8, [b"".join(bytes((x * 60, y * 80, 128, 255)) for x in range(4)) for y in range(3)]))
put("png", "gray16_2x2.png", png(2, 2, 0, 16, [b"\x00\x00\xff\xff", b"\x80\x00\x40\x00"]))
put("png", "palette_3x1.png", png(3, 1, 3, 8, [b"\x00\x01\x02"], palette=b"\xff\x00\x00\x00\xff\x00\x00\x00\xff"))
def rgbe(r, g, b):
    import math
    m = max(r, g, b)
    if m < 1e-32:
        return b"\0\0\0\0"
    mant, e = math.frexp(m)
    s = mant * 256.0 / m
    return bytes((int(r * s), int(g * s), int(b * s), e + 128))
pixels = b"".join(rgbe(0.5 * x, 0.25 * y, 2.0) for y in range(3) for x in range(4))
put("hdr", "flat_4x3.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 3 +X 4\n" + pixels)
# New-style RLE scanlines need widths 8..32767: one 8-pixel row, each channel as one run.
row = b"\x02\x02\x00\x08" + b"".join(bytes((128 + 8, v)) for v in (100, 50, 25, 129))
put("hdr", "rle_8x1.hdr", b"#?RGBE\nEXPOSURE=1\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n" + row)

# ---- BTF image folders: "name\\nbytes" (see fuzz_btf_folder.cpp) ----
put("btf_folder", "utia.txt", b"tl000_pl000_tv000_pv000.png\n" + png(2, 2, 2, 8, [b"\x10\x20\x30" * 2, b"\x40\x50\x60" * 2]))
put("btf_folder", "ubo.txt", b"tv000_pv000/00000 tl000 pl000 tv000 pv000.png\n" + png(2, 1, 2, 8, [b"\x10\x20\x30\x40\x50\x60"]))
# ---- .btfraw: 1 x 2 texels, 2 lights x 2 views (files.cpp: header, FNV-1a checksums) ----
def fnv1a(data):
    h = 0xcbf29ce484222325
    for byte in data:
        h = ((h ^ byte) * 0x100000001b3) & 0xffffffffffffffff
    return h
dirs = [(0.0, 0.0), (0.5, 1.0), (0.2, 0.0), (1.0, 3.0)]
samples = b"".join(struct.pack("<f", 0.05 * i) for i in range(1 * 2 * 2 * 2 * 3))
header = b"WEFTBTFR" + struct.pack("<IIIIII", 1, 48 + len(dirs) * 8 + 8, 1, 2, 2, 2)
header += struct.pack("<QQ", len(samples) // 4, fnv1a(samples)) + b"".join(struct.pack("<ff", *d) for d in dirs)
header += struct.pack("<Q", fnv1a(header))
put("btfraw", "tiny.btfraw", header + samples)

# ---- past crashes (issue 21), replayed by ctest from tests/fuzz/crashes ----
crashes = os.path.join(os.path.dirname(os.path.abspath(__file__)), "crashes")
def crash(folder, name, data):
    d = os.path.join(crashes, folder)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
crash("gltf", "extras_nested_20000.gltf", '{"asset": {"version": "2.0"}, "extras": ' + "[" * 20000 + "]" * 20000 + "}")
crash("gltf", "buffer_uri_escapes.gltf", gltf_json(', "uri": "../../../../../../../../etc/passwd"'))
crash("obj", "nan_vertex.obj", "v 0 0 0\nv 1 0 0\nv nan nan nan\nf 1 2 3\n")
crash("scene_json", "nested_20000.json", '{"version": 1, "description": ' + "[" * 20000 + "]" * 20000 + "}")
print("seeds written under", root)
