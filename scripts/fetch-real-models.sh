#!/usr/bin/env bash
# Fetches real OBJ/MTL and glTF models written by other tools, checks them and
# renders each with twinray. Nothing here is needed by the tests (they use the
# small files committed under crates/twinray/tests/data/models).
#
#   scripts/fetch-real-models.sh [DIR]      (default DIR: models/, git-ignored)
#
# Needs: pip, npm, node, and a release build of twinray (cargo build --release).
# Sources, all from the package registries:
#   * PyPI `pybullet` 3.2.7: the wheel's pybullet_data folder (zlib licence):
#     textured OBJ/MTL models exported by Blender and Maya;
#   * PyPI `genesis-world` 1.4.5, `gradio` 6.31.0, `pyvista` 0.49.2 and
#     `pymeshfix` 0.18.1, with pybullet: the 50 OBJ, STL and PLY meshes of
#     scripts/upright.txt, in upright/ (the up-axis measurement, below);
#   * npm `bunny` 1.0.1: the Stanford bunny (positions and cells as JSON);
#   * npm `obj2gltf` 3.2.0 (Cesium) turns each OBJ into .gltf and .glb;
#   * npm `gltf-validator` 2.0.0-dev.3.10 (Khronos) checks every glTF file.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=$(realpath -m "${1:-$root/models}")
twinray=${TWINRAY:-$root/target/release/twinray}
mkdir -p "$out" && cd "$out"

echo "== wheels (PyPI pybullet 3.2.7, genesis-world 1.4.5, gradio 6.31.0, pyvista 0.49.2, pymeshfix 0.18.1)"
for pkg in pybullet==3.2.7 genesis-world==1.4.5 gradio==6.31.0 pyvista==0.49.2 pymeshfix==0.18.1; do
    name=${pkg%%==*}
    ls wheel/"${name//-/_}"-*.whl >/dev/null 2>&1 ||
        pip download --quiet "$pkg" --no-deps --only-binary :all: -d wheel
done

echo "== pybullet_data (PyPI pybullet 3.2.7)"
if [ ! -d pybullet_data ]; then
    python3 - <<'PY'
import glob, zipfile
wheel = zipfile.ZipFile(glob.glob("wheel/pybullet-*.whl")[0])
wanted = ("duck.obj", "duck.mtl", "duckCM.png", "cube.png",
          "torus/torus_textured.obj", "torus/torus_textured.mtl",
          "domino/domino.obj", "domino/domino.mtl", "domino/domino.jpg",
          "jenga/jenga.obj", "jenga/jenga.mtl", "jenga/jenga.png",
          "table/table.obj", "table/table.mtl", "table/table.png",
          "tray/tray_textured.obj", "tray/tray_textured.mtl", "tray/tray.jpg",
          "soccerball.obj", "soccerball.mtl", "colors16.png",
          "samurai_monastry.obj", "sphere_smooth.obj", "cube.obj")
for name in wanted:
    try:
        wheel.extract("pybullet_data/" + name, ".")
    except KeyError:
        print("not in the wheel:", name)
PY
fi

echo "== the up-axis set (scripts/upright.txt) in upright/"
python3 - "$root/scripts/upright.txt" <<'PY'
import glob, os, posixpath, sys, zipfile
wheels = {}
for line in open(sys.argv[1]):
    if line.startswith("#") or not line.strip():
        continue
    package, path, _ = line.split()
    if package not in wheels:
        wheels[package] = zipfile.ZipFile(glob.glob("wheel/%s-*.whl" % package)[0])
    wheel = wheels[package]
    names = set(wheel.namelist())
    dest = os.path.join("upright", package, path)
    if os.path.exists(dest):
        continue
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    with open(dest, "wb") as f:
        f.write(wheel.read(path))
    # An OBJ's material library, and the textures it names, beside it.
    if not path.endswith(".obj"):
        continue
    folder = posixpath.dirname(path)
    for obj_line in open(dest, errors="replace"):
        if not obj_line.startswith("mtllib"):
            continue
        mtl = posixpath.join(folder, obj_line.split(None, 1)[1].strip())
        if mtl not in names:
            continue
        mtl_dest = os.path.join("upright", package, mtl)
        with open(mtl_dest, "wb") as f:
            f.write(wheel.read(mtl))
        for mtl_line in open(mtl_dest, errors="replace"):
            words = mtl_line.split()
            texture = words and posixpath.join(folder, words[-1])
            if words and words[0].lower().startswith("map_") and texture in names:
                os.makedirs(os.path.dirname(os.path.join("upright", package, texture)), exist_ok=True)
                with open(os.path.join("upright", package, texture), "wb") as f:
                    f.write(wheel.read(texture))
PY

echo "== Stanford bunny (npm bunny 1.0.1) as OBJ"
if [ ! -f bunny.obj ]; then
    npm pack --silent bunny@1.0.1 >/dev/null
    tar xzf bunny-1.0.1.tgz && rm bunny-1.0.1.tgz
    node -e '
const b = require("./package/index.js");
const lines = ["# Stanford bunny, from the npm package bunny 1.0.1"];
for (const p of b.positions) lines.push("v " + p.join(" "));
for (const c of b.cells) lines.push("f " + c.map(i => i + 1).join(" "));
require("fs").writeFileSync("bunny.obj", lines.join("\n") + "\n");'
    rm -rf package
fi

echo "== obj2gltf and gltf-validator (npm)"
if [ ! -d node_modules/obj2gltf ] || [ ! -d node_modules/gltf-validator ]; then
    npm install --silent --no-audit --no-fund obj2gltf@3.2.0 gltf-validator@2.0.0-dev.3.10
fi
cp "$root/scripts/validate-gltf.js" .
mapfile -t objs < <(find . -name '*.obj' -not -path './node_modules/*' -not -path './upright/*' | sort)
for obj in "${objs[@]}"; do
    base=${obj%.obj}
    [ -f "$base.glb" ] || node node_modules/obj2gltf/bin/obj2gltf.js -i "$obj" -o "$base.glb" >/dev/null
    [ -f "$base.gltf" ] || node node_modules/obj2gltf/bin/obj2gltf.js -i "$obj" -o "$base.gltf" >/dev/null
done
mapfile -t gltfs < <(find . \( -name '*.glb' -o -name '*.gltf' \) -not -path './node_modules/*' -not -path './upright/*' | sort)
node validate-gltf.js "${gltfs[@]}"

echo "== twinray renders (64x48, stereo anaglyph)"
mkdir -p renders
for f in "${objs[@]}" "${gltfs[@]}"; do
    name=$(echo "${f#./}" | tr '/' '_')
    if "$twinray" render "$f" -o "renders/$name.png" --size 64x48 --stereo --interaxial 0.05 \
        --layout anaglyph -q 2>"renders/$name.log"; then
        echo "ok    $f"
    else
        echo "FAIL  $f: $(tail -1 "renders/$name.log")"
    fi
done

echo "== up axis on the upright set (the axis twinray's note names against scripts/upright.txt)"
good=0 total=0
while read -r package path want; do
    [[ $package == \#* || -z $package ]] && continue
    got=$("$twinray" render "upright/$package/$path" -o renders/upright.png --size 32x24 \
        --samples 1 2>&1 | sed -nE 's/.*: up axis ([yz]) .*/\1/p' | head -1)
    total=$((total + 1))
    if [ "$got" = "$want" ]; then
        good=$((good + 1))
    else
        echo "lies down: $package $path (up axis ${got:-?}, upright is $want)"
    fi
done < "$root/scripts/upright.txt"
echo "upright: $good of $total"
