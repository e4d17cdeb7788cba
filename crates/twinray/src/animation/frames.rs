//! Frame ranges (`--frames A..B`) and the output name of each frame.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::{Error, Result};

/// Frames `first` to `last`, both included.
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
        Ok(FrameRange { first, last })
    }
}

/// How the frames' files are named.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    pattern: String,
}

impl FramePattern {
    /// `out`'s name with a frame number: a run of `#` (`out_####.png`: the
    /// number zero-padded to the run's width), `{frame}` or `{frame:0N}`;
    /// a name with none gets `_####` before its extension. Returns the
    /// pattern and whether the number was added.
    pub fn new(out: &Path) -> (FramePattern, bool) {
        let name = out.to_string_lossy().into_owned();
        let file = out
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        if file.contains('#') || file.contains("{frame") {
            return (FramePattern { pattern: name }, false);
        }
        let stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tagged = match out.extension() {
            Some(ext) => format!("{stem}_####.{}", ext.to_string_lossy()),
            None => format!("{stem}_####"),
        };
        (
            FramePattern {
                pattern: out.with_file_name(tagged).to_string_lossy().into_owned(),
            },
            true,
        )
    }

    /// The path of `frame`: every `{frame}`/`{frame:0N}` and the last run of
    /// `#` replaced.
    pub fn path(&self, frame: u32) -> PathBuf {
        let mut s = self.pattern.clone();
        while let Some(at) = s.find("{frame") {
            let Some(end) = s[at..].find('}').map(|e| at + e) else {
                break;
            };
            let width: usize = s[at + "{frame".len()..end]
                .strip_prefix(":0")
                .or_else(|| s[at + "{frame".len()..end].strip_prefix(':'))
                .and_then(|w| w.parse().ok())
                .unwrap_or(0);
            s.replace_range(at..=end, &format!("{frame:0width$}"));
        }
        if let Some(end) = s.rfind('#') {
            let start = s[..end].rfind(|c| c != '#').map_or(0, |i| i + 1);
            let width = end + 1 - start;
            s.replace_range(start..=end, &format!("{frame:0width$}"));
        }
        PathBuf::from(s)
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
        let p = |s: &str, f| FramePattern::new(Path::new(s)).0.path(f);
        assert_eq!(p("shots/out_####.png", 7), Path::new("shots/out_0007.png"));
        assert_eq!(p("out_##.png", 123), Path::new("out_123.png"));
        assert_eq!(p("f{frame}.exr", 42), Path::new("f42.exr"));
        assert_eq!(p("f{frame:05}.exr", 42), Path::new("f00042.exr"));
        assert_eq!(p("shots/f.png", 3), Path::new("shots/f_0003.png"));
        assert!(FramePattern::new(Path::new("f.png")).1);
        assert!(!FramePattern::new(Path::new("f_#.png")).1);
    }
}
