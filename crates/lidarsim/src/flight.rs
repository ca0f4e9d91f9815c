//! A flight: the checked survey and its built world together, with what
//! follows from the two — the plan, the pulses of each line, every
//! warning — worked out once, so that every front end (the command line,
//! Python, Dask, the benchmark) asks the flight rather than working them
//! out again.

use std::path::Path;
use std::sync::Arc;

use crate::budget::Budget;
use crate::geometry::{Aabb, DVec3};
use crate::output::LasSettings;
use crate::plan::Plan;
use crate::sensor::platform::FlightLine;
use crate::survey::{Survey, SurveyError};
use crate::world::World;

/// A survey and its world, ready to fly.
pub struct Flight {
    survey: Arc<Survey>,
    world: Arc<World>,
    plan: Plan,
    /// Pulse slots of each flight line.
    line_pulses: Vec<u64>,
    /// The survey's warnings, the world's, then those of the survey over
    /// its scene.
    warnings: Vec<String>,
}

impl std::fmt::Debug for Flight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Flight")
            .field("world", &self.world)
            .field("pulses", &self.pulses())
            .finish_non_exhaustive()
    }
}

impl Flight {
    /// The flight of `survey` over `world`, its world (built from it, its
    /// lines perhaps changed since).
    pub fn new(survey: impl Into<Arc<Survey>>, world: impl Into<Arc<World>>) -> Self {
        let (survey, world) = (survey.into(), world.into());
        let plan = crate::plan::plan(&survey, &world);
        let line_pulses = world.lines.iter().map(|l| survey.pulses_of(l)).collect();
        let mut warnings = world.warnings_with(&survey);
        warnings.extend(crate::plan::warnings(&survey, &world, &plan));
        Self {
            survey,
            world,
            plan,
            line_pulses,
            warnings,
        }
    }

    /// Builds the world of `survey` ([`World::build`]) and its flight.
    pub fn build(survey: impl Into<Arc<Survey>>) -> Result<Self, SurveyError> {
        let survey = survey.into();
        let world = World::build(&survey)?;
        Ok(Self::new(survey, world))
    }

    /// Reads and checks the survey file at `path` (with `seed` in place of
    /// its own when given) and builds its flight ([`crate::world::load`]).
    pub fn load(path: &Path, seed: Option<u64>) -> Result<Self, SurveyError> {
        let (survey, world) = crate::world::load(path, seed)?;
        Ok(Self::new(survey, world))
    }

    /// The survey.
    pub fn survey(&self) -> &Survey {
        &self.survey
    }

    /// The survey, shared.
    pub fn shared_survey(&self) -> &Arc<Survey> {
        &self.survey
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The flight lines, in flight order.
    pub fn lines(&self) -> &[FlightLine] {
        &self.world.lines
    }

    /// The survey's expected figures over its scene.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Pulse slots of the whole flight (every tick of every line, a
    /// polygon's silent ones included).
    pub fn pulses(&self) -> u64 {
        self.line_pulses.iter().sum()
    }

    /// Pulse slots of each flight line.
    pub fn line_pulses(&self) -> &[u64] {
        &self.line_pulses
    }

    /// Every warning: the survey's (each at its key), the world's, then
    /// those of the survey over its scene ([`crate::plan::warnings`]).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// What a run on `threads` threads will cost ([`crate::budget`]).
    pub fn estimate(&self, threads: usize) -> Budget {
        crate::budget::estimate(&self.survey, &self.world, &self.line_pulses, threads)
    }

    /// The settings of the run's LAS files ([`crate::files::las_settings`]).
    pub fn las_settings(&self) -> LasSettings {
        crate::files::las_settings(&self.survey, &self.world)
    }

    /// The part of the scene the flight lines can see: each line's
    /// bounding box widened by half its swath and 10 m, within the scene's
    /// bounds (x, y); the area of the report's maps.
    pub fn covered_area(&self) -> Aabb {
        let scene = self.world.scene_bounds();
        let mut area = Aabb::EMPTY;
        for (line, lp) in self.lines().iter().zip(&self.plan.lines) {
            let m = DVec3::new(
                lp.swath_width_m / 2.0 + 10.0,
                lp.swath_width_m / 2.0 + 10.0,
                0.0,
            );
            area = area
                .union_point(line.start_m.min(line.end_m) - m)
                .union_point(line.start_m.max(line.end_m) + m);
        }
        if scene.is_empty() || area.is_empty() {
            return if scene.is_empty() { area } else { scene };
        }
        let min = area.min.max(scene.min);
        let max = area.max.min(scene.max);
        if min.x < max.x && min.y < max.y {
            Aabb { min, max }
        } else {
            scene
        }
    }
}
