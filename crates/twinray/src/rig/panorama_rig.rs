//! A panorama's pair of eyes, and its comfort in degrees.
//!
//! A headset shows each eye's panorama at its true angles, so the depth
//! budget is an angular disparity: the angle between the eyes' rays to
//! one point (ODS: `2·asin(r/d)` for the eyes' circle of radius `r`, faded
//! toward the poles by the merge; parallel VR180 cameras: `2·atan(r/d)`).
//! The depth pass traces the centre's rays through a grid of the image;
//! the automatic IPD is the largest that keeps every sampled point within
//! the budget, and at most the eyes' 64 mm where the scene's unit is known.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::depth_pass::nearest_hit;
use super::projection::Projection;
use super::Camera;
use crate::bvh::TraversalStats;
use crate::math::Ray;
use crate::named::named_values;
use crate::world::World;

/// The eyes' distance the automatic IPD keeps to at most, metres.
pub const HUMAN_IPD_M: f64 = 0.064;

/// The default angular budget, degrees.
pub const DEFAULT_ANGULAR_BUDGET_DEG: f64 = 1.0;

/// Most sampled columns of the depth pass (rows: half as many for 360°).
const DEPTH_COLUMNS: u32 = 512;

/// A scene's length unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneUnits {
    M,
    Cm,
    Mm,
    In,
    Ft,
}

named_values!(SceneUnits {
    M = "m",
    Cm = "cm",
    Mm = "mm",
    In = "in",
    Ft = "ft",
});

impl SceneUnits {
    /// One scene unit in metres.
    pub fn metres(self) -> f64 {
        match self {
            SceneUnits::M => 1.0,
            SceneUnits::Cm => 0.01,
            SceneUnits::Mm => 0.001,
            SceneUnits::In => 0.0254,
            SceneUnits::Ft => 0.3048,
        }
    }
}

/// Where the scene's unit came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UnitsKnown {
    Given(SceneUnits),
    /// From the file format (glTF is in metres).
    Guessed(SceneUnits),
    Unknown,
}

impl UnitsKnown {
    fn units(self) -> Option<SceneUnits> {
        match self {
            UnitsKnown::Given(u) | UnitsKnown::Guessed(u) => Some(u),
            UnitsKnown::Unknown => None,
        }
    }
}

/// One sample of the depth pass: the distance from the centre and the
/// latitude of its direction (radians).
#[derive(Clone, Copy, Debug)]
struct Sample {
    distance: f64,
    latitude: f64,
}

/// The panorama's visible depths, and the pair's angular disparities.
#[derive(Clone, Debug, PartialEq)]
pub struct PanoramaRig {
    pub projection: Projection,
    /// The IPD chosen, scene units.
    pub ipd: f64,
    /// How: fitted to the budget, the eyes' 64 mm, or given.
    pub chosen_by: IpdChoice,
    pub units: UnitsKnown,
    /// The budget, degrees.
    pub budget_deg: f64,
    /// The largest angular disparity of a sampled point, degrees, and its
    /// distance from the centre; `None` where nothing was hit.
    pub near: Option<(f64, f64)>,
    /// The smallest, degrees (0 where a ray sees the background), and its
    /// distance (infinite for the background).
    pub far: Option<(f64, f64)>,
    /// The nearest and farthest hit distances sampled.
    pub distances: Option<(f64, f64)>,
    /// Every hit sample's angular disparity, degrees (for the preview's
    /// histogram).
    pub disparities_deg: Vec<f32>,
}

/// How the IPD was chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IpdChoice {
    /// The largest within the budget.
    Budget,
    /// The eyes' 64 mm in the scene's unit, within the budget.
    Human,
    /// `--interaxial` given.
    Given,
    /// Nothing visible to fit to, the unit unknown: the budget's IPD at
    /// the camera's `at` distance.
    AtTarget,
}

/// The eye's angular disparity, radians, for a point at `s` with eyes
/// `ipd` apart.
fn disparity(projection: &Projection, s: Sample, ipd: f64) -> f64 {
    match projection {
        Projection::Ods(merge) => {
            projection.angular_disparity(ipd * merge.fade(s.latitude), s.distance)
        }
        _ => projection.angular_disparity(ipd, s.distance),
    }
}

/// The distances of the centre's nearest hits through a grid of the
/// image (the projection's rays from the eye; `None` for the background).
fn depth_samples(world: &World, camera: &Camera) -> Vec<Option<Sample>> {
    let f = camera.frame();
    let p = camera.projection;
    let columns = camera.width.clamp(1, DEPTH_COLUMNS);
    let rows = camera.height.clamp(1, DEPTH_COLUMNS);
    let (sx, sy) = (
        camera.width as f32 / columns as f32,
        camera.height as f32 / rows as f32,
    );
    (0..rows)
        .into_par_iter()
        .flat_map_iter(|j| {
            let mut stats = TraversalStats::default();
            (0..columns)
                .filter_map(|i| {
                    let (x, y) = ((i as f32 + 0.5) * sx - 0.5, (j as f32 + 0.5) * sy - 0.5);
                    let (origin, dir) = p.ray(&f, 0.0, x, y)?;
                    let t = nearest_hit(world, &Ray::new(origin, dir), camera.hither, &mut stats);
                    Some(t.is_finite().then(|| Sample {
                        distance: t as f64,
                        latitude: (dir.dot(f.up) as f64).clamp(-1.0, 1.0).asin(),
                    }))
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The pair of a panorama: `ipd` given, or fitted to `budget_deg` (and at
/// most the eyes' 64 mm where `units` are known), with its disparities.
pub fn settle(
    world: &World,
    camera: &Camera,
    ipd: Option<f64>,
    budget_deg: f64,
    units: UnitsKnown,
    at_distance: f64,
) -> PanoramaRig {
    let projection = camera.projection;
    let samples = depth_samples(world, camera);
    let hits: Vec<Sample> = samples.iter().flatten().copied().collect();
    let budget = budget_deg.to_radians();
    let human = units.units().map(|u| HUMAN_IPD_M / u.metres());
    // Per sample, the IPD that puts it at the budget: the smallest of
    // them keeps every sample within it.
    let fit = hits
        .iter()
        .map(|s| {
            let fade = match projection {
                Projection::Ods(merge) => merge.fade(s.latitude),
                _ => 1.0,
            };
            match fade > 0.0 {
                true => projection.ipd_for(budget, s.distance) / fade,
                false => f64::INFINITY,
            }
        })
        .fold(f64::INFINITY, f64::min);
    let (ipd, chosen_by) = match (ipd, human) {
        (Some(b), _) => (b, IpdChoice::Given),
        (None, Some(h)) if h <= fit => (h, IpdChoice::Human),
        (None, _) if fit.is_finite() => (fit, IpdChoice::Budget),
        (None, _) => (projection.ipd_for(budget, at_distance), IpdChoice::AtTarget),
    };
    let disparities: Vec<(f64, f64)> = hits
        .iter()
        .map(|&s| (disparity(&projection, s, ipd), s.distance))
        .collect();
    let near = disparities
        .iter()
        .copied()
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(a, d)| (a.to_degrees(), d));
    let far = match hits.len() < samples.len() {
        true => Some((0.0, f64::INFINITY)),
        false => disparities
            .iter()
            .copied()
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(a, d)| (a.to_degrees(), d)),
    };
    let distances = hits
        .iter()
        .map(|s| s.distance)
        .fold(None, |acc, d| match acc {
            None => Some((d, d)),
            Some((lo, hi)) => Some((f64::min(lo, d), f64::max(hi, d))),
        });
    PanoramaRig {
        projection,
        ipd,
        chosen_by,
        units,
        budget_deg,
        near,
        far,
        distances,
        disparities_deg: disparities
            .iter()
            .map(|d| d.0.to_degrees() as f32)
            .collect(),
    }
}

impl PanoramaRig {
    /// The `-v` lines: the IPD chosen and why, the near and far angular
    /// disparities.
    pub fn report_lines(&self) -> Vec<String> {
        let units = match self.units {
            UnitsKnown::Given(u) => format!("scene unit {u} (given)"),
            UnitsKnown::Guessed(u) => format!("scene unit {u} (glTF's)"),
            UnitsKnown::Unknown => "scene unit unknown (--units)".to_string(),
        };
        let metres = match self.units.units() {
            Some(u) => format!(" = {:.1} mm", self.ipd * u.metres() * 1000.0),
            None => String::new(),
        };
        let why = match self.chosen_by {
            IpdChoice::Budget => format!("the largest within {}°", self.budget_deg),
            IpdChoice::Human => format!("the eyes' 64 mm, within {}°", self.budget_deg),
            IpdChoice::Given => "given".to_string(),
            IpdChoice::AtTarget => "nothing visible: the budget at the target's distance".into(),
        };
        let mut lines = vec![format!(
            "panorama ({}): 2 eyes, IPD {:.6}{metres} ({why}); {units}",
            self.projection.name(),
            self.ipd
        )];
        let at = |(a, d): (f64, f64)| match d.is_finite() {
            true => format!("{a:.3}° at distance {d:.4}"),
            false => format!("{a:.3}° (the background)"),
        };
        if let (Some(near), Some(far)) = (self.near, self.far) {
            lines.push(format!(
                "  angular disparity: near {}, far {}; budget {}°",
                at(near),
                at(far),
                self.budget_deg
            ));
        }
        lines
    }

    /// A warning where a given IPD exceeds the budget.
    pub fn budget_warning(&self) -> Option<String> {
        let (near, d) = self.near?;
        (near > self.budget_deg * 1.0001).then(|| {
            format!(
                "the nearest point (distance {d:.4}) has an angular disparity of {near:.2}°, over the budget of {}°: a smaller --interaxial is more comfortable",
                self.budget_deg
            )
        })
    }
}
