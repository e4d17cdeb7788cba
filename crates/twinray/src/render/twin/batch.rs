//! A twin batch: some neighbouring views of the rig traced together, one
//! packet lane per view, with what every row of them shares (the scene,
//! the batch's views and their eyes, how they share shading), and the
//! scratch space a worker keeps from row to row. The stages of a row
//! (`eye_pass`, `groups`, `cut`, `reprojection`, `mono`, the fast
//! method's `shared_shading`) are methods of the batch, one file each.

use super::grouping::Group;
use super::kept::{KeptShading, Received};
use super::lanes::{DonorPacket, TakerPacket};
use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::{Color, Vec3};
use crate::render::batch::RenderInputs;
use crate::render::fast::FastStages;
use crate::render::options::{PaperTechniques, ReprojectMode};
use crate::render::sampler::SampleRow;
use crate::render::tracer::{flat_materials, Donor, SecondaryRays};
use crate::rig::{Camera, Rig};
use crate::shapes::SurfaceHit;
use crate::world::World;

/// No hit.
pub(super) const NONE: SurfaceHit = SurfaceHit {
    t: f32::INFINITY,
    u: 0.0,
    v: 0.0,
};

/// What a batch's views share of their shading, and how their secondary
/// rays go: the twin method's (exact, or with the paper's techniques), or
/// the fast method's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::render) struct Shading {
    pub sharing: Sharing,
    pub secondary: SecondaryRays,
}

/// Whose shading a view's sample may take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::render) enum Sharing {
    /// None: every group of samples is shaded exactly, as one packet.
    Exact,
    /// The paper's reprojection, safe: view 0's light and secondary colour,
    /// where the sample sees the same point and the tree is diffuse
    /// (`threshold`).
    Reproject { threshold: f32 },
    /// The paper's reprojection as published: view 0's colour where its hit
    /// projects.
    ReprojectForward { threshold: f32 },
    /// The fast method's shading cache, within `tolerance`.
    Cache { tolerance: f32 },
}

impl Shading {
    /// The twin method's, with the paper's techniques asked for.
    pub(in crate::render) fn of_paper(paper: PaperTechniques) -> Shading {
        let sharing = match paper.reproject {
            None => Sharing::Exact,
            Some(r) if r.mode == ReprojectMode::Safe => Sharing::Reproject {
                threshold: r.threshold,
            },
            Some(r) => Sharing::ReprojectForward {
                threshold: r.threshold,
            },
        };
        Shading {
            sharing,
            secondary: match paper.merge_secondary {
                true => SecondaryRays::MergedOnPlanes,
                false => SecondaryRays::Own,
            },
        }
    }

    /// The fast method's batches: the shading cache within the tolerance,
    /// as its stages say; every view traces its own secondary rays.
    pub(in crate::render) fn of_fast(stages: &FastStages) -> Shading {
        Shading {
            sharing: match stages.shared_cache {
                true => Sharing::Cache {
                    tolerance: stages.tolerance,
                },
                false => Sharing::Exact,
            },
            secondary: SecondaryRays::Own,
        }
    }
}

/// A twin batch: some neighbouring views of the rig traced together, one
/// packet lane per view, and what every row of them shares: the scene, the
/// batch's views (a rig of their own: its view 0 leads the groups) and their eyes.
pub(in crate::render) struct TwinBatch<'a, const K: usize> {
    pub world: &'a World,
    pub camera: &'a Camera,
    pub rig: Rig,
    pub views: usize,
    /// Index of the batch's view 0 in the whole rig (for the per-view counts).
    pub first_view: usize,
    pub origins: [Vec3; K],
    pub shifts: Vec<i32>,
    pub min_shift: i32,
    pub max_shift: i32,
    /// What the batch's views share of their shading, and how their
    /// secondary rays go.
    pub shading: Shading,
    /// Per material, whether every eye hit on it shades to one colour
    /// (`tracer::flat_materials`): the mono row shades one and copies it.
    pub flat: Vec<bool>,
    /// Lanes per packet of donors, takers and exact groups (`packed`):
    /// `EYE_PACKET`, or 1 in the tests' reference.
    pub packet_lanes: usize,
}

/// A row's eye rays and hits, kept per worker thread from row to row.
#[derive(Default)]
pub(in crate::render) struct RowScratch<const K: usize> {
    /// `dirs[v][i]`: view `v`'s eye ray direction through sample `i`.
    pub dirs: Vec<Vec<Vec3>>,
    /// `hits[v][i]`: the nearest hit of view `v`'s sample `i`.
    pub hits: Vec<Vec<(u32, SurfaceHit)>>,
    /// `points[v][i]`: where it is (`None` also for hits beyond a cut).
    pub points: Vec<Vec<Option<Vec3>>>,
    /// With a cut: `far[v][i]`, whether the hit lies beyond it; per camera
    /// column from `first_column`, the rig centre's ray along it, its
    /// nearest hit beyond the cut, and that hit's colour.
    pub far: Vec<Vec<bool>>,
    pub first_column: i32,
    pub far_rays: Vec<Option<(Vec3, u32, SurfaceHit)>>,
    pub far_colors: Vec<Option<Color>>,
    pub claimed: Vec<Vec<bool>>,
    pub groups: Vec<Group<K>>,
    pub donor: Donor,
    /// Donors and the samples that take their light, eight to a packet
    /// (`packed`).
    pub donors: DonorPacket,
    pub takers: TakerPacket,
    pub kept: KeptShading,
    /// Paper-mode reprojection: per view and sample, the depth of the nearest
    /// point of view 0 projected there so far, and its colour if it gives it.
    pub received: Vec<Vec<Option<Received>>>,
    /// A batch of one view traced without grouping (`trace_mono_row`): per
    /// sample, its eye ray's direction and nearest hit.
    pub mono: Vec<(Vec3, u32, SurfaceHit)>,
    /// Per material whose eye hits shade to one colour (`TwinBatch::flat`),
    /// that colour once a hit on it was shaded.
    pub flat: Vec<Option<Color>>,
}

/// Sizes `v` to `views` rows of `len` copies of `fill`.
pub(super) fn fit<T: Clone>(v: &mut Vec<Vec<T>>, views: usize, len: usize, fill: T) {
    v.resize_with(views, Vec::new);
    for row in v.iter_mut() {
        row.clear();
        row.resize(len, fill.clone());
    }
}

impl<const K: usize> RowScratch<K> {
    /// Sizes the buffers every mode uses for `views` views of a row of `len`
    /// samples; `far` (a cut) and `received` (the paper's reprojection) are
    /// sized by the stages that use them.
    pub(super) fn reset(&mut self, views: usize, len: usize) {
        fit(&mut self.dirs, views, len, Vec3::Z);
        fit(&mut self.hits, views, len, (PacketHits::<K>::NO_HIT, NONE));
        fit(&mut self.points, views, len, None);
        fit(&mut self.claimed, views, len, false);
    }
}

impl<'a, const K: usize> TwinBatch<'a, K> {
    /// The twin batch of the views `first_view..first_view + rig.views.len()` of a
    /// job, `rig` holding just them.
    pub(super) fn new(
        job: &RenderInputs<'a>,
        rig: Rig,
        first_view: usize,
        shading: Shading,
    ) -> TwinBatch<'a, K> {
        let camera = job.camera;
        let n = rig.views.len();
        let mut origins = [camera.eye; K];
        for (v, view) in rig.views.iter().enumerate() {
            origins[v] = camera.eye_at(view.offset);
        }
        let shifts: Vec<i32> = rig.views.iter().map(|v| v.shift).collect();
        TwinBatch {
            world: job.world,
            camera,
            views: n,
            first_view,
            origins,
            min_shift: shifts.iter().copied().min().unwrap_or(0),
            max_shift: shifts.iter().copied().max().unwrap_or(0),
            shifts,
            rig,
            shading,
            flat: flat_materials(&job.world.scene, &job.opts.trace),
            packet_lanes: EYE_PACKET,
        }
    }

    pub(in crate::render) fn dir(
        &self,
        scratch: &RowScratch<K>,
        view: usize,
        sample: usize,
    ) -> Vec3 {
        scratch.dirs[view][sample]
    }

    pub(in crate::render) fn has_hit(scratch: &RowScratch<K>, view: usize, sample: usize) -> bool {
        scratch.hits[view][sample].0 != PacketHits::<K>::NO_HIT
    }

    /// `f(i, direction)` for every sample `i` of `row`, in order, of the
    /// view of image shift `shift`: eight at a time (`Camera::directions8`:
    /// one vector square root and division for eight, each direction
    /// `Camera::direction`'s bit for bit).
    #[inline]
    pub(in crate::render) fn row_dirs(
        &self,
        row: &SampleRow,
        shift: i32,
        mut f: impl FnMut(usize, Vec3),
    ) {
        for first in (0..row.len()).step_by(8) {
            let n = (row.len() - first).min(8);
            let (mut columns, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
            for k in 0..n {
                (columns[k], ys[k]) = row.camera_point(first + k, shift);
            }
            let dirs = self.camera.directions8(columns, ys);
            for (k, &dir) in dirs[..n].iter().enumerate() {
                f(first + k, dir);
            }
        }
    }

    /// The eye rays of a group's samples as one packet, with their known hits.
    pub(in crate::render) fn group_packet(
        &self,
        scratch: &RowScratch<K>,
        group: &Group<K>,
    ) -> (Packet<K>, PacketHits<K>) {
        let mut packet = Packet {
            origins: self.origins,
            dirs: [Vec3::Z; K],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; K],
            mask: 0,
        };
        let mut hits = PacketHits {
            prim: [PacketHits::<K>::NO_HIT; K],
            hit: [NONE; K],
        };
        for (v, sample) in group.iter().enumerate() {
            if let Some(i) = *sample {
                packet.mask |= 1 << v;
                packet.dirs[v] = self.dir(scratch, v, i);
                (hits.prim[v], hits.hit[v]) = scratch.hits[v][i];
            }
        }
        (packet, hits)
    }

    /// The rig centre's eye ray along `dir` (what every view sees beyond a cut).
    pub(in crate::render) fn centre_ray(&self, dir: Vec3) -> Packet<1> {
        self.eye_ray(self.camera.eye, dir)
    }

    /// An empty packet of eight eye rays from `origin` (the mono row's
    /// lanes: its directions and mask written in place).
    pub(in crate::render) fn mono_packet(&self, origin: Vec3) -> Packet<EYE_PACKET> {
        Packet {
            origins: [origin; EYE_PACKET],
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: 0,
        }
    }

    pub(in crate::render) fn eye_ray(&self, origin: Vec3, dir: Vec3) -> Packet<1> {
        Packet {
            origins: [origin],
            dirs: [dir],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY],
            mask: 1,
        }
    }

    /// Whether view `v`'s sample `k` sees the surface point that view 0's
    /// sample `i` sees: the same primitive (or one plane of one material),
    /// the same face of it (views either side of its plane see two faces,
    /// lit apart), and within one pixel's footprint on the surface.
    pub(in crate::render) fn same_point(
        &self,
        scratch: &RowScratch<K>,
        i: usize,
        v: usize,
        k: usize,
    ) -> bool {
        let ((prim0, _), (prim, hit)) = (scratch.hits[0][i], scratch.hits[v][k]);
        let (Some(p0), Some(p)) = (scratch.points[0][i], scratch.points[v][k]) else {
            return false;
        };
        if prim != prim0 && !self.world.coplanar(prim0, prim) {
            return false;
        }
        let d = self.dir(scratch, v, k);
        let shape = &self.world.scene.shapes[prim as usize];
        // One normal for both rays: coplanar triangles wound apart are one face.
        let normal = shape.geometric_normal(p);
        if (normal.dot(d) < 0.0) != (normal.dot(self.dir(scratch, 0, i)) < 0.0) {
            return false;
        }
        let cos = normal.dot(d).abs().max(0.05);
        let footprint = self.camera.pixel_size * hit.t / cos;
        (p - p0).length() <= footprint
    }
}
