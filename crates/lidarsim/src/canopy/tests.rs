//! Tests of the marches through crowns.
use super::*;
use crate::accel::{Bvh, RayCaster};
use crate::geometry::{DVec3, Ray};
use crate::rng::{Purpose, Stream};
use crate::scene::{
    FoliageSettings, Material, Primitive, Scene, Shape, Species, SurfaceClass, TreeSpec,
};

fn one_tree(uniform: Option<f64>, k: f64) -> Bvh {
    tree_of(uniform, k, &FoliageSettings::default())
}

/// [`one_tree`] with its crown filled as `foliage` says.
fn tree_of(uniform: Option<f64>, k: f64, settings: &FoliageSettings) -> Bvh {
    let mut scene = Scene::default();
    let foliage = scene.add_material(Material {
        name: "f".into(),
        reflectance: 0.4,
        incidence_exponent: 0.0,
        spectrum: Vec::new(),
    });
    let obj = scene.add_object("tree");
    let mut spec = TreeSpec::new(DVec3::ZERO, Species::Spruce, 0.3, 20.0, 6.0);
    spec.uniform_density = uniform;
    spec.extinction_per_m = Some(k);
    scene.primitives.push(Primitive {
        shape: Shape::Crown(Box::new(spec.crown(settings))),
        material: foliage,
        class: SurfaceClass::Vegetation,
        object: obj,
    });
    Bvh::build(scene)
}

/// Fraction of vertical rays at horizontal offset `x` that cross the
/// crown, and the analytic `exp(−k ∫ρ ds)`.
fn crossing(bvh: &Bvh, x: f64, k: f64, rho: f64) -> (f64, f64) {
    let ray = Ray::new(DVec3::new(x, 0.0, 100.0), -DVec3::Z);
    let mut spans = Vec::new();
    bvh.trace(&ray, 0.0, 1e9, &mut spans);
    let Shape::Crown(c) = &bvh.scene().primitives[0].shape else {
        unreachable!()
    };
    // Path length inside the envelope along the vertical line, by fine
    // sampling of the envelope test.
    let inside = (0..200_000)
        .filter(|i| c.contains(DVec3::new(x, 0.0, 6.0 + *i as f64 * 1e-4)))
        .count() as f64
        * 1e-4;
    let n = 20_000;
    let passed = (0..n)
        .filter(|&i| {
            let mut rng = Stream::new(1, 0, i, Purpose::Canopy);
            matches!(
                march(
                    bvh.scene(),
                    &ray,
                    &spans,
                    &CanopyConfig::default(),
                    &mut rng
                ),
                Fate::Passed { .. }
            )
        })
        .count() as f64
        / n as f64;
    (passed, (-k * rho * inside).exp())
}

#[test]
fn crossing_probability_is_beer_lambert() {
    for (k, rho) in [(0.3, 0.5), (0.6, 0.5), (0.6, 0.9)] {
        let bvh = one_tree(Some(rho), k);
        for x in [0.0, 0.8] {
            let (got, want) = crossing(&bvh, x, k, rho);
            assert!(
                (got - want).abs() < 0.02 + 0.05 * want,
                "k={k} ρ={rho} x={x}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn interceptions_lie_inside_the_envelope_and_depths_vary() {
    // The specification's field: foliage from the top to near the base.
    let bvh = tree_of(None, 0.9, &FoliageSettings::specification());
    let Shape::Crown(c) = &bvh.scene().primitives[0].shape else {
        unreachable!()
    };
    let ray = Ray::new(DVec3::new(0.4, 0.3, 100.0), -DVec3::Z);
    let mut spans = Vec::new();
    bvh.trace(&ray, 0.0, 1e9, &mut spans);
    let mut depths = Vec::new();
    for i in 0..2000 {
        let mut rng = Stream::new(2, 0, i, Purpose::Canopy);
        if let Fate::Intercepted {
            t,
            density,
            transmission,
            ..
        } = march(
            bvh.scene(),
            &ray,
            &spans,
            &CanopyConfig::default(),
            &mut rng,
        ) {
            let p = ray.at(t);
            assert!(c.contains(p));
            assert!((c.density_at(p) - density).abs() < 1e-12 && density > 0.0);
            assert!(transmission > 0.0 && transmission <= 1.0);
            depths.push(t);
        }
    }
    assert!(depths.len() > 1000);
    let lo = depths.iter().cloned().fold(f64::MAX, f64::min);
    let hi = depths.iter().cloned().fold(f64::MIN, f64::max);
    assert!(hi - lo > 5.0, "interceptions spread over the crown depth");
}

/// The crown of `one_tree`.
fn crown_of(bvh: &Bvh) -> &crate::scene::Crown {
    let Shape::Crown(c) = &bvh.scene().primitives[0].shape else {
        unreachable!()
    };
    c
}

#[test]
fn the_density_at_a_level_is_the_density_at_a_point() {
    // Pine, spruce and birch shapes (c = 0.6, 0.9, 0.5): the levels' table
    // of χ^c and tabulated whorl rotation against `density_at`'s powf and
    // sin_cos, at points all over the crown; both fields.
    let fields = [FoliageSettings::default(), FoliageSettings::specification()];
    for (species, foliage) in [Species::Pine, Species::Spruce, Species::Birch]
        .into_iter()
        .flat_map(|s| fields.iter().map(move |f| (s, f)))
    {
        let mut spec = TreeSpec::new(DVec3::new(3.0, -2.0, 1.0), species, 0.3, 20.0, 6.0);
        spec.seed = 17;
        let c = spec.crown(foliage);
        let mut rng = Stream::new(5, 0, 0, Purpose::Canopy);
        let (mut inside, mut worst, mut top) = (0, 0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let p = DVec3::new(
                3.0 + (rng.uniform() - 0.5) * 2.0 * c.max_radius_m(),
                -2.0 + (rng.uniform() - 0.5) * 2.0 * c.max_radius_m(),
                1.0 + 6.0 + rng.uniform() * 14.0,
            );
            let level = c.level(p.z).expect("within the crown's heights");
            let got = level.density(p.x - 3.0, p.y + 2.0);
            let want = c.density_at(p);
            // Points within 0.1 mm of the envelope may fall either side.
            let (chi, r) = ((21.0 - p.z) / 14.0, level.radius);
            let d = (p.x - 3.0).hypot(p.y + 2.0);
            if (d - r).abs() < 1e-4 || chi < 1e-3 {
                continue;
            }
            inside += usize::from(d < r);
            // Relative to the field's largest density (1 for the
            // specification's, 2 · 9/7 for the physical model's).
            worst = worst.max((got - want).abs());
            top = top.max(want);
        }
        assert!(inside > 3000, "{species:?}: {inside} points inside");
        assert!(
            worst < 1e-4 * top,
            "{species:?} {:?}: largest difference {worst} of {top}",
            foliage.model
        );
    }
}

/// The fates of `n` sub-rays from `(x, 0, 1000)` that pass 1 cm apart
/// near the ground, over `pulses` pulses, through the pulse march.
fn pulse_fates(bvh: &Bvh, x: f64, n: usize, pulses: u64) -> Vec<Fate> {
    let mut march = PulseMarch::default();
    let mut fates = Vec::new();
    let origin = DVec3::new(x, 0.0, 1000.0);
    // The one crown of the scene.
    let volumes = [0];
    for k in 0..pulses {
        march.clear();
        for i in 0..n {
            let dir = DVec3::new(0.01 * i as f64, 0.0, -1000.0).normalize();
            march.push(dir, 0.0, 1000.0);
        }
        let mut rng = Stream::new(3, 0, k, Purpose::Canopy);
        march.run(
            bvh.scene(),
            origin,
            &volumes,
            &CanopyConfig::default(),
            &mut rng,
        );
        fates.extend_from_slice(march.fates());
    }
    fates
}

#[test]
fn the_pulse_march_crosses_with_the_beer_lambert_probability() {
    for (k, rho) in [(0.3, 0.5), (0.6, 0.9)] {
        let bvh = one_tree(Some(rho), k);
        for x in [0.0, 0.8] {
            let (_, want) = crossing(&bvh, x, k, rho);
            let fates = pulse_fates(&bvh, x, 8, 2500);
            let passed = fates
                .iter()
                .filter(|f| matches!(f, Fate::Passed { .. }))
                .count() as f64
                / fates.len() as f64;
            assert!(
                (passed - want).abs() < 0.02 + 0.05 * want,
                "k={k} ρ={rho} x={x}: {passed} vs {want}"
            );
        }
    }
}

#[test]
fn pulse_march_interceptions_lie_in_the_crown() {
    let bvh = one_tree(None, 0.9);
    let c = crown_of(&bvh);
    let fates = pulse_fates(&bvh, 0.4, 8, 500);
    let mut depths = Vec::new();
    for f in &fates {
        if let Fate::Intercepted {
            t,
            density,
            transmission,
            ..
        } = *f
        {
            let z = 1000.0 - t * 1000.0 / 1000.0f64.hypot(0.01 * 4.0);
            let (z_base, z_top) = c.z_range();
            // Within the crown's heights, and the density there positive
            // (the cell, at most one step of 0.3 m, may reach past it).
            assert!(z <= z_top && z >= z_base - 0.3, "z {z}");
            assert!(density > 0.0 && transmission == 1.0);
            depths.push(t);
        }
    }
    assert!(depths.len() > 2000);
    let lo = depths.iter().cloned().fold(f64::MAX, f64::min);
    let hi = depths.iter().cloned().fold(f64::MIN, f64::max);
    assert!(hi - lo > 5.0, "interceptions spread over the crown depth");
}

/// A single crown of the physical model, crossed by vertical sub-rays at
/// distance `d` from its stem, over many crowns (the tree's seed lays its
/// clump cells out anew): the share that passes is the gap probability
/// of a clumped medium (Nilson 1971's binomial clumping, one foliated cell
/// per vertical cell of the path, each holding foliage with probability
/// `f` at `1/f` times the shell's density), computed here from the
/// envelope and the shell alone: `Π_m (1 − f + f·exp(−k·s_m/f))` with
/// `s_m` the path's plant-area depth in cell `m` (`∫ ρ_shell dz`, fine
/// sampling). Both marches give it, within three binomial deviations.
#[test]
fn a_clumped_crowns_gap_probability_is_binomial_beer_lambert() {
    let settings = FoliageSettings::default();
    let (f, cell, k) = (settings.clump_fraction, settings.clump_m, 0.25);
    for d in [0.35f64, 1.05, 1.85] {
        let (mut passed, mut rays) = (0usize, 0usize);
        let (mut pulse_passed, mut pulse_rays) = (0usize, 0usize);
        let mut want = 0.0;
        let trees = 300u64;
        for seed in 0..trees {
            let mut scene = Scene::default();
            let material = scene.add_material(Material {
                name: "f".into(),
                reflectance: 0.4,
                incidence_exponent: 0.0,
                spectrum: Vec::new(),
            });
            let object = scene.add_object("tree");
            let mut spec = TreeSpec::new(DVec3::ZERO, Species::Pine, 0.3, 20.0, 6.0);
            spec.extinction_per_m = Some(k);
            spec.seed = seed;
            let crown = spec.crown(&settings);
            if seed == 0 {
                want = binomial_gap(&crown, d, (f, cell, k, settings.shell_m));
            }
            scene.primitives.push(Primitive {
                shape: Shape::Crown(Box::new(crown)),
                material,
                class: SurfaceClass::Vegetation,
                object,
            });
            let bvh = Bvh::build(scene);
            let ray = Ray::new(DVec3::new(d, 0.0, 100.0), -DVec3::Z);
            let mut spans = Vec::new();
            bvh.trace(&ray, 0.0, 1e9, &mut spans);
            for i in 0..20 {
                let mut rng = Stream::new(seed, 0, i, Purpose::Canopy);
                let fate = march(
                    bvh.scene(),
                    &ray,
                    &spans,
                    &CanopyConfig::default(),
                    &mut rng,
                );
                passed += usize::from(matches!(fate, Fate::Passed { .. }));
                rays += 1;
            }
            // The pulse march's 8 sub-rays, 7 cm across: in one cell.
            for fate in pulse_fates(&bvh, d, 8, 2) {
                pulse_passed += usize::from(matches!(fate, Fate::Passed { .. }));
                pulse_rays += 1;
            }
        }
        // Rays of one crown share its cells: the deviation is that of the
        // crowns' mean, at most sqrt(p(1 − p) / trees).
        let sd = (want * (1.0 - want) / trees as f64).sqrt();
        for (got, march) in [
            (passed as f64 / rays as f64, "sub-ray"),
            (pulse_passed as f64 / pulse_rays as f64, "pulse"),
        ] {
            assert!(
                (got - want).abs() < 3.0 * sd + 0.01,
                "d = {d} m, {march} march: {got} passed, the clumped medium lets {want} \
                 through (sd {sd})"
            );
        }
        assert!(want > 0.05 && want < 0.95, "d = {d} m: {want}, a weak test");
    }
}

/// `Π_m (1 − f + f·exp(−k·s_m/f))` along the vertical line at distance `d`
/// from `crown`'s stem (see the test above), from the envelope, the
/// shell's depth and the level's ring normalisation.
fn binomial_gap(
    crown: &crate::scene::Crown,
    d: f64,
    (f, cell, k, shell): (f64, f64, f64, f64),
) -> f64 {
    let (z_base, z_top) = crown.z_range();
    let steps = 100_000;
    let dz = (z_top - z_base) / steps as f64;
    let mut depth_in_cell = std::collections::BTreeMap::<i64, f64>::new();
    for i in 0..steps {
        let z = z_top - (i as f64 + 0.5) * dz;
        let chi = (z_top - z) / (z_top - z_base);
        let r = crown.radius_at_chi(chi);
        // In the envelope and within `shell` of it.
        if d > r || r - d > shell {
            continue;
        }
        let core = if r > shell { 1.0 - shell / r } else { 0.0 };
        let ring = 1.0 / (1.0 - core * core);
        *depth_in_cell
            .entry(((z_top - z) / cell).floor() as i64)
            .or_default() += ring * dz;
    }
    depth_in_cell
        .values()
        .map(|s| 1.0 - f + f * (-k * s / f).exp())
        .product()
}
