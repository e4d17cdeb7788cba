//! Interpolated views (approximate, `--interpolate-views`): on a span of a
//! camera column's views that the eye runs proved to see one primitive
//! (`strip`, `bvh/run.rs`), the views between the two ends take the colour
//! interpolated linearly in offset between the ends' finished colours, with
//! no shading and no shadow rays, where that is provably close:
//!
//! 1. **view-independent shading** — the primitive's material has no
//!    highlight (`ks` 0) and mirror + transmission weights of at most the
//!    tolerance `E`, and so has each end's whole shading tree;
//! 2. **a flat, plain surface** — a flat triangle (no per-corner normals or
//!    colours), no texture, emission, occlusion, alpha or normal map: the
//!    ends' light is the same function of the hit point, whose segment the
//!    views between sweep;
//! 3. **the ends agree** — their colours differ by at most `E` per channel;
//! 4. **the light is nearly linear and unshadowed between the hits** — the
//!    key views' test (`Tracer::chains_agree`): both ends' shading trees hit
//!    the same primitives, the direct light's second derivative along the
//!    segment bounds the interpolation's error by `E`, and one shadow fan per
//!    light proves nothing shadows the segment from the light.
//!
//! Otherwise the span's middle view is shaded exactly and both halves are
//! judged again, down to neighbours (as the eye runs split). The ends and
//! middles are shaded one at a time, each exactly as the batches would (the
//! same colour bit for bit); the batches skip the samples this pass owns (it
//! hands them a miss and overwrites the background they shade).
//!
//! What the images owe to the order of work: nothing. A row's spans are
//! those of its own families, judged in a fixed order by one thread.

use super::sampler::{RowColors, SampleRow};
use super::strip::StripRow;
use super::tracer::{Chain, Donor, Link, SecondaryRays};
use super::Tracer;
use crate::bvh::{distance_to_segment, Packet, PacketHits};
use crate::math::{Color, Vec3};
use crate::rig::{Camera, Rig};
use crate::shapes::{Shape, SurfaceHit, TriangleNormals};
use crate::world::World;
use serde::Serialize;

/// `--interpolate-views`: the views between proved key views of a camera
/// column interpolated (see `render::interpolated_views`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InterpolateViews {
    /// Largest error, in image values (1 = white), that the interpolation
    /// may add per channel where radiance is at most 1 (`E`).
    pub tolerance: f32,
}

/// What the interpolation did (`--stats`, `-v`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct InterpStats {
    /// Proved spans (of three views or more) on a hit primitive.
    pub spans: u64,
    /// Of those, spans not taken for the primitive's material (rule 1: a
    /// highlight, mirror or glass) or its shape (rule 2: curved, a map,
    /// per-corner normals or colours); their samples are shaded by the
    /// batches.
    pub spans_refused_material: u64,
    pub spans_refused_surface: u64,
    /// Pairs of shaded views judged, and those refused: an end's shading
    /// tree view-dependent beyond the tolerance (rule 1), the colours apart
    /// (rule 3), the light's curvature, a shadow or the trees' primitives
    /// (rule 4).
    pub pairs: u64,
    pub refused_tree: u64,
    pub refused_colour: u64,
    pub refused_light: u64,
    /// Of rule 4's refusals, those decided by the ends' own shadow rays (a
    /// light one end sees and the other not, or neither sees though it
    /// faces them): no shadow fan asked.
    pub refused_shadow: u64,
    /// Spans whose views between were too few to be worth judging (a shadow
    /// fan costs more than their shading): shaded.
    pub short_spans: u64,
    /// Samples this pass shaded exactly (ends and middles), and samples that
    /// took an interpolated colour.
    pub shaded: u64,
    pub interpolated: u64,
}

/// The fewest views between two shaded ones that are judged: fewer are
/// shaded (see docs/benchmarks.md, "Issue 16, fifth pass").
const MIN_BETWEEN: usize = 1;

/// What every row of a render's interpolation shares.
pub(super) struct ViewInterpolation<'a> {
    world: &'a World,
    camera: &'a Camera,
    /// Every view's eye and offset on the camera line.
    origins: Vec<Vec3>,
    offsets: Vec<f32>,
    shifts: Vec<i32>,
    tolerance: f32,
    /// The fewest views between two shaded ones that are judged (fewer are
    /// shaded).
    min_between: usize,
}

/// A sample the pass owns: its view and sample, its eye hit, and once
/// shaded or interpolated its colour (with, for a shaded one, its shading
/// tree's largest coefficient and its chain).
struct Owned {
    view: usize,
    sample: usize,
    hit: (u32, SurfaceHit),
    color: Option<Color>,
    coefficient: f32,
    chain: usize,
}

/// One thread's buffers, reused from row to row.
#[derive(Default)]
pub(super) struct InterpScratch {
    /// `index[v][i]`: the owned entry of view `v`'s sample `i` (`u32::MAX`:
    /// not owned).
    index: Vec<Vec<u32>>,
    owned: Vec<Owned>,
    /// The spans taken: their owned entries in offset order, as
    /// `span_entries[start..start + len]`.
    spans: Vec<(usize, usize)>,
    span_entries: Vec<u32>,
    chains: Vec<Chain>,
    chains_used: usize,
    /// Per shaded sample (by its chain's index), its transmittance toward
    /// each light.
    through: Vec<f32>,
    pairs: Vec<(usize, usize)>,
    donor: Donor,
}

impl<'a> ViewInterpolation<'a> {
    pub(super) fn new(
        world: &'a World,
        camera: &'a Camera,
        rig: &Rig,
        settings: InterpolateViews,
    ) -> Self {
        ViewInterpolation {
            world,
            camera,
            origins: rig.views.iter().map(|v| camera.eye_at(v.offset)).collect(),
            offsets: rig.views.iter().map(|v| v.offset).collect(),
            shifts: rig.views.iter().map(|v| v.shift).collect(),
            tolerance: settings.tolerance,
            min_between: MIN_BETWEEN,
        }
    }

    /// Whether `prim`'s material may give view-independent light (rule 1).
    fn view_independent(&self, prim: u32) -> bool {
        let m = self.world.material_of(prim);
        m.ks <= 0.0 && m.mirror + m.t <= self.tolerance
    }

    /// Whether `prim` is a flat triangle with an even, unmapped material
    /// (rule 2: the premise of the light's curvature bound).
    fn plain_flat(&self, prim: u32) -> bool {
        let m = self.world.material_of(prim);
        matches!(&self.world.scene.shapes[prim as usize],
            Shape::Triangle(t) if t.normals == TriangleNormals::Flat)
            && m.texture.is_none()
            && m.emission_texture.is_none()
            && m.occlusion_texture.is_none()
            && m.alpha_texture.is_none()
            && m.normal_map.is_none()
    }

    /// Takes the proved spans of `strip`'s row that may be interpolated:
    /// their samples become this pass's, and the batches are handed a miss
    /// for them (`strip.hits`), which `finish_row` overwrites.
    pub(super) fn claim(&self, tracer: &mut Tracer, strip: &mut StripRow, s: &mut InterpScratch) {
        s.owned.clear();
        s.spans.clear();
        s.span_entries.clear();
        s.chains_used = 0;
        if !strip.traced {
            return;
        }
        let len = strip.hits.first().map_or(0, Vec::len);
        s.index.resize_with(strip.hits.len(), Vec::new);
        for row in s.index.iter_mut() {
            row.clear();
            row.resize(len, u32::MAX);
        }
        let stats = &mut tracer.counts.interp;
        for span in &strip.proved {
            if span.prim == u32::MAX || span.len < 3 {
                continue;
            }
            let members = &strip.proved_members[span.start..span.start + span.len];
            // A member whose kept-hit check failed was traced alone: it may
            // (in principle) have found another primitive.
            if members
                .iter()
                .any(|&(v, i)| strip.hits[v][i].0 != span.prim)
            {
                continue;
            }
            stats.spans += 1;
            if !self.view_independent(span.prim) {
                stats.spans_refused_material += 1;
                continue;
            }
            if !self.plain_flat(span.prim) {
                stats.spans_refused_surface += 1;
                continue;
            }
            let start = s.span_entries.len();
            for &(v, i) in members {
                if s.index[v][i] == u32::MAX {
                    s.index[v][i] = s.owned.len() as u32;
                    s.owned.push(Owned {
                        view: v,
                        sample: i,
                        hit: strip.hits[v][i],
                        color: None,
                        coefficient: 0.0,
                        chain: usize::MAX,
                    });
                }
                s.span_entries.push(s.index[v][i]);
            }
            s.spans.push((start, members.len()));
        }
        for o in &s.owned {
            strip.hits[o.view][o.sample] = super::strip::NO_HIT;
        }
    }

    /// The owned samples' colours into `out` (`out[v][i]`, every view of
    /// the rig): each span's ends shaded, then judged pair by pair (see the
    /// module), interpolated or split at the middle view.
    pub(super) fn finish_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        s: &mut InterpScratch,
        out: &mut [RowColors],
    ) {
        for span in 0..s.spans.len() {
            let (start, len) = s.spans[span];
            s.pairs.clear();
            s.pairs.push((0, len - 1));
            while let Some((a, b)) = s.pairs.pop() {
                let (ea, eb) = (s.span_entries[start + a], s.span_entries[start + b]);
                self.shade(tracer, row, s, ea);
                self.shade(tracer, row, s, eb);
                if b - a < 2 {
                    continue;
                }
                if b - a - 1 < self.min_between {
                    tracer.counts.interp.short_spans += 1;
                    for k in a + 1..b {
                        self.shade(tracer, row, s, s.span_entries[start + k]);
                    }
                    continue;
                }
                let between = &s.span_entries[start + a + 1..start + b];
                if self.close(tracer, row, s, ea, eb, between) {
                    let (oa, ob) = (&s.owned[ea as usize], &s.owned[eb as usize]);
                    let (ca, cb) = (oa.color.unwrap_or_default(), ob.color.unwrap_or_default());
                    let (xa, xb) = (self.offsets[oa.view], self.offsets[ob.view]);
                    for &e in between {
                        let o = &mut s.owned[e as usize];
                        let w = (self.offsets[o.view] - xa) / (xb - xa);
                        o.color = Some(ca * (1.0 - w) + cb * w);
                        tracer.counts.interp.interpolated += 1;
                    }
                } else {
                    let m = (a + b) / 2;
                    s.pairs.push((m, b));
                    s.pairs.push((a, m));
                }
            }
        }
        for o in &s.owned {
            if let Some(c) = o.color {
                out[o.view][o.sample] = c;
            }
        }
    }

    /// View `o.view`'s eye ray through sample `o.sample` and its known hit.
    fn eye_packet(&self, row: &SampleRow, o: &Owned) -> (Packet<1>, PacketHits<1>) {
        let (column, y) = row.camera_point(o.sample, self.shifts[o.view]);
        let packet = Packet {
            origins: [self.origins[o.view]],
            dirs: [self.camera.direction(column, y)],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY],
            mask: 1,
        };
        let hits = PacketHits {
            prim: [o.hit.0],
            hit: [o.hit.1],
        };
        (packet, hits)
    }

    /// Shades owned entry `e` exactly, with its chain, unless it has a colour.
    fn shade(&self, tracer: &mut Tracer, row: &SampleRow, s: &mut InterpScratch, e: u32) {
        if s.owned[e as usize].color.is_some() {
            return;
        }
        let (packet, hits) = self.eye_packet(row, &s.owned[e as usize]);
        if s.chains_used == s.chains.len() {
            s.chains.push(Chain::new());
        }
        let c = s.chains_used;
        s.chains_used += 1;
        tracer.shade_key(
            &packet,
            &hits,
            SecondaryRays::Own,
            &mut s.donor,
            &mut s.chains[c],
        );
        // The tree's chain lists its secondary rays; its eye hit leads it,
        // so that `chains_agree` judges the eye hit's light too.
        let t = hits.hit[0].t;
        s.chains[c].insert(
            0,
            Link {
                level: 1,
                prim: hits.prim[0],
                point: packet.origins[0] + packet.dirs[0] * t,
                dir: packet.dirs[0],
                t,
            },
        );
        let lights = self.world.scene.lights.len();
        s.through.resize((c + 1) * lights, 0.0);
        s.through[c * lights..].copy_from_slice(&s.donor.through[..lights]);
        let o = &mut s.owned[e as usize];
        o.color = Some(s.donor.color);
        o.coefficient = s.donor.tree_coefficient;
        o.chain = c;
        tracer.counts.interp.shaded += 1;
    }

    /// Whether the views `between` may take the colour interpolated between
    /// shaded entries `a` and `b` (rules 1, 3 and 4 of the module; rule 2
    /// was checked when the span was claimed).
    fn close(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        s: &InterpScratch,
        a: u32,
        b: u32,
        between: &[u32],
    ) -> bool {
        let (oa, ob) = (&s.owned[a as usize], &s.owned[b as usize]);
        let e = self.tolerance;
        tracer.counts.interp.pairs += 1;
        if oa.coefficient > e || ob.coefficient > e {
            tracer.counts.interp.refused_tree += 1;
            return false;
        }
        let (ca, cb) = (oa.color.unwrap_or_default(), ob.color.unwrap_or_default());
        if (ca - cb).abs().max_element() > e {
            tracer.counts.interp.refused_colour += 1;
            return false;
        }
        if self.shadowed(s, oa, ob) {
            tracer.counts.interp.refused_shadow += 1;
            return false;
        }
        // The views between hit the segment between the ends' hits but for
        // rounding: the fans are widened by how far they stray from it.
        let point = |o: &Owned| {
            let (p, _) = self.eye_packet(row, o);
            p.origins[0] + p.dirs[0] * o.hit.1.t
        };
        let (pa, pb) = (point(oa), point(ob));
        let slack = between
            .iter()
            .map(|&k| distance_to_segment(point(&s.owned[k as usize]), pa, pb))
            .fold(0.0f32, f32::max);
        let agree = slack.is_finite()
            && tracer.chains_agree(&s.chains[oa.chain], &s.chains[ob.chain], 2.0 * slack, e);
        if !agree {
            tracer.counts.interp.refused_light += 1;
        }
        agree
    }

    /// Whether the ends' own shadow rays refuse the pair before any fan is
    /// asked: toward some light, one end is lit and the other not, a shadow
    /// dims either, or neither is lit though one faces it (`chains_agree`
    /// would refuse all of these, the last two after a fan's descent).
    fn shadowed(&self, s: &InterpScratch, a: &Owned, b: &Owned) -> bool {
        let scene = &self.world.scene;
        let lights = scene.lights.len();
        let through = |o: &Owned| &s.through[o.chain * lights..][..lights];
        let shape = &scene.shapes[a.hit.0 as usize];
        // Whether the eye hit of `o` (its chain's first link) faces `light`.
        let faces = |o: &Owned, light: Vec3| {
            s.chains[o.chain].first().is_some_and(|link| {
                let n = shape.geometric_normal(link.point);
                let facing = if n.dot(link.dir) < 0.0 { n } else { -n };
                facing.dot(light - link.point) > 0.0
            })
        };
        let (ta, tb) = (through(a), through(b));
        ta.iter().zip(tb).enumerate().any(|(l, (&x, &y))| {
            if x != y || (x > 0.0 && x < 1.0) {
                return true;
            }
            x <= 0.0
                && scene.lights[l]
                    .position()
                    .is_some_and(|p| faces(a, p) || faces(b, p))
        })
    }
}
