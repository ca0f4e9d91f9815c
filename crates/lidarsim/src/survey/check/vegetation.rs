//! `[vegetation]`, `[[tree]]` and `[[forest]]`: how sub-rays march through
//! crowns, single trees and generated stands (placed on the ground by
//! [`crate::world`]).

use super::{Bounds, Checker, outline};
use crate::canopy::{CanopyConfig, Marching, ReturnModel};
use crate::message::num;
use crate::scene::forest::ForestSpec;
use crate::scene::{FoliageModel, FoliageSettings, Species, TreeSpec};
use crate::survey::spec::TreeTableEntry;
use crate::survey::{KeyPath, MAX_SPECIES_WEIGHT, MAX_TREES, MIN_TREE_HEIGHT_M, RawSurvey, raw};

/// Checks `[vegetation]`: the canopy march and how crowns are filled.
pub(crate) fn vegetation(c: &mut Checker, raw: &RawSurvey) -> (CanopyConfig, FoliageSettings) {
    let root = KeyPath::root();
    let v = &raw.vegetation;
    let vp = root.key("vegetation");
    let return_model = match v.return_model.as_deref() {
        None => ReturnModel::default(),
        Some(name) => ReturnModel::from_name(name).unwrap_or_else(|| {
            c.err(
                vp.key("return_model"),
                format!(
                    "unknown return model '{name}'; expected \"physical\" (the default) or \
                     \"specification\""
                ),
            );
            ReturnModel::default()
        }),
    };
    // Partial blocking removes energy the lottery already accounts for:
    // only the specification's model has it.
    let partial_blocking = match return_model {
        ReturnModel::Specification => c.number(
            vp.key("partial_blocking"),
            v.partial_blocking,
            0.5,
            Bounds::between(0.0, 10.0, ""),
        ),
        ReturnModel::Physical => {
            if v.partial_blocking.is_some() {
                c.err(
                    vp.key("partial_blocking"),
                    "applies only with return_model = \"specification\": in the physical \
                     model a sub-ray that passes the foliage keeps its energy (the \
                     interception lottery already removes what the foliage intercepts)",
                );
            }
            0.0
        }
    };
    let marching = match v.march.as_deref() {
        None => Marching::default(),
        Some(name) => Marching::from_name(name).unwrap_or_else(|| {
            c.err(
                vp.key("march"),
                format!(
                    "unknown march '{name}'; expected \"pulse\" (the default: all sub-rays \
                     of a pulse together) or \"sub-ray\" (the reference: each sub-ray with a \
                     lottery at every step)"
                ),
            );
            Marching::default()
        }),
    };
    let canopy = CanopyConfig {
        step_m: c.number(
            vp.key("step_m"),
            v.step_m,
            0.3,
            Bounds::between(0.01, 10.0, " m"),
        ),
        partial_blocking,
        return_model,
        marching,
    };
    let model = match v.foliage.as_deref() {
        None => FoliageModel::default(),
        Some(name) => FoliageModel::from_name(name).unwrap_or_else(|| {
            c.err(
                vp.key("foliage"),
                format!(
                    "unknown foliage model '{name}'; expected \"physical\" (the default) or \
                     \"specification\" (the specification's three factors)"
                ),
            );
            FoliageModel::default()
        }),
    };
    let d = FoliageSettings::default();
    let foliage = FoliageSettings {
        model,
        whorl_spacing_m: c.number(
            vp.key("whorl_spacing_m"),
            v.whorl_spacing_m,
            d.whorl_spacing_m,
            Bounds::above(0.0, " m").at_most(10.0),
        ),
        clump_m: c.number(
            vp.key("clump_m"),
            v.clump_m,
            d.clump_m,
            Bounds::between(0.01, 10.0, " m"),
        ),
        clump_fraction: c.number(
            vp.key("clump_fraction"),
            v.clump_fraction,
            d.clump_fraction,
            Bounds::above(0.0, "").at_most(1.0),
        ),
        shell_m: c.number(
            vp.key("shell_m"),
            v.shell_m,
            d.shell_m,
            Bounds::above(0.0, " m").at_most(1000.0),
        ),
    };
    (canopy, foliage)
}

/// Checks `[[tree]]` entries.
pub(crate) fn trees(c: &mut Checker, raw: &RawSurvey, seed: u64) -> Vec<(usize, TreeSpec)> {
    let root = KeyPath::root();
    let mut out = Vec::new();
    for (i, t) in raw.trees.iter().enumerate() {
        let tp = root.key("tree").index(i);
        if let Some(tree) = check_tree(c, &tp, t, seed, i) {
            out.push((i, tree));
        }
    }
    out
}

/// Checks `[[forest]]` entries, and that the survey's trees stay within
/// [`MAX_TREES`].
pub(crate) fn forests(c: &mut Checker, raw: &RawSurvey, seed: u64) -> Vec<Option<ForestSpec>> {
    let root = KeyPath::root();
    let mut planned = raw.trees.len() as f64;
    let mut out = Vec::new();
    for (i, f) in raw.forests.iter().enumerate() {
        let fp = root.key("forest").index(i);
        let Some(spec) = check_forest(c, &fp, f, seed, i) else {
            out.push(None);
            continue;
        };
        let hectares = crate::scene::forest::polygon_area(&spec.area) / 10_000.0;
        let stand = hectares * spec.stems_per_ha;
        planned += stand;
        if planned > MAX_TREES {
            c.err(
                fp.key("stems_per_ha"),
                format!(
                    "the stand would hold {} trees ({} ha at {} stems/ha), {} in the \
                     survey; a survey may hold at most {} trees",
                    num(stand.round()),
                    num(hectares),
                    num(spec.stems_per_ha),
                    num(planned.round()),
                    num(MAX_TREES)
                ),
            );
            out.push(None);
            continue;
        }
        out.push(Some(spec));
    }
    out
}

/// Checks `[[tree_table]]` entries: a CSV file each (read by the world),
/// an offset and a default species.
pub(crate) fn tree_tables(
    c: &mut Checker,
    raw: &RawSurvey,
    base: &std::path::Path,
    seed: u64,
) -> Vec<TreeTableEntry> {
    let mut out = Vec::new();
    for (index, t) in raw.tree_tables.iter().enumerate() {
        let tp = KeyPath::root().key("tree_table").index(index);
        let problems = c.problems.len();
        let offset_m = match &t.offset_m {
            None => Some(crate::geometry::DVec3::ZERO),
            some => c.point(tp.key("offset_m"), some),
        };
        let species = t.species.as_deref().and_then(|name| {
            let species = Species::from_name(name);
            if species.is_none() {
                c.err(
                    tp.key("species"),
                    format!("unknown species '{name}'; expected pine, spruce or birch"),
                );
            }
            species
        });
        if t.file.is_none() {
            c.err(
                tp.key("file"),
                "is required: a CSV file of trees, one a row (x_m, y_m, z_m, height_m, …)",
            );
        }
        if let (Some(file), Some(offset_m), true) =
            (&t.file, offset_m, c.problems.len() == problems)
        {
            out.push(TreeTableEntry {
                index,
                path: base.join(file),
                offset_m,
                species,
                survey_seed: seed,
            });
        }
    }
    out
}

/// Validates one `[[tree]]` entry.
fn check_tree(
    c: &mut Checker,
    tp: &KeyPath,
    t: &raw::RawTree,
    survey_seed: u64,
    index: usize,
) -> Option<TreeSpec> {
    let base = c.point(tp.key("position_m"), &t.position_m);
    let species = match t.species.as_deref() {
        None => {
            c.err(
                tp.key("species"),
                "is required: \"pine\", \"spruce\" or \"birch\"",
            );
            None
        }
        Some(name) => Species::from_name(name).or_else(|| {
            let names: Vec<&str> = Species::ALL.iter().map(|(n, _)| *n).collect();
            c.err(
                tp.key("species"),
                format!(
                    "unknown species '{name}'; expected one of: {}",
                    names.join(", ")
                ),
            );
            None
        }),
    };
    let required = |c: &mut Checker, key: &str, v: Option<f64>, what: &str| {
        if v.is_none() {
            c.err(tp.key(key), format!("is required: {what}"));
        }
    };
    required(c, "dbh_m", t.dbh_m, "diameter at breast height in metres");
    required(c, "height_m", t.height_m, "tree height in metres");
    required(
        c,
        "crown_base_m",
        t.crown_base_m,
        "height of the crown base in metres",
    );
    let dbh = c.number(
        tp.key("dbh_m"),
        t.dbh_m,
        0.2,
        Bounds::above(0.0, " m").at_most(5.0),
    );
    let problems_before = c.problems.len();
    let height = c.number(
        tp.key("height_m"),
        t.height_m,
        15.0,
        Bounds::between(MIN_TREE_HEIGHT_M, 150.0, " m"),
    );
    let height_ok = c.problems.len() == problems_before;
    let crown_base = c.number(
        tp.key("crown_base_m"),
        t.crown_base_m,
        5.0,
        Bounds::between(0.0, 150.0, " m"),
    );
    if height_ok && crown_base >= height {
        c.err(
            tp.key("crown_base_m"),
            format!("must be below the tree top ({height} m), got {crown_base}"),
        );
    }
    let (base, species) = (base?, species?);
    if t.dbh_m.is_none() || t.height_m.is_none() || t.crown_base_m.is_none() {
        return None;
    }
    let mut tree = TreeSpec::new(base, species, dbh, height, crown_base);
    tree.foliage_reflectance = c.number(
        tp.key("foliage_reflectance"),
        t.foliage_reflectance,
        tree.foliage_reflectance,
        Bounds::between(0.0, 1.0, ""),
    );
    tree.bark_reflectance = c.number(
        tp.key("bark_reflectance"),
        t.bark_reflectance,
        tree.bark_reflectance,
        Bounds::between(0.0, 1.0, ""),
    );
    tree.crown_radius_m = c.positive(
        tp.key("crown_radius_m"),
        t.crown_radius_m,
        tree.crown_radius_m,
        " m",
    );
    tree.extinction_per_m = t.extinction_per_m.map(|k| {
        c.number(
            tp.key("extinction_per_m"),
            Some(k),
            k,
            Bounds::between(0.0, 100.0, " 1/m"),
        )
    });
    tree.uniform_density = t.uniform_density.map(|d| {
        c.number(
            tp.key("uniform_density"),
            Some(d),
            0.5,
            Bounds::between(0.0, 1.0, ""),
        )
    });
    tree.seed = t.seed.unwrap_or_else(|| {
        crate::rng::entry_seed(survey_seed, crate::rng::Purpose::TreeSeed, index)
    });
    Some(tree)
}

/// Validates one `[[forest]]` entry.
fn check_forest(
    c: &mut Checker,
    fp: &KeyPath,
    f: &raw::RawForest,
    survey_seed: u64,
    index: usize,
) -> Option<ForestSpec> {
    let area = outline(c, fp, &f.rectangle_m, &f.area_m);
    if f.stems_per_ha.is_none() {
        c.err(
            fp.key("stems_per_ha"),
            "is required: stem density in trees per hectare",
        );
    }
    let stems = c.number(
        fp.key("stems_per_ha"),
        f.stems_per_ha,
        500.0,
        Bounds::above(0.0, " /ha").at_most(20_000.0),
    );
    let mix: Vec<(Species, f64)> = match &f.species {
        None => vec![(Species::Pine, 1.0)],
        Some(m) => {
            let mut mix = Vec::new();
            for (name, w) in m {
                match Species::from_name(name) {
                    Some(s) if *w > 0.0 && *w <= MAX_SPECIES_WEIGHT => mix.push((s, *w)),
                    Some(_) => c.err(
                        fp.key("species").key(name),
                        format!(
                            "weight must be greater than 0 and at most {} (weights are relative \
                             shares), got {}",
                            num(MAX_SPECIES_WEIGHT),
                            num(*w)
                        ),
                    ),
                    None => c.err(
                        fp.key("species").key(name),
                        format!("unknown species '{name}'; expected pine, spruce or birch"),
                    ),
                }
            }
            if m.is_empty() {
                c.err(fp.key("species"), "names no species");
            }
            mix
        }
    };
    let heights = match &f.height_m {
        None => (15.0, 25.0),
        Some(h) if h.len() == 2 && h[0] >= MIN_TREE_HEIGHT_M && h[1] >= h[0] && h[1] <= 150.0 => {
            (h[0], h[1])
        }
        Some(_) => {
            c.err(
                fp.key("height_m"),
                "must be [smallest, largest] tree height in metres, from 2 to 150 m, smallest first",
            );
            (15.0, 25.0)
        }
    };
    let min_spacing_m = c.number(
        fp.key("min_spacing_m"),
        f.min_spacing_m,
        1.0,
        Bounds::between(0.0, 100.0, " m"),
    );
    let seed = f.seed.unwrap_or_else(|| {
        crate::rng::entry_seed(survey_seed, crate::rng::Purpose::ForestSeed, index)
    });
    if mix.is_empty() {
        return None;
    }
    Some(ForestSpec {
        area: area?,
        stems_per_ha: stems,
        mix,
        height_range_m: heights,
        min_spacing_m,
        seed,
    })
}
