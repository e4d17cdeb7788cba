//! Which axis is up in a mesh file that does not say (OBJ, STL, PLY): y, the
//! convention of OBJ exporters and glTF, or z, that of CAD, 3D printing and
//! robotics (URDF: every pybullet model).
//!
//! Three kinds of evidence, in order, each decisive only where it is clear:
//!
//! 1. **The ground plane.** Modelling tools put a model on the plane through
//!    the origin: its lowest point along the up axis is at 0 (within 0.5 % of
//!    its size), while along the other axis it reaches well below 0 (5 %).
//! 2. **The resting pose.** Set down on its lowest end along an axis, a model
//!    rests on the convex hull of its points there (its *support*: the points
//!    within a slab of 2 % of its size); it stands if its centre of mass (of
//!    its surface) is over the support, and its stability is the angle it
//!    must be tipped by to fall, `atan(margin / height)`. One pose stable by
//!    5° or more while the other topples decides.
//! 3. **The footprint.** A base is wide: the support's area along one axis
//!    1.25 times the other's decides.
//!
//! Otherwise the format's convention does (z for STL, y for OBJ and PLY),
//! and the note says that the shape did not tell.
//!
//! Measured on 50 real meshes of five packages (docs/formats.md, "Up axis"):
//! 48 stand upright. A textured cube and a bicycle frame modelled lying flat
//! do not; the job says what it chose in a note, and `--up-axis` overrides it.

use crate::math::{Aabb, Vec3};
use crate::scene::{Scene, SceneFormat};
use crate::shapes::Shape;

/// The slab at a model's lowest end, in its largest side.
pub const SUPPORT_SLAB: f32 = 0.02;
/// How much larger one footprint must be than the other to decide.
pub const DECISIVE_RATIO: f32 = 1.25;
/// How near 0 a lowest point must be to sit on the origin's plane, and how
/// far below 0 the other axis must reach, in the model's largest side.
const ON_PLANE: f32 = 0.005;
const BELOW_PLANE: f32 = 0.05;
/// The tipping angle, in degrees, of a pose that stands clearly.
const STABLE_DEG: f32 = 5.0;

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

    pub fn other(self) -> UpAxis {
        match self {
            UpAxis::Y => UpAxis::Z,
            UpAxis::Z => UpAxis::Y,
        }
    }
}

/// How a model rests on its lowest end along one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// The lowest coordinate along the axis, in the model's largest side.
    pub lowest: f32,
    /// The area of the support (the convex hull of the points at that end).
    pub footprint: f32,
    /// The angle in degrees the model must be tipped by to fall: negative
    /// where its centre of mass is outside the support (it topples), −90
    /// where the support has no area.
    pub tipping_deg: f32,
}

/// What decided the axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evidence {
    GroundPlane,
    Resting,
    Footprint,
    /// Nothing clear: the format's convention.
    Convention,
}

/// What the heuristic chose, and on what grounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detection {
    pub axis: UpAxis,
    pub evidence: Evidence,
    /// The model resting on its lowest end along y and along z.
    pub y: Pose,
    pub z: Pose,
}

impl Detection {
    fn pose(&self, axis: UpAxis) -> &Pose {
        match axis {
            UpAxis::Y => &self.y,
            UpAxis::Z => &self.z,
        }
    }

    /// One line for a note: what was chosen and why.
    pub fn reason(&self) -> String {
        let (up, other) = (self.axis.name(), self.axis.other().name());
        match self.evidence {
            Evidence::GroundPlane => format!("it stands on the plane {up} = 0, as modelling tools place a model"),
            Evidence::Resting => format!(
                "it stands on its base along −{up}; set down along −{other} its centre of mass overhangs its base"
            ),
            Evidence::Footprint => {
                let (mine, theirs) = (self.pose(self.axis).footprint, self.pose(self.axis.other()).footprint);
                let ratio = if theirs > 0.0 {
                    format!("{:.1}×", mine / theirs)
                } else {
                    "far".to_string()
                };
                format!("its base along −{up} is {ratio} wider than along −{other}")
            }
            Evidence::Convention => {
                "not clear from its shape, so the format's usual axis".to_string()
            }
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
    let flat = Pose {
        lowest: 0.0,
        footprint: 0.0,
        tipping_deg: -90.0,
    };
    let mut d = Detection {
        axis: fallback,
        evidence: Evidence::Convention,
        y: flat,
        z: flat,
    };
    if !(bounds.min.is_finite() && bounds.max.is_finite() && bounds.min.x <= bounds.max.x) {
        return d;
    }
    let size = (bounds.max - bounds.min).max_element();
    if size <= 0.0 {
        return d;
    }
    let center = center_of_mass(shapes).unwrap_or((bounds.min + bounds.max) * 0.5);
    d.y = pose(shapes, &bounds, center, UpAxis::Y);
    d.z = pose(shapes, &bounds, center, UpAxis::Z);
    (d.axis, d.evidence) = choose(&d.y, &d.z).unwrap_or((fallback, Evidence::Convention));
    d
}

/// The axis the evidence names, in order of trust, and which evidence; `None`
/// where none is clear.
fn choose(y: &Pose, z: &Pose) -> Option<(UpAxis, Evidence)> {
    type Test = fn(&Pose, &Pose) -> bool;
    let on_plane: Test = |a, b| a.lowest.abs() <= ON_PLANE && b.lowest < -BELOW_PLANE;
    let resting: Test = |a, b| a.tipping_deg >= STABLE_DEG && b.tipping_deg < 0.0;
    let wider: Test = |a, b| a.footprint > b.footprint * DECISIVE_RATIO;
    [
        (Evidence::GroundPlane, on_plane),
        (Evidence::Resting, resting),
        (Evidence::Footprint, wider),
    ]
    .into_iter()
    .find_map(|(evidence, test)| {
        if test(y, z) {
            Some((UpAxis::Y, evidence))
        } else if test(z, y) {
            Some((UpAxis::Z, evidence))
        } else {
            None
        }
    })
}

/// The points of a shape: a triangle's corners, another shape's box corners
/// (spheres and cones: NFF only).
fn for_each_point(shapes: &[Shape], mut take: impl FnMut(Vec3)) {
    for s in shapes {
        match s {
            Shape::Triangle(t) => {
                take(t.v0);
                take(t.v0 + t.e1);
                take(t.v0 + t.e2);
            }
            other => super::framing::box_corners(other.bounds()).for_each(&mut take),
        }
    }
}

/// The centre of mass of the model's surface: its triangles' centroids
/// weighted by their areas (a mesh need not be closed to have one).
fn center_of_mass(shapes: &[Shape]) -> Option<Vec3> {
    let (mut sum, mut area) = (glam::DVec3::ZERO, 0.0f64);
    for s in shapes {
        let (c, a) = match s {
            Shape::Triangle(t) => (t.v0 + (t.e1 + t.e2) / 3.0, 0.5 * t.e1.cross(t.e2).length()),
            other => {
                let b = other.bounds();
                ((b.min + b.max) * 0.5, (b.max - b.min).length_squared())
            }
        };
        if a.is_finite() && c.is_finite() {
            sum += c.as_dvec3() * f64::from(a);
            area += f64::from(a);
        }
    }
    (area > 0.0).then(|| (sum / area).as_vec3())
}

/// The model set down on its lowest end along `axis` (`center`: its centre
/// of mass).
fn pose(shapes: &[Shape], bounds: &Aabb, center: Vec3, axis: UpAxis) -> Pose {
    let a = axis.index();
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    let size = (bounds.max - bounds.min).max_element();
    let low = bounds.min[a] + size * SUPPORT_SLAB;
    let mut support = Vec::new();
    for_each_point(shapes, |p| {
        if p[a] <= low {
            support.push([p[b], p[c]]);
        }
    });
    let hull = convex_hull(support);
    let footprint = polygon_area(&hull);
    let height = center[a] - bounds.min[a];
    let tipping_deg = if footprint > 0.0 {
        let margin = inside_margin(&hull, [center[b], center[c]]);
        margin.atan2(height.max(0.0)).to_degrees()
    } else {
        -90.0
    };
    Pose {
        lowest: bounds.min[a] / size,
        footprint,
        tipping_deg,
    }
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn convex_hull(mut points: Vec<[f32; 2]>) -> Vec<[f32; 2]> {
    points.sort_by(|p, q| p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f32; 2], p: [f32; 2], q: [f32; 2]| {
        (f64::from(p[0]) - f64::from(o[0])) * (f64::from(q[1]) - f64::from(o[1]))
            - (f64::from(p[1]) - f64::from(o[1])) * (f64::from(q[0]) - f64::from(o[0]))
    };
    let mut hull: Vec<[f32; 2]> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Box<dyn Iterator<Item = &[f32; 2]>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in ordered {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        // The chain's last point is the next chain's first.
        hull.pop();
    }
    hull
}

fn polygon_area(polygon: &[[f32; 2]]) -> f32 {
    if polygon.len() < 3 {
        return 0.0;
    }
    let twice: f64 = (0..polygon.len())
        .map(|i| {
            let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            f64::from(p[0]) * f64::from(q[1]) - f64::from(q[0]) * f64::from(p[1])
        })
        .sum();
    (twice.abs() * 0.5) as f32
}

/// The distance from `point` to the nearest edge of the counter-clockwise
/// convex `polygon`: positive inside, negative outside.
fn inside_margin(polygon: &[[f32; 2]], point: [f32; 2]) -> f32 {
    (0..polygon.len())
        .filter_map(|i| {
            let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            let (ex, ey) = (q[0] - p[0], q[1] - p[1]);
            let length = ex.hypot(ey);
            // The edge's inward normal is its direction turned left.
            (length > 0.0).then(|| ((point[0] - p[0]) * -ey + (point[1] - p[1]) * ex) / length)
        })
        .fold(f32::INFINITY, f32::min)
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
                assert_ne!(d.evidence, Evidence::Convention, "{d:?}");
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
            assert_eq!(
                (d.axis, d.evidence),
                (axis, Evidence::Convention),
                "{format:?}"
            );
            assert!(d.reason().contains("not clear"), "{}", d.reason());
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

    #[test]
    fn a_cabinet_on_the_origins_plane_stands_although_its_back_is_wider() {
        // A dispenser y-up, standing on y = 0, centred across: 2 wide, 2.2
        // tall, 1.2 deep, its back wider than its base (the footprints alone
        // would lay it on its back), and feet that make the base ragged.
        let scene = boxes(
            SceneFormat::Obj,
            &[
                ([-1.0, 0.1, -0.6], [1.0, 2.2, 0.6]),
                ([-1.0, 0.0, -0.6], [-0.8, 0.1, -0.4]),
                ([0.8, 0.0, 0.4], [1.0, 0.1, 0.6]),
            ],
        );
        let d = detect(&scene, scene.shapes.len());
        assert_eq!(
            (d.axis, d.evidence),
            (UpAxis::Y, Evidence::GroundPlane),
            "{d:?}"
        );
        assert!(d.z.footprint > d.y.footprint * DECISIVE_RATIO, "{d:?}");
        assert!(d.reason().contains("plane y = 0"), "{}", d.reason());
        // Moved off the plane, the footprints decide: on its back.
        let mut lifted = scene.clone();
        for s in &mut lifted.shapes {
            if let Shape::Triangle(t) = s {
                t.v0 += Vec3::new(0.0, 5.0, 0.0);
            }
        }
        assert_eq!(detect(&lifted, lifted.shapes.len()).axis, UpAxis::Z);
    }

    #[test]
    fn the_centre_of_mass_over_the_support_is_a_stable_pose() {
        // An L: a light foot plate at the low end along y, and a heavy body
        // beside it, whose centre of mass overhangs the plate.
        let scene = boxes(
            SceneFormat::Obj,
            &[
                ([0.0, 0.0, 0.0], [1.0, 0.05, 1.0]),
                ([3.0, 0.5, 0.0], [6.0, 3.0, 1.0]),
            ],
        );
        let center = center_of_mass(&scene.shapes).unwrap();
        let bounds = scene.bounds();
        let y = pose(&scene.shapes, &bounds, center, UpAxis::Y);
        let z = pose(&scene.shapes, &bounds, center, UpAxis::Z);
        assert!(y.tipping_deg < 0.0, "topples: {y:?}");
        assert!(z.tipping_deg > STABLE_DEG, "stands: {z:?}");
        assert!((y.footprint - 1.0).abs() < 1e-4, "{y:?}");
        // A box stands by 45° on a face as wide as it is tall.
        let cube = boxes(SceneFormat::Obj, &[([0.0; 3], [1.0; 3])]);
        let c = center_of_mass(&cube.shapes).unwrap();
        let p = pose(&cube.shapes, &cube.bounds(), c, UpAxis::Y);
        assert!((p.tipping_deg - 45.0).abs() < 0.01, "{p:?}");
    }

    #[test]
    fn evidence_is_taken_in_order_of_trust() {
        let pose = |lowest: f32, footprint: f32, tipping_deg: f32| Pose {
            lowest,
            footprint,
            tipping_deg,
        };
        // On the plane along y beats a stable, wider base along z.
        let (y, z) = (pose(0.0, 1.0, 10.0), pose(-0.5, 3.0, 40.0));
        assert_eq!(choose(&y, &z), Some((UpAxis::Y, Evidence::GroundPlane)));
        // Off the plane: z's wider base topples, y's narrower one stands.
        let (y, z) = (pose(-0.5, 1.0, 20.0), pose(-0.5, 3.0, -5.0));
        assert_eq!(choose(&y, &z), Some((UpAxis::Y, Evidence::Resting)));
        // Both stand: the wider base.
        let (y, z) = (pose(-0.5, 1.0, 20.0), pose(-0.5, 3.0, 30.0));
        assert_eq!(choose(&y, &z), Some((UpAxis::Z, Evidence::Footprint)));
        // Nothing clear.
        let (y, z) = (pose(-0.5, 1.0, 20.0), pose(-0.5, 1.1, 30.0));
        assert_eq!(choose(&y, &z), None);
    }

    #[test]
    fn convex_hull_and_margin() {
        let square = convex_hull(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [0.5, 0.5],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.0, 1.0],
        ]);
        assert_eq!(square.len(), 4, "{square:?}");
        assert!((polygon_area(&square) - 1.0).abs() < 1e-6);
        assert!((inside_margin(&square, [0.5, 0.25]) - 0.25).abs() < 1e-6);
        assert!((inside_margin(&square, [1.5, 0.5]) + 0.5).abs() < 1e-6);
        assert_eq!(
            polygon_area(&convex_hull(vec![[0.0, 0.0], [1.0, 1.0]])),
            0.0
        );
    }
}
