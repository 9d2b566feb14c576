"""The layout contributors rely on (docs/architecture.md): a domain never imports one above
it, the web plumbing imports no domain, and no module outside the science package grows
past 400 lines. Read from the code's own imports (every import, also those inside functions
and under TYPE_CHECKING)."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "backend" / "alcove"

#: Each unit of ``alcove`` (a subpackage or top-level module) and its floor: a unit may
#: import its own floor's units only where listed in SIDEWAYS, lower floors always.
FLOORS: dict[str, int] = {
    "settings": 0,
    "errors": 0,
    "ids": 0,
    "names": 0,
    "models": 1,
    "science": 1,
    "db": 2,
    "lineage": 3,
    "jobs": 3,
    "api": 4,
    "users": 5,
    "versioning": 6,
    "pool": 7,
    "tasks": 7,
    "surrogates": 8,
    "oracles": 8,
    "solving": 9,
    "campaigns": 10,
    "previews": 11,
    "app": 12,
}
SIDEWAYS: set[tuple[str, str]] = {("settings", "errors"), ("models", "errors")}
MAX_LINES = 400


def unit_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "alcove" and len(parts) > 1 else None


def imported_modules(path: Path, module: str) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = module.split(".")[: -node.level] if path.name != "__init__.py" else module.split(".")
                if path.name == "__init__.py" and node.level > 1:
                    base = module.split(".")[: -(node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.append(target)
            if target == "alcove":  # from alcove import versioning
                out += [f"alcove.{a.name}" for a in node.names]
    return out


def unit_imports() -> dict[tuple[str, str], list[str]]:
    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        module = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        src = unit_of(module)
        if src is None:
            continue
        for target in imported_modules(path, module):
            dst = unit_of(target)
            if dst is not None and dst != src:
                edges[(src, dst)].append(str(path.relative_to(REPO)))
    return edges


def test_every_unit_has_a_floor() -> None:
    units = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir() if p.suffix == ".py" or p.is_dir()}
    units -= {"__init__", "__pycache__", "static", "presets"}
    assert units <= set(FLOORS), f"give these a floor in FLOORS (and docs/architecture.md): {units - set(FLOORS)}"


def test_no_unit_imports_one_above_it() -> None:
    upward = [
        f"{src} -> {dst} ({', '.join(sorted(set(files)))})"
        for (src, dst), files in sorted(unit_imports().items())
        if FLOORS[dst] > FLOORS[src] or (FLOORS[dst] == FLOORS[src] and (src, dst) not in SIDEWAYS)
    ]
    assert not upward, "imports that run up (or sideways) the layers:\n" + "\n".join(upward)


def test_the_lower_domains_never_import_campaigns() -> None:
    edges = unit_imports()
    for lower in ("pool", "surrogates", "oracles", "tasks", "solving", "users", "api", "jobs"):
        assert (lower, "campaigns") not in edges, edges.get((lower, "campaigns"))


def test_no_module_outside_science_over_400_lines() -> None:
    roots = [PACKAGE, REPO / "worker", REPO / "bench", REPO / "scripts"]
    long = [
        f"{p.relative_to(REPO)}: {n} lines"
        for root in roots
        for p in sorted(root.rglob("*.py"))
        if "science" not in p.relative_to(REPO).parts and (n := len(p.read_text().splitlines())) > MAX_LINES
    ]
    assert not long, "split these where a reader would:\n" + "\n".join(long)
