//! The processor check. The workspace builds for x86-64-v3 (AVX2, FMA,
//! BMI1/2; `.cargo/config.toml`, docs/decisions.md), so on an older x86-64
//! processor the first such instruction would kill the process with SIGILL.
//! `main` asks here first and refuses in one line instead.
//!
//! Only the features this build was compiled with are required (`cfg!`): a
//! build with other flags (`RUSTFLAGS`) checks what it uses, or nothing.

/// The instruction-set extensions this build may use, by the names
/// `is_x86_feature_detected!` and the processor's manuals give them, each
/// with whether the running processor has it.
#[cfg(target_arch = "x86_64")]
fn features() -> Vec<(&'static str, bool)> {
    macro_rules! used {
        ($($f:tt),*) => {
            vec![$((
                $f,
                !cfg!(target_feature = $f) || std::arch::is_x86_feature_detected!($f),
            )),*]
        };
    }
    used!("sse3", "ssse3", "sse4.1", "sse4.2", "popcnt", "avx", "avx2", "fma", "bmi1", "bmi2", "lzcnt", "movbe", "f16c")
}

#[cfg(not(target_arch = "x86_64"))]
fn features() -> Vec<(&'static str, bool)> {
    Vec::new()
}

/// The one-line refusal for a processor that lacks `missing`, if it does.
fn refusal(missing: &[&str]) -> Option<String> {
    (!missing.is_empty()).then(|| {
        format!(
            "this build needs an x86-64-v3 processor (AVX2 and FMA: Intel Haswell, AMD \
             Excavator or later); this one lacks {}. Build for it with \
             RUSTFLAGS=\"-C target-cpu=native\" cargo build --release",
            missing.join(", ")
        )
    })
}

/// `Err` with the message when this processor cannot run this build.
///
/// Kept out of line and small, so that nothing compiled for the newer
/// instructions runs before it answers.
#[inline(never)]
pub fn check() -> Result<(), String> {
    let missing: Vec<&str> = features()
        .into_iter()
        .filter(|&(_, has)| !has)
        .map(|(name, _)| name)
        .collect();
    refusal(&missing).map_or(Ok(()), Err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_processor_runs_this_build() {
        // The tests themselves run, so every feature they were built with
        // is there: the check must agree.
        assert_eq!(check(), Ok(()));
    }

    #[test]
    fn a_missing_feature_is_named_in_one_line() {
        assert_eq!(refusal(&[]), None);
        let line = refusal(&["avx2", "fma"]).unwrap();
        assert!(!line.contains('\n'), "{line}");
        assert!(line.contains("lacks avx2, fma"), "{line}");
        assert!(line.contains("target-cpu=native"), "{line}");
    }
}
