//! The processor check. The workspace builds for x86-64-v3 (AVX2, FMA,
//! BMI1/2; `.cargo/config.toml`, docs/decisions.md), so on an older x86-64
//! processor the first such instruction would kill the process with SIGILL.
//! `main` calls [`require`] first, which refuses in one line instead.
//!
//! Everything here is compiled for x86-64-v3 too, so it is written to leave
//! the compiler nothing to vectorise (seen under `qemu-x86_64 -cpu Nehalem`:
//! a `Vec` of answers, and then bits combined in a mask, became AVX moves
//! that ran before the answer was in): one feature at a time, each asked of
//! the processor by a call the compiler cannot see through (CPUID:
//! `is_x86_feature_detected!` answers `true` at compile time for a feature
//! the build enables), and the refusal written with `write(2)`.
//!
//! Only the features this build was compiled with are required (`cfg!`): a
//! build with other flags (`RUSTFLAGS`) checks what it uses, or nothing.

/// Returns if this processor runs this build; otherwise names the first
/// feature it lacks, on stderr in one line, and exits with status 1.
#[inline(never)]
pub fn require() {
    #[cfg(target_arch = "x86_64")]
    {
        // (name, CPUID leaf, register: 1 ebx, 2 ecx, bit)
        macro_rules! need {
            ($($f:tt: $leaf:expr, $reg:expr, $bit:expr;)*) => {$(
                if cfg!(target_feature = $f) && !has($leaf, $reg, $bit) {
                    refuse($f);
                }
            )*};
        }
        // AVX's registers need the operating system's support (OSXSAVE).
        if cfg!(target_feature = "avx") && !has(1, 2, 27) {
            refuse("avx (the operating system does not save its registers)");
        }
        need! {
            "avx": 1, 2, 28;
            "avx2": 7, 1, 5;
            "fma": 1, 2, 12;
            "bmi1": 7, 1, 3;
            "bmi2": 7, 1, 8;
            "lzcnt": 0x8000_0001, 2, 5;
            "movbe": 1, 2, 22;
            "f16c": 1, 2, 29;
            "popcnt": 1, 2, 23;
            "sse4.2": 1, 2, 20;
            "sse4.1": 1, 2, 19;
            "ssse3": 1, 2, 9;
            "sse3": 1, 2, 0;
        }
    }
}

/// Whether bit `bit` of register `register` (1: ebx, 2: ecx) of CPUID leaf
/// `leaf` (subleaf 0) is set; false where the processor has no such leaf.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn has(leaf: u32, register: u32, bit: u32) -> bool {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    let highest = __cpuid(leaf & 0x8000_0000).eax;
    if highest < leaf {
        return false;
    }
    let r = __cpuid_count(leaf, 0);
    let value = if register == 1 { r.ebx } else { r.ecx };
    bit_set(value, bit)
}

/// Whether bit `bit` of `value` is set, by the `bt` instruction: a shift
/// written in Rust became BMI2's `shrx` in this build (seen under
/// `qemu-x86_64 -cpu Nehalem`), the very instruction being asked about.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn bit_set(value: u32, bit: u32) -> bool {
    let set: u8;
    // SAFETY: `bt` and `setc` read two registers and write one byte
    // register; no memory, no stack, and both are in every x86-64.
    unsafe {
        std::arch::asm!(
            "bt {v:e}, {b:e}",
            "setc {s}",
            v = in(reg) value,
            b = in(reg) bit,
            s = out(reg_byte) set,
            options(pure, nomem, nostack),
        );
    }
    set != 0
}

const BEFORE: &[u8] = b"twinray: this build needs an x86-64-v3 processor (AVX2 and FMA: Intel \
    Haswell, AMD Excavator or later); this one lacks ";
const AFTER: &[u8] =
    b". Build for it with RUSTFLAGS=\"-C target-cpu=native\" cargo build --release\n";

/// The refusal: one line naming `feature`, and exit status 1.
#[cold]
#[inline(never)]
fn refuse(feature: &'static str) -> ! {
    #[cfg(unix)]
    {
        for part in [BEFORE, feature.as_bytes(), AFTER] {
            // SAFETY: write(2) reads `part.len()` bytes of a live static
            // slice; a short or failed write only shortens the message.
            unsafe {
                libc::write(2, part.as_ptr().cast(), part.len());
            }
        }
        // SAFETY: _exit ends the process at once; nothing of ours is
        // pending (this runs before anything else in main).
        unsafe { libc::_exit(1) }
    }
    #[cfg(not(unix))]
    {
        eprintln!(
            "{}{feature}{}",
            String::from_utf8_lossy(BEFORE),
            String::from_utf8_lossy(AFTER).trim_end()
        );
        std::process::exit(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_feature_read_is_one_this_processor_has() {
        // The tests run here, so this processor has the features they were
        // built with: a wrong leaf, register or bit would read as missing.
        for (leaf, register, bit) in [
            (1, 2, 27),
            (1, 2, 28),
            (7, 1, 5),
            (1, 2, 12),
            (7, 1, 3),
            (7, 1, 8),
            (0x8000_0001, 2, 5),
            (1, 2, 22),
            (1, 2, 29),
            (1, 2, 23),
        ] {
            assert!(has(leaf, register, bit), "{leaf:#x} {register} {bit}");
        }
        // A leaf past the highest is absent, not garbage.
        assert!(!has(0x7fff_ffff, 1, 0));
        require();
    }

    #[test]
    fn the_refusal_is_one_line() {
        let line = [BEFORE, b"avx2", AFTER].concat();
        let text = String::from_utf8(line).unwrap();
        assert_eq!(text.matches('\n').count(), 1, "{text}");
        assert!(
            text.ends_with('\n') && text.contains("lacks avx2."),
            "{text}"
        );
    }
}
