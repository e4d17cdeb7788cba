//! Looking Glass quilts: N views tiled in one image.
//!
//! The convention of Looking Glass's tools: the views fill a grid of
//! `columns` x `rows` tiles left to right, bottom row first, so view 0 (the
//! leftmost camera) is the bottom-left tile and the last view the top-right
//! one. The software reads the grid and the views' aspect (width / height)
//! from the file name: `NAME_qs{columns}x{rows}a{aspect}.png`, e.g.
//! `scene_qs8x6a0.75.png`.
//!
//! The presets hold the grids the devices' documentation recommends. Their
//! view sizes keep twinray's square pixels at the device's aspect (the
//! devices' own quilts stretch tiles of another shape to it).

use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::encode::{check_rgb8, rgb8_into, stage_rgb8, Rgb8};
use super::{write_image, ImageFormat, WriteOptions};
use crate::{Error, Image, Result, Rgb8Image};

/// A grid of views.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QuiltLayout {
    pub columns: u32,
    pub rows: u32,
}

/// A device's quilt settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuiltPreset {
    /// The name `--quilt` takes.
    pub name: &'static str,
    pub device: &'static str,
    pub layout: QuiltLayout,
    /// Size of one view, in pixels.
    pub view_width: u32,
    pub view_height: u32,
    /// The view cone the device expects, in degrees.
    pub view_cone: f64,
}

/// Looking Glass Portrait (8x6, 48 views of 0.75), Go (11x6, 66 views of
/// 0.5625) and the first-generation 8.9" and 15.6" displays (5x9, 45 views of
/// 1.6). Cone: the 35° the devices' documentation gives for rendering.
pub const PRESETS: &[QuiltPreset] = &[
    QuiltPreset {
        name: "portrait",
        device: "Looking Glass Portrait",
        layout: QuiltLayout {
            columns: 8,
            rows: 6,
        },
        view_width: 420,
        view_height: 560,
        view_cone: 35.0,
    },
    QuiltPreset {
        name: "go",
        device: "Looking Glass Go",
        layout: QuiltLayout {
            columns: 11,
            rows: 6,
        },
        view_width: 369,
        view_height: 656,
        view_cone: 35.0,
    },
    QuiltPreset {
        name: "legacy",
        device: "Looking Glass 8.9\" and 15.6\" (first generation)",
        layout: QuiltLayout {
            columns: 5,
            rows: 9,
        },
        view_width: 768,
        view_height: 480,
        view_cone: 35.0,
    },
];

/// What `--quilt` names: a grid, or a device preset (with its grid).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuiltSpec {
    pub layout: QuiltLayout,
    pub preset: Option<&'static QuiltPreset>,
}

impl FromStr for QuiltSpec {
    type Err = Error;

    /// `COLSxROWS` (e.g. `8x6`) or a preset name (`portrait`, `go`, `legacy`).
    fn from_str(s: &str) -> Result<QuiltSpec> {
        let key = s.trim().to_ascii_lowercase();
        if let Some(p) = PRESETS.iter().find(|p| p.name == key) {
            return Ok(QuiltSpec {
                layout: p.layout,
                preset: Some(p),
            });
        }
        let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
        let bad = || {
            Error::Invalid(format!(
                "quilt '{s}': use COLSxROWS (e.g. 8x6) or a preset ({})",
                names.join(", ")
            ))
        };
        let (c, r) = key.split_once('x').ok_or_else(bad)?;
        let columns: u32 = c.trim().parse().map_err(|_| bad())?;
        let rows: u32 = r.trim().parse().map_err(|_| bad())?;
        if columns == 0 || rows == 0 || columns.saturating_mul(rows) > 4096 {
            return Err(Error::Invalid(format!(
                "quilt '{s}': 1 to 4096 tiles (columns x rows)"
            )));
        }
        Ok(QuiltSpec {
            layout: QuiltLayout { columns, rows },
            preset: None,
        })
    }
}

impl QuiltLayout {
    pub fn tiles(&self) -> usize {
        self.columns as usize * self.rows as usize
    }

    /// The top-left corner of view `view`'s tile in a quilt of `width` x
    /// `height` views: column `view % columns`, row `view / columns` counted
    /// from the bottom.
    pub fn tile_origin(&self, view: usize, width: u32, height: u32) -> (u32, u32) {
        let column = (view % self.columns as usize) as u32;
        let row_from_bottom = (view / self.columns as usize) as u32;
        (
            column * width,
            (self.rows - 1 - row_from_bottom.min(self.rows - 1)) * height,
        )
    }

    /// Size of the quilt of views of `width` x `height`, as u64 (for checks
    /// before anything is allocated).
    pub fn size(&self, width: u32, height: u32) -> (u64, u64) {
        (
            u64::from(self.columns) * u64::from(width),
            u64::from(self.rows) * u64::from(height),
        )
    }
}

/// The views' aspect as the file name gives it: up to four decimals, no
/// trailing zeros (`0.75`, `0.5625`, `1.6`, `1`).
pub fn aspect_label(width: u32, height: u32) -> String {
    let text = format!("{:.4}", f64::from(width) / f64::from(height.max(1)));
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// `out` with the quilt suffix: `dir/NAME.png` → `dir/NAME_qs8x6a0.75.png`
/// (kept as it is when the name already ends with that suffix).
pub fn quilt_path(out: &Path, layout: QuiltLayout, width: u32, height: u32) -> PathBuf {
    let suffix = format!(
        "_qs{}x{}a{}",
        layout.columns,
        layout.rows,
        aspect_label(width, height)
    );
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if stem.ends_with(&suffix) {
        return out.to_path_buf();
    }
    let name = match out.extension() {
        Some(ext) => format!("{stem}{suffix}.{}", ext.to_string_lossy()),
        None => format!("{stem}{suffix}"),
    };
    out.with_file_name(name)
}

/// The quilt of `views` (left to right) in `layout`: view 0 bottom-left, the
/// last view top-right. Tiles beyond the last view stay black.
///
/// Errors: no views, more views than tiles, views of different sizes or
/// malformed, a quilt larger than memory can index.
pub fn compose_quilt(views: &[Image], layout: QuiltLayout) -> Result<Image> {
    let (w, h, qw, qh) = quilt_size(views, layout)?;
    let mut quilt = Image::new(qw, qh);
    for (i, v) in views.iter().enumerate() {
        let (x0, y0) = layout.tile_origin(i, w, h);
        for y in 0..h {
            let src = &v.pixels[(y * w) as usize..((y + 1) * w) as usize];
            let start = ((y0 + y) as usize) * qw as usize + x0 as usize;
            quilt.pixels[start..start + w as usize].copy_from_slice(src);
        }
    }
    Ok(quilt)
}

/// Writes the quilt of `views` to `path`. An 8-bit file's pixels are
/// quantised from the views straight into the quilt's bytes, with no quilt
/// of floats between (for 48 views of 420×560, 135 MB less fresh memory,
/// which the kernel must clear first); the bytes are those of
/// `compose_quilt` written with `write_image`.
pub fn write_quilt(
    path: &Path,
    views: &[Image],
    layout: QuiltLayout,
    opts: &WriteOptions,
) -> Result<()> {
    if !ImageFormat::from_path(path)?.is_8_bit() {
        return write_image(path, &compose_quilt(views, layout)?, opts);
    }
    let (w, h, qw, qh) = quilt_size(views, layout)?;
    let bytes = quilt_bytes(layout, views.len(), (w, h), (qw, qh), |v, y, to| {
        rgb8_into(
            &views[v].pixels[y * w as usize..(y + 1) * w as usize],
            to,
            opts,
        )
    });
    commit_quilt(path, &bytes, (qw, qh))
}

/// Writes the quilt of `views` kept as 8-bit pixels
/// ([`ViewStorage::Rgb8`](crate::render::ViewStorage::Rgb8)) to `path`, a
/// PNG or JPEG: their rows copied into the quilt's, the file of
/// [`write_quilt`] with the options the views were quantised with.
pub fn write_quilt_rgb8(path: &Path, views: &[Rgb8Image], layout: QuiltLayout) -> Result<()> {
    if !ImageFormat::from_path(path)?.is_8_bit() {
        return Err(Error::Invalid(format!(
            "{}: views kept as 8-bit pixels go to a PNG or JPEG quilt",
            path.display()
        )));
    }
    for (i, v) in views.iter().enumerate() {
        check_rgb8(v, &format!("view {i}"))?;
    }
    let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.width, v.height)).collect();
    let (w, h, qw, qh) = quilt_size_of(&sizes, layout)?;
    let row = 3 * w as usize;
    let bytes = quilt_bytes(layout, views.len(), (w, h), (qw, qh), |v, y, to| {
        to.copy_from_slice(&views[v].bytes[y * row..(y + 1) * row])
    });
    commit_quilt(path, &bytes, (qw, qh))
}

/// Encodes the quilt's bytes for `path` and puts the file in place.
fn commit_quilt(path: &Path, bytes: &[u8], (width, height): (u32, u32)) -> Result<()> {
    stage_rgb8(
        path,
        &Rgb8 {
            bytes,
            width,
            height,
        },
    )?
    .commit()
}

/// The 8-bit quilt of `count` views of `w` x `h`: `tile_row(v, y, bytes)`
/// writes row `y` of view `v` into its place; tiles beyond the last view stay
/// black. Rows go to the current thread pool.
fn quilt_bytes(
    layout: QuiltLayout,
    count: usize,
    (w, h): (u32, u32),
    (qw, qh): (u32, u32),
    tile_row: impl Fn(usize, usize, &mut [u8]) + Sync,
) -> Vec<u8> {
    use rayon::prelude::*;
    let origins: Vec<(u32, u32)> = (0..count).map(|i| layout.tile_origin(i, w, h)).collect();
    let row_bytes = qw as usize * 3;
    let mut bytes = vec![0u8; row_bytes * qh as usize];
    bytes
        .par_chunks_mut(row_bytes)
        .enumerate()
        .for_each(|(qy, row)| {
            let qy = qy as u32;
            for (v, &(x0, y0)) in origins.iter().enumerate() {
                if (y0..y0 + h).contains(&qy) {
                    let at = x0 as usize * 3;
                    tile_row(v, (qy - y0) as usize, &mut row[at..at + 3 * w as usize]);
                }
            }
        });
    bytes
}

/// The views' size and the quilt's, checked: at least one view, no more
/// than the tiles, all of one size, a quilt that fits in `u32`.
fn quilt_size(views: &[Image], layout: QuiltLayout) -> Result<(u32, u32, u32, u32)> {
    for (i, v) in views.iter().enumerate() {
        super::check_image(v, &format!("view {i}"))?;
    }
    let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.width, v.height)).collect();
    quilt_size_of(&sizes, layout)
}

/// [`quilt_size`] of views of `sizes`, each already checked well-formed.
fn quilt_size_of(sizes: &[(u32, u32)], layout: QuiltLayout) -> Result<(u32, u32, u32, u32)> {
    let Some(&(w, h)) = sizes.first() else {
        return Err(Error::Invalid("a quilt needs at least one view".into()));
    };
    if sizes.len() > layout.tiles() {
        return Err(Error::Invalid(format!(
            "{} views do not fit a {}x{} quilt ({} tiles)",
            sizes.len(),
            layout.columns,
            layout.rows,
            layout.tiles()
        )));
    }
    for (i, &(vw, vh)) in sizes.iter().enumerate() {
        if (vw, vh) != (w, h) {
            return Err(Error::Invalid(format!(
                "quilt views differ in size: view 0 is {w}x{h}, view {i} is {vw}x{vh}"
            )));
        }
    }
    let (qw, qh) = layout.size(w, h);
    let (Ok(qw), Ok(qh)) = (u32::try_from(qw), u32::try_from(qh)) else {
        return Err(Error::Invalid(format!(
            "a {}x{} quilt of {w}x{h} views is too large",
            layout.columns, layout.rows
        )));
    };
    Ok((w, h, qw, qh))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    #[test]
    fn view_zero_is_bottom_left_and_the_last_top_right() {
        let layout = QuiltLayout {
            columns: 3,
            rows: 2,
        };
        let views: Vec<Image> = (0..6)
            .map(|i| Image::filled(2, 1, Color::splat(i as f32)))
            .collect();
        let q = compose_quilt(&views, layout).unwrap();
        assert_eq!((q.width, q.height), (6, 2));
        // Bottom row (y = 1): views 0 1 2; top row (y = 0): views 3 4 5.
        let tile = |x: u32, y: u32| q.get(x, y).x as usize;
        assert_eq!(
            [tile(0, 1), tile(2, 1), tile(4, 1)],
            [0, 1, 2],
            "bottom row"
        );
        assert_eq!([tile(0, 0), tile(2, 0), tile(5, 0)], [3, 4, 5], "top row");
        assert_eq!(layout.tile_origin(0, 2, 1), (0, 1));
        assert_eq!(layout.tile_origin(5, 2, 1), (4, 0));
    }

    #[test]
    fn missing_views_leave_black_tiles_and_extra_views_are_refused() {
        let layout = QuiltLayout {
            columns: 2,
            rows: 2,
        };
        let views = vec![Image::filled(1, 1, Color::ONE); 3];
        let q = compose_quilt(&views, layout).unwrap();
        assert_eq!(q.get(1, 0), Color::ZERO, "tile 3 (top right) is empty");
        assert!(compose_quilt(&vec![Image::new(1, 1); 5], layout).is_err());
        assert!(compose_quilt(&[], layout).is_err());
        assert!(compose_quilt(&[Image::new(1, 1), Image::new(2, 1)], layout).is_err());
    }

    /// An 8-bit quilt quantised straight from the views is, byte for byte,
    /// the file of the quilt of floats (PNG and JPEG, sRGB or not, a tile
    /// left empty); a float file goes the float way.
    #[test]
    fn an_8_bit_quilt_from_the_views_is_the_file_of_the_float_quilt() {
        let layout = QuiltLayout {
            columns: 3,
            rows: 2,
        };
        // Five views of 7x4 (the sixth tile stays black), every pixel its own
        // colour, some outside [0, 1] and one NaN.
        let views: Vec<Image> = (0..5)
            .map(|v| {
                let mut img = Image::new(7, 4);
                for (k, p) in img.pixels.iter_mut().enumerate() {
                    let t = (v * 28 + k) as f32;
                    *p = Color::new(t / 140.0, 1.2 - t / 90.0, (t * 0.37).fract());
                }
                img.pixels[3] = Color::new(f32::NAN, 0.5, 2.0);
                img
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        for (name, srgb) in [
            ("q.png", true),
            ("q.png", false),
            ("q.jpg", true),
            ("q.pfm", true),
        ] {
            let opts = WriteOptions { srgb };
            let (direct, floats) = (
                dir.path().join(format!("a{name}")),
                dir.path().join(format!("b{name}")),
            );
            write_quilt(&direct, &views, layout, &opts).unwrap();
            write_image(&floats, &compose_quilt(&views, layout).unwrap(), &opts).unwrap();
            let (a, b) = (
                std::fs::read(&direct).unwrap(),
                std::fs::read(&floats).unwrap(),
            );
            assert!(a == b, "{name} srgb {srgb}: the files differ");
            // The views kept as 8-bit pixels, as the renderer keeps them.
            let kept = dir.path().join(format!("c{name}"));
            let bytes: Vec<Rgb8Image> = views
                .iter()
                .map(|v| Rgb8Image {
                    width: v.width,
                    height: v.height,
                    bytes: super::super::encode::to_rgb8(v, &opts),
                })
                .collect();
            if name.ends_with(".pfm") {
                assert!(write_quilt_rgb8(&kept, &bytes, layout).is_err());
                continue;
            }
            write_quilt_rgb8(&kept, &bytes, layout).unwrap();
            let c = std::fs::read(&kept).unwrap();
            assert!(
                a == c,
                "{name} srgb {srgb}: the file of 8-bit views differs"
            );
        }
        let short = Rgb8Image {
            width: 7,
            height: 4,
            bytes: vec![0; 7 * 4 * 3 - 1],
        };
        let err = write_quilt_rgb8(&dir.path().join("d.png"), &[short], layout);
        assert!(err.is_err_and(|e| e.to_string().contains("malformed")));
        let too_many: Vec<Image> = (0..7).map(|_| Image::new(7, 4)).collect();
        assert!(write_quilt(
            &dir.path().join("c.png"),
            &too_many,
            layout,
            &WriteOptions { srgb: true }
        )
        .is_err());
    }

    #[test]
    fn names_carry_grid_and_aspect() {
        let layout = QuiltLayout {
            columns: 8,
            rows: 6,
        };
        assert_eq!(
            quilt_path(Path::new("out/scene.png"), layout, 420, 560),
            PathBuf::from("out/scene_qs8x6a0.75.png")
        );
        assert_eq!(
            quilt_path(Path::new("scene_qs8x6a0.75.png"), layout, 420, 560),
            PathBuf::from("scene_qs8x6a0.75.png")
        );
        assert_eq!(aspect_label(369, 656), "0.5625");
        assert_eq!(aspect_label(768, 480), "1.6");
        assert_eq!(aspect_label(64, 64), "1");
        assert_eq!(aspect_label(640, 480), "1.3333");
    }

    #[test]
    fn specs_parse_grids_and_presets() {
        let s: QuiltSpec = "8x6".parse().unwrap();
        assert_eq!(
            s.layout,
            QuiltLayout {
                columns: 8,
                rows: 6
            }
        );
        assert!(s.preset.is_none());
        let p: QuiltSpec = "Portrait".parse().unwrap();
        assert_eq!(p.layout.tiles(), 48);
        assert_eq!(
            p.preset.map(|p| (p.view_width, p.view_height)),
            Some((420, 560))
        );
        assert_eq!("go".parse::<QuiltSpec>().unwrap().layout.tiles(), 66);
        assert_eq!("legacy".parse::<QuiltSpec>().unwrap().layout.tiles(), 45);
        for bad in ["8", "0x6", "axb", "100x100", "hologram"] {
            assert!(bad.parse::<QuiltSpec>().is_err(), "{bad}");
        }
        for p in PRESETS {
            let label = aspect_label(p.view_width, p.view_height);
            assert!(
                ["0.75", "0.5625", "1.6"].contains(&label.as_str()),
                "{}",
                p.name
            );
        }
    }
}
