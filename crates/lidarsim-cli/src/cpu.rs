//! The processor check at start-up: [`lidarsim::kernels::cpu`] answers,
//! this explains.

pub use lidarsim::kernels::cpu::missing;

/// Explains on standard error that the processor lacks `feature`, with
/// plain writes of byte strings (no formatting machinery).
#[inline(never)]
pub fn refuse(feature: &str) {
    use std::io::Write;
    let mut e = std::io::stderr().lock();
    let _ = e.write_all(b"error: this lidarsim was built for x86-64-v3 processors (AVX2, 2013 and later), and this processor lacks '");
    let _ = e.write_all(feature.as_bytes());
    let _ = e.write_all(
        b"'.\nRebuild it for this machine with RUSTFLAGS=\"-C target-cpu=native\" cargo build --release\n",
    );
}
