"""The layout contributors rely on (docs/architecture.md): a domain never imports one above
it, the web plumbing imports no domain, the science package is layered the same way inside,
the campaign domain's wings import only what every wing reads and the wings below them (``run``
and ``views`` never each other), the architecture page's import tables are the measured ones, the
domains have the files it names and their routers change rows only through their services,
and no module outside the science package grows past 400 lines. Read from the code's own imports (every import, also
those inside functions and under TYPE_CHECKING)."""

from __future__ import annotations

import ast
import re
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

#: The units of ``alcove.science`` (a subpackage or module) and their floors, read the same way:
#: the tools every part uses at the bottom, the OCP (which takes any contact model: the
#: auxiliary law or a surrogate) at the top.
SCIENCE_FLOORS: dict[str, int] = {
    "arrays": 0,
    "errors": 0,
    "json_values": 0,
    "parallel": 0,
    "symbolic": 0,
    "spec_checks": 0,
    "geometry": 1,
    "series": 2,
    "multibody": 2,
    "press_family": 3,
    "oracles": 3,
    "surrogate": 4,
    "validation_suite": 4,
    "ocp": 5,
}
ARCHITECTURE = REPO / "docs" / "architecture.md"


def unit_of(module: str, package: tuple[str, ...] = ("alcove",)) -> str | None:
    parts = module.split(".")
    n = len(package)
    return parts[n] if tuple(parts[:n]) == package and len(parts) > n else None


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
            # from alcove import versioning; from alcove.campaigns import service
            out += [f"{target}.{a.name}" for a in node.names]
    return out


def unit_imports(package: tuple[str, ...] = ("alcove",)) -> dict[tuple[str, str], list[str]]:
    """(importing unit, imported unit) -> the files with such an import, for the units of
    ``package`` (``("alcove",)``, or ``("alcove", "science")`` for the science's own)."""
    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for path in PACKAGE.parent.joinpath(*package).rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        module = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        src = unit_of(module, package)
        if src is None:
            continue
        for target in imported_modules(path, module):
            dst = unit_of(target, package)
            if dst is not None and dst != src:
                edges[(src, dst)].append(str(path.relative_to(REPO)))
    return edges


def documented_imports(heading: str) -> dict[str, set[str]]:
    """The first table after the paragraph starting ``heading`` in docs/architecture.md: unit ->
    the units it imports (``| `unit` | `a`, `b` |``; a dash for none)."""
    text = ARCHITECTURE.read_text()
    assert heading in text, f"docs/architecture.md has no paragraph {heading!r}"
    table: dict[str, set[str]] = {}
    lines = text.split(heading, 1)[1].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))  # the table after the paragraph
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        units = re.findall(r"`([a-z_]+)`", cells[0])
        if len(cells) != 2 or not units:
            continue  # the header and its rule
        for unit in units:
            table[unit] = set(re.findall(r"`([a-z_]+)`", cells[1]))
    return table


def measured_imports(package: tuple[str, ...], floors: dict[str, int], below: int) -> dict[str, set[str]]:
    """unit -> the units above floor ``below`` it imports, for every unit of ``floors`` above it."""
    table: dict[str, set[str]] = {u: set() for u, floor in floors.items() if floor > below}
    for src, dst in unit_imports(package):
        if src in table and floors[dst] > below:
            table[src].add(dst)
    return table


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


def test_science_units_import_only_lower_ones() -> None:
    units = {
        p.stem if p.is_file() else p.name for p in (PACKAGE / "science").iterdir() if p.suffix == ".py" or p.is_dir()
    }
    units -= {"__init__", "__pycache__"}
    assert units <= set(SCIENCE_FLOORS), (
        f"give these a floor in SCIENCE_FLOORS (and docs/architecture.md): {units - set(SCIENCE_FLOORS)}"
    )
    upward = [
        f"{src} -> {dst} ({', '.join(sorted(set(files)))})"
        for (src, dst), files in sorted(unit_imports(("alcove", "science")).items())
        if SCIENCE_FLOORS[dst] >= SCIENCE_FLOORS[src]
    ]
    assert not upward, "science imports that run up (or sideways) its layers:\n" + "\n".join(upward)


def test_the_documented_import_tables_are_the_measured_ones() -> None:
    for heading, package, floors, below in [
        ("Which units import which", ("alcove",), FLOORS, 2),
        ("Inside `science/`", ("alcove", "science"), SCIENCE_FLOORS, 0),
    ]:
        documented, measured = documented_imports(heading), measured_imports(package, floors, below)
        wrong = [
            f"{unit}: documented {sorted(documented.get(unit, set()))}, measured {sorted(imports)}"
            for unit, imports in sorted(measured.items())
            if documented.get(unit) != imports
        ]
        wrong += [f"{unit}: documented, not a unit" for unit in sorted(set(documented) - set(measured))]
        assert not wrong, f"docs/architecture.md, {heading!r}, disagrees with the code:\n" + "\n".join(wrong)


def campaign_modules() -> list[str]:
    """The campaign domain's modules as paths inside ``campaigns/`` (``service.py``, ``run/steps.py``)."""
    root = PACKAGE / "campaigns"
    return [p.relative_to(root).as_posix() for p in sorted(root.rglob("*.py")) if p.name != "__init__.py"]


def test_every_campaign_module_is_on_the_architecture_page() -> None:
    text = ARCHITECTURE.read_text()
    missing = [name for name in campaign_modules() if f"`{name}`" not in text]
    assert not missing, f"say what these do in docs/architecture.md's campaign table: {missing}"


#: The campaign domain's wings (``campaigns/<wing>/``) and what each may import of the domain
#: besides itself: the modules at its root that every wing reads (BASE) and the wings listed here.
#: ``run`` (in a worker) and ``views`` (what the API reads) never import each other, nor does a
#: wing import the lifecycle at the root (service, router, schemas, draft, ...).
CAMPAIGN_BASE = {"config", "repository", "candidate_queries", "suite"}
CAMPAIGN_WINGS: dict[str, set[str]] = {"machine": set(), "run": {"machine"}, "views": {"machine"}}


def test_campaign_wings_import_only_the_base_and_the_wings_below() -> None:
    root = PACKAGE / "campaigns"
    wrong = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).with_suffix("")
        part = rel.parts[0] if len(rel.parts) > 1 else None  # the wing, or None at the root
        module = "alcove.campaigns." + ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        if part is None and rel.name not in CAMPAIGN_BASE:
            continue  # the lifecycle may import anything of its domain
        allowed = CAMPAIGN_BASE | ({part} | CAMPAIGN_WINGS[part] if part else set())
        for target in imported_modules(path, module):
            inside = unit_of(target, ("alcove", "campaigns"))
            if inside is not None and inside not in allowed:
                wrong.append(f"{path.relative_to(REPO)} imports {target}")
    assert not wrong, "the campaign wings import only the base and the wings below them:\n" + "\n".join(wrong)


def test_run_and_views_never_import_each_other() -> None:
    edges = unit_imports(("alcove", "campaigns"))
    assert ("run", "views") not in edges, edges.get(("run", "views"))
    assert ("views", "run") not in edges, edges.get(("views", "run"))


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


#: The domains the API reaches and the files each has (docs/architecture.md, "A domain that the
#: API reaches"): the four of a domain, or what the previews have instead.
DOMAIN_FILES: dict[str, set[str]] = {
    **{
        d: {"schemas", "service", "repository", "router"}
        for d in ("users", "tasks", "oracles", "pool", "surrogates", "campaigns")
    },
    "previews": {"service", "router", "worker"},
    "solving": {"repository", "steps"},
}


def test_the_domains_have_the_files_the_architecture_page_names() -> None:
    missing = [f"{d}/{name}.py" for d, names in DOMAIN_FILES.items() for name in sorted(names)]
    missing = [m for m in missing if not (PACKAGE / m).is_file()]
    assert not missing, f"docs/architecture.md names these files: {missing}"
    assert not (PACKAGE / "previews" / "repository.py").is_file(), "the previews' queries live in their service"
    assert not (PACKAGE / "solving" / "router.py").is_file(), "solving/ has no route"


def test_routers_change_definitions_through_their_service() -> None:
    """A router parses, calls its service for a change and commits: it never adds, deletes or
    versions rows itself (``versioning.create``/``update``/``delete``, ``session.add``/``delete``)."""
    wrong = []
    for path in sorted(PACKAGE.rglob("*router*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and isinstance(node.func.value, ast.Name)
                and (
                    (node.func.value.id == "versioning" and node.func.attr in {"create", "update", "delete"})
                    or (node.func.value.id in {"session", "s"} and node.func.attr in {"add", "add_all", "delete"})
                )
            ):
                wrong.append(f"{path.relative_to(REPO)}:{node.lineno}: {node.func.value.id}.{node.func.attr}")
    assert not wrong, "writes that belong in the service:\n" + "\n".join(wrong)
