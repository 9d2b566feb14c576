"""The import graph of alcove.science: no cycles, and nothing from the web, database or job layers.

Every import statement counts, including those inside functions and under ``TYPE_CHECKING``:
a lazy import hides a cycle from the interpreter, not from a reader.
"""

import ast
import graphlib
from pathlib import Path

import pytest

import alcove.science

SCIENCE = Path(alcove.science.__file__).parent
PACKAGE_ROOT = SCIENCE.parents[1]  # the folder holding the alcove package
FORBIDDEN = ("fastapi", "starlette", "sqlalchemy", "alembic", "celery", "kombu", "redis", "psycopg", "uvicorn")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names(path: Path) -> set[str]:
    """Absolute names of everything ``path`` imports (``from a import b`` gives ``a`` and ``a.b``)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            out.add(base)
            out.update(f"{base}.{alias.name}" for alias in node.names)
    return out


def science_graph() -> dict[str, set[str]]:
    """Module -> the science modules it imports."""
    files = {module_name(p): p for p in SCIENCE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        targets = set()
        for imported in imported_names(path):
            while imported and imported not in files:  # a name inside a module: the module
                imported = imported.rpartition(".")[0]
            if imported and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


def test_the_graph_sees_the_modules_and_their_imports():
    graph = science_graph()
    assert "alcove.science.oracles.command.oracle" in graph
    assert "alcove.science.geometry" in graph["alcove.science.oracles.command.template"]


def test_no_import_cycles_in_science():
    try:
        list(graphlib.TopologicalSorter(science_graph()).static_order())
    except graphlib.CycleError as exc:
        pytest.fail(f"import cycle: {' -> '.join(exc.args[1])}")


def test_a_cycle_would_be_found():
    graph = {"a": {"b"}, "b": {"a"}}
    with pytest.raises(graphlib.CycleError):
        list(graphlib.TopologicalSorter(graph).static_order())


@pytest.mark.parametrize("path", sorted(SCIENCE.rglob("*.py")), ids=lambda p: str(p.relative_to(SCIENCE)))
def test_science_imports_no_web_database_or_job_code(path):
    for name in imported_names(path):
        top = name.split(".")[0]
        assert top not in FORBIDDEN, f"{module_name(path)} imports {name}"
        if top == "alcove" and name != "alcove":  # alcove itself gives __version__
            assert name.startswith("alcove.science"), f"{module_name(path)} imports {name}"
