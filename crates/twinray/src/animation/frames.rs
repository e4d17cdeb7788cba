//! Frame ranges (`--frames A..B`) and the output name of each frame.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::{Error, Result};

/// Most frames one range may hold: eleven and a half hours at 24 frames a
/// second. A range to 4294967295 was accepted, and its count overflowed.
pub const MAX_FRAMES: u32 = 1_000_000;

/// Frames `first` to `last`, both included (at most [`MAX_FRAMES`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    pub first: u32,
    pub last: u32,
}

impl FrameRange {
    pub fn count(&self) -> u32 {
        self.last - self.first + 1
    }

    pub fn iter(&self) -> impl Iterator<Item = u32> {
        self.first..=self.last
    }
}

impl FromStr for FrameRange {
    type Err = Error;

    /// `A..B` (both included, as in `0..239` for 240 frames), `A..=B`, or one frame `N`.
    fn from_str(s: &str) -> Result<FrameRange> {
        let bad = || {
            Error::Invalid(format!(
                "--frames '{s}': give A..B, the first and last frame numbers (0..239: 240 frames)"
            ))
        };
        let number = |t: &str| t.trim().parse::<u32>().map_err(|_| bad());
        let (first, last) = match s.split_once("..") {
            Some((a, b)) => (number(a)?, number(b.strip_prefix('=').unwrap_or(b))?),
            None => (number(s)?, number(s)?),
        };
        if last < first {
            return Err(Error::Invalid(format!(
                "--frames {s}: the last frame comes before the first"
            )));
        }
        if last - first >= MAX_FRAMES {
            return Err(Error::Invalid(format!(
                "--frames {s}: {} frames; at most {MAX_FRAMES} a range",
                u64::from(last - first) + 1
            )));
        }
        Ok(FrameRange { first, last })
    }
}

/// How the frames' files are named.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    folder: PathBuf,
    /// The file name: where the number goes.
    file: String,
}

impl FramePattern {
    /// `out`'s name with a frame number: one run of `#` in the file name
    /// (`out_####.png`: the number zero-padded to the run's width),
    /// `{frame}` or `{frame:0N}`; a name with none gets `_####` before its
    /// extension. Two runs of `#` (`f_##_##.png`), or `#` beside
    /// `{frame}`, are refused: which is the number would be a guess.
    /// Returns the pattern and whether the number was added.
    pub fn new(out: &Path) -> Result<(FramePattern, bool)> {
        let folder = out.parent().unwrap_or(Path::new("")).to_path_buf();
        let file = out
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let runs = file
            .split(|c| c != '#')
            .filter(|run| !run.is_empty())
            .count();
        let braces = file.contains("{frame");
        if runs > 1 || (runs == 1 && braces) {
            return Err(Error::Invalid(format!(
                "-o {}: the frame number goes in one place: one run of # (f_####.png) or {{frame}}",
                out.display()
            )));
        }
        if runs == 1 || braces {
            return Ok((FramePattern { folder, file }, false));
        }
        let stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tagged = match out.extension() {
            Some(ext) => format!("{stem}_####.{}", ext.to_string_lossy()),
            None => format!("{stem}_####"),
        };
        Ok((
            FramePattern {
                folder,
                file: tagged,
            },
            true,
        ))
    }

    /// The path of `frame`: the file name's `{frame}`/`{frame:0N}` or its
    /// run of `#` replaced (a `#` in a folder's name stays).
    pub fn path(&self, frame: u32) -> PathBuf {
        let mut s = self.file.clone();
        while let Some(at) = s.find("{frame") {
            let Some(end) = s[at..].find('}').map(|e| at + e) else {
                break;
            };
            let width: usize = s[at + "{frame".len()..end]
                .strip_prefix(":0")
                .or_else(|| s[at + "{frame".len()..end].strip_prefix(':'))
                .and_then(|w| w.parse::<usize>().ok())
                .unwrap_or(0)
                // A file name holds at most 255 bytes anyway.
                .min(255);
            s.replace_range(at..=end, &format!("{frame:0width$}"));
        }
        if let Some(end) = s.rfind('#') {
            let start = s[..end].rfind(|c| c != '#').map_or(0, |i| i + 1);
            let width = end + 1 - start;
            s.replace_range(start..=end, &format!("{frame:0width$}"));
        }
        self.folder.join(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        let r: FrameRange = "0..239".parse().unwrap();
        assert_eq!((r.first, r.last, r.count()), (0, 239, 240));
        assert_eq!("5..=7".parse::<FrameRange>().unwrap().count(), 3);
        assert_eq!("12".parse::<FrameRange>().unwrap().count(), 1);
        for bad in ["", "a..b", "5..2", "-1..3", "1...3"] {
            assert!(bad.parse::<FrameRange>().is_err(), "{bad}");
        }
    }

    #[test]
    fn names() {
        let p = |s: &str, f| FramePattern::new(Path::new(s)).unwrap().0.path(f);
        assert_eq!(p("shots/out_####.png", 7), Path::new("shots/out_0007.png"));
        assert_eq!(p("out_##.png", 123), Path::new("out_123.png"));
        assert_eq!(p("f{frame}.exr", 42), Path::new("f42.exr"));
        assert_eq!(p("f{frame:05}.exr", 42), Path::new("f00042.exr"));
        assert_eq!(p("shots/f.png", 3), Path::new("shots/f_0003.png"));
        assert!(FramePattern::new(Path::new("f.png")).unwrap().1);
        assert!(!FramePattern::new(Path::new("f_#.png")).unwrap().1);
        // A `#` in a folder's name is not the number's place.
        assert_eq!(p("take#2/f_##.png", 5), Path::new("take#2/f_05.png"));
        assert_eq!(p("take#2/f.png", 5), Path::new("take#2/f_0005.png"));
    }

    /// `f_##_##.png` replaced only its last run: which run is the number
    /// is not guessed any more.
    #[test]
    fn two_places_for_the_number_are_refused() {
        for name in ["f_##_##.png", "#f#.png", "f_{frame}_##.png"] {
            let e = FramePattern::new(Path::new(name)).unwrap_err().to_string();
            assert!(
                e.contains("the frame number goes in one place"),
                "{name}: {e}"
            );
        }
    }

    #[test]
    fn ranges_are_bounded() {
        let e = "0..4294967295"
            .parse::<FrameRange>()
            .unwrap_err()
            .to_string();
        assert!(e.contains("4294967296 frames; at most 1000000"), "{e}");
        let r: FrameRange = format!("5..{}", 5 + MAX_FRAMES - 1).parse().unwrap();
        assert_eq!(r.count(), MAX_FRAMES);
        assert!(format!("5..{}", 5 + MAX_FRAMES)
            .parse::<FrameRange>()
            .is_err());
    }
}
