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
#   * npm `bunny` 1.0.1: the Stanford bunny (positions and cells as JSON);
#   * npm `obj2gltf` 3.2.0 (Cesium) turns each OBJ into .gltf and .glb;
#   * npm `gltf-validator` 2.0.0-dev.3.10 (Khronos) checks every glTF file.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=$(realpath -m "${1:-$root/models}")
twinray=${TWINRAY:-$root/target/release/twinray}
mkdir -p "$out" && cd "$out"

echo "== pybullet_data (PyPI pybullet 3.2.7)"
if [ ! -d pybullet_data ]; then
    pip download --quiet pybullet==3.2.7 --no-deps --only-binary :all: -d wheel
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
    rm -rf wheel
fi

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
mapfile -t objs < <(find . -name '*.obj' -not -path './node_modules/*' | sort)
for obj in "${objs[@]}"; do
    base=${obj%.obj}
    [ -f "$base.glb" ] || node node_modules/obj2gltf/bin/obj2gltf.js -i "$obj" -o "$base.glb" >/dev/null
    [ -f "$base.gltf" ] || node node_modules/obj2gltf/bin/obj2gltf.js -i "$obj" -o "$base.gltf" >/dev/null
done
mapfile -t gltfs < <(find . \( -name '*.glb' -o -name '*.gltf' \) -not -path './node_modules/*' | sort)
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
