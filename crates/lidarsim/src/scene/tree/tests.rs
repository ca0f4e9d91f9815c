use super::*;

fn pine() -> TreeSpec {
    TreeSpec::new(DVec3::new(10.0, 20.0, 5.0), Species::Pine, 0.25, 18.0, 8.0)
}

#[test]
fn envelope_follows_equation_4() {
    let crown = pine().crown(&FoliageSettings::specification());
    let (zb, zt) = crown.z_range();
    assert_eq!((zb, zt), (13.0, 23.0));
    for chi in [0.0, 0.25, 0.5, 0.9, 1.0] {
        let r = crown.radius_at_chi(chi);
        let want = crown.a + crown.b * chi.powf(crown.c);
        assert!((r - want).abs() < 1e-12);
        let z = zt - chi * (zt - zb);
        // Just inside and just outside the envelope at that height.
        assert!(crown.contains(DVec3::new(10.0 + r - 1e-6, 20.0, z)));
        assert!(!crown.contains(DVec3::new(10.0, 20.0 + r + 1e-6, z)));
    }
    assert!((crown.max_radius_m() - Species::Pine.crown_radius_m(0.25)).abs() < 1e-12);
}

/// Above the depth it gives, every level's envelope is narrower than
/// the radius asked for, and that depth lies just short of where the
/// envelope reaches it (every shape: the pine's table, the spruce's,
/// the birch's square root).
#[test]
fn a_crown_is_narrower_than_a_radius_above_the_depth_it_gives() {
    for species in [Species::Pine, Species::Spruce, Species::Birch] {
        let spec = TreeSpec::new(DVec3::ZERO, species, 0.3, 20.0, 8.0);
        let profile = spec.crown(&FoliageSettings::default()).profile();
        let (zb, zt) = profile.crown().z_range();
        let top = profile.envelope(zt).expect("the top").radius;
        assert_eq!(profile.depth_narrower_than(top), None);
        for step in 1..=40 {
            let radius = top + step as f64 * 0.1;
            let chi = profile.depth_narrower_than(radius).expect("below the top");
            for k in 0..=1000 {
                let z = zt - chi * (zt - zb) * k as f64 / 1000.0;
                let r = profile.envelope(z).expect("inside").radius;
                assert!(r < radius, "{species:?}: {r} at {z} for {radius}");
            }
            // Just short of the root (or the whole crown).
            let deeper = (chi + 1e-4).min(1.0);
            let r = profile
                .envelope(zt - deeper * (zt - zb))
                .expect("inside")
                .radius;
            assert!(
                chi == 1.0 || r >= radius - 1e-3,
                "{species:?}: {r} < {radius}"
            );
        }
    }
}

#[test]
fn density_factors() {
    let crown = pine().crown(&FoliageSettings::specification());
    let (zb, zt) = crown.z_range();
    // On the stem axis rc = 0 and φ = 0.
    let at = |chi: f64, rc: f64, phi: f64| {
        let z = zt - chi * (zt - zb);
        let r = crown.radius_at_chi(chi) * rc;
        crown.density_at(DVec3::new(10.0 + r * phi.cos(), 20.0 + r * phi.sin(), z))
    };
    // Six branches per whorl: density repeats every 60°.
    for phi in [0.1, 0.7, 2.0] {
        let d1 = at(0.3, 0.4, phi);
        let d2 = at(0.3, 0.4, phi + std::f64::consts::PI / 3.0);
        assert!((d1 - d2).abs() < 1e-9);
    }
    // Height factor: flat to χ = 0.5, then linear to 0 at χ = 1 —
    // compare the best branch direction at each height.
    let best = |chi: f64| {
        (0..3600)
            .map(|i| at(chi, 0.5, i as f64 * 0.1f64.to_radians()))
            .fold(0.0, f64::max)
    };
    assert!((best(0.2) - 0.5).abs() < 1e-3);
    assert!((best(0.45) - 0.5).abs() < 1e-3);
    assert!((best(0.75) - 0.25).abs() < 1e-3);
    // Radius factor 1 − rc.
    let b = |rc: f64| {
        (0..3600)
            .map(|i| at(0.3, rc, i as f64 * 0.1f64.to_radians()))
            .fold(0.0, f64::max)
    };
    assert!((b(0.001) - 0.999).abs() < 1e-3 && (b(0.8) - 0.2).abs() < 1e-3);
    // The whorl pattern rotates between whorls 0.3 m apart.
    let z1 = zt - 1.0;
    let z2 = z1 - 0.3;
    let p = |z: f64| crown.density_at(DVec3::new(10.5, 20.2, z));
    assert!((p(z1) - p(z2)).abs() > 1e-6);
}

#[test]
fn trunk_cone_radius_and_intersection() {
    let t = pine().trunk();
    assert!((t.radius_at(5.0 + 1.3) - 0.125).abs() < 1e-12);
    assert!(t.radius_at(5.0) > 0.125);
    assert_eq!(t.radius_at(23.0), 0.0);
    // A horizontal ray at breast height hits the stem at dbh/2.
    let ray = Ray::new(DVec3::new(0.0, 20.0, 6.3), DVec3::X);
    let (d, n) = t.intersect(&ray, 0.0, 100.0).unwrap();
    assert!((d - (10.0 - 0.125)).abs() < 1e-9);
    assert!(n.x < -0.99);
    // A vertical ray beside the stem misses it; one onto the axis hits
    // the apex region.
    let miss = Ray::new(DVec3::new(10.3, 20.0, 50.0), -DVec3::Z);
    assert!(t.intersect(&miss, 0.0, 100.0).is_none());
    let down = Ray::new(DVec3::new(10.05, 20.0, 50.0), -DVec3::Z);
    let (d, _) = t.intersect(&down, 0.0, 100.0).unwrap();
    let z = 50.0 - d;
    assert!((t.radius_at(z) - 0.05).abs() < 1e-9);
}

#[test]
fn crown_span_is_the_cylinder_interval() {
    let crown = pine().crown(&FoliageSettings::specification());
    let r = crown.max_radius_m();
    let ray = Ray::new(DVec3::new(10.0, 20.0, 100.0), -DVec3::Z);
    let (a, b) = crown.span(&ray, 0.0, 1e9).unwrap();
    assert!((a - 77.0).abs() < 1e-9 && (b - 87.0).abs() < 1e-9);
    let side = Ray::new(DVec3::new(-50.0, 20.0, 15.0), DVec3::X);
    let (a, b) = crown.span(&side, 0.0, 1e9).unwrap();
    assert!((a - (60.0 - r)).abs() < 1e-9 && (b - (60.0 + r)).abs() < 1e-9);
    let off = Ray::new(DVec3::new(10.0 + r + 0.1, 20.0, 100.0), -DVec3::Z);
    assert!(crown.span(&off, 0.0, 1e9).is_none());
}
