#!/usr/bin/env python3
"""Writes a height-field terrain as one mesh: NX x NZ cells, two triangles
each (1000 x 500 = 1,000,000 triangles by default), indexed, with normals.

    python3 bench/make_terrain_gltf.py OUT.glb [NX NZ]

.glb gives one binary glTF file; .gltf gives JSON with an external .bin next
to it; .obj gives the same triangles as Wavefront OBJ (v, vn, f v//vn); .stl
gives them as binary STL (a face normal and three vertices per triangle);
.ply as binary little-endian PLY (float x y z vertices, uchar/int index lists).
Only the standard library is used (array, struct, json).
"""
import array, json, math, struct, sys

out = sys.argv[1]
nx = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
nz = int(sys.argv[3]) if len(sys.argv) > 3 else 500

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
