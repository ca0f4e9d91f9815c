//! GNSS/IMU errors: from the trajectory flown to the trajectory measured.
//!
//! Specification, "Trajectory": "In practice, instrumentation called
//! GNSS/IMU is used to get the geometry over time. This instrumentation has
//! limited accuracy ... We can simulate it with our simulator." Rays are
//! cast from the *true* pose; echoes are georeferenced with the *observed*
//! one, exactly as a real processing chain does, so navigation errors
//! become point-cloud errors.
//!
//! Error model, per flight line, added to the true trajectory:
//! * GNSS position: a constant bias, a first-order Gauss–Markov process
//!   (stationary standard deviation `random_walk_m`, correlation time
//!   `correlation_time_s`) and white noise `sigma_m` per pulse;
//! * IMU attitude (roll, pitch, yaw): bias, Gauss–Markov process and white
//!   noise in the same way;
//! * boresight: a constant rotation between the IMU and the scanner that the
//!   processing does not know (the true beam leaves the misaligned scanner);
//! * lever arm: the error of the IMU-to-scanner offset (body frame): the true
//!   scanner sits there, the processing assumes it at the IMU;
//! * ranging noise `sigma_m` and mirror encoder noise on every echo.
//!
//! The Gauss–Markov processes are generated once per line at
//! [`EPOCH_RATE_HZ`] by the exact discretisation
//! `x[n+1] = φ x[n] + σ √(1 − φ²) w[n]`, `φ = exp(−Δt/τ)` (Gelb, "Applied
//! Optimal Estimation", 1974, §3.8), and interpolated linearly, so the
//! observed pose stays a pure function of time. White noise comes from the
//! counter-based stream of each pulse.

use super::Pose;
use crate::geometry::{Attitude, DMat3, DVec3, rot_x, rot_y, rot_z};
use crate::rng::{Purpose, Stream};

/// Rate at which the correlated errors are generated, Hz.
pub const EPOCH_RATE_HZ: f64 = 100.0;

/// Errors of one sensor group (three axes).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ErrorModel {
    /// Constant bias per axis (m for GNSS x/y/z, rad for IMU roll/pitch/yaw).
    pub bias: [f64; 3],
    /// Standard deviation of the white noise per axis.
    pub sigma: [f64; 3],
    /// Stationary standard deviation of the Gauss–Markov process per axis.
    pub random_walk: [f64; 3],
    /// Correlation time of the Gauss–Markov process, s.
    pub correlation_time_s: f64,
}

impl ErrorModel {
    /// True when the model adds nothing.
    pub fn is_zero(&self) -> bool {
        self.bias == [0.0; 3] && self.sigma == [0.0; 3] && self.random_walk == [0.0; 3]
    }
}

/// All navigation and measurement errors of a survey.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NavigationErrors {
    /// GNSS position errors, m.
    pub gnss: ErrorModel,
    /// IMU attitude errors (roll, pitch, yaw), rad.
    pub imu: ErrorModel,
    /// Boresight misalignment (roll, pitch, yaw of the scanner relative to
    /// the IMU), rad.
    pub boresight_rad: [f64; 3],
    /// Lever-arm error in the body frame (x right, y forward, z up), m.
    pub lever_arm_m: DVec3,
    /// Ranging noise, m.
    pub range_sigma_m: f64,
    /// Mirror angle encoder noise, rad.
    pub encoder_sigma_rad: f64,
}

impl NavigationErrors {
    /// True when nothing perturbs the georeferencing.
    pub fn is_zero(&self) -> bool {
        self.gnss.is_zero()
            && self.imu.is_zero()
            && self.boresight_rad == [0.0; 3]
            && self.lever_arm_m == DVec3::ZERO
            && self.range_sigma_m == 0.0
            && self.encoder_sigma_rad == 0.0
    }

    /// The boresight rotation (scanner relative to the body), in the
    /// body's level-north frame: `Rz(yaw)·Rx(pitch)·Ry(roll)` like the
    /// attitude.
    pub fn boresight(&self) -> DMat3 {
        let [r, p, y] = self.boresight_rad;
        rot_z(y) * rot_x(p) * rot_y(r)
    }
}

/// Gauss–Markov error series of one flight line.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LineErrors {
    /// Per epoch: GNSS x, y, z (m) and IMU roll, pitch, yaw (rad).
    epochs: Vec<[f64; 6]>,
}

impl LineErrors {
    /// Generates the correlated errors of flight line `line` lasting
    /// `duration_s` from the stream `(seed, line, 0, Navigation)`.
    pub fn new(errors: &NavigationErrors, seed: u64, line: u32, duration_s: f64) -> Self {
        let models = [&errors.gnss, &errors.imu];
        if models.iter().all(|m| m.random_walk == [0.0; 3]) {
            return Self::default();
        }
        let n = (duration_s * EPOCH_RATE_HZ).ceil() as usize + 2;
        let dt = 1.0 / EPOCH_RATE_HZ;
        let mut rng = Stream::new(seed, line, 0, Purpose::Navigation);
        let phi: Vec<f64> = models
            .iter()
            .map(|m| {
                if m.correlation_time_s > 0.0 {
                    (-dt / m.correlation_time_s).exp()
                } else {
                    0.0
                }
            })
            .collect();
        let mut state = [0.0; 6];
        for (k, s) in state.iter_mut().enumerate() {
            // Start in the stationary distribution.
            *s = models[k / 3].random_walk[k % 3] * rng.normal();
        }
        let mut epochs = Vec::with_capacity(n);
        for _ in 0..n {
            epochs.push(state);
            for (k, s) in state.iter_mut().enumerate() {
                let (m, f) = (models[k / 3], phi[k / 3]);
                *s = f * *s + m.random_walk[k % 3] * (1.0 - f * f).sqrt() * rng.normal();
            }
        }
        Self { epochs }
    }

    /// The correlated errors at `t_s` since the line start (zero when none).
    pub fn at(&self, t_s: f64) -> [f64; 6] {
        if self.epochs.is_empty() {
            return [0.0; 6];
        }
        let x = (t_s * EPOCH_RATE_HZ).max(0.0);
        let i = (x.floor() as usize).min(self.epochs.len() - 2);
        let f = (x - i as f64).min(1.0);
        let (a, b) = (self.epochs[i], self.epochs[i + 1]);
        std::array::from_fn(|k| a[k] + f * (b[k] - a[k]))
    }
}

/// The observed pose at `t_s` since the line start: true pose plus biases
/// and correlated errors, plus white noise when `white` is given (drawn
/// from it: three GNSS values, then three IMU values).
pub fn observed_pose(
    truth: &Pose,
    errors: &NavigationErrors,
    line_errors: &LineErrors,
    t_s: f64,
    white: Option<&mut Stream>,
) -> Pose {
    let c = line_errors.at(t_s);
    let (g, i) = (&errors.gnss, &errors.imu);
    let mut e = [
        g.bias[0] + c[0],
        g.bias[1] + c[1],
        g.bias[2] + c[2],
        i.bias[0] + c[3],
        i.bias[1] + c[4],
        i.bias[2] + c[5],
    ];
    if let Some(rng) = white {
        let sig = [g.sigma, i.sigma].concat();
        for (k, v) in e.iter_mut().enumerate() {
            if sig[k] > 0.0 {
                *v += sig[k] * rng.normal();
            }
        }
    }
    Pose {
        position_m: truth.position_m + DVec3::new(e[0], e[1], e[2]),
        attitude: Attitude {
            roll_rad: truth.attitude.roll_rad + e[3],
            pitch_rad: truth.attitude.pitch_rad + e[4],
            yaw_rad: truth.attitude.yaw_rad + e[5],
        },
    }
}

/// Named sets of navigation errors.
pub fn preset(name: &str) -> Option<(ErrorModel, ErrorModel)> {
    let deg = |d: f64| d.to_radians();
    match name {
        // A survey-grade GNSS/IMU after post-processing: about 2 cm / 3 cm
        // position noise and 0.005° roll and pitch, 0.008° heading — the
        // class of the post-processed accuracies Applanix publishes for its
        // POS AV 610 (0.0025°/0.005°) and Trimble/Applanix AP60 systems.
        "survey-grade" => Some((
            ErrorModel {
                bias: [0.0; 3],
                sigma: [0.01, 0.01, 0.015],
                random_walk: [0.02, 0.02, 0.03],
                correlation_time_s: 300.0,
            },
            ErrorModel {
                bias: [0.0; 3],
                sigma: [deg(0.002), deg(0.002), deg(0.004)],
                random_walk: [deg(0.005), deg(0.005), deg(0.008)],
                correlation_time_s: 60.0,
            },
        )),
        // A consumer-grade UAV without RTK: single-frequency GNSS (metre
        // level, slowly wandering) and a MEMS IMU (tenths of a degree).
        "uav" => Some((
            ErrorModel {
                bias: [0.0; 3],
                sigma: [0.05, 0.05, 0.1],
                random_walk: [1.0, 1.0, 2.0],
                correlation_time_s: 60.0,
            },
            ErrorModel {
                bias: [0.0; 3],
                sigma: [deg(0.02), deg(0.02), deg(0.05)],
                random_walk: [deg(0.1), deg(0.1), deg(0.3)],
                correlation_time_s: 30.0,
            },
        )),
        _ => None,
    }
}

/// Names accepted by [`preset`].
pub const PRESETS: [&str; 2] = ["survey-grade", "uav"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_markov_statistics() {
        let errors = NavigationErrors {
            gnss: ErrorModel {
                random_walk: [0.5, 0.5, 0.5],
                correlation_time_s: 2.0,
                ..Default::default()
            },
            ..Default::default()
        };
        // Stationary σ and the lag-τ autocorrelation e^{−1}, pooled over
        // many lines (each one an independent realisation).
        let (mut sum2, mut lag, mut n) = (0.0, 0.0, 0.0);
        for line in 0..200 {
            let e = LineErrors::new(&errors, 5, line, 20.0);
            for k in 0..1800 {
                let t = k as f64 * 0.01;
                let (a, b) = (e.at(t)[0], e.at(t + 2.0)[0]);
                sum2 += a * a;
                lag += a * b;
                n += 1.0;
            }
        }
        let var = sum2 / n;
        assert!((var.sqrt() - 0.5).abs() < 0.03, "{}", var.sqrt());
        let rho = lag / n / var;
        assert!((rho - (-1.0f64).exp()).abs() < 0.05, "{rho}");
    }

    #[test]
    fn biases_add_and_presets_exist() {
        let truth = Pose {
            position_m: DVec3::new(1.0, 2.0, 3.0),
            attitude: Attitude::default(),
        };
        let errors = NavigationErrors {
            gnss: ErrorModel {
                bias: [0.1, -0.2, 0.3],
                ..Default::default()
            },
            imu: ErrorModel {
                bias: [0.01, 0.0, -0.02],
                ..Default::default()
            },
            ..Default::default()
        };
        let o = observed_pose(&truth, &errors, &LineErrors::default(), 3.0, None);
        assert!((o.position_m - DVec3::new(1.1, 1.8, 3.3)).length() < 1e-12);
        assert_eq!(o.attitude.roll_rad, 0.01);
        assert_eq!(o.attitude.yaw_rad, -0.02);
        for p in PRESETS {
            assert!(preset(p).is_some());
        }
    }
}
