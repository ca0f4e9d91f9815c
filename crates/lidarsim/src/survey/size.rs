//! The size of a survey's text, bounded before it is parsed: a TOML reader
//! holds every value of an array as a tree node of its own (a 31 MB
//! `reflectance_spectrum` of two million pairs took 2 GB), so the text's
//! length and the items of its arrays are counted by a lexical scan first,
//! which allocates nothing per item. Bulk data belongs in the files a
//! survey names (meshes, rasters, clouds, trajectories), not in the survey.

use super::diagnostic::{Diagnostic, SurveyError};

/// Largest survey text, bytes.
pub const MAX_SURVEY_BYTES: usize = crate::io::input::MAX_SURVEY_BYTES as usize;

/// Most items in one array of a survey (a polygon's vertices, a
/// spectrum's pairs, a stand's outline).
pub const MAX_ARRAY_ITEMS: usize = 100_000;

/// Most array items in a whole survey.
pub const MAX_ARRAY_ITEMS_TOTAL: usize = 500_000;

/// An array being scanned.
struct Open {
    /// Items so far.
    items: usize,
    /// Whether the next non-blank character starts an item.
    want_item: bool,
    /// Where it opened: line (1-based) and the key it is the value of.
    line: usize,
    key: String,
}

/// What encloses the scanner's position.
enum Frame {
    Array(Open),
    InlineTable,
}

/// Refuses survey text longer than [`MAX_SURVEY_BYTES`], with an array of
/// more than [`MAX_ARRAY_ITEMS`] items, or with more than
/// [`MAX_ARRAY_ITEMS_TOTAL`] array items in all; the problem names `file`,
/// the line where the array opens and its key. Text the scan cannot follow
/// (a TOML syntax error) passes: the parser reports it.
pub fn check(text: &str, file: &str) -> Result<(), SurveyError> {
    let refused = |d: Diagnostic| SurveyError {
        diagnostics: vec![d],
    };
    if text.len() > MAX_SURVEY_BYTES {
        return Err(refused(Diagnostic::file_level(
            file,
            0,
            format!(
                "the survey is {} bytes, more than the {MAX_SURVEY_BYTES} bytes a survey may \
                 hold: give bulk data as files the survey names (meshes, rasters, point clouds, \
                 trajectories)",
                text.len()
            ),
        )));
    }
    Scan::new(text.as_bytes(), file)
        .run()
        .map(|_| ())
        .map_err(|d| refused(*d))
}

/// The lexical scan of [`check`].
struct Scan<'a> {
    b: &'a [u8],
    i: usize,
    line: usize,
    file: &'a str,
    frames: Vec<Frame>,
    /// After `=` outside any array: a `[` opens an array, not a table.
    after_equals: bool,
    /// The key of the last `key =` at the top level or in an inline table,
    /// with its table's header.
    key: String,
    /// The header of the table the scan is in.
    table: String,
    /// Entries of each array of tables so far.
    entries: std::collections::HashMap<String, usize>,
    /// Where the current line started.
    line_start: usize,
    total: usize,
}

impl<'a> Scan<'a> {
    fn new(b: &'a [u8], file: &'a str) -> Self {
        Self {
            b,
            i: 0,
            line: 1,
            file,
            frames: Vec::new(),
            after_equals: false,
            key: String::new(),
            table: String::new(),
            entries: std::collections::HashMap::new(),
            line_start: 0,
            total: 0,
        }
    }

    /// Scans the whole text; the array items in all.
    fn run(mut self) -> Result<usize, Box<Diagnostic>> {
        while self.i < self.b.len() {
            let c = self.b[self.i];
            if !matches!(c, b' ' | b'\t' | b'\r' | b'\n' | b'#' | b']' | b'}' | b',') {
                self.item()?;
            }
            match c {
                b'\n' => self.newline(),
                b'#' => self.skip_comment(),
                b'"' | b'\'' => self.skip_string(c),
                b'[' => self.open_bracket(),
                b']' => {
                    if let Some(Frame::Array(_)) = self.frames.last() {
                        self.frames.pop();
                    }
                }
                b'{' => {
                    self.frames.push(Frame::InlineTable);
                    self.after_equals = false;
                }
                b'}' => {
                    if let Some(Frame::InlineTable) = self.frames.last() {
                        self.frames.pop();
                    }
                }
                b',' => {
                    if let Some(Frame::Array(a)) = self.frames.last_mut() {
                        a.want_item = true;
                    } else {
                        self.after_equals = false;
                    }
                }
                b'=' if !matches!(self.frames.last(), Some(Frame::Array(_))) => {
                    let start = self.key_start();
                    let key = String::from_utf8_lossy(&self.b[start..self.i]);
                    self.key = match (self.table.as_str(), key.trim()) {
                        ("", key) => key.to_string(),
                        (table, key) => format!("{table}.{key}"),
                    };
                    self.after_equals = true;
                }
                _ => {}
            }
            self.i += 1;
        }
        Ok(self.total)
    }

    /// Counts an item if the innermost array wants one.
    fn item(&mut self) -> Result<(), Box<Diagnostic>> {
        let Some(Frame::Array(a)) = self.frames.last_mut() else {
            return Ok(());
        };
        if !a.want_item {
            return Ok(());
        }
        a.want_item = false;
        a.items += 1;
        self.total += 1;
        if a.items > MAX_ARRAY_ITEMS {
            let (line, key) = (a.line, a.key.clone());
            return Err(self.refuse(
                line,
                &key,
                format!(
                    "the array holds more than {MAX_ARRAY_ITEMS} items, the most a survey array \
                     may hold"
                ),
            ));
        }
        if self.total > MAX_ARRAY_ITEMS_TOTAL {
            let (line, key) = (a.line, a.key.clone());
            return Err(self.refuse(
                line,
                &key,
                format!(
                    "the survey's arrays hold more than {MAX_ARRAY_ITEMS_TOTAL} items in all, \
                     the most a survey may hold"
                ),
            ));
        }
        Ok(())
    }

    /// The problem of an array too large, opened at `line` as the value of
    /// `key`.
    fn refuse(&self, line: usize, key: &str, why: String) -> Box<Diagnostic> {
        let mut d = Diagnostic::file_level(
            self.file,
            line,
            format!(
                "{why}: give bulk data as files the survey names (meshes, rasters, point clouds, trajectories)"
            ),
        );
        d.key = key.to_string();
        Box::new(d)
    }

    /// Where the key before the `=` at `self.i` begins: after the last
    /// `{` or `,` of an inline table, or at the start of the line.
    fn key_start(&self) -> usize {
        let mut j = self.i;
        while j > self.line_start && !matches!(self.b[j - 1], b'{' | b',') {
            j -= 1;
        }
        j
    }

    fn newline(&mut self) {
        self.line += 1;
        self.line_start = self.i + 1;
        if self.frames.is_empty() {
            self.after_equals = false;
        }
    }

    /// `[` opens an array in a value, else a table header, skipped to the
    /// end of its line.
    fn open_bracket(&mut self) {
        let in_array = matches!(self.frames.last(), Some(Frame::Array(_)));
        if in_array || self.after_equals {
            self.frames.push(Frame::Array(Open {
                items: 0,
                want_item: true,
                line: self.line,
                key: self.key.clone(),
            }));
            self.after_equals = false;
            return;
        }
        let start = self.i;
        let mut end = self.i;
        while self.i + 1 < self.b.len() && self.b[self.i + 1] != b'\n' {
            self.i += 1;
            match self.b[self.i] {
                b'"' | b'\'' => self.skip_string(self.b[self.i]),
                b']' => end = self.i,
                b'#' => break,
                _ => {}
            }
        }
        let header = String::from_utf8_lossy(&self.b[start..=end.max(start)]).into_owned();
        let name = header
            .trim_matches(|c: char| c == '[' || c == ']' || c.is_whitespace())
            .to_string();
        // `[[name]]` is the next entry of an array of tables.
        self.table = if header.starts_with("[[") {
            let count = self.entries.entry(name.clone()).or_insert(0);
            *count += 1;
            format!("{name}[{}]", *count - 1)
        } else {
            name
        };
    }

    fn skip_comment(&mut self) {
        while self.i + 1 < self.b.len() && self.b[self.i + 1] != b'\n' {
            self.i += 1;
        }
    }

    /// Skips the string that opens at `self.i` with `quote`, single or
    /// triple, leaving `self.i` on its closing quote.
    fn skip_string(&mut self, quote: u8) {
        let triple = self.b[self.i..].starts_with(&[quote; 3]);
        let basic = quote == b'"';
        self.i += if triple { 3 } else { 1 };
        while self.i < self.b.len() {
            let c = self.b[self.i];
            if basic && c == b'\\' {
                self.i += 2;
                continue;
            }
            if c == b'\n' {
                if !triple {
                    // An unclosed string: the parser reports it.
                    self.i -= 1;
                    return;
                }
                self.line += 1;
                self.line_start = self.i + 1;
            }
            if c == quote && (!triple || self.b[self.i..].starts_with(&[quote; 3])) {
                if triple {
                    // A closing `"""` may be followed by up to two quotes
                    // of the string's own.
                    self.i += 2;
                    while self.b.get(self.i + 1) == Some(&quote) {
                        self.i += 1;
                    }
                }
                return;
            }
            self.i += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn array_text(key: &str, n: usize) -> String {
        let items: Vec<String> = (0..n).map(|i| format!("[{i}, 0.5]")).collect();
        format!(
            "# a comment with [brackets] and \"quotes\"\n[[polygon]]\n[[polygon]]\n\
             [materials.leaf]\nname = \"a]b,[c\"\n{key} = [\n{}\n]\n",
            items.join(",\n")
        )
    }

    #[test]
    fn an_array_at_the_limit_passes_and_one_more_item_is_refused_at_its_line() {
        check(&array_text("spectrum", MAX_ARRAY_ITEMS), "s.toml").unwrap();
        let e = check(&array_text("spectrum", MAX_ARRAY_ITEMS + 1), "s.toml").unwrap_err();
        let d = &e.diagnostics[0];
        assert_eq!(
            (d.line, d.key.as_str()),
            (6, "materials.leaf.spectrum"),
            "{d}"
        );
        let text = format!(
            "[[polygon]]\n[[polygon]]\nvertices_m = [{}]\n",
            "0,".repeat(100_001)
        );
        let e = check(&text, "s.toml").unwrap_err();
        assert_eq!(e.diagnostics[0].key, "polygon[1].vertices_m");
        assert!(d.message.contains("more than 100000 items"), "{d}");
    }

    #[test]
    fn nested_arrays_count_their_own_items_and_headers_are_not_arrays() {
        // The outer array holds 3 items, each inner one 3 (12 so far); the
        // inline table's array 2; strings, comments and headers hold none.
        let text = "[[polygon]]\nvertices_m = [[0, 0, 0], [1, 0, 0], [1, 1, 0]] # [x]\n\
                    [\"odd].key\"]\nt = { a = [1, 2], b = \"]\" }\ns = '''\n[not, an, array]\n'''\n\
                    e = []\n";
        assert_eq!(Scan::new(text.as_bytes(), "s.toml").run().unwrap(), 14);
    }

    #[test]
    fn too_many_items_in_all_are_refused() {
        let per = MAX_ARRAY_ITEMS;
        let mut text = String::new();
        for k in 0..=(MAX_ARRAY_ITEMS_TOTAL / per) {
            let items = vec!["1"; per].join(",");
            text.push_str(&format!("a{k} = [{items}]\n"));
        }
        let e = check(&text, "s.toml").unwrap_err();
        let d = &e.diagnostics[0];
        assert!(d.message.contains("in all"), "{d}");
        assert_eq!(d.key, format!("a{}", MAX_ARRAY_ITEMS_TOTAL / per));
    }

    #[test]
    fn text_beyond_the_size_limit_is_refused() {
        let text = "#".repeat(MAX_SURVEY_BYTES + 1);
        let e = check(&text, "s.toml").unwrap_err();
        assert!(e.diagnostics[0].message.contains("bytes"), "{e}");
    }
}
