//! Tiles of one still: horizontal bands of rows that machines render apart
//! (`twinray render --tiles N --tile K`, a spec's `tile`) and [`merge`]
//! stacks again. A band starts on a row where the renderer's bands of
//! samples start, and takes the samples of its neighbours that its filter
//! reaches ([`render_rows`](crate::render::render_rows)), so the merged
//! image is the one-machine render, bit for bit.

use std::ops::Range;
use std::path::{Path, PathBuf};

use super::spec::{JobSpec, LayoutSpec, TileSpec};
use crate::output::{self, ImageFormat, WriteOptions};
use crate::render::TILE_ROW_ALIGNMENT;
use crate::{Error, Image, Result};

/// The tile's values and what it combines with: layouts whose rows are
/// the views' rows (not top-bottom, MPO, quilts or multi-view EXR), lossless
/// files, no depth channels, no frames.
pub(super) fn check(spec: &JobSpec, tile: TileSpec) -> Result<()> {
    let TileSpec { index, count } = tile;
    if count == 0 || index >= count {
        return Err(Error::Invalid(format!(
            "--tile {index} of --tiles {count}: the tiles are numbered 0 to N-1, N >= 1"
        )));
    }
    let layout = spec.output.layout;
    if matches!(
        layout,
        LayoutSpec::Tb | LayoutSpec::Mpo | LayoutSpec::Quilt | LayoutSpec::Multiview
    ) {
        return Err(Error::Invalid(format!(
            "--tiles splits the image into bands of rows: --layout {} does not (use separate, sbs, cross, anaglyph or interlace)",
            layout.name()
        )));
    }
    if spec.output.depth {
        return Err(Error::Invalid(
            "--tiles does not combine with --depth".into(),
        ));
    }
    if spec.output.stats.is_some() {
        return Err(Error::Invalid(
            "--tiles does not combine with --stats (each tile would count its own rays)".into(),
        ));
    }
    if ImageFormat::from_path(&spec.output.path)? == ImageFormat::Jpeg {
        return Err(Error::Invalid(
            "--tiles needs a lossless output (.png, .exr or .pfm): JPEG tiles would not merge into the one-machine image".into(),
        ));
    }
    Ok(())
}

/// The rows of tile `index` of `count` in an image `height` rows high:
/// `count` bands of about equal height, each starting at a multiple of
/// [`TILE_ROW_ALIGNMENT`].
pub fn tile_rows(height: u32, tile: TileSpec) -> Result<Range<u32>> {
    let a = TILE_ROW_ALIGNMENT;
    let groups = height.div_ceil(a);
    if tile.count == 0 || tile.index >= tile.count || tile.count > groups {
        return Err(Error::Invalid(format!(
            "--tiles {}: a {height}-row image has at most {groups} tiles (bands of {a} rows)",
            tile.count
        )));
    }
    let edge = |k: u32| {
        let g = (u64::from(groups) * u64::from(k) / u64::from(tile.count)) as u32;
        (g * a).min(height)
    };
    Ok(edge(tile.index)..edge(tile.index + 1))
}

/// `NAME_tileKofN.ext` beside `out`.
pub fn tile_path(out: &Path, tile: TileSpec) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("image");
    let tag = format!("{stem}_tile{}of{}", tile.index, tile.count);
    let name = match out.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!("{tag}.{ext}"),
        None => tag,
    };
    out.with_file_name(name)
}

/// The tile a file's name says it is: the last `_tileKofN` in it.
pub fn parse_tile_name(path: &Path) -> Option<TileSpec> {
    let name = path.file_name()?.to_str()?;
    let at = name.rfind("_tile")?;
    let rest = &name[at + "_tile".len()..];
    let digits = |s: &str| s.bytes().take_while(u8::is_ascii_digit).count();
    let k = digits(rest);
    let index = rest[..k].parse().ok()?;
    let rest = rest[k..].strip_prefix("of")?;
    let n = digits(rest);
    let count = rest[..n].parse().ok()?;
    Some(TileSpec { index, count })
}

/// Stacks the tiles `inputs` (named `…_tileKofN…`, in any order) into one
/// image at `out`, written atomically; every tile from 0 to N-1 exactly
/// once, all of one width. PNG (8-bit, values as stored: never a curve
/// applied twice), EXR and PFM round-trip exactly, so the merge is the
/// one-machine image.
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<()> {
    let mut tiles: Vec<(TileSpec, &PathBuf)> = Vec::with_capacity(inputs.len());
    for p in inputs {
        let t = parse_tile_name(p).ok_or_else(|| {
            Error::Invalid(format!(
                "{}: not a tile (its name has no _tileKofN)",
                p.display()
            ))
        })?;
        tiles.push((t, p));
    }
    tiles.sort_by_key(|(t, _)| t.index);
    let count = tiles.first().map_or(0, |(t, _)| t.count);
    let complete = tiles.len() == count as usize
        && tiles
            .iter()
            .enumerate()
            .all(|(i, (t, _))| t.count == count && t.index == i as u32);
    if !complete {
        let have: Vec<String> = tiles
            .iter()
            .map(|(t, _)| format!("{}of{}", t.index, t.count))
            .collect();
        return Err(Error::Invalid(format!(
            "merge needs every tile 0 to N-1 of one set exactly once; got {}",
            if have.is_empty() {
                "none".to_string()
            } else {
                have.join(", ")
            }
        )));
    }
    if ImageFormat::from_path(out)? == ImageFormat::Jpeg {
        return Err(Error::Invalid(
            "merge writes a lossless image: .png, .exr or .pfm".into(),
        ));
    }
    let inputs: Vec<&Path> = tiles.iter().map(|(_, p)| p.as_path()).collect();
    output::check_distinct(&[out.to_path_buf()], &inputs)?;
    let mut merged: Option<Image> = None;
    for (_, path) in &tiles {
        let tile = output::read_image(path)?;
        match &mut merged {
            None => merged = Some(tile),
            Some(m) if m.width == tile.width => {
                m.height += tile.height;
                m.pixels.extend(tile.pixels);
            }
            Some(m) => {
                return Err(Error::Invalid(format!(
                    "{}: {} pixels wide, the tiles before it {}",
                    path.display(),
                    tile.width,
                    m.width
                )))
            }
        }
    }
    let merged = merged.ok_or_else(|| Error::Invalid("merge: no tiles".into()))?;
    output::write_image(out, &merged, &WriteOptions { srgb: false })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_image_once_and_start_aligned() {
        for height in [1u32, 7, 8, 9, 100, 360, 4096] {
            for count in 1..=height.div_ceil(8).min(9) {
                let mut next = 0;
                for index in 0..count {
                    let r = tile_rows(height, TileSpec { index, count }).unwrap();
                    assert_eq!(r.start, next, "height {height} tile {index}/{count}");
                    assert!(r.end > r.start);
                    assert_eq!(r.start % 8, 0);
                    next = r.end;
                }
                assert_eq!(next, height);
            }
        }
        assert!(tile_rows(16, TileSpec { index: 0, count: 3 }).is_err());
    }

    #[test]
    fn tile_names_round_trip() {
        let t = TileSpec {
            index: 3,
            count: 12,
        };
        let p = tile_path(Path::new("shots/f.png"), t);
        assert_eq!(p, Path::new("shots/f_tile3of12.png"));
        assert_eq!(parse_tile_name(&p), Some(t));
        assert_eq!(parse_tile_name(Path::new("f_tile3of12_L.png")), Some(t));
        assert_eq!(parse_tile_name(Path::new("f.png")), None);
    }
}
