//! Counter-based random streams.
//!
//! Every random number in the simulator comes from a stream keyed by
//! `(seed, flight line, pulse index, purpose)`. A stream is a pure function of its key and of how many
//! numbers were drawn from it, so the result never depends on which thread
//! simulated a pulse or in which order pulses were scheduled.
//!
//! The generator is SplitMix64 (Steele, Lea & Flood, "Fast splittable
//! pseudorandom number generators", OOPSLA 2014) applied to a counter: the
//! `i`-th output of a stream is `mix(key + (i + 1) * GOLDEN)`, where the key
//! is itself a mix of the four key parts. SplitMix64's finaliser passes
//! BigCrush and is cheap: two multiplications per 64-bit output.

use core::convert::Infallible;
use rand::TryRng;

/// What a stream is used for; part of the stream key so that two purposes
/// of the same pulse never share numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum Purpose {
    /// Speckle factors of the sub-ray returns of one pulse.
    Speckle = 1,
    /// Receiver white noise added to the waveform of one pulse.
    ReceiverNoise = 2,
    /// Phases of the attitude sway of one flight line (pulse index 0).
    Sway = 3,
    /// The interception lottery of a pulse's sub-rays in tree crowns.
    Canopy = 4,
    /// Placement of generated forests (line = forest index).
    Forest = 5,
    /// Correlated GNSS/IMU errors of a flight line (pulse index 0).
    Navigation = 6,
    /// White navigation, ranging and encoder noise of one pulse.
    Measurement = 7,
    /// The sub-ray pattern of one pulse.
    Beam = 8,
    /// The seed of a `[[tree]]` entry without one (its whorl turn).
    TreeSeed = 9,
    /// The seed of a `[[forest]]` entry without one.
    ForestSeed = 10,
    /// The seed of a generated `[[terrain]]` without one.
    TerrainSeed = 11,
    /// The seed of a `[[tree_table]]` row without one (its whorl turn).
    TreeTableSeed = 12,
    /// Spare purpose for tests and user extensions.
    Test = 0xFFFF,
}

const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// Substreams whose salt is worked out at compile time.
const SALTED: usize = 1024;

/// [`substream_salt`] of the first [`SALTED`] substreams.
const SALTS: [u64; SALTED] = {
    let mut t = [0; SALTED];
    let mut i = 0;
    while i < SALTED {
        t[i] = mix64((i as u64 + 1).wrapping_mul(GOLDEN));
        i += 1;
    }
    t
};

/// What substream `i` mixes into its parent's key: `mix64((i + 1)·φ)`,
/// from a table for the first ones (a pulse's sub-rays and fine rays).
#[inline]
fn substream_salt(i: u64) -> u64 {
    match usize::try_from(i).ok().and_then(|k| SALTS.get(k)) {
        Some(&salt) => salt,
        None => mix64(i.wrapping_add(1).wrapping_mul(GOLDEN)),
    }
}

/// SplitMix64 finaliser: a bijective 64-bit mixing function.
#[inline]
pub const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of entry `index` of a survey table that names none, derived
/// from the survey's `seed` for `purpose` ([`Purpose::TreeSeed`],
/// [`Purpose::ForestSeed`] or [`Purpose::TerrainSeed`]; each combines the
/// two in its own fixed way, so that surveys keep their trees, stands and
/// terrains).
pub fn entry_seed(seed: u64, purpose: Purpose, index: usize) -> u64 {
    let i = index as u64;
    match purpose {
        Purpose::TreeSeed => mix64(seed ^ i.wrapping_mul(0x9E37_79B9)),
        Purpose::ForestSeed => mix64(seed.wrapping_add(0xF0_2E57 + i)),
        Purpose::TerrainSeed => mix64(seed.wrapping_add(0x7E_4A1 + i)),
        other => mix64(seed ^ (other as u64).wrapping_mul(GOLDEN) ^ i),
    }
}

/// A deterministic random stream for one `(seed, line, pulse, purpose)` key.
#[derive(Clone, Debug)]
pub struct Stream {
    key: u64,
    counter: u64,
}

impl Stream {
    /// The stream for a key. Different keys give statistically independent
    /// streams.
    pub fn new(seed: u64, line: u32, pulse: u64, purpose: Purpose) -> Self {
        let mut k = mix64(seed ^ 0x6C69_6461_7273_696D); // "lidarsim"
        k = mix64(k ^ (u64::from(line)).wrapping_mul(GOLDEN));
        k = mix64(k ^ pulse.wrapping_mul(0xD1B5_4A32_D192_ED03));
        k = mix64(k ^ (purpose as u64).wrapping_mul(0xAEF1_7502_108E_F2D9));
        Self { key: k, counter: 0 }
    }

    /// Next uniform 64-bit integer.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.counter = self.counter.wrapping_add(1);
        mix64(self.key.wrapping_add(self.counter.wrapping_mul(GOLDEN)))
    }

    /// Skips the next `n` numbers: the stream then gives what it would have
    /// after `n` calls of [`Stream::next_u64`].
    #[inline]
    pub fn skip(&mut self, n: u64) {
        self.counter = self.counter.wrapping_add(n);
    }

    /// Uniform number in `[0, 1)` with 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard exponential deviate, mean 1 (the ziggurat method of
    /// Marsaglia & Tsang, as implemented by `rand_distr::Exp1`).
    #[inline]
    pub fn exp1(&mut self) -> f64 {
        use rand_distr::Distribution;
        rand_distr::Exp1.sample(self)
    }

    /// The `i`-th of a family of streams derived from this one's key:
    /// independent of it and of each other, whatever was drawn from any
    /// (for numbers that belong to the `i`-th of many things, drawn in any
    /// order or not at all).
    #[inline]
    pub fn substream(&self, i: u64) -> Stream {
        Stream {
            key: mix64(self.key ^ substream_salt(i)),
            counter: 0,
        }
    }

    /// Standard normal deviate (the ziggurat method of Marsaglia & Tsang,
    /// as implemented by `rand_distr::StandardNormal`).
    #[inline]
    pub fn normal(&mut self) -> f64 {
        use rand_distr::Distribution;
        rand_distr::StandardNormal.sample(self)
    }
}

impl TryRng for Stream {
    type Error = Infallible;

    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((Stream::next_u64(self) >> 32) as u32)
    }

    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        Ok(Stream::next_u64(self))
    }

    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        for chunk in dst.chunks_mut(8) {
            let bytes = Stream::next_u64(self).to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skip_gives_what_drawing_would() {
        let mut drawn = Stream::new(9, 1, 2, Purpose::Forest);
        let mut skipped = drawn.clone();
        for _ in 0..5 {
            drawn.next_u64();
        }
        skipped.skip(5);
        assert_eq!(drawn.next_u64(), skipped.next_u64());
    }

    #[test]
    fn same_key_same_numbers_different_key_different_numbers() {
        let a: Vec<u64> = {
            let mut s = Stream::new(7, 0, 42, Purpose::Speckle);
            (0..8).map(|_| s.next_u64()).collect()
        };
        let b: Vec<u64> = {
            let mut s = Stream::new(7, 0, 42, Purpose::Speckle);
            (0..8).map(|_| s.next_u64()).collect()
        };
        assert_eq!(a, b);
        for other in [
            Stream::new(8, 0, 42, Purpose::Speckle),
            Stream::new(7, 1, 42, Purpose::Speckle),
            Stream::new(7, 0, 43, Purpose::Speckle),
            Stream::new(7, 0, 42, Purpose::ReceiverNoise),
        ] {
            let mut o = other;
            let c: Vec<u64> = (0..8).map(|_| o.next_u64()).collect();
            assert!(a.iter().zip(&c).all(|(x, y)| x != y));
        }
    }

    #[test]
    fn substream_salts_are_splitmix64_outputs() {
        // SplitMix64 seeded with 0 gives mix64(k·φ) as its k-th output:
        // 0xE220A8397B1DCDAF, then 0x6E789E6AA1B965F4 (Steele, Lea & Flood
        // 2014; the reference generator's published first outputs).
        assert_eq!(substream_salt(0), 0xE220_A839_7B1D_CDAF);
        assert_eq!(substream_salt(1), 0x6E78_9E6A_A1B9_65F4);
        // The table's last entry and the first one past it follow the same
        // rule.
        for i in [SALTED as u64 - 1, SALTED as u64, 1 << 40] {
            assert_eq!(substream_salt(i), mix64((i + 1).wrapping_mul(GOLDEN)));
        }
    }

    /// Substreams are streams of their own: the same for the same index,
    /// unrelated to the parent's numbers and to each other's.
    #[test]
    fn substreams_are_independent_of_the_parent_and_each_other() {
        let parent = Stream::new(3, 1, 77, Purpose::Canopy);
        let first = |mut s: Stream| (0..4).map(|_| s.next_u64()).collect::<Vec<_>>();
        assert_eq!(first(parent.substream(5)), first(parent.substream(5)));
        let mut drawn = parent.clone();
        drawn.next_u64();
        assert_eq!(first(parent.substream(5)), first(drawn.substream(5)));
        let own = first(parent.clone());
        for i in 0..50 {
            let a = first(parent.substream(i));
            assert!(a.iter().all(|x| !own.contains(x)));
            assert!(a != first(parent.substream(i + 1)));
        }
    }

    #[test]
    fn exponential_moments() {
        // Mean 1, variance 1 and P(E > 3) = e^-3 over 200 000 draws,
        // within about five standard errors.
        let n = 200_000;
        let mut s = Stream::new(1, 2, 4, Purpose::Test);
        let e: Vec<f64> = (0..n).map(|_| s.exp1()).collect();
        let mean = e.iter().sum::<f64>() / n as f64;
        let var = e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let tail = e.iter().filter(|&&x| x > 3.0).count() as f64 / n as f64;
        assert!(e.iter().all(|&x| x >= 0.0));
        assert!((mean - 1.0).abs() < 5.0 / (n as f64).sqrt());
        assert!((var - 1.0).abs() < 5.0 * (8.0 / n as f64).sqrt());
        let p = (-3.0f64).exp();
        assert!((tail - p).abs() < 5.0 * (p * (1.0 - p) / n as f64).sqrt());
    }

    #[test]
    fn uniform_and_normal_moments() {
        // Moments of 200 000 draws against the analytic values; the
        // tolerances are about five standard errors.
        let n = 200_000;
        let mut s = Stream::new(1, 2, 3, Purpose::Test);
        let u: Vec<f64> = (0..n).map(|_| s.uniform()).collect();
        let mean = u.iter().sum::<f64>() / n as f64;
        let var = u.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
        assert!((var - 1.0 / 12.0).abs() < 0.002);
        assert!(u.iter().all(|&x| (0.0..1.0).contains(&x)));

        let z: Vec<f64> = (0..n).map(|_| s.normal()).collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 5.0 / (n as f64).sqrt());
        assert!((var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt());
    }
}
