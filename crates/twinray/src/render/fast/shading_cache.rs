//! The multi-view shading cache of the fast method's batches: what a
//! surface point's light costs is paid once for every view that sees it.
//!
//! The twin method traces the views of a row of samples batch after batch
//! (`twin`). Each batch's first view (its *leader*) shades, one sample at a
//! time, the points no earlier leader of the row shaded, and keeps their
//! view-independent light here: the transmittance toward each light (shadow
//! rays) and the weighted colour of their reflected and refracted rays. Every
//! later sample of any view that sees a point of the same primitive, on the
//! same face, within half a pixel's width (at its depth) of a kept one takes
//! that light and adds its own
//! ambient, diffuse and highlight terms (its own normal, texture and view
//! direction), tracing no ray.
//!
//! An entry is the cell of a leader's sample: key = the primitive it hit and
//! that sample, whose footprint on the surface is the cell; a point is found
//! in it by projecting it into the leader's image (the rig's views differ along
//! rows only, so the sample is on the same row). The row is filled in a fixed
//! order (batch by batch, sample by sample, and cleared when the row's first
//! batch starts), by one thread: the images do not depend on the thread count.
//!
//! What may be shared (the bound of the fast method's tolerance `E`, see
//! docs/stereo.md, "Shared shading across views"): the receiving and the
//! giving surfaces both have mirror + transmission weights of at most `E`, so the secondary colour
//! taken differs from the sample's own by at most `E × L`, `L` the largest
//! radiance a secondary ray returns (≤ 1 in scenes whose light fits the
//! image's range). Light visibility is taken only from a kept sample whose row
//! neighbours in its own view saw every light as it did: a shadow edge within
//! a pixel of it refuses the entry (the receiving samples are shaded exactly).
//! Texture edges cost nothing: the colour of the surface is the receiver's own.

use crate::math::{Color, Vec3};
use crate::rig::{Camera, View};

use crate::render::sampler::SampleRow;
use crate::render::twin::grouping::nearest_sample;

/// One exactly shaded sample of a leader view.
#[derive(Clone, Copy, Debug)]
struct Entry {
    prim: u32,
    point: Vec3,
    /// The leader saw the primitive's front (against its geometric normal).
    front: bool,
    /// Distance along the leader's eye ray (its footprint's scale).
    t: f32,
    secondary: Color,
    /// Its own surface may give (mirror + transmission ≤ the tolerance).
    gives: bool,
    /// It may be taken: it gives, and no shadow edge passes next to it.
    shareable: bool,
    /// The sample's finished colour.
    color: Color,
    /// Its whole shading tree is diffuse within the tolerance (no highlight,
    /// mirror or transmission weight above it, on any surface of the tree).
    whole: bool,
    /// Its colour may be taken as it is: it is shareable, whole, and its row
    /// neighbours are whole and within the tolerance of its colour.
    finished: bool,
}

/// A sample's hit as the cache keeps and finds it: the primitive hit, the
/// point, the face seen (the front: against the geometric normal), and the
/// distance along the eye ray.
#[derive(Clone, Copy, Debug)]
pub struct Seen {
    pub prim: u32,
    pub point: Vec3,
    pub front: bool,
    pub t: f32,
}

/// What a leader's exactly shaded sample leaves in the cache (`keep`).
#[derive(Clone, Copy, Debug)]
pub struct Kept<'a> {
    pub seen: Seen,
    /// Transmittance toward each light.
    pub through: &'a [f32],
    /// Weighted colour of its reflected and refracted rays.
    pub secondary: Color,
    /// Its finished colour.
    pub color: Color,
    /// Its surface may give light (mirror + transmission ≤ the tolerance).
    pub gives: bool,
    /// Its whole shading tree is within the tolerance (see `Entry::whole`).
    pub whole: bool,
}

/// A leader view of the row and, per sample, the entry its hit found or made.
#[derive(Debug, Default)]
struct Leader {
    view: Option<View>,
    slots: Vec<Option<u32>>,
}

/// How far back (in leaders) a sample looks for an entry: its own batch's
/// leader, then the two before (a point hidden from one leader is often seen
/// by the one before).
const LEADERS_SEARCHED: usize = 3;

/// The cache of one row of samples, for every view of the rig.
#[derive(Debug, Default)]
pub struct ShadingCache {
    lights: usize,
    /// The tolerance: how far apart a kept colour and its neighbours'
    /// may be for the colour to be taken whole.
    tolerance: f32,
    entries: Vec<Entry>,
    /// `lights` transmittances per entry.
    through: Vec<f32>,
    leaders: Vec<Leader>,
    /// Leaders in use this row (`leaders` keeps the others' buffers).
    used: usize,
    /// The first entry of the current leader (`settle` judges those).
    first_new: usize,
}

/// What a sample found in the cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Found(u32);

impl ShadingCache {
    /// Empties the cache for a new row of samples (the row's first batch),
    /// for a scene of `lights` lights and the sharing's `tolerance`.
    pub fn start_row(&mut self, lights: usize, tolerance: f32) {
        self.lights = lights;
        self.tolerance = tolerance;
        self.entries.clear();
        self.through.clear();
        self.used = 0;
        self.first_new = 0;
    }

    /// The next batch's leader, `view`, for a row of `len` samples.
    pub fn begin_leader(&mut self, view: View, len: usize) {
        if self.used == self.leaders.len() {
            self.leaders.push(Leader::default());
        }
        let leader = &mut self.leaders[self.used];
        leader.view = Some(view);
        leader.slots.clear();
        leader.slots.resize(len, None);
        self.used += 1;
        self.first_new = self.entries.len();
    }

    fn current(&mut self) -> Option<&mut Leader> {
        self.used.checked_sub(1).map(|l| &mut self.leaders[l])
    }

    /// Keeps the current leader's exactly shaded sample `i` (see [`Kept`]).
    pub fn keep(&mut self, i: usize, kept: Kept) {
        let e = self.entries.len() as u32;
        self.entries.push(Entry {
            prim: kept.seen.prim,
            point: kept.seen.point,
            front: kept.seen.front,
            t: kept.seen.t,
            secondary: kept.secondary,
            gives: kept.gives,
            shareable: false,
            color: kept.color,
            whole: kept.whole,
            finished: false,
        });
        let lights = self.lights;
        self.through
            .extend((0..lights).map(|l| kept.through.get(l).copied().unwrap_or(0.0)));
        self.point_to(i, Found(e));
    }

    /// The current leader's sample `i` sees the point of entry `found`.
    pub fn point_to(&mut self, i: usize, found: Found) {
        if let Some(slot) = self.current().and_then(|l| l.slots.get_mut(i)) {
            *slot = Some(found.0);
        }
    }

    fn through_of(&self, e: u32) -> &[f32] {
        let at = e as usize * self.lights;
        &self.through[at..at + self.lights]
    }

    /// Judges the current leader's new entries: one may be taken if it gives
    /// and each of its row neighbours (in the leader's row) points to an entry
    /// that gives and saw every light exactly as it did — no shadow edge
    /// passes within a pixel of it. Its colour may be taken whole if, besides,
    /// it and its neighbours' entries are whole and their colours lie within
    /// the tolerance of its own (no texture, silhouette or shading edge within
    /// a pixel). Returns how many were refused for a shadow edge.
    pub fn settle(&mut self) -> u64 {
        let Some(l) = self.used.checked_sub(1) else {
            return 0;
        };
        let slots = std::mem::take(&mut self.leaders[l].slots);
        let width = slots.len();
        let mut refused = 0;
        for (i, slot) in slots.iter().enumerate() {
            let Some(e) = *slot else { continue };
            if (e as usize) < self.first_new || !self.entries[e as usize].gives {
                continue;
            }
            let coherent = [i.wrapping_sub(1), i + 1]
                .into_iter()
                .filter(|&j| j < width)
                .all(|j| {
                    slots[j].is_some_and(|n| {
                        self.entries[n as usize].gives && self.through_of(n) == self.through_of(e)
                    })
                });
            // E = 0 shares light only: a colour is then never taken whole.
            let finished = coherent && self.tolerance > 0.0 && self.entries[e as usize].whole && {
                let (own, tolerance) = (self.entries[e as usize].color, self.tolerance);
                [i.wrapping_sub(1), i + 1]
                    .into_iter()
                    .filter(|&j| j < width)
                    .all(|j| {
                        slots[j].is_some_and(|n| {
                            let n = &self.entries[n as usize];
                            n.whole && (n.color - own).abs().max_element() <= tolerance
                        })
                    })
            };
            let entry = &mut self.entries[e as usize];
            entry.shareable = coherent;
            entry.finished = finished;
            refused += u64::from(!coherent);
        }
        self.leaders[l].slots = slots;
        refused
    }

    /// The entry whose light the sample `source` of a row may take, which
    /// `seen` describes. Searched in
    /// the current leader's row, then in the earlier ones': the leader's
    /// sample nearest to where the point projects, if its entry may be taken,
    /// is of the same primitive seen on the same face (views either side of
    /// a surface's plane see two faces, lit apart), and lies within half a
    /// pixel's width (at the nearer of the two depths) of it.
    ///
    /// The radius is not stretched by the surface's slant: both points lie in
    /// the row's plane (the rig's views differ along rows), where the leader's
    /// samples are at least a pixel's width apart, so the point lies between
    /// the kept sample and one of its row neighbours — whose light `settle`
    /// found equal to the kept sample's. (With the slant, a point on a floor
    /// seen at a grazing angle could lie several samples away, beyond a shadow
    /// edge that the neighbours do not see.)
    pub fn find(
        &self,
        camera: &Camera,
        row: &SampleRow,
        source: usize,
        seen: Seen,
    ) -> Option<Found> {
        let Seen {
            prim,
            point,
            front,
            t,
        } = seen;
        self.leaders[..self.used]
            .iter()
            .rev()
            .take(LEADERS_SEARCHED)
            .find_map(|leader| {
                let k = nearest_sample(camera, row, leader.view.as_ref()?, point, source)?;
                let e = (*leader.slots.get(k)?)?;
                let entry = &self.entries[e as usize];
                let radius = 0.5 * camera.pixel_size * t.min(entry.t);
                (entry.shareable
                    && entry.prim == prim
                    && entry.front == front
                    && (point - entry.point).length() <= radius)
                    .then_some(Found(e))
            })
    }

    /// The finished colour of entry `found`, if it may be taken whole.
    pub fn finished(&self, found: Found) -> Option<Color> {
        let entry = &self.entries[found.0 as usize];
        entry.finished.then_some(entry.color)
    }

    /// The light of entry `found`: the transmittance toward each light, and
    /// the weighted secondary colour.
    pub fn light(&self, found: Found) -> (&[f32], Color) {
        (
            self.through_of(found.0),
            self.entries[found.0 as usize].secondary,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::Pattern;
    use crate::scene::Viewpoint;

    /// The rig's centre view, unshifted.
    const CENTRE: View = View {
        offset: 0.0,
        shift: 0,
    };

    fn camera() -> Camera {
        let vp = Viewpoint {
            from: Vec3::new(0.0, 0.0, 5.0),
            at: Vec3::ZERO,
            up: Vec3::Y,
            ..Viewpoint::default()
        };
        Camera::new(&vp, 64, 8)
    }

    fn row() -> SampleRow {
        SampleRow::full(64, Pattern::Fixed { dx: 0.0, y: 4.0 })
    }

    /// The point that the centre view's sample `x` of the row sees on the z = 0 plane.
    fn seen(camera: &Camera, x: usize) -> Vec3 {
        let d = camera.direction(x as f32, 4.0);
        camera.eye + d * (-camera.eye.z / d.z)
    }

    /// A row of one leader (the centre view) whose every sample saw the z = 0
    /// plane (primitive 3) lit, `through[x]` toward the single light.
    fn filled(camera: &Camera, through: impl Fn(usize) -> f32) -> ShadingCache {
        filled_with(camera, through, |_| 0.5)
    }

    /// `filled`, sample `x` of a grey `color(x)` (times its transmittance).
    fn filled_with(
        camera: &Camera,
        through: impl Fn(usize) -> f32,
        color: impl Fn(usize) -> f32,
    ) -> ShadingCache {
        let mut cache = ShadingCache::default();
        cache.start_row(1, 0.01);
        cache.begin_leader(CENTRE, 64);
        for x in 0..64 {
            let p = seen(camera, x);
            let t = (p - camera.eye).length();
            let through = [through(x)];
            cache.keep(
                x,
                Kept {
                    seen: Seen {
                        prim: 3,
                        point: p,
                        front: true,
                        t,
                    },
                    through: &through,
                    secondary: Color::ZERO,
                    color: Color::splat(color(x) * through[0]),
                    gives: true,
                    whole: true,
                },
            );
        }
        cache.settle();
        cache
    }

    fn look(cache: &ShadingCache, camera: &Camera, x: usize, prim: u32, dz: f32) -> Option<Found> {
        look_on(cache, camera, x, prim, dz, true)
    }

    fn look_on(
        cache: &ShadingCache,
        camera: &Camera,
        x: usize,
        prim: u32,
        dz: f32,
        front: bool,
    ) -> Option<Found> {
        let p = seen(camera, x) + Vec3::new(0.0, 0.0, dz);
        let t = (p - camera.eye).length();
        let seen = Seen {
            prim,
            point: p,
            front,
            t,
        };
        cache.find(camera, &row(), x, seen)
    }

    #[test]
    fn a_point_of_the_same_primitive_in_the_cell_finds_the_entry() {
        let camera = camera();
        let cache = filled(&camera, |_| 1.0);
        let found = look(&cache, &camera, 20, 3, 0.0).expect("found");
        assert_eq!(cache.light(found).0, &[1.0]);
    }

    /// The key holds the primitive: another surface through the same point
    /// (an object resting on the plane) takes nothing from it.
    #[test]
    fn another_primitive_at_the_same_point_finds_nothing() {
        let camera = camera();
        let cache = filled(&camera, |_| 1.0);
        assert_eq!(look(&cache, &camera, 20, 4, 0.0), None);
    }

    /// The same point of the same primitive seen on its other face (by a
    /// view on the other side of its plane, which its light may not reach)
    /// takes nothing from it.
    #[test]
    fn the_other_face_of_the_same_point_finds_nothing() {
        let camera = camera();
        let cache = filled(&camera, |_| 1.0);
        assert!(look_on(&cache, &camera, 20, 3, 0.0, true).is_some());
        assert_eq!(look_on(&cache, &camera, 20, 3, 0.0, false), None);
    }

    /// A point farther than half a pixel's footprint (here in front of the
    /// plane, as a thin pole would be) finds nothing.
    #[test]
    fn a_point_outside_the_cell_finds_nothing() {
        let camera = camera();
        let cache = filled(&camera, |_| 1.0);
        let footprint = camera.pixel_size * 5.0;
        assert!(look(&cache, &camera, 20, 3, 0.3 * footprint).is_some());
        assert_eq!(look(&cache, &camera, 20, 3, 2.0 * footprint), None);
    }

    /// A shadow edge between samples 30 and 31: both refuse their entries,
    /// their neighbours beyond keep them.
    #[test]
    fn entries_next_to_a_shadow_edge_are_refused() {
        let camera = camera();
        let cache = filled(&camera, |x| if x <= 30 { 0.0 } else { 1.0 });
        for (x, shared) in [(29, true), (30, false), (31, false), (32, true)] {
            assert_eq!(
                look(&cache, &camera, x, 3, 0.0).is_some(),
                shared,
                "sample {x}"
            );
        }
    }

    /// A colour edge (a texture's or a seam's) between samples 30 and 31, with
    /// the light unchanged: their light may be taken, their colour may not;
    /// their neighbours beyond keep both. Within the tolerance, it may.
    #[test]
    fn colours_next_to_a_colour_edge_are_not_taken_whole() {
        let camera = camera();
        for (step, beyond) in [(0.02, false), (0.005, true)] {
            let cache = filled_with(&camera, |_| 1.0, |x| if x <= 30 { 0.5 } else { 0.5 + step });
            for (x, whole) in [(29, true), (30, beyond), (31, beyond), (32, true)] {
                let found = look(&cache, &camera, x, 3, 0.0).expect("light shared");
                assert_eq!(
                    cache.finished(found).is_some(),
                    whole,
                    "sample {x}, step {step}"
                );
            }
        }
    }

    /// A new row forgets the last one's entries.
    #[test]
    fn a_new_row_starts_empty() {
        let camera = camera();
        let mut cache = filled(&camera, |_| 1.0);
        cache.start_row(1, 0.01);
        cache.begin_leader(CENTRE, 64);
        assert_eq!(look(&cache, &camera, 20, 3, 0.0), None);
    }
}
