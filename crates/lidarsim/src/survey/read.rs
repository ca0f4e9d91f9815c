//! The first stage: survey text into its raw form. A TOML syntax error
//! stops at once; unknown keys and values of the wrong type anywhere in the
//! file are each reported, the offending key set aside and the rest read
//! again, so that every such problem shows at once.

use crate::message::edit_distance;

use super::diagnostic::{Diagnose, Diagnostic, SurveyError, diagnostics_in_file_order};
use super::{KeyPath, Locator, RawSurvey, Seg};

/// Splits a serde message into what the user reads and a hint: an unknown
/// field gets "did you mean" when one of the expected names is within two
/// edits of the one given (otherwise the list of valid names); Rust type
/// names become TOML words.
pub(crate) fn explain(message: &str) -> (String, Option<String>) {
    let message = message.trim();
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some((given, expected)) = rest.split_once('`')
    {
        let names: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
        let best = names
            .iter()
            .map(|name| (edit_distance(given, name), *name))
            .min();
        let help = match best {
            Some((d, name)) if d <= 2 => format!("did you mean `{name}`?"),
            _ if names.is_empty() => "this table takes no keys".to_string(),
            _ => format!("valid keys here: {}", names.join(", ")),
        };
        return (format!("unknown field `{given}`"), Some(help));
    }
    let mut m = message.to_string();
    for (rust, toml) in [
        ("expected f64", "expected a number"),
        ("expected u64", "expected a non-negative integer"),
        ("expected i64", "expected an integer"),
        ("expected a sequence", "expected an array"),
        ("expected a boolean", "expected true or false"),
    ] {
        m = m.replace(rust, toml);
    }
    if let Some(at) = m.find("expected struct Raw") {
        m.replace_range(at.., "expected a table");
    }
    if let Some(rest) = m.strip_prefix("invalid type: integer `")
        && let Some((n, _)) = rest.split_once("` as i128")
    {
        m = format!(
            "integer {n} is too large: TOML integers are 64-bit (up to 9223372036854775807)"
        );
    }
    // serde writes a float of the wrong type out in full: 1e300 as 301
    // digits.
    if let Some(rest) = m.strip_prefix("invalid type: floating point `")
        && let Some((v, tail)) = rest.split_once('`')
        && let Ok(v) = v.parse::<f64>()
    {
        m = format!(
            "invalid type: floating point `{}`{tail}",
            crate::message::num(v)
        );
    }
    if m.contains("did not match any variant of untagged enum NumberOrList") {
        m = "expected a number or an array of numbers".to_string();
    }
    (m, None)
}

/// Most problems of structure (unknown keys, wrong types) collected before
/// giving up on a file.
const MAX_READ_PROBLEMS: usize = 100;

/// Our key path of a serde path.
fn key_path_of(path: &serde_path_to_error::Path) -> KeyPath {
    use serde_path_to_error::Segment;
    let mut k = KeyPath::root();
    for seg in path.iter() {
        k = match seg {
            Segment::Map { key } => k.key(key),
            Segment::Seq { index } => k.index(*index),
            Segment::Enum { .. } | Segment::Unknown => k,
        };
    }
    k
}

/// Removes the table key nearest to the end of `path` (the whole key of an
/// array element) and returns its path, or `None` when there is none.
fn remove_key(table: &mut toml::Table, path: &KeyPath) -> Option<KeyPath> {
    let last = path.0.iter().rposition(|s| matches!(s, Seg::Key(_)))?;
    let Seg::Key(name) = &path.0[last] else {
        return None;
    };
    let mut t = table;
    let mut segs = &path.0[..last];
    while let Some((Seg::Key(k), rest)) = segs.split_first() {
        let mut v = t.get_mut(k)?;
        let mut rest = rest;
        while let Some((Seg::Index(i), r)) = rest.split_first() {
            v = v.as_array_mut()?.get_mut(*i)?;
            rest = r;
        }
        t = v.as_table_mut()?;
        segs = rest;
    }
    if !segs.is_empty() {
        return None;
    }
    t.remove(name)?;
    Some(KeyPath(path.0[..=last].to_vec()))
}

/// Reads `text` into a raw survey, with the diagnostics of the keys set
/// aside and their paths (problems found later under them are not
/// reported again). A syntax error, or too many problems of structure,
/// gives the error at once.
pub(crate) fn read_raw(
    text: &str,
    locator: &Locator,
    diagnose: &Diagnose<'_>,
) -> Result<(RawSurvey, Vec<Diagnostic>, Vec<KeyPath>), SurveyError> {
    let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let span = e.span().unwrap_or(0..0);
        let key = locator.path_at(&span);
        let (message, help) = explain(e.message());
        SurveyError {
            diagnostics: vec![diagnose.at(&key, Some(span), message, help)],
        }
    })?;
    let mut diagnostics = Vec::new();
    let mut set_aside: Vec<KeyPath> = Vec::new();
    loop {
        let value = toml::Value::Table(table.clone());
        match serde_path_to_error::deserialize::<_, RawSurvey>(value) {
            Ok(raw) => return Ok((raw, diagnostics, set_aside)),
            Err(e) => {
                let path = key_path_of(e.path());
                let (message, help) = explain(e.inner().message());
                let span = if help.is_some() {
                    locator.key_span_of(&path)
                } else {
                    locator.span_of(&path)
                };
                diagnostics.push(diagnose.at(&path, span, message, help));
                match remove_key(&mut table, &path) {
                    Some(removed) if diagnostics.len() < MAX_READ_PROBLEMS => {
                        set_aside.push(removed)
                    }
                    _ => return Err(diagnostics_in_file_order(diagnostics)),
                }
            }
        }
    }
}
