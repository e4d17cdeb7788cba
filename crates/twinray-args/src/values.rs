//! Parsers of the flags' values: sizes, vectors, lights, and the spec's own
//! named values (a layout, a filter, ...), which clap takes by their names
//! (`FromStr`), so that each choice is spelt once, by the type the spec holds.

use std::str::FromStr;

use clap::builder::{PossibleValuesParser, TypedValueParser};

use twinray::job::LightSpec;
use twinray::math::Vec3;
use twinray::output::QuiltSpec;
use twinray::rig::budget::DepthBudget;

/// A parser of one of `names`, into the type that has them (its `FromStr`).
pub(crate) fn one_of<T>(names: &'static [&'static str]) -> impl TypedValueParser<Value = T>
where
    T: FromStr<Err = twinray::Error> + Clone + Send + Sync + 'static,
{
    PossibleValuesParser::new(names).try_map(|s| s.parse::<T>())
}

/// `WxH`, both at least 1.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH"))?;
    let w: u32 = w.parse().map_err(|_| format!("'{w}' is not a width"))?;
    let h: u32 = h.parse().map_err(|_| format!("'{h}' is not a height"))?;
    if w == 0 || h == 0 {
        return Err("width and height must be at least 1".into());
    }
    Ok((w, h))
}

/// `FROM,TO`: two latitudes in degrees, `0 <= FROM <= TO <= 90`.
pub fn parse_pole_merge(s: &str) -> Result<[f64; 2], String> {
    let numbers: Vec<f64> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{s}' is not FROM,TO (two latitudes)"))
        })
        .collect::<Result<_, _>>()?;
    match numbers[..] {
        [from, to] if (0.0..=90.0).contains(&from) && (from..=90.0).contains(&to) => Ok([from, to]),
        _ => Err(format!(
            "'{s}': two latitudes in degrees, 0 <= FROM <= TO <= 90"
        )),
    }
}

/// `X,Y,Z`: three finite numbers.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f32> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 && numbers.iter().all(|v| v.is_finite()) => {
            Ok(Vec3::new(x, y, z))
        }
        _ => Err(format!("'{s}' is not X,Y,Z (three numbers)")),
    }
}

/// `X,Y,Z` or `X,Y,Z:R,G,B`.
pub(crate) fn parse_light(s: &str) -> Result<LightSpec, String> {
    let (position, color) = match s.split_once(':') {
        Some((p, c)) => (p, Some(c)),
        None => (s, None),
    };
    let bad = |_| {
        format!("'{s}' is not X,Y,Z[:R,G,B] (three finite numbers, then optionally three more)")
    };
    let position = parse_vec3(position).map_err(bad)?.to_array();
    let color = match color {
        Some(c) => parse_vec3(c).map_err(bad)?.to_array(),
        None => [1.0; 3],
    };
    Ok(LightSpec { position, color })
}

/// Checks a depth budget as clap parses it; the spec keeps the text.
pub(crate) fn parse_budget(s: &str) -> Result<String, String> {
    s.parse::<DepthBudget>().map_err(|e| e.to_string())?;
    Ok(s.to_string())
}

/// Checks a quilt grid as clap parses it; the spec keeps the text.
pub(crate) fn parse_quilt(s: &str) -> Result<String, String> {
    s.parse::<QuiltSpec>().map_err(|e| e.to_string())?;
    Ok(s.to_string())
}
