#!/usr/bin/env python3
"""Fails when the modules of a crate import each other in a loop.

Usage: .ci/cycles.py SRC_DIR...   (e.g. kernel/src host/src)

A module's imports are the `crate::a::b`, `crate::{a, b}` and `super::a`
paths of its non-test code (everything before its first `#[cfg(test)]`),
each taken to the deepest module file that exists. Prints every loop
(strongly connected set of two or more files) and exits 1 if there is one.

Also fails when a module imports from a higher layer: `LAYERS` ranks the
top-level modules (folders) of each crate, and a module may import only
from its own folder or from folders of the same or a lower rank (a loop
between two folders of one rank is still a loop). A top-level module that
`LAYERS` does not rank fails too, so a new folder must be placed.
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


# Rank of each top-level module, lowest first (docs/architecture.md).
LAYERS = {
    "kernel/src": {
        # 0 numbers: leaves
        "real": 0, "error": 0, "events": 0, "executor": 0, "random": 0, "periodic": 0,
        "digest": 0, "lanes": 0,
        "steps": 0,
        # 1 model laws
        "constants": 1, "contact": 1, "flow": 1, "fluid": 1,
        # 2 storage and records
        "grains": 2, "neighbours": 2, "bed": 2, "observe": 2, "fields": 2,
        # 3 the step's two paths, on the data they are handed
        "step": 3,
        # 4 the simulation: `Sim` and its topics
        "sim": 4,
        # 5 a complete run set-up
        "scenario": 5,
    },
    "host/src": {
        # 0 foundation: errors; files and terminals
        "error": 0, "io": 0,
        # 1 numbers from the literature and statistics
        "science": 1,
        # 2 the configuration; figures from plain series
        "config": 2, "figures": 2,
        # 3 heap simulations and what touches one
        "sim": 3,
        # 4 the units of work: beds, cells, the experiment, the store
        "work": 4,
        # 5 what a run writes from its outcome
        "report": 5,
        # 6 commands beside the main job; 7 the calibration
        "tools": 6, "calibrate": 7,
        # 8 the command line
        "cli": 8,
    },
}


def layer_faults(arg, mods, graph):
    ranks = LAYERS.get(arg.rstrip("/"))
    if ranks is None:
        return []
    out = []
    for m, imps in sorted(graph.items()):
        if not m:
            continue
        if m[0] not in ranks:
            out.append(f"{arg}: {mods[m].relative_to(arg)}: top-level module `{m[0]}` has no layer in .ci/cycles.py")
            continue
        for i in sorted(imps):
            if i[0] != m[0] and ranks.get(i[0], -1) > ranks[m[0]]:
                out.append(
                    f"{arg}: {mods[m].relative_to(arg)} (layer {ranks[m[0]]}, {m[0]}) imports "
                    f"{'::'.join(i)} (layer {ranks[i[0]]}, {i[0]}): a lower layer never imports a higher one"
                )
    return out


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


def main(args):
    status = 0
    for arg in args:
        src = Path(arg)
        mods = modules(src)
        graph = {m: imports(m, p, mods) for m, p in mods.items()}
        for comp in loops(graph):
            names = sorted(str(mods[m].relative_to(src)) for m in comp)
            print(f"{arg}: import loop of {len(comp)} files: {', '.join(names)}")
            status = 1
        for fault in layer_faults(arg, mods, graph):
            print(fault)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
