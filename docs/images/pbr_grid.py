#!/usr/bin/env python3
"""Writes docs/images/pbr-grid.gltf: glTF metallic-roughness spheres on a
floor, to show how twinray maps PBR materials to its Whitted model
(docs/formats.md). Rows: metallic 0, 0.5, 1; columns: roughness 0, 0.25,
0.5, 1; a fourth row of transmitting spheres (KHR_materials_transmission,
ior 1.5) with roughness 0, 0.25, 0.5, 1. A point light and a camera.

    python3 docs/images/pbr_grid.py docs/images/pbr-grid.gltf
    twinray render docs/images/pbr-grid.gltf -o docs/images/pbr-grid.png --size 640x480
"""
import array, base64, json, math, sys

def sphere(n_lat=24, n_lon=48):
    pos, nor, idx = [], [], []
    for i in range(n_lat + 1):
        th = math.pi * i / n_lat
        for j in range(n_lon + 1):
            ph = 2 * math.pi * j / n_lon
            p = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.extend(p)
            nor.extend(p)
    w = n_lon + 1
    for i in range(n_lat):
        for j in range(n_lon):
            a = i * w + j
            if i > 0:  # no zero-area triangles at the poles
                idx.extend((a, a + 1, a + w))
            if i < n_lat - 1:
                idx.extend((a + 1, a + w + 1, a + w))
    return pos, nor, idx

pos, nor, idx = sphere()
floor_pos = [-6, -1, -4, 6, -1, -4, 6, -1, 5, -6, -1, 5]
floor_nor = [0, 1, 0] * 4
floor_idx = [0, 2, 1, 0, 3, 2]
parts = [array.array("f", pos), array.array("f", nor), array.array("I", idx),
         array.array("f", floor_pos), array.array("f", floor_nor), array.array("I", floor_idx)]
blob, views, offset = b"", [], 0
for p in parts:
    b = p.tobytes()
    views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b)})
    blob += b
    offset += len(b)
def acc(view, count, kind, comp, extra=None):
    a = {"bufferView": view, "componentType": comp, "count": count, "type": kind}
    a.update(extra or {})
    return a
accessors = [
    acc(0, len(pos) // 3, "VEC3", 5126, {"min": [-1, -1, -1], "max": [1, 1, 1]}),
    acc(1, len(nor) // 3, "VEC3", 5126),
    acc(2, len(idx), "SCALAR", 5125),
    acc(3, 4, "VEC3", 5126, {"min": [-6, -1, -4], "max": [6, -1, 5]}),
    acc(4, 4, "VEC3", 5126),
    acc(5, 6, "SCALAR", 5125),
]
materials, meshes, nodes = [], [], []
roughness = [0.0, 0.25, 0.5, 1.0]
rows = [("metallic 0", 0.0, 0.0), ("metallic 0.5", 0.5, 0.0), ("metallic 1", 1.0, 0.0), ("transmission 1", 0.0, 1.0)]
for r, (name, metal, transmission) in enumerate(rows):
    for c, rough in enumerate(roughness):
        m = {"name": f"{name}, roughness {rough}",
             "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.55, 0.2, 1], "metallicFactor": metal, "roughnessFactor": rough}}
        if transmission:
            m["pbrMetallicRoughness"]["baseColorFactor"] = [0.8, 0.9, 1.0, 1]
            m["extensions"] = {"KHR_materials_transmission": {"transmissionFactor": transmission},
                               "KHR_materials_ior": {"ior": 1.5}}
        materials.append(m)
        meshes.append({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": len(materials) - 1}]})
        nodes.append({"mesh": len(meshes) - 1, "name": m["name"],
                      "translation": [(c - 1.5) * 2.4, 0, (r - 1.5) * 2.4], "scale": [0.95, 0.95, 0.95]})
materials.append({"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}})
meshes.append({"primitives": [{"attributes": {"POSITION": 3, "NORMAL": 4}, "indices": 5, "material": len(materials) - 1}]})
nodes.append({"mesh": len(meshes) - 1, "name": "floor"})
# Camera above and in front, looking down at the grid.
eye, target = (0.0, 9.0, 11.0), (0.0, -0.5, 0.5)
d = [t - e for t, e in zip(target, eye)]
pitch = math.atan2(-d[1], -d[2])
nodes.append({"camera": 0, "name": "camera", "translation": list(eye),
              "rotation": [-math.sin(pitch / 2), 0, 0, math.cos(pitch / 2)]})
nodes.append({"name": "light", "translation": [-4, 10, 6], "extensions": {"KHR_lights_punctual": {"light": 0}}})
doc = {
    "asset": {"version": "2.0", "generator": "twinray docs/images/pbr_grid.py"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 150.0, "color": [1, 1, 1]}]}},
    "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}],
    "nodes": nodes, "meshes": meshes, "materials": materials,
    "cameras": [{"type": "perspective", "name": "camera", "perspective": {"yfov": 0.75, "znear": 0.1, "aspectRatio": 4 / 3}}],
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": views, "accessors": accessors,
}
with open(sys.argv[1] if len(sys.argv) > 1 else "pbr-grid.gltf", "w") as f:
    json.dump(doc, f)
