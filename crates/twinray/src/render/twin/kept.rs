//! What the paper's safe reprojection keeps of a row's donors for the
//! other views (`reprojection`), and what its published form gives a
//! sample.

use crate::math::Color;
use crate::render::tracer::Donors;

/// Paper-mode reprojection: the depth of the nearest point of view 0 that
/// landed on a sample, and its colour if its shading tree is diffuse.
pub(super) type Received = (f32, Option<Color>);

/// Per sample of view 0 in a row, what a donor kept for the other views
/// (safe reprojection).
#[derive(Default)]
pub(in crate::render) struct KeptShading {
    pub(super) lights: usize,
    /// Shaded alone as a donor in step 1.
    pub(super) donor: Vec<bool>,
    /// A donor whose whole shading tree is diffuse.
    pub(super) diffuse: Vec<bool>,
    /// Transmittance toward each light, `lights` per sample.
    pub(super) through: Vec<f32>,
    pub(super) secondary: Vec<Color>,
}

impl KeptShading {
    pub(super) fn reset(&mut self, width: usize, lights: usize) {
        self.lights = lights;
        self.donor.clear();
        self.donor.resize(width, false);
        self.diffuse.clear();
        self.diffuse.resize(width, false);
        self.through.clear();
        self.through.resize(width * lights, 0.0);
        self.secondary.clear();
        self.secondary.resize(width, Color::ZERO);
    }

    /// Sample `i` was shaded as lane `l` of a packet of donors.
    pub(super) fn keep_lane(&mut self, i: usize, donors: &Donors, l: usize, threshold: f32) {
        self.donor[i] = true;
        self.diffuse[i] = donors.tree_coefficients[l] <= threshold;
        let lights = self.lights;
        self.through[i * lights..(i + 1) * lights].copy_from_slice(donors.through(l, lights));
        self.secondary[i] = donors.secondary[l];
    }

    pub(super) fn through(&self, i: usize) -> &[f32] {
        &self.through[i * self.lights..(i + 1) * self.lights]
    }

    /// Whether the row neighbours of sample `i` were donors that saw every
    /// light exactly as it did: no shadow edge passes within a pixel of it.
    pub(super) fn coherent(&self, i: usize) -> bool {
        let width = self.diffuse.len();
        [i.wrapping_sub(1), i + 1]
            .into_iter()
            .filter(|&j| j < width)
            .all(|j| self.diffuse[j] && self.through(j) == self.through(i))
    }
}
