//! The processor check. The workspace builds for x86-64-v3 (AVX2, FMA,
//! BMI1/2; `.cargo/config.toml`, docs/decisions.md), so on an older x86-64
//! processor the first such instruction would kill the process with SIGILL.
//! `main` calls [`require`] first, which refuses in one line instead.
//!
//! The processor is asked itself (CPUID): `is_x86_feature_detected!` answers
//! `true` at compile time for a feature the build enables. And the check is
//! plain integer code that writes fixed bytes: anything more (a `Vec`, a
//! `format!`) let the compiler move memory with AVX instructions before the
//! answer was in (seen under `qemu-x86_64 -cpu Nehalem`).
//!
//! Only the features this build was compiled with are required (`cfg!`): a
//! build with other flags (`RUSTFLAGS`) checks what it uses, or nothing.

/// The extensions this build may use, by the names the compiler gives them,
/// in the order of the bits of [`missing`].
const NAMES: [&str; 13] = [
    "sse3", "ssse3", "fma", "sse4.1", "sse4.2", "movbe", "popcnt", "avx", "f16c", "bmi1", "avx2",
    "bmi2", "lzcnt",
];

/// The features this build uses that the running processor lacks, as bits
/// in the order of [`NAMES`]; 0 when it has them all.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn missing() -> u32 {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    let bit = |register: u32, n: u32| register >> n & 1 == 1;
    let basic = __cpuid(0).eax;
    let one = __cpuid(1);
    let seven = if basic >= 7 {
        __cpuid_count(7, 0).ebx
    } else {
        0
    };
    let extended = if __cpuid(0x8000_0000).eax >= 0x8000_0001 {
        __cpuid(0x8000_0001).ecx
    } else {
        0
    };
    // AVX needs the operating system to save its registers (OSXSAVE).
    let avx = bit(one.ecx, 28) && bit(one.ecx, 27);
    let has = [
        (cfg!(target_feature = "sse3"), bit(one.ecx, 0)),
        (cfg!(target_feature = "ssse3"), bit(one.ecx, 9)),
        (cfg!(target_feature = "fma"), bit(one.ecx, 12) && avx),
        (cfg!(target_feature = "sse4.1"), bit(one.ecx, 19)),
        (cfg!(target_feature = "sse4.2"), bit(one.ecx, 20)),
        (cfg!(target_feature = "movbe"), bit(one.ecx, 22)),
        (cfg!(target_feature = "popcnt"), bit(one.ecx, 23)),
        (cfg!(target_feature = "avx"), avx),
        (cfg!(target_feature = "f16c"), bit(one.ecx, 29) && avx),
        (cfg!(target_feature = "bmi1"), bit(seven, 3)),
        (cfg!(target_feature = "avx2"), bit(seven, 5) && avx),
        (cfg!(target_feature = "bmi2"), bit(seven, 8)),
        (cfg!(target_feature = "lzcnt"), bit(extended, 5)),
    ];
    let mut mask = 0;
    let mut i = 0;
    while i < has.len() {
        let (used, present) = has[i];
        if used && !present {
            mask |= 1 << i;
        }
        i += 1;
    }
    mask
}

#[cfg(not(target_arch = "x86_64"))]
fn missing() -> u32 {
    0
}

/// Returns if this processor runs this build; otherwise says which features
/// it lacks, on stderr in one line, and exits with status 1.
#[inline(never)]
pub fn require() {
    let mask = missing();
    if mask != 0 {
        refuse(mask);
    }
}

#[cold]
#[inline(never)]
fn refuse(mask: u32) -> ! {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    // Fixed pieces only (see the module's note); a failed write changes nothing.
    let _ = err.write_all(
        b"twinray: this build needs an x86-64-v3 processor (AVX2 and FMA: Intel Haswell, \
          AMD Excavator or later); this one lacks",
    );
    let mut i = 0;
    while i < NAMES.len() {
        if mask >> i & 1 == 1 {
            let _ = err.write_all(b" ");
            let _ = err.write_all(NAMES[i].as_bytes());
        }
        i += 1;
    }
    let _ = err.write_all(
        b". Build for it with RUSTFLAGS=\"-C target-cpu=native\" cargo build --release\n",
    );
    std::process::exit(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_processor_runs_this_build() {
        // The tests run here, so this processor has every feature they were
        // built with: a wrong register or bit would read as missing.
        assert_eq!(missing(), 0);
    }
}
