#!/usr/bin/env python3
"""Checks the library's module structure (part of the test command):

1. No import cycle between the top-level modules of `crates/lidarsim/src`
   (a module's `use crate::X` and `crate::X::` paths are its dependencies;
   a layer may use only layers below it). Prints the layers, lowest first.
2. No source file of the workspace longer than 800 lines unless its first
   lines say why (a line starting `//! Long file:`).

Usage: check_layers.py [--graph]   (--graph also prints every edge)
Exits non-zero naming the cycle or the file.
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "crates" / "lidarsim" / "src"
MAX_LINES = 800


def top_modules():
    mods = {}
    for p in sorted(SRC.iterdir()):
        if p.suffix == ".rs" and p.stem not in ("lib", "main"):
            mods[p.stem] = [p]
        elif p.is_dir():
            # A module's `tests.rs` files are its tests: they may use anything.
            mods[p.name] = sorted(f for f in p.rglob("*.rs") if f.name != "tests.rs")
    return mods


def strip_tests(text):
    """The text before a `#[cfg(test)]` module (tests may use anything)."""
    i = text.find("#[cfg(test)]\nmod tests")
    return text if i < 0 else text[:i]


def dependencies(mods):
    edges = {m: set() for m in mods}
    pattern = re.compile(r"crate::([a-z_][a-z0-9_]*)")
    group = re.compile(r"use crate::\{([^}]*)\}", re.S)
    for m, files in mods.items():
        for f in files:
            text = strip_tests(f.read_text())
            text = "\n".join(l for l in text.splitlines() if not l.strip().startswith("//"))
            found = set(pattern.findall(text))
            for g in group.findall(text):
                found.update(re.findall(r"(?:^|[,\s{])([a-z_][a-z0-9_]*)(?:::|\s*[,}]|$)", g))
            for d in found:
                if d in mods and d != m:
                    edges[m].add(d)
    return edges


def find_cycle(edges):
    state = {}
    stack = []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for d in sorted(edges[n]):
            if state.get(d) == 1:
                return stack[stack.index(d):] + [d]
            if d not in state:
                c = visit(d)
                if c:
                    return c
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(edges):
        if n not in state:
            c = visit(n)
            if c:
                return c
    return None


def layers(edges):
    level = {}

    def depth(n):
        if n not in level:
            level[n] = 0
            level[n] = 1 + max((depth(d) for d in edges[n]), default=-1)
        return level[n]

    for n in edges:
        depth(n)
    out = {}
    for n, l in level.items():
        out.setdefault(l, []).append(n)
    return [sorted(out[l]) for l in sorted(out)]


def long_files():
    bad = []
    for p in sorted((ROOT / "crates").rglob("*.rs")):
        if "target" in p.parts:
            continue
        lines = p.read_text().splitlines()
        if len(lines) > MAX_LINES and not any(
            l.startswith("//! Long file:") for l in lines[:40]
        ):
            bad.append((p.relative_to(ROOT), len(lines)))
    return bad


def main():
    mods = top_modules()
    edges = dependencies(mods)
    if "--graph" in sys.argv:
        for m in sorted(edges):
            print(f"{m} -> {', '.join(sorted(edges[m])) or '(none)'}")
    failed = False
    cycle = find_cycle(edges)
    if cycle:
        print("import cycle: " + " -> ".join(cycle))
        failed = True
    else:
        for i, l in enumerate(layers(edges)):
            print(f"layer {i}: {', '.join(l)}")
    for path, n in long_files():
        print(f"{path}: {n} lines, over {MAX_LINES} without a `//! Long file:` reason")
        failed = True
    if failed:
        sys.exit(1)
    print("no import cycle; no file over 800 lines without a reason")


if __name__ == "__main__":
    main()
