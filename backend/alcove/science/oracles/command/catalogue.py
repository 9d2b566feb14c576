"""Reading the administrator's YAML catalogue of command oracles into validated entries."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from alcove.science.oracles.builtin import BUILTIN_TYPE_NAMES
from alcove.science.oracles.command.launcher import LauncherSpec
from alcove.science.oracles.command.spec import CatalogueError, CommandOracleSpec
from alcove.science.spec_checks import error_location

#: built-in oracle types that run an external program, which a catalogue's ``launchers`` may dispatch
EXTERNAL_BUILTIN_TYPES = ("fe-headrest-3d-ccx",)


def load_command_catalogue(path: str | Path) -> dict[str, CommandOracleSpec]:
    """Read the administrator's YAML catalogue.

    Format::

        command_oracles:
          lsdyna-headrest:
            description: LS-DYNA headrest model (MAT_057 foam)
            argv: ["{catalogue_dir}/run_lsdyna.sh", "ncpu=4"]
            template: lsdyna/headrest.k.tmpl
            timeout_s: 1800

    ``{catalogue_dir}`` (the catalogue's folder) and ``{python}`` (the Python running alcove)
    are replaced in ``argv`` and ``env`` values (also the launcher's ``env`` and ``job_root``);
    relative template paths are resolved from
    the catalogue's folder. Raises :class:`CatalogueError` naming the entry and key.
    """
    path = Path(path)
    raw = _read_yaml(path)
    if not isinstance(raw, dict) or not isinstance(raw.get("command_oracles"), dict):
        raise CatalogueError(
            "command_oracles", f"{path} must have a top-level mapping 'command_oracles: {{name: entry}}'"
        )
    base = path.resolve().parent

    def substitute(text: str) -> str:
        return text.replace("{catalogue_dir}", str(base)).replace("{python}", sys.executable)

    catalogue: dict[str, CommandOracleSpec] = {}
    for name, entry in raw["command_oracles"].items():
        field = f"command_oracles.{name}"
        if not isinstance(entry, dict):
            raise CatalogueError(field, "must be a mapping of settings")
        if str(name) in BUILTIN_TYPE_NAMES:
            raise CatalogueError(field, f"the name is a built-in oracle type ({', '.join(sorted(BUILTIN_TYPE_NAMES))})")
        if "name" in entry and entry["name"] != name:
            raise CatalogueError(f"{field}.name", "differs from the entry's key; leave it out")
        entry = {**entry, "name": str(name)}
        if isinstance(entry.get("argv"), str):
            raise CatalogueError(f"{field}.argv", "must be a list of arguments, not a shell string")
        if isinstance(entry.get("argv"), list):
            entry["argv"] = [substitute(a) if isinstance(a, str) else a for a in entry["argv"]]
        if isinstance(entry.get("env"), dict):
            entry["env"] = {k: substitute(v) if isinstance(v, str) else v for k, v in entry["env"].items()}
        launcher = entry.get("launcher")
        if isinstance(launcher, dict):
            launcher = dict(launcher)
            if isinstance(launcher.get("env"), dict):
                launcher["env"] = {k: substitute(v) if isinstance(v, str) else v for k, v in launcher["env"].items()}
            if isinstance(launcher.get("job_root"), str):
                launcher["job_root"] = substitute(launcher["job_root"])
            entry["launcher"] = launcher
        if isinstance(entry.get("template"), str):
            entry["template"] = base / substitute(entry["template"])
        try:
            spec = CommandOracleSpec.model_validate(entry)
        except ValidationError as exc:
            raise CatalogueError(*error_location(exc.errors()[0], prefix=("command_oracles", str(name)))) from None
        if spec.template is not None and not spec.template.is_file():
            raise CatalogueError(f"{field}.template", f"{spec.template} does not exist")
        catalogue[spec.name] = spec
    return catalogue


def load_builtin_launchers(path: str | Path) -> dict[str, LauncherSpec]:
    """The catalogue's optional ``launchers`` section: where built-in types that run an external
    program (``fe-headrest-3d-ccx``) run, by type name, e.g. ``launchers: {fe-headrest-3d-ccx:
    {scheduler: slurm, cpus_per_task: 4}}``. Raises :class:`CatalogueError` naming the key."""
    raw = _read_yaml(Path(path))
    section = raw.get("launchers") if isinstance(raw, dict) else None
    if section is None:
        return {}
    if not isinstance(section, dict):
        raise CatalogueError("launchers", "must be a mapping {built-in type: launcher}")
    launchers: dict[str, LauncherSpec] = {}
    for name, entry in section.items():
        if name not in EXTERNAL_BUILTIN_TYPES:
            raise CatalogueError(
                f"launchers.{name}", f"not a built-in type that runs a program ({', '.join(EXTERNAL_BUILTIN_TYPES)})"
            )
        try:
            launchers[str(name)] = LauncherSpec.model_validate(entry)
        except ValidationError as exc:
            raise CatalogueError(*error_location(exc.errors()[0], prefix=("launchers", str(name)))) from None
    return launchers


def _read_yaml(path: Path) -> Any:
    """The parsed YAML document (any YAML value: the caller checks its shape)."""
    try:
        return yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise CatalogueError("catalogue", f"{path} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CatalogueError("catalogue", f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise CatalogueError("catalogue", f"{path} is not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None


__all__ = ["EXTERNAL_BUILTIN_TYPES", "load_builtin_launchers", "load_command_catalogue"]
