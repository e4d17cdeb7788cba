//! glTF animations of node transforms and morph-target weights: the
//! channels' samplers (linear, step, cubic spline) evaluated at a time, giving
//! the animated nodes' local transforms for the hierarchy walk and their
//! meshes' morph weights. Every animation of the file plays at once unless
//! one is chosen (`LoadOptions::animation`, `--animation NAME|INDEX`).

use std::collections::HashMap;

use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};

use super::Loader;
use crate::Result;

/// Whether the file's document has animations (read without its buffers).
pub fn has_animations(bytes: &[u8]) -> bool {
    gltf::Gltf::from_slice_without_validation(bytes)
        .map(|g| g.document.animations().next().is_some())
        .unwrap_or(false)
}

/// The animated part of a pose: local transforms and morph weights of the
/// nodes the channels animate.
#[derive(Default)]
pub struct Pose {
    pub locals: HashMap<usize, Mat4>,
    pub weights: HashMap<usize, Vec<f32>>,
}

impl Pose {
    /// The morph weights of `node`'s instance of `mesh`: animated, else the
    /// node's, else the mesh's (empty: none).
    pub fn weights_of(&self, node: &gltf::Node, mesh: &gltf::Mesh) -> Vec<f32> {
        match self.weights.get(&node.index()) {
            Some(w) => w.clone(),
            None => node.weights().or(mesh.weights()).unwrap_or(&[]).to_vec(),
        }
    }
}

impl Loader<'_> {
    /// The animation `LoadOptions::animation` names, by name or index
    /// (`None`: no choice, all play); an unknown one is refused with the
    /// list of those the file has.
    pub(super) fn chosen_animation(&self) -> Result<Option<usize>> {
        let Some(wanted) = self.opts.animation.as_deref() else {
            return Ok(None);
        };
        let names: Vec<String> = self
            .doc
            .animations()
            .map(|a| match a.name() {
                Some(n) => format!("{} '{n}'", a.index()),
                None => format!("{} (unnamed)", a.index()),
            })
            .collect();
        let found = self
            .doc
            .animations()
            .find(|a| a.name() == Some(wanted))
            .or_else(|| {
                let i: usize = wanted.parse().ok()?;
                self.doc.animations().nth(i)
            });
        match found {
            Some(a) => Ok(Some(a.index())),
            None if names.is_empty() => Err(self.err(format!(
                "--animation '{wanted}': the file has no animations"
            ))),
            None => Err(self.err(format!(
                "--animation '{wanted}': no such animation; the file has {}",
                names.join(", ")
            ))),
        }
    }

    /// The pose at `time` seconds of every node the animations (or the one
    /// `clip`) animate: the node's own translation, rotation and scale with
    /// the animated ones replaced by their samplers' values, and animated
    /// morph weights (held before the first key and after the last).
    pub(super) fn animated_pose(
        &self,
        doc: &gltf::Document,
        buffers: &[Vec<u8>],
        time: f32,
        clip: Option<usize>,
    ) -> Result<Pose> {
        let mut poses: HashMap<usize, (Vec3, Quat, Vec3)> = HashMap::new();
        let mut weights: HashMap<usize, Vec<f32>> = HashMap::new();
        for anim in doc.animations() {
            if clip.is_some_and(|c| c != anim.index()) {
                continue;
            }
            for channel in anim.channels() {
                let what = format!("animations[{}].channels[{}]", anim.index(), channel.index());
                let property = channel.target().property();
                let width = match property {
                    Property::Translation | Property::Scale => 3,
                    Property::Rotation => 4,
                    Property::MorphTargetWeights => 1,
                };
                let sampler = channel.sampler();
                let input = self.accessor(
                    &sampler.input(),
                    buffers,
                    Dimensions::Scalar,
                    &[DataType::F32],
                )?;
                let times: Vec<f32> = (0..input.count).map(|i| input.float(i, 0)).collect();
                if times.is_empty()
                    || times.iter().any(|t| !t.is_finite())
                    || times.windows(2).any(|w| w[1] <= w[0])
                {
                    return Err(
                        self.err(format!("{what}: key times must be finite and increasing"))
                    );
                }
                let dims = match width {
                    1 => Dimensions::Scalar,
                    3 => Dimensions::Vec3,
                    _ => Dimensions::Vec4,
                };
                let output = self.accessor(&sampler.output(), buffers, dims, &[DataType::F32])?;
                let interpolation = sampler.interpolation();
                let per_key = if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
                let node = channel.target().node();
                if property == Property::MorphTargetWeights {
                    // One weight per morph target, for every key.
                    let keys = times.len() * per_key;
                    if output.count % keys != 0 {
                        return Err(self.err(format!(
                            "{what}: {} weights for {} key times is not a whole number of weights a key",
                            output.count,
                            times.len()
                        )));
                    }
                    let targets = output.count / keys;
                    let w = (0..targets)
                        .map(|j| {
                            let value = |k: usize| Vec4::splat(output.float(k * targets + j, 0));
                            sample(&times, &value, interpolation, time, false).x
                        })
                        .collect();
                    weights.insert(node.index(), w);
                    continue;
                }
                if output.count != times.len() * per_key {
                    return Err(self.err(format!(
                        "{what}: {} output values for {} key times ({:?} takes {per_key} a key)",
                        output.count,
                        times.len(),
                        interpolation
                    )));
                }
                let value = |k: usize| {
                    let c = |i| if i < width { output.float(k, i) } else { 0.0 };
                    Vec4::new(c(0), c(1), c(2), c(3))
                };
                let v = sample(&times, &value, interpolation, time, width == 4);
                let pose = poses.entry(node.index()).or_insert_with(|| {
                    let (t, r, s) = node.transform().decomposed();
                    (Vec3::from(t), Quat::from_array(r), Vec3::from(s))
                });
                match property {
                    Property::Translation => pose.0 = v.truncate(),
                    Property::Rotation => pose.1 = Quat::from_vec4(v).normalize(),
                    Property::Scale => pose.2 = v.truncate(),
                    Property::MorphTargetWeights => {}
                }
            }
        }
        Ok(Pose {
            locals: poses
                .into_iter()
                .map(|(i, (t, r, s))| (i, Mat4::from_scale_rotation_translation(s, r, t)))
                .collect(),
            weights,
        })
    }
}

/// A sampler's value at `time`. `value(k)` is output element `k` (for a
/// cubic spline, keys come as in-tangent, value, out-tangent). Rotations
/// interpolate linearly by slerp, and are normalised by the caller.
pub fn sample(
    times: &[f32],
    value: &dyn Fn(usize) -> Vec4,
    interpolation: Interpolation,
    time: f32,
    rotation: bool,
) -> Vec4 {
    let cubic = interpolation == Interpolation::CubicSpline;
    let key = |k: usize| if cubic { value(3 * k + 1) } else { value(k) };
    let last = times.len() - 1;
    if time <= times[0] {
        return key(0);
    }
    if time >= times[last] {
        return key(last);
    }
    let k = times.partition_point(|&t| t <= time) - 1;
    let dt = times[k + 1] - times[k];
    let s = (time - times[k]) / dt;
    match interpolation {
        Interpolation::Step => key(k),
        Interpolation::Linear if rotation => {
            let (a, b) = (Quat::from_vec4(key(k)), Quat::from_vec4(key(k + 1)));
            Vec4::from(a.slerp(b, s))
        }
        Interpolation::Linear => key(k).lerp(key(k + 1), s),
        Interpolation::CubicSpline => {
            let (s2, s3) = (s * s, s * s * s);
            let (v0, b0) = (value(3 * k + 1), value(3 * k + 2));
            let (a1, v1) = (value(3 * (k + 1)), value(3 * (k + 1) + 1));
            v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                + b0 * (dt * (s3 - 2.0 * s2 + s))
                + v1 * (-2.0 * s3 + 3.0 * s2)
                + a1 * (dt * (s3 - s2))
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use serde_json::json;

    use super::super::parse_gltf;
    use super::super::tests::{data_uri, mesh_bytes, one_mesh};
    use crate::loaders::LoadOptions;
    use crate::math::Vec3;

    const QUAD: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    const QUAD_INDICES: [u32; 6] = [0, 1, 2, 0, 2, 3];

    /// A unit quad on a node whose translation (linear), rotation (step)
    /// and scale (cubic spline) are animated.
    fn animated_quad() -> serde_json::Value {
        let mut doc = one_mesh(
            &QUAD,
            &QUAD_INDICES,
            &data_uri(&mesh_bytes(&QUAD, &QUAD_INDICES)),
        );
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let floats: Vec<f32> = [
            vec![0.0, 2.0],                           // times of translation
            vec![0.0, 0.0, 0.0, 4.0, 0.0, 0.0],       // translation keys
            vec![0.0, 1.0],                           // times of rotation, scale
            vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, h, h], // identity, 90 deg about z
            vec![
                0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, // in, value, out of key 0
                0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 0.0, 0.0, 0.0,
            ], // of key 1
        ]
        .concat();
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = |offset: usize, floats: usize| json!({"buffer": 1, "byteOffset": offset * 4, "byteLength": floats * 4});
        doc["buffers"]
            .as_array_mut()
            .unwrap()
            .push(json!({"byteLength": bytes.len(), "uri": data_uri(&bytes)}));
        let views = doc["bufferViews"].as_array_mut().unwrap();
        views.extend([
            view(0, 2),
            view(2, 6),
            view(8, 2),
            view(10, 8),
            view(18, 18),
        ]);
        let acc = |view: usize, count: usize, kind: &str| json!({"bufferView": view, "componentType": 5126, "count": count, "type": kind});
        let accessors = doc["accessors"].as_array_mut().unwrap();
        let mut t0 = acc(2, 2, "SCALAR");
        t0["min"] = json!([0.0]);
        t0["max"] = json!([2.0]);
        let mut t1 = acc(4, 2, "SCALAR");
        t1["min"] = json!([0.0]);
        t1["max"] = json!([1.0]);
        accessors.extend([
            t0,
            acc(3, 2, "VEC3"),
            t1,
            acc(5, 2, "VEC4"),
            acc(6, 6, "VEC3"),
        ]);
        doc["animations"] = json!([{
            "samplers": [
                {"input": 2, "output": 3, "interpolation": "LINEAR"},
                {"input": 4, "output": 5, "interpolation": "STEP"},
                {"input": 4, "output": 6, "interpolation": "CUBICSPLINE"}
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 0, "path": "translation"}},
                {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 2, "target": {"node": 0, "path": "scale"}}
            ]
        }]);
        doc
    }

    fn bounds_at(doc: &serde_json::Value, time: Option<f32>) -> (Vec3, Vec3) {
        let opts = LoadOptions {
            animation_time: time,
            ..LoadOptions::default()
        };
        let s = parse_gltf(doc.to_string().as_bytes(), Path::new("a.gltf"), &opts).unwrap();
        let b = s.bounds();
        (b.min, b.max)
    }

    fn close(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
        (a.0 - b.0).abs().max_element() < 1e-5 && (a.1 - b.1).abs().max_element() < 1e-5
    }

    #[test]
    fn node_transforms_follow_linear_step_and_cubic_samplers() {
        let doc = animated_quad();
        assert!(super::has_animations(doc.to_string().as_bytes()));
        let v = |x, y, z| Vec3::new(x, y, z);
        // No time: the node's own transform (identity).
        assert!(close(bounds_at(&doc, None), (v(0., 0., 0.), v(1., 1., 0.))));
        // Before the first keys: the first values.
        assert!(close(
            bounds_at(&doc, Some(-1.0)),
            (v(0., 0., 0.), v(1., 1., 0.))
        ));
        // t = 0.5: translation 4 * 0.5/2 = 1 along x; rotation still the
        // first step; scale by the Hermite basis at s = 0.5:
        // 0.5 * 1 + 0.125 * 2 (out-tangent, dt 1) + 0.5 * 3 - 0.125 * 0 = 2.25.
        let b = bounds_at(&doc, Some(0.5));
        assert!(close(b, (v(1., 0., 0.), v(3.25, 2.25, 0.))), "{b:?}");
        // t = 1.5: translation 3; rotation 90 degrees about z: (x, y) -> (-y, x);
        // scale held at the last key, 3. The quad [0,3]^2 turns to
        // [-3,0]x[0,3], then moves by 3 along x.
        let b = bounds_at(&doc, Some(1.5));
        assert!(close(b, (v(0., 0., 0.), v(3., 3., 0.))), "{b:?}");
        // Past the end: translation 4.
        let b = bounds_at(&doc, Some(9.0));
        assert!(close(b, (v(1., 0., 0.), v(4., 3., 0.))), "{b:?}");
    }

    fn bounds_of(doc: &serde_json::Value, time: f32, clip: &str) -> Result<(Vec3, Vec3), String> {
        let opts = LoadOptions {
            animation_time: Some(time),
            animation: Some(clip.into()),
            ..LoadOptions::default()
        };
        let s = parse_gltf(doc.to_string().as_bytes(), Path::new("a.gltf"), &opts)
            .map_err(|e| e.to_string())?;
        let b = s.bounds();
        Ok((b.min, b.max))
    }

    #[test]
    fn one_animation_is_chosen_by_name_or_index() {
        let mut doc = animated_quad();
        doc["animations"][0]["name"] = json!("Walk");
        // A second animation of the same node: only its scale (the cubic
        // spline of the first).
        doc["animations"].as_array_mut().unwrap().push(json!({
            "name": "Grow",
            "samplers": [{"input": 4, "output": 6, "interpolation": "CUBICSPLINE"}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "scale"}}]
        }));
        let v = |x, y, z| Vec3::new(x, y, z);
        // "Grow" alone at t = 0.5: scale 2.25 (see above), no move, no turn.
        for clip in ["Grow", "1"] {
            let b = bounds_of(&doc, 0.5, clip).unwrap();
            assert!(
                close(b, (v(0., 0., 0.), v(2.25, 2.25, 0.))),
                "{clip}: {b:?}"
            );
        }
        // "Walk" at t = 1.5 moves, turns and scales, as all of them did.
        let b = bounds_of(&doc, 1.5, "Walk").unwrap();
        assert!(close(b, (v(0., 0., 0.), v(3., 3., 0.))), "{b:?}");
        let b = bounds_of(&doc, 1.5, "0").unwrap();
        assert!(close(b, (v(0., 0., 0.), v(3., 3., 0.))), "{b:?}");
        let e = bounds_of(&doc, 0.5, "Jump").unwrap_err();
        assert!(
            e.contains("--animation 'Jump'") && e.contains("0 'Walk', 1 'Grow'"),
            "{e}"
        );
        let e = bounds_of(&doc, 0.5, "2").unwrap_err();
        assert!(e.contains("no such animation"), "{e}");
        doc.as_object_mut().unwrap().remove("animations");
        let e = bounds_of(&doc, 0.5, "Walk").unwrap_err();
        assert!(e.contains("the file has no animations"), "{e}");
    }

    /// A triangle with normals and two morph targets, whose weights go
    /// linearly from (0, 0) at t = 0 to (1, 0.5) at t = 1; the mesh's own
    /// weights are (1, 0).
    fn morphing_triangle() -> serde_json::Value {
        const TRI: [[f32; 3]; 3] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
        let mut doc = one_mesh(&TRI, &[0, 1, 2], &data_uri(&mesh_bytes(&TRI, &[0, 1, 2])));
        let floats: Vec<f32> = [
            vec![0., 0., 1., 0., 0., 1., 0., 0., 1.], // normals
            vec![0., 0., 2., 0., 0., 0., 0., 0., 0.], // target 0: vertex 0 up by 2
            vec![1., 0., 0., 0., 0., 0., 0., 0., 0.], // target 0: vertex 0's normal tilts
            vec![0., 0., 0., 2., 0., 0., 0., 0., 0.], // target 1: vertex 1 out by 2
            vec![0.0, 1.0],                           // key times
            vec![0.0, 0.0, 1.0, 0.5],                 // weights of keys 0 and 1
            vec![0.; 9],                              // target 1's normals
        ]
        .concat();
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        doc["buffers"]
            .as_array_mut()
            .unwrap()
            .push(json!({"byteLength": bytes.len(), "uri": data_uri(&bytes)}));
        let views = doc["bufferViews"].as_array_mut().unwrap();
        for (offset, floats) in [(0, 9), (9, 9), (18, 9), (27, 9), (36, 2), (38, 4), (42, 9)] {
            views.push(json!({"buffer": 1, "byteOffset": offset * 4, "byteLength": floats * 4}));
        }
        let acc = |view: usize, count: usize, kind: &str| json!({"bufferView": view, "componentType": 5126, "count": count, "type": kind});
        let mut times = acc(6, 2, "SCALAR");
        times["min"] = json!([0.0]);
        times["max"] = json!([1.0]);
        let mut t0 = acc(3, 3, "VEC3");
        t0["min"] = json!([0, 0, 0]);
        t0["max"] = json!([0, 0, 2]);
        let mut t1 = acc(5, 3, "VEC3");
        t1["min"] = json!([0, 0, 0]);
        t1["max"] = json!([2, 0, 0]);
        doc["accessors"].as_array_mut().unwrap().extend([
            acc(2, 3, "VEC3"),   // 2: normals
            t0,                  // 3
            acc(4, 3, "VEC3"),   // 4: target 0 normals
            t1,                  // 5
            times,               // 6
            acc(7, 4, "SCALAR"), // 7: weights
            acc(8, 3, "VEC3"),   // 8: target 1 normals
        ]);
        let prim = &mut doc["meshes"][0]["primitives"][0];
        prim["attributes"]["NORMAL"] = json!(2);
        prim["targets"] = json!([{"POSITION": 3, "NORMAL": 4}, {"POSITION": 5, "NORMAL": 8}]);
        doc["meshes"][0]["weights"] = json!([1.0, 0.0]);
        doc["animations"] = json!([{
            "samplers": [{"input": 6, "output": 7, "interpolation": "LINEAR"}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}]
        }]);
        doc
    }

    /// The triangle's corners and corner normals at `time`.
    fn morphed(doc: &serde_json::Value, time: Option<f32>) -> ([Vec3; 3], [Vec3; 3]) {
        let opts = LoadOptions {
            animation_time: time,
            ..LoadOptions::default()
        };
        let s = parse_gltf(doc.to_string().as_bytes(), Path::new("m.gltf"), &opts).unwrap();
        assert_eq!(s.shapes.len(), 1);
        let crate::shapes::Shape::Triangle(t) = &s.shapes[0] else {
            panic!("{:?}", s.shapes[0])
        };
        let crate::shapes::TriangleNormals::Patch(c) = t.normals else {
            panic!("smooth")
        };
        let normals = s.corners[c as usize].normals.expect("normals");
        ([t.v0, t.v0 + t.e1, t.v0 + t.e2], normals)
    }

    #[test]
    fn morph_weights_move_positions_and_normals() {
        let doc = morphing_triangle();
        let v = |x, y, z| Vec3::new(x, y, z);
        let parallel = |a: Vec3, b: Vec3| a.cross(b).length() < 1e-6 && a.dot(b) > 0.0;
        // A still: the mesh's weights (1, 0): vertex 0 up by 2, its normal
        // (0, 0, 1) + (1, 0, 0).
        let (p, n) = morphed(&doc, None);
        assert_eq!(p, [v(0., 0., 2.), v(1., 0., 0.), v(0., 1., 0.)]);
        assert!(
            parallel(n[0], v(1., 0., 1.)) && parallel(n[1], v(0., 0., 1.)),
            "{n:?}"
        );
        // t = 0.5: weights (0.5, 0.25): vertex 0 up by 1, vertex 1 out by
        // 0.5; normal 0 is (0, 0, 1) + 0.5 (1, 0, 0).
        let (p, n) = morphed(&doc, Some(0.5));
        assert_eq!(p, [v(0., 0., 1.), v(1.5, 0., 0.), v(0., 1., 0.)]);
        assert!(parallel(n[0], v(0.5, 0., 1.)), "{n:?}");
        // t = 0: both 0, the base mesh; past the end: (1, 0.5).
        assert_eq!(
            morphed(&doc, Some(0.0)).0,
            [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)]
        );
        assert_eq!(
            morphed(&doc, Some(7.0)).0,
            [v(0., 0., 2.), v(2., 0., 0.), v(0., 1., 0.)]
        );
        // A node's weights override the mesh's.
        let mut own = doc.clone();
        own["nodes"][0]["weights"] = json!([0.0, 1.0]);
        assert_eq!(
            morphed(&own, None).0,
            [v(0., 0., 0.), v(3., 0., 0.), v(0., 1., 0.)]
        );
    }

    #[test]
    fn bad_key_times_are_refused() {
        let mut doc = animated_quad();
        doc["accessors"][2]["count"] = json!(1);
        let opts = LoadOptions {
            animation_time: Some(0.5),
            ..LoadOptions::default()
        };
        let e = parse_gltf(doc.to_string().as_bytes(), Path::new("a.gltf"), &opts)
            .unwrap_err()
            .to_string();
        assert!(e.contains("animations[0].channels[0]"), "{e}");
    }
}
