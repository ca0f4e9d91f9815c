//! Each kernel against its scalar twin, to the bit, on random inputs; and
//! the scalar twins against plain definitions.

use super::*;
use crate::rng::{Purpose, Stream};

fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = Stream::new(seed, 0, 0, Purpose::Test);
    move || s.uniform() - 0.5
}

#[test]
fn direction_bounds_match_the_scalar_twin_and_the_definition() {
    let mut u = uniform(1);
    for case in 0..5000 {
        let n = 1 + case % 40;
        let mut dirs: Vec<DVec3> = (0..n)
            .map(|_| DVec3::new(u(), u(), u()).normalize())
            .collect();
        // Directions in a coordinate plane: signed zeros.
        if case % 3 == 0 {
            for (i, d) in dirs.iter_mut().enumerate() {
                d[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
            }
        }
        let bits = |b: DirectionBounds| {
            let sum = [b.sum.x, b.sum.y, b.sum.z];
            [b.lo, b.hi, sum].map(|v| v.map(f64::to_bits))
        };
        let want = scalar::direction_bounds(&dirs);
        assert_eq!(bits(direction_bounds(&dirs)), bits(want), "case {case}");
        let sum = dirs.iter().fold(DVec3::ZERO, |s, d| s + *d);
        assert_eq!(want.sum, sum);
        for a in 0..3 {
            assert_eq!(
                want.lo[a],
                dirs.iter().map(|d| d[a]).fold(f64::INFINITY, f64::min)
            );
            assert_eq!(
                want.hi[a],
                dirs.iter().map(|d| d[a]).fold(f64::NEG_INFINITY, f64::max)
            );
        }
    }
}

#[test]
fn bundle_box_tests_match_the_scalar_twin() {
    let mut u = uniform(2);
    let signs = [Sign::Positive, Sign::Negative, Sign::Straddles];
    let (mut entered, mut missed) = (0, 0);
    for case in 0..20_000 {
        let sign = [0, 1, 2].map(|a| signs[(case / (1 + a * 3)) % 3]);
        let o = [0, 1, 2].map(|_| (u() * 100.0) as f32);
        // Reciprocal bounds of the sign each axis says.
        let recip = |s: Sign, u: &mut dyn FnMut() -> f64| {
            let (lo, hi) = match s {
                Sign::Positive => (0.1 + u().abs(), 0.6 + u().abs()),
                Sign::Negative => (-0.6 - u().abs(), -0.1 - u().abs()),
                Sign::Straddles => (-0.1 - u().abs(), 0.1 + u().abs()),
            };
            ((1.0 / lo) as f32, (1.0 / hi) as f32)
        };
        let mut inv_lo = [0.0f32; 3];
        let mut inv_hi = [0.0f32; 3];
        for a in 0..3 {
            (inv_lo[a], inv_hi[a]) = recip(sign[a], &mut u);
        }
        let b = BundleSlabs::new(o, sign, inv_lo, inv_hi);
        let mut boxes = [[f32::INFINITY; LANES]; 6];
        for r in &mut boxes[3..] {
            *r = [f32::NEG_INFINITY; LANES];
        }
        // The last slot of every third case stays empty.
        for slot in 0..LANES - usize::from(case % 3 == 0) {
            for a in 0..3 {
                let c = o[a] as f64 + u() * 300.0;
                let half = (u() + 0.5) * [0.0, 1.0, 30.0][(case + slot) % 3];
                boxes[a][slot] = (c - half) as f32;
                boxes[3 + a][slot] = (c + half) as f32;
            }
        }
        let t_max = [1e3f32, 60.0][case % 2];
        let (mask, t) = b.enters(&boxes, t_max);
        let (want_mask, want_t) = scalar::enters(&b, &boxes, t_max);
        assert_eq!(mask, want_mask, "case {case}");
        assert_eq!(t.map(f32::to_bits), want_t.map(f32::to_bits), "case {case}");
        entered += mask.count_ones();
        missed += LANES as u32 - mask.count_ones();
        if case % 3 == 0 {
            assert_eq!(mask >> (LANES - 1), 0, "an empty slot is entered");
        }
    }
    assert!(entered > 10_000 && missed > 10_000, "{entered} {missed}");
}

#[test]
fn triangle_edge_planes_match_the_scalar_twin() {
    let mut u = uniform(3);
    let mut kinds = [0usize; 3];
    for case in 0..20_000 {
        let origin = DVec3::new(u(), u(), u()) * 1000.0 + DVec3::Z * 500.0;
        let axis = DVec3::new(u() * 0.8, u() * 0.8, -1.0).normalize();
        let spread = [0.0, 1e-4, 0.02, 0.3][case % 4];
        let cone = EdgeCone::new(origin, axis, spread);
        let at = origin + axis * 500.0;
        let size = [0.05, 1.0, 30.0][case % 3];
        let corners = [0, 1, 2].map(|_| at + DVec3::new(u(), u(), u() * 0.2) * size);
        let got = cone.edges(corners);
        let want = scalar::edges(&cone, corners);
        assert_eq!(
            (got.certain, got.positive),
            (want.certain, want.positive),
            "case {case}"
        );
        let bits = |n: [DVec3; 3]| n.map(|e| [e.x, e.y, e.z].map(f64::to_bits));
        assert_eq!(bits(got.normals()), bits(want.normals()), "case {case}");
        let certain = want.certain.count_ones() as usize;
        kinds[certain.min(2)] += 1;
    }
    // No edge certain, one, two or three: each well represented.
    assert!(kinds.iter().all(|&n| n > 300), "{kinds:?}");
}

/// Waveform-like samples: positive, with plateaus and repeated values.
fn samples(u: &mut impl FnMut() -> f64, n: usize) -> Vec<f64> {
    let mut s = Vec::with_capacity(n);
    for i in 0..n {
        let v = if i > 0 && u() < -0.3 {
            s[i - 1]
        } else {
            ((u() + 0.5) * 8.0).round() / 8.0
        };
        s.push(v);
    }
    s
}

#[test]
fn maxima_match_the_scalar_twin_and_the_definition() {
    let mut u = uniform(4);
    for case in 0..5000 {
        let s = samples(&mut u, case % 50);
        // Thresholds between the levels and on them.
        let thr = [(u() + 0.5) * 0.5, 0.5, 0.0][case % 3];
        let mut got = Vec::new();
        for_each_maximum(&s, thr, |i| got.push(i));
        let mut twin = Vec::new();
        scalar::for_each_maximum(&s, thr, |i| twin.push(i));
        let want: Vec<usize> = (1..s.len().saturating_sub(1))
            .filter(|&i| s[i] > thr && s[i] > s[i - 1] && s[i] >= s[i + 1])
            .collect();
        assert_eq!(got, want, "case {case}");
        assert_eq!(twin, want, "case {case}");
    }
}

#[test]
fn lowest_before_higher_matches_the_scalar_twin_and_the_definition() {
    let mut u = uniform(5);
    for case in 0..5000 {
        let run = samples(&mut u, case % 40);
        let h = (u() + 0.5) * 1.1;
        for side in [Side::Before, Side::After] {
            let got = lowest_before_higher(&run, h, side);
            let twin = scalar::lowest_before_higher(&run, h, side);
            // From the maximum outwards until a higher sample.
            let order: Vec<f64> = match side {
                Side::Before => run.iter().rev().copied().collect(),
                Side::After => run.clone(),
            };
            let stop = order.iter().position(|&v| v > h);
            let met = &order[..stop.unwrap_or(order.len())];
            let want = (met.iter().fold(h, |m, &v| m.min(v)), stop.is_none());
            assert_eq!(got, want, "case {case} {side:?}");
            assert_eq!(twin, want, "case {case} {side:?}");
        }
    }
}

#[test]
fn accumulated_depths_match_the_scalar_twin_and_the_definition() {
    let mut u = uniform(6);
    for case in 0..5000 {
        let depth: [f32; LANES] = std::array::from_fn(|_| (u() + 0.5) as f32 * 3.0);
        let level: [f32; LANES] = std::array::from_fn(|_| (u() + 0.5) as f32 * 0.5);
        // Thresholds around the sums, some on them exactly, and the
        // padding's +∞.
        let threshold: [f32; LANES] = std::array::from_fn(|l| match (case + l) % 4 {
            0 => depth[l] + level[l],
            1 => f32::INFINITY,
            _ => depth[l] + (u() + 0.5) as f32,
        });
        let (mut got, mut twin) = (depth, depth);
        let mask = accumulate_depths(&mut got, &level, &threshold);
        assert_eq!(
            mask,
            scalar::accumulate_depths(&mut twin, &level, &threshold)
        );
        assert_eq!(got.map(f32::to_bits), twin.map(f32::to_bits), "case {case}");
        for l in 0..LANES {
            let reached = depth[l] + level[l] >= threshold[l];
            assert_eq!(mask >> l & 1 == 1, reached, "case {case} lane {l}");
            let want = if reached {
                depth[l]
            } else {
                depth[l] + level[l]
            };
            assert_eq!(got[l].to_bits(), want.to_bits(), "case {case} lane {l}");
        }
    }
}
