//! Full waveforms beside a LAS file: the `.wdp` file of digitised
//! packets (one per pulse with an echo) and the wave packet fields of
//! point format 9 that link each point to its pulse's packet.

use std::io::{self, Write};
use std::path::PathBuf;

use super::AtomicFile;
use super::vlr::fixed_str;
use crate::geometry::SPEED_OF_LIGHT_MPS;
use crate::output::PointRecord;

/// Bits per waveform sample in the `.wdp` file.
pub const WAVEFORM_BITS: u8 = 16;
/// The digitiser of the stored waveforms: sample spacing and the mapping
/// of 16-bit counts to amplitude units, `amplitude = offset + gain · count`
/// (LAS 1.4 R15, Table 17, "Digitizer Gain" and "Digitizer Offset").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Digitizer {
    /// Temporal sample spacing, ps.
    pub bin_ps: u32,
    /// Amplitude units per count.
    pub gain: f64,
    /// Amplitude of count 0.
    pub offset: f64,
}

impl Digitizer {
    /// A digitiser whose counts span `−full_scale / 16 … full_scale`
    /// amplitude units (the negative part keeps noise below the background
    /// visible); stronger signals saturate at 65535 as a real digitiser's
    /// would.
    pub fn with_full_scale(bin_ps: u32, full_scale: f64) -> Self {
        let full_scale = if full_scale.is_finite() && full_scale > 0.0 {
            full_scale
        } else {
            1.0
        };
        let offset = -full_scale / 16.0;
        Self {
            bin_ps,
            gain: (full_scale - offset) / 65535.0,
            offset,
        }
    }

    /// The count of an amplitude (rounded, saturating at 0 and 65535).
    pub fn count(&self, amplitude: f64) -> u16 {
        ((amplitude - self.offset) / self.gain)
            .round()
            .clamp(0.0, 65535.0) as u16
    }
}
/// Waveform packets hold a multiple of this many samples; descriptor `i`
/// (record ID 99 + i) describes packets of `i ×` this many samples.
pub const WAVEFORM_SAMPLES_STEP: usize = 16;
/// Number of waveform packet descriptors written (indices 1–255, all the
/// specification allows), so packets can hold up to 4080 samples.
pub const WAVEFORM_DESCRIPTORS: usize = 255;
/// Size of the header at the start of the `.wdp` file (an EVLR header,
/// LAS 1.4 R15 Table 21), bytes; packet offsets count from the start of the
/// file, so the first packet is at this offset.
pub const WDP_HEADER_LEN: u64 = 60;

/// The external waveform file and where its packets go.
pub(super) struct WdpFile {
    /// `None` when another writer writes the same file.
    pub file: Option<AtomicFile>,
    pub path: PathBuf,
    /// Offset of the next packet from the start of the file.
    pub next_offset: u64,
    /// Sample spacing and quantisation.
    pub digitizer: Digitizer,
    /// Quantised samples of one packet.
    pub buf: Vec<u8>,
}

/// Where a pulse's packet went in the `.wdp` file.
#[derive(Clone, Copy, Debug)]
pub(super) struct WavePacketLink {
    /// Descriptor index (1–255).
    index: u8,
    /// Byte offset from the start of the `.wdp` file.
    offset: u64,
    /// Packet size, bytes.
    size: u32,
    /// Two-way time of the first sample, ps.
    first_sample_ps: f64,
    /// Samples in the packet.
    samples: usize,
}

/// Appends the 29-byte wave packet of format 9 (LAS 1.4 R15, Table 11).
///
/// Return point waveform location: ps from the first digitised sample to
/// the echo. X(t), Y(t), Z(t): the parametric line of the waveform, in
/// metres per ps, as LASlib reads it: sample `s` lies at
/// `point + (location − s · spacing) · (X(t), Y(t), Z(t))`, so the first
/// sample (the "anchor") is at `point + location · (X(t), Y(t), Z(t))` and
/// the vector points from the echo back towards the scanner: minus the beam
/// direction times c/2 per ps (two-way time).
pub(super) fn write_wave_packet(
    buf: &mut Vec<u8>,
    p: &PointRecord,
    link: Option<WavePacketLink>,
    bin_ps: u32,
) {
    let location = link.map(|l| p.echo_time_ps - l.first_sample_ps);
    match (link, location) {
        (Some(l), Some(loc))
            if loc.is_finite()
                && loc >= 0.0
                && loc <= ((l.samples.max(1) - 1) as f64) * f64::from(bin_ps) =>
        {
            buf.push(l.index);
            buf.extend_from_slice(&l.offset.to_le_bytes());
            buf.extend_from_slice(&l.size.to_le_bytes());
            buf.extend_from_slice(&(loc as f32).to_le_bytes());
            let per_ps = -p.beam_dir * (SPEED_OF_LIGHT_MPS / 2.0 * 1e-12);
            for v in [per_ps.x, per_ps.y, per_ps.z] {
                buf.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        // No waveform for this point (descriptor index 0).
        _ => buf.extend_from_slice(&[0u8; 29]),
    }
}

impl WdpFile {
    /// Quantises and appends one pulse's samples, padded with zero signal
    /// to a multiple of [`WAVEFORM_SAMPLES_STEP`] (and cut after
    /// 255 × 16 samples).
    pub(super) fn write_packet(
        &mut self,
        samples: &[f32],
        first_sample_ps: f64,
    ) -> io::Result<WavePacketLink> {
        let max = WAVEFORM_DESCRIPTORS * WAVEFORM_SAMPLES_STEP;
        let used = samples.len().min(max);
        let n = used.div_ceil(WAVEFORM_SAMPLES_STEP).max(1) * WAVEFORM_SAMPLES_STEP;
        let count = |v: f64| self.digitizer.count(v);
        self.buf.clear();
        for &v in &samples[..used] {
            self.buf
                .extend_from_slice(&count(f64::from(v)).to_le_bytes());
        }
        let zero = count(0.0);
        for _ in used..n {
            self.buf.extend_from_slice(&zero.to_le_bytes());
        }
        if let Some(f) = self.file.as_mut() {
            f.writer().write_all(&self.buf)?;
        }
        let link = WavePacketLink {
            index: (n / WAVEFORM_SAMPLES_STEP) as u8,
            offset: self.next_offset,
            size: self.buf.len() as u32,
            first_sample_ps,
            samples: used,
        };
        self.next_offset += self.buf.len() as u64;
        Ok(link)
    }
}

/// The 60-byte header that starts a `.wdp` file: the EVLR header of the
/// waveform data packet record (LAS 1.4 R15, Table 21: reserved, user ID
/// `LASF_Spec`, record ID 65535, record length after header u64,
/// description), as LASlib writes it.
pub(super) fn wdp_header(record_len: u64) -> Vec<u8> {
    let mut h = Vec::with_capacity(WDP_HEADER_LEN as usize);
    h.extend_from_slice(&0u16.to_le_bytes());
    h.extend_from_slice(&fixed_str::<16>("LASF_Spec"));
    h.extend_from_slice(&65535u16.to_le_bytes());
    h.extend_from_slice(&record_len.to_le_bytes());
    h.extend_from_slice(&fixed_str::<32>("lidarsim waveforms"));
    debug_assert_eq!(h.len() as u64, WDP_HEADER_LEN);
    h
}
