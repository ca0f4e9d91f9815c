//! HTML text: escaped strings, table rows and pictures as inline SVG.

use std::fmt::Write as _;

use crate::render::Figure;

pub use crate::render::base64;

/// An inline `<svg>` element drawing `fig`: the browser sets its text and
/// keeps its lines sharp when zoomed; its rasters are embedded as PNG.
pub(super) fn svg_tag(fig: &Figure, label: &str) -> Result<String, png::EncodingError> {
    fig.to_svg(label)
}

/// `s` with `&`, `<` and `>` escaped.
pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Rows of a two-column table: a heading and an escaped value each.
pub(super) fn table_rows(h: &mut String, rows: impl IntoIterator<Item = (&'static str, String)>) {
    for (k, v) in rows {
        let _ = write!(h, "<tr><th>{k}</th><td>{}</td></tr>", esc(&v));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_examples() {
        // RFC 4648, section 10.
        for (raw, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(raw.as_bytes()), enc);
        }
    }
}
