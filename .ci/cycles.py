#!/usr/bin/env python3
"""Fails when the modules of a crate import each other in a loop.

Usage: .ci/cycles.py SRC_DIR...   (e.g. kernel/src host/src)

A module's imports are the `crate::a::b`, `crate::{a, b}` and `super::a`
paths of its non-test code (everything before its first `#[cfg(test)]`),
each taken to the deepest module file that exists. Prints every loop
(strongly connected set of two or more files) and exits 1 if there is one.
"""
import re
import sys
from pathlib import Path


def modules(src):
    out = {}
    for p in src.rglob("*.rs"):
        parts = list(p.relative_to(src).with_suffix("").parts)
        if parts[-1] == "mod" or parts in (["lib"], ["main"]):
            parts = parts[:-1]
        out[tuple(parts)] = p
    return out


def imports(name, path, mods):
    text = path.read_text(encoding="utf-8").split("#[cfg(test)]")[0]
    text = re.sub(r"//[^\n]*", "", text)
    paths = [p.split("::") for p in re.findall(r"crate::([\w:]+)", text)]
    for group in re.findall(r"crate::\{([^}]*)\}", text):
        paths += [i.split(" as ")[0].strip().split("::") for i in group.split(",") if i.strip()]
    paths += [list(name[:-1]) + p.split("::") for p in re.findall(r"super::([\w:]+)", text)]
    found = set()
    for p in paths:
        hits = [tuple(p[:k]) for k in range(1, len(p) + 1) if tuple(p[:k]) in mods]
        if hits and hits[-1] not in (name, ()):
            found.add(hits[-1])
    return found


def loops(graph):
    """Tarjan's strongly connected components with more than one member."""
    index, low, stack, out = {}, {}, [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while comp[-1:] != [v]:
                comp.append(stack.pop())
            if len(comp) > 1:
                out.append(comp)

    for v in graph:
        if v not in index:
            visit(v)
    return out


status = 0
for arg in sys.argv[1:]:
    src = Path(arg)
    mods = modules(src)
    graph = {m: imports(m, p, mods) for m, p in mods.items()}
    for comp in loops(graph):
        names = sorted(str(mods[m].relative_to(src)) for m in comp)
        print(f"{arg}: import loop of {len(comp)} files: {', '.join(names)}")
        status = 1
sys.exit(status)
