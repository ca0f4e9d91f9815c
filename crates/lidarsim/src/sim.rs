//! The simulation driver: pulses in, points out.
//!
//! For pulse `k` of a flight line (ARCHITECTURE.md, the pipeline):
//! pose at `t_k` ∘ mirror angle at `t_k` → central ray and sub-rays →
//! closest hits → Eq. 2 per sub-ray (with speckle) → waveform → echoes →
//! georeferenced points (Eq. 1 on the central ray) with ground-truth
//! classes. Pulses are independent; blocks of pulses run in parallel on
//! the run's threads and are handed to the sinks in pulse order by the
//! calling thread, itself one of them, so the output
//! is the same for any number of threads and memory does not grow with the
//! length of the flight.

use std::io;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::{Condvar, Mutex};
use std::time::Instant;

use crate::accel::{Hit, PulseTrace, RayCaster, VolumeSpan};
use crate::canopy::{CanopyConfig, Fate, march};
use crate::detection::{DetectScratch, Detector, Echo};
use crate::geometry::{Attitude, DMat3, DVec3, Ray, SCANNER_TO_LEVEL_NORTH};
use crate::output::{PointRecord, PointSink, WaveformBlock, WaveformPacket};
use crate::radiometry::{Speckle, surface_return};
use crate::rng::{Purpose, Stream};
use crate::scene::{Shape, SurfaceClass};
use crate::sensor::beam::{Beam, BeamPattern};
use crate::sensor::navigation::observed_pose;
use crate::sensor::platform::{FlightLine, LineFrame};
use crate::sensor::scanner::Mirror;
use crate::survey::Survey;
use crate::waveform::{Receiver, Return, Waveform};
use crate::world::World;

/// ASPRS class of an echo no surface contributed to (receiver noise).
pub const NOISE_CLASS: u8 = 7;

/// [`PointRecord::component`] of an echo from a surface.
pub const COMPONENT_SURFACE: u8 = 0;
/// [`PointRecord::component`] of an echo from foliage in a crown.
pub const COMPONENT_FOLIAGE: u8 = 1;
/// [`PointRecord::component`] of an echo from a trunk.
pub const COMPONENT_TRUNK: u8 = 2;

/// Pulses per parallel work unit.
pub const BLOCK_PULSES: u64 = 2048;

/// Counts gathered while simulating.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Pulses emitted.
    pub pulses: u64,
    /// Points written.
    pub points: u64,
    /// Pulses with at least one echo.
    pub pulses_with_echo: u64,
    /// Points by return number (index 0 = first return).
    pub points_by_return: [u64; 15],
}

impl RunCounts {
    /// Adds the counts of `o`.
    pub fn add(&mut self, o: &RunCounts) {
        self.pulses += o.pulses;
        self.points += o.points;
        self.pulses_with_echo += o.pulses_with_echo;
        for (a, b) in self.points_by_return.iter_mut().zip(o.points_by_return) {
            *a += b;
        }
    }
}

/// Reusable per-thread buffers of the per-pulse computation.
#[derive(Default)]
pub struct Scratch {
    dirs: Vec<DVec3>,
    trace: PulseTrace,
    /// Which sub-rays' cells are sampled again.
    refine: Vec<bool>,
    /// The fine samples of those cells: undeflected direction and share.
    fine: Vec<(DVec3, f64)>,
    /// Their directions in the world frame.
    fine_dirs: Vec<DVec3>,
    /// Their closest hits and crown spans.
    fine_trace: PulseTrace,
    spans: Vec<VolumeSpan>,
    returns: Vec<Return>,
    /// Primitive of each return and the surface normal there (NaN for
    /// foliage), parallel to `returns`.
    return_surfaces: Vec<(u32, DVec3)>,
    waveform: Waveform,
    detect: DetectScratch,
    echoes: Vec<Echo>,
    /// Energy per primitive within one echo.
    energy_by_prim: Vec<(u32, f64)>,
    frames: FrameCache,
}

/// The per-line and per-attitude constants of the last pulse, reused while
/// they stay the same to the bit (so the values are those computed afresh):
/// the line's direction and heading, and the rotations of its attitude.
#[derive(Default)]
struct FrameCache {
    /// Bits of the line's start and end (all its frame depends on).
    line: Option<([u64; 6], LineFrame)>,
    /// Bits of roll, pitch, yaw and the boresight matrix; body-to-world
    /// rotation; scanner (with boresight) to world rotation.
    attitude: Option<([u64; 12], DMat3, DMat3)>,
}

impl FrameCache {
    /// [`FlightLine::frame`] of `line`.
    fn line(&mut self, line: &FlightLine) -> LineFrame {
        let (a, b) = (line.start_m, line.end_m);
        let key = [a.x, a.y, a.z, b.x, b.y, b.z];
        match self.line {
            Some((k, frame)) if same_bits(&k, &key) => frame,
            _ => {
                let frame = line.frame();
                self.line = Some((key.map(f64::to_bits), frame));
                frame
            }
        }
    }

    /// The body-to-world rotation of `attitude` and `body · boresight ·`
    /// [`SCANNER_TO_LEVEL_NORTH`].
    fn rotations(&mut self, attitude: &Attitude, boresight: DMat3) -> (DMat3, DMat3) {
        let b = boresight.to_cols_array();
        let key = [
            attitude.roll_rad,
            attitude.pitch_rad,
            attitude.yaw_rad,
            b[0],
            b[1],
            b[2],
            b[3],
            b[4],
            b[5],
            b[6],
            b[7],
            b[8],
        ];
        match self.attitude {
            Some((k, body, rot)) if same_bits(&k, &key) => (body, rot),
            _ => {
                let body = attitude.body_to_world();
                let rot = body * boresight * SCANNER_TO_LEVEL_NORTH;
                self.attitude = Some((key.map(f64::to_bits), body, rot));
                (body, rot)
            }
        }
    }
}

/// The surface that put the most energy into an echo: per primitive, the
/// powers of its sub-ray returns whose bin lies in `[lo, hi)`, added in ray
/// order; the first to reach the largest sum (in order of first
/// appearance). `span` holds the smallest and largest of `bins`: when the
/// echo's bins hold them all (the usual single echo), no return is tested.
/// `sums` is working storage.
fn dominant_surface(
    returns: &[Return],
    surfaces: &[(u32, DVec3)],
    bins: &[f64],
    span: (f64, f64),
    (lo, hi): (f64, f64),
    sums: &mut Vec<(u32, f64)>,
) -> Option<u32> {
    if lo <= span.0 && span.1 < hi {
        energy_leader(returns, surfaces, bins, |_| true, sums)
    } else {
        energy_leader(returns, surfaces, bins, |b| b >= lo && b < hi, sums)
    }
}

/// [`dominant_surface`] over the returns whose bin is `inside`.
#[inline(always)]
fn energy_leader(
    returns: &[Return],
    surfaces: &[(u32, DVec3)],
    bins: &[f64],
    inside: impl Fn(f64) -> bool,
    sums: &mut Vec<(u32, f64)>,
) -> Option<u32> {
    sums.clear();
    // Neighbouring sub-rays mostly meet the same surface: its sum is kept
    // in `open` (entry, energy) and stored when another surface comes (in a
    // register, not reloaded from the vector for each ray).
    let mut open: Option<(usize, f64)> = None;
    for ((r, &(p, _)), &b) in returns.iter().zip(surfaces).zip(bins) {
        if !inside(b) {
            continue;
        }
        if let Some((k, e)) = &mut open {
            if sums[*k].0 == p {
                *e += r.power;
                continue;
            }
            sums[*k].1 = *e;
        }
        open = Some(match sums.iter().position(|(q, _)| *q == p) {
            Some(k) => (k, sums[k].1 + r.power),
            None => {
                sums.push((p, r.power));
                (sums.len() - 1, r.power)
            }
        });
    }
    if let Some((k, e)) = open {
        sums[k].1 = e;
    }
    sums.iter()
        .copied()
        .reduce(|a, b| if b.1 > a.1 { b } else { a })
        .map(|(p, _)| p)
}

/// Whether `values` have the bits of `key`, compared one by one (comparing
/// whole arrays loads the values' fresh stores back wider than they were
/// written, which stalls).
#[inline]
fn same_bits<const N: usize>(key: &[u64; N], values: &[f64; N]) -> bool {
    key.iter().zip(values).all(|(k, v)| *k == v.to_bits())
}

impl Scratch {
    /// The waveform of the last simulated pulse.
    pub fn waveform(&self) -> &Waveform {
        &self.waveform
    }

    /// The echoes of the last simulated pulse.
    pub fn echoes(&self) -> &[Echo] {
        &self.echoes
    }

    /// The sub-ray returns of the last simulated pulse.
    pub fn returns(&self) -> &[Return] {
        &self.returns
    }
}

/// Everything needed to simulate pulses of one survey.
pub struct Simulator<'a> {
    survey: &'a Survey,
    caster: &'a dyn RayCaster,
    lines: &'a [FlightLine],
    receiver: Receiver,
    detector: Detector,
    beam: Beam,
    /// Range difference between neighbouring sub-rays that makes their
    /// cells be sampled again: the range resolution, `c·FWHM/2` (closer
    /// surfaces merge into one echo whatever their share).
    discontinuity_m: f64,
    speckle: Option<Speckle>,
    canopy: CanopyConfig,
    time_offset_s: f64,
    /// Keep each pulse's waveform for the sinks (full-waveform output).
    record_waveforms: bool,
    /// Boresight misalignment of the real scanner (identity without).
    boresight: DMat3,
    /// True when no navigation or measurement error is configured.
    exact_georeferencing: bool,
}

impl<'a> Simulator<'a> {
    /// Prepares the receiver, detector and beam pattern of `survey` over the
    /// scene indexed by `caster`.
    pub fn new(survey: &'a Survey, world: &'a World) -> Self {
        let receiver = Receiver::new(survey.receiver.clone());
        let detector = Detector::new(survey.detector.clone(), &receiver);
        Self {
            survey,
            caster: world.index(),
            lines: &world.lines,
            beam: Beam::new(survey.scanner.subrays, survey.scanner.divergence_rad),
            discontinuity_m: crate::geometry::SPEED_OF_LIGHT_MPS * survey.receiver.pulse.fwhm_s()
                / 2.0,
            speckle: survey.speckle_looks.and_then(Speckle::new),
            canopy: survey.canopy,
            boresight: survey.navigation.boresight(),
            exact_georeferencing: survey.navigation.is_zero(),
            receiver,
            detector,
            time_offset_s: survey.output.gps_start_time_s.unwrap_or(0.0),
            record_waveforms: false,
        }
    }

    /// Makes [`Simulator::run`] hand every pulse's recorded waveform to the
    /// sinks with its points ([`PointSink::write_block`]); off by default,
    /// when it costs nothing.
    pub fn with_waveforms(mut self, on: bool) -> Self {
        self.record_waveforms = on;
        self
    }

    /// The survey.
    pub fn survey(&self) -> &Survey {
        self.survey
    }

    /// The receiver.
    pub fn receiver(&self) -> &Receiver {
        &self.receiver
    }

    /// The echo detector.
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// Time of emission of pulse `k` of `line` since the flight start, s
    /// (`t_k = t_0 + k / PRF`, computed from the integer tick).
    #[inline]
    pub fn pulse_time(&self, line: &FlightLine, k: u64) -> f64 {
        line.start_time_s + k as f64 / self.survey.scanner.prf_hz
    }

    /// Simulates pulse `k` of `line`, appending its points to `out`.
    /// Returns the number of echoes.
    pub fn simulate_pulse(
        &self,
        line: &FlightLine,
        k: u64,
        scratch: &mut Scratch,
        out: &mut Vec<PointRecord>,
    ) -> usize {
        let s = self.survey;
        let prf = s.scanner.prf_hz;
        let t_line = k as f64 / prf;
        let t = line.start_time_s + t_line;
        // The true pose casts the rays: the scanner sits at the lever arm
        // from the IMU and is turned by the boresight misalignment.
        let frame = scratch.frames.line(line);
        let pose = line.pose_in(&frame, t_line);
        let mirror = &s.scanner.mirror;
        let theta = mirror.angle_at(t);
        let (body, rot) = scratch.frames.rotations(&pose.attitude, self.boresight);
        let origin = pose.position_m + body * s.navigation.lever_arm_m;
        // The deflection's third column is the beam direction
        // (`Mirror::beam_direction`), from the same sine and cosine.
        let deflection = crate::sensor::beam::deflection(theta);
        let central = rot * deflection.z_axis;
        // Random streams are keyed by pulse and purpose, so creating them
        // only when first needed gives the same numbers.
        let stream = |purpose| Stream::new(s.seed, line.index, k, purpose);

        // Sub-rays in the world frame, cast as one pulse: the pulse's
        // jittered pattern.
        let pattern = self.beam.for_pulse(|| stream(Purpose::Beam));
        let to_world = rot * deflection;
        let Scratch {
            dirs,
            trace,
            spans,
            refine,
            fine,
            fine_dirs,
            fine_trace,
            returns,
            return_surfaces,
            ..
        } = &mut *scratch;
        dirs.clear();
        dirs.extend(pattern.base_directions().iter().map(|d| to_world * *d));
        let (t_min, t_max) = (s.scanner.min_range_m, s.scanner.max_range_m);
        self.caster
            .trace_pulse(origin, dirs, t_min, t_max, spans, trace);
        // Cells across a discontinuity the receiver resolves are sampled
        // again, finely (beam.rs).
        let refined = pattern.refined() && self.mark_discontinuities(pattern, trace, refine);
        if refined {
            fine.clear();
            for (i, _) in refine.iter().enumerate().filter(|(_, r)| **r) {
                pattern.fine_samples(i, fine);
            }
            fine_dirs.clear();
            fine_dirs.extend(fine.iter().map(|(d, _)| to_world * *d));
            self.caster
                .trace_pulse(origin, fine_dirs, t_min, t_max, spans, fine_trace);
        }

        // Each sub-ray: through the crowns on its way (the interception
        // lottery), then Eq. 2 at the surface it reaches.
        let scene = self.caster.scene();
        let rn = s.receiver.reference_range_m;
        let mut speckle_rng: Option<Stream> = None;
        let mut canopy_rng: Option<Stream> = None;
        returns.clear();
        return_surfaces.clear();
        // Eq. 2 at the surface a sub-ray of energy `share` reached.
        let surface = |hit: &Hit, dir: &DVec3, share: f64| {
            let mat = &scene.materials[scene.primitives[hit.prim as usize].material as usize];
            let cos_inc = (-dir.dot(hit.normal)).clamp(0.0, 1.0);
            surface_return(
                share,
                hit.t,
                rn,
                mat.reflectance,
                cos_inc,
                mat.incidence_exponent,
            )
        };
        let share = pattern.share();
        if !refined && trace.has_no_spans() {
            // No crown on any sub-ray's way and no cell sampled again:
            // every sub-ray brings all its energy to its surface.
            for (i, dir) in dirs.iter().enumerate() {
                let Some(hit) = trace.hit(i) else {
                    continue;
                };
                let mut power = surface(&hit, dir, share);
                if let Some(sp) = &self.speckle {
                    power *= sp.factor(speckle_rng.get_or_insert_with(|| stream(Purpose::Speckle)));
                }
                returns.push(Return {
                    range_m: hit.t,
                    power,
                });
                return_surfaces.push((hit.prim, hit.normal));
            }
        } else {
            let mut emit = |dir: &DVec3, share: f64, hit: Option<Hit>, crowns: &[VolumeSpan]| {
                let fate = if crowns.is_empty() {
                    Fate::Passed { transmission: 1.0 }
                } else {
                    let ray = Ray { origin, dir: *dir };
                    let rng = canopy_rng.get_or_insert_with(|| stream(Purpose::Canopy));
                    march(scene, &ray, crowns, &self.canopy, rng)
                };
                let (range_m, prim, mut power, normal) = match fate {
                    Fate::Intercepted {
                        t,
                        prim,
                        density,
                        transmission,
                    } => {
                        let mat =
                            &scene.materials[scene.primitives[prim as usize].material as usize];
                        let power = self.canopy.return_model.foliage_return(
                            share,
                            transmission,
                            t,
                            rn,
                            mat.reflectance,
                            density,
                        );
                        (t, prim, power, DVec3::NAN)
                    }
                    Fate::Passed { transmission } => {
                        let Some(hit) = hit else {
                            return;
                        };
                        let power = transmission * surface(&hit, dir, share);
                        (hit.t, hit.prim, power, hit.normal)
                    }
                };
                if let Some(sp) = &self.speckle {
                    power *= sp.factor(speckle_rng.get_or_insert_with(|| stream(Purpose::Speckle)));
                }
                returns.push(Return { range_m, power });
                return_surfaces.push((prim, normal));
            };
            let mut f = 0;
            for (i, dir) in dirs.iter().enumerate() {
                if refined && refine[i] {
                    for _ in 0..crate::sensor::beam::FINE_PER_CELL {
                        emit(
                            &fine_dirs[f],
                            fine[f].1,
                            fine_trace.hit(f),
                            fine_trace.spans_of(f),
                        );
                        f += 1;
                    }
                } else {
                    emit(dir, share, trace.hit(i), trace.spans_of(i));
                }
            }
        }
        if scratch.returns.is_empty() {
            scratch.waveform.samples.clear();
            scratch.echoes.clear();
            return 0;
        }

        let mut noise_rng = Stream::new(s.seed, line.index, k, Purpose::ReceiverNoise);
        self.receiver
            .synthesize(&scratch.returns, &mut noise_rng, &mut scratch.waveform);
        self.detector
            .detect(&scratch.waveform, &mut scratch.detect, &mut scratch.echoes);
        let n = scratch.echoes.len();
        if n == 0 {
            return 0;
        }

        // Georeferencing uses what the processing knows: the observed pose
        // (GNSS/IMU errors), no boresight or lever arm, the encoder's angle
        // and the measured ranges (navigation.rs).
        let nav = &s.navigation;
        let mut measure: Option<Stream> = None;
        let (obs_origin, obs_body, obs_central) = if self.exact_georeferencing {
            (origin, body, central)
        } else {
            let obs = observed_pose(
                &pose,
                nav,
                &line.nav_errors,
                t_line,
                Some(measure.get_or_insert_with(|| stream(Purpose::Measurement))),
            );
            let theta_obs = if nav.encoder_sigma_rad > 0.0 {
                theta
                    + nav.encoder_sigma_rad
                        * measure
                            .get_or_insert_with(|| stream(Purpose::Measurement))
                            .normal()
            } else {
                theta
            };
            // Without attitude errors the observed rotation is the true one,
            // to the bit: no need to compute it again.
            let a = (obs.attitude, pose.attitude);
            let obs_body = if [a.0.roll_rad, a.0.pitch_rad, a.0.yaw_rad].map(f64::to_bits)
                == [a.1.roll_rad, a.1.pitch_rad, a.1.yaw_rad].map(f64::to_bits)
            {
                body
            } else {
                obs.attitude.body_to_world()
            };
            // `Attitude::scanner_to_world` from that rotation.
            let dir = obs_body * SCANNER_TO_LEVEL_NORTH * Mirror::beam_direction(theta_obs);
            (obs.position_m, obs_body, dir)
        };
        // Attributes shared by the pulse's points.
        let right = obs_body * DVec3::X;
        let right_h = DVec3::new(right.x, right.y, 0.0).normalize_or_zero();
        let scan_angle_deg = obs_central.dot(right_h).atan2(-obs_central.z).to_degrees();
        let moving_left = mirror.moving_left_at(t);
        // The next pulse's time from its own tick, exactly as it will be
        // computed for that pulse, so that the two agree on the direction.
        let t_next = line.start_time_s + (k + 1) as f64 / prf;
        let edge = moving_left != mirror.moving_left_at(t_next);
        let bin_s = s.receiver.bin_s;

        for (i, echo) in scratch.echoes.iter().enumerate() {
            let truth = origin + central * echo.range_m;
            let measured_range = if nav.range_sigma_m > 0.0 {
                echo.range_m
                    + nav.range_sigma_m
                        * measure
                            .get_or_insert_with(|| stream(Purpose::Measurement))
                            .normal()
            } else {
                echo.range_m
            };
            // Specification Eq. 1 with the observed pose and direction.
            let position = obs_origin + obs_central * measured_range;
            // Ground truth: the surface that put most energy into the echo.
            let mut incidence_angle_deg = None;
            let lo = echo.first_bin as f64;
            let hi = echo.last_bin as f64 + 1.0;
            let bins = &scratch.waveform.return_bins;
            let best = dominant_surface(
                &scratch.returns,
                &scratch.return_surfaces,
                bins,
                scratch.waveform.return_span,
                (lo, hi),
                &mut scratch.energy_by_prim,
            );
            let (classification, object_id, component) = match best {
                Some(p) => {
                    // Incidence on the dominant surface: its normal where
                    // the first of its sub-rays in the echo met it.
                    incidence_angle_deg = bins
                        .iter()
                        .zip(&scratch.return_surfaces)
                        .find(|(b, (q, _))| *q == p && **b >= lo && **b < hi)
                        .filter(|(_, (_, n))| n.is_finite())
                        .map(|(_, (_, n))| central.dot(*n).abs().min(1.0).acos().to_degrees());
                    let prim = &scene.primitives[p as usize];
                    let h = if prim.class == SurfaceClass::Vegetation {
                        self.height_above_ground(truth)
                    } else {
                        0.0
                    };
                    let component = match prim.shape {
                        Shape::Crown(_) => COMPONENT_FOLIAGE,
                        Shape::Trunk(_) => COMPONENT_TRUNK,
                        _ => COMPONENT_SURFACE,
                    };
                    (prim.class.asprs_code(h), prim.object, component)
                }
                None => (NOISE_CLASS, u32::MAX, COMPONENT_SURFACE),
            };
            out.push(PointRecord {
                position_m: position,
                gps_time_s: self.time_offset_s + t,
                intensity: (s.intensity_gain * echo.amplitude)
                    .round()
                    .clamp(0.0, 65535.0) as u16,
                amplitude: echo.amplitude,
                echo_width_ns: echo.width_ns,
                range_m: measured_range,
                beam_dir: obs_central,
                error_m: position - truth,
                return_number: (i + 1) as u8,
                number_of_returns: n as u8,
                scan_direction_positive: !moving_left,
                edge_of_flight_line: edge,
                scan_angle_deg,
                classification,
                point_source_id: (line.index + 1).min(u16::MAX as u32) as u16,
                pulse_index: k,
                object_id,
                component,
                incidence_angle_deg,
                echo_time_ps: echo.bin * bin_s * 1e12,
            });
        }
        n
    }

    /// Marks in `refine` the sub-rays of `pattern` whose closest hit in
    /// `trace` and a neighbour's differ by more than the range resolution
    /// (or one hits and the other misses): the cells on both sides of a
    /// discontinuity the receiver resolves. Returns whether any is.
    fn mark_discontinuities(
        &self,
        pattern: &BeamPattern,
        trace: &PulseTrace,
        refine: &mut Vec<bool>,
    ) -> bool {
        let n = pattern.len();
        // The usual case: every sub-ray meets one continuous surface.
        let (lo, hi) = trace.range_span();
        if lo == f64::INFINITY || hi - lo <= self.discontinuity_m {
            return false;
        }
        refine.clear();
        refine.resize(n, false);
        let differ = |a: f64, b: f64| {
            a.is_finite() != b.is_finite()
                || (a.is_finite() && (a - b).abs() > self.discontinuity_m)
        };
        let mut any = false;
        for i in 0..n {
            let a = trace.range(i);
            for j in pattern.neighbours(i) {
                if differ(a, trace.range(j)) {
                    refine[i] = true;
                    refine[j] = true;
                    any = true;
                }
            }
        }
        any
    }

    /// Height of `p` above the ground-class surface beneath it (infinite
    /// when there is none).
    pub fn height_above_ground(&self, p: DVec3) -> f64 {
        let ray = Ray {
            origin: p + DVec3::Z * 0.01,
            dir: -DVec3::Z,
        };
        self.caster
            .closest_hit_where(&ray, 0.0, 1e5, &|prim| prim.class.is_ground())
            .map_or(f64::INFINITY, |h| h.t - 0.01)
    }

    /// Simulates pulses `[k0, k1)` of `line`.
    pub fn simulate_block(
        &self,
        line: &FlightLine,
        k0: u64,
        k1: u64,
        scratch: &mut Scratch,
    ) -> (Vec<PointRecord>, RunCounts) {
        self.simulate_block_recording(line, k0, k1, scratch, None)
    }

    /// Simulates pulses `[k0, k1)` of `line`; with `waveforms`, also keeps
    /// the waveform of every pulse that has an echo there (the whole window
    /// the receiver synthesised: from before the first sub-ray return by the
    /// pulse's rise to after the last by its tail, see
    /// [`Receiver::synthesize`]).
    // Kept out of line: profiles (scripts/profile_bench.sh) count the
    // instructions under it, whatever the inlining around it.
    #[inline(never)]
    pub fn simulate_block_recording(
        &self,
        line: &FlightLine,
        k0: u64,
        k1: u64,
        scratch: &mut Scratch,
        mut waveforms: Option<&mut WaveformBlock>,
    ) -> (Vec<PointRecord>, RunCounts) {
        let mut points = Vec::with_capacity(((k1 - k0) as usize) * 2);
        let mut counts = RunCounts::default();
        let bin_ps = self.survey.receiver.bin_s * 1e12;
        for k in k0..k1 {
            let n = self.simulate_pulse(line, k, scratch, &mut points);
            counts.pulses += 1;
            if n > 0 {
                counts.pulses_with_echo += 1;
                if let Some(w) = waveforms.as_deref_mut() {
                    let wf = &scratch.waveform;
                    w.packets.push(WaveformPacket {
                        point_source_id: (line.index + 1).min(u16::MAX as u32) as u16,
                        pulse_index: k,
                        first_sample_ps: wf.first_bin as f64 * bin_ps,
                        start: w.samples.len(),
                        len: wf.samples.len(),
                    });
                    w.samples.extend(wf.samples.iter().map(|&v| v as f32));
                }
            }
        }
        counts.points = points.len() as u64;
        for p in &points {
            counts.points_by_return[usize::from(p.return_number.clamp(1, 15)) - 1] += 1;
        }
        (points, counts)
    }

    /// Simulates every pulse of every flight line on `threads` threads and
    /// writes the points, in pulse order, to `sinks`. The calling thread is
    /// one of the `threads`: it writes each block as soon as the blocks
    /// before it are written and simulates blocks in between, so one
    /// thread runs everything in turn on the caller.
    /// `progress` is called with the number of pulses done so far.
    /// The sinks are not finished here.
    pub fn run(
        &self,
        threads: usize,
        sinks: &mut [&mut (dyn PointSink + 'static)],
        progress: &(dyn Fn(u64) + Sync),
    ) -> io::Result<RunCounts> {
        self.run_from(threads, sinks, progress, &RunControl::default())
            .map(|o| o.counts)
    }

    /// [`Simulator::run`] from `control.start` on, stopping at the next
    /// block boundary once `control.stop` is set (checked before every
    /// block a thread takes; the blocks already simulated are written
    /// first, as far as they follow each other).
    /// The counts are those of the pulses simulated by this call; the
    /// outcome says where it stopped, if it did.
    pub fn run_from(
        &self,
        threads: usize,
        sinks: &mut [&mut (dyn PointSink + 'static)],
        progress: &(dyn Fn(u64) + Sync),
        control: &RunControl<'_>,
    ) -> io::Result<RunOutcome> {
        let threads = threads.max(1);
        // The blocks to simulate, in output order, within the pulse budget
        // (a block is taken while fewer pulses than the budget precede it).
        let mut jobs: Vec<(usize, u64, u64)> = Vec::new();
        let mut budget_end = None;
        let mut sent = 0u64;
        'lines: for (l, line) in self.lines.iter().enumerate().skip(control.start.line) {
            let n = self.survey.pulses_of(line);
            let mut k = if l == control.start.line {
                control.start.pulse.min(n)
            } else {
                0
            };
            while k < n {
                if control.pulse_budget.is_some_and(|b| sent >= b) {
                    budget_end = Some(PulsePosition { line: l, pulse: k });
                    break 'lines;
                }
                let k1 = (k + BLOCK_PULSES).min(n);
                jobs.push((l, k, k1));
                sent += k1 - k;
                k = k1;
            }
        }
        let stopped = || control.stop.is_some_and(|s| s.load(Ordering::SeqCst));

        // `threads` threads take the blocks in order from a shared counter,
        // at most `window` blocks ahead of the writer, which puts them back
        // in order: no barrier between batches, memory bounded by the
        // window. The calling thread is one of them: it writes every block
        // that is next in order as soon as it has it and simulates a block
        // itself whenever none is, so a run keeps exactly `threads` cores
        // busy (one thread: no other thread at all) and the writer's work
        // is shared like the pulses' rather than taken from a core the
        // workers do not use.
        let window = 4 * threads;
        let next_job = AtomicUsize::new(0);
        let abort = AtomicBool::new(false);
        let written = (Mutex::new(0usize), Condvar::new());
        type Block = (Vec<PointRecord>, RunCounts, WaveformBlock);
        let simulate = |j: usize, scratch: &mut Scratch| -> Block {
            let (l, k0, k1) = jobs[j];
            let mut waves = WaveformBlock::default();
            let record = self.record_waveforms.then_some(&mut waves);
            let (points, counts) =
                self.simulate_block_recording(&self.lines[l], k0, k1, scratch, record);
            (points, counts, waves)
        };
        let (tx, rx) = mpsc::channel::<(usize, Block)>();
        std::thread::scope(|scope| {
            for _ in 1..threads {
                let tx = tx.clone();
                let (jobs, next_job, abort, written) = (&jobs, &next_job, &abort, &written);
                let simulate = &simulate;
                scope.spawn(move || {
                    let mut scratch = Scratch::default();
                    loop {
                        if stopped() || abort.load(Ordering::SeqCst) {
                            return;
                        }
                        let j = next_job.fetch_add(1, Ordering::SeqCst);
                        if j >= jobs.len() {
                            return;
                        }
                        // Wait until the writer is within the window.
                        {
                            let (lock, cv) = written;
                            let mut w = lock.lock().unwrap_or_else(|e| e.into_inner());
                            while j >= *w + window && !abort.load(Ordering::SeqCst) {
                                w = cv.wait(w).unwrap_or_else(|e| e.into_inner());
                            }
                        }
                        if tx.send((j, simulate(j, &mut scratch))).is_err() {
                            return;
                        }
                    }
                });
            }
            drop(tx);
            // The calling thread: blocks in job order to every sink, and a
            // block of its own whenever the next one in order is not there.
            let mut scratch = Scratch::default();
            let mut total = RunCounts::default();
            let mut pending = std::collections::BTreeMap::new();
            let mut done = 0usize;
            let mut result = Ok(());
            let mut workers_left = threads > 1;
            loop {
                while let Ok((j, block)) = rx.try_recv() {
                    pending.insert(j, block);
                }
                let before = done;
                while let Some((points, counts, waves)) = pending.remove(&done) {
                    for sink in sinks.iter_mut() {
                        if let Err(e) = sink.write_block(&points, &waves) {
                            result = Err(e);
                            break;
                        }
                    }
                    if result.is_err() {
                        break;
                    }
                    total.add(&counts);
                    done += 1;
                    let (lock, cv) = &written;
                    *lock.lock().unwrap_or_else(|e| e.into_inner()) = done;
                    cv.notify_all();
                }
                if result.is_err() {
                    let (lock, cv) = &written;
                    let _held = lock.lock().unwrap_or_else(|e| e.into_inner());
                    abort.store(true, Ordering::SeqCst);
                    cv.notify_all();
                    break;
                }
                if done > before {
                    progress(total.pulses);
                }
                // Take the next block when it is within the window (the
                // writer cannot wait for itself). A block that the workers
                // still simulate is then written after this one.
                let j = next_job.load(Ordering::SeqCst);
                if !stopped() && j < jobs.len() && j < done + window {
                    // A worker may take job `j` first: then look again.
                    if next_job
                        .compare_exchange(j, j + 1, Ordering::SeqCst, Ordering::SeqCst)
                        .is_ok()
                    {
                        pending.insert(j, simulate(j, &mut scratch));
                    }
                    continue;
                }
                // Nothing to simulate here: wait for a worker's block, or
                // end once every worker has ended and the blocks in order
                // are written (a gap left by a stop stays unwritten).
                if !workers_left {
                    break;
                }
                match rx.recv() {
                    Ok((j, block)) => {
                        pending.insert(j, block);
                    }
                    Err(_) => workers_left = false,
                }
            }
            drop(rx);
            result?;
            // Stopped early when blocks remain unwritten; a stop requested
            // after the last block changes nothing.
            let stopped_at = match jobs.get(done) {
                Some(&(l, k0, _)) => Some(PulsePosition { line: l, pulse: k0 }),
                None => budget_end,
            };
            Ok(RunOutcome {
                counts: total,
                stopped_at,
            })
        })
    }
}

/// A pulse of a survey: flight line (0-based index) and pulse within it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PulsePosition {
    /// Index of the flight line (0 = first).
    pub line: usize,
    /// Pulse index within the line.
    pub pulse: u64,
}

/// Where [`Simulator::run_from`] starts and what makes it stop early.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunControl<'a> {
    /// First pulse to simulate (the pulses before it are skipped).
    pub start: PulsePosition,
    /// Set (by a signal handler, say) to stop at the next block boundary.
    pub stop: Option<&'a AtomicBool>,
    /// Stop once this many pulses were simulated, rounded up to a whole
    /// block (at the end of a line, where the line ends): a run in slices.
    pub pulse_budget: Option<u64>,
}

/// What [`Simulator::run_from`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunOutcome {
    /// Counts of the pulses simulated by this call.
    pub counts: RunCounts,
    /// The first pulse not simulated when the run was stopped early; `None`
    /// when it reached the end of the survey.
    pub stopped_at: Option<PulsePosition>,
}

/// Simulates a whole survey into memory on `threads` threads: its world
/// built, every pulse, the points in pulse order. For tests and small
/// surveys; [`crate::run::run_to_dir`] streams to files instead.
pub fn simulate_to_memory(survey: &Survey, threads: usize) -> io::Result<Vec<PointRecord>> {
    let world = World::build(survey)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    simulate_world_to_memory(survey, &world, threads)
}

/// Simulates a survey over a world already built (its lines perhaps
/// changed since) into memory on `threads` threads, the points in pulse
/// order.
pub fn simulate_world_to_memory(
    survey: &Survey,
    world: &World,
    threads: usize,
) -> io::Result<Vec<PointRecord>> {
    let sim = Simulator::new(survey, world);
    let mut sink = crate::output::MemorySink::default();
    sim.run(threads, &mut [&mut sink], &|_| {})?;
    Ok(sink.points)
}

/// Wall-clock timing helper for summaries.
#[derive(Debug)]
pub struct Timer(Instant);

impl Timer {
    /// Starts timing.
    pub fn start() -> Self {
        Self(Instant::now())
    }

    /// Seconds since the start.
    pub fn seconds(&self) -> f64 {
        self.0.elapsed().as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{rot_x, rot_y, rot_z};

    /// The dominant surface is the one of the largest sum, the sums taken
    /// one surface at a time over the returns in the echo's bins, the first
    /// surface of equal sums winning, for surfaces in runs and interleaved.
    #[test]
    fn dominant_surface_has_the_largest_energy() {
        let mut rng = crate::rng::Stream::new(4, 0, 0, crate::rng::Purpose::Test);
        let mut sums = Vec::new();
        let mut checked = 0;
        for case in 0..5000 {
            let n = 1 + (rng.uniform() * 30.0) as usize;
            let kinds = 1 + case % 4;
            let mut p = 0u32;
            let (mut returns, mut surfaces, mut bins) = (vec![], vec![], vec![]);
            for _ in 0..n {
                // Runs of one surface, sometimes broken.
                if rng.uniform() < 0.3 {
                    p = (rng.uniform() * kinds as f64) as u32;
                }
                // Powers from a few values, so that sums can tie.
                let power = [0.25, 0.5, 1.0][(rng.uniform() * 3.0) as usize];
                returns.push(Return {
                    range_m: 0.0,
                    power,
                });
                surfaces.push((p, DVec3::Z));
                bins.push(rng.uniform() * 10.0);
            }
            // Every fourth window holds all the returns.
            let (lo, hi) = if case % 4 == 3 {
                (-rng.uniform(), 10.0 + rng.uniform())
            } else {
                (rng.uniform() * 4.0, 4.0 + rng.uniform() * 6.0)
            };
            let span = bins
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            let inside = |i: usize| bins[i] >= lo && bins[i] < hi;
            // Each surface's sum on its own, in ray order.
            let mut order: Vec<u32> = vec![];
            for i in (0..n).filter(|&i| inside(i)) {
                if !order.contains(&surfaces[i].0) {
                    order.push(surfaces[i].0);
                }
            }
            let sum_of = |q: u32| {
                (0..n)
                    .filter(|&i| inside(i) && surfaces[i].0 == q)
                    .fold(0.0, |s, i| s + returns[i].power)
            };
            let mut want: Option<(u32, f64)> = None;
            for q in order {
                let e = sum_of(q);
                if want.is_none_or(|(_, w)| e > w) {
                    want = Some((q, e));
                }
            }
            let got = dominant_surface(&returns, &surfaces, &bins, span, (lo, hi), &mut sums);
            assert_eq!(got, want.map(|(q, _)| q), "case {case}");
            checked += usize::from(got.is_some());
        }
        assert!(checked > 3000, "{checked}");
    }

    fn line(index: u32, start: DVec3, end: DVec3) -> FlightLine {
        FlightLine {
            index,
            ..crate::sensor::platform::tests::line(start, end)
        }
    }

    #[test]
    fn frame_cache_answers_as_computed_afresh() {
        let mut cache = FrameCache::default();
        // Same number, other ends; the same end from another start; the same
        // start to another end; then back: each answer is that line's own.
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let lines = [
            line(0, p(-150.0, 0.0, 500.0), p(150.0, 0.0, 500.0)),
            line(0, p(-150.0, 50.0, 500.0), p(150.0, 0.0, 500.0)),
            line(0, p(-150.0, 50.0, 500.0), p(150.0, 80.0, 510.0)),
            line(0, p(0.0, -150.0, 500.0), p(0.0, 150.0, 500.0)),
            line(1, p(0.0, -150.0, 500.0), p(0.0, 150.0, 500.0)),
        ];
        for l in lines.iter().chain(&lines).chain(lines.iter().rev()) {
            assert_eq!(cache.line(l), l.frame());
            let (a, b) = (l.pose_in(&cache.line(l), 1.7), l.pose_at(1.7));
            assert_eq!((a.position_m, a.attitude), (b.position_m, b.attitude));
        }
        // Repeated and changing attitudes and boresights (a boresight change
        // alone must not return the old scanner rotation).
        let boresights = [DMat3::IDENTITY, rot_z(1e-3) * rot_x(-2e-3) * rot_y(5e-4)];
        let attitudes = [
            Attitude::default(),
            Attitude {
                roll_rad: 0.01,
                pitch_rad: -0.02,
                yaw_rad: 1.3,
            },
        ];
        for step in 0..12 {
            let att = attitudes[(step / 3) % 2];
            let bs = boresights[step % 2];
            let body = att.body_to_world();
            let want = (body, body * bs * SCANNER_TO_LEVEL_NORTH);
            assert_eq!(cache.rotations(&att, bs), want, "step {step}");
        }
    }
}
