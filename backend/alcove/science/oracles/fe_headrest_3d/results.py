"""Reading CalculiX's output: the ``.dat`` node prints, the ``.sta`` increment log, ``*ERROR`` lines.

``.dat`` blocks look like::

     forces (fx,fy,fz) for set HEADREF and time  0.7500000E+00

          4105 -6.105571E+01 -8.703291E-12 -3.528675E-02

:func:`read_dat` returns, per (quantity, set), the times and a (times, nodes, 3) array;
:class:`CcxOutputError` says what is missing or garbled.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from alcove.science.arrays import FloatArray

HEADER = re.compile(r"^\s*(\w[\w ]*?)\s*\(([^)]*)\)\s+for set\s+(\S+)\s+and time\s+(\S+)\s*$")


class CcxOutputError(ValueError):
    """CalculiX's output is missing or cannot be read; the message says which file and why."""


@dataclass
class NodeSeries:
    times: FloatArray  # (k,)
    nodes: list[int]
    values: FloatArray  # (k, n, 3)


def read_dat(path: Path) -> dict[tuple[str, str], NodeSeries]:
    """Every node print of a ``.dat`` file, keyed by (quantity, set): ("forces", "HEADREF"), ..."""
    if not path.is_file():
        raise CcxOutputError(f"{path.name} is missing (ccx wrote no results)")
    blocks: dict[tuple[str, str], list[tuple[float, list[int], list[list[float]]]]] = {}
    current: tuple[list[int], list[list[float]]] | None = None
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        match = HEADER.match(line)
        if match:
            key = (match.group(1).strip(), match.group(3).upper())
            try:
                time = float(match.group(4))
            except ValueError:
                raise CcxOutputError(f"{path.name} line {number}: bad time {match.group(4)!r}") from None
            current = ([], [])
            blocks.setdefault(key, []).append((time, current[0], current[1]))
            continue
        fields = line.split()
        if not fields or current is None:
            continue
        if len(fields) != 4 or not fields[0].isdigit():
            current = None  # another kind of block (totals, contact prints): not ours
            continue
        try:
            values = [float(v) for v in fields[1:]]
        except ValueError:
            raise CcxOutputError(f"{path.name} line {number}: cannot read {line.strip()!r}") from None
        current[0].append(int(fields[0]))
        current[1].append(values)
    out: dict[tuple[str, str], NodeSeries] = {}
    for key, entries in blocks.items():
        nodes = entries[0][1]
        if any(e[1] != nodes for e in entries):
            raise CcxOutputError(f"{path.name}: the nodes of {key[0]} of set {key[1]} change between times")
        array: FloatArray = np.array([e[2] for e in entries], dtype=float).reshape(len(entries), len(nodes), 3)
        if not np.all(np.isfinite(array)):
            raise CcxOutputError(f"{path.name}: {key[0]} of set {key[1]} holds NaN or infinite values")
        out[key] = NodeSeries(np.array([e[0] for e in entries]), nodes, array)
    return out


@dataclass(frozen=True)
class StatusSummary:
    increments: int  # converged increments
    attempts: int  # all attempts, cut back or not
    iterations: int  # Newton iterations of the converged increments
    iterations_all: int  # of every attempt
    last_time: float | None


def read_sta(path: Path) -> StatusSummary:
    """Increments and Newton iterations from the ``.sta`` file (one line per attempt; ``U`` = cut back)."""
    increments = attempts = iterations = iterations_all = 0
    last: float | None = None
    if path.is_file():
        for line in path.read_text(errors="replace").splitlines():
            fields = line.split()
            if len(fields) != 7 or not fields[0].isdigit():
                continue
            attempt, its = fields[2], fields[3]
            try:
                n_it = int(its)
            except ValueError:
                continue
            attempts += 1
            iterations_all += n_it
            if not attempt.endswith("U"):
                increments += 1
                iterations += n_it
                last = float(fields[4])
    return StatusSummary(increments, attempts, iterations, iterations_all, last)


def solver_errors(log: str) -> list[str]:
    """ccx's own ``*ERROR`` messages in its standard output (each with its continuation lines)."""
    lines = log.splitlines()
    messages = []
    for i, line in enumerate(lines):
        if "*ERROR" in line.upper():
            text = [line.strip()]
            for more in lines[i + 1 : i + 4]:
                if not more.strip() or "*" in more[:3]:
                    break
                text.append(more.strip())
            messages.append(" ".join(text))
    return messages


__all__ = ["CcxOutputError", "NodeSeries", "StatusSummary", "read_dat", "read_sta", "solver_errors"]
