//! Tree tables: CSV files of trees, one a row, that a survey names in
//! `[[tree_table]]` (what `lidarsim twin` writes, for tens of thousands of
//! trees that a user can edit in a spreadsheet).
//!
//! The first line that is neither blank nor a comment (`#`) names the
//! columns: `x_m`, `y_m`, `z_m` (the stem base) and `height_m` are
//! required; `species`, `dbh_m`, `crown_base_m`, `crown_radius_m`,
//! `foliage_reflectance`, `bark_reflectance`, `extinction_per_m`,
//! `uniform_density` and `seed` are the `[[tree]]` keys of the same names,
//! each optional (an empty field takes the default); `id` is the user's
//! and is not read. A value out of the `[[tree]]` key's range is an error
//! that names the file, the line, the column and its name.

use std::path::Path;

use crate::geometry::DVec3;
use crate::message::num;
use crate::scene::{Species, TreeSpec};

/// Most rows of a tree table (the trees a survey may hold).
pub const MAX_ROWS: usize = 5_000_000;

/// The columns a tree table may have, in the order `lidarsim twin`
/// writes them.
pub const COLUMNS: [&str; 14] = [
    "id",
    "x_m",
    "y_m",
    "z_m",
    "species",
    "height_m",
    "crown_base_m",
    "crown_radius_m",
    "dbh_m",
    "foliage_reflectance",
    "bark_reflectance",
    "extinction_per_m",
    "uniform_density",
    "seed",
];

/// How a table's rows are read: its offset, default species and seed.
#[derive(Clone, Copy, Debug)]
pub struct TableSettings {
    /// Added to every position, m.
    pub offset_m: DVec3,
    /// Species of rows that name none.
    pub species: Option<Species>,
    /// Seed of the rows without a `seed` column or value.
    pub seed: u64,
}

/// Why a tree table could not be read: the message names the file and,
/// where there is one, the line, the column and its name.
#[derive(Debug, thiserror::Error)]
#[error("'{path}'{at}: {reason}")]
pub struct TreeTableError {
    /// The file.
    pub path: std::path::PathBuf,
    /// ` line L` or ` line L, column C (name)`, or nothing.
    pub at: String,
    /// What is wrong.
    pub reason: String,
}

/// Reads the trees of a tree table.
pub fn read_tree_table(
    path: &Path,
    settings: &TableSettings,
) -> Result<Vec<TreeSpec>, TreeTableError> {
    let fail = |at: String, reason: String| TreeTableError {
        path: path.to_path_buf(),
        at,
        reason,
    };
    let bytes = crate::io::input::read_input(path, crate::io::input::MAX_INPUT_BYTES)
        .map_err(|e| fail(String::new(), format!("cannot read the tree table: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        fail(
            format!(" line {line}"),
            "not valid UTF-8: a tree table is a CSV text file".into(),
        )
    })?;
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((header_line, header)) = rows.next() else {
        return Err(fail(
            String::new(),
            "holds no header line: name the columns, e.g. x_m,y_m,z_m,height_m".into(),
        ));
    };
    let columns = Columns::parse(header)
        .map_err(|(col, why)| fail(format!(" line {header_line}, column {col}"), why))?;
    let mut trees = Vec::new();
    for (line, row) in rows {
        if trees.len() == MAX_ROWS {
            return Err(fail(
                format!(" line {line}"),
                format!("more than {MAX_ROWS} trees, the most a survey may hold"),
            ));
        }
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != columns.names.len() {
            return Err(fail(
                format!(" line {line}"),
                format!(
                    "{} fields, but the header names {} columns",
                    fields.len(),
                    columns.names.len()
                ),
            ));
        }
        let tree = columns
            .tree(&fields, settings, trees.len())
            .map_err(|(col, why)| {
                let name = columns.names[col];
                fail(format!(" line {line}, column {} ({name})", col + 1), why)
            })?;
        trees.push(tree);
    }
    Ok(trees)
}

/// The header: each column's name, by position.
struct Columns<'a> {
    names: Vec<&'a str>,
}

/// A problem at a column (0-based) of a row.
type CellError = (usize, String);

impl<'a> Columns<'a> {
    /// The header's columns, each known and given once, the required ones
    /// among them. Errors name the column (1-based).
    fn parse(header: &'a str) -> Result<Self, (usize, String)> {
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        for (i, name) in names.iter().enumerate() {
            if !COLUMNS.contains(name) {
                let near = COLUMNS
                    .iter()
                    .filter(|c| crate::message::edit_distance(c, name) <= 2)
                    .min_by_key(|c| crate::message::edit_distance(c, name))
                    .map(|c| format!(" (did you mean `{c}`?)"))
                    .unwrap_or_default();
                return Err((
                    i + 1,
                    format!(
                        "unknown column `{name}`{near}; a tree table has the columns {}",
                        COLUMNS.join(", ")
                    ),
                ));
            }
            if names[..i].contains(name) {
                return Err((i + 1, format!("column `{name}` is named twice")));
            }
        }
        for needed in ["x_m", "y_m", "z_m", "height_m"] {
            if !names.contains(&needed) {
                return Err((
                    names.len(),
                    format!(
                        "the header has no column `{needed}` (x_m, y_m, z_m and height_m are \
                         required)"
                    ),
                ));
            }
        }
        Ok(Self { names })
    }

    /// The column of `name`, if the table has it.
    fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| *n == name)
    }

    /// The number in column `name` of `fields` within `[lo, hi]`, or
    /// `None` for a column the table lacks or an empty field.
    fn number(
        &self,
        fields: &[&str],
        name: &str,
        (lo, lo_open, hi): (f64, bool, f64),
    ) -> Result<Option<f64>, CellError> {
        let Some(col) = self.find(name) else {
            return Ok(None);
        };
        let text = fields[col];
        if text.is_empty() {
            return Ok(None);
        }
        let v: f64 = text
            .parse()
            .map_err(|_| (col, format!("'{text}' is not a number")))?;
        let below = if lo_open { v <= lo } else { v < lo };
        if !v.is_finite() || below || v > hi {
            let from = if lo_open { "above" } else { "from" };
            return Err((
                col,
                format!("must be {from} {} to {}, got {}", num(lo), num(hi), num(v)),
            ));
        }
        Ok(Some(v))
    }

    /// The required number in column `name`.
    fn required(
        &self,
        fields: &[&str],
        name: &str,
        range: (f64, bool, f64),
    ) -> Result<f64, CellError> {
        let col = self.find(name).unwrap_or(0);
        self.number(fields, name, range)?
            .ok_or_else(|| (col, "is empty: a number is required".to_string()))
    }

    /// The tree of one row (`row`: its number among the trees, for its
    /// default seed).
    fn tree(
        &self,
        fields: &[&str],
        settings: &TableSettings,
        row: usize,
    ) -> Result<TreeSpec, CellError> {
        let coordinate = (
            -crate::geometry::MAX_COORDINATE_M,
            false,
            crate::geometry::MAX_COORDINATE_M,
        );
        let base = DVec3::new(
            self.required(fields, "x_m", coordinate)?,
            self.required(fields, "y_m", coordinate)?,
            self.required(fields, "z_m", coordinate)?,
        ) + settings.offset_m;
        let species = self.species(fields, settings)?;
        let height_col = self.find("height_m").unwrap_or(0);
        let height = self.required(
            fields,
            "height_m",
            (crate::scene::tree::MIN_TREE_HEIGHT_M, false, 150.0),
        )?;
        let dbh = match self.number(fields, "dbh_m", (0.0, true, 5.0))? {
            Some(d) => d,
            None => species.dbh_or_nearest_m(height),
        };
        let crown_base = match self.number(fields, "crown_base_m", (0.0, false, 150.0))? {
            Some(b) if b >= height => {
                let col = self.find("crown_base_m").unwrap_or(height_col);
                return Err((
                    col,
                    format!(
                        "must be below the tree top ({} m), got {}",
                        num(height),
                        num(b)
                    ),
                ));
            }
            Some(b) => b,
            None => height * (1.0 - species.preset().crown_ratio),
        };
        let mut tree = TreeSpec::new(base, species, dbh, height, crown_base);
        let set = |v: Option<f64>, into: &mut f64| {
            if let Some(v) = v {
                *into = v;
            }
        };
        set(
            self.number(fields, "crown_radius_m", (0.0, true, 100.0))?,
            &mut tree.crown_radius_m,
        );
        set(
            self.number(fields, "foliage_reflectance", (0.0, false, 1.0))?,
            &mut tree.foliage_reflectance,
        );
        set(
            self.number(fields, "bark_reflectance", (0.0, false, 1.0))?,
            &mut tree.bark_reflectance,
        );
        if let Some(k) = self.number(fields, "extinction_per_m", (0.0, false, 100.0))? {
            tree.extinction_per_m = Some(k);
        }
        tree.uniform_density = self.number(fields, "uniform_density", (0.0, false, 1.0))?;
        tree.seed = match self.find("seed").map(|c| (c, fields[c])) {
            Some((c, text)) if !text.is_empty() => text
                .parse::<u64>()
                .ok()
                .filter(|s| *s <= i64::MAX as u64)
                .ok_or_else(|| {
                    (
                        c,
                        format!(
                            "'{text}' is not a seed (a whole number from 0 to {})",
                            i64::MAX
                        ),
                    )
                })?,
            _ => crate::rng::entry_seed(settings.seed, crate::rng::Purpose::TreeTableSeed, row),
        };
        Ok(tree)
    }

    /// The row's species, else the table's.
    fn species(&self, fields: &[&str], settings: &TableSettings) -> Result<Species, CellError> {
        let column = self.find("species").map(|c| (c, fields[c]));
        match column {
            Some((c, name)) if !name.is_empty() => Species::from_name(name).ok_or_else(|| {
                (
                    c,
                    format!("unknown species '{name}'; expected pine, spruce or birch"),
                )
            }),
            _ => settings.species.ok_or_else(|| {
                (
                    column.map_or(0, |(c, _)| c),
                    "names no species: give a `species` column or the table's `species` key"
                        .to_string(),
                )
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("lidarsim-tree-table-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const SETTINGS: TableSettings = TableSettings {
        offset_m: DVec3::new(100.0, 200.0, 0.0),
        species: Some(Species::Spruce),
        seed: 5,
    };

    /// Rows read as the `[[tree]]` entries with the same keys would be,
    /// defaults from the species where a value is missing.
    #[test]
    fn rows_read_with_their_defaults() {
        let p = write(
            "good.csv",
            "# trees\nid,x_m,y_m,z_m,species,height_m,crown_base_m,crown_radius_m\n\
             7,1.5,2,3,pine,20,8,2.5\n8,4,5,6,,12,,\n",
        );
        let trees = read_tree_table(&p, &SETTINGS).unwrap();
        assert_eq!(trees.len(), 2);
        let a = &trees[0];
        assert_eq!(a.base_m, DVec3::new(101.5, 202.0, 3.0));
        assert_eq!(
            (a.species, a.height_m, a.crown_base_m),
            (Species::Pine, 20.0, 8.0)
        );
        assert_eq!(a.crown_radius_m, 2.5);
        // dbh from the height curve: it gives the height back.
        assert!((Species::Pine.height_from_dbh_m(a.dbh_m) - 20.0).abs() < 1e-6);
        let b = &trees[1];
        assert_eq!(b.species, Species::Spruce);
        // Crown base from the species' live crown ratio (spruce 0.70).
        assert!((b.crown_base_m - 12.0 * 0.3).abs() < 1e-9);
        assert_eq!(b.crown_radius_m, Species::Spruce.crown_radius_m(b.dbh_m));
        assert_ne!(a.seed, b.seed);
    }

    /// Each problem names the line, the column and its name.
    #[test]
    fn problems_name_line_and_column() {
        let header = "x_m,y_m,z_m,height_m,crown_base_m\n";
        for (body, wanted) in [
            (
                "1,2,3,abc,1\n",
                "line 2, column 4 (height_m): 'abc' is not a number",
            ),
            (
                "1,2,3,1,0.5\n",
                "line 2, column 4 (height_m): must be from 2 to 150, got 1",
            ),
            (
                "1,2,3,10,12\n",
                "line 2, column 5 (crown_base_m): must be below the tree top",
            ),
            (
                "1,2,3\n",
                "line 2: 3 fields, but the header names 5 columns",
            ),
            ("1,2,,10,1\n", "line 2, column 3 (z_m): is empty"),
        ] {
            let p = write("bad.csv", &format!("{header}{body}"));
            let e = read_tree_table(&p, &SETTINGS).unwrap_err().to_string();
            assert!(e.contains(wanted) && e.contains("bad.csv"), "{e}");
        }
        let p = write("bad.csv", "x_m,y_m,z_m,hieght_m\n");
        let e = read_tree_table(&p, &SETTINGS).unwrap_err().to_string();
        assert!(
            e.contains("column 4") && e.contains("did you mean `height_m`"),
            "{e}"
        );
        let p = write("bad.csv", "x_m,y_m,z_m\n");
        let e = read_tree_table(&p, &SETTINGS).unwrap_err().to_string();
        assert!(e.contains("no column `height_m`"), "{e}");
        let p = write("bad.csv", "x_m,y_m,z_m,height_m\n1,2,3,10\n");
        let none = TableSettings {
            species: None,
            ..SETTINGS
        };
        let e = read_tree_table(&p, &none).unwrap_err().to_string();
        assert!(e.contains("names no species"), "{e}");
    }
}
