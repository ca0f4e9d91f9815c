//! The variable-length records of the LAS header: extra-bytes
//! descriptors, waveform packet descriptors, the CRS WKT and the LASzip
//! item description.

use crate::output::WriteCause;

use super::LasSettings;
use super::wdp::{WAVEFORM_BITS, WAVEFORM_DESCRIPTORS, WAVEFORM_SAMPLES_STEP};

/// One extra-bytes field (LAS 1.4 R15, Table 24).
pub(super) struct ExtraField {
    name: &'static str,
    description: &'static str,
    /// Data type code: 5 unsigned long, 9 float.
    data_type: u8,
}

impl ExtraField {
    fn size(&self) -> u16 {
        4
    }
}

/// The echo attributes as extra bytes, in record order.
pub(super) const ATTRIBUTE_FIELDS: [ExtraField; 5] = [
    ExtraField {
        name: "amplitude",
        description: "echo energy / unit pulse energy",
        data_type: 9,
    },
    ExtraField {
        name: "echo_width",
        description: "echo width FWHM (ns)",
        data_type: 9,
    },
    ExtraField {
        name: "range",
        description: "range from the sensor (m)",
        data_type: 9,
    },
    ExtraField {
        name: "incidence_angle",
        description: "beam to normal (deg), NaN=foliage",
        data_type: 9,
    },
    ExtraField {
        name: "object_id",
        description: "scene object that returned it",
        data_type: 5,
    },
];

/// The georeferencing error as extra bytes.
pub(super) const ERROR_FIELDS: [ExtraField; 3] = [
    ExtraField {
        name: "error_x",
        description: "computed minus true x (m)",
        data_type: 9,
    },
    ExtraField {
        name: "error_y",
        description: "computed minus true y (m)",
        data_type: 9,
    },
    ExtraField {
        name: "error_z",
        description: "computed minus true z (m)",
        data_type: 9,
    },
];

/// Size of a VLR header, bytes (LAS 1.4 R15, Table 13).
const VLR_HEADER_LEN: usize = 54;
/// Size of one Extra Bytes descriptor, bytes (LAS 1.4 R15, Table 24).
const EXTRA_BYTES_DESCRIPTOR_LEN: usize = 192;
/// Size of a Waveform Packet Descriptor, bytes (LAS 1.4 R15, Table 17).
const WAVE_DESCRIPTOR_LEN: usize = 26;

/// One variable-length record (LAS 1.4 R15, section 2.5).
pub(super) struct Vlr {
    /// User ID, up to 16 bytes.
    pub user_id: &'static str,
    /// Record ID.
    pub record_id: u16,
    /// Description, up to 32 bytes.
    pub description: String,
    /// The record after its header.
    pub data: Vec<u8>,
}

impl Vlr {
    /// Bytes of the record with its header.
    pub fn len(&self) -> usize {
        VLR_HEADER_LEN + self.data.len()
    }
}

impl LasSettings {
    /// The extra-bytes fields, in record order.
    pub(super) fn extra_fields(&self) -> impl Iterator<Item = &'static ExtraField> {
        let a: &'static [ExtraField] = if self.attribute_extra_bytes {
            &ATTRIBUTE_FIELDS
        } else {
            &[]
        };
        let e: &'static [ExtraField] = if self.error_extra_bytes {
            &ERROR_FIELDS
        } else {
            &[]
        };
        a.iter().chain(e.iter())
    }

    pub(super) fn extra_bytes_len(&self) -> u16 {
        self.extra_fields().map(ExtraField::size).sum()
    }

    /// The VLRs between the header and the points.
    pub(super) fn vlr_list(&self) -> Result<Vec<Vlr>, WriteCause> {
        let mut list = Vec::new();
        let fields: Vec<&ExtraField> = self.extra_fields().collect();
        if !fields.is_empty() {
            let mut d = Vec::with_capacity(fields.len() * EXTRA_BYTES_DESCRIPTOR_LEN);
            for f in fields {
                // Extra Bytes descriptor (Table 24): reserved (2), data type,
                // options 0 (no no-data/min/max/scale/offset), name (32),
                // unused (4), no_data, min, max, scale, offset (5 × 24),
                // description (32).
                d.extend_from_slice(&[0, 0, f.data_type, 0]);
                d.extend_from_slice(&fixed_str::<32>(f.name));
                d.extend_from_slice(&[0u8; 4]);
                d.extend_from_slice(&[0u8; 24 * 5]);
                d.extend_from_slice(&fixed_str::<32>(f.description));
            }
            list.push(Vlr {
                user_id: "LASF_Spec",
                record_id: 4,
                description: "extra bytes".to_string(),
                data: d,
            });
        }
        if let Some(dig) = self.waveform {
            for i in 1..=WAVEFORM_DESCRIPTORS {
                // Waveform Packet Descriptor (Table 17): bits per sample,
                // compression type 0, number of samples, temporal sample
                // spacing (ps), digitizer gain, digitizer offset
                // (volts = offset + gain · sample).
                let mut d = Vec::with_capacity(WAVE_DESCRIPTOR_LEN);
                d.push(WAVEFORM_BITS);
                d.push(0);
                d.extend_from_slice(&((i * WAVEFORM_SAMPLES_STEP) as u32).to_le_bytes());
                d.extend_from_slice(&dig.bin_ps.to_le_bytes());
                d.extend_from_slice(&dig.gain.to_le_bytes());
                d.extend_from_slice(&dig.offset.to_le_bytes());
                debug_assert_eq!(d.len(), WAVE_DESCRIPTOR_LEN);
                list.push(Vlr {
                    user_id: "LASF_Spec",
                    record_id: 99 + i as u16,
                    description: format!("{} samples", i * WAVEFORM_SAMPLES_STEP),
                    data: d,
                });
            }
        }
        if let Some(wkt) = &self.crs_wkt {
            // OGC coordinate system WKT (section 2.5): a null-terminated
            // string.
            let mut d = wkt.as_bytes().to_vec();
            d.push(0);
            if d.len() > usize::from(u16::MAX) {
                return Err(WriteCause::Unsupported(
                    "the CRS WKT is longer than a VLR can hold (65535 bytes)".into(),
                ));
            }
            list.push(Vlr {
                user_id: "LASF_Projection",
                record_id: 2112,
                description: "OGC WKT".to_string(),
                data: d,
            });
        }
        if self.compressed {
            let mut d = Vec::new();
            self.laz_vlr()?.write_to(&mut d)?;
            list.push(Vlr {
                user_id: "laszip encoded",
                record_id: 22204,
                description: "lazrs".to_string(),
                data: d,
            });
        }
        Ok(list)
    }

    /// The VLRs' bytes.
    pub(super) fn vlrs(&self) -> Result<Vec<u8>, WriteCause> {
        let mut v = Vec::new();
        for vlr in self.vlr_list()? {
            // VLR header (Table 13): reserved, user ID, record ID, record
            // length after header, description.
            v.extend_from_slice(&0u16.to_le_bytes());
            v.extend_from_slice(&fixed_str::<16>(vlr.user_id));
            v.extend_from_slice(&vlr.record_id.to_le_bytes());
            v.extend_from_slice(&(vlr.data.len() as u16).to_le_bytes());
            v.extend_from_slice(&fixed_str::<32>(&vlr.description));
            v.extend_from_slice(&vlr.data);
        }
        Ok(v)
    }
}

/// `s` in a field of `N` bytes, cut or padded with zeros.
pub(super) fn fixed_str<const N: usize>(s: &str) -> [u8; N] {
    let mut out = [0u8; N];
    let b = s.as_bytes();
    let n = b.len().min(N);
    out[..n].copy_from_slice(&b[..n]);
    out
}
