//! Flags that were removed, refused with what replaced them: a command that
//! used one fails with a line that says what to do instead, not clap's
//! "unexpected argument".

use std::ffi::OsString;

/// A removed flag and what to use instead.
#[derive(Clone, Copy, Debug)]
pub struct Removed {
    pub flag: &'static str,
    /// Why it went and what replaced it, after "FLAG was removed: ".
    pub instead: &'static str,
}

const EXACT: &str =
    "the default method computes every view exactly and measured faster; for speed use --fast";

/// Every removed flag of `render` (and `preview`, `bench-stereo`).
pub const REMOVED: &[Removed] = &[
    Removed {
        flag: "--strip",
        instead: EXACT,
    },
    Removed {
        flag: "--eye-runs",
        instead: EXACT,
    },
    Removed {
        flag: "--shadow-fans",
        instead: EXACT,
    },
    Removed {
        flag: "--views-per-batch",
        instead: "the views are traced in batches of 4 neighbours, which measured fastest",
    },
    Removed {
        flag: "--interpolate-views",
        instead: "it measured slower than the exact views; for speed use --fast (its error set by --tolerance)",
    },
    Removed {
        flag: "--synthesize-views",
        instead: "for speed use --fast (its error set by --tolerance)",
    },
    Removed {
        flag: "--synthesis-spacing",
        instead: "for speed use --fast (its error set by --tolerance)",
    },
    Removed {
        flag: "--key-spacing",
        instead: "key views measured slower; for speed use --fast (its error set by --tolerance)",
    },
    Removed {
        flag: "--share-shading",
        instead: "the shared shading is part of --fast: use --fast",
    },
    Removed {
        flag: "--epipolar-views",
        instead: "the epipolar rows are part of --fast: use --fast",
    },
    Removed {
        flag: "--share-tolerance",
        instead: "use --fast --tolerance E",
    },
];

/// The removed flag among `args` (the command line after the program's
/// name), as one line: `--strip was removed: ...`. Arguments after `--` are
/// not flags.
pub fn refuse_removed(args: &[OsString]) -> Result<(), String> {
    for arg in args {
        let Some(arg) = arg.to_str() else { continue };
        if arg == "--" {
            break;
        }
        let flag = arg.split_once('=').map_or(arg, |(f, _)| f);
        if let Some(r) = REMOVED.iter().find(|r| r.flag == flag) {
            return Err(format!("{} was removed: {}", r.flag, r.instead));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(list: &[&str]) -> Vec<OsString> {
        list.iter().map(OsString::from).collect()
    }

    #[test]
    fn a_removed_flag_is_named_with_what_replaced_it() {
        let err = refuse_removed(&args(&["render", "a.nff", "-o", "b.png", "--strip"]));
        assert_eq!(
            err,
            Err(format!("--strip was removed: {EXACT}")),
            "the flag and the method that replaced it"
        );
        let err = refuse_removed(&args(&["render", "--share-tolerance=0.02"]));
        assert!(err.is_err_and(|e| e.contains("--tolerance")));
        assert!(
            refuse_removed(&args(&["render", "a.nff", "--fast", "--tolerance", "0.02"])).is_ok()
        );
        // A file named like a flag, after `--`, is a file.
        assert!(refuse_removed(&args(&["render", "-o", "x.png", "--", "--strip"])).is_ok());
    }
}
