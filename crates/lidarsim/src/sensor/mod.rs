//! The sensor: where it is and where it points. A flight line's pose as a
//! function of time ([`platform`]), what the GNSS/IMU makes of it
//! ([`navigation`]), what deflects the beam ([`deflector`]), the channels of a
//! multi-channel head ([`channel`]) and the beam's sub-rays ([`beam`]).

pub mod beam;
pub mod channel;
pub mod deflector;
pub mod navigation;
pub mod platform;

use crate::geometry::{Attitude, DVec3};

/// Position and attitude of the scanner at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Scanner position, world metres.
    pub position_m: DVec3,
    /// Attitude.
    pub attitude: Attitude,
}
