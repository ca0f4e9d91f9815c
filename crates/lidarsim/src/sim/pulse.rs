//! One pulse, in named stages (ARCHITECTURE.md, the pipeline):
//!
//! 1. [`emit`](Simulator::emit): pose at `t_k` ∘ mirror angle at `t_k` →
//!    the scanner's origin, the central direction and the sub-rays' frame;
//! 2. [`cast`](Simulator::cast): the sub-rays' closest hits and crown
//!    spans, cells across a resolved discontinuity sampled again;
//! 3. [`gather_returns`](Simulator::gather_returns): each sub-ray through
//!    the crowns on its way, then Eq. 2 at the surface it reaches (with
//!    speckle);
//! 4. the receiver's waveform and the detector's echoes;
//! 5. [`georeference`](Simulator::georeference): one point per echo (Eq. 1
//!    on the central ray, with the observed pose) and its ground truth.
//!
//! Random streams are keyed by pulse and purpose, so each stage creates
//! its streams only when it first needs them and gets the same numbers.

use super::NOISE_CLASS;
use super::Simulator;
use super::scratch::Scratch;
use super::truth::{ReturnSource, dominant_surface};
use crate::accel::{Hit, PulseTrace};
use crate::canopy::Fate;
use crate::geometry::{DMat3, DVec3, Ray, SCANNER_TO_LEVEL_NORTH};
use crate::output::{Component, PointRecord};
use crate::radiometry::surface_return;
use crate::rng::{Purpose, Stream};
use crate::scene::{MEDIUM_VEGETATION_MAX_M, Shape, SurfaceClass};
use crate::sensor::Pose;
use crate::sensor::beam::BeamPattern;
use crate::sensor::navigation::observed_pose;
use crate::sensor::platform::FlightLine;
use crate::waveform::Return;

/// The channel of a multi-channel head that fired a pulse.
#[derive(Clone, Copy, Debug)]
struct Channel {
    /// Its number, from 0.
    index: u8,
    /// Its mounting on the head; `None` for a single straight channel.
    mount: Option<DMat3>,
}

impl Channel {
    /// A frame or direction of the deflector turned by the mounting.
    fn turn<T>(&self, deflected: T) -> T
    where
        DMat3: std::ops::Mul<T, Output = T>,
    {
        match self.mount {
            Some(mount) => mount * deflected,
            None => deflected,
        }
    }
}

/// Where, when and in which direction a pulse leaves the scanner.
struct Emission {
    /// Time since the line's start, s.
    t_line: f64,
    /// Time since the flight's start, s.
    t: f64,
    /// The true pose of the platform.
    pose: Pose,
    /// The channel that fired.
    channel: Channel,
    /// Beam direction in the scanner frame, the mounting included.
    beam: DVec3,
    /// Body-to-world rotation of the true attitude.
    body: DMat3,
    /// The scanner's position: the pose's plus the lever arm.
    origin: DVec3,
    /// Direction of the central ray, world frame.
    central: DVec3,
    /// Undeflected beam frame to world (sub-ray patterns are drawn in it).
    to_world: DMat3,
}

/// How stage 2 sampled a pulse's beam.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Sampling {
    /// By the pattern's sub-rays, each carrying the pattern's share.
    Coarse,
    /// Some cells sampled again (across a discontinuity, or where a
    /// surface lies between the sub-rays, cone.rs): their fine samples
    /// carry each cell's own energy ([`BeamPattern::cell_energy`]), and
    /// the other sub-rays what is left, `share` each, so that the pulse's
    /// energy stays whole.
    Refined {
        /// Energy share of each sub-ray whose cell is not sampled again.
        share: f64,
    },
}

/// The sub-rays of a pulse in emission order: the pattern's, each cell
/// sampled again replaced by its fine samples.
struct Rays<'a> {
    dirs: &'a [DVec3],
    trace: &'a PulseTrace,
    /// How many fine samples stand for each cell, 0 for its sub-ray
    /// (empty when no cell is sampled again).
    counts: &'a [u32],
    fine: &'a [(DVec3, f64)],
    fine_dirs: &'a [DVec3],
    fine_trace: &'a PulseTrace,
    /// Energy share of a pattern sub-ray not sampled again.
    share: f64,
}

impl Rays<'_> {
    /// Calls `f` with each sub-ray's direction, energy share and closest
    /// hit.
    #[inline(always)]
    fn each(&self, mut f: impl FnMut(&DVec3, f64, Option<Hit>)) {
        let mut j = 0;
        for (i, dir) in self.dirs.iter().enumerate() {
            let count = self.counts.get(i).copied().unwrap_or(0);
            if count > 0 {
                for _ in 0..count {
                    let (dir, share) = (&self.fine_dirs[j], self.fine[j].1);
                    f(dir, share, self.fine_trace.hit(j));
                    j += 1;
                }
            } else {
                f(dir, self.share, self.trace.hit(i));
            }
        }
    }
}

impl Simulator<'_> {
    /// Simulates pulse `k` of `line`, appending its points to `out`.
    /// Returns the number of echoes, or `None` when no pulse leaves at
    /// this tick (a polygon facet looking outside the field of view).
    pub(crate) fn simulate_pulse(
        &self,
        line: &FlightLine,
        k: u64,
        scratch: &mut Scratch,
        out: &mut Vec<PointRecord>,
    ) -> Option<usize> {
        let seed = self.survey.seed;
        let stream = |purpose| Stream::new(seed, line.index, k, purpose);
        let Some(em) = self.emit(line, k, scratch) else {
            scratch.waveform.samples.clear();
            scratch.echoes.clear();
            return None;
        };
        let c = usize::from(em.channel.index);
        let pattern = self.beams[c.min(self.beams.len() - 1)].for_pulse(|| stream(Purpose::Beam));
        let sampling = self.cast(&em, pattern, scratch);
        self.gather_returns(&em, pattern, sampling, scratch, &stream);
        if scratch.returns.is_empty() {
            scratch.waveform.samples.clear();
            scratch.echoes.clear();
            return Some(0);
        }
        let mut noise_rng = stream(Purpose::ReceiverNoise);
        self.receiver
            .synthesize(&scratch.returns, &mut noise_rng, &mut scratch.waveform);
        self.detector
            .detect(&scratch.waveform, &mut scratch.detect, &mut scratch.echoes);
        if scratch.echoes.is_empty() {
            return Some(0);
        }
        Some(self.georeference(line, k, &em, scratch, &stream, out))
    }

    /// Stage 1: the true pose casts the rays; the scanner sits at the
    /// lever arm from the IMU and is turned by the boresight misalignment.
    /// `None` when no pulse leaves at this tick (a polygon facet looking
    /// outside the field of view).
    #[inline(always)]
    fn emit(&self, line: &FlightLine, k: u64, scratch: &mut Scratch) -> Option<Emission> {
        let s = self.survey;
        let t_line = k as f64 / s.scanner.prf_hz;
        let t = line.start_time_s + t_line;
        let deflector = &s.scanner.deflector;
        if !deflector.emits_at(t) {
            return None;
        }
        let frame = scratch.frames.line(line);
        let pose = line.pose_in(&frame, t_line);
        let (body, rot) = scratch.frames.rotations(&pose.attitude, self.boresight);
        let origin = pose.position_m + body * s.navigation.lever_arm_m;
        // The deflection's third column is the beam direction; a channel of
        // a multi-channel head turns it by its mounting.
        let c = self.firing.channel_of(k);
        let channel = Channel {
            index: c as u8,
            mount: self.mounts.get(c).copied(),
        };
        let deflection = channel.turn(deflector.beam_frame(t));
        Some(Emission {
            t_line,
            t,
            pose,
            channel,
            beam: deflection.z_axis,
            body,
            origin,
            central: rot * deflection.z_axis,
            to_world: rot * deflection,
        })
    }

    /// Stage 2: the sub-rays of `pattern`, in the world frame, cast as one
    /// pulse; the cells across a discontinuity the receiver resolves
    /// sampled again, finely (beam.rs).
    #[inline(always)]
    fn cast(&self, em: &Emission, pattern: &BeamPattern, scratch: &mut Scratch) -> Sampling {
        let Scratch {
            dirs,
            trace,
            refine,
            counts,
            cone,
            fine,
            fine_dirs,
            fine_trace,
            ..
        } = scratch;
        let to_world = em.to_world;
        dirs.clear();
        dirs.extend(pattern.base_directions().iter().map(|d| to_world * *d));
        let (t_min, t_max) = (
            self.survey.scanner.min_range_m,
            self.survey.scanner.max_range_m,
        );
        self.caster
            .trace_pulse(em.origin, dirs, t_min, t_max, trace);
        let marked = pattern.refined() && self.mark_discontinuities(pattern, trace, refine);
        let marked = if marked { &refine[..] } else { &[] };
        let patched = pattern.refined()
            && (!trace.unseen().is_empty() || !marked.is_empty())
            && self.find_patches((em.origin, to_world), pattern, trace, marked, cone);
        if marked.is_empty() && !patched {
            return Sampling::Coarse;
        }
        let edge = self.survey.scanner.edge_fineness;
        let share = Self::sample_cells(pattern, edge, marked, cone, fine, counts);
        fine_dirs.clear();
        fine_dirs.extend(fine.iter().map(|(d, _)| to_world * *d));
        self.caster
            .trace_pulse(em.origin, fine_dirs, t_min, t_max, fine_trace);
        Sampling::Refined { share }
    }

    /// Stage 3: each sub-ray through the crowns on its way (the
    /// interception lottery), then Eq. 2 at the surface it reaches; the
    /// returns and their sources into `scratch`.
    #[inline(always)]
    fn gather_returns(
        &self,
        em: &Emission,
        pattern: &BeamPattern,
        sampling: Sampling,
        scratch: &mut Scratch,
        stream: &impl Fn(Purpose) -> Stream,
    ) {
        let Scratch {
            dirs,
            trace,
            counts,
            fine,
            fine_dirs,
            fine_trace,
            returns,
            sources,
            canopy,
            volumes,
            ..
        } = scratch;
        let scene = self.caster.scene();
        let reflectance =
            &self.reflectance[usize::from(em.channel.index).min(self.reflectance.len() - 1)];
        let rn = self.survey.receiver.reference_range_m;
        let mut speckle_rng: Option<Stream> = None;
        returns.clear();
        sources.clear();
        // Eq. 2 at the surface a sub-ray of energy `share` reached.
        let surface = |hit: &Hit, dir: &DVec3, share: f64| {
            let m = scene.primitives[hit.prim as usize].material as usize;
            let mat = &scene.materials[m];
            let cos_inc = (-dir.dot(hit.normal)).clamp(0.0, 1.0);
            surface_return(
                share,
                hit.t,
                rn,
                reflectance[m],
                cos_inc,
                mat.incidence_exponent,
            )
        };
        let (refined, share) = match sampling {
            Sampling::Coarse => (false, pattern.share()),
            Sampling::Refined { share } => (true, share),
        };
        if !refined && trace.has_no_volumes() {
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
                sources.push(ReturnSource {
                    prim: hit.prim,
                    normal: hit.normal,
                });
            }
            return;
        }
        // Every sub-ray through the crowns, the pulse's together.
        let t_min = self.survey.scanner.min_range_m;
        let t_max = self.survey.scanner.max_range_m;
        canopy.clear();
        let rays = Rays {
            dirs,
            trace,
            counts: if refined { counts } else { &[] },
            fine,
            fine_dirs,
            fine_trace,
            share,
        };
        rays.each(|dir, _, hit| {
            canopy.push(*dir, t_min, hit.map_or(t_max, |h| h.t));
        });
        // The crowns of the fine samples' ways too, each once.
        let crowns: &[u32] = if refined && !fine_trace.has_no_volumes() {
            volumes.clear();
            volumes.extend_from_slice(trace.volumes());
            volumes.extend_from_slice(fine_trace.volumes());
            volumes.sort_unstable();
            volumes.dedup();
            volumes
        } else {
            trace.volumes()
        };
        canopy.run(
            scene,
            em.origin,
            crowns,
            &self.canopy,
            &mut stream(Purpose::Canopy),
        );
        let fates = canopy.fates();
        let mut emit = |lane: usize, dir: &DVec3, share: f64, hit: Option<Hit>| {
            let (range_m, prim, mut power, normal) = match fates[lane] {
                Fate::Intercepted {
                    t,
                    prim,
                    density,
                    transmission,
                } => {
                    let m = scene.primitives[prim as usize].material as usize;
                    let power = self.canopy.return_model.foliage_return(
                        share,
                        transmission,
                        t,
                        rn,
                        reflectance[m],
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
            sources.push(ReturnSource { prim, normal });
        };
        let mut k = 0;
        rays.each(|dir, share, hit| {
            emit(k, dir, share, hit);
            k += 1;
        });
    }

    /// Stage 5: the points of the pulse's echoes. Georeferencing uses what
    /// the processing knows: the observed pose (GNSS/IMU errors), no
    /// boresight or lever arm, the encoder's angle and the measured ranges
    /// (navigation.rs). Returns the number of points.
    #[inline(always)]
    fn georeference(
        &self,
        line: &FlightLine,
        k: u64,
        em: &Emission,
        scratch: &mut Scratch,
        stream: &impl Fn(Purpose) -> Stream,
        out: &mut Vec<PointRecord>,
    ) -> usize {
        let s = self.survey;
        let nav = &s.navigation;
        let deflector = &s.scanner.deflector;
        let (t, origin, body, central) = (em.t, em.origin, em.body, em.central);
        let mut measure: Option<Stream> = None;
        let (obs_origin, obs_body, obs_central) = if self.exact_georeferencing {
            (origin, body, central)
        } else {
            let obs = observed_pose(
                &em.pose,
                nav,
                &line.nav_errors,
                em.t_line,
                Some(measure.get_or_insert_with(|| stream(Purpose::Measurement))),
            );
            let beam_obs = if nav.encoder_sigma_rad > 0.0 {
                let error = nav.encoder_sigma_rad
                    * measure
                        .get_or_insert_with(|| stream(Purpose::Measurement))
                        .normal();
                let observed = deflector.observed_direction(t, error);
                em.channel.turn(observed)
            } else {
                em.beam
            };
            // Without attitude errors the observed rotation is the true one,
            // to the bit: no need to compute it again.
            let a = (obs.attitude, em.pose.attitude);
            let obs_body = if [a.0.roll_rad, a.0.pitch_rad, a.0.yaw_rad].map(f64::to_bits)
                == [a.1.roll_rad, a.1.pitch_rad, a.1.yaw_rad].map(f64::to_bits)
            {
                body
            } else {
                obs.attitude.body_to_world()
            };
            // `Attitude::scanner_to_world` from that rotation.
            let dir = obs_body * SCANNER_TO_LEVEL_NORTH * beam_obs;
            (obs.position_m, obs_body, dir)
        };
        // Attributes shared by the pulse's points.
        let right = obs_body * DVec3::X;
        let right_h = DVec3::new(right.x, right.y, 0.0).normalize_or_zero();
        let scan_angle_deg = obs_central.dot(right_h).atan2(-obs_central.z).to_degrees();
        let scan_direction_positive = deflector.scan_direction_positive(t);
        // The next pulse's time from its own tick, exactly as it will be
        // computed for that pulse, so that the two agree on the direction.
        let t_next = line.start_time_s + (k + 1) as f64 / s.scanner.prf_hz;
        let edge = deflector.line_ends_between(t, t_next);
        let bin_s = s.receiver.bin_s;
        let scene = self.caster.scene();
        let n = scratch.echoes.len();

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
                &scratch.sources,
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
                        .zip(&scratch.sources)
                        .find(|(b, src)| src.prim == p && **b >= lo && **b < hi)
                        .filter(|(_, src)| src.normal.is_finite())
                        .map(|(_, src)| central.dot(src.normal).abs().min(1.0).acos().to_degrees());
                    let prim = &scene.primitives[p as usize];
                    let h = if prim.class == SurfaceClass::Vegetation {
                        self.height_above_ground(truth, MEDIUM_VEGETATION_MAX_M)
                            .unwrap_or(f64::INFINITY)
                    } else {
                        0.0
                    };
                    let component = match prim.shape {
                        Shape::Crown(_) => Component::Foliage,
                        Shape::Trunk(_) => Component::Trunk,
                        _ => Component::Surface,
                    };
                    (prim.class.asprs_code(h), Some(prim.object), component)
                }
                None => (NOISE_CLASS, None, Component::Surface),
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
                scan_direction_positive,
                channel: em.channel.index,
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

    /// Height of `p` above the ground-class surface beneath it, if one lies
    /// within `limit_m` below it (a vegetation point's class needs to know
    /// no more, and a short search stays among the primitives next to it).
    pub fn height_above_ground(&self, p: DVec3, limit_m: f64) -> Option<f64> {
        let ray = Ray {
            origin: p + DVec3::Z * 0.01,
            dir: -DVec3::Z,
        };
        let ground = |prim: &crate::scene::Primitive| prim.class.is_ground();
        match self.ground {
            Some(g) => g.closest_hit(&ray, 0.0, limit_m + 0.01),
            None => self
                .caster
                .closest_hit_where(&ray, 0.0, limit_m + 0.01, &ground),
        }
        .map(|h| h.t - 0.01)
    }
}
