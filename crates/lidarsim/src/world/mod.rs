//! The third and fourth stages: a checked [`Survey`]'s scene built from
//! the files it names (readers in [`crate::io`]), indexed once, its forests
//! placed on the ground, and its flight lines planned over that ground.
//!
//! A [`World`] owns the scene (inside its index, in leaf order) and the
//! flight lines; the survey stays settings. Problems found here — a file
//! that cannot be read, a scene beyond the coordinate limit, a LAS scale
//! too fine for it — are reported as the survey's diagnostics, at the keys
//! that named them.

mod lines;
pub use lines::{MAX_TILES, reachable_area, tiles_over};
mod scene;

use std::path::Path;

use crate::accel::{Bvh, RayCaster};
use crate::scene::Scene;
use crate::sensor::platform::FlightLine;
use crate::survey::{KeyPath, Survey, SurveyError};

/// Reads and checks the survey file at `path` (with `seed` in place of its
/// own when given), then builds its world: the two stages a run starts
/// with. Problems of the file itself are reported first, all at once;
/// problems of the files it names, once it is free of them.
pub fn load(path: &Path, seed: Option<u64>) -> Result<(Survey, World), SurveyError> {
    let survey = Survey::load_with_seed(path, seed)?;
    let world = World::build(&survey)?;
    Ok((survey, world))
}

/// [`load`] for survey text; `path` names it in messages and resolves the
/// files it names.
pub fn from_toml(text: &str, path: Option<&Path>) -> Result<(Survey, World), SurveyError> {
    let survey = Survey::from_toml(text, path)?;
    let world = World::build(&survey)?;
    Ok((survey, world))
}

/// The scene of a survey, indexed, and its flight lines.
pub struct World {
    index: Bvh,
    /// The ground-class surfaces indexed apart, when the scene has
    /// vegetation: the class of a vegetation point depends on the ground
    /// below it, which a search among the ground alone finds at once.
    ground: Option<Bvh>,
    /// Flight lines in flight order.
    pub lines: Vec<FlightLine>,
    /// Trees placed by each `[[forest]]` entry.
    pub forest_trees: Vec<usize>,
    /// Things that are allowed but probably not what was meant, found while
    /// building (a stand with less room than its density asks for).
    pub warnings: Vec<String>,
    /// Time spent building the index, s.
    pub index_time_s: f64,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("primitives", &self.index.scene().primitives.len())
            .field("lines", &self.lines.len())
            .finish_non_exhaustive()
    }
}

impl World {
    /// Builds the world of `survey`: reads its files, builds and indexes
    /// the scene, places its forests and plans its lines. Every problem is
    /// reported at once, at the survey's keys.
    pub fn build(survey: &Survey) -> Result<Self, SurveyError> {
        let mut problems: Vec<(KeyPath, String)> = Vec::new();
        let built = scene::build(survey, &mut problems);
        let lines = lines::flight_lines(survey, &built.index, &mut problems);
        lines::check_las_scale(survey, built.index.scene_bounds(), &lines, &mut problems);
        lines::check_tiles(survey, built.index.scene_bounds(), &lines, &mut problems);
        lines::check_times(survey, &lines, &mut problems);
        if built.index.scene().primitives.is_empty() && problems.is_empty() {
            problems.push((
                KeyPath::root(),
                "the scene is empty: add [[polygon]], [[mesh]], [[terrain]], [[point_cloud]], \
                 [[tree]] or [[forest]] entries for the laser to hit"
                    .to_string(),
            ));
        }
        if !problems.is_empty() {
            return Err(survey.diagnose(problems));
        }
        let ground = ground_index(built.index.scene());
        Ok(World {
            index: built.index,
            ground,
            lines,
            forest_trees: built.forest_trees,
            warnings: built.warnings,
            index_time_s: built.index_time_s,
        })
    }

    /// The index of the scene (its closest-hit queries).
    pub fn index(&self) -> &Bvh {
        &self.index
    }

    /// The index of the ground-class surfaces alone, when the scene has
    /// vegetation (whose points' classes depend on the ground below them).
    pub fn ground_index(&self) -> Option<&Bvh> {
        self.ground.as_ref()
    }

    /// The scene, in the index's order.
    pub fn scene(&self) -> &Scene {
        self.index.scene()
    }

    /// The scene's bounding box ([`Scene::bounds`], kept from the index's
    /// build: a scene of millions of primitives is not walked again).
    pub fn scene_bounds(&self) -> crate::geometry::Aabb {
        self.index.scene_bounds()
    }

    /// The survey's warnings followed by the world's.
    pub fn warnings_with(&self, survey: &Survey) -> Vec<String> {
        let mut w = survey.warnings.clone();
        w.extend(self.warnings.iter().cloned());
        w
    }
}

/// The index of `scene`'s ground-class surfaces, if the scene has
/// vegetation.
fn ground_index(scene: &Scene) -> Option<Bvh> {
    use crate::scene::SurfaceClass;
    if !scene
        .primitives
        .iter()
        .any(|p| p.class == SurfaceClass::Vegetation)
    {
        return None;
    }
    let ground = Scene {
        primitives: scene
            .primitives
            .iter()
            .filter(|p| p.class.is_ground())
            .cloned()
            .collect(),
        materials: scene.materials.clone(),
        objects: Vec::new(),
    };
    Some(Bvh::build(ground))
}

#[cfg(test)]
mod tests;
