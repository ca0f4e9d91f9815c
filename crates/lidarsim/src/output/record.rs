//! What a sink receives: the points of a block, each an echo with its
//! attributes, and the block's recorded waveforms.

use crate::geometry::DVec3;

/// The object ID the point files write for an echo no object contributed
/// to (receiver noise): [`PointRecord::object_code`].
pub const NO_OBJECT: u32 = u32::MAX;

/// What returned an echo: its code is written to the LAS user data byte
/// and the other formats' `component` field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Component {
    /// A surface: ground, a roof, a wall, a mesh, terrain (and receiver
    /// noise, which has no source).
    #[default]
    Surface = 0,
    /// Foliage in a tree crown.
    Foliage = 1,
    /// A tree trunk.
    Trunk = 2,
}

impl Component {
    /// The code the point files write.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The component of a code the point files write.
    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Surface),
            1 => Some(Self::Foliage),
            2 => Some(Self::Trunk),
            _ => None,
        }
    }
}

/// One point of the output cloud: an echo with its attributes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointRecord {
    /// Georeferenced position, world metres (specification Eq. 1).
    pub position_m: DVec3,
    /// Time of emission of the pulse, s, in the output time base.
    pub gps_time_s: f64,
    /// LAS intensity (energy amplitude × gain, clipped).
    pub intensity: u16,
    /// Energy amplitude of the echo, amplitude units.
    pub amplitude: f64,
    /// Echo width (FWHM), ns.
    pub echo_width_ns: f64,
    /// Measured range from the sensor, m.
    pub range_m: f64,
    /// Unit direction of the beam axis used to georeference the point
    /// (`position = origin + beam_dir × range`), world frame.
    pub beam_dir: DVec3,
    /// Georeferencing error: computed position minus where the central ray
    /// really met the echo range, m (zero without navigation errors).
    pub error_m: DVec3,
    /// 1-based number of this echo within its pulse.
    pub return_number: u8,
    /// Number of echoes of the pulse.
    pub number_of_returns: u8,
    /// LAS scan direction flag: true when the beam moves left to right.
    pub scan_direction_positive: bool,
    /// LAS edge-of-flight-line flag: last pulse before the mirror turns.
    pub edge_of_flight_line: bool,
    /// Scan angle, degrees, LAS convention (0 = vertical, positive to the
    /// right of the flight direction), attitude included.
    pub scan_angle_deg: f64,
    /// ASPRS classification code.
    pub classification: u8,
    /// Flight line number (LAS point source ID).
    pub point_source_id: u16,
    /// Pulse index within the flight line.
    pub pulse_index: u64,
    /// Scene object that returned most of the echo's energy; `None` for
    /// receiver noise (the files write [`NO_OBJECT`]).
    pub object_id: Option<u32>,
    /// Angle between the beam axis and the normal of the surface that
    /// returned most of the echo's energy (the normal where the first sub-ray
    /// of that surface in the echo met it), degrees, 0–90; `None` for
    /// echoes from foliage (no surface) and receiver noise (files write NaN).
    pub incidence_angle_deg: Option<f64>,
    /// Two-way travel time of the echo's peak since emission, ps (the
    /// detector's fitted position on the receiver's time axis, before any
    /// range noise).
    pub echo_time_ps: f64,
    /// What returned it (its code is written to the LAS user data byte).
    pub component: Component,
    /// The scanner channel that fired the pulse, 0–3 (LAS scanner
    /// channel).
    pub channel: u8,
}

impl PointRecord {
    /// The object ID as the point files write it ([`NO_OBJECT`] for none).
    pub fn object_code(&self) -> u32 {
        self.object_id.unwrap_or(NO_OBJECT)
    }
}

/// The recorded waveforms of the pulses of one block that have echoes, in
/// pulse order: what a full-waveform digitiser keeps of each pulse (the
/// window of the record that holds signal).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WaveformBlock {
    /// One entry per pulse with at least one echo.
    pub packets: Vec<WaveformPacket>,
    /// The samples of all packets, one after the other, amplitude units.
    pub samples: Vec<f32>,
}

/// Where one pulse's waveform lies in [`WaveformBlock::samples`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveformPacket {
    /// Flight line number + 1 (the points' `point_source_id`).
    pub point_source_id: u16,
    /// Pulse index within the flight line (the points' `pulse_index`).
    pub pulse_index: u64,
    /// Two-way travel time of the first sample since emission, ps.
    pub first_sample_ps: f64,
    /// Index of the first sample in [`WaveformBlock::samples`].
    pub start: usize,
    /// Number of samples.
    pub len: usize,
}

impl WaveformBlock {
    /// Empties the block, keeping its allocations.
    pub fn clear(&mut self) {
        self.packets.clear();
        self.samples.clear();
    }

    /// The samples of a packet.
    pub fn samples_of(&self, packet: &WaveformPacket) -> &[f32] {
        &self.samples[packet.start..packet.start + packet.len]
    }
}
