#!/usr/bin/env python3
"""Checks the source's shape, as docs/ARCHITECTURE.md describes it:

- no two top-level modules of src/ that use each other, directly or
  through others (read from `crate::name` paths in the code of src/, its
  tests and comments aside), so a layer never reaches back up to one
  built on it;
- in src/search, src/template, src/scene and src/gpu, no file over 600
  lines and no function over 80 (a function runs from its `fn` line to
  the closing brace at the same indent).

    python3 scripts/check-structure.py

Prints each violation and exits 1 if there is one, else prints a summary
and exits 0. Reads text only: a path built in a macro is not seen."""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src"
SIZED = ["search", "template", "scene", "gpu"]
MAX_FILE_LINES = 600
MAX_FN_LINES = 80
# The binary and the JavaScript binding sit on top of the library: they
# use every layer, and nothing uses them.
ENTRY_POINTS = {"bin", "wasm", "lib"}


def code_of(path):
    """The file's code: comments and its test module left out (tests may
    drive a layer through the ones above it)."""
    if path.name == "tests.rs" or "tests" in path.relative_to(SRC).parts[:-1]:
        return ""
    text = path.read_text().split("#[cfg(test)]\nmod tests {")[0]
    return "\n".join(line.split("//")[0] for line in text.split("\n"))


def top_module(path):
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".rs")


def module_graph():
    modules = {top_module(p) for p in SRC.rglob("*.rs")} - ENTRY_POINTS
    uses = {m: set() for m in modules}
    for path in SRC.rglob("*.rs"):
        here = top_module(path)
        if here in ENTRY_POINTS:
            continue
        text = code_of(path)
        # `use crate::{a, b::c}` names several modules at once.
        for group in re.findall(r"crate::\{([^}]*)\}", text):
            for name in re.findall(r"(?:^|,)\s*(\w+)", group):
                if name in modules and name != here:
                    uses[here].add(name)
        for name in re.findall(r"crate::(\w+)", text):
            if name in modules and name != here:
                uses[here].add(name)
    return uses


def cycles(uses):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(uses[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(10000)
    for v in sorted(uses):
        if v not in index:
            visit(v)
    return found


FN = re.compile(r"^(\s*)(pub(\([^)]*\))?\s+)?(async\s+)?(const\s+)?(unsafe\s+)?fn\s+(\w+)")


def long_functions(path):
    lines = path.read_text().split("\n")
    found = []
    for i, line in enumerate(lines):
        m = FN.match(line)
        if not m or line.rstrip().endswith(";"):
            continue
        indent = m.group(1)
        for j in range(i + 1, len(lines)):
            closing = lines[j]
            if closing.startswith(indent + "}") and len(closing) - len(closing.lstrip()) == len(indent):
                if j - i + 1 > MAX_FN_LINES:
                    found.append((m.group(7), i + 1, j - i + 1))
                break
    return found


def main():
    problems = []
    uses = module_graph()
    for component in cycles(uses):
        problems.append("modules that use each other: " + ", ".join(component))
    files = 0
    for folder in SIZED:
        base = SRC / folder
        paths = list(base.rglob("*.rs")) if base.is_dir() else [SRC / f"{folder}.rs"]
        for path in paths:
            files += 1
            rel = path.relative_to(ROOT)
            count = len(path.read_text().split("\n")) - 1
            if count > MAX_FILE_LINES:
                problems.append(f"{rel}: {count} lines (at most {MAX_FILE_LINES})")
            for name, line, length in long_functions(path):
                problems.append(f"{rel}:{line}: fn {name} is {length} lines (at most {MAX_FN_LINES})")
    for p in problems:
        print(p)
    if problems:
        return 1
    print(f"{len(uses)} modules, no two using each other; {files} files in "
          f"{', '.join('src/' + f for f in SIZED)} within {MAX_FILE_LINES} lines, "
          f"functions within {MAX_FN_LINES}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
