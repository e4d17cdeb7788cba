//! Output paths and format limits, checked before any rendering: a missing
//! directory, a read-only file, a JPEG wider than the format allows or an
//! interaxial out of an MPO's range are found in milliseconds, not after the render
//! (they were found after 8.8 s and 19 s). Messages name the user's path.

use std::path::{Path, PathBuf};

use super::atomic::target;
use super::{separate_paths, ImageFormat, Layout, StereoOptions};
use crate::{Error, Result};

/// Largest width or height a JPEG (and so an MPO) can hold.
pub const JPEG_MAX_SIDE: u64 = 65_535;

/// Largest interaxial an MPO stores (its `BaselineLength` tag), in metres (the field's rational range as
/// written by [`write_mpo`](super::write_mpo)).
pub const MPO_MAX_INTERAXIAL_M: f64 = 4.0e3;

/// Checks that an image of `width` x `height` can be written to `path`: a
/// known format that can hold the size, a directory that exists and a target
/// that may be replaced (see [`crate::output`] on non-regular files).
pub fn check_image_target(path: &Path, width: u64, height: u64) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    if format == ImageFormat::Jpeg {
        check_jpeg_size(path, width, height)?;
    }
    check_file_target(path)
}

/// Checks that a file of any kind (statistics, a table) can be written to
/// `path`: the directory exists and what is there may be replaced.
pub fn check_file_target(path: &Path) -> Result<()> {
    target(path).map(|_| ())
}

fn check_jpeg_size(path: &Path, width: u64, height: u64) -> Result<()> {
    if width > JPEG_MAX_SIDE || height > JPEG_MAX_SIDE {
        return Err(Error::Invalid(format!(
            "{}: a JPEG holds at most {JPEG_MAX_SIDE} pixels per side, this image is \
             {width}x{height} (use .png or .exr)",
            path.display()
        )));
    }
    Ok(())
}

/// Checks everything [`write_stereo`](super::write_stereo) will need for a pair
/// of `width` x `height` eyes, before they exist; returns the files it will
/// write.
pub fn check_stereo_targets(
    out: &Path,
    layout: Layout,
    width: u32,
    height: u32,
    opts: &StereoOptions,
) -> Result<Vec<PathBuf>> {
    let (w, h) = (u64::from(width), u64::from(height));
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let frame = match layout {
        Layout::Separate => {
            ImageFormat::from_path(out)?;
            let (l, r) = separate_paths(out);
            check_image_target(&l, w, h)?;
            check_image_target(&r, w, h)?;
            return Ok(vec![l, r]);
        }
        Layout::Mpo => {
            if !matches!(ext.as_str(), "mpo" | "jpg" | "jpeg") {
                return Err(Error::Invalid(format!(
                    "{}: the mpo layout needs a .mpo (or .jpg) file name",
                    out.display()
                )));
            }
            let interaxial = opts.interaxial_m;
            if !(interaxial.is_finite() && (0.0..MPO_MAX_INTERAXIAL_M).contains(&interaxial)) {
                return Err(Error::Invalid(format!(
                    "{}: an MPO stores an interaxial (its BaselineLength) between 0 and \
                     {MPO_MAX_INTERAXIAL_M} m, not {interaxial}",
                    out.display()
                )));
            }
            check_jpeg_size(out, w, h)?;
            check_file_target(out)?;
            return Ok(vec![out.to_path_buf()]);
        }
        Layout::MultiviewExr => {
            if ext != "exr" {
                return Err(Error::Invalid(format!(
                    "{}: the multiview-exr layout needs a .exr file name",
                    out.display()
                )));
            }
            check_file_target(out)?;
            return Ok(vec![out.to_path_buf()]);
        }
        // Unsqueezed sizes: an upper bound of the squeezed ones.
        Layout::SideBySide | Layout::Cross => (2 * w, h),
        Layout::TopBottom => (w, 2 * h),
        Layout::Anaglyph(_) | Layout::Interlace(_) => (w, h),
    };
    check_image_target(out, frame.0, frame.1)?;
    Ok(vec![out.to_path_buf()])
}

/// Refuses outputs that would overwrite an input (the scene file) or each
/// other (`--stats out.png`): the attack overwrote the scene with JSON and
/// exited 0.
pub fn check_distinct(outputs: &[PathBuf], inputs: &[&Path]) -> Result<()> {
    for (i, out) in outputs.iter().enumerate() {
        if let Some(input) = inputs.iter().find(|input| same_file(out, input)) {
            return Err(Error::Invalid(format!(
                "{}: would overwrite the input {}",
                out.display(),
                input.display()
            )));
        }
        if let Some(other) = outputs[..i].iter().find(|other| same_file(out, other)) {
            return Err(Error::Invalid(format!(
                "{}: written twice (also as {})",
                out.display(),
                other.display()
            )));
        }
    }
    Ok(())
}

/// Whether two paths name one file: the same inode when both exist, else the
/// same file name in the same (canonical) directory.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return (ma.dev(), ma.ino()) == (mb.dev(), mb.ino());
        }
    }
    let canonical = |p: &Path| -> Option<PathBuf> {
        if let Ok(c) = std::fs::canonicalize(p) {
            return Some(c);
        }
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(std::fs::canonicalize(dir).ok()?.join(p.file_name()?))
    };
    match (canonical(a), canonical(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::AnaglyphMethod;

    #[test]
    fn jpeg_and_mpo_limits_are_known_before_rendering() {
        let dir = tempfile::tempdir().unwrap();
        let jpg = dir.path().join("wide.jpg");
        let err = check_image_target(&jpg, 70_000, 10)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("wide.jpg: a JPEG holds at most 65535"),
            "{err}"
        );
        assert!(check_image_target(&jpg, 65_535, 10).is_ok());
        // Side by side doubles the width.
        let opts = StereoOptions::default();
        assert!(check_stereo_targets(&jpg, Layout::SideBySide, 40_000, 10, &opts).is_err());
        assert!(check_stereo_targets(&jpg, Layout::TopBottom, 40_000, 10, &opts).is_ok());
        let mpo = dir.path().join("pair.mpo");
        let far = StereoOptions {
            interaxial_m: 5000.0,
            ..opts
        };
        let err = check_stereo_targets(&mpo, Layout::Mpo, 8, 8, &far)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("pair.mpo: an MPO stores an interaxial"),
            "{err}"
        );
        let anaglyph = Layout::Anaglyph(AnaglyphMethod::Dubois);
        assert_eq!(
            check_stereo_targets(&jpg, anaglyph, 8, 8, &opts).unwrap(),
            vec![jpg.clone()]
        );
        assert_eq!(
            check_stereo_targets(&dir.path().join("p.png"), Layout::Separate, 8, 8, &opts)
                .unwrap()
                .len(),
            2
        );
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }

    #[test]
    fn missing_directories_name_the_users_path() {
        let err = check_image_target(Path::new("no/such/dir/out.png"), 8, 8)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("no/such/dir/out.png: no directory"),
            "{err}"
        );
    }

    #[test]
    fn outputs_must_not_be_inputs_or_each_other() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.nff");
        std::fs::write(&scene, "s 0 0 0 1\n").unwrap();
        let out = dir.path().join("out.png");
        // The same file by another spelling.
        let aliased = dir.path().join(".").join("scene.nff");
        let err = check_distinct(&[out.clone(), aliased], &[&scene])
            .unwrap_err()
            .to_string();
        assert!(err.contains("would overwrite the input"), "{err}");
        let err = check_distinct(&[out.clone(), dir.path().join("./out.png")], &[&scene])
            .unwrap_err()
            .to_string();
        assert!(err.contains("written twice"), "{err}");
        assert!(check_distinct(&[out, dir.path().join("stats.json")], &[&scene]).is_ok());
    }
}
