//! The fine samples of a pattern's cells, worked out once.
//!
//! A refined cell is sampled by its fineness's jittered grid mapped onto
//! it ([`super::BeamPattern::fine_samples`]). The grid and the cell belong
//! to the pattern, so each sample's point, direction and irradiance are
//! the same every time the cell is refined: they are worked out the first
//! time a fineness is asked for, for every cell of the pattern, and then
//! read. Only what is read is worked out (most surveys use one fineness,
//! and a survey without stems none).

use std::sync::OnceLock;

use super::PlanePoint;
use crate::geometry::DVec3;

/// One fine sample of a cell.
#[derive(Clone, Copy, Debug)]
pub(super) struct FineSample {
    /// Its point in the pattern's plane.
    pub x: PlanePoint,
    /// The undeflected unit direction through it.
    pub dir: DVec3,
    /// The beam's relative irradiance there.
    pub weight: f64,
}

/// Per fineness, the fine samples of every cell, cell after cell, each
/// cell's as many as the fineness's grid has points.
#[derive(Clone, Debug, Default)]
pub(super) struct FineTables([OnceLock<Vec<FineSample>>; 3]);

impl FineTables {
    /// The samples of cell `cell` at fineness index `f` (`per_cell` to a
    /// cell), worked out for every cell by `make` the first time.
    pub(super) fn get(
        &self,
        f: usize,
        cell: usize,
        per_cell: usize,
        make: impl FnOnce() -> Vec<FineSample>,
    ) -> &[FineSample] {
        let all = self.0[f].get_or_init(make);
        &all[cell * per_cell..(cell + 1) * per_cell]
    }
}

/// The tables are worked out from the pattern's other fields, whose
/// equality they follow whether they have been worked out yet or not.
impl PartialEq for FineTables {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}
