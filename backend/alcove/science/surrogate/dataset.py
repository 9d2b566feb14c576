"""The in-memory data pool: a list of datasets, one per simulation.

A :class:`PoolDataset` holds one simulation: ``name``, time ``t`` (n,), joint positions
``q`` and velocities ``qd`` (n, ndof), contact ``force`` and ``moment`` (n, 3) on the head
(headrest frame, moment about the head frame origin), its ``origin`` (``preliminary``,
``oracle`` or ``upload``) and an optional sample ``weight``. For preliminary data (no
time axis) ``t`` is the sample index.

Pool folder (``alcove surrogate train --pool DIR``)
---------------------------------------------------
Pairs ``NAME.traj.csv`` + ``NAME.forces.csv`` exactly as ``alcove ocp solve`` and
``alcove oracle run`` write them (see :mod:`alcove.science.series`), one pair per
simulation, on the same time grid. An optional ``pool.json``
``{"NAME": {"origin": "oracle", "weight": 0.5}, ...}`` sets origins and weights; without an
entry a dataset whose name starts with ``preliminary`` has origin ``preliminary``, any
other ``oracle``.

Preliminary upload CSV
----------------------
One CSV file with a header row; columns in any order:

``simulation`` (optional)
    label grouping rows into simulations; a simulation is never split between training
    and test. Without it, rows are independent samples, dealt round-robin into ``chunks``
    groups named ``upload-00``, ``upload-01``, ...
``t`` (optional)
    time [s], strictly increasing within a simulation; without it, the row index.
``q_0..q_{n-1}``, ``qd_0..qd_{n-1}``
    joint positions [rad] and velocities [rad/s].
``fx,fy,fz,mx,my,mz``
    contact force on the head [N] and its moment about the head frame origin [N m], in
    the headrest frame.

Every value must be a finite number within a plausible range (:func:`check_plausible`:
joint angles within the model's joint range, at most 90 degrees either way from the
vertical without a task; velocities within +-100 rad/s; forces within +-1e5 N; moments
within +-1e4 N m); errors name the column and the data row.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Literal, TypedDict

import numpy as np

from alcove.science.arrays import FloatArray, IndexArray
from alcove.science.errors import FieldError
from alcove.science.series import FORCE_COLUMNS, ForceSeries, SeriesFormatError, Trajectory

Origin = Literal["preliminary", "oracle", "upload"]
ORIGINS: tuple[str, ...] = ("preliminary", "oracle", "upload")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,127}$")


class ManifestEntry(TypedDict, total=False):
    """One dataset's entry in a pool folder's ``pool.json``."""

    origin: str
    weight: float


class PoolDataError(FieldError):
    """A dataset or pool is malformed; ``field`` names what is wrong."""


@dataclass(frozen=True)
class PoolDataset:
    """One simulation of the pool (see the module docstring)."""

    name: str
    t: FloatArray
    q: FloatArray
    qd: FloatArray
    force: FloatArray
    moment: FloatArray
    origin: str = "oracle"
    weight: float | None = None
    #: m: the headrest offset of the scenario the data were simulated in (HeadNeckPreset.headrest_offset;
    #: the features are relative to that headrest); None: the task's own headrest
    headrest_offset: float | None = None
    #: rad: the headrest tilt of the scenario the data were simulated in (HeadNeckPreset.tilt), recorded
    #: when the scenario drew it; None: the task's own tilt
    headrest_tilt: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise PoolDataError(
                "name", f"{self.name!r} is not a valid dataset name (letters, digits, _ . + -, at most 128)"
            )
        if self.origin not in ORIGINS:
            raise PoolDataError(f"{self.name}.origin", f"{self.origin!r} is not one of {', '.join(ORIGINS)}")
        if self.weight is not None and not (np.isfinite(self.weight) and self.weight >= 0):
            raise PoolDataError(f"{self.name}.weight", f"must be a finite number >= 0, got {self.weight!r}")
        t = np.asarray(self.t, float)
        if t.ndim != 1 or t.shape[0] == 0:
            raise PoolDataError(f"{self.name}.t", "must be a non-empty one-dimensional array (the data set is empty)")
        n = t.shape[0]
        arrays = {"t": t}
        for key in ("q", "qd", "force", "moment"):
            a = np.asarray(getattr(self, key), float)
            if a.ndim == 1:
                a = a[:, None] if key in ("q", "qd") else a.reshape(-1, 3)
            if a.ndim != 2 or a.shape[0] != n:
                raise PoolDataError(f"{self.name}.{key}", f"has shape {a.shape}, expected {n} rows")
            arrays[key] = a
        for key in ("force", "moment"):
            if arrays[key].shape[1] != 3:
                raise PoolDataError(f"{self.name}.{key}", f"must have 3 columns, got {arrays[key].shape[1]}")
        if arrays["qd"].shape[1] != arrays["q"].shape[1]:
            raise PoolDataError(
                f"{self.name}.qd", f"has {arrays['qd'].shape[1]} columns but q has {arrays['q'].shape[1]}"
            )
        for key, a in arrays.items():
            bad = ~np.isfinite(a)
            if bad.any():
                row = int(np.argwhere(bad)[0][0])
                raise PoolDataError(f"{self.name}.{key}", f"non-finite value (NaN or inf) at row {row + 1}")
            object.__setattr__(self, key, a)
        if n > 1 and np.any(np.diff(t) <= 0):
            raise PoolDataError(f"{self.name}.t", "time must increase strictly")

    @cached_property
    def content_key(self) -> str:
        """A digest of what the dataset is (its arrays, headrest offset and tilt), not of where it is stored:
        the same data get the same key in any database or folder (the stable warm-start split keys on it)."""
        h = hashlib.blake2b(digest_size=16)
        for a in (self.t, self.q, self.qd, self.force, self.moment):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
            h.update(str(np.shape(a)).encode())
        h.update(repr(self.headrest_offset).encode())
        if self.headrest_tilt is not None:  # only then: the keys of data without a recorded tilt stay as they were
            h.update(f"tilt={self.headrest_tilt!r}".encode())
        return h.hexdigest()

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def ndof(self) -> int:
        return int(self.q.shape[1])

    @classmethod
    def from_series(
        cls, name: str, trajectory: Trajectory, forces: ForceSeries, origin: str = "oracle", weight: float | None = None
    ) -> PoolDataset:
        """Pair a trajectory with the forces an oracle computed on the same time grid."""
        if len(trajectory) != len(forces) or not np.allclose(trajectory.t, forces.t, rtol=0, atol=1e-9):
            raise PoolDataError(
                f"{name}.t",
                f"the trajectory ({len(trajectory)} rows) and the forces ({len(forces)} rows) "
                "are not on the same time grid",
            )
        return cls(name, trajectory.t, trajectory.q, trajectory.qd, forces.force, forces.moment, origin, weight)

    def trajectory(self) -> Trajectory:
        return Trajectory(self.t, self.q, self.qd)

    def forces(self) -> ForceSeries:
        return ForceSeries(self.t, self.force, self.moment)


def default_origin(name: str) -> str:
    return "preliminary" if name.startswith("preliminary") else "oracle"


def load_pool_dir(path: str | Path) -> list[PoolDataset]:
    """Read a pool folder of ``NAME.traj.csv`` + ``NAME.forces.csv`` pairs (sorted by name)."""
    root = Path(path)
    if not root.is_dir():
        raise PoolDataError("pool", f"{root} is not a directory")
    manifest: dict[str, ManifestEntry] = {}
    if (root / "pool.json").exists():
        try:
            manifest = json.loads((root / "pool.json").read_text())
        except json.JSONDecodeError as exc:
            raise PoolDataError("pool.json", f"not valid JSON: {exc.msg}") from None
        if not isinstance(manifest, dict) or not all(isinstance(v, dict) for v in manifest.values()):
            raise PoolDataError("pool.json", 'must map dataset names to {"origin": ..., "weight": ...}')
    names = sorted(p.name[: -len(".traj.csv")] for p in root.glob("*.traj.csv"))
    orphans = sorted(p.name for p in root.glob("*.forces.csv") if p.name[: -len(".forces.csv")] not in names)
    if orphans:
        raise PoolDataError(orphans[0], "forces file without a matching NAME.traj.csv")
    if not names:
        raise PoolDataError("pool", f"{root} holds no NAME.traj.csv + NAME.forces.csv pairs (the pool is empty)")
    pool = []
    for name in names:
        forces_path = root / f"{name}.forces.csv"
        if not forces_path.exists():
            raise PoolDataError(f"{name}.forces.csv", "missing: every NAME.traj.csv needs its NAME.forces.csv")
        try:
            traj = Trajectory.from_csv(root / f"{name}.traj.csv")
        except SeriesFormatError as exc:
            raise PoolDataError(f"{name}.traj.csv:{exc.field}", exc.reason) from None
        try:
            forces = ForceSeries.from_csv(forces_path)
        except SeriesFormatError as exc:
            raise PoolDataError(f"{name}.forces.csv:{exc.field}", exc.reason) from None
        meta = manifest.get(name, {})
        pool.append(
            PoolDataset.from_series(name, traj, forces, meta.get("origin", default_origin(name)), meta.get("weight"))
        )
    check_pool(pool)
    return pool


def save_pool_dir(pool: list[PoolDataset], path: str | Path) -> Path:
    """Write a pool as a folder readable by :func:`load_pool_dir` (with ``pool.json``)."""
    root = Path(path)
    root.mkdir(parents=True, exist_ok=True)
    for ds in pool:
        ds.trajectory().to_csv(root / f"{ds.name}.traj.csv")
        ds.forces().to_csv(root / f"{ds.name}.forces.csv")
    manifest = {
        ds.name: {"origin": ds.origin, **({"weight": ds.weight} if ds.weight is not None else {})} for ds in pool
    }
    (root / "pool.json").write_text(json.dumps(manifest, indent=1))
    return root


def check_pool(pool: list[PoolDataset]) -> None:
    """A usable pool: not empty, unique names, one number of degrees of freedom."""
    if not pool:
        raise PoolDataError("pool", "is empty: train needs at least one dataset")
    seen: set[str] = set()
    for ds in pool:
        if not isinstance(ds, PoolDataset):
            raise PoolDataError("pool", f"holds a {type(ds).__name__}, expected PoolDataset")
        if ds.name in seen:
            raise PoolDataError(ds.name, "duplicate dataset name in the pool")
        seen.add(ds.name)
        if ds.ndof != pool[0].ndof:
            raise PoolDataError(
                f"{ds.name}.q", f"has {ds.ndof} degrees of freedom but {pool[0].name} has {pool[0].ndof}"
            )


def load_preliminary_csv(
    source: str | Path | io.TextIOBase,
    origin: str = "upload",
    chunks: int = 10,
    prefix: str | None = None,
    max_simulations: int | None = None,
) -> list[PoolDataset]:
    """Read a preliminary upload CSV (format in the module docstring) into pool datasets, in
    time linear in its size; at most ``max_simulations`` distinct ``simulation`` labels (one
    dataset each) when given."""
    if isinstance(source, (str, Path)):
        try:
            text = Path(source).read_text()
        except FileNotFoundError:
            raise PoolDataError("file", f"{source} does not exist") from None
        except UnicodeDecodeError:
            raise PoolDataError("file", f"{source} is not a UTF-8 text file") from None
    else:
        text = source.read()
    try:
        # newline="": a line may end in \r, \n or \r\n, as the csv module reads it
        rows = [r for r in csv.reader(io.StringIO(text, newline="")) if r and any(c.strip() for c in r)]
    except csv.Error as err:
        raise PoolDataError("file", f"not a CSV file the reader can parse: {err}") from None
    if not rows:
        raise PoolDataError("header", "the file is empty")
    header = [c.strip() for c in rows[0]]
    body = rows[1:]
    if not body:
        raise PoolDataError("rows", "the file has a header but no data rows (the data set is empty)")
    counts = Counter(header)
    dup = [c for c in header if counts[c] > 1]
    if dup:
        raise PoolDataError(dup[0], "duplicate column")
    n_q = sum(1 for c in header if re.fullmatch(r"q_\d+", c))
    if n_q == 0:
        raise PoolDataError("q_0", "missing: expected columns q_0..q_{n-1} and qd_0..qd_{n-1}")
    required = [f"q_{i}" for i in range(n_q)] + [f"qd_{i}" for i in range(n_q)] + list(FORCE_COLUMNS)
    for c in required:
        if c not in counts:
            raise PoolDataError(c, "missing column")
    known = set(required) | {"simulation", "t"}
    for c in header:
        if c not in known:
            raise PoolDataError(c, "unknown column")
    col = {c: j for j, c in enumerate(header)}
    numeric = [c for c in header if c != "simulation"]
    data = np.empty((len(body), len(numeric)))
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise PoolDataError(f"row {i + 2}", f"has {len(r)} fields, the header has {len(header)}")
        for j, c in enumerate(numeric):
            try:
                v = float(r[col[c]])
            except ValueError:
                raise PoolDataError(c, f"not a number at data row {i + 1}: {r[col[c]]!r}") from None
            if not np.isfinite(v):
                raise PoolDataError(c, f"non-finite value (NaN or inf) at data row {i + 1}")
            data[i, j] = v
    num = {c: data[:, j] for j, c in enumerate(numeric)}
    if "simulation" in col:
        groups: dict[str, list[int]] = {}
        for i, r in enumerate(body):
            groups.setdefault(r[col["simulation"]].strip(), []).append(i)
        if max_simulations is not None and len(groups) > max_simulations:
            raise PoolDataError(
                "simulation",
                f"has {len(groups)} distinct labels, at most {max_simulations} are allowed per upload"
                " (one data set each): split the file into several uploads",
            )
        named = {(f"{prefix}-{lab}" if prefix else lab): idx for lab, idx in groups.items()}
    else:
        k = max(1, min(chunks, len(body)))
        stem = prefix or origin
        named = {f"{stem}-{g:02d}": list(range(g, len(body), k)) for g in range(k)}
    pool = []
    for name, idx in named.items():
        idx_a = np.asarray(idx)
        t = num["t"][idx_a] if "t" in num else np.arange(len(idx_a), dtype=float)
        pool.append(
            PoolDataset(
                name,
                t,
                _stacked(num, [f"q_{i}" for i in range(n_q)], idx_a),
                _stacked(num, [f"qd_{i}" for i in range(n_q)], idx_a),
                _stacked(num, FORCE_COLUMNS[:3], idx_a),
                _stacked(num, FORCE_COLUMNS[3:], idx_a),
                origin,
            )
        )
    check_pool(pool)
    return pool


#: |contact force| [N] and |moment| [N m] of plausible data: a head on a headrest sees up to a
#: few kN in a crash; anything beyond this is a unit mistake or garbage, not a measurement.
MAX_CONTACT_FORCE = 1e5
MAX_CONTACT_MOMENT = 1e4


@dataclass(frozen=True)
class StateRange:
    """Plausible joint angles [rad] and velocities [rad/s] of data for one model."""

    q_min: float
    q_max: float
    qd_max: float
    what: str  # where the range comes from, for the error message


def default_state_range() -> StateRange:
    """Without a task: the bounds every task's model keeps to."""
    from alcove.science.geometry import ANGLE_LIMIT, MAX_ANGULAR_VELOCITY

    return StateRange(-ANGLE_LIMIT, ANGLE_LIMIT, MAX_ANGULAR_VELOCITY, "the joint range any model allows")


def check_plausible(pool: Sequence[PoolDataset], state: StateRange | None = None) -> None:
    """Every value of every dataset within its plausible range, else :class:`PoolDataError`
    naming the column (``q_0``, ``qd_0``, ``fx``, ...), the dataset and the row. Data outside
    the task's model range would train a surrogate on states the OCP can never reach (and
    values like 1e308 overflow in the standardisation)."""
    state = state or default_state_range()
    for ds in pool:
        checks: list[tuple[str, FloatArray, float, float, str]] = []
        for i in range(ds.ndof):
            checks.append((f"q_{i}", ds.q[:, i], state.q_min, state.q_max, f"rad ({state.what})"))
            checks.append((f"qd_{i}", ds.qd[:, i], -state.qd_max, state.qd_max, "rad/s"))
        for j, c in enumerate(FORCE_COLUMNS[:3]):
            checks.append((c, ds.force[:, j], -MAX_CONTACT_FORCE, MAX_CONTACT_FORCE, "N"))
        for j, c in enumerate(FORCE_COLUMNS[3:]):
            checks.append((c, ds.moment[:, j], -MAX_CONTACT_MOMENT, MAX_CONTACT_MOMENT, "N m"))
        for column, values, lo, hi, unit in checks:
            bad = np.flatnonzero((values < lo) | (values > hi))
            if bad.size:
                row = int(bad[0])
                raise PoolDataError(
                    column,
                    f"{values[row]:g} at row {row + 1} of dataset {ds.name} lies outside {lo:g} to {hi:g} {unit}",
                )


def _stacked(columns: dict[str, FloatArray], names: Sequence[str], rows: IndexArray) -> FloatArray:
    """The ``rows`` of the named columns side by side, shape (len(rows), len(names))."""
    return np.stack([columns[c][rows] for c in names], -1)


__all__ = [
    "MAX_CONTACT_FORCE",
    "MAX_CONTACT_MOMENT",
    "ORIGINS",
    "Origin",
    "PoolDataError",
    "PoolDataset",
    "StateRange",
    "check_plausible",
    "check_pool",
    "default_origin",
    "default_state_range",
    "load_pool_dir",
    "load_preliminary_csv",
    "save_pool_dir",
]
