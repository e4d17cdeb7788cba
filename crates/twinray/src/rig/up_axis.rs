//! Which axis is up in a mesh file that does not say (OBJ, STL, PLY): y, the
//! convention of OBJ exporters and glTF, or z, that of CAD, 3D printing and
//! robotics (URDF: every pybullet model).
//!
//! The heuristic: a model stands on its base, and a base is wide. For each
//! candidate axis, the points of the model within a thin slab at its lowest
//! end along that axis (2 % of the model's largest side) are its support,
//! and the support's *footprint* is the area of their bounding rectangle
//! across the axis: a robot's base plate, a vehicle's four tyres, a mug's
//! bottom. The axis whose footprint is clearly the larger (1.25 times) is up;
//! otherwise the format's convention decides (z for STL, y for OBJ and PLY).
//!
//! It fails where a standing model's side is wider than its base: a tall
//! bookcase modelled y-up has a wider back than base and is laid on its
//! back, and so is a car whose flat side outspans its four tyres. The job
//! says what it chose in a note, and `--up-axis` overrides it.

use crate::math::{Aabb, Vec3};
use crate::scene::{Scene, SceneFormat};
use crate::shapes::Shape;

/// The slab at a model's lowest end, in its largest side.
pub const SUPPORT_SLAB: f32 = 0.02;
/// How much larger one footprint must be than the other to decide.
pub const DECISIVE_RATIO: f32 = 1.25;

/// An up axis of a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpAxis {
    Y,
    Z,
}

impl UpAxis {
    pub fn name(self) -> &'static str {
        match self {
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }

    fn index(self) -> usize {
        match self {
            UpAxis::Y => 1,
            UpAxis::Z => 2,
        }
    }

    fn other(self) -> UpAxis {
        match self {
            UpAxis::Y => UpAxis::Z,
            UpAxis::Z => UpAxis::Y,
        }
    }
}

/// What the heuristic chose, and on what grounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detection {
    pub axis: UpAxis,
    /// Footprint of the support at the low end along y and along z.
    pub footprint_y: f32,
    pub footprint_z: f32,
    /// Whether the footprints decided (else the format's convention did).
    pub by_footprint: bool,
}

impl Detection {
    /// One line for a note: what was chosen and why.
    pub fn reason(&self) -> String {
        let (mine, other) = match self.axis {
            UpAxis::Y => (self.footprint_y, self.footprint_z),
            UpAxis::Z => (self.footprint_z, self.footprint_y),
        };
        if self.by_footprint {
            let ratio = if other > 0.0 {
                format!("{:.1}×", mine / other)
            } else {
                "far".to_string()
            };
            format!(
                "its base along −{} is {ratio} wider than along −{}",
                self.axis.name(),
                self.axis.other().name()
            )
        } else {
            "no clearly wider base, so the format's usual axis".to_string()
        }
    }
}

/// The format's own convention where the geometry does not decide.
pub fn conventional(format: SceneFormat) -> UpAxis {
    match format {
        SceneFormat::Stl => UpAxis::Z,
        _ => UpAxis::Y,
    }
}

/// The up axis of `scene`'s shapes (the first `shapes` of them: the model).
pub fn detect(scene: &Scene, shapes: usize) -> Detection {
    let shapes = &scene.shapes[..shapes.min(scene.shapes.len())];
    let bounds = shapes.iter().fold(Aabb::EMPTY, |b, s| b.union(s.bounds()));
    let fallback = conventional(scene.format);
    if !(bounds.min.is_finite() && bounds.max.is_finite() && bounds.min.x <= bounds.max.x) {
        return Detection {
            axis: fallback,
            footprint_y: 0.0,
            footprint_z: 0.0,
            by_footprint: false,
        };
    }
    let slab = (bounds.max - bounds.min).max_element() * SUPPORT_SLAB;
    let footprint_y = footprint(shapes, &bounds, UpAxis::Y, slab);
    let footprint_z = footprint(shapes, &bounds, UpAxis::Z, slab);
    let (axis, by_footprint) = if footprint_z > footprint_y * DECISIVE_RATIO {
        (UpAxis::Z, true)
    } else if footprint_y > footprint_z * DECISIVE_RATIO {
        (UpAxis::Y, true)
    } else {
        (fallback, false)
    };
    Detection {
        axis,
        footprint_y,
        footprint_z,
        by_footprint,
    }
}

/// Area across `axis` of the bounding rectangle of the points within `slab`
/// of the model's low end along `axis`.
fn footprint(shapes: &[Shape], bounds: &Aabb, axis: UpAxis, slab: f32) -> f32 {
    let a = axis.index();
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    let low = bounds.min[a] + slab;
    let mut rect = [
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    let mut take = |p: Vec3| {
        if p[a] <= low {
            rect = [
                rect[0].min(p[b]),
                rect[1].max(p[b]),
                rect[2].min(p[c]),
                rect[3].max(p[c]),
            ];
        }
    };
    for s in shapes {
        match s {
            Shape::Triangle(t) => {
                take(t.v0);
                take(t.v0 + t.e1);
                take(t.v0 + t.e2);
            }
            // Spheres and cones (NFF only): their boxes' low corners.
            other => super::framing::box_corners(other.bounds()).for_each(&mut take),
        }
    }
    if rect[0] > rect[1] {
        return 0.0;
    }
    (rect[1] - rect[0]) * (rect[3] - rect[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{MeshPolygon, Scene};

    /// A scene of axis-aligned boxes `(min, max)`, each as its 12 triangles.
    fn boxes(format: SceneFormat, list: &[([f32; 3], [f32; 3])]) -> Scene {
        let mut scene = Scene::new();
        scene.format = format;
        let m = scene.add_material(Default::default());
        for &(lo, hi) in list {
            let corners: Vec<Vec3> = super::super::framing::box_corners(Aabb {
                min: Vec3::from(lo),
                max: Vec3::from(hi),
            })
            .collect();
            let corner = |i: usize| corners[i];
            let g = scene.new_group();
            for face in [
                [0, 2, 3, 1],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 4, 6, 2],
                [1, 3, 7, 5],
            ] {
                let v = face.map(corner);
                scene.add_mesh_polygon(
                    &MeshPolygon {
                        vertices: &v,
                        normals: None,
                        uv: None,
                        material: m,
                        group: g,
                    },
                    &String::new,
                );
            }
        }
        scene
    }

    /// A car body on four wheels, up along `up`: long in x, wide across,
    /// low along up.
    fn car(up: UpAxis, format: SceneFormat) -> Scene {
        // (x, across, height) boxes: a body above four small wheels.
        let parts = [
            ([0.0, 0.0, 0.2], [4.0, 2.0, 0.8]),
            ([0.3, 0.0, 0.0], [0.9, 0.3, 0.5]),
            ([0.3, 1.7, 0.0], [0.9, 2.0, 0.5]),
            ([3.1, 0.0, 0.0], [3.7, 0.3, 0.5]),
            ([3.1, 1.7, 0.0], [3.7, 2.0, 0.5]),
        ];
        let turned: Vec<_> = parts
            .iter()
            .map(|&(lo, hi)| match up {
                // z up: (x, across, height) as (x, y, z).
                UpAxis::Z => (lo, hi),
                // y up: height along y, across along −z.
                UpAxis::Y => ([lo[0], lo[2], -hi[1]], [hi[0], hi[2], -lo[1]]),
            })
            .collect();
        boxes(format, &turned)
    }

    #[test]
    fn a_vehicle_stands_on_its_wheels_either_way_up() {
        for format in [SceneFormat::Obj, SceneFormat::Stl, SceneFormat::Ply] {
            for up in [UpAxis::Y, UpAxis::Z] {
                let scene = car(up, format);
                let d = detect(&scene, scene.shapes.len());
                assert_eq!(d.axis, up, "{format:?} {d:?}");
                assert!(d.by_footprint, "{d:?}");
            }
        }
    }

    #[test]
    fn a_cube_says_nothing_and_the_format_decides() {
        for (format, axis) in [
            (SceneFormat::Obj, UpAxis::Y),
            (SceneFormat::Ply, UpAxis::Y),
            (SceneFormat::Stl, UpAxis::Z),
        ] {
            let scene = boxes(format, &[([0.0; 3], [1.0; 3])]);
            let d = detect(&scene, scene.shapes.len());
            assert_eq!((d.axis, d.by_footprint), (axis, false), "{format:?}");
            assert!(d.reason().contains("usual"));
        }
    }

    #[test]
    fn shapes_after_the_model_are_left_out() {
        // A z-up car, then a wide thin plate below it along −y (a floor
        // added by the job, say) that would make y look up.
        let mut scene = car(UpAxis::Z, SceneFormat::Obj);
        let model = scene.shapes.len();
        let plate = boxes(
            SceneFormat::Obj,
            &[([-10.0, -1.01, -10.0], [10.0, -1.0, 10.0])],
        );
        scene.shapes.extend(plate.shapes);
        assert_eq!(detect(&scene, model).axis, UpAxis::Z);
        assert_eq!(detect(&scene, scene.shapes.len()).axis, UpAxis::Y);
    }

    #[test]
    fn an_empty_model_takes_the_convention() {
        let mut scene = Scene::new();
        scene.format = SceneFormat::Stl;
        assert_eq!(detect(&scene, 0).axis, UpAxis::Z);
    }
}
