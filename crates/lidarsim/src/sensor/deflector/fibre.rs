//! The fibre array (TopoSys Falcon, Trimble Harrier): a line of `M` glass
//! fibres fanned across the track behind the telescope. A small nodding
//! mirror sweeps the laser across the fibre ends, `f` sweeps per second,
//! so each sweep fires the whole fan in the same order — each fibre once
//! when `PRF = M·f`, as the instruments run, or several pulses in a row
//! at a higher PRF — and the fibres' directions never change: fibre `j`
//! looks at
//! `θ_j = θ (1 − 2j/(M − 1))` across the track (positive to the left: the
//! sweep runs from left to right).

/// A fibre-array scanner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fibre {
    /// Fibres in the fan, `M` (at least 2).
    pub fibres: u32,
    /// Half of the fan's angle, `θ`, rad.
    pub scan_half_angle_rad: f64,
    /// Sweeps of the fan per second, Hz.
    pub sweep_rate_hz: f64,
}

impl Fibre {
    /// Fibre slots since time 0 at `t_s` (the fan fires `M` per sweep),
    /// nudged by a millionth of a slot so that pulses at exact multiples of
    /// the slot time keep their own slot despite rounding.
    fn slot_at(&self, t_s: f64) -> i64 {
        (self.sweep_rate_hz * t_s * f64::from(self.fibres) + 1e-6).floor() as i64
    }

    /// Index of the sweep at `t_s`.
    pub fn sweep_at(&self, t_s: f64) -> i64 {
        self.slot_at(t_s).div_euclid(i64::from(self.fibres))
    }

    /// The fibre the pulse at `t_s` leaves through.
    pub fn fibre_at(&self, t_s: f64) -> u32 {
        self.slot_at(t_s).rem_euclid(i64::from(self.fibres)) as u32
    }

    /// Direction of fibre `j` across the track, rad, positive to the left.
    pub fn fibre_angle(&self, j: u32) -> f64 {
        let m = f64::from(self.fibres.max(2) - 1);
        self.scan_half_angle_rad * (1.0 - 2.0 * f64::from(j) / m)
    }

    /// Deflection at `t_s`, rad.
    pub fn angle_at(&self, t_s: f64) -> f64 {
        self.fibre_angle(self.fibre_at(t_s))
    }

    /// Angle between neighbouring fibres, rad.
    pub fn step_rad(&self) -> f64 {
        2.0 * self.scan_half_angle_rad / f64::from(self.fibres.max(2) - 1)
    }
}
