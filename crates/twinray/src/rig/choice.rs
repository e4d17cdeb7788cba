//! The depth budget and the automatic rig.
//!
//! Stereographers limit the screen disparity of what is visible to a budget,
//! in per cent of the image width: Sky's 3D guidelines allow −1 % (in front of
//! the screen) to +2 % (behind it). Given the nearest and farthest visible
//! depths (from a depth pass), [`choose_rig`] picks the interaxial and the
//! convergence that fit them into the budget.
//!
//! **Which disparity.** The budget bounds the disparity between *adjacent*
//! views, `x_{v+1} − x_v`. For a stereo pair that is the pair's disparity; for
//! N views the outer views' disparity is N − 1 times as large. A viewer of a
//! multi-view display sees two neighbouring views at a time, so that is the
//! pair the budget is for (docs/decisions.md; a Looking Glass's 35° view cone
//! over 48 views gives about +2 % per adjacent pair at infinity).
//!
//! **The arithmetic.** With `f` the focal length in pixels, `b` the interaxial of
//! adjacent views and `T` the rig's whole-pixel shift between the outer views
//! (`m = N − 1` gaps), a point at depth `z` has the adjacent disparity
//! `p(z) = T/m − f·b/z` (see `rig.rs`: the shift is rounded to whole pixels,
//! and the fit accounts for that rounding, so the budget holds for the rig
//! actually rendered, not only for the continuous formula). With a budget of
//! `[−n, +r]` pixels and visible depths `[z_n, z_f]`:
//!
//! * interaxial and convergence automatic: the largest `T` with
//!   `T/m ≤ (n/z_f + r/z_n)/(1/z_n − 1/z_f)`, then `b = (T/m + n)·z_n/f`:
//!   the nearest point sits at `−n` and the farthest at or just inside `+r`;
//! * interaxial automatic, convergence given: the largest `b` whose rounded
//!   shift keeps both ends inside (`--convergence near` is `C = z_n`);
//! * interaxial given, convergence automatic: the shift that places the range
//!   in the budget's proportions (exceeding it when the range is too deep for
//!   that interaxial; the report says so);
//! * a view cone (`--view-cone`): the outer views `2·C·tan(cone/2)` apart, so
//!   the interaxial follows the convergence; automatic convergence again places
//!   the range in the budget's proportions.
//!
//! An automatic interaxial never puts the outer views farther apart than the
//! nearest visible depth (a convergence angle of 53°): without that cap a scene
//! with no depth range (one wall facing the camera) would allow any interaxial.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use super::budget::DepthBudget;
use super::depth_pass::{depth_pass, DepthRange, OuterPasses};
use super::{Camera, Rig, View};
use crate::world::World;
use crate::{Error, Result};

/// How the interaxial of the views is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InteraxialRequest {
    /// Fitted to the depth budget.
    Auto,
    /// Adjacent views this far apart (scene units): `--interaxial B`.
    Distance(f32),
    /// The outer views span this angle (degrees) seen from the convergence
    /// point, as light-field displays take it: `2·C·tan(cone/2)` apart.
    ViewCone(f64),
}

/// How the convergence (zero-parallax) distance is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Convergence {
    /// Fitted to the depth budget.
    Auto,
    /// At the nearest visible point: everything behind the screen.
    Nearest,
    /// At this distance (scene units).
    Distance(f64),
    /// Parallel cameras.
    Infinity,
}

/// What a render asks of its rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigRequest {
    pub views: usize,
    pub interaxial: InteraxialRequest,
    pub convergence: Convergence,
    pub budget: DepthBudget,
    /// The distance to the scene's `at` point: the convergence when nothing
    /// else decides it (nothing visible).
    pub fallback_distance: f64,
}

impl RigRequest {
    /// Whether choosing the rig needs the visible depth range.
    pub fn needs_depth(&self) -> bool {
        matches!(self.interaxial, InteraxialRequest::Auto)
            || matches!(self.convergence, Convergence::Auto | Convergence::Nearest)
    }
}

/// The rig chosen and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RigChoice {
    /// Distance between adjacent views (scene units).
    pub interaxial: f32,
    /// Convergence asked of [`Rig::multi_view`] (`None` = parallel).
    pub convergence: Option<f64>,
    /// `explicit`, `auto` or `view-cone`.
    pub interaxial_from: &'static str,
    /// `explicit`, `auto`, `near`, `infinity` or `at` (the scene's `at` point).
    pub convergence_from: &'static str,
    /// The depth range the choice was fitted to, if one was used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_to: Option<DepthRange>,
    /// One sentence: what decided the values.
    pub reason: String,
}

impl RigChoice {
    /// The rig itself (see [`Rig::multi_view`] for what is refused).
    pub fn rig(&self, camera: &Camera, views: usize) -> Result<Rig> {
        Rig::multi_view(camera, views, self.interaxial, self.convergence)
    }
}

/// A safety margin on fitted interaxials: the rig stores the interaxial as an
/// `f32` and recomputes the shift from it, so a value exactly on a limit could
/// round across it.
const MARGIN: f64 = 1.0 - 1e-6;

/// Chooses the interaxial and convergence `req` asks for, fitted where asked to
/// the visible depths `range` (`None`: nothing visible). Explicit values are
/// returned as they are; the report (`disparity`) then says how they fit.
pub fn choose_rig(
    camera: &Camera,
    req: &RigRequest,
    range: Option<DepthRange>,
) -> Result<RigChoice> {
    let max_total = check_fits_the_image(camera, req)?;
    let choice = RigChoice::unfitted(req);
    match range.filter(|_| req.needs_depth()) {
        // Nothing to fit to: explicit values, or nothing visible.
        None => choose_without_depths(req, choice),
        Some(range) => Fit::new(camera, req, range, max_total).choose(choice),
    }
}

/// Refuses a budget or a view cone the image cannot hold; returns the largest
/// total shift `Rig::multi_view` accepts (`ceil(T / 2) < width`).
fn check_fits_the_image(camera: &Camera, req: &RigRequest) -> Result<i64> {
    let (near_px, far_px) = req.budget.pixels(camera.width);
    let width = f64::from(camera.width);
    if -near_px >= width || far_px >= width {
        return Err(Error::Invalid(format!(
            "the depth budget {} is as wide as the image ({} px) or wider",
            req.budget, camera.width
        )));
    }
    let max_total = (2 * i64::from(camera.width) - 2).max(0);
    if let InteraxialRequest::ViewCone(cone) = req.interaxial {
        // Whatever the convergence, the outer views are shifted
        // 2·f·tan(cone/2) pixels apart.
        let total = (2.0 * camera.focal_pixels() * (cone.to_radians() / 2.0).tan()).round();
        if total.is_nan() || total > max_total as f64 {
            return Err(Error::Invalid(format!(
                "a {cone}° view cone shifts the outer views {total} pixels apart, more than \
                 a {}-pixel-wide image allows ({max_total}): use a narrower cone",
                camera.width
            )));
        }
    }
    Ok(max_total)
}

impl RigChoice {
    /// A choice not made yet, with where its values will come from.
    fn unfitted(req: &RigRequest) -> RigChoice {
        RigChoice {
            interaxial: 0.0,
            convergence: None,
            interaxial_from: match req.interaxial {
                InteraxialRequest::Auto => "auto",
                InteraxialRequest::Distance(_) => "explicit",
                InteraxialRequest::ViewCone(_) => "view-cone",
            },
            convergence_from: match req.convergence {
                Convergence::Auto => "auto",
                Convergence::Nearest => "near",
                Convergence::Distance(_) => "explicit",
                Convergence::Infinity => "infinity",
            },
            fitted_to: None,
            reason: String::new(),
        }
    }
}

/// The rig of explicit values, or of a scene with nothing visible: the
/// scene's `at` point for an automatic convergence, the 1/30 rule for an
/// automatic interaxial.
fn choose_without_depths(req: &RigRequest, mut choice: RigChoice) -> Result<RigChoice> {
    let gaps = (req.views.max(2) - 1) as f64;
    let convergence = match req.convergence {
        Convergence::Distance(c) => Some(c),
        Convergence::Infinity => None,
        Convergence::Auto | Convergence::Nearest => {
            choice.convergence_from = "at";
            Some(req.fallback_distance)
        }
    };
    let (interaxial, why) = match req.interaxial {
        InteraxialRequest::Distance(interaxial) => (f64::from(interaxial), "as given".to_string()),
        InteraxialRequest::ViewCone(cone) => {
            let c = convergence.ok_or_else(|| cone_needs_convergence(cone))?;
            (
                cone_interaxial(cone, c, gaps),
                format!("a {cone}° view cone at {c:.4}"),
            )
        }
        InteraxialRequest::Auto => {
            // The stereographers' 1/30 rule on the distance to the scene's
            // `at` point (capped like a fitted interaxial).
            let c = convergence.unwrap_or(req.fallback_distance);
            (
                (c / 30.0).min(c / gaps),
                format!(
                    "nothing visible in the depth pass: the 1/30 rule on the distance \
                     {c:.4} to the scene's 'at' point"
                ),
            )
        }
    };
    choice.interaxial = interaxial as f32;
    choice.convergence = convergence;
    choice.reason = format!(
        "interaxial {}, convergence {}: {why}",
        choice.interaxial,
        show_convergence(convergence)
    );
    Ok(choice)
}

/// What fitting a rig to the visible depths reads: the focal length, the
/// gaps between the outer views, the budget in pixels (`n` in front of the
/// screen, `r` behind it), the depths and their inverses, and the cap.
struct Fit<'a> {
    camera: &'a Camera,
    req: &'a RigRequest,
    range: DepthRange,
    max_total: i64,
    f: f64,
    gaps: f64,
    n: f64,
    r: f64,
    inv_n: f64,
    inv_f: f64,
    /// The outer views no farther apart than the nearest point.
    cap: f64,
    /// The depths, for the reason given.
    ends: String,
}

impl<'a> Fit<'a> {
    fn new(camera: &'a Camera, req: &'a RigRequest, range: DepthRange, max_total: i64) -> Self {
        let gaps = (req.views.max(2) - 1) as f64;
        let (near_px, far_px) = req.budget.pixels(camera.width);
        let (zn, zf) = (range.near, range.far);
        Fit {
            camera,
            req,
            range,
            max_total,
            f: camera.focal_pixels(),
            gaps,
            n: -near_px,
            r: far_px,
            inv_n: 1.0 / zn,
            inv_f: if zf.is_finite() { 1.0 / zf } else { 0.0 },
            cap: zn / gaps,
            ends: format!("nearest visible depth {zn:.4}, farthest {}", show_depth(zf)),
        }
    }

    /// The convergence asked for, where it does not depend on the fit.
    fn fixed_convergence(&self) -> Option<f64> {
        match self.req.convergence {
            Convergence::Distance(c) => Some(c),
            Convergence::Nearest => Some(self.range.near),
            Convergence::Infinity | Convergence::Auto => None,
        }
    }

    fn choose(&self, mut choice: RigChoice) -> Result<RigChoice> {
        choice.fitted_to = Some(self.range);
        let spread = self.inv_n - self.inv_f;
        match (self.req.interaxial, self.req.convergence) {
            (InteraxialRequest::Auto, Convergence::Auto) if spread * self.range.near > 1e-6 => {
                self.auto_interaxial_and_convergence(choice)
            }
            (InteraxialRequest::Auto, Convergence::Auto) => {
                // No depth range to speak of: the cap decides, the convergence
                // goes to the middle of the budget.
                self.balance(choice, self.cap, "a scene without depth range (the cap: outer views no farther apart than the nearest point)")
            }
            (InteraxialRequest::Auto, _) => Ok(self.auto_interaxial(choice)),
            (InteraxialRequest::Distance(interaxial), Convergence::Auto) => {
                self.balance(choice, f64::from(interaxial), "as given")
            }
            (InteraxialRequest::ViewCone(cone), Convergence::Auto) => {
                Ok(self.cone_auto_convergence(choice, cone))
            }
            (InteraxialRequest::ViewCone(cone), _) => {
                let c = self
                    .fixed_convergence()
                    .ok_or_else(|| cone_needs_convergence(cone))?;
                choice.interaxial = cone_interaxial(cone, c, self.gaps) as f32;
                choice.convergence = Some(c);
                choice.reason = format!(
                    "interaxial {} from a {cone}° view cone at convergence {c:.4}",
                    choice.interaxial
                );
                Ok(choice)
            }
            (InteraxialRequest::Distance(interaxial), _) => {
                choice.interaxial = interaxial;
                choice.convergence = self.fixed_convergence();
                choice.reason = format!(
                    "interaxial {interaxial} as given, convergence {} ({})",
                    show_convergence(choice.convergence),
                    self.ends
                );
                Ok(choice)
            }
        }
    }

    /// `balance_convergence` with this fit's inputs.
    fn balance(&self, choice: RigChoice, interaxial: f64, why: &str) -> Result<RigChoice> {
        balance_convergence(
            self.camera,
            self.req,
            choice,
            interaxial,
            self.range,
            self.max_total,
            why,
        )
    }

    /// Both automatic: the largest total shift whose fitted interaxial keeps the
    /// far end inside, `T/m <= (n/z_f + r/z_n) / (1/z_n - 1/z_f)`.
    fn auto_interaxial_and_convergence(&self, mut choice: RigChoice) -> Result<RigChoice> {
        let (f, gaps, n, r) = (self.f, self.gaps, self.n, self.r);
        let spread = self.inv_n - self.inv_f;
        let d_max = (n * self.inv_f + r * self.inv_n) / spread;
        let total = ((gaps * d_max).floor() as i64).clamp(0, self.max_total);
        let d = total as f64 / gaps;
        let interaxial = (d + n) * self.range.near / f * MARGIN;
        if interaxial > self.cap {
            return self.balance(
                choice,
                self.cap,
                "the cap (outer views no farther apart than the nearest point)",
            );
        }
        let budget = self.req.budget;
        choice.interaxial = interaxial as f32;
        choice.convergence = (total > 0).then(|| f * gaps * interaxial / total as f64);
        choice.reason = format!(
            "interaxial {} and convergence {}: the largest interaxial that puts the \
             nearest point at {} and the farthest within {} ({})",
            choice.interaxial,
            show_convergence(choice.convergence),
            budget.near,
            budget.far,
            self.ends
        );
        Ok(choice)
    }

    /// The interaxial automatic, the convergence given (or the nearest point).
    fn auto_interaxial(&self, mut choice: RigChoice) -> RigChoice {
        let (f, gaps, n, r, cap) = (self.f, self.gaps, self.n, self.r, self.cap);
        let (zn, zf) = (self.range.near, self.range.far);
        let convergence = self.fixed_convergence();
        let interaxial = match convergence {
            None => (n * zn / f).min(cap) * MARGIN,
            Some(c) => {
                best_interaxial_for_convergence(f, gaps, c, n, r, zn, zf, cap, self.max_total)
            }
        };
        choice.interaxial = interaxial as f32;
        choice.convergence = convergence;
        let limit = if interaxial >= cap * MARGIN * MARGIN {
            "the cap (outer views no farther apart than the nearest point)".to_string()
        } else {
            format!("the budget {}", self.req.budget)
        };
        choice.reason = format!(
            "interaxial {} for convergence {}: the largest that {limit} allows ({})",
            choice.interaxial,
            show_convergence(convergence),
            self.ends
        );
        if interaxial == 0.0 {
            choice.reason.push_str(
                "; no interaxial fits: the nearest point lies in front of the convergence \
                 and the budget allows nothing there (use --convergence near or auto)",
            );
        }
        choice
    }

    /// A view cone with an automatic convergence: `T = round(f·S/C) =
    /// round(2·f·tan(cone/2))` whatever `C` is, so the convergence places the
    /// depths in the budget's proportions and the interaxial follows.
    fn cone_auto_convergence(&self, mut choice: RigChoice, cone: f64) -> RigChoice {
        let (gaps, n, r, inv_n, inv_f) = (self.gaps, self.n, self.r, self.inv_n, self.inv_f);
        let k0 = 2.0 * self.f * (cone.to_radians() / 2.0).tan() / gaps;
        let d = (k0 * gaps).round() / gaps;
        let c = if n > 0.0 && r > 0.0 {
            d * (1.0 / n + 1.0 / r) / (k0 * (inv_n / n + inv_f / r))
        } else if r == 0.0 && inv_f > 0.0 {
            d / (k0 * inv_f)
        } else {
            d / (k0 * inv_n)
        };
        choice.interaxial = cone_interaxial(cone, c, gaps) as f32;
        choice.convergence = Some(c);
        choice.reason = format!(
            "a {cone}° view cone: convergence {c:.4} places the depths in the budget's \
             proportions, interaxial {} follows from the cone ({})",
            choice.interaxial, self.ends
        );
        choice
    }
}

/// A rig chosen for a render, with the depth passes of its outer views when
/// they were measured for it.
pub struct PlannedRig {
    pub rig: Rig,
    pub choice: RigChoice,
    pub passes: Option<OuterPasses>,
}

/// Chooses the rig `req` asks for. When it needs the visible depths: a depth
/// pass of the camera's own view (every `stride`-th pixel) gives a first rig;
/// the passes of that rig's outer views, which see a little more at the frame's
/// edges, widen the range if they must, and the rig is fitted again (twice at
/// most). The outer passes of the rig returned come with it.
pub fn plan_rig(
    world: &World,
    camera: &Camera,
    req: &RigRequest,
    stride: u32,
) -> Result<PlannedRig> {
    if !req.needs_depth() {
        let choice = choose_rig(camera, req, None)?;
        let rig = choice.rig(camera, req.views)?;
        return Ok(PlannedRig {
            rig,
            choice,
            passes: None,
        });
    }
    let centre = View {
        offset: 0.0,
        shift: 0,
    };
    let mut range = DepthRange::of(depth_pass(world, camera, centre, stride).finite_depths());
    let mut choice = choose_rig(camera, req, range)?;
    let mut rig = choice.rig(camera, req.views)?;
    let mut passes = OuterPasses::measure(world, camera, &rig, stride);
    for _ in 0..2 {
        let seen = match (range, passes.range()) {
            (Some(a), Some(b)) => Some(a.union(b)),
            (a, b) => a.or(b),
        };
        if seen == range {
            break;
        }
        range = seen;
        choice = choose_rig(camera, req, range)?;
        rig = choice.rig(camera, req.views)?;
        passes = OuterPasses::measure(world, camera, &rig, stride);
    }
    Ok(PlannedRig {
        rig,
        choice,
        passes: Some(passes),
    })
}

/// InteraxialRequest `b` given: the whole-pixel shift that puts the depth range in the
/// budget's proportions, `p(z_n) = −n·k` and `p(z_f) = r·k` for one `k`
/// (within the budget when `k ≤ 1`).
fn balance_convergence(
    camera: &Camera,
    req: &RigRequest,
    mut choice: RigChoice,
    interaxial: f64,
    range: DepthRange,
    max_total: i64,
    why_interaxial: &str,
) -> Result<RigChoice> {
    let gaps = (req.views.max(2) - 1) as f64;
    let f = camera.focal_pixels();
    let (near_px, far_px) = req.budget.pixels(camera.width);
    let (n, r) = (-near_px, far_px);
    let inv_n = 1.0 / range.near;
    let inv_f = if range.far.is_finite() {
        1.0 / range.far
    } else {
        0.0
    };
    let k = f * interaxial * (inv_n - inv_f) / (n + r);
    let d = f * interaxial * inv_n - n * k;
    let total = ((gaps * d).round() as i64).clamp(0, max_total);
    choice.interaxial = interaxial as f32;
    choice.convergence =
        (total > 0 && interaxial > 0.0).then(|| f * gaps * interaxial / total as f64);
    choice.reason = format!(
        "interaxial {} ({why_interaxial}), convergence {}: places the depths {:.4} to {} in the \
         budget's proportions{}",
        choice.interaxial,
        show_convergence(choice.convergence),
        range.near,
        show_depth(range.far),
        if k > 1.0 {
            format!(", at {:.0} % of the budget {}", k * 100.0, req.budget)
        } else {
            String::new()
        }
    );
    Ok(choice)
}

/// Convergence `c` given: the largest interaxial whose rig (its total shift
/// `T = round(f·m·b/c)`) keeps the adjacent disparities of the depths
/// `[z_n, z_f]` within `[−n, +r]`. For each `T` the interaxials that round to it
/// form an interval; the budget bounds `b` from above (near end) and below
/// (far end). `T = 0, b = 0` always fits, so there is always an answer.
#[allow(clippy::too_many_arguments)]
fn best_interaxial_for_convergence(
    f: f64,
    gaps: f64,
    c: f64,
    n: f64,
    r: f64,
    zn: f64,
    zf: f64,
    cap: f64,
    max_total: i64,
) -> f64 {
    let mut best = 0.0f64;
    let per_total = c / (f * gaps);
    for total in 0..=max_total {
        let t = total as f64;
        let d = t / gaps;
        let round_lo = ((t - 0.5) * per_total).max(0.0);
        if round_lo > cap {
            break;
        }
        let round_hi = (t + 0.5) * per_total;
        let near_hi = (d + n) * zn / f;
        let far_lo = if zf.is_finite() {
            (d - r) * zf / f
        } else if d <= r {
            0.0
        } else {
            continue;
        };
        let lo = round_lo.max(far_lo * (2.0 - MARGIN)).max(0.0);
        let hi = (round_hi * MARGIN).min(near_hi * MARGIN).min(cap * MARGIN);
        if lo <= hi && hi > best {
            best = hi;
        }
    }
    best
}

fn cone_interaxial(cone_deg: f64, convergence: f64, gaps: f64) -> f64 {
    2.0 * convergence * (cone_deg.to_radians() / 2.0).tan() / gaps
}

fn cone_needs_convergence(cone: f64) -> Error {
    Error::Invalid(format!(
        "a {cone}° view cone needs a finite convergence distance (not inf)"
    ))
}

fn show_convergence(c: Option<f64>) -> String {
    c.map_or("infinity (parallel)".into(), |c| format!("{c:.4}"))
}

fn show_depth(z: f64) -> String {
    if z.is_finite() {
        format!("{z:.4}")
    } else {
        "infinity".into()
    }
}

/// The interaxial asked for: a distance or `auto`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Interaxial {
    Auto,
    Distance(f32),
}

impl FromStr for Interaxial {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(Interaxial::Auto);
        }
        match s.trim().parse::<f32>() {
            Ok(interaxial) if interaxial.is_finite() && interaxial >= 0.0 => {
                Ok(Interaxial::Distance(interaxial))
            }
            _ => Err(format!(
                "'{s}': the interaxial is a finite distance >= 0 or 'auto'"
            )),
        }
    }
}

impl fmt::Display for Interaxial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Interaxial::Auto => f.write_str("auto"),
            Interaxial::Distance(interaxial) => write!(f, "{interaxial}"),
        }
    }
}

/// The view cone a quilt uses when neither an interaxial nor a cone is given.
pub const QUILT_VIEW_CONE: f64 = 35.0;

/// What the rig flags ask, parsed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigFlags<'a> {
    pub interaxial: Option<Interaxial>,
    pub convergence: Option<&'a str>,
    pub view_cone: Option<f64>,
    pub budget: Option<DepthBudget>,
}

/// The rig asked for by the interaxial, view cone, convergence and depth
/// budget, for `views` views. Omitted, the interaxial is automatic (a quilt:
/// a 35° view cone), and the convergence automatic too unless the interaxial
/// is explicit, which keeps the scene's `at` point at `at_distance`.
pub fn rig_request(
    flags: &RigFlags,
    quilt: bool,
    views: usize,
    at_distance: f64,
) -> Result<RigRequest> {
    let interaxial = match (flags.interaxial, flags.view_cone) {
        (_, Some(cone)) => {
            if !(cone.is_finite() && cone > 0.0 && cone < 180.0) {
                return Err(Error::Invalid(format!(
                    "--view-cone must be an angle between 0 and 180 degrees, got {cone}"
                )));
            }
            InteraxialRequest::ViewCone(cone)
        }
        (Some(Interaxial::Distance(interaxial)), None) => InteraxialRequest::Distance(interaxial),
        (None, None) if quilt => InteraxialRequest::ViewCone(QUILT_VIEW_CONE),
        (Some(Interaxial::Auto) | None, None) => InteraxialRequest::Auto,
    };
    let convergence = match flags.convergence {
        None if matches!(interaxial, InteraxialRequest::Distance(_)) => {
            Convergence::Distance(at_distance)
        }
        None => Convergence::Auto,
        Some(s) => parse_convergence(s)?,
    };
    if matches!(interaxial, InteraxialRequest::ViewCone(_)) && convergence == Convergence::Infinity
    {
        return Err(Error::Invalid(
            "--view-cone needs a finite convergence (not --convergence inf)".into(),
        ));
    }
    Ok(RigRequest {
        views,
        interaxial,
        convergence,
        budget: flags.budget.unwrap_or_default(),
        fallback_distance: at_distance,
    })
}

/// `--convergence`: a distance, `auto`, `near` or `inf`.
fn parse_convergence(s: &str) -> Result<Convergence> {
    Ok(match s.trim().to_ascii_lowercase().as_str() {
        "auto" => Convergence::Auto,
        "near" | "nearest" => Convergence::Nearest,
        "inf" | "infinity" => Convergence::Infinity,
        _ => {
            let c: f64 = s.trim().parse().map_err(|e| {
                Error::Invalid(format!(
                    "--convergence '{s}' is neither a distance nor inf, auto or near: {e}"
                ))
            })?;
            if !(c.is_finite() && c > 0.0) {
                return Err(Error::Invalid(format!(
                    "--convergence must be a distance > 0, inf, auto or near, got {s}"
                )));
            }
            Convergence::Distance(c)
        }
    })
}

/// The rig before the scene is built: the final one when nothing depends on
/// the visible depths, else a parallel stand-in with no interaxial (used only to
/// check the outputs before rendering; [`settle`](super::report::settle) replaces it).
pub fn rig_before_depths(
    camera: &Camera,
    request: &RigRequest,
) -> Result<(Rig, Option<RigChoice>)> {
    if request.needs_depth() {
        let rig = Rig::multi_view(camera, request.views, 0.0, None)?;
        return Ok((rig, None));
    }
    let choice = choose_rig(camera, request, None)?;
    let rig = choice
        .rig(camera, request.views)
        .map_err(|e| Error::Invalid(format!("--interaxial and --convergence: {e}")))?;
    Ok((rig, Some(choice)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::rig::budget::Amount;
    use crate::scene::Viewpoint;

    fn camera(width: u32, height: u32) -> Camera {
        let vp = Viewpoint {
            from: Vec3::ZERO,
            at: Vec3::Y,
            up: Vec3::Z,
            angle_deg: 50.0,
            angle_span: Default::default(),
            hither: 0.0,
            width,
            height,
        };
        Camera::new(&vp, width, height)
    }

    /// Adjacent disparity of depth `z` in the rig actually built: the outer
    /// views' over the gaps between them.
    fn disparity(cam: &Camera, rig: &Rig, z: f64) -> f64 {
        let (a, b) = (rig.views[0], rig.views[rig.views.len() - 1]);
        let outer =
            f64::from(a.shift - b.shift) - cam.focal_pixels() * f64::from(b.offset - a.offset) / z;
        outer / (rig.views.len() - 1) as f64
    }

    fn request(
        views: usize,
        interaxial: InteraxialRequest,
        convergence: Convergence,
    ) -> RigRequest {
        RigRequest {
            views,
            interaxial,
            convergence,
            budget: DepthBudget::default(),
            fallback_distance: 4.0,
        }
    }

    #[test]
    fn budgets_parse_in_percent_and_pixels() {
        let b: DepthBudget = "-1%,+2%".parse().unwrap();
        assert_eq!(b, DepthBudget::default());
        assert_eq!(b.pixels(640), (-6.4, 12.8));
        let b: DepthBudget = " -6px , 12px ".parse().unwrap();
        assert_eq!(b.pixels(640), (-6.0, 12.0));
        let b: DepthBudget = "-0.5,1.5".parse().unwrap();
        assert_eq!(b.near, Amount::Percent(-0.5));
        assert_eq!(b.to_string(), "-0.5%,+1.5%");
        for bad in [
            "-1%", "1%,2%", "-1%,-2%", "0,0", "-1%,x", "-200%,1%", "-1%,inf",
        ] {
            let err = bad.parse::<DepthBudget>().unwrap_err().to_string();
            assert!(err.contains("depth budget"), "{bad}: {err}");
        }
    }

    #[test]
    fn auto_rig_puts_both_ends_on_the_budget() {
        let cam = camera(640, 360);
        for views in [2, 5, 32] {
            for (zn, zf) in [(2.0, 15.0), (3.0, f64::INFINITY), (1.0, 1.5), (10.0, 800.0)] {
                let range = DepthRange { near: zn, far: zf };
                let req = request(views, InteraxialRequest::Auto, Convergence::Auto);
                let choice = choose_rig(&cam, &req, Some(range)).unwrap();
                let rig = choice.rig(&cam, views).unwrap();
                let (near, far) = (disparity(&cam, &rig, zn), disparity(&cam, &rig, zf));
                assert!(near >= -6.4 - 1e-3, "{views} {zn}: near {near}");
                assert!(far <= 12.8 + 1e-3, "{views} {zf}: far {far}");
                let span = choice.interaxial as f64 * (views - 1) as f64;
                if span < zn * 0.999 {
                    // The budget decides: the near end on it, the far end
                    // within the rounding of the shift (a pixel over the gaps).
                    assert!(near < -6.39, "{views} {zn}: near {near}");
                    assert!(
                        far > 12.8 - 1.0 / (views - 1) as f64 - 1e-6,
                        "{views} {zn}-{zf}: far {far}"
                    );
                } else {
                    // The cap decides (many views): inside, the range balanced.
                    assert!(span <= zn * (1.0 + 1e-6), "{views}: span {span}");
                }
            }
        }
    }

    #[test]
    fn auto_interaxial_for_a_given_convergence_stays_inside() {
        let cam = camera(257, 129);
        let (n, r) = DepthBudget::default().pixels(257);
        for c in [2.5, 4.0, 9.0] {
            for convergence in [
                Convergence::Distance(c),
                Convergence::Nearest,
                Convergence::Infinity,
            ] {
                let range = DepthRange {
                    near: 2.0,
                    far: 15.0,
                };
                let req = request(2, InteraxialRequest::Auto, convergence);
                let choice = choose_rig(&cam, &req, Some(range)).unwrap();
                let rig = choice.rig(&cam, 2).unwrap();
                let (near, far) = (disparity(&cam, &rig, 2.0), disparity(&cam, &rig, 15.0));
                assert!(
                    near >= n - 1e-3 && far <= r + 1e-3,
                    "{convergence:?}: {near} {far}"
                );
                assert!(choice.interaxial > 0.0, "{convergence:?}");
                // Tight at one end, within the rounding of a pixel.
                assert!(
                    near < n + 1.0 || far > r - 1.0,
                    "{convergence:?}: {near} {far}"
                );
            }
        }
    }

    #[test]
    fn explicit_interaxial_with_auto_convergence_is_balanced() {
        let cam = camera(640, 360);
        let range = DepthRange {
            near: 2.0,
            far: 15.0,
        };
        let req = request(2, InteraxialRequest::Distance(0.05), Convergence::Auto);
        let choice = choose_rig(&cam, &req, Some(range)).unwrap();
        assert_eq!(choice.interaxial, 0.05);
        let rig = choice.rig(&cam, 2).unwrap();
        let (near, far) = (disparity(&cam, &rig, 2.0), disparity(&cam, &rig, 15.0));
        // In the proportions -1 : 2, up to the whole-pixel rounding.
        assert!((far + 2.0 * near).abs() < 1.5, "{near} {far}");
    }

    #[test]
    fn a_view_cone_spaces_the_views_from_the_convergence() {
        let cam = camera(420, 560);
        let req = request(
            48,
            InteraxialRequest::ViewCone(35.0),
            Convergence::Distance(10.0),
        );
        let choice = choose_rig(&cam, &req, None).unwrap();
        let span = choice.interaxial as f64 * 47.0;
        assert!((span - 2.0 * 10.0 * (17.5f64).to_radians().tan()).abs() < 1e-4);
        assert!(choose_rig(
            &cam,
            &request(48, InteraxialRequest::ViewCone(35.0), Convergence::Infinity),
            None
        )
        .is_err());
        let wide = choose_rig(
            &cam,
            &request(2, InteraxialRequest::ViewCone(179.0), Convergence::Auto),
            None,
        );
        assert!(wide.unwrap_err().to_string().contains("narrower cone"));
        // Auto convergence: the range in the budget's proportions.
        let range = DepthRange {
            near: 5.0,
            far: 20.0,
        };
        let req = request(8, InteraxialRequest::ViewCone(35.0), Convergence::Auto);
        let choice = choose_rig(&cam, &req, Some(range)).unwrap();
        let c = choice.convergence.unwrap();
        assert!(c > 5.0 && c < 20.0, "{c}");
    }

    #[test]
    fn nothing_visible_falls_back_to_the_one_in_thirty_rule() {
        let cam = camera(64, 48);
        let choice = choose_rig(
            &cam,
            &request(2, InteraxialRequest::Auto, Convergence::Auto),
            None,
        )
        .unwrap();
        assert_eq!(choice.convergence, Some(4.0));
        assert!((choice.interaxial - 4.0 / 30.0).abs() < 1e-6);
        assert_eq!(choice.convergence_from, "at");
    }

    #[test]
    fn a_flat_scene_is_capped() {
        let cam = camera(640, 360);
        let range = DepthRange {
            near: 5.0,
            far: 5.0,
        };
        let choice = choose_rig(
            &cam,
            &request(2, InteraxialRequest::Auto, Convergence::Auto),
            Some(range),
        )
        .unwrap();
        assert!(
            (choice.interaxial - 5.0).abs() < 1e-3,
            "{}",
            choice.interaxial
        );
        assert!(choice.rig(&cam, 2).is_ok());
    }
}

#[cfg(test)]
mod request_tests {
    use super::*;

    #[test]
    fn interaxial_values() {
        assert_eq!("auto".parse(), Ok(Interaxial::Auto));
        assert_eq!("AUTO".parse(), Ok(Interaxial::Auto));
        assert_eq!("0.25".parse(), Ok(Interaxial::Distance(0.25)));
        for bad in ["-1", "nan", "inf", "x"] {
            assert!(bad.parse::<Interaxial>().is_err(), "{bad}");
        }
        for v in [Interaxial::Auto, Interaxial::Distance(0.1)] {
            assert_eq!(v.to_string().parse(), Ok(v));
        }
    }

    #[test]
    fn omitted_values_default_as_documented() {
        let none = RigFlags::default();
        let r = rig_request(&none, false, 2, 7.0).unwrap();
        assert_eq!(
            (r.interaxial, r.convergence),
            (InteraxialRequest::Auto, Convergence::Auto)
        );
        let explicit = RigFlags {
            interaxial: Some(Interaxial::Distance(0.3)),
            ..RigFlags::default()
        };
        let r = rig_request(&explicit, false, 2, 7.0).unwrap();
        assert_eq!(
            (r.interaxial, r.convergence),
            (InteraxialRequest::Distance(0.3), Convergence::Distance(7.0))
        );
        let r = rig_request(&none, true, 48, 7.0).unwrap();
        assert_eq!(r.interaxial, InteraxialRequest::ViewCone(QUILT_VIEW_CONE));
        let near = RigFlags {
            convergence: Some("near"),
            ..RigFlags::default()
        };
        assert_eq!(
            rig_request(&near, false, 2, 7.0).unwrap().convergence,
            Convergence::Nearest
        );
        let zero = RigFlags {
            convergence: Some("0"),
            ..RigFlags::default()
        };
        assert!(rig_request(&zero, false, 2, 7.0).is_err());
        let cone = RigFlags {
            view_cone: Some(35.0),
            convergence: Some("inf"),
            ..RigFlags::default()
        };
        assert!(rig_request(&cone, false, 8, 7.0).is_err());
    }
}
