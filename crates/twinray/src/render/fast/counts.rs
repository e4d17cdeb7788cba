//! What the fast method did (`--stats`, `-v`): its shading cache and its
//! epipolar rows.

use serde::Serialize;

/// The fast method's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct FastCounts {
    pub cache: CacheCounts,
    pub epipolar: EpipolarCounts,
}

/// The shading cache the batches of views share (`shading_cache`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct CacheCounts {
    /// Samples shaded exactly and kept for other views; of those, the ones
    /// refused for a shadow edge next to them.
    pub entries: u64,
    pub edge_refusals: u64,
    /// Samples that took a kept sample's light; of those, the ones that took
    /// its finished colour, computing nothing.
    pub hits: u64,
    pub colour_hits: u64,
    /// Samples that might have taken an entry but found none: shaded exactly.
    pub fallbacks: u64,
}

/// What the epipolar rows did (`--stats`, `-v`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct EpipolarCounts {
    /// Rows done in their plane, and rows traced exactly in every view
    /// (other samplings, a tree deeper than the descent's stack).
    pub rows: u64,
    pub rows_exact: u64,
    /// Primitives gathered for the rows (summed over rows), and the exact
    /// ray tests the visibility made.
    pub primitives: u64,
    pub tests: u64,
    /// Samples that took their colour from two shade points; those that
    /// took their light (shaded with it, no ray traced); and those that took
    /// the light of the lights their shade points saw alike and traced their
    /// own shadow rays toward the others, `lights_traced` rays in all.
    pub taken: u64,
    pub light_taken: u64,
    pub light_partly_taken: u64,
    pub lights_traced: u64,
    /// Samples traced and shaded exactly, and those that hit nothing.
    pub traced: u64,
    pub misses: u64,
    /// Why samples were traced: no shade point on one side; the two shade
    /// points' colours apart or not straight with their neighbours' (or no
    /// neighbour to tell) and their light not alike; the two too far apart
    /// in the view, not either side of the sample or not at its depth; one
    /// of the two seen on the other face of the surface (by a view on the
    /// other side of its plane); a mirror, glass or highlight; a section
    /// through the eyes.
    pub no_bracket: u64,
    pub refused_colour: u64,
    pub refused_wide: u64,
    pub refused_face: u64,
    pub refused_material: u64,
    pub refused_shape: u64,
    /// Shade points kept.
    pub shade_points: u64,
}

impl FastCounts {
    /// The `-v` lines: one per stage that ran, or one saying that none did
    /// (the views were traced exactly: a pair or the adaptive sampling
    /// outside the epipolar rows).
    pub fn lines(&self) -> Vec<String> {
        let (c, e) = (&self.cache, &self.epipolar);
        let mut lines = Vec::new();
        if *c != CacheCounts::default() {
            lines.push(format!(
                "fast, shared shading: cache entries {} (refused at a shadow edge {}), samples that took an entry's light {} (its whole colour {}), exact fall-backs {}",
                c.entries, c.edge_refusals, c.hits, c.colour_hits, c.fallbacks
            ));
        }
        if *e != EpipolarCounts::default() {
            lines.push(format!(
                "fast, epipolar rows: {} in their planes ({} traced exactly), primitives gathered {}, visibility tests {}; samples: colour taken {}, light taken {}, light partly taken {} ({} shadow rays), shaded exactly {} (no shade point {}, colours and light apart {}, shade points apart {}, seen on the other face {}, mirror, glass or highlight {}, shape {}), background {}; shade points {}",
                e.rows, e.rows_exact, e.primitives, e.tests, e.taken, e.light_taken, e.light_partly_taken, e.lights_traced, e.traced, e.no_bracket, e.refused_colour, e.refused_wide, e.refused_face, e.refused_material, e.refused_shape, e.misses, e.shade_points
            ));
        }
        if lines.is_empty() {
            lines.push("fast: nothing shared, every view traced exactly".into());
        }
        lines
    }
}
