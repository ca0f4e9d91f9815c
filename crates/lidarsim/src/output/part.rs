//! The points of a part of a split survey, kept whole: every field of every
//! point record and every recorded waveform, in a binary file that a merge
//! reads back and hands to the same writers an unsplit run uses. What the
//! writers get is therefore, value for value, what they would have got
//! from the simulator, and their files are the same bytes.
//!
//! Layout (little-endian): the 8-byte [`MAGIC`], then blocks, each a
//! header of three counts (`u32` points, `u32` waveform packets, `u64`
//! samples) followed by the points ([`RECORD_BYTES`] each), the packets
//! (26 bytes each: point source id, pulse index, first-sample time and
//! sample count) and the samples (`f32`).

use std::io::{BufReader, Read, Write};
use std::path::Path;

use super::{
    AtFile, AtomicFile, Component, NO_OBJECT, PointRecord, PointSink, WaveformBlock,
    WaveformPacket, WriteCause, WriteError,
};
use crate::geometry::DVec3;

/// The first bytes of a part's point file.
pub const MAGIC: &[u8; 8] = b"LSPART01";

/// Bytes of one point record.
pub const RECORD_BYTES: usize = 150;

/// Bytes of one waveform packet.
const PACKET_BYTES: usize = 26;

/// Writes a part's point file.
#[derive(Debug)]
pub struct PartWriter {
    file: AtomicFile,
    buf: Vec<u8>,
}

impl PartWriter {
    /// Creates `path` (as `path.partial` until finished).
    pub fn create(path: &Path) -> Result<Self, WriteError> {
        let mut file = AtomicFile::create(path)?;
        file.writer().write_all(MAGIC).map_err(|e| file.error(e))?;
        Ok(Self {
            file,
            buf: Vec::new(),
        })
    }
}

impl PointSink for PartWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        self.write_block(points, &WaveformBlock::default())
    }

    fn write_block(
        &mut self,
        points: &[PointRecord],
        waves: &WaveformBlock,
    ) -> Result<(), WriteError> {
        let b = &mut self.buf;
        b.clear();
        let path = self.file.path();
        let count = |n: usize| {
            u32::try_from(n).map_err(|_| {
                WriteError::new(
                    path,
                    WriteCause::Unsupported("a block of more than 2^32 points".into()),
                )
            })
        };
        b.extend_from_slice(&count(points.len())?.to_le_bytes());
        b.extend_from_slice(&count(waves.packets.len())?.to_le_bytes());
        b.extend_from_slice(&(waves.samples.len() as u64).to_le_bytes());
        for p in points {
            encode(p, b);
        }
        for w in &waves.packets {
            b.extend_from_slice(&w.point_source_id.to_le_bytes());
            b.extend_from_slice(&w.pulse_index.to_le_bytes());
            b.extend_from_slice(&w.first_sample_ps.to_le_bytes());
            b.extend_from_slice(&(w.len as u64).to_le_bytes());
        }
        for s in &waves.samples {
            b.extend_from_slice(&s.to_le_bytes());
        }
        let buf = &self.buf;
        self.file
            .writer()
            .write_all(buf)
            .map_err(|e| self.file.error(e))
    }

    fn finish(self: Box<Self>) -> Result<(), WriteError> {
        self.file.commit()
    }

    fn suspend(self: Box<Self>) -> Result<(), WriteError> {
        self.file.suspend()
    }

    fn discard(self: Box<Self>) {}
}

/// Appends the bytes of `p` to `b`.
pub(crate) fn encode(p: &PointRecord, b: &mut Vec<u8>) {
    let f64s = |b: &mut Vec<u8>, v: &[f64]| {
        for x in v {
            b.extend_from_slice(&x.to_le_bytes());
        }
    };
    f64s(b, &p.position_m.to_array());
    f64s(b, &[p.gps_time_s]);
    b.extend_from_slice(&p.intensity.to_le_bytes());
    f64s(b, &[p.amplitude, p.echo_width_ns, p.range_m]);
    f64s(b, &p.beam_dir.to_array());
    f64s(b, &p.error_m.to_array());
    let flags = u8::from(p.scan_direction_positive)
        | u8::from(p.edge_of_flight_line) << 1
        | u8::from(p.incidence_angle_deg.is_some()) << 2;
    b.extend_from_slice(&[p.return_number, p.number_of_returns, flags]);
    f64s(b, &[p.scan_angle_deg]);
    b.push(p.classification);
    b.extend_from_slice(&p.point_source_id.to_le_bytes());
    b.extend_from_slice(&p.pulse_index.to_le_bytes());
    b.extend_from_slice(&p.object_code().to_le_bytes());
    f64s(b, &[p.incidence_angle_deg.unwrap_or(0.0), p.echo_time_ps]);
    b.extend_from_slice(&[p.component.code(), p.channel]);
}

/// Reads a little-endian value from the front of a slice.
struct Cursor<'a>(&'a [u8]);

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let (head, rest) = self.0.split_at(N);
        self.0 = rest;
        head.try_into().expect("N bytes")
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn vec3(&mut self) -> DVec3 {
        DVec3::new(self.f64(), self.f64(), self.f64())
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
}

/// The point of [`RECORD_BYTES`] bytes written by [`encode`].
pub(crate) fn decode(bytes: &[u8]) -> PointRecord {
    let mut c = Cursor(bytes);
    let position_m = c.vec3();
    let gps_time_s = c.f64();
    let intensity = c.u16();
    let (amplitude, echo_width_ns, range_m) = (c.f64(), c.f64(), c.f64());
    let beam_dir = c.vec3();
    let error_m = c.vec3();
    let (return_number, number_of_returns, flags) = (c.u8(), c.u8(), c.u8());
    let scan_angle_deg = c.f64();
    let classification = c.u8();
    let point_source_id = c.u16();
    let pulse_index = c.u64();
    let object_id = Some(c.u32()).filter(|&id| id != NO_OBJECT);
    let (incidence, echo_time_ps) = (c.f64(), c.f64());
    // A part's records are checked against the CRC its run recorded
    // before they are read: a code is one `encode` wrote.
    let (component, channel) = (Component::from_code(c.u8()).unwrap_or_default(), c.u8());
    PointRecord {
        position_m,
        gps_time_s,
        intensity,
        amplitude,
        echo_width_ns,
        range_m,
        beam_dir,
        error_m,
        return_number,
        number_of_returns,
        scan_direction_positive: flags & 1 != 0,
        edge_of_flight_line: flags & 2 != 0,
        scan_angle_deg,
        classification,
        point_source_id,
        pulse_index,
        object_id,
        incidence_angle_deg: (flags & 4 != 0).then_some(incidence),
        echo_time_ps,
        component,
        channel,
    }
}

/// Reads a part's point file block by block.
pub struct PartReader {
    file: BufReader<std::fs::File>,
    path: std::path::PathBuf,
    buf: Vec<u8>,
}

impl PartReader {
    /// Opens `path`, checking its magic bytes.
    pub fn open(path: &Path) -> Result<Self, WriteError> {
        let mut file = BufReader::with_capacity(1 << 20, std::fs::File::open(path).at(path)?);
        let mut magic = [0u8; 8];
        file.read_exact(&mut magic).at(path)?;
        if &magic != MAGIC {
            return Err(WriteError::mismatch(
                path,
                "join",
                "it is not the point file of a lidarsim part",
            ));
        }
        Ok(Self {
            file,
            path: path.to_path_buf(),
            buf: Vec::new(),
        })
    }

    /// The next block into `points` and `waves` (cleared first); `false`
    /// at the end of the file.
    pub fn next_block(
        &mut self,
        points: &mut Vec<PointRecord>,
        waves: &mut WaveformBlock,
    ) -> Result<bool, WriteError> {
        points.clear();
        waves.clear();
        let path = &self.path;
        let mut head = [0u8; 16];
        match self.file.read(&mut head[..1]).at(path)? {
            0 => return Ok(false),
            _ => self.file.read_exact(&mut head[1..]).at(path)?,
        }
        let mut c = Cursor(&head);
        let (n, m, samples) = (c.u32() as usize, c.u32() as usize, c.u64() as usize);
        let len = n * RECORD_BYTES + m * PACKET_BYTES + samples * 4;
        self.buf.resize(len, 0);
        self.file.read_exact(&mut self.buf).at(path)?;
        let (records, rest) = self.buf.split_at(n * RECORD_BYTES);
        points.extend(records.chunks_exact(RECORD_BYTES).map(decode));
        let (packets, samples) = rest.split_at(m * PACKET_BYTES);
        let mut start = 0;
        for p in packets.chunks_exact(PACKET_BYTES) {
            let mut c = Cursor(p);
            let (point_source_id, pulse_index, first_sample_ps) = (c.u16(), c.u64(), c.f64());
            let len = c.u64() as usize;
            waves.packets.push(WaveformPacket {
                point_source_id,
                pulse_index,
                first_sample_ps,
                start,
                len,
            });
            start += len;
        }
        waves.samples.extend(
            samples
                .chunks_exact(4)
                .map(|s| f32::from_le_bytes(s.try_into().expect("4 bytes"))),
        );
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a point and every waveform sample reads back as it
    /// was written, `None` and NaN included.
    #[test]
    fn a_block_reads_back_as_written() {
        let p = PointRecord {
            position_m: DVec3::new(1.0 / 3.0, -2e7, f64::MIN_POSITIVE),
            gps_time_s: 123_456.789,
            intensity: 65_535,
            amplitude: f64::NAN,
            echo_width_ns: 4.25,
            range_m: 500.125,
            beam_dir: DVec3::new(0.1, -0.2, -0.97),
            error_m: DVec3::new(0.0, -0.0, 1e-9),
            return_number: 3,
            number_of_returns: 5,
            scan_direction_positive: true,
            edge_of_flight_line: false,
            scan_angle_deg: -19.99,
            classification: 5,
            point_source_id: 7,
            pulse_index: u64::MAX - 1,
            object_id: Some(4_000_000_000),
            incidence_angle_deg: None,
            echo_time_ps: 3.3e6,
            component: Component::Foliage,
            channel: 2,
        };
        let q = PointRecord {
            amplitude: 0.75,
            incidence_angle_deg: Some(12.5),
            edge_of_flight_line: true,
            scan_direction_positive: false,
            ..p
        };
        let waves = WaveformBlock {
            packets: vec![
                WaveformPacket {
                    point_source_id: 7,
                    pulse_index: 9,
                    first_sample_ps: 1.5e6,
                    start: 0,
                    len: 3,
                },
                WaveformPacket {
                    point_source_id: 7,
                    pulse_index: 10,
                    first_sample_ps: 1.6e6,
                    start: 3,
                    len: 2,
                },
            ],
            samples: vec![0.5, -1.0, f32::MAX, 1e-30, 2.0],
        };
        let dir = std::env::temp_dir().join(format!("lidarsim-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("points.part");
        let mut w = Box::new(PartWriter::create(&path).unwrap());
        w.write_block(&[p, q], &waves).unwrap();
        w.write_block(&[q], &WaveformBlock::default()).unwrap();
        w.finish().unwrap();
        let mut r = PartReader::open(&path).unwrap();
        let (mut points, mut got) = (Vec::new(), WaveformBlock::default());
        assert!(r.next_block(&mut points, &mut got).unwrap());
        assert_eq!(points.len(), 2);
        // NaN is not equal to itself: compare the bits through the encoder.
        let (mut a, mut b) = (Vec::new(), Vec::new());
        encode(&points[0], &mut a);
        encode(&p, &mut b);
        assert_eq!(a, b);
        assert_eq!(a.len(), RECORD_BYTES);
        assert_eq!(points[1], q);
        assert_eq!(got, waves);
        assert!(r.next_block(&mut points, &mut got).unwrap());
        assert_eq!(points, [q]);
        assert!(got.packets.is_empty());
        assert!(!r.next_block(&mut points, &mut got).unwrap());
        std::fs::remove_dir_all(&dir).ok();
    }
}
