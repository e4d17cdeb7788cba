//! Multi-view OpenEXR: all views of a rig in one single-part file.
//!
//! Follows the OpenEXR multi-view convention ("Storing Multi-View Images in
//! OpenEXR Files"): the header attribute `multiView` (stringvector) lists the
//! view names, the first being the *default view*, whose channels carry
//! unprefixed names (`R`, `G`, `B`), so a viewer that knows nothing about
//! views shows it. Every other view's channels are prefixed with the view
//! name and a dot (`right.R`, `right.G`, `right.B`). All channels are 32-bit
//! float, linear, losslessly compressed.
//!
//! Two more header attributes, as Nuke and other stereo tools read them:
//! `interocularDistance` (float: the rig's interaxial, in scene units)
//! and `convergenceDistance` (float, scene units). A parallel rig converges
//! at infinity: then `convergenceDistance` is **omitted** (no attribute),
//! rather than written as a large stand-in value.

use std::collections::HashSet;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes,
    SmallVec, Text, WritableImage,
};

use crate::output::atomic::write_atomically;
use crate::output::check_image;
use crate::output::depth_channels::DepthChannels;
use crate::output::encode::exr_failure;
use crate::{Error, Image, Result};

/// Name of the header attribute holding the interaxial (float): the
/// OpenEXR multi-view convention calls it the interocular distance.
pub const INTEROCULAR_ATTRIBUTE: &str = "interocularDistance";
/// Name of the header attribute holding the convergence distance (float).
pub const CONVERGENCE_ATTRIBUTE: &str = "convergenceDistance";

/// Writes `views` (name, image) to one multi-view EXR at `path`, atomically.
///
/// `views[0]` is the default view (unprefixed channels); for a stereo pair
/// pass `&[("left", &l), ("right", &r)]`. `interaxial` and `convergence`
/// are in scene units; `convergence: None` means parallel (infinite) and
/// omits `convergenceDistance`.
///
/// Errors (`Error::Invalid`): no views; a view name that is empty, repeated,
/// contains a `.` or a non-printable / non-ASCII character; images of
/// different sizes; a non-finite or negative `interaxial`; a non-finite or
/// non-positive `convergence`.
pub fn write_multiview_exr(
    path: &std::path::Path,
    views: &[(&str, &Image)],
    interaxial: f32,
    convergence: Option<f32>,
) -> Result<()> {
    write_views(path, views, None, interaxial, convergence)
}

/// [`write_multiview_exr`] with each view's `Z` and `disparity` channels
/// (`depth[i]` for `views[i]`; `right.Z`, `right.disparity` for a view that
/// is not the first), see [`DepthChannels`].
pub fn write_multiview_exr_with_depth(
    path: &std::path::Path,
    views: &[(&str, &Image)],
    depth: &[DepthChannels],
    interaxial: f32,
    convergence: Option<f32>,
) -> Result<()> {
    if depth.len() != views.len() {
        return Err(Error::Invalid(format!(
            "{} views but {} depth channel sets",
            views.len(),
            depth.len()
        )));
    }
    write_views(path, views, Some(depth), interaxial, convergence)
}

fn write_views(
    path: &std::path::Path,
    views: &[(&str, &Image)],
    depth: Option<&[DepthChannels]>,
    interaxial: f32,
    convergence: Option<f32>,
) -> Result<()> {
    let Some(&(_, first)) = views.first() else {
        return Err(Error::Invalid(
            "a multi-view EXR needs at least one view".to_string(),
        ));
    };
    let mut seen = HashSet::new();
    for &(name, img) in views {
        let valid_name = !name.is_empty()
            && !name.contains('.')
            && name.bytes().all(|b| b.is_ascii_graphic() || b == b' ');
        if !valid_name {
            return Err(Error::Invalid(format!(
                "invalid EXR view name '{name}' (use printable ASCII without '.')"
            )));
        }
        if !seen.insert(name) {
            return Err(Error::Invalid(format!("EXR view '{name}' given twice")));
        }
        check_image(img, name)?;
        if (img.width, img.height) != (first.width, first.height) {
            return Err(Error::Invalid(format!(
                "EXR views differ in size: '{}' is {}x{}, '{name}' is {}x{}",
                views[0].0, first.width, first.height, img.width, img.height
            )));
        }
    }
    if !interaxial.is_finite() || interaxial < 0.0 {
        return Err(Error::Invalid(format!(
            "the interaxial (the interocularDistance attribute) must be finite and non-negative, not {interaxial}"
        )));
    }
    if let Some(c) = convergence {
        if !c.is_finite() || c <= 0.0 {
            return Err(Error::Invalid(format!(
                "convergence distance must be finite and positive, not {c} (use none for parallel)"
            )));
        }
    }

    let text = |s: &str| {
        Text::new_or_none(s)
            .ok_or_else(|| Error::Invalid(format!("'{s}' cannot be stored in an EXR header")))
    };
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (i, &(name, img)) in views.iter().enumerate() {
        let prefix = if i == 0 {
            String::new()
        } else {
            format!("{name}.")
        };
        for (channel, pick) in [("R", 0), ("G", 1), ("B", 2)] {
            let samples = img.pixels.iter().map(|c| c[pick]).collect();
            channels.push(AnyChannel::new(
                text(&format!("{prefix}{channel}"))?,
                FlatSamples::F32(samples),
            ));
        }
        if let Some(d) = depth.and_then(|d| d.get(i)) {
            d.check(img, name)?;
            for (channel, samples) in d.named() {
                channels.push(AnyChannel::new(
                    text(&format!("{prefix}{channel}"))?,
                    FlatSamples::F32(samples.to_vec()),
                ));
            }
        }
    }

    let view_names = views
        .iter()
        .map(|&(name, _)| text(name))
        .collect::<Result<Vec<_>>>()?;
    let mut attributes = LayerAttributes {
        multi_view_names: Some(view_names),
        ..LayerAttributes::default()
    };
    attributes.other.insert(
        text(INTEROCULAR_ATTRIBUTE)?,
        AttributeValue::F32(interaxial),
    );
    if let Some(c) = convergence {
        attributes
            .other
            .insert(text(CONVERGENCE_ATTRIBUTE)?, AttributeValue::F32(c));
    }

    let layer = Layer::new(
        (first.width as usize, first.height as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let image = exr::prelude::Image::from_layer(layer);
    write_atomically(path, |w| image.write().to_buffered(w).map_err(exr_failure))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::math::Color;
    use exr::prelude::{ReadChannels, ReadLayers};
    use std::io::Cursor;

    fn eye(width: u32, height: u32, tag: f32) -> Image {
        let mut img = Image::new(width, height);
        for y in 0..height {
            for x in 0..width {
                img.set(x, y, Color::new(x as f32 + 0.25, y as f32 * 1e-7, tag));
            }
        }
        img
    }

    type ExrImage = exr::prelude::Image<Layer<AnyChannels<FlatSamples>>>;

    /// Reads an EXR file back, every channel (also for `depth_channels`' tests).
    pub(in crate::output) fn read_back(path: &std::path::Path) -> ExrImage {
        let bytes = std::fs::read(path).unwrap();
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
            .unwrap()
    }

    /// The samples of channel `name`, as `f32`.
    pub(in crate::output) fn channel(img: &ExrImage, name: &str) -> Vec<f32> {
        img.layer_data
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .unwrap_or_else(|| panic!("no channel {name}"))
            .sample_data
            .values_as_f32()
            .collect()
    }

    #[test]
    fn stereo_file_has_views_channels_attributes_and_pixels() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pair.exr");
        let (l, r) = (eye(5, 3, -1.0), eye(5, 3, 7.5));
        write_multiview_exr(&path, &[("left", &l), ("right", &r)], 0.065, Some(2.5)).unwrap();

        let img = read_back(&path);
        let layer = &img.layer_data;
        assert_eq!((layer.size.x(), layer.size.y()), (5, 3));
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R", "right.B", "right.G", "right.R"]);

        let views: Vec<String> = layer
            .attributes
            .multi_view_names
            .as_ref()
            .unwrap()
            .iter()
            .map(|t| t.to_string())
            .collect();
        assert_eq!(views, ["left", "right"]);
        let attr = |name: &str| layer.attributes.other.get(&Text::from(name)).cloned();
        assert_eq!(
            attr("interocularDistance"),
            Some(AttributeValue::F32(0.065))
        );
        assert_eq!(attr("convergenceDistance"), Some(AttributeValue::F32(2.5)));

        for (prefix, src) in [("", &l), ("right.", &r)] {
            for (ch, i) in [("R", 0), ("G", 1), ("B", 2)] {
                let expected: Vec<u32> = src.pixels.iter().map(|c| c[i].to_bits()).collect();
                let got: Vec<u32> = channel(&img, &format!("{prefix}{ch}"))
                    .iter()
                    .map(|v| v.to_bits())
                    .collect();
                assert_eq!(got, expected, "{prefix}{ch}");
            }
        }
        // A plain reader sees the default (left) view.
        assert_eq!(crate::output::read_image(&path).unwrap(), l);
    }

    #[test]
    fn parallel_rig_omits_convergence() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("par.exr");
        let (l, r) = (eye(2, 2, 0.0), eye(2, 2, 1.0));
        write_multiview_exr(&path, &[("left", &l), ("right", &r)], 6.5, None).unwrap();
        let img = read_back(&path);
        let other = &img.layer_data.attributes.other;
        assert!(!other.contains_key(&Text::from("convergenceDistance")));
        assert_eq!(
            other.get(&Text::from("interocularDistance")),
            Some(&AttributeValue::F32(6.5))
        );
    }

    #[test]
    fn more_than_two_views() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("multi.exr");
        let (a, b, c) = (eye(2, 1, 0.0), eye(2, 1, 1.0), eye(2, 1, 2.0));
        write_multiview_exr(
            &path,
            &[("center", &a), ("left", &b), ("right", &c)],
            1.0,
            None,
        )
        .unwrap();
        let img = read_back(&path);
        assert_eq!(channel(&img, "B"), vec![0.0, 0.0]);
        assert_eq!(channel(&img, "left.B"), vec![1.0, 1.0]);
        assert_eq!(channel(&img, "right.B"), vec![2.0, 2.0]);
    }

    #[test]
    fn bad_parameters_are_errors_and_write_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        let (l, r) = (eye(2, 2, 0.0), eye(2, 2, 1.0));
        let small = eye(1, 2, 0.0);
        type Case<'a> = (Vec<(&'a str, &'a Image)>, f32, Option<f32>);
        let cases: Vec<Case> = vec![
            (vec![], 0.1, None),
            (vec![("left", &l), ("left", &r)], 0.1, None),
            (vec![("left", &l), ("ri.ght", &r)], 0.1, None),
            (vec![("left", &l), ("", &r)], 0.1, None),
            (vec![("left", &l), ("rechts\u{e9}", &r)], 0.1, None),
            (vec![("left", &l), ("right", &small)], 0.1, None),
            (vec![("left", &l), ("right", &r)], f32::NAN, None),
            (vec![("left", &l), ("right", &r)], -1.0, None),
            (vec![("left", &l), ("right", &r)], 0.1, Some(0.0)),
            (vec![("left", &l), ("right", &r)], 0.1, Some(f32::INFINITY)),
        ];
        for (views, io, conv) in cases {
            let err = write_multiview_exr(&path, &views, io, conv).unwrap_err();
            assert!(matches!(err, Error::Invalid(_)), "{err:?}");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
