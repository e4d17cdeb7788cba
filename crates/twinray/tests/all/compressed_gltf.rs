//! GLB files whose meshes need a geometry-compression extension twinray does
//! not decode: one line naming the extension and the way to decompress.

use serde_json::json;
use twinray::loaders::{load_scene, LoadOptions};

/// A GLB (JSON chunk only) of one Draco- or meshopt-compressed triangle: the
/// accessors have no buffer view of their own, as such exporters write them.
fn compressed_glb(ext: &str) -> Vec<u8> {
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": [ext],
        "extensionsRequired": [ext],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0},
            "indices": 1,
            "extensions": {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}
        }]}],
        "buffers": [{"byteLength": 16}],
        "bufferViews": [{"buffer": 0, "byteLength": 16}],
        "accessors": [
            {"componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"componentType": 5123, "count": 3, "type": "SCALAR"}
        ]
    });
    let mut json = doc.to_string().into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb
}

#[test]
fn compressed_meshes_are_refused_in_one_line_naming_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["KHR_draco_mesh_compression", "EXT_meshopt_compression"] {
        let path = dir.path().join("controller.glb");
        std::fs::write(&path, compressed_glb(ext)).unwrap();
        let err = load_scene(&path, &LoadOptions::default())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains(ext), "{ext}: {err}");
        assert!(err.contains("gltf-transform"), "{err}");
        assert!(err.contains("controller.glb"), "{err}");
        assert!(
            !err.contains('\n') && !err.contains("more problems"),
            "{err}"
        );
    }
}
