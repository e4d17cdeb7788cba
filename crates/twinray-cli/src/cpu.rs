//! The processor check. The workspace builds for x86-64-v3 (AVX2, FMA,
//! BMI1/2; `.cargo/config.toml`, docs/decisions.md), so on an older x86-64
//! processor the first such instruction would kill the process with SIGILL.
//! `main` asks here first and refuses in one line instead.
//!
//! Only the features this build was compiled with are required (`cfg!`): a
//! build with other flags (`RUSTFLAGS`) checks what it uses, or nothing.

/// The instruction-set extensions this build may use, by the names the
/// compiler and the processor's manuals give them, each with whether the
/// running processor has it.
///
/// Asked of the processor itself (CPUID): `is_x86_feature_detected!` answers
/// `true` at compile time for a feature the build enables, which is every
/// one of these, and so could not tell.
#[cfg(target_arch = "x86_64")]
fn features() -> Vec<(&'static str, bool)> {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    let bit = |register: u32, n: u32| register >> n & 1 == 1;
    let basic = __cpuid(0).eax;
    let one = __cpuid(1);
    let seven = if basic >= 7 {
        __cpuid_count(7, 0)
    } else {
        __cpuid(0)
    };
    let seven_ebx = if basic >= 7 { seven.ebx } else { 0 };
    let extended = if __cpuid(0x8000_0000).eax >= 0x8000_0001 {
        __cpuid(0x8000_0001).ecx
    } else {
        0
    };
    // AVX needs the operating system to save its registers (OSXSAVE).
    let avx = bit(one.ecx, 28) && bit(one.ecx, 27);
    macro_rules! used {
        ($($f:tt => $has:expr),* $(,)?) => {
            vec![$(($f, !cfg!(target_feature = $f) || $has)),*]
        };
    }
    used!(
        "sse3" => bit(one.ecx, 0),
        "ssse3" => bit(one.ecx, 9),
        "fma" => bit(one.ecx, 12) && avx,
        "sse4.1" => bit(one.ecx, 19),
        "sse4.2" => bit(one.ecx, 20),
        "movbe" => bit(one.ecx, 22),
        "popcnt" => bit(one.ecx, 23),
        "avx" => avx,
        "f16c" => bit(one.ecx, 29) && avx,
        "bmi1" => bit(seven_ebx, 3),
        "avx2" => bit(seven_ebx, 5) && avx,
        "bmi2" => bit(seven_ebx, 8),
        "lzcnt" => bit(extended, 5),
    )
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

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_bit_read_is_one_this_processor_has() {
        // The tests run here, so this processor has every feature they were
        // built with: a wrong register or bit would read 0 for one of them.
        let asked = features();
        assert_eq!(asked.len(), 13);
        for (name, has) in asked {
            assert!(has, "{name}");
        }
    }

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
