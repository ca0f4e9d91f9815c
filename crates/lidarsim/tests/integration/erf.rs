//! The error function, for expectations of the energy a Gaussian beam puts
//! on a rectangle: shared by the integration tests and, through a `#[path]`
//! module, by the beam's unit tests (`src/sensor/beam/tests.rs`).

/// The error function, to 1.2 × 10⁻⁷ (Numerical Recipes, `erfcc`).
pub fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * (-x * x + poly).exp();
    if x >= 0.0 { 1.0 - erfc } else { erfc - 1.0 }
}
