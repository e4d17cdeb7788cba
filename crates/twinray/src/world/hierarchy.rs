//! The scene made ready to trace: the hierarchy built (whole, or in two with
//! the paper's cut), and the shapes stored in the hierarchy's leaf order so
//! that a leaf's primitives sit together in memory.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::bvh::{self, primitive_box, BuildOptions, Bvh, PAD};
use crate::math::Aabb;
use crate::scene::{AlphaMode, Material, Scene};
use crate::shapes::{Shape, TriangleNormals};

use super::cut::Cut;

pub struct World {
    pub scene: Scene,
    /// The hierarchy over every primitive, or with a cut (the paper's section
    /// 2.3) over the primitives nearer than the cut.
    pub bvh: Bvh,
    /// With a cut: the hierarchy over the primitives beyond it. The views' eye
    /// rays see them as the rig's centre does (see `render::twin`); shadow and
    /// secondary rays see them where they are.
    pub far: Option<Bvh>,
    /// Seconds spent building the hierarchy.
    pub build_seconds: f64,
    /// Whether some material's alpha matters (`Scene::has_alpha`): rays then
    /// go on past cut-away hits, and shadow rays ask the alpha where they meet
    /// such a material.
    pub has_alpha: bool,
    /// A two-level hierarchy ([`World::two_level`]): its instances, and how
    /// many of them (and of their primitives) were built for it.
    pub instances: Option<InstanceCounts>,
    /// The boxes of the primitives filed in pieces. See `filed_boxes`.
    pub(super) pieces: PieceBoxes,
}

/// What a two-level build rebuilt: the test hook and `-v` line of an
/// animation's frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InstanceCounts {
    pub instances: usize,
    pub rebuilt_instances: usize,
    pub primitives: usize,
    pub rebuilt_primitives: usize,
    /// Primitives made from the file for this frame (an animated glTF file's
    /// moving instances), set by the caller; the others were kept.
    pub made_primitives: usize,
}

/// The padded boxes of the primitives that `bvh` files in pieces
/// (`Cone::pieces`), computed once: the shadow cache checks them for every
/// segment whose cached blocker is such a cone (4 % of SPD rings' time went to
/// computing them there). Primitive `p`'s are `boxes[start[p]..start[p + 1]]`,
/// none where it is filed whole; both are empty without pieces.
#[derive(Default)]
pub(crate) struct PieceBoxes {
    start: Vec<u32>,
    boxes: Vec<Aabb>,
}

impl PieceBoxes {
    /// From the pieces each shape is filed under (empty: one each).
    fn new(shapes: &[Shape], pieces: &[u8]) -> PieceBoxes {
        if pieces.is_empty() {
            return PieceBoxes::default();
        }
        let mut start = Vec::with_capacity(shapes.len() + 1);
        let mut boxes = Vec::new();
        start.push(0);
        for (s, &k) in shapes.iter().zip(pieces) {
            if k > 1 {
                boxes.extend(filed_bounds(s, k).map(|b| primitive_box(&b)));
            }
            start.push(boxes.len() as u32);
        }
        PieceBoxes { start, boxes }
    }

    /// Primitive `prim`'s boxes (empty where it is filed whole).
    #[inline]
    fn of(&self, prim: u32) -> &[Aabb] {
        let p = prim as usize;
        match self.start.get(p..p + 2) {
            Some(&[a, b]) => &self.boxes[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// How to build the hierarchy over `shapes`: leaves costed and filled as
/// blocks of four when they are mostly triangles (at most one shape in
/// `MOSTLY_TRIANGLES` another kind: SPD's mount, a terrain with four glass
/// spheres, renders 10 % faster so), else today's leaves, aligned so that
/// those of triangles still make blocks. Leaves that hold another shape are
/// tested one by one in either case.
pub(super) fn build_options<'a>(shapes: impl Iterator<Item = &'a Shape>) -> BuildOptions {
    let (mut all, mut others) = (0usize, 0usize);
    for s in shapes {
        all += 1;
        others += !matches!(s, Shape::Triangle(_)) as usize;
    }
    options_for(others, all)
}

/// The hierarchy over all of the scene's shapes with `build_options`, and
/// the pieces each is filed under (`Cone::pieces`; empty: one each). Without
/// pieces, their bounds and the count of shapes that are not triangles are
/// taken in one pass over them, on all threads (no array of boxes).
fn build_all(scene: &Scene) -> (Bvh, Vec<u8>) {
    let shapes = &scene.shapes;
    let pieces = pieces_of(scene);
    if !pieces.is_empty() {
        let boxes: Vec<(u32, Aabb)> = shapes
            .iter()
            .zip(&pieces)
            .enumerate()
            .flat_map(|(i, (s, &k))| filed_bounds(s, k).map(move |b| (i as u32, b)))
            .collect();
        let bvh = bvh::build_pieces(&boxes, &build_options(shapes.iter()));
        return (bvh, pieces);
    }
    let others = AtomicUsize::new(0);
    let bvh = bvh::build_by(
        shapes.len(),
        |i| {
            let s = &shapes[i];
            if !matches!(s, Shape::Triangle(_)) {
                others.fetch_add(1, Ordering::Relaxed);
            }
            s.bounds()
        },
        || options_for(others.load(Ordering::Relaxed), shapes.len()),
    );
    (bvh, Vec::new())
}

/// The pieces each shape of `scene` is filed under in the hierarchy: more
/// than one only for long tilted cones (`Cone::pieces`) of opaque materials,
/// since a shadow segment through a glass or cut-out cone filed in two
/// leaves would meet it, and count its transmittance, twice. Empty if every
/// shape is filed whole.
fn pieces_of(scene: &Scene) -> Vec<u8> {
    if !scene.shapes.iter().any(|s| matches!(s, Shape::Cone(_))) {
        return Vec::new();
    }
    let pieces: Vec<u8> = scene
        .shapes
        .par_iter()
        .zip(&scene.shape_material)
        .map(|(s, &m)| {
            let m = &scene.materials[m as usize];
            match s {
                Shape::Cone(c) if m.t <= 0.0 && m.alpha_mode == AlphaMode::Opaque => {
                    c.pieces() as u8
                }
                _ => 1,
            }
        })
        .collect();
    if pieces.iter().all(|&k| k == 1) {
        Vec::new()
    } else {
        pieces
    }
}

/// Bounds of the `k` pieces `shape` is filed under.
fn filed_bounds(shape: &Shape, k: u8) -> impl Iterator<Item = Aabb> + '_ {
    let (cone, whole) = match shape {
        Shape::Cone(c) if k > 1 => (Some(c.piece_boxes(k as u32)), None),
        _ => (None, Some(shape.bounds())),
    };
    cone.into_iter().flatten().chain(whole)
}

/// The choice of `build_options`, given how many of `all` shapes are not
/// triangles.
fn options_for(others: usize, all: usize) -> BuildOptions {
    if others * MOSTLY_TRIANGLES <= all {
        BuildOptions::triangle_blocks()
    } else {
        BuildOptions::aligned()
    }
}

/// See `build_options`.
const MOSTLY_TRIANGLES: usize = 16;

/// Puts the shapes (their materials and groups with them) in the leaf order
/// of `trees`, one after the other, so that a leaf's primitives sit together
/// in memory; the trees' orders then index them in order (past the padding
/// between leaves), and each tree gets its blocks of triangles. Returns each
/// shape's index before.
pub(super) fn into_leaf_order<'a>(
    scene: &mut Scene,
    trees: impl Iterator<Item = &'a mut Bvh>,
) -> Vec<u32> {
    let mut order = Vec::with_capacity(scene.shapes.len());
    let mut trees: Vec<&mut Bvh> = trees.collect();
    // A primitive filed in several leaves (its pieces', `build_pieces`) has
    // one place, its first leaf's.
    let mut placed = vec![u32::MAX; scene.shapes.len()];
    for tree in trees.iter_mut() {
        for o in tree.order.iter_mut().filter(|o| **o != PAD) {
            let at = &mut placed[*o as usize];
            if *at == u32::MAX {
                order.push(*o);
                *at = order.len() as u32 - 1;
            }
            *o = *at;
        }
    }
    let shapes = order
        .par_iter()
        .map(|&i| scene.shapes[i as usize].clone())
        .collect();
    let old_shapes = std::mem::replace(&mut scene.shapes, shapes);
    scene.shape_material = order
        .par_iter()
        .map(|&i| scene.shape_material[i as usize])
        .collect();
    scene.shape_group = order
        .par_iter()
        .map(|&i| scene.shape_group[i as usize])
        .collect();
    // The shapes in their first order freed beside the blocks, off their path.
    rayon::join(
        || drop(old_shapes),
        || {
            for tree in trees {
                tree.attach_blocks(&scene.shapes);
            }
        },
    );
    order
}

impl World {
    pub fn new(scene: Scene) -> World {
        World::with_cut(scene, None)
    }

    /// The scene made ready to trace, its object tree cut at `cut` if given.
    /// The cut takes whole groups (the loader's unit: an NFF entity, an OBJ
    /// object, a glTF node), and a group only if all of it lies beyond the cut,
    /// so that objects that touch across the cut stay together.
    pub fn with_cut(mut scene: Scene, cut: Option<Cut>) -> World {
        let start = Instant::now();
        scene.finish();
        // (Without a cut the build asks for the bounds itself.)
        let boxes: Vec<Aabb> = match cut {
            None => Vec::new(),
            Some(_) => scene.shapes.par_iter().map(|s| s.bounds()).collect(),
        };
        let far_groups: Vec<bool> = match cut {
            None => Vec::new(),
            Some(c) => {
                let groups = scene
                    .shape_group
                    .iter()
                    .map(|&g| g as usize + 1)
                    .max()
                    .unwrap_or(0);
                let mut beyond = vec![true; groups];
                for (b, &g) in boxes.iter().zip(&scene.shape_group) {
                    beyond[g as usize] &= c.beyond(b);
                }
                beyond
            }
        };
        // Without a cut every shape is near: the build then takes the shapes
        // as they are (no index list, no array of boxes, no renumbering of
        // the order).
        let (near, far): (Vec<u32>, Vec<u32>) = if far_groups.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            (0..boxes.len() as u32).partition(|&i| {
                !far_groups
                    .get(scene.shape_group[i as usize] as usize)
                    .copied()
                    .unwrap_or(false)
            })
        };
        // `set`: the shapes to build over, or all of them.
        // (A cut's trees file every shape whole.)
        let build = |set: Option<&[u32]>| {
            let Some(set) = set else {
                return build_all(&scene);
            };
            let set_boxes: Vec<Aabb> = set.par_iter().map(|&i| boxes[i as usize]).collect();
            let opts = build_options(set.iter().map(|&i| &scene.shapes[i as usize]));
            let mut bvh = bvh::build(&set_boxes, &opts);
            for o in bvh.order.iter_mut().filter(|o| **o != PAD) {
                *o = set[*o as usize];
            }
            (bvh, Vec::new())
        };
        let (mut bvh, pieces) = build((!far_groups.is_empty()).then_some(&near[..]));
        let mut far_bvh = (!far.is_empty()).then(|| build(Some(&far)).0);
        // Shapes into leaf order (near, then far).
        let before = into_leaf_order(
            &mut scene,
            std::iter::once(&mut bvh).chain(far_bvh.as_mut()),
        );
        let pieces: Vec<u8> = if pieces.is_empty() {
            pieces
        } else {
            before.iter().map(|&i| pieces[i as usize]).collect()
        };
        World {
            pieces: PieceBoxes::new(&scene.shapes, &pieces),
            has_alpha: scene.has_alpha(),
            scene,
            bvh,
            far: far_bvh,
            build_seconds: start.elapsed().as_secs_f64(),
            instances: None,
        }
    }

    /// Primitives beyond the cut.
    pub fn cut_primitives(&self) -> usize {
        self.far.as_ref().map_or(0, Bvh::primitive_count)
    }

    /// The boxes the hierarchy files primitive `prim` under (padded as the
    /// build pads them): a traversal tests `prim` only for a ray that enters
    /// one of them.
    pub fn filed_boxes(&self, prim: u32) -> impl Iterator<Item = Aabb> + '_ {
        let pieces = self.pieces.of(prim);
        let whole = pieces
            .is_empty()
            .then(|| primitive_box(&self.scene.shapes[prim as usize].bounds()));
        pieces.iter().copied().chain(whole)
    }

    /// The transmission coefficient `T` of a primitive's material.
    #[inline]
    pub fn transmission_of(&self, prim: u32) -> f32 {
        self.scene.materials[self.scene.shape_material[prim as usize] as usize].t
    }

    /// The material of a primitive.
    #[inline]
    pub fn material_of(&self, prim: u32) -> &Material {
        &self.scene.materials[self.scene.shape_material[prim as usize] as usize]
    }

    /// Whether primitives `a` and `b` are flat triangles of one plane and one
    /// material (one polygon, or polygons that continue each other): the
    /// "same planar surface" of the paper's section 2.4.
    pub fn coplanar(&self, a: u32, b: u32) -> bool {
        let s = &self.scene;
        let flat = |p: u32| match &s.shapes[p as usize] {
            Shape::Triangle(t) if t.normals == TriangleNormals::Flat => Some(t),
            _ => None,
        };
        let (Some(ta), Some(tb)) = (flat(a), flat(b)) else {
            return false;
        };
        if a == b {
            return true;
        }
        if s.shape_material[a as usize] != s.shape_material[b as usize]
            || ta.face_normal.dot(tb.face_normal) < 1.0 - 1e-6
        {
            return false;
        }
        let scale = ta
            .v0
            .abs()
            .max_element()
            .max(tb.v0.abs().max_element())
            .max(1.0);
        ta.face_normal.dot(tb.v0 - ta.v0).abs() <= 1e-5 * scale
    }

    /// Bytes held by shapes, materials, corner attributes, textures and the hierarchy.
    pub fn memory_bytes(&self) -> usize {
        self.scene.memory_bytes()
            + self.bvh.memory_bytes()
            + self.far.as_ref().map_or(0, Bvh::memory_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loaders::nff::parse_nff;
    use crate::loaders::LoadOptions;
    use crate::math::{Color, Vec3};

    fn scene(text: &str) -> Scene {
        parse_nff(text, std::path::Path::new("t.nff"), &LoadOptions::default()).expect("test scene")
    }

    const HEADER: &str = "b 0 0 0\nv\nfrom 0 -10 1\nat 0 0 1\nup 0 0 1\nangle 40\nhither 0.01\n\
        resolution 8 8\nl 0 -5 5\n";

    /// Each shape as comparable bits, with its material's colour and its group.
    fn shape_keys(s: &Scene) -> Vec<([u32; 6], [u32; 3], u32)> {
        let mut keys: Vec<_> = (0..s.shapes.len())
            .map(|i| {
                let b = s.shapes[i].bounds();
                let m = &s.materials[s.shape_material[i] as usize];
                (
                    [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z].map(f32::to_bits),
                    m.color.to_array().map(f32::to_bits),
                    s.shape_group[i],
                )
            })
            .collect();
        keys.sort_unstable();
        keys
    }

    /// The renderer's nearest test for one ray: leaves of triangles as
    /// blocks, the others one by one.
    struct Blocks<'a> {
        shapes: &'a [Shape],
        ray: crate::math::Ray,
    }

    impl bvh::NearestTest for Blocks<'_> {
        fn test(&mut self, p: u32, _: usize, t_max: f32) -> Option<crate::shapes::SurfaceHit> {
            self.shapes[p as usize].intersect(&self.ray, 1e-4, t_max)
        }

        fn test_block(
            &mut self,
            block: &crate::shapes::Triangle4,
            _: usize,
            t_max: f32,
        ) -> Option<crate::shapes::BlockHits> {
            Some(block.intersect(&self.ray, 1e-4, t_max))
        }
    }

    /// A mesh with a few spheres (SPD's mount) is built as a mesh: leaves of
    /// up to two blocks, costed in blocks; more than one shape in 16 of
    /// another kind, as before. The leaves with spheres are tested one by
    /// one, the others as blocks, and every ray's nearest hit is brute
    /// force's, bit for bit.
    #[test]
    fn mostly_triangles_build_as_a_mesh_and_find_the_spheres() {
        let mut text = HEADER.to_string();
        text += "f 0.5 0.5 0.5 1 0 1 0 1\n";
        for k in 0..30 * 30 {
            let (x, y) = ((k % 30) as f32 * 0.3 - 4.5, (k / 30) as f32 * 0.3);
            let z = (x * 0.7).sin() * 0.3;
            let (x1, y1, z1) = (x + 0.3, y + 0.3, z + 0.1);
            text += &format!("p 3\n{x} {y} {z}\n{x1} {y} {z}\n{x} {y1} {z1}\n");
        }
        // Spheres sunk in the terrain: they share leaves with triangles.
        for i in 0..6 {
            let (x, y) = (i as f32 * 1.5 - 4.0, 2.0 + i as f32);
            text += &format!("s {x} {y} 0.1 0.3\n");
        }
        let world = World::new(scene(&text));
        let opts = build_options(world.scene.shapes.iter());
        assert!(opts.cost_in_blocks && opts.max_leaf == 8, "{opts:?}");
        assert!(
            world.bvh.leaves().any(|l| l.len() > 4),
            "leaves of two blocks"
        );
        let spheres = world
            .scene
            .shapes
            .iter()
            .filter(|s| matches!(s, Shape::Sphere(_)));
        assert_eq!(spheres.count(), 6);
        // Fourteen triangles and a sphere: more than one in 16, today's leaves.
        let few: Vec<Shape> = world
            .scene
            .shapes
            .iter()
            .filter(|s| matches!(s, Shape::Triangle(_)))
            .take(14)
            .cloned()
            .chain([world
                .scene
                .shapes
                .iter()
                .find(|s| matches!(s, Shape::Sphere(_)))
                .cloned()
                .unwrap_or_else(|| panic!("a sphere"))])
            .collect();
        assert!(!build_options(few.iter()).cost_in_blocks);
        let shapes = &world.scene.shapes;
        let mut sphere_hits = 0;
        for k in 0..40 * 40 {
            let origin = Vec3::new(0.0, -10.0, 1.0);
            let target = Vec3::new(
                (k % 40) as f32 * 0.25 - 5.0,
                4.0,
                (k / 40) as f32 * 0.05 - 0.5,
            );
            let ray = crate::math::Ray::new(origin, (target - origin).normalize());
            let packet = bvh::Packet {
                origins: [ray.origin],
                dirs: [ray.dir],
                t_min: 1e-4,
                t_max: [f32::INFINITY],
                mask: 1,
            };
            let test = Blocks { shapes, ray };
            let got = world
                .bvh
                .closest(&packet, &mut bvh::TraversalStats::default(), test);
            let brute = bvh::brute_force::closest_hits(shapes, &packet);
            assert_eq!(got.prim[0], brute.prim[0], "ray {k}");
            assert_eq!(got.hit[0].t.to_bits(), brute.hit[0].t.to_bits(), "ray {k}");
            let prim = shapes.get(got.prim[0] as usize);
            sphere_hits += matches!(prim, Some(Shape::Sphere(_))) as u32;
        }
        assert!(sphere_hits > 50, "{sphere_hits} rays hit a sphere");
    }

    #[test]
    fn shapes_in_leaf_order_keep_their_materials_and_groups() {
        let mut text = HEADER.to_string();
        let mut rng = fastrand::Rng::with_seed(4);
        for i in 0..60 {
            let (x, y, z) = (rng.f32() * 10.0 - 5.0, rng.f32() * 10.0, rng.f32() * 3.0);
            text += &format!("f {} 0.5 0.5 1 0 1 0 1\n", i as f32 / 60.0);
            text += &if i % 2 == 0 {
                format!("s {x} {y} {z} 0.3\n")
            } else {
                format!(
                    "p 4\n{x} {y} {z}\n{} {y} {z}\n{} {} {z}\n{x} {} {z}\n",
                    x + 1.0,
                    x + 1.0,
                    y + 1.0,
                    y + 1.0
                )
            };
        }
        let before = scene(&text);
        let keys = shape_keys(&before);
        let world = World::new(before);
        assert_eq!(shape_keys(&world.scene), keys);
        // The hierarchy indexes the reordered shapes directly.
        let n = world.scene.shapes.len() as u32;
        let slots: Vec<u32> = world
            .bvh
            .order
            .iter()
            .copied()
            .filter(|&p| p != PAD)
            .collect();
        assert_eq!(slots, (0..n).collect::<Vec<_>>());
        assert!(world.far.is_none() && world.cut_primitives() == 0);
    }

    #[test]
    fn a_box_is_beyond_a_cut_only_if_all_of_it_is() {
        let cut = Cut {
            eye: Vec3::new(0.0, -10.0, 0.0),
            forward: Vec3::Y,
            depth: 10.0,
        };
        let at = |y0: f32, y1: f32| Aabb {
            min: Vec3::new(-1.0, y0, -1.0),
            max: Vec3::new(1.0, y1, 1.0),
        };
        assert!(cut.beyond(&at(0.0, 2.0)), "from depth 10 on");
        assert!(!cut.beyond(&at(-0.5, 2.0)), "straddles it");
        assert!(!cut.beyond(&at(-5.0, -1.0)), "in front");
        assert!(!cut.beyond(&Aabb::EMPTY));
        // Looking along a diagonal, a box's nearest corner decides.
        let diagonal = Cut {
            forward: Vec3::new(1.0, 1.0, 0.0).normalize(),
            ..cut
        };
        let corner_depth = |b: &Aabb| (b.min - diagonal.eye).dot(diagonal.forward);
        let b = at(5.0, 6.0);
        assert!(Cut {
            depth: corner_depth(&b),
            ..diagonal
        }
        .beyond(&b));
        assert!(!Cut {
            depth: corner_depth(&b) + 0.01,
            ..diagonal
        }
        .beyond(&b));
    }

    #[test]
    fn a_cut_takes_whole_groups_and_keeps_those_that_reach_across_it() {
        // Beyond depth 15 (y > 5): two spheres; a polygon from y = 0 to 20
        // reaches across, and its triangles beyond stay with it.
        let text = format!(
            "{HEADER}f 1 0 0 1 0 1 0 1\ns 0 8 1 0.5\ns 2 9 1 0.5\ns 0 2 1 0.5\n\
             f 0 1 0 1 0 1 0 1\np 6\n-1 0 0\n1 0 0\n1 10 0\n1 20 0\n-1 20 0\n-1 10 0\n"
        );
        let cut = Cut {
            eye: Vec3::new(0.0, -10.0, 1.0),
            forward: Vec3::Y,
            depth: 15.0,
        };
        let world = World::with_cut(scene(&text), Some(cut));
        assert_eq!(world.cut_primitives(), 2);
        let far = world.far.as_ref().expect("far hierarchy");
        for &p in far.order.iter().filter(|&&p| p != PAD) {
            assert!(matches!(world.scene.shapes[p as usize], Shape::Sphere(_)));
            assert!(cut.beyond(&world.scene.shapes[p as usize].bounds()));
        }
        let triangles = world
            .bvh
            .order
            .iter()
            .filter(|&&p| p != PAD && matches!(world.scene.shapes[p as usize], Shape::Triangle(_)))
            .count();
        assert_eq!(triangles, 4, "the polygon stays whole, before the cut");
    }

    #[test]
    fn coplanar_means_flat_triangles_of_one_plane_and_one_material() {
        let text = format!(
            "{HEADER}f 1 1 1 1 0 1 0 1\n\
             p 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
             p 3\n5 5 0\n6 5 0\n6 6 0\n\
             p 3\n0 0 1\n1 0 1\n1 1 1\n\
             pp 3\n0 3 0 0 0 1\n1 3 0 0 0 1\n1 4 0 0 0 1\n\
             p 3\n0 6 0\n1 6 0\n1 7 1\n\
             s 0 0 3 1\n\
             f 0 0 1 1 0 1 0 1\np 3\n2 0 0\n3 0 0\n3 1 0\n"
        );
        let world = World::new(scene(&text));
        let s = &world.scene;
        // Find shapes by where they are (the world reorders them).
        let find = |x: f32, y: f32, z: f32| -> Vec<u32> {
            (0..s.shapes.len() as u32)
                .filter(|&p| {
                    let b = s.shapes[p as usize].bounds();
                    b.min.x <= x
                        && x <= b.max.x
                        && b.min.y <= y
                        && y <= b.max.y
                        && b.min.z <= z
                        && z <= b.max.z
                })
                .collect()
        };
        let quad = find(0.5, 0.5, 0.0);
        assert_eq!(quad.len(), 2, "two triangles of the quad");
        let (a, b) = (quad[0], quad[1]);
        assert!(world.coplanar(a, b) && world.coplanar(a, a));
        let far_same_plane = find(5.9, 5.1, 0.0)[0];
        assert!(
            world.coplanar(a, far_same_plane),
            "another polygon of the plane"
        );
        let above = find(0.9, 0.1, 1.0)[0];
        assert!(!world.coplanar(a, above), "a parallel plane");
        let tilted = find(0.9, 6.5, 0.5)[0];
        assert!(
            !world.coplanar(a, tilted),
            "a plane through the quad's plane"
        );
        let patch = find(0.9, 3.1, 0.0)[0];
        assert!(!world.coplanar(a, patch), "a smooth patch");
        let sphere = find(0.0, 0.0, 3.0)[0];
        assert!(!world.coplanar(a, sphere) && !world.coplanar(sphere, sphere));
        let other_material = find(2.9, 0.1, 0.0)[0];
        assert!(!world.coplanar(a, other_material), "another material");
        assert_eq!(
            world.material_of(other_material).color,
            Color::new(0.0, 0.0, 1.0)
        );
        assert_eq!(world.transmission_of(a), 0.0);
    }
}
