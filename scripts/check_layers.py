#!/usr/bin/env python3
"""Checks the workspace's structure (part of the test command):

1. No import cycle between the top-level modules of any crate
   (`crates/*/src`: a module's `use crate::X` and `crate::X::` paths, and
   `super::X` in a file just under the crate root, are its dependencies; a
   layer may use only layers below it). Prints each crate's layers, lowest
   first, a cycle as `{a <-> b (cycle)}`.
2. No function in `crates/*/src` longer than 150 lines (from its signature
   to its closing brace) unless a comment line starting `// long:` stands
   among the comment and attribute lines directly above it. Tests
   (`tests.rs` files and `#[cfg(test)] mod` blocks) are not counted.
3. No source file of the workspace longer than 800 lines unless its first
   lines say why (a line starting `//! Long file:`).

Functions are found by a small Rust tokenizer (comments, strings, raw
strings, characters and lifetimes told apart), tested on `SAMPLE` first.

Usage: check_layers.py [--graph]   (--graph also prints every edge)
Prints the long functions that give a reason; exits non-zero naming every
cycle, function and file that breaks a rule (all of them, not the first).
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CRATES = ROOT / "crates"
MAX_LINES = 800
MAX_FN_LINES = 150


# --- Rust tokens ----------------------------------------------------------


class Token:
    __slots__ = ("kind", "text", "start", "line", "end_line")

    def __init__(self, kind, text, start, line):
        self.kind = kind  # ident, lifetime, literal, comment, punct
        self.text = text
        self.start = start  # offset in the file's text
        self.line = line  # 1-based, first line
        self.end_line = line + text.count("\n")  # 1-based, last line

    def __repr__(self):
        return f"{self.kind}:{self.text!r}@{self.line}"


IDENT_START = re.compile(r"[A-Za-z_\u0080-\U0010ffff]")
IDENT = re.compile(r"[A-Za-z0-9_\u0080-\U0010ffff]*")
NUMBER = re.compile(r"[0-9][0-9A-Za-z_]*(\.[0-9][0-9_]*)?([eE][+-]?[0-9_]+)?[A-Za-z0-9_]*")


def tokenize(text):
    """Rust tokens with their lines: comments (nested block comments
    included), strings (escaped, raw, byte and C strings), characters
    (told from lifetimes), identifiers, numbers, single punctuation."""
    tokens = []
    i, n, line = 0, len(text), 1

    def add(kind, start, end):
        tokens.append(Token(kind, text[start:end], start, line))
        return tokens[-1].end_line - line

    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            add("comment", i, j)
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            line += add("comment", i, j)
            i = j
        elif c == '"':
            j = quoted_end(text, i + 1, '"')
            line += add("literal", i, j)
            i = j
        elif c == "'":
            # A character ('{', '\n', '\u{7b}', '\'') or a lifetime or label.
            if i + 1 < n and text[i + 1] == "\\":
                j = quoted_end(text, i + 1, "'")
                add("literal", i, j)
            elif i + 2 < n and text[i + 2] == "'":
                j = i + 3
                add("literal", i, j)
            else:
                m = IDENT.match(text, i + 1)
                j = m.end()
                add("lifetime", i, j)
            i = j
        elif IDENT_START.match(c):
            j = IDENT.match(text, i).end()
            word = text[i:j]
            if word in ("r", "br", "cr") and j < n and text[j] in '"#':
                hashes = 0
                while j + hashes < n and text[j + hashes] == "#":
                    hashes += 1
                if j + hashes < n and text[j + hashes] == '"':
                    close = '"' + "#" * hashes
                    k = text.find(close, j + hashes + 1)
                    k = n if k < 0 else k + len(close)
                    line += add("literal", i, k)
                    i = k
                    continue
                if word == "r" and hashes == 1:  # a raw identifier, r#match
                    j = IDENT.match(text, j + 1).end()
            elif word in ("b", "c") and j < n and text[j] in "\"'":
                k = quoted_end(text, j + 1, text[j])
                line += add("literal", i, k)
                i = k
                continue
            add("ident", i, j)
            i = j
        elif c.isdigit():
            j = NUMBER.match(text, i).end()
            add("literal", i, j)
            i = j
        else:
            add("punct", i, i + 1)
            i += 1
    return tokens


def quoted_end(text, i, quote):
    """The index past the closing `quote` of a literal whose text starts at i."""
    n = len(text)
    while i < n:
        if text[i] == "\\":
            i += 2
        elif text[i] == quote:
            return i + 1
        else:
            i += 1
    return n


def matching(tokens, i):
    """The index of the bracket closing the one at tokens[i]."""
    opening = tokens[i].text
    closing = {"{": "}", "(": ")", "[": "]"}[opening]
    depth = 0
    for j in range(i, len(tokens)):
        t = tokens[j]
        if t.kind != "punct":
            continue
        if t.text == opening:
            depth += 1
        elif t.text == closing:
            depth -= 1
            if depth == 0:
                return j
    return len(tokens) - 1


def attribute_start(tokens, i):
    """If tokens[i] is the `]` of an attribute `#[...]` or `#![...]`, the
    index of its `#`; otherwise None."""
    if tokens[i].kind != "punct" or tokens[i].text != "]":
        return None
    depth = 0
    for j in range(i, -1, -1):
        t = tokens[j]
        if t.kind == "punct" and t.text in "[]":
            depth += 1 if t.text == "]" else -1
            if depth == 0:
                k = j - 1
                if k >= 0 and tokens[k].text == "!":
                    k -= 1
                return k if k >= 0 and tokens[k].text == "#" else None
    return None


def without_tests(tokens):
    """The tokens outside `#[cfg(test)] mod NAME { ... }` (and `mod NAME;`)
    items: tests may use anything and be as long as they like."""
    out, i = [], 0
    while i < len(tokens):
        if is_cfg_test(tokens, i):
            j = i + 7  # past `# [ cfg ( test ) ]`
            while j < len(tokens) and tokens[j].kind == "comment":
                j += 1
            if j + 1 < len(tokens) and tokens[j].text == "mod":
                k = j + 2
                if k < len(tokens) and tokens[k].text == "{":
                    i = matching(tokens, k) + 1
                    continue
                if k < len(tokens) and tokens[k].text == ";":
                    i = k + 1
                    continue
        out.append(tokens[i])
        i += 1
    return out


def is_cfg_test(tokens, i):
    texts = [t.text for t in tokens[i : i + 7]]
    return texts == ["#", "[", "cfg", "(", "test", ")", "]"]


# --- import cycles --------------------------------------------------------


def top_modules(src):
    """The top-level modules of a crate's source directory: name -> files.
    The crate root (`lib.rs`, `main.rs`) is not a module of its own."""
    mods = {}
    for p in sorted(src.iterdir()):
        if p.suffix == ".rs" and p.stem not in ("lib", "main"):
            mods[p.stem] = [p]
        elif p.is_dir() and p.name != "bin":
            # A module's `tests.rs` files are its tests: they may use anything.
            mods[p.name] = sorted(f for f in p.rglob("*.rs") if f.name != "tests.rs")
    return mods


def code_text(path):
    """A file's code as text without comments, literals and tests."""
    out, end = [], None
    for t in without_tests(tokenize(path.read_text())):
        if t.kind in ("comment", "literal"):
            continue
        if end is not None and t.start != end:
            out.append(" ")
        out.append(t.text)
        end = t.start + len(t.text)
    return "".join(out)


def dependencies(src, mods):
    """Which modules each module uses: `crate::X` paths and `use crate::{...}`
    groups, and `super::X` in the files whose parent is the crate root (a
    top-level file, a top-level directory's `mod.rs`)."""
    edges = {m: set() for m in mods}
    crate_path = re.compile(r"\bcrate\s*::\s*([a-z_][a-z0-9_]*)")
    crate_group = re.compile(r"\buse\s+crate\s*::\s*\{")
    super_path = re.compile(r"\bsuper\s*::\s*([a-z_][a-z0-9_]*)")
    super_group = re.compile(r"\buse\s+super\s*::\s*\{")
    for m, files in mods.items():
        for f in files:
            text = code_text(f)
            at_top = f.parent == src or (f.name == "mod.rs" and f.parent.parent == src)
            paths = [crate_path, super_path] if at_top else [crate_path]
            groups = [crate_group, super_group] if at_top else [crate_group]
            found = {d for p in paths for d in p.findall(text)}
            for group in groups:
                for g in group.finditer(text):
                    found.update(group_heads(text, g.end()))
            for d in found:
                if d in mods and d != m:
                    edges[m].add(d)
    return edges


def group_heads(text, i):
    """The first names of the paths of a `use crate::{...}` group whose
    text starts at i (past the `{`): `a::b, c, d::{e, f}` -> a, c, d."""
    heads, depth, first = [], 0, True
    for m in re.finditer(r"[A-Za-z_][A-Za-z0-9_]*|[{},]", text[i:]):
        tok = m.group()
        if tok == "{":
            depth += 1
        elif tok == "}":
            if depth == 0:
                break
            depth -= 1
        elif tok == ",":
            first = first or depth == 0
        elif first:
            heads.append(tok)
            first = False
    return heads


def components(edges):
    """Strongly connected components (Tarjan), each a sorted list."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def layers(edges, comps):
    """The components by layer: a component's layer is one above the
    highest layer it uses (0 when it uses none)."""
    of = {m: tuple(c) for c in comps for m in c}
    level = {}

    def depth(c):
        if c not in level:
            below = {of[d] for m in c for d in edges[m]} - {c}
            level[c] = 1 + max((depth(b) for b in below), default=-1)
        return level[c]

    out = {}
    for c in comps:
        out.setdefault(depth(tuple(c)), []).append(c)
    return [sorted(out[l]) for l in sorted(out)]


def crate_dirs():
    return sorted(p for p in CRATES.iterdir() if (p / "src").is_dir())


def check_cycles(graph):
    """Prints every crate's layers; returns the failures, one per cycle."""
    failures = []
    for crate in crate_dirs():
        mods = top_modules(crate / "src")
        edges = dependencies(crate / "src", mods)
        if graph:
            for m in sorted(edges):
                print(f"{crate.name}: {m} -> {', '.join(sorted(edges[m])) or '(none)'}")
        comps = components(edges)
        print(f"{crate.name}:")
        if not mods:
            print("  one module (the crate root)")
        for i, layer in enumerate(layers(edges, comps)):
            names = []
            for c in layer:
                if len(c) == 1:
                    names.append(c[0])
                    continue
                names.append("{" + " <-> ".join(c) + " (cycle)}")
                inner = ", ".join(f"{m} -> {d}" for m in c for d in sorted(edges[m]) if d in c)
                failures.append(f"import cycle in crates/{crate.name} among {', '.join(c)}: {inner}")
            print(f"  layer {i}: {', '.join(names)}")
    return failures


# --- long functions -------------------------------------------------------

QUALIFIERS = {"pub", "const", "async", "unsafe", "extern", "default", "safe"}


def functions(tokens):
    """Every function with a body: (name, first line, last line, reason),
    reason being whether a `// long:` comment stands among the comment and
    attribute lines directly above it."""
    out = []
    for i, t in enumerate(tokens):
        if t.kind != "ident" or t.text != "fn":
            continue
        if i + 1 >= len(tokens) or tokens[i + 1].kind != "ident":
            continue  # `fn(u32) -> u32`, a type; `$name` in a macro
        body = body_start(tokens, i + 2)
        if body is None:
            continue
        end = matching(tokens, body)
        start = signature_start(tokens, i)
        out.append((tokens[i + 1].text, tokens[start].line, tokens[end].end_line, has_reason(tokens, start)))
    return out


def body_start(tokens, i):
    """The index of the `{` opening the body of a function whose signature
    continues at tokens[i]; None for a declaration ending in `;`."""
    depth = 0
    for j in range(i, len(tokens)):
        t = tokens[j]
        if t.kind != "punct":
            continue
        if t.text in "([":
            depth += 1
        elif t.text in ")]":
            depth -= 1
        elif depth == 0 and t.text == "{":
            return j
        elif depth == 0 and t.text == ";":
            return None
    return None


def signature_start(tokens, i):
    """The index of a function's first token: `pub(crate) const unsafe
    extern "C" fn` starts at `pub`."""
    while i > 0:
        p = tokens[i - 1]
        if p.kind == "ident" and p.text in QUALIFIERS:
            i -= 1
        elif p.kind == "literal" and i > 1 and tokens[i - 2].text == "extern":
            i -= 1
        elif p.text == ")" and i > 2 and tokens[i - 3].text == "(":
            # pub(crate), pub(super), pub(self)
            if i > 3 and tokens[i - 4].text == "pub":
                i -= 3
            else:
                break
        elif p.text == ")" and i > 4 and tokens[i - 5].text == "pub" and tokens[i - 4].text == "(":
            i -= 4  # pub(in path)
        else:
            break
    return i


def has_reason(tokens, i):
    """Whether a `// long:` comment stands among the comment and attribute
    lines directly above tokens[i] (no blank line between)."""
    top = tokens[i].line
    k = i - 1
    while k >= 0:
        t = tokens[k]
        if t.end_line < top - 1:
            return False
        if t.kind == "comment":
            if t.text.startswith("// long:"):
                return True
            top = t.line
            k -= 1
            continue
        a = attribute_start(tokens, k)
        if a is None:
            return False
        top = tokens[a].line
        k = a - 1
    return False


def long_functions():
    """(path, name, first line, lines, reason) of every function over
    MAX_FN_LINES lines in the crates' sources."""
    out = []
    for crate in crate_dirs():
        for p in sorted((crate / "src").rglob("*.rs")):
            if p.name == "tests.rs":
                continue
            tokens = without_tests(tokenize(p.read_text()))
            for name, first, last, reason in functions(tokens):
                lines = last - first + 1
                if lines > MAX_FN_LINES:
                    out.append((p.relative_to(CRATES).as_posix(), name, first, lines, reason))
    return out


def check_functions():
    """Prints the long functions with a reason; returns those without."""
    failures = []
    for path, name, first, lines, reason in long_functions():
        where = f"crates/{path}:{first}: {name}, {lines} lines"
        if reason:
            print(f"{where} (// long: reason)")
        else:
            failures.append(f"{where}, over {MAX_FN_LINES} without a `// long:` reason")
    return failures


def long_files():
    bad = []
    for p in sorted(CRATES.rglob("*.rs")):
        if "target" in p.parts:
            continue
        lines = p.read_text().splitlines()
        if len(lines) > MAX_LINES and not any(
            l.startswith("//! Long file:") for l in lines[:40]
        ):
            bad.append((p.relative_to(ROOT), len(lines)))
    return bad


# --- the checker's own test -----------------------------------------------

SAMPLE = r"""
fn braces_in_strings() {
    let s = "}}}\"}";
    let t = '{';
    let u = '\'';
    let v = '\u{7b}';
    let w = b'}';
    let x = r#"}"# ;
    let y = br##"{"#}"##;
    // }
    /* { /* } */ } */
}
fn lifetimes<'a>(x: &'a str, y: [u8; 4]) -> &'a str where 'a: 'a {
    let f = |v: u32| { v + 1 };
    'outer: loop { break 'outer; }
    x
}
trait T {
    fn declared(&self) -> [u8; 2];
    fn defaulted(&self) {
    }
}
impl T for () {
    /// Doc.
    // long: a reason
    #[inline]
    #[allow(
        dead_code
    )]
    pub(crate) const unsafe extern "C" fn in_impl(&self) {
    }

    // long: a reason, but a blank line under it

    fn no_reason() {}
}
const F: fn(u32) -> u32 = id;
#[cfg(test)]
mod tests {
    fn hidden() {}
}
fn after_tests() {}
"""


def self_test():
    """The tokenizer and function finder on SAMPLE's awkward corners."""
    got = [(n, a, b, r) for n, a, b, r in functions(without_tests(tokenize(SAMPLE)))]
    want = [
        ("braces_in_strings", 2, 12, False),
        ("lifetimes", 13, 17, False),
        ("defaulted", 20, 21, False),
        ("in_impl", 30, 31, True),
        ("no_reason", 35, 35, False),
        ("after_tests", 42, 42, False),
    ]
    assert got == want, f"check_layers.py self-test: {got} != {want}"
    text = "use crate::{a::b, c, d::{e, f}};"
    assert group_heads(text, text.index("{") + 1) == ["a", "c", "d"]


def main():
    self_test()
    failures = check_cycles("--graph" in sys.argv)
    failures += check_functions()
    for path, n in long_files():
        failures.append(f"{path}: {n} lines, over {MAX_LINES} without a `//! Long file:` reason")
    for f in failures:
        print(f)
    if failures:
        sys.exit(1)
    print(
        f"no import cycle, no function over {MAX_FN_LINES} lines without a reason, "
        f"no file over {MAX_LINES} lines without a reason"
    )


if __name__ == "__main__":
    main()
