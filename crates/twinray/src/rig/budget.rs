//! The depth budget: the disparity allowed between adjacent views, in per
//! cent of the image width or in pixels (`-1%,+2%`: Sky's 3D guidelines).

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::{Error, Result};

/// An amount of disparity: per cent of the image width, or pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Amount {
    Percent(f64),
    Pixels(f64),
}

impl Amount {
    /// The amount in pixels for an image `width` pixels wide.
    pub fn pixels(self, width: u32) -> f64 {
        match self {
            Amount::Percent(p) => p / 100.0 * f64::from(width),
            Amount::Pixels(px) => px,
        }
    }

    fn value(self) -> f64 {
        match self {
            Amount::Percent(v) | Amount::Pixels(v) => v,
        }
    }
}

impl fmt::Display for Amount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Amount::Percent(p) => write!(f, "{p:+}%"),
            Amount::Pixels(px) => write!(f, "{px:+}px"),
        }
    }
}

/// The disparity allowed between adjacent views: `near` (≤ 0, in front of
/// the screen) to `far` (≥ 0, behind it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DepthBudget {
    pub near: Amount,
    pub far: Amount,
}

impl Default for DepthBudget {
    /// Sky's 3D guidelines: −1 % to +2 % of the image width.
    fn default() -> Self {
        DepthBudget {
            near: Amount::Percent(-1.0),
            far: Amount::Percent(2.0),
        }
    }
}

impl fmt::Display for DepthBudget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.near, self.far)
    }
}

impl FromStr for DepthBudget {
    type Err = Error;

    /// `NEAR,FAR`, each a number with `%` (or no unit: per cent) or `px`:
    /// `-1%,+2%`, `-1,2`, `-6px,12px`. NEAR ≤ 0 ≤ FAR, not both 0, at most
    /// 100 % each.
    fn from_str(s: &str) -> Result<DepthBudget> {
        let bad = |why: &str| {
            Error::Invalid(format!(
                "depth budget '{s}': {why} (expected NEAR,FAR such as -1%,+2% or -6px,12px)"
            ))
        };
        let (near, far) = s.split_once(',').ok_or_else(|| bad("no comma"))?;
        let amount = |text: &str| -> Result<Amount> {
            let t = text.trim();
            let (number, make): (&str, fn(f64) -> Amount) = if let Some(n) = t.strip_suffix('%') {
                (n, Amount::Percent)
            } else if let Some(n) = t.strip_suffix("px") {
                (n, Amount::Pixels)
            } else {
                (t, Amount::Percent)
            };
            let v: f64 = number
                .trim()
                .parse()
                .map_err(|_| bad(&format!("'{t}' is not a number")))?;
            if !v.is_finite() {
                return Err(bad(&format!("'{t}' is not finite")));
            }
            let a = make(v);
            if matches!(a, Amount::Percent(p) if p.abs() > 100.0) {
                return Err(bad(&format!("'{t}' is more than the image width")));
            }
            Ok(a)
        };
        let budget = DepthBudget {
            near: amount(near)?,
            far: amount(far)?,
        };
        if budget.near.value() > 0.0 {
            return Err(bad("NEAR must be 0 or negative (in front of the screen)"));
        }
        if budget.far.value() < 0.0 {
            return Err(bad("FAR must be 0 or positive (behind the screen)"));
        }
        if budget.near.value() == 0.0 && budget.far.value() == 0.0 {
            return Err(bad("it allows no depth at all"));
        }
        Ok(budget)
    }
}

impl DepthBudget {
    /// `(near, far)` in pixels for an image `width` pixels wide: near ≤ 0 ≤ far.
    pub fn pixels(&self, width: u32) -> (f64, f64) {
        (self.near.pixels(width), self.far.pixels(width))
    }
}
