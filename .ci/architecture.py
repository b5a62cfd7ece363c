#!/usr/bin/env python3
"""Keeps docs/architecture.md's module tables equal to the code.

Usage: .ci/architecture.py [--write]

Every row of docs/architecture.md whose second column links one module
file, e.g. ``[`work/cell`](../host/src/work/cell.rs)``, has in its last
column that module's imports as `.ci/cycles.py` finds them (the crate's
modules it names through `crate::` and `super::` outside tests, by their
path under src/ without `.rs` or `/mod`, sorted, comma-separated; `—` for
none). Fails (exit 1) when a row's imports differ from the code's, when a
row names a module that does not exist, or when a module of kernel/src or
host/src has no row. `--write` rewrites the imports columns from the code
instead (the rows and their descriptions stay as written).

Also fails when a relative link of README.md or a page under docs/ or
validation/ points to a file or folder that does not exist (a moved module
leaves no dead link behind).
"""
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from cycles import imports, modules  # noqa: E402

DOC = Path("docs/architecture.md")
CRATES = {"kernel/src": "../kernel/src/", "host/src": "../host/src/"}
ROW = re.compile(r"^\|(?P<cells>.*)\|\s*$")
LINK = re.compile(r"^\s*\[`(?P<name>[\w/]+)`\]\((?P<target>\.\./(?:kernel|host)/src/[\w/]+\.rs)\)\s*$")


def name_of(parts):
    return "/".join(parts) if parts else "lib"


def code_graph():
    """{(crate src, module name): (file, sorted import names)} of both crates."""
    out = {}
    for src in CRATES:
        mods = modules(Path(src))
        for m, p in mods.items():
            if not m:
                continue  # lib.rs / main.rs: the crate root
            out[(src, name_of(m))] = (
                p,
                sorted(name_of(i) for i in imports(m, p, mods)),
            )
    return out


def dead_links():
    """Relative links of the README and the docs whose target is missing."""
    out = []
    pages = [Path("README.md")] + sorted(Path("docs").rglob("*.md")) + sorted(Path("validation").rglob("*.md"))
    for page in pages:
        for k, line in enumerate(page.read_text(encoding="utf-8").split("\n")):
            for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", line):
                if re.match(r"^[a-z]+:", target):
                    continue
                if not (page.parent / target).exists():
                    out.append(f"{page}:{k + 1}: dead link {target}")
    return out


def main(write):
    graph = code_graph()
    lines = DOC.read_text(encoding="utf-8").split("\n")
    faults, seen = [], set()
    for k, line in enumerate(lines):
        m = ROW.match(line)
        if not m:
            continue
        cells = m.group("cells").split("|")
        if len(cells) < 3:
            continue
        link = LINK.match(cells[1])
        if not link:
            continue
        target = link.group("target")
        src = next(s for s, prefix in CRATES.items() if target.startswith(prefix))
        path = Path(src) / target[len(CRATES[src]):]
        key = (src, link.group("name"))
        if key not in graph or graph[key][0] != path:
            faults.append(f"{DOC}:{k + 1}: `{link.group('name')}` ({target}) is not a module of {src}")
            continue
        seen.add(key)
        want = ", ".join(graph[key][1]) or "—"
        have = ", ".join(sorted(i.strip() for i in cells[-1].split(",") if i.strip() not in ("", "—")))
        if have != (want if want != "—" else ""):
            if write:
                cells[-1] = f" {want} "
                lines[k] = "|" + "|".join(cells) + "|"
            else:
                faults.append(f"{DOC}:{k + 1}: `{key[1]}` imports {want}, the row says {cells[-1].strip()}")
    for key in sorted(set(graph) - seen):
        faults.append(f"{DOC}: no row for `{key[1]}` ({key[0]}/{graph[key][0].relative_to(key[0])})")
    faults += dead_links()
    if write:
        DOC.write_text("\n".join(lines), encoding="utf-8")
    for f in faults:
        print(f)
    if faults and not write:
        print("fix the rows or links; `python3 .ci/architecture.py --write` regenerates the imports columns")
    return 1 if faults else 0


if __name__ == "__main__":
    sys.exit(main("--write" in sys.argv[1:]))
