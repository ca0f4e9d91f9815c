//! The processor against the instruction set the build was compiled for.
//!
//! The workspace builds for x86-64-v3 (`.cargo/config.toml`). On an older
//! processor the first AVX2 or BMI instruction would kill the program with
//! "illegal instruction"; a program asks [`missing`] first and explains.
//! Only the standard library (shipped built for baseline x86-64) and this
//! module's integer code run before the answer.

/// Features of x86-64-v3 and below that a build may have been compiled with.
#[cfg(target_arch = "x86_64")]
const LEVEL_FEATURES: [(&str, bool); 10] = [
    ("sse4.2", cfg!(target_feature = "sse4.2")),
    ("popcnt", cfg!(target_feature = "popcnt")),
    ("avx", cfg!(target_feature = "avx")),
    ("avx2", cfg!(target_feature = "avx2")),
    ("bmi1", cfg!(target_feature = "bmi1")),
    ("bmi2", cfg!(target_feature = "bmi2")),
    ("fma", cfg!(target_feature = "fma")),
    ("lzcnt", cfg!(target_feature = "lzcnt")),
    ("movbe", cfg!(target_feature = "movbe")),
    ("f16c", cfg!(target_feature = "f16c")),
];

/// Whether this processor has the x86 feature `name` (one of
/// [`LEVEL_FEATURES`]), read from CPUID itself: `is_x86_feature_detected!`
/// answers "yes" at compile time for features the build enables, which is
/// the very question here. Leaf 1 ECX, leaf 7 EBX and leaf 0x8000_0001 ECX
/// (Intel SDM vol. 2A, CPUID); AVX also needs the operating system to save
/// the YMM registers (OSXSAVE, and XCR0 bits 1 and 2).
#[cfg(target_arch = "x86_64")]
fn detected(name: &str) -> bool {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    #[allow(unused_unsafe)]
    // SAFETY: CPUID exists on every x86-64 processor; leaves above the
    // highest supported one are not asked.
    let (max, l1, l7, ext) = unsafe {
        let max = __cpuid(0).eax;
        let max_ext = __cpuid(0x8000_0000).eax;
        let l1 = __cpuid(1).ecx;
        let l7 = if max >= 7 { __cpuid_count(7, 0).ebx } else { 0 };
        let ext = if max_ext >= 0x8000_0001 {
            __cpuid(0x8000_0001).ecx
        } else {
            0
        };
        (max, l1, l7, ext)
    };
    let bit = |reg: u32, b: u32| max >= 1 && reg >> b & 1 == 1;
    let ymm_saved = || {
        if !bit(l1, 27) {
            return false;
        }
        // SAFETY: OSXSAVE (leaf 1 ECX bit 27) says XGETBV is available.
        let xcr0 = unsafe { xgetbv0() };
        xcr0 & 0b110 == 0b110
    };
    match name {
        "sse4.2" => bit(l1, 20),
        "popcnt" => bit(l1, 23),
        "fma" => bit(l1, 12) && ymm_saved(),
        "movbe" => bit(l1, 22),
        "avx" => bit(l1, 28) && ymm_saved(),
        "f16c" => bit(l1, 29) && ymm_saved(),
        "avx2" => bit(l7, 5) && bit(l1, 28) && ymm_saved(),
        "bmi1" => bit(l7, 3),
        "bmi2" => bit(l7, 8),
        "lzcnt" => bit(ext, 5),
        _ => false,
    }
}

/// XCR0, the register of state components the operating system saves.
///
/// # Safety
/// The processor must report OSXSAVE.
#[cfg(target_arch = "x86_64")]
unsafe fn xgetbv0() -> u64 {
    let (lo, hi): (u32, u32);
    // SAFETY: the caller checked OSXSAVE; XGETBV with ECX = 0 reads XCR0
    // and touches nothing else.
    unsafe {
        std::arch::asm!("xgetbv", in("ecx") 0u32, out("eax") lo, out("edx") hi,
            options(nomem, nostack, preserves_flags));
    }
    u64::from(hi) << 32 | u64::from(lo)
}

/// The first of `compiled` (name, whether the build uses it) that the build
/// uses and `has` says the processor lacks.
pub fn first_missing<'a>(
    compiled: &[(&'a str, bool)],
    has: impl Fn(&str) -> bool,
) -> Option<&'a str> {
    compiled
        .iter()
        .find(|&&(name, used)| used && !has(name))
        .map(|&(name, _)| name)
}

/// The first processor feature this build relies on that the processor
/// running it lacks.
#[inline(never)]
pub fn missing() -> Option<&'static str> {
    #[cfg(target_arch = "x86_64")]
    {
        first_missing(&LEVEL_FEATURES, detected)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_the_first_used_feature_the_processor_lacks() {
        let compiled = [
            ("avx", true),
            ("avx2", true),
            ("fma", false),
            ("bmi2", true),
        ];
        assert_eq!(first_missing(&compiled, |_| true), None);
        assert_eq!(first_missing(&compiled, |f| f != "avx2"), Some("avx2"));
        // A feature the build does not use is not asked for.
        assert_eq!(first_missing(&compiled, |f| f != "fma"), None);
        assert_eq!(first_missing(&compiled, |f| f == "avx"), Some("avx2"));
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn every_listed_feature_is_one_the_detector_knows() {
        // `detected` answers false for names it does not know; each listed
        // feature the build uses must be known and present here, or the
        // tests could not be running.
        for (name, used) in LEVEL_FEATURES {
            if used {
                assert!(detected(name), "{name}");
            }
        }
    }
}
