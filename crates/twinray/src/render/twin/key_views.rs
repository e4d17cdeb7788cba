//! Key views for view-dependent light (approximate, `--share-shading`,
//! tolerance above 0): a group's lanes that see one mirror or glass
//! primitive are traced in full only at some of them, the key views; a lane
//! between two key views takes its own ambient and direct light plus the key
//! views' secondary colours interpolated by its place between them, where
//! that is close: both key views' secondary rays hit the same primitives,
//! nothing shadows the lights between their hits (`Tracer::chains_agree`),
//! their secondary colours agree within the tolerance, and the lane's own
//! first reflected and refracted rays hit what theirs did (a probe). Any
//! other lane is traced exactly, as one packet with the rest of its group.
//!
//! The key views are every `key_spacing`-th lane that sees the primitive and
//! the last (spacing 1: every view traces its own, as without key views,
//! the group as one packet); with spacing 0 (adaptive), the outermost two, and where two key
//! views disagree, the lane halfway between them becomes a key view too,
//! down to neighbours. The key views' own colours are exact.

use super::{RowScratch, TwinBatch};
use crate::bvh::distance_to_segment;
use crate::math::Color;
use crate::render::grouping::Group;
use crate::render::sampler::RowColors;
use crate::render::tracer::Chain;
use crate::render::Tracer;

/// Per lane of a group: its key view's chain and secondary colour; and the
/// primitive whose key views last interpolated nothing, with the groups of
/// it traced as packets since (cleared for every batch's row: the images do
/// not depend on which thread traced which row).
#[derive(Default)]
pub(super) struct KeyScratch {
    chains: Vec<Chain>,
    secondary: Vec<Color>,
    given_up: Option<u32>,
    skipped: u32,
}

/// Groups of a primitive traced as packets after its key views gave
/// nothing, before they are tried again.
const RETRY_AFTER: u32 = 8;

impl KeyScratch {
    /// Forgets what the last row's key views gave.
    pub(super) fn start_row(&mut self) {
        self.given_up = None;
        self.skipped = 0;
    }
}

impl<const K: usize> TwinBatch<'_, K> {
    /// Shades `group` (exact for its key views, see the module), into `out`.
    pub(super) fn shade_with_key_views(
        &self,
        tracer: &mut Tracer,
        scratch: &mut RowScratch<K>,
        group: &Group<K>,
        tolerance: f32,
        out: &mut [RowColors],
    ) {
        // The lanes that see the primitive of the group's first sample.
        let first = group.iter().enumerate().find_map(|(v, s)| {
            s.filter(|&i| scratch.points[v][i].is_some())
                .map(|i| (v, i))
        });
        let Some((v0, i0)) = first.filter(|_| tolerance > 0.0 && self.key_spacing != 1) else {
            return self.shade_group(tracer, scratch, group, out);
        };
        let prim = scratch.hits[v0][i0].0;
        let material = self.world.material_of(prim);
        if material.mirror <= 0.0 && material.t <= 0.0 {
            // Nothing view-dependent to carry but the highlight: exact.
            return self.shade_group(tracer, scratch, group, out);
        }
        let mut lanes = [0usize; K];
        let mut n = 0;
        for (v, sample) in group.iter().enumerate() {
            if sample
                .is_some_and(|i| scratch.points[v][i].is_some() && scratch.hits[v][i].0 == prim)
            {
                lanes[n] = v;
                n += 1;
            }
        }
        if n < 3 {
            return self.shade_group(tracer, scratch, group, out);
        }
        // A primitive whose last group interpolated nothing is traced as
        // packets for its next groups (key views traced one by one cost more
        // than the packet), with a new try every `RETRY_AFTER` groups.
        if scratch.keys.given_up == Some(prim) && scratch.keys.skipped < RETRY_AFTER {
            scratch.keys.skipped += 1;
            tracer.counts.key_view_skipped_groups += 1;
            return self.shade_group(tracer, scratch, group, out);
        }
        let mut keys = std::mem::take(&mut scratch.keys);
        keys.chains.resize_with(K, Chain::new);
        keys.secondary.resize(K, Color::ZERO);
        let mut rest = *group;
        let mut between: Group<K> = [None; K];
        // Per lane between two key views that agree: those two views.
        let mut span = [(0usize, 0usize); K];
        // Positions (in `lanes`) of consecutive key views still to judge.
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        let spacing = if self.key_spacing == 0 {
            n - 1
        } else {
            self.key_spacing
        };
        let mut a = 0;
        self.trace_key(tracer, scratch, &mut keys, group, lanes[0], out);
        rest[lanes[0]] = None;
        while a < n - 1 {
            let b = (a + spacing).min(n - 1);
            self.trace_key(tracer, scratch, &mut keys, group, lanes[b], out);
            rest[lanes[b]] = None;
            if b - a >= 2 {
                pairs.push((a, b));
            }
            a = b;
        }
        while let Some((a, b)) = pairs.pop() {
            let (va, vb) = (lanes[a], lanes[b]);
            let point = |v: usize| group[v].and_then(|i| scratch.points[v][i]);
            // How far the views between see their point off the line of the
            // key views' points: their rays start that much aside.
            let slack = match (point(va), point(vb)) {
                (Some(pa), Some(pb)) => lanes[a + 1..b]
                    .iter()
                    .filter_map(|&v| point(v))
                    .map(|p| distance_to_segment(p, pa, pb))
                    .fold(0.0f32, f32::max),
                _ => f32::INFINITY,
            };
            let close = (keys.secondary[va] - keys.secondary[vb])
                .abs()
                .max_element()
                <= tolerance
                && slack.is_finite()
                && tracer.chains_agree(&keys.chains[va], &keys.chains[vb], 2.0 * slack, tolerance);
            if close {
                for &v in &lanes[a + 1..b] {
                    let Some(k) = group[v] else { continue };
                    let (packet, hits) = self.sample_packet(scratch, v, k);
                    if tracer.probe_matches(&packet, &hits, &keys.chains[va]) {
                        between[v] = Some(k);
                        span[v] = (va, vb);
                        rest[v] = None;
                    } else {
                        tracer.counts.key_view_fallbacks += 1;
                    }
                }
            } else if self.key_spacing == 0 {
                // Adaptive: the lane halfway becomes a key view.
                let m = (a + b) / 2;
                self.trace_key(tracer, scratch, &mut keys, group, lanes[m], out);
                rest[lanes[m]] = None;
                pairs.extend([(a, m), (m, b)].into_iter().filter(|(x, y)| y - x >= 2));
            } else {
                tracer.counts.key_view_fallbacks += (b - a - 1) as u64;
            }
        }
        if between.iter().any(Option::is_some) {
            let (packet, hits) = self.group_packet(scratch, &between);
            let direct = tracer.shade_direct(&packet, &hits);
            for (v, sample) in between.iter().enumerate() {
                let Some(k) = *sample else { continue };
                let (left, right) = span[v];
                let w = (v - left) as f32 / (right - left) as f32;
                out[v][k] =
                    direct[v] + keys.secondary[left] * (1.0 - w) + keys.secondary[right] * w;
                tracer.counts.interpolated_samples += 1;
            }
        }
        if between.iter().any(Option::is_some) {
            keys.given_up = None;
        } else {
            keys.given_up = Some(prim);
            keys.skipped = 0;
        }
        scratch.keys = keys;
        if rest.iter().any(Option::is_some) {
            self.shade_group(tracer, scratch, &rest, out);
        }
    }

    /// Traces view `v`'s sample of `group` in full as a key view: its colour
    /// into `out`, its chain and secondary colour into `keys`.
    fn trace_key(
        &self,
        tracer: &mut Tracer,
        scratch: &mut RowScratch<K>,
        keys: &mut KeyScratch,
        group: &Group<K>,
        v: usize,
        out: &mut [RowColors],
    ) {
        let Some(k) = group[v] else { return };
        let (packet, hits) = self.sample_packet(scratch, v, k);
        let mut donor = std::mem::take(&mut scratch.donor);
        tracer.shade_key(
            &packet,
            &hits,
            self.secondary,
            &mut donor,
            &mut keys.chains[v],
        );
        out[v][k] = donor.color;
        keys.secondary[v] = donor.secondary;
        scratch.donor = donor;
    }
}
