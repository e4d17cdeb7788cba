//! How an image position becomes a ray: the pinhole camera's plane, or a
//! panorama for headsets.
//!
//! * `Equirect`: 360°×180° equirectangular, longitude along the columns
//!   (the camera's `forward` at the image centre, the seam behind it),
//!   latitude along the rows.
//! * `Ods`: omni-directional stereo on the same grid. A pixel's rays share
//!   one direction in every view; view `v`'s origin lies `offset_v` along
//!   that direction's horizontal right perpendicular (the rays are tangent
//!   to the circle of the eyes), faded to zero toward the poles between
//!   the two latitudes of [`PoleMerge`] (Blender's cosine fade).
//! * `Vr180`: 180°×180° equirectangular, and `Vr180Fisheye`: an
//!   equidistant fisheye of 180° inscribed in the image; both with parallel
//!   cameras on the right axis, as a flat rig has. Fisheye positions
//!   outside the circle have no ray (black).
//!
//! Image positions are in pixel units with pixel centres at integers, as
//! for the pinhole camera: column `c` spans `c - 0.5 .. c + 0.5`.

use std::f64::consts::{FRAC_PI_2, PI};

use crate::math::Vec3;
use crate::named::named_values;

/// The projection of the camera.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Projection {
    #[default]
    Pinhole,
    Equirect,
    Ods(PoleMerge),
    Vr180,
    Vr180Fisheye,
}

/// The latitudes, in degrees, where an ODS camera's eyes start to merge
/// and where they are one (Blender's defaults: 60° and 75°).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoleMerge {
    pub from_deg: f64,
    pub to_deg: f64,
}

impl Default for PoleMerge {
    fn default() -> PoleMerge {
        PoleMerge {
            from_deg: 60.0,
            to_deg: 75.0,
        }
    }
}

impl PoleMerge {
    /// The share of the interocular offset kept at `latitude` (radians):
    /// 1 below `from`, 0 beyond `to`, a cosine fade between.
    pub fn fade(&self, latitude: f64) -> f64 {
        let (from, to) = (self.from_deg.to_radians(), self.to_deg.to_radians());
        let a = latitude.abs();
        if a >= to {
            0.0
        } else if a <= from {
            1.0
        } else {
            ((a - from) / (to - from) * FRAC_PI_2).cos()
        }
    }
}

/// The projections by name, as `--projection` and a saved job spell them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ProjectionName {
    #[default]
    Pinhole,
    Equirect,
    Ods,
    Vr180,
    Vr180Fisheye,
}

named_values!(ProjectionName {
    Pinhole = "pinhole",
    Equirect = "equirect",
    Ods = "ods",
    Vr180 = "vr180",
    Vr180Fisheye = "vr180-fisheye",
});

impl ProjectionName {
    /// The projection, with the ODS pole merge given.
    pub fn projection(self, merge: PoleMerge) -> Projection {
        match self {
            ProjectionName::Pinhole => Projection::Pinhole,
            ProjectionName::Equirect => Projection::Equirect,
            ProjectionName::Ods => Projection::Ods(merge),
            ProjectionName::Vr180 => Projection::Vr180,
            ProjectionName::Vr180Fisheye => Projection::Vr180Fisheye,
        }
    }
}

/// The camera frame a panorama is laid out in.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub eye: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub width: u32,
    pub height: u32,
}

impl Projection {
    pub fn is_panorama(&self) -> bool {
        *self != Projection::Pinhole
    }

    pub fn name(&self) -> ProjectionName {
        match self {
            Projection::Pinhole => ProjectionName::Pinhole,
            Projection::Equirect => ProjectionName::Equirect,
            Projection::Ods(_) => ProjectionName::Ods,
            Projection::Vr180 => ProjectionName::Vr180,
            Projection::Vr180Fisheye => ProjectionName::Vr180Fisheye,
        }
    }

    /// Horizontal and vertical extent of the image, degrees.
    pub fn span_deg(&self) -> (f64, f64) {
        match self {
            Projection::Equirect | Projection::Ods(_) => (360.0, 180.0),
            _ => (180.0, 180.0),
        }
    }

    /// The ray of the view at `offset` through image position (`column`,
    /// `row`) of a panorama: its origin and unit direction, or `None` (a
    /// fisheye position outside the circle). Pinhole: `None`.
    #[inline]
    pub fn ray(&self, f: &Frame, offset: f32, column: f32, row: f32) -> Option<(Vec3, Vec3)> {
        let s = self.sample_ray(f, column, row)?;
        Some((s.origin(f, offset), s.dir))
    }

    /// What every view's ray through image position (`column`, `row`)
    /// shares: its direction, and what places its origin
    /// ([`SampleRay::origin`]); `None` as for [`Projection::ray`].
    #[inline]
    pub fn sample_ray(&self, f: &Frame, column: f32, row: f32) -> Option<SampleRay> {
        let (w, h) = (f.width as f64, f.height as f64);
        let u = (column as f64 + 0.5) / w;
        let v = (row as f64 + 0.5) / h;
        let (lon, lat) = match self {
            Projection::Pinhole => return None,
            Projection::Equirect | Projection::Ods(_) => ((u - 0.5) * 2.0 * PI, (0.5 - v) * PI),
            Projection::Vr180 => ((u - 0.5) * PI, (0.5 - v) * PI),
            Projection::Vr180Fisheye => {
                let (x, y) = (2.0 * u - 1.0, 1.0 - 2.0 * v);
                let rho = x.hypot(y);
                if rho > 1.0 {
                    return None;
                }
                let theta = rho * FRAC_PI_2;
                let (sx, sy) = match rho > 0.0 {
                    true => (x / rho, y / rho),
                    false => (0.0, 0.0),
                };
                let (s, c) = theta.sin_cos();
                let dir = combine(f, c, s * sx, s * sy);
                return Some(SampleRay { dir, ods: None });
            }
        };
        let (sl, cl) = lon.sin_cos();
        let (sp, cp) = lat.sin_cos();
        let dir = combine(f, cp * cl, cp * sl, sp);
        let ods = match self {
            Projection::Ods(merge) => Some((sl, cl, merge.fade(lat))),
            _ => None,
        };
        Some(SampleRay { dir, ods })
    }

    /// Where the world point `p` lands in the image of the view at
    /// `offset`, in pixel units (column, row); `None` outside the image
    /// (behind a 180° camera) or at the eye. ODS solves the tangent ray
    /// through `p` (with the pole merge, by fixed-point iteration on the
    /// latitude).
    pub fn project(&self, f: &Frame, p: Vec3, offset: f32) -> Option<(f64, f64)> {
        let (w, h) = (f.width as f64, f.height as f64);
        let local = |o: Vec3| {
            let rel = p - o;
            (
                rel.dot(f.forward) as f64,
                rel.dot(f.right) as f64,
                rel.dot(f.up) as f64,
            )
        };
        match self {
            Projection::Pinhole => None,
            Projection::Equirect | Projection::Vr180 => {
                let (z, x, y) = local(parallel_eye(f, offset));
                let lon = x.atan2(z);
                let lat = y.atan2(x.hypot(z));
                let span = match self {
                    Projection::Vr180 if lon.abs() > FRAC_PI_2 => return None,
                    Projection::Vr180 => PI,
                    _ => 2.0 * PI,
                };
                Some(((lon / span + 0.5) * w - 0.5, (0.5 - lat / PI) * h - 0.5))
            }
            Projection::Vr180Fisheye => {
                let (z, x, y) = local(parallel_eye(f, offset));
                let len = (x * x + y * y + z * z).sqrt();
                if len == 0.0 || z < 0.0 {
                    return None;
                }
                let theta = (z / len).clamp(-1.0, 1.0).acos();
                let rho = theta / FRAC_PI_2;
                let phi = y.atan2(x);
                let (u, v) = (rho * phi.cos(), rho * phi.sin());
                Some(((u + 1.0) * 0.5 * w - 0.5, (1.0 - v) * 0.5 * h - 0.5))
            }
            Projection::Ods(merge) => {
                let (z, x, y) = local(f.eye);
                let horizontal = x.hypot(z);
                let azimuth = x.atan2(z);
                let mut lat = y.atan2(horizontal);
                let mut lon = azimuth;
                for _ in 0..64 {
                    let r = offset as f64 * merge.fade(lat);
                    if r.abs() >= horizontal {
                        return None;
                    }
                    lon = azimuth - (r / horizontal).asin();
                    let next = y.atan2((horizontal * horizontal - r * r).sqrt());
                    let done = (next - lat).abs() < 1e-13;
                    lat = next;
                    if done {
                        break;
                    }
                }
                let lon = (lon + PI).rem_euclid(2.0 * PI) - PI;
                Some((
                    (lon / (2.0 * PI) + 0.5) * w - 0.5,
                    (0.5 - lat / PI) * h - 0.5,
                ))
            }
        }
    }

    /// The angular disparity, radians, between two eyes `ipd` apart of a
    /// point at `distance` straight ahead at the horizon: `2·asin(ipd/2d)`
    /// for ODS, `2·atan(ipd/2d)` for parallel cameras.
    pub fn angular_disparity(&self, ipd: f64, distance: f64) -> f64 {
        let half = ipd * 0.5;
        match self {
            Projection::Ods(_) => match half >= distance {
                true => PI,
                false => 2.0 * (half / distance).asin(),
            },
            _ => 2.0 * (half / distance).atan(),
        }
    }

    /// The interocular distance whose angular disparity of a point at
    /// `distance` is `angle` radians (the inverse of `angular_disparity`).
    pub fn ipd_for(&self, angle: f64, distance: f64) -> f64 {
        match self {
            Projection::Ods(_) => 2.0 * distance * (angle * 0.5).sin(),
            _ => 2.0 * distance * (angle * 0.5).tan(),
        }
    }
}

/// Every view's ray through one image position but for its origin: a
/// pair's eyes share the direction (ODS by its definition, VR180's
/// parallel cameras by theirs), so it is computed once for both.
#[derive(Clone, Copy, Debug)]
pub struct SampleRay {
    pub dir: Vec3,
    /// ODS: the sine and cosine of the longitude, and the pole merge's
    /// share of the offset at this latitude; `None`: parallel cameras.
    ods: Option<(f64, f64, f64)>,
}

impl SampleRay {
    /// The origin of the view at `offset`: on the horizontal right
    /// perpendicular of the direction (ODS), or on the right axis.
    #[inline]
    pub fn origin(&self, f: &Frame, offset: f32) -> Vec3 {
        match self.ods {
            Some((sl, cl, fade)) => {
                let scale = offset as f64 * fade;
                if scale == 0.0 {
                    f.eye
                } else {
                    f.eye + combine(f, -sl * scale, cl * scale, 0.0)
                }
            }
            None => parallel_eye(f, offset),
        }
    }
}

/// `forward * a + right * b + up * c`, in single precision from double.
#[inline]
fn combine(f: &Frame, a: f64, b: f64, c: f64) -> Vec3 {
    f.forward * a as f32 + f.right * b as f32 + f.up * c as f32
}

#[inline]
fn parallel_eye(f: &Frame, offset: f32) -> Vec3 {
    if offset == 0.0 {
        f.eye
    } else {
        f.eye + f.right * offset
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: u32, h: u32) -> Frame {
        Frame {
            eye: Vec3::new(1.0, 2.0, 3.0),
            forward: Vec3::Y,
            right: Vec3::X,
            up: Vec3::Z,
            width: w,
            height: h,
        }
    }

    #[test]
    fn names_agree_with_serde() {
        assert!(crate::named::serde_names_agree(&[
            ProjectionName::Pinhole,
            ProjectionName::Equirect,
            ProjectionName::Ods,
            ProjectionName::Vr180,
            ProjectionName::Vr180Fisheye,
        ]));
    }

    #[test]
    fn equirect_centre_looks_forward_and_the_seam_is_behind() {
        let f = frame(64, 32);
        let p = Projection::Equirect;
        let (_, d) = p.ray(&f, 0.0, 31.5, 15.5).unwrap();
        assert!((d - Vec3::Y).length() < 1e-6, "{d}");
        // Column 0's left edge and column W-1's right edge both look back.
        let (_, a) = p.ray(&f, 0.0, -0.5, 15.5).unwrap();
        let (_, b) = p.ray(&f, 0.0, 63.5, 15.5).unwrap();
        assert!((a - b).length() < 1e-6 && (a + Vec3::Y).length() < 1e-6);
        // A quarter to the right is +x; row 0's top edge is up.
        let (_, r) = p.ray(&f, 0.0, 47.5, 15.5).unwrap();
        assert!((r - Vec3::X).length() < 1e-6, "{r}");
        let (_, top) = p.ray(&f, 0.0, 10.0, -0.5).unwrap();
        assert!((top - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn project_inverts_ray_for_every_projection() {
        let f = frame(200, 100);
        let merge = PoleMerge::default();
        for p in [
            Projection::Equirect,
            Projection::Ods(merge),
            Projection::Vr180,
            Projection::Vr180Fisheye,
        ] {
            for offset in [0.0f32, -0.03, 0.03] {
                for (c, r) in [(10.3, 20.0), (99.5, 49.5), (150.0, 80.2), (120.0, 5.0)] {
                    let Some((o, d)) = p.ray(&f, offset, c, r) else {
                        continue;
                    };
                    let point = o + d * 7.5;
                    let (x, y) = p.project(&f, point, offset).unwrap();
                    assert!(
                        (x - c as f64).abs() < 2e-3 && (y - r as f64).abs() < 2e-3,
                        "{p:?} offset {offset}: ({c}, {r}) -> ({x}, {y})"
                    );
                }
            }
        }
    }

    #[test]
    fn ods_eyes_are_tangent_to_the_circle_and_merge_at_the_poles() {
        let f = frame(360, 180);
        let p = Projection::Ods(PoleMerge::default());
        for col in [0.0f32, 45.0, 200.0, 359.0] {
            let (o, d) = p.ray(&f, 0.032, col, 90.0).unwrap();
            let rel = o - f.eye;
            assert!((rel.length() - 0.032).abs() < 1e-6);
            assert!(rel.dot(d).abs() < 1e-6 && rel.z.abs() < 1e-7);
            // The right eye's offset is to the right of the direction.
            assert!(d.cross(rel).z < 0.0);
            let (l, dl) = p.ray(&f, -0.032, col, 90.0).unwrap();
            assert_eq!(dl, d);
            assert!((l - f.eye + rel).length() < 1e-6);
        }
        // Beyond 75°: one eye; between 60° and 75°: partly merged.
        let row_of = |lat: f64| ((0.5 - lat / 180.0) * 180.0 - 0.5) as f32;
        let (a, _) = p.ray(&f, -0.032, 10.0, row_of(76.0)).unwrap();
        let (b, _) = p.ray(&f, 0.032, 10.0, row_of(76.0)).unwrap();
        assert_eq!(a, b);
        let (a, _) = p.ray(&f, -0.032, 10.0, row_of(-67.5)).unwrap();
        let gap = (a - f.eye).length();
        assert!(gap > 0.005 && gap < 0.03, "{gap}");
    }

    #[test]
    fn fisheye_has_no_ray_outside_its_circle() {
        let f = frame(100, 100);
        let p = Projection::Vr180Fisheye;
        assert!(p.ray(&f, 0.0, 0.0, 0.0).is_none());
        assert!(p.ray(&f, 0.0, 99.0, 99.0).is_none());
        let (_, d) = p.ray(&f, 0.0, 49.5, 49.5).unwrap();
        assert!((d - Vec3::Y).length() < 1e-6);
        // The rim looks sideways: 90° from forward.
        let (_, d) = p.ray(&f, 0.0, -0.5, 49.5).unwrap();
        assert!((d + Vec3::X).length() < 1e-6, "{d}");
    }

    #[test]
    fn disparity_and_ipd_are_inverse() {
        for p in [Projection::Ods(PoleMerge::default()), Projection::Vr180] {
            let a = p.angular_disparity(0.064, 2.0);
            assert!((p.ipd_for(a, 2.0) - 0.064).abs() < 1e-12);
        }
        let a =
            Projection::Ods(PoleMerge::default()).angular_disparity(0.064, 0.032 / 0.5f64.sin());
        assert!((a - 1.0).abs() < 1e-12);
    }
}
