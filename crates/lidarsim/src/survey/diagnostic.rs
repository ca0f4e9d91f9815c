//! Problems of a survey file as the user sees them: each names the key
//! and what is wrong, then the file, line and column, the line itself with
//! the offending value underlined, and a hint where one is obvious (the
//! layout of rustc's and miette's diagnostics, without colours).

use std::fmt;
use std::ops::Range;

use super::{KeyPath, Locator};

/// One problem in a survey file.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// The survey file (or `<demo>` for the built-in survey).
    pub file: String,
    /// 1-based line (0 when unknown).
    pub line: usize,
    /// 1-based column (0 when unknown).
    pub column: usize,
    /// The key the problem is about (`scanner.prf_hz`).
    pub key: String,
    /// What is wrong, and what would be right.
    pub message: String,
    /// The offending line of the file.
    pub source_line: Option<String>,
    /// Characters to underline from `column` on (at least 1).
    pub width: usize,
    /// A hint, when one is obvious ("did you mean `prf_hz`?").
    pub help: Option<String>,
}

impl Diagnostic {
    /// A problem with the whole file (unreadable, not UTF-8), at `line` if
    /// known (0 otherwise).
    pub fn file_level(file: &str, line: usize, message: String) -> Self {
        Self {
            file: file.to_string(),
            line,
            column: 0,
            key: String::new(),
            message,
            source_line: None,
            width: 1,
            help: None,
        }
    }
}

/// Rendered like the diagnostics of rustc and miette, without colours:
///
/// ```text
/// key `flight_line[0].speed_mps`: must be greater than 0 m/s, got -3
///   --> survey.toml:11:13
///    |
/// 11 | speed_mps = -3
///    |             ^^
///    = help: …
/// ```
impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}", self.message)?;
        } else {
            write!(f, "key `{}`: {}", self.key, self.message)?;
        }
        let gutter = " ".repeat(self.line.max(1).to_string().len());
        write!(f, "\n{gutter}--> {}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}", self.line)?;
            if self.column > 0 {
                write!(f, ":{}", self.column)?;
            }
        }
        if let Some(src) = &self.source_line {
            // A long line is shown as a window around the column, so that
            // a 20 MB value is not echoed whole.
            let src: Vec<char> = src.trim_end().chars().collect();
            let col = self.column.max(1) - 1;
            let from = col.saturating_sub(SHOWN_BEFORE);
            let to = (col + SHOWN_AFTER).min(src.len());
            let lead = if from > 0 { "…" } else { "" };
            let tail = if to < src.len() { "…" } else { "" };
            let text: String = src[from.min(to)..to].iter().collect();
            write!(f, "\n{gutter} |\n{} | {lead}{text}{tail}", self.line)?;
            if self.column > 0 {
                let shown = to - from.min(to);
                let at = col - from + lead.chars().count();
                let width = self.width.min(shown.saturating_sub(col - from)).max(1);
                write!(f, "\n{gutter} | {}{}", " ".repeat(at), "^".repeat(width))?;
            }
        }
        if let Some(help) = &self.help {
            write!(f, "\n{gutter} = help: {help}")?;
        }
        Ok(())
    }
}

/// Characters of a source line shown before the column of a problem.
const SHOWN_BEFORE: usize = 60;
/// Characters of a source line shown from the column of a problem on.
const SHOWN_AFTER: usize = 100;

/// A survey that could not be loaded: one or more diagnostics.
#[derive(Clone, Debug, PartialEq)]
pub struct SurveyError {
    /// All problems found.
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for SurveyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for SurveyError {}

/// The error of `diagnostics` sorted by line (those without a line last).
pub(crate) fn diagnostics_in_file_order(mut diagnostics: Vec<Diagnostic>) -> SurveyError {
    diagnostics.sort_by_key(|d| if d.line == 0 { usize::MAX } else { d.line });
    SurveyError { diagnostics }
}

/// Turns key paths and messages into diagnostics of `file`, located in its
/// `text` when there is one.
pub(crate) struct Diagnose<'a> {
    /// The file's name in messages.
    pub file: &'a str,
    /// The file's text and its key locator, if the survey came from text.
    pub text: Option<(&'a str, &'a Locator<'a>)>,
}

impl Diagnose<'_> {
    /// The diagnostic of `key` at `span` (or found from the key).
    pub fn at(
        &self,
        key: &KeyPath,
        span: Option<Range<usize>>,
        message: String,
        help: Option<String>,
    ) -> Diagnostic {
        let Some((text, locator)) = self.text else {
            return Diagnostic {
                key: key.to_string(),
                help,
                ..Diagnostic::file_level(self.file, 0, message)
            };
        };
        let (line, column) = span.as_ref().map_or((0, 0), |s| locator.line_col(s.start));
        let width = span.map_or(1, |s| text[s].chars().take_while(|&c| c != '\n').count());
        Diagnostic {
            file: self.file.to_string(),
            line,
            column,
            key: key.to_string(),
            message,
            source_line: (line > 0).then(|| locator.line_text(line).to_string()),
            width: width.max(1),
            help,
        }
    }

    /// The diagnostics of checked problems, in file order.
    pub fn problems(&self, problems: Vec<(KeyPath, String)>) -> SurveyError {
        let diagnostics = problems
            .into_iter()
            .map(|(key, message)| {
                let span = self.text.and_then(|(_, l)| l.span_of(&key));
                self.at(&key, span, message, None)
            })
            .collect();
        diagnostics_in_file_order(diagnostics)
    }
}
