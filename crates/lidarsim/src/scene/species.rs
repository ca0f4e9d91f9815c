//! Tree species: the crown shape, allometry and reflectances of each
//! (sources in `docs/trees.md`), and the height curve that relates a
//! tree's height to its diameter at breast height.

/// Tree species with presets for crown shape and allometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Species {
    /// Scots pine, *Pinus sylvestris*.
    Pine,
    /// Norway spruce, *Picea abies*.
    Spruce,
    /// Silver birch, *Betula pendula* (in leaf).
    Birch,
}

/// Species parameters; the numbers and their sources are in
/// `docs/trees.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeciesPreset {
    /// Crown shape exponent `c` of Eq. 4.
    pub shape_c: f64,
    /// Flat-top constant `a` of Eq. 4 as a fraction of the crown radius.
    pub flat_top_fraction: f64,
    /// Crown radius allometry of forest-grown trees (Jakobsons 1970):
    /// `a + b = r0 + r1 · dbh_cm`, m.
    pub crown_r0_m: f64,
    /// Slope of the crown radius allometry, m per cm of dbh.
    pub crown_r1_m_per_cm: f64,
    /// Attenuation `μ` of the crown's plant area, 1/m, in the physical
    /// foliage model (its density averages 1 over a crown): needles or
    /// leaves and woody area, `2·STAR·NAD + G·(BAI/LAI)·NAD`.
    pub extinction_per_m: f64,
    /// Interception coefficient `k` of the specification's density field
    /// (which averages 0.16 over a crown), 1/m.
    pub specification_extinction_per_m: f64,
    /// Woody (branch) area per unit needle or leaf area, BAI/LAI: what the
    /// crown's echoes take of the bark's reflectance.
    pub woody_ratio: f64,
    /// Foliage reflectance at 1064 nm.
    pub foliage_reflectance: f64,
    /// Bark reflectance at 1064 nm.
    pub bark_reflectance: f64,
    /// Height curve of Pukkala, Lähde & Laiho (2009):
    /// `h = A / (1 + b1/d + b2/d²)`, d in cm, h in m.
    pub height_a_m: f64,
    /// `b1` of the height curve, cm.
    pub height_b1: f64,
    /// `b2` of the height curve, cm².
    pub height_b2: f64,
    /// Typical live crown ratio (crown length / height).
    pub crown_ratio: f64,
}

impl Species {
    /// All species with their names in survey files.
    pub const ALL: [(&'static str, Species); 3] = [
        ("pine", Species::Pine),
        ("spruce", Species::Spruce),
        ("birch", Species::Birch),
    ];

    /// Parses a species name (also the Latin binomial and common aliases).
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "pine" | "scots pine" | "scots_pine" | "pinus sylvestris" => Some(Species::Pine),
            "spruce" | "norway spruce" | "norway_spruce" | "picea abies" => Some(Species::Spruce),
            "birch" | "silver birch" | "silver_birch" | "betula pendula" => Some(Species::Birch),
            _ => None,
        }
    }

    /// The name used in survey files.
    pub fn name(self) -> &'static str {
        match self {
            Species::Pine => "pine",
            Species::Spruce => "spruce",
            Species::Birch => "birch",
        }
    }

    /// The preset of this species (sources in `docs/trees.md`).
    pub fn preset(self) -> SpeciesPreset {
        match self {
            Species::Pine => SpeciesPreset {
                shape_c: 0.6,
                flat_top_fraction: 0.1,
                crown_r0_m: 0.519,
                crown_r1_m_per_cm: 0.0744,
                extinction_per_m: 0.38,
                specification_extinction_per_m: 1.8,
                woody_ratio: 0.18,
                foliage_reflectance: 0.42,
                bark_reflectance: 0.35,
                height_a_m: 32.694,
                height_b1: 19.260,
                height_b2: 31.721,
                crown_ratio: 0.43,
            },
            Species::Spruce => SpeciesPreset {
                shape_c: 0.9,
                flat_top_fraction: 0.02,
                crown_r0_m: 0.761,
                crown_r1_m_per_cm: 0.060,
                extinction_per_m: 0.9,
                specification_extinction_per_m: 2.8,
                woody_ratio: 0.18,
                foliage_reflectance: 0.40,
                bark_reflectance: 0.30,
                height_a_m: 39.691,
                height_b1: 25.683,
                height_b2: 37.785,
                crown_ratio: 0.70,
            },
            Species::Birch => SpeciesPreset {
                shape_c: 0.5,
                flat_top_fraction: 0.1,
                crown_r0_m: 0.750,
                crown_r1_m_per_cm: 0.0875,
                extinction_per_m: 0.46,
                specification_extinction_per_m: 2.5,
                woody_ratio: 0.15,
                foliage_reflectance: 0.48,
                bark_reflectance: 0.50,
                height_a_m: 37.089,
                height_b1: 22.640,
                height_b2: -8.0,
                crown_ratio: 0.52,
            },
        }
    }

    /// Maximum crown radius (m) of a tree of this species with the given dbh.
    pub fn crown_radius_m(self, dbh_m: f64) -> f64 {
        let p = self.preset();
        p.crown_r0_m + p.crown_r1_m_per_cm * dbh_m * 100.0
    }

    /// Height (m) of a tree with the given dbh from the height curve.
    pub fn height_from_dbh_m(self, dbh_m: f64) -> f64 {
        height_curve(self.height_curve(), dbh_m)
    }

    /// The height curve's coefficients `(A, b1, b2)`.
    fn height_curve(self) -> (f64, f64, f64) {
        let p = self.preset();
        (p.height_a_m, p.height_b1, p.height_b2)
    }

    /// Range of dbh over which the height curve is used, m: 3–80 cm, the
    /// span of the data such curves are fitted to.
    pub const DBH_RANGE_M: (f64, f64) = (0.03, 0.8);

    /// dbh (m) of a tree of the given height: the height curve inverted by
    /// bisection over [`Species::DBH_RANGE_M`] (it increases with d there),
    /// until the interval stops changing. The curve's closed inverse (a
    /// quadratic in 1/d) decides every halving whose midpoint lies more
    /// than a relative 10⁻¹⁰ from it, where the computed curve is certain
    /// to lie on that side of the height (it is monotone but for rounding
    /// a few doubles wide), so that only the last few halvings evaluate
    /// the curve: the same answer as evaluating it at every one. Heights
    /// outside the curve's range over those diameters give `None`.
    pub fn dbh_from_height_m(self, height_m: f64) -> Option<f64> {
        let [dbh] = Self::dbh_from_heights_m([(self, height_m)]);
        dbh
    }

    /// [`Species::dbh_from_height_m`], or the nearer end of
    /// [`Species::DBH_RANGE_M`] for a height the curve does not reach
    /// there (as a `[[forest]]` tree's).
    pub fn dbh_or_nearest_m(self, height_m: f64) -> f64 {
        let (lo, hi) = Self::DBH_RANGE_M;
        self.dbh_from_height_m(height_m)
            .unwrap_or(if height_m < self.height_from_dbh_m(lo) {
                lo
            } else {
                hi
            })
    }

    /// [`Species::dbh_from_height_m`] of `N` trees at once, each its
    /// answer to the bit: their bisections are independent chains of
    /// dependent steps, and run side by side they overlap in the processor.
    pub fn dbh_from_heights_m<const N: usize>(trees: [(Species, f64); N]) -> [Option<f64>; N] {
        let (d_lo, d_hi) = Self::DBH_RANGE_M;
        let reached =
            trees.map(|(s, h)| h >= s.height_from_dbh_m(d_lo) && h <= s.height_from_dbh_m(d_hi));
        // H = a / (1 + b1/d + b2/d²) with d in cm: b2·u² + b1·u + c = 0 for
        // u = 1/d and c = 1 − a/H < 0; its positive root, in the form
        // without cancellation.
        let closed = trees.map(|(s, h)| {
            let p = s.preset();
            let c = 1.0 - p.height_a_m / h;
            let root = (p.height_b1 * p.height_b1 - 4.0 * p.height_b2 * c).sqrt();
            0.01 * (p.height_b1 + root) / (-2.0 * c)
        });
        let height = trees.map(|(_, h)| h);
        let margin = closed.map(|d| 1e-10 * d);
        let coeffs = trees.map(|(s, _)| s.height_curve());
        // Every step is the same operations on all lanes (they vectorise);
        // the curve is evaluated, for all of them, only in the steps where
        // some lane's midpoint is within the margin: the last few.
        let (mut lo, mut hi) = ([d_lo; N], [d_hi; N]);
        for _ in 0..80 {
            let mid: [f64; N] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
            let near: [bool; N] = std::array::from_fn(|k| (mid[k] - closed[k]).abs() <= margin[k]);
            let mut below: [bool; N] = std::array::from_fn(|k| mid[k] < closed[k]);
            if near.iter().any(|&n| n) {
                let curve: [f64; N] = std::array::from_fn(|k| height_curve(coeffs[k], mid[k]));
                for k in 0..N {
                    below[k] = select_bool(near[k], curve[k] < height[k], below[k]);
                }
            }
            // The side is as good as random from step to step: the new
            // ends are chosen by a mask, not a branch.
            let l: [f64; N] = std::array::from_fn(|k| select(below[k], mid[k], lo[k]));
            let h: [f64; N] = std::array::from_fn(|k| select(below[k], hi[k], mid[k]));
            // Once an interval stops changing it never changes again (the
            // step depends on it alone): the same answer as all 80 steps,
            // after about 55.
            if (l, h) == (lo, hi) {
                break;
            }
            (lo, hi) = (l, h);
        }
        std::array::from_fn(|k| reached[k].then(|| 0.5 * (lo[k] + hi[k])))
    }
}

/// Height (m) at dbh `dbh_m` of the height curve
/// `h(d) = A / (1 + b1/d + b2/d²)`, d in cm.
#[inline(always)]
fn height_curve((a, b1, b2): (f64, f64, f64), dbh_m: f64) -> f64 {
    let d = dbh_m * 100.0;
    a / (1.0 + b1 / d + b2 / (d * d))
}

/// `a` if `pick`, else `b`, without a branch.
#[inline(always)]
fn select_bool(pick: bool, a: bool, b: bool) -> bool {
    (pick & a) | (!pick & b)
}

/// `a` if `pick`, else `b`, by a bit mask: no branch for the processor to
/// mispredict.
#[inline(always)]
fn select(pick: bool, a: f64, b: f64) -> f64 {
    let mask = u64::from(pick).wrapping_neg();
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Species::dbh_from_height_m`] gives the answer of 80 halvings of
    /// the dbh range (a bisection of the height curve), at heights all
    /// over the curve's range and at its ends.
    #[test]
    fn dbh_from_height_is_the_answer_of_80_halvings() {
        let mut rng = crate::rng::Stream::new(4, 0, 0, crate::rng::Purpose::Test);
        for species in [Species::Pine, Species::Spruce, Species::Birch] {
            let (d0, d1) = Species::DBH_RANGE_M;
            let (h0, h1) = (species.height_from_dbh_m(d0), species.height_from_dbh_m(d1));
            let heights = (0..=2000)
                .map(|k| h0 + (h1 - h0) * k as f64 / 2000.0)
                .chain((0..100_000).map(|_| h0 + (h1 - h0) * rng.uniform()))
                .chain([h0.next_up(), h1.next_down()]);
            for h in heights {
                let (mut lo, mut hi) = (d0, d1);
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if species.height_from_dbh_m(mid) < h {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let want = 0.5 * (lo + hi);
                assert_eq!(species.dbh_from_height_m(h), Some(want), "{species:?} {h}");
            }
        }
    }

    /// Trees of mixed species and heights (some beyond the curve) in
    /// batches of 16 and of 3 get each the answer it gets alone.
    #[test]
    fn a_batch_of_trees_gets_the_answers_of_each_alone() {
        let mut rng = crate::rng::Stream::new(6, 0, 0, crate::rng::Purpose::Test);
        let all = [Species::Pine, Species::Spruce, Species::Birch];
        let mut tree = || {
            (
                all[(rng.uniform() * 3.0) as usize],
                1.0 + 34.0 * rng.uniform(),
            )
        };
        for _ in 0..5000 {
            let trees: [(Species, f64); 16] = std::array::from_fn(|_| tree());
            let want = trees.map(|(s, h)| s.dbh_from_height_m(h));
            assert_eq!(Species::dbh_from_heights_m(trees), want, "{trees:?}");
            let trees: [(Species, f64); 3] = std::array::from_fn(|_| tree());
            let want = trees.map(|(s, h)| s.dbh_from_height_m(h));
            assert_eq!(Species::dbh_from_heights_m(trees), want, "{trees:?}");
        }
    }

    #[test]
    fn allometry_matches_the_published_values() {
        // Jakobsons (1970) forest-grown crown radii at dbh 20 and 40 cm, and
        // Pukkala et al. (2009) heights, as tabulated in docs/trees.md.
        let cases = [
            (Species::Pine, 2.007, 3.495, 16.0, 21.8),
            (Species::Spruce, 1.961, 3.161, 16.7, 23.8),
            (Species::Birch, 2.500, 4.250, 17.6, 23.8),
        ];
        for (s, r20, r40, h20, h40) in cases {
            assert!((s.crown_radius_m(0.2) - r20).abs() < 0.01, "{s:?}");
            assert!((s.crown_radius_m(0.4) - r40).abs() < 0.01, "{s:?}");
            assert!((s.height_from_dbh_m(0.2) - h20).abs() < 0.1, "{s:?}");
            assert!((s.height_from_dbh_m(0.4) - h40).abs() < 0.1, "{s:?}");
            for d in [0.1, 0.2, 0.35] {
                let back = s.dbh_from_height_m(s.height_from_dbh_m(d)).unwrap();
                assert!((back - d).abs() < 1e-9, "{s:?} {d} {back}");
            }
        }
        assert!(Species::Pine.dbh_from_height_m(40.0).is_none());
        assert!(Species::Birch.dbh_from_height_m(2.0).is_none());
    }
}
