#!/usr/bin/env python3
"""Writes a height-field terrain as one mesh: NX x NZ cells, two triangles
each (1000 x 500 = 1,000,000 triangles by default), indexed, with normals.

    python3 bench/make_terrain_gltf.py OUT.glb [NX NZ] [--animated]

.glb gives one binary glTF file; .gltf gives JSON with an external .bin next
to it; .obj gives the same triangles as Wavefront OBJ (v, vn, f v//vn); .stl
gives them as binary STL (a face normal and three vertices per triangle);
.ply as binary little-endian PLY (float x y z vertices, uchar/int index lists).
--animated (glTF only) adds a small cube (12 triangles) on a second node
that slides across the terrain and turns over 2 seconds (animation "slide"):
a large static scene with one small moving node, for
`cargo bench -p twinray-bench --bench animated_instances`.
Only the standard library is used (array, struct, json).
"""
import array, json, math, struct, sys

animated = "--animated" in sys.argv
argv = [a for a in sys.argv if a != "--animated"]
out = argv[1]
nx = int(argv[2]) if len(argv) > 2 else 1000
nz = int(argv[3]) if len(argv) > 3 else 500

def height(x, z):
    return 0.05 * math.sin(x * 0.11) * math.cos(z * 0.07) + 0.02 * math.sin(x * 0.53 + z * 0.31)

pos = array.array("f")
nor = array.array("f")
for j in range(nz + 1):
    for i in range(nx + 1):
        x, z = i / nx * 4 - 2, j / nz * 2 - 1
        y = height(i, j)
        pos.extend((x, y, z))
        dx = (height(i + 1, j) - height(i - 1, j)) / (2 * 4 / nx)
        dz = (height(i, j + 1) - height(i, j - 1)) / (2 * 2 / nz)
        l = math.sqrt(dx * dx + 1 + dz * dz)
        nor.extend((-dx / l, 1 / l, -dz / l))
idx = array.array("I")
w = nx + 1
for j in range(nz):
    for i in range(nx):
        a = j * w + i
        idx.extend((a, a + w, a + 1, a + 1, a + w, a + w + 1))
blobs = [pos.tobytes(), nor.tobytes(), idx.tobytes()]
offsets = [0, len(blobs[0]), len(blobs[0]) + len(blobs[1])]
binary = b"".join(blobs)
n = (nx + 1) * (nz + 1)
doc = {
    "asset": {"version": "2.0", "generator": "twinray bench/make_terrain_gltf.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "name": "terrain"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.5, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
    "buffers": [{"byteLength": len(binary)}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": offsets[0], "byteLength": len(blobs[0]), "target": 34962},
        {"buffer": 0, "byteOffset": offsets[1], "byteLength": len(blobs[1]), "target": 34962},
        {"buffer": 0, "byteOffset": offsets[2], "byteLength": len(blobs[2]), "target": 34963},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
         "min": [min(pos[0::3]), min(pos[1::3]), min(pos[2::3])],
         "max": [max(pos[0::3]), max(pos[1::3]), max(pos[2::3])]},
        {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
    ],
}
if animated:
    # A cube of half-side 0.1 (its own mesh, node 1), moved along x from -1.5
    # to 1.5 and turned half a turn about y, linearly over 2 seconds.
    cube = array.array("f", [c for k in range(8) for c in ((k & 1) * 0.2 - 0.1, (k >> 1 & 1) * 0.2 - 0.1, (k >> 2 & 1) * 0.2 - 0.1)])
    cube_idx = array.array("I", [0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5])
    times = array.array("f", [0.0, 1.0, 2.0])
    moves = array.array("f", [-1.5, 0.3, 0.0, 0.0, 0.3, 0.0, 1.5, 0.3, 0.0])
    s = math.sqrt(0.5)
    turns = array.array("f", [0, 0, 0, 1, 0, s, 0, s, 0, 1, 0, 0])
    for data, count, kind, target in [(cube, 8, "VEC3", 34962), (cube_idx, 36, "SCALAR", 34963),
                                      (times, 3, "SCALAR", None), (moves, 3, "VEC3", None), (turns, 3, "VEC4", None)]:
        view = {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data.tobytes())}
        if target:
            view["target"] = target
        doc["bufferViews"].append(view)
        acc = {"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5125 if data is cube_idx else 5126,
               "count": count, "type": kind}
        if data is cube:
            acc["min"], acc["max"] = [-0.1] * 3, [0.1] * 3
        if data is times:
            acc["min"], acc["max"] = [0.0], [2.0]
        doc["accessors"].append(acc)
        binary += data.tobytes()
    doc["buffers"][0]["byteLength"] = len(binary)
    a = len(doc["accessors"]) - 5
    doc["meshes"].append({"primitives": [{"attributes": {"POSITION": a}, "indices": a + 1, "material": 1}]})
    doc["materials"].append({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 0.5}})
    doc["nodes"].append({"mesh": 1, "name": "mover"})
    doc["scenes"][0]["nodes"].append(1)
    doc["animations"] = [{"name": "slide", "samplers": [
        {"input": a + 2, "output": a + 3, "interpolation": "LINEAR"},
        {"input": a + 2, "output": a + 4, "interpolation": "LINEAR"}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}},
                     {"sampler": 1, "target": {"node": 1, "path": "rotation"}}]}]
if out.endswith(".obj"):
    with open(out, "w") as f:
        f.write("o terrain\n")
        f.write("".join("v %.6f %.6f %.6f\n" % tuple(pos[k:k + 3]) for k in range(0, len(pos), 3)))
        f.write("".join("vn %.6f %.6f %.6f\n" % tuple(nor[k:k + 3]) for k in range(0, len(nor), 3)))
        f.write("".join("f %d//%d %d//%d %d//%d\n" % (idx[k] + 1, idx[k] + 1, idx[k + 1] + 1, idx[k + 1] + 1, idx[k + 2] + 1, idx[k + 2] + 1)
                        for k in range(0, len(idx), 3)))
elif out.endswith(".stl"):
    with open(out, "wb") as f:
        f.write(b"twinray bench/make_terrain_gltf.py".ljust(80, b" "))
        f.write(struct.pack("<I", len(idx) // 3))
        tri = struct.Struct("<12fH")
        chunk = []
        for k in range(0, len(idx), 3):
            a, b, c = (idx[k + j] * 3 for j in range(3))
            pa, pb, pc = pos[a:a + 3], pos[b:b + 3], pos[c:c + 3]
            u = [pb[j] - pa[j] for j in range(3)]
            v = [pc[j] - pa[j] for j in range(3)]
            nx_, ny_, nz_ = u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]
            l = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_) or 1.0
            chunk.append(tri.pack(nx_ / l, ny_ / l, nz_ / l, *pa, *pb, *pc, 0))
            if len(chunk) == 65536:
                f.write(b"".join(chunk))
                chunk = []
        f.write(b"".join(chunk))
elif out.endswith(".ply"):
    with open(out, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\ncomment twinray bench/make_terrain_gltf.py\n"
                 "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
                 % (n, len(idx) // 3)).encode())
        f.write(pos.tobytes())
        faces = bytearray()
        face = struct.Struct("<B3i")
        for k in range(0, len(idx), 3):
            faces += face.pack(3, idx[k], idx[k + 1], idx[k + 2])
        f.write(faces)
elif out.endswith(".glb"):
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    with open(out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)
else:
    bin_name = out.rsplit("/", 1)[-1].rsplit(".", 1)[0] + ".bin"
    doc["buffers"][0]["uri"] = bin_name
    with open(out.rsplit("/", 1)[0] + "/" + bin_name if "/" in out else bin_name, "wb") as f:
        f.write(binary)
    with open(out, "w") as f:
        json.dump(doc, f)
print(f"{out}: {len(idx) // 3} triangles, {n} vertices")
