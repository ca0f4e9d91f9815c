//! From key paths to places in the survey file, and back.
//!
//! The TOML text is parsed a second time into toml's spanned document tree,
//! which keeps the byte range of every key and value. A validation error
//! names a key path (`polygon[2].vertices_m`); this module turns it into a
//! `line:column`, and turns the byte range of a parser error into the key
//! path it falls in.

use std::fmt;
use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Seg {
    /// A table key.
    Key(String),
    /// An array element.
    Index(usize),
}

/// A key path such as `scanner.prf_hz` or `polygon[2].vertices_m[1]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    /// The empty path (the whole file).
    pub fn root() -> Self {
        Self(Vec::new())
    }

    /// This path extended by a key.
    pub fn key(&self, k: &str) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Key(k.to_string()));
        Self(v)
    }

    /// This path extended by an index.
    pub fn index(&self, i: usize) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Index(i));
        Self(v)
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// The spanned tree of a survey file.
pub struct Locator<'a> {
    text: &'a str,
    root: Option<toml::Spanned<DeTable<'a>>>,
}

impl<'a> Locator<'a> {
    /// Parses `text` (a file that does not parse gives a locator that knows
    /// only line numbers of byte offsets).
    pub fn new(text: &'a str) -> Self {
        Self {
            text,
            root: DeTable::parse(text).ok(),
        }
    }

    /// 1-based line and column of a byte offset.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let col = before.rfind('\n').map_or(offset, |nl| offset - nl - 1) + 1;
        (line, col)
    }

    /// The text of a 1-based line.
    pub fn line_text(&self, line: usize) -> &'a str {
        self.text.lines().nth(line.saturating_sub(1)).unwrap_or("")
    }

    /// Byte range of the value at `path`, or of the deepest part of the path
    /// that exists (a missing key points at its table).
    pub fn span_of(&self, path: &KeyPath) -> Option<Range<usize>> {
        self.find(path).map(|(_, value)| value)
    }

    /// Byte range of the key that ends `path` (of the value when the path
    /// ends in an array index), or of the deepest part that exists.
    pub fn key_span_of(&self, path: &KeyPath) -> Option<Range<usize>> {
        self.find(path).map(|(key, value)| key.unwrap_or(value))
    }

    fn find(&self, path: &KeyPath) -> Option<(Option<Range<usize>>, Range<usize>)> {
        let root = self.root.as_ref()?;
        let mut best = None;
        let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
        let mut array: Option<&[toml::Spanned<DeValue<'_>>]> = None;
        for seg in &path.0 {
            let (key, next): (Option<Range<usize>>, &toml::Spanned<DeValue<'_>>) = match seg {
                Seg::Key(k) => match table.and_then(|t| t.get_key_value(k.as_str())) {
                    Some((key, v)) => (Some(key.span()), v),
                    None => break,
                },
                Seg::Index(i) => match array.and_then(|a| a.get(*i)) {
                    Some(v) => (None, v),
                    None => break,
                },
            };
            best = Some((key, next.span()));
            table = None;
            array = None;
            match next.get_ref() {
                DeValue::Table(t) => table = Some(t),
                DeValue::Array(a) => array = Some(a),
                _ => {}
            }
        }
        best
    }

    /// The deepest key path whose key or value contains the byte range.
    /// (The span toml gives a table is that of its `[header]`, not of its
    /// body, so tables and arrays are searched whatever their span.)
    pub fn path_at(&self, span: &Range<usize>) -> KeyPath {
        fn contains(r: &Range<usize>, span: &Range<usize>) -> bool {
            r.start <= span.start && span.end <= r.end.max(r.start + 1)
        }
        fn walk(v: &DeValue<'_>, span: &Range<usize>, path: &KeyPath, best: &mut (usize, KeyPath)) {
            match v {
                DeValue::Table(t) => {
                    for (k, v) in t.iter() {
                        let p = path.key(k.get_ref());
                        if (contains(&k.span(), span) || contains(&v.span(), span))
                            && p.0.len() > best.0
                        {
                            *best = (p.0.len(), p.clone());
                        }
                        walk(v.get_ref(), span, &p, best);
                    }
                }
                DeValue::Array(a) => {
                    for (i, e) in a.iter().enumerate() {
                        let p = path.index(i);
                        if contains(&e.span(), span) && p.0.len() > best.0 {
                            *best = (p.0.len(), p.clone());
                        }
                        walk(e.get_ref(), span, &p, best);
                    }
                }
                _ => {}
            }
        }
        let mut best = (0, KeyPath::root());
        if let Some(root) = &self.root {
            for (k, v) in root.get_ref().iter() {
                let p = KeyPath::root().key(k.get_ref());
                if (contains(&k.span(), span) || contains(&v.span(), span)) && best.0 < 1 {
                    best = (1, p.clone());
                }
                walk(v.get_ref(), span, &p, &mut best);
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "seed = 3\n[scanner]\nprf_hz = -5\n\n[[polygon]]\nmaterial = \"a\"\n\
                        [[polygon]]\nvertices_m = [[0, 0, 0], [1, 0, 0]]\n";

    #[test]
    fn finds_values_by_path() {
        let l = Locator::new(TEXT);
        let p = KeyPath::root().key("scanner").key("prf_hz");
        let s = l.span_of(&p).unwrap();
        assert_eq!(&TEXT[s.clone()], "-5");
        assert_eq!(l.line_col(s.start), (3, 10));
        let v = KeyPath::root()
            .key("polygon")
            .index(1)
            .key("vertices_m")
            .index(1);
        let s = l.span_of(&v).unwrap();
        assert_eq!(&TEXT[s.clone()], "[1, 0, 0]");
        assert_eq!(l.line_col(s.start).0, 8);
        assert_eq!(v.to_string(), "polygon[1].vertices_m[1]");
        // A missing key points at its parent.
        let missing = KeyPath::root().key("polygon").index(0).key("vertices_m");
        assert_eq!(l.line_col(l.span_of(&missing).unwrap().start).0, 5);
    }

    #[test]
    fn finds_path_of_a_span() {
        let l = Locator::new(TEXT);
        let start = TEXT.find("-5").unwrap();
        assert_eq!(l.path_at(&(start..start + 2)).to_string(), "scanner.prf_hz");
    }
}
