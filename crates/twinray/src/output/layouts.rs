//! Frame-packed stereo layouts: pure functions of the two eye images.
//!
//! Every function checks that both eyes are well-formed images of the same
//! size (else [`Error::Invalid`]) and returns a new image.
//!
//! **Squeezed (half) layouts and odd sizes.** With `squeeze`, each eye is
//! halved along the packing direction by averaging pairs of columns (or rows)
//! so that the frame has the size of one eye. When the eye width (height) `n`
//! is odd, each eye is squeezed to `n / 2` (rounded down) columns and the last
//! output column averages the last *three* source columns, so no source column
//! is dropped and both halves stay exactly equal, which is what a half-SBS /
//! half-TB player assumes when it splits the frame in the middle. The frame is
//! then `n - 1` wide (high), one less than the eye. An eye only 1 column
//! (row) wide cannot be squeezed: [`Error::Invalid`].

use std::path::{Path, PathBuf};

use crate::math::Color;
use crate::output::encode::check_rgb8;
use crate::output::{check_pair, check_same_size, Layout};
use crate::{Error, Image, Result, Rgb8Image};

/// How [`interlace`] alternates the eyes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InterlaceMode {
    /// Even rows (0, 2, …) from the left eye, odd rows from the right
    /// (line-interleaved / row-interlaced 3D monitors).
    Rows,
    /// Even columns from the left eye, odd columns from the right.
    Columns,
    /// Pixels with `x + y` even from the left eye, the others from the right
    /// (checkerboard, as DLP 3D displays take it).
    Checker,
}

/// Left | right, side by side (parallel viewing). With `squeeze`, half-width
/// each, so the frame has the eye's size (see the module notes on odd widths).
pub fn side_by_side(left: &Image, right: &Image, squeeze: bool) -> Result<Image> {
    check_pair(left, right)?;
    if squeeze {
        hconcat(&squeeze_columns(left)?, &squeeze_columns(right)?)
    } else {
        hconcat(left, right)
    }
}

/// Right | left, side by side (cross-eyed viewing). With `squeeze`, as
/// [`side_by_side`].
pub fn cross(left: &Image, right: &Image, squeeze: bool) -> Result<Image> {
    check_pair(left, right)?;
    side_by_side(right, left, squeeze)
}

/// Left above right. With `squeeze`, half-height each, so the frame has the
/// eye's size (see the module notes on odd heights).
pub fn top_bottom(left: &Image, right: &Image, squeeze: bool) -> Result<Image> {
    check_pair(left, right)?;
    if squeeze {
        vconcat(&squeeze_rows(left)?, &squeeze_rows(right)?)
    } else {
        vconcat(left, right)
    }
}

/// Both eyes woven into one eye-sized frame (see [`InterlaceMode`]).
pub fn interlace(left: &Image, right: &Image, mode: InterlaceMode) -> Result<Image> {
    check_pair(left, right)?;
    Ok(Image {
        width: left.width,
        height: left.height,
        pixels: woven(&left.pixels, &right.pixels, left.width as usize, 1, mode),
    })
}

/// The eyes' pixels (`per_pixel` values each, rows of `width` pixels) woven
/// as `mode` says.
fn woven<T: Copy>(
    left: &[T],
    right: &[T],
    width: usize,
    per_pixel: usize,
    mode: InterlaceMode,
) -> Vec<T> {
    let mut out = left.to_vec();
    let row = (width * per_pixel).max(1);
    for (y, (to, from)) in out.chunks_mut(row).zip(right.chunks(row)).enumerate() {
        for (x, (to, from)) in to
            .chunks_mut(per_pixel)
            .zip(from.chunks(per_pixel))
            .enumerate()
        {
            let from_left = match mode {
                InterlaceMode::Rows => y % 2 == 0,
                InterlaceMode::Columns => x % 2 == 0,
                InterlaceMode::Checker => (x + y) % 2 == 0,
            };
            if !from_left {
                to.copy_from_slice(from);
            }
        }
    }
    out
}

/// Whether `layout` packs the eyes by moving their pixels only (side by
/// side, crossed or top-bottom without `squeeze`, interlaced): a frame that
/// [`pair_frame_rgb8`] makes from 8-bit eyes, the bytes of the float frame's.
pub fn moves_pixels_only(layout: Layout, squeeze: bool) -> bool {
    match layout {
        Layout::SideBySide | Layout::Cross | Layout::TopBottom => !squeeze,
        Layout::Interlace(_) => true,
        _ => false,
    }
}

/// The frame of `layout` (one that [`moves_pixels_only`] without squeeze)
/// from eyes kept as 8-bit pixels.
pub fn pair_frame_rgb8(left: &Rgb8Image, right: &Rgb8Image, layout: Layout) -> Result<Rgb8Image> {
    check_rgb8(left, "left image")?;
    check_rgb8(right, "right image")?;
    check_same_size((left.width, left.height), (right.width, right.height))?;
    let (w, h) = (left.width, left.height);
    let frame = |width, height, bytes| Rgb8Image {
        width,
        height,
        bytes,
    };
    let row = 3 * w as usize;
    Ok(match layout {
        Layout::SideBySide => frame(
            2 * w,
            h,
            side_by_side_rows(&left.bytes, row, &right.bytes, row),
        ),
        Layout::Cross => frame(
            2 * w,
            h,
            side_by_side_rows(&right.bytes, row, &left.bytes, row),
        ),
        Layout::TopBottom => frame(w, 2 * h, [&left.bytes[..], &right.bytes[..]].concat()),
        Layout::Interlace(mode) => {
            frame(w, h, woven(&left.bytes, &right.bytes, w as usize, 3, mode))
        }
        _ => {
            return Err(Error::Invalid(format!(
                "the {} layout is composed from the eyes' float colours",
                layout.name()
            )))
        }
    })
}

/// Rows of `a` and `b` (`a_row` and `b_row` values each) side by side.
fn side_by_side_rows<T: Copy>(a: &[T], a_row: usize, b: &[T], b_row: usize) -> Vec<T> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    for (ra, rb) in a
        .chunks_exact(a_row.max(1))
        .zip(b.chunks_exact(b_row.max(1)))
    {
        out.extend_from_slice(ra);
        out.extend_from_slice(rb);
    }
    out
}

/// The two file names of the `Separate` layout: `dir/pair.png` →
/// (`dir/pair_L.png`, `dir/pair_R.png`); without extension `pair` →
/// (`pair_L`, `pair_R`).
pub fn separate_paths(out: &Path) -> (PathBuf, PathBuf) {
    let with_suffix = |suffix: &str| {
        let mut name = out.file_stem().unwrap_or_default().to_os_string();
        name.push(suffix);
        if let Some(ext) = out.extension() {
            name.push(".");
            name.push(ext);
        }
        out.with_file_name(name)
    };
    (with_suffix("_L"), with_suffix("_R"))
}

fn hconcat(a: &Image, b: &Image) -> Result<Image> {
    let width = a.width.checked_add(b.width).ok_or_else(|| {
        Error::Invalid(format!(
            "side-by-side frame too wide ({} + {})",
            a.width, b.width
        ))
    })?;
    let (aw, bw) = (a.width as usize, b.width as usize);
    Ok(Image {
        width,
        height: a.height,
        pixels: side_by_side_rows(&a.pixels, aw, &b.pixels, bw),
    })
}

fn vconcat(a: &Image, b: &Image) -> Result<Image> {
    let height = a.height.checked_add(b.height).ok_or_else(|| {
        Error::Invalid(format!(
            "top-bottom frame too high ({} + {})",
            a.height, b.height
        ))
    })?;
    let mut pixels = Vec::with_capacity(a.pixels.len() + b.pixels.len());
    pixels.extend_from_slice(&a.pixels);
    pixels.extend_from_slice(&b.pixels);
    Ok(Image {
        width: a.width,
        height,
        pixels,
    })
}

/// Source index ranges averaged into each of the `n / 2` outputs: pairs,
/// with the last output taking the leftover when `n` is odd.
fn halving_groups(n: u32, what: &str) -> Result<Vec<std::ops::Range<u32>>> {
    if n < 2 {
        return Err(Error::Invalid(format!(
            "cannot squeeze an image only {n} {what} across"
        )));
    }
    let half = n / 2;
    Ok((0..half)
        .map(|i| {
            let end = if i + 1 == half { n } else { 2 * i + 2 };
            2 * i..end
        })
        .collect())
}

fn average(colors: impl Iterator<Item = Color>) -> Color {
    let (sum, count) = colors.fold((Color::ZERO, 0u32), |(s, c), x| (s + x, c + 1));
    sum / count.max(1) as f32
}

fn squeeze_columns(img: &Image) -> Result<Image> {
    let groups = halving_groups(img.width, "column(s)")?;
    let mut out = Image::new(groups.len() as u32, img.height);
    for y in 0..img.height {
        for (x, g) in groups.iter().enumerate() {
            out.set(x as u32, y, average(g.clone().map(|sx| img.get(sx, y))));
        }
    }
    Ok(out)
}

fn squeeze_rows(img: &Image) -> Result<Image> {
    let groups = halving_groups(img.height, "row(s)")?;
    let mut out = Image::new(img.width, groups.len() as u32);
    for (y, g) in groups.iter().enumerate() {
        for x in 0..img.width {
            out.set(x, y as u32, average(g.clone().map(|sy| img.get(x, sy))));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::AnaglyphMethod;

    #[test]
    fn eight_bit_eyes_of_two_sizes_or_a_mixing_layout_are_refused() {
        let eye = |w: u32, h: u32, v: u8| Rgb8Image {
            width: w,
            height: h,
            bytes: vec![v; (3 * w * h) as usize],
        };
        let (l, r) = (eye(2, 1, 10), eye(2, 1, 20));
        let sbs = pair_frame_rgb8(&l, &r, Layout::SideBySide).unwrap();
        assert_eq!((sbs.width, sbs.height), (4, 1));
        assert_eq!(sbs.bytes, [[10u8; 6], [20u8; 6]].concat());
        let cross = pair_frame_rgb8(&l, &r, Layout::Cross).unwrap();
        assert_eq!(cross.bytes, [[20u8; 6], [10u8; 6]].concat());
        let err = pair_frame_rgb8(&l, &eye(3, 1, 20), Layout::TopBottom).unwrap_err();
        assert!(err.to_string().contains("differ in size"), "{err}");
        let short = Rgb8Image {
            bytes: vec![0; 5],
            ..eye(2, 1, 0)
        };
        let err = pair_frame_rgb8(&short, &r, Layout::SideBySide).unwrap_err();
        assert!(err.to_string().contains("malformed"), "{err}");
        let anaglyph = Layout::Anaglyph(AnaglyphMethod::Dubois);
        assert!(pair_frame_rgb8(&l, &r, anaglyph).is_err());
    }

    const RED: Color = Color::new(1.0, 0.0, 0.0);
    const BLUE: Color = Color::new(0.0, 0.0, 1.0);

    /// Pixel value encodes its coordinates: (x, y, tag).
    fn coords(width: u32, height: u32, tag: f32) -> Image {
        let mut img = Image::new(width, height);
        for y in 0..height {
            for x in 0..width {
                img.set(x, y, Color::new(x as f32, y as f32, tag));
            }
        }
        img
    }

    #[test]
    fn side_by_side_puts_left_on_the_left() {
        let out =
            side_by_side(&Image::filled(4, 3, RED), &Image::filled(4, 3, BLUE), false).unwrap();
        assert_eq!((out.width, out.height), (8, 3));
        for y in 0..3 {
            for x in 0..8 {
                assert_eq!(out.get(x, y), if x < 4 { RED } else { BLUE }, "({x},{y})");
            }
        }
    }

    #[test]
    fn side_by_side_keeps_every_pixel_in_place() {
        let out = side_by_side(&coords(3, 2, 0.0), &coords(3, 2, 1.0), false).unwrap();
        assert_eq!(out.get(2, 1), Color::new(2.0, 1.0, 0.0));
        assert_eq!(out.get(3, 0), Color::new(0.0, 0.0, 1.0));
        assert_eq!(out.get(5, 1), Color::new(2.0, 1.0, 1.0));
    }

    #[test]
    fn cross_puts_right_on_the_left() {
        let out = cross(&Image::filled(4, 3, RED), &Image::filled(4, 3, BLUE), false).unwrap();
        assert_eq!((out.width, out.height), (8, 3));
        assert_eq!(out.get(0, 0), BLUE);
        assert_eq!(out.get(3, 2), BLUE);
        assert_eq!(out.get(4, 0), RED);
        assert_eq!(out.get(7, 2), RED);
        let sq = cross(&Image::filled(4, 3, RED), &Image::filled(4, 3, BLUE), true).unwrap();
        assert_eq!((sq.width, sq.height), (4, 3));
        assert_eq!(sq.get(0, 0), BLUE);
        assert_eq!(sq.get(3, 0), RED);
    }

    #[test]
    fn top_bottom_puts_left_on_top() {
        let out = top_bottom(&Image::filled(4, 3, RED), &Image::filled(4, 3, BLUE), false).unwrap();
        assert_eq!((out.width, out.height), (4, 6));
        for y in 0..6 {
            for x in 0..4 {
                assert_eq!(out.get(x, y), if y < 3 { RED } else { BLUE });
            }
        }
    }

    #[test]
    fn squeezed_side_by_side_has_eye_size_and_averages_pairs() {
        let l = coords(6, 2, 0.0);
        let r = coords(6, 2, 1.0);
        let out = side_by_side(&l, &r, true).unwrap();
        assert_eq!((out.width, out.height), (6, 2));
        // Column 1 of the left half averages source columns 2 and 3.
        assert_eq!(out.get(1, 1), Color::new(2.5, 1.0, 0.0));
        // Column 0 of the right half averages columns 0 and 1 of the right eye.
        assert_eq!(out.get(3, 0), Color::new(0.5, 0.0, 1.0));
        assert_eq!(out.get(5, 0), Color::new(4.5, 0.0, 1.0));
    }

    #[test]
    fn squeezed_side_by_side_with_odd_width() {
        let out = side_by_side(&coords(5, 1, 0.0), &coords(5, 1, 1.0), true).unwrap();
        // 5 columns squeeze to 2 per eye: (0,1) and (2,3,4).
        assert_eq!((out.width, out.height), (4, 1));
        assert_eq!(out.get(0, 0), Color::new(0.5, 0.0, 0.0));
        assert_eq!(out.get(1, 0), Color::new(3.0, 0.0, 0.0));
        assert_eq!(out.get(2, 0), Color::new(0.5, 0.0, 1.0));
        assert_eq!(out.get(3, 0), Color::new(3.0, 0.0, 1.0));
        // A 3-column eye squeezes to one column averaging all three.
        let out = side_by_side(&coords(3, 1, 0.0), &coords(3, 1, 1.0), true).unwrap();
        assert_eq!(out.width, 2);
        assert_eq!(out.get(0, 0), Color::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn squeezed_top_bottom_has_eye_size() {
        let out = top_bottom(&coords(2, 4, 0.0), &coords(2, 4, 1.0), true).unwrap();
        assert_eq!((out.width, out.height), (2, 4));
        assert_eq!(out.get(1, 0), Color::new(1.0, 0.5, 0.0));
        assert_eq!(out.get(1, 1), Color::new(1.0, 2.5, 0.0));
        assert_eq!(out.get(0, 2), Color::new(0.0, 0.5, 1.0));
        assert_eq!(out.get(0, 3), Color::new(0.0, 2.5, 1.0));
        let odd = top_bottom(&coords(2, 3, 0.0), &coords(2, 3, 1.0), true).unwrap();
        assert_eq!((odd.width, odd.height), (2, 2));
        assert_eq!(odd.get(0, 0), Color::new(0.0, 1.0, 0.0));
        assert_eq!(odd.get(0, 1), Color::new(0.0, 1.0, 1.0));
    }

    #[test]
    fn squeezing_a_single_column_is_an_error() {
        let l = Image::filled(1, 4, RED);
        assert!(matches!(side_by_side(&l, &l, true), Err(Error::Invalid(_))));
        assert!(side_by_side(&l, &l, false).is_ok());
        let l = Image::filled(4, 1, RED);
        assert!(matches!(top_bottom(&l, &l, true), Err(Error::Invalid(_))));
    }

    #[test]
    fn mismatched_or_broken_eyes_are_errors() {
        let a = Image::filled(4, 3, RED);
        let b = Image::filled(3, 4, BLUE);
        assert!(matches!(
            side_by_side(&a, &b, false),
            Err(Error::Invalid(_))
        ));
        assert!(matches!(cross(&a, &b, true), Err(Error::Invalid(_))));
        assert!(matches!(top_bottom(&a, &b, false), Err(Error::Invalid(_))));
        for mode in [
            InterlaceMode::Rows,
            InterlaceMode::Columns,
            InterlaceMode::Checker,
        ] {
            assert!(matches!(interlace(&a, &b, mode), Err(Error::Invalid(_))));
        }
        let broken = Image {
            width: 4,
            height: 3,
            pixels: vec![RED; 5],
        };
        assert!(matches!(
            side_by_side(&broken, &a, false),
            Err(Error::Invalid(_))
        ));
        assert!(matches!(
            interlace(&a, &broken, InterlaceMode::Rows),
            Err(Error::Invalid(_))
        ));
    }

    #[test]
    fn interlace_rows() {
        let out = interlace(
            &Image::filled(3, 4, RED),
            &Image::filled(3, 4, BLUE),
            InterlaceMode::Rows,
        )
        .unwrap();
        assert_eq!((out.width, out.height), (3, 4));
        for y in 0..4 {
            for x in 0..3 {
                assert_eq!(out.get(x, y), if y % 2 == 0 { RED } else { BLUE });
            }
        }
    }

    #[test]
    fn interlace_columns() {
        let out = interlace(
            &Image::filled(3, 4, RED),
            &Image::filled(3, 4, BLUE),
            InterlaceMode::Columns,
        )
        .unwrap();
        assert_eq!((out.width, out.height), (3, 4));
        for y in 0..4 {
            for x in 0..3 {
                assert_eq!(out.get(x, y), if x % 2 == 0 { RED } else { BLUE });
            }
        }
    }

    #[test]
    fn interlace_checker() {
        let out = interlace(
            &Image::filled(3, 3, RED),
            &Image::filled(3, 3, BLUE),
            InterlaceMode::Checker,
        )
        .unwrap();
        assert_eq!(out.get(0, 0), RED);
        assert_eq!(out.get(1, 0), BLUE);
        assert_eq!(out.get(0, 1), BLUE);
        assert_eq!(out.get(1, 1), RED);
        assert_eq!(out.get(2, 2), RED);
        assert_eq!(out.get(2, 1), BLUE);
    }

    #[test]
    fn interlace_takes_pixels_from_the_same_position() {
        let out = interlace(
            &coords(4, 4, 0.0),
            &coords(4, 4, 1.0),
            InterlaceMode::Checker,
        )
        .unwrap();
        for y in 0..4 {
            for x in 0..4 {
                let c = out.get(x, y);
                assert_eq!((c.x, c.y), (x as f32, y as f32));
            }
        }
    }

    #[test]
    fn separate_paths_add_eye_suffixes() {
        assert_eq!(
            separate_paths(Path::new("out/pair.png")),
            (
                PathBuf::from("out/pair_L.png"),
                PathBuf::from("out/pair_R.png")
            )
        );
        assert_eq!(
            separate_paths(Path::new("pair")),
            (PathBuf::from("pair_L"), PathBuf::from("pair_R"))
        );
        assert_eq!(
            separate_paths(Path::new("a.b/pair.v2.exr")),
            (
                PathBuf::from("a.b/pair.v2_L.exr"),
                PathBuf::from("a.b/pair.v2_R.exr")
            )
        );
    }
}
