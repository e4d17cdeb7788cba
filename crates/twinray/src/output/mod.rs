//! Composing and writing images: single-image encoders, stereo layouts,
//! MPO, multi-view OpenEXR, and image comparison.
//!
//! * [`encode`]: PNG / EXR / PFM / JPEG by file extension ([`write_image`],
//!   [`read_image`]).
//! * [`layouts`] and [`anaglyph`](mod@anaglyph): pure functions `(left, right) → image`.
//! * [`mpo`]: the stereo-camera Multi-Picture Object ([`write_mpo`]).
//! * [`multiview_exr`]: every view in one EXR ([`write_multiview_exr`]).
//! * [`compare`](mod@compare): [`compare()`] and [`difference_image`].
//! * [`quilt`]: Looking Glass quilts ([`compose_quilt`], [`quilt_path`]).
//! * [`floating_window`]: masks at the frame's edges ([`apply_floating_window`]).
//! * [`depth_channels`]: `Z` and `disparity` channels in EXR files.
//! * [`write_stereo`] ties them together for a [`Layout`] name.
//!
//! **Atomic writes.** Every file is first written to a temporary file in the
//! target's directory and renamed over the target only when complete, so an
//! error never leaves a partial output (nor destroys an existing one). Sets of
//! files are encoded first and put in place together ([`stage_image`],
//! [`commit_all`]). FIFOs and devices are written through, symbolic links
//! followed, read-only files refused ([`atomic`](self) module notes).
//!
//! **Checked first.** [`targets`] checks paths and format limits before the
//! images exist, so a caller can refuse a job before rendering it.
//!
//! **Validation.** Every function checks its images (`pixels.len() ==
//! width * height`, neither dimension 0) and, for pairs, that both eyes have
//! the same size; bad input is an `Error::Invalid`, never a panic.

pub mod anaglyph;
mod atomic;
pub mod compare;
pub mod depth_channels;
pub mod display;
pub mod encode;
pub mod floating_window;
pub mod layouts;
pub mod mpo;
pub mod multiview_exr;
pub mod panorama_meta;
pub mod quilt;
pub mod targets;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

pub use anaglyph::{anaglyph, AnaglyphMethod};
pub use atomic::{commit_all, remove_temporary_files, write_text, Staged};
pub use compare::{compare, difference_image, Difference};
pub use depth_channels::{stage_exr_with_depth, DepthChannels};
pub use display::{DisplayTransform, Tonemap};
pub(crate) use encode::rgb8_into;
pub use encode::{
    png_bytes, read_image, stage_image, stage_rgb8_image, to_rgb8, write_image, ImageFormat,
    WriteOptions,
};
pub use floating_window::{apply_floating_window, mask_edges};
pub use layouts::{
    cross, interlace, moves_pixels_only, pair_frame_rgb8, separate_paths, side_by_side, top_bottom,
    InterlaceMode,
};
pub use mpo::write_mpo;
pub use multiview_exr::{write_multiview_exr, write_multiview_exr_with_depth};
pub use quilt::{
    compose_quilt, quilt_path, write_quilt, write_quilt_rgb8, QuiltLayout, QuiltPreset, QuiltSpec,
};
pub use targets::{check_distinct, check_file_target, check_image_target, check_stereo_targets};

use crate::{Error, Image, Result};

/// How a stereo pair is delivered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Layout {
    /// Two files, `name_L.ext` and `name_R.ext` ([`separate_paths`]).
    Separate,
    /// Left | right ([`side_by_side`]).
    SideBySide,
    /// Right | left, for cross-eyed viewing ([`cross`]).
    Cross,
    /// Left over right ([`top_bottom`]).
    TopBottom,
    /// One colour anaglyph ([`anaglyph()`]).
    Anaglyph(AnaglyphMethod),
    /// Both eyes woven row, column or pixel-wise ([`interlace`]).
    Interlace(InterlaceMode),
    /// A Multi-Picture Object, as stereo cameras write ([`write_mpo`]).
    Mpo,
    /// One OpenEXR holding both views ([`write_multiview_exr`]).
    MultiviewExr,
}

impl Layout {
    /// Every layout name [`Layout::from_str`] accepts (canonical names;
    /// aliases: `sbs`, `tb`, `anaglyph` = `anaglyph-dubois`, `interlace` =
    /// `interlace-rows`, `exr` = `multiview-exr`).
    pub const NAMES: &'static [&'static str] = &[
        "separate",
        "side-by-side",
        "cross",
        "top-bottom",
        "anaglyph-dubois",
        "anaglyph-color",
        "anaglyph-gray",
        "anaglyph-green-magenta",
        "anaglyph-yellow-blue",
        "interlace-rows",
        "interlace-columns",
        "interlace-checker",
        "mpo",
        "multiview-exr",
    ];

    /// The canonical name (one of [`Layout::NAMES`]).
    pub fn name(self) -> &'static str {
        match self {
            Layout::Separate => "separate",
            Layout::SideBySide => "side-by-side",
            Layout::Cross => "cross",
            Layout::TopBottom => "top-bottom",
            Layout::Anaglyph(AnaglyphMethod::Dubois) => "anaglyph-dubois",
            Layout::Anaglyph(AnaglyphMethod::Color) => "anaglyph-color",
            Layout::Anaglyph(AnaglyphMethod::Gray) => "anaglyph-gray",
            Layout::Anaglyph(AnaglyphMethod::GreenMagenta) => "anaglyph-green-magenta",
            Layout::Anaglyph(AnaglyphMethod::YellowBlue) => "anaglyph-yellow-blue",
            Layout::Interlace(InterlaceMode::Rows) => "interlace-rows",
            Layout::Interlace(InterlaceMode::Columns) => "interlace-columns",
            Layout::Interlace(InterlaceMode::Checker) => "interlace-checker",
            Layout::Mpo => "mpo",
            Layout::MultiviewExr => "multiview-exr",
        }
    }
}

impl fmt::Display for Layout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Layout {
    type Err = Error;

    /// Case-insensitive; `_` and `-` are interchangeable.
    fn from_str(s: &str) -> Result<Layout> {
        let key = s.trim().to_ascii_lowercase().replace('_', "-");
        let layout = match key.as_str() {
            "sbs" => Layout::SideBySide,
            "tb" => Layout::TopBottom,
            "anaglyph" => Layout::Anaglyph(AnaglyphMethod::Dubois),
            "interlace" => Layout::Interlace(InterlaceMode::Rows),
            "exr" => Layout::MultiviewExr,
            other => {
                return ALL_LAYOUTS
                    .iter()
                    .copied()
                    .find(|l| l.name() == other)
                    .ok_or_else(|| {
                        Error::Invalid(format!(
                            "unknown stereo layout '{s}' (use one of: {})",
                            Layout::NAMES.join(", ")
                        ))
                    })
            }
        };
        Ok(layout)
    }
}

const ALL_LAYOUTS: [Layout; 14] = [
    Layout::Separate,
    Layout::SideBySide,
    Layout::Cross,
    Layout::TopBottom,
    Layout::Anaglyph(AnaglyphMethod::Dubois),
    Layout::Anaglyph(AnaglyphMethod::Color),
    Layout::Anaglyph(AnaglyphMethod::Gray),
    Layout::Anaglyph(AnaglyphMethod::GreenMagenta),
    Layout::Anaglyph(AnaglyphMethod::YellowBlue),
    Layout::Interlace(InterlaceMode::Rows),
    Layout::Interlace(InterlaceMode::Columns),
    Layout::Interlace(InterlaceMode::Checker),
    Layout::Mpo,
    Layout::MultiviewExr,
];

/// Parameters of [`write_stereo`] beyond the layout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoOptions {
    /// 8-bit quantisation (PNG, JPEG, MPO).
    pub image: WriteOptions,
    /// Half-width / half-height frames for side-by-side, cross and
    /// top-bottom (see [`layouts`] for odd sizes).
    pub squeeze: bool,
    /// The interaxial in metres, written as MPO `BaselineLength` and EXR
    /// `interocularDistance`. Convert first if the scene unit is not a metre.
    pub interaxial_m: f64,
    /// Convergence distance in metres (EXR `convergenceDistance`);
    /// `None` = parallel (infinite).
    pub convergence_m: Option<f64>,
}

impl Default for StereoOptions {
    fn default() -> Self {
        StereoOptions {
            image: WriteOptions::default(),
            squeeze: false,
            interaxial_m: 0.065,
            convergence_m: None,
        }
    }
}

/// Composes the pair as `layout` and writes it to `out` (for
/// [`Layout::Separate`], to the two [`separate_paths`] of `out`, both or
/// neither). Returns the files written. `Mpo` needs a `.mpo`, `.jpg` or `.jpeg` name,
/// `MultiviewExr` a `.exr` name; the others any [`ImageFormat`].
/// Everything is validated before the first file is written.
pub fn write_stereo(
    out: &Path,
    layout: Layout,
    left: &Image,
    right: &Image,
    opts: &StereoOptions,
) -> Result<Vec<PathBuf>> {
    check_pair(left, right)?;
    let files = check_stereo_targets(out, layout, left.width, left.height, opts)?;
    let frame = match layout {
        Layout::Separate => {
            // Both eyes or neither: encoded first, then put in place together.
            let staged = vec![
                stage_image(&files[0], left, &opts.image)?,
                stage_image(&files[1], right, &opts.image)?,
            ];
            return commit_all(staged);
        }
        Layout::Mpo => {
            write_mpo(out, left, right, opts.interaxial_m, &opts.image)?;
            return Ok(files);
        }
        Layout::MultiviewExr => {
            write_multiview_exr(
                out,
                &[("left", left), ("right", right)],
                opts.interaxial_m as f32,
                opts.convergence_m.map(|c| c as f32),
            )?;
            return Ok(files);
        }
        Layout::SideBySide => side_by_side(left, right, opts.squeeze)?,
        Layout::Cross => cross(left, right, opts.squeeze)?,
        Layout::TopBottom => top_bottom(left, right, opts.squeeze)?,
        Layout::Anaglyph(method) => anaglyph(left, right, method)?,
        Layout::Interlace(mode) => interlace(left, right, mode)?,
    };
    write_image(out, &frame, &opts.image)?;
    Ok(vec![out.to_path_buf()])
}

/// `img` is well-formed: non-empty and `pixels.len() == width * height`.
pub(crate) fn check_image(img: &Image, what: &str) -> Result<()> {
    if img.width == 0 || img.height == 0 {
        return Err(Error::Invalid(format!(
            "{what} is empty ({}x{})",
            img.width, img.height
        )));
    }
    let expected = (img.width as usize).checked_mul(img.height as usize);
    if expected != Some(img.pixels.len()) {
        return Err(Error::Invalid(format!(
            "{what} is malformed: {}x{} but {} pixels",
            img.width,
            img.height,
            img.pixels.len()
        )));
    }
    Ok(())
}

/// Both eyes are well-formed and of the same size.
pub(crate) fn check_pair(left: &Image, right: &Image) -> Result<()> {
    check_image(left, "left image")?;
    check_image(right, "right image")?;
    check_same_size((left.width, left.height), (right.width, right.height))
}

/// The eyes' sizes (`width`, `height`) are the same.
pub(crate) fn check_same_size(left: (u32, u32), right: (u32, u32)) -> Result<()> {
    if left != right {
        return Err(Error::Invalid(format!(
            "left and right images differ in size: {}x{} and {}x{}",
            left.0, left.1, right.0, right.1
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    const RED: Color = Color::new(1.0, 0.0, 0.0);
    const BLUE: Color = Color::new(0.0, 0.0, 1.0);

    #[test]
    fn layout_names_round_trip() {
        assert_eq!(Layout::NAMES.len(), ALL_LAYOUTS.len());
        for (layout, name) in ALL_LAYOUTS.iter().zip(Layout::NAMES) {
            assert_eq!(layout.name(), *name);
            assert_eq!(name.parse::<Layout>().unwrap(), *layout);
            assert_eq!(layout.to_string(), *name);
        }
        assert_eq!("SBS".parse::<Layout>().unwrap(), Layout::SideBySide);
        assert_eq!("top_bottom".parse::<Layout>().unwrap(), Layout::TopBottom);
        assert_eq!(
            "anaglyph".parse::<Layout>().unwrap(),
            Layout::Anaglyph(AnaglyphMethod::Dubois)
        );
        let err = "hologram".parse::<Layout>().unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        assert!(err.to_string().contains("side-by-side"));
    }

    #[test]
    fn write_stereo_separate_writes_both_eyes() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("pair.png");
        let written = write_stereo(
            &out,
            Layout::Separate,
            &Image::filled(4, 2, RED),
            &Image::filled(4, 2, BLUE),
            &StereoOptions::default(),
        )
        .unwrap();
        assert_eq!(
            written,
            vec![dir.path().join("pair_L.png"), dir.path().join("pair_R.png")]
        );
        assert_eq!(read_image(&written[0]).unwrap(), Image::filled(4, 2, RED));
        assert_eq!(read_image(&written[1]).unwrap(), Image::filled(4, 2, BLUE));
        assert!(!out.exists());
    }

    #[test]
    fn write_stereo_composed_layouts() {
        let dir = tempfile::tempdir().unwrap();
        let opts = StereoOptions::default();
        for layout in ALL_LAYOUTS {
            let ext = match layout {
                Layout::Mpo => "mpo",
                Layout::MultiviewExr | Layout::Separate => "exr",
                _ => "pfm",
            };
            let out = dir.path().join(format!("{}.{ext}", layout.name()));
            let written = write_stereo(
                &out,
                layout,
                &Image::filled(4, 2, RED),
                &Image::filled(4, 2, BLUE),
                &opts,
            )
            .unwrap();
            for p in &written {
                assert!(p.exists(), "{layout}: {}", p.display());
            }
        }
        let sbs = read_image(&dir.path().join("side-by-side.pfm")).unwrap();
        assert_eq!((sbs.width, sbs.height), (8, 2));
        assert_eq!(sbs.get(0, 0), RED);
        assert_eq!(sbs.get(7, 1), BLUE);
        let mv = read_image(&dir.path().join("multiview-exr.exr")).unwrap();
        assert_eq!(mv, Image::filled(4, 2, RED));
    }

    #[test]
    fn write_stereo_checks_names_and_sizes_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let opts = StereoOptions::default();
        let (l, r) = (Image::filled(4, 2, RED), Image::filled(4, 2, BLUE));
        for (layout, name) in [
            (Layout::Mpo, "pair.png"),
            (Layout::MultiviewExr, "pair.png"),
            (Layout::Separate, "pair.xyz"),
            (Layout::SideBySide, "pair"),
        ] {
            let err = write_stereo(&dir.path().join(name), layout, &l, &r, &opts).unwrap_err();
            assert!(matches!(err, Error::Invalid(_)), "{layout}: {err:?}");
        }
        let err = write_stereo(
            &dir.path().join("pair.png"),
            Layout::Separate,
            &l,
            &Image::new(2, 2),
            &opts,
        )
        .unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn image_checks() {
        assert!(check_image(&Image::new(2, 3), "x").is_ok());
        assert!(check_image(&Image::new(0, 3), "x").is_err());
        let bad = Image {
            width: 2,
            height: 2,
            pixels: vec![],
        };
        assert!(check_image(&bad, "x").is_err());
        assert!(check_pair(&Image::new(2, 3), &Image::new(3, 2)).is_err());
    }
}
