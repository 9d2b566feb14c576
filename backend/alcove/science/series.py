"""Time series exchanged between the OCP, the oracles and the surrogate, with CSV I/O.

Two file formats, used by the CLI, the ``command`` oracle contract and pool folders:

* trajectory CSV: header ``t,q_0,...,q_{n-1},qd_0,...,qd_{n-1},tau_0,...,tau_{n-1}``
  (s, rad, rad/s, N m), then the contact body's pose and twist relative to the headrest
  ``head_x,head_z,head_angle,head_vx,head_vz,head_omega`` (headrest frame; m, rad, m/s,
  rad/s; :data:`alcove.science.geometry.POSE_COLUMNS`). ``tau`` columns may be absent (an
  oracle does not need them); the pose columns may be absent only for a 1-joint trajectory
  (a file of the head-neck-1dof preset from before they existed: the reader computes the
  pose from that preset).
* forces CSV: header ``t,fx,fy,fz,mx,my,mz`` (s, N, N m; contact force on the head and
  its moment about the head frame origin, both in the headrest frame).

Readers validate strictly and raise :class:`SeriesFormatError` naming the column (or
row) and the reason.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.errors import FieldError
from alcove.science.geometry import POSE_COLUMNS, PoseFunction

FORCE_COLUMNS = ("fx", "fy", "fz", "mx", "my", "mz")


def stack_wrench(force: FloatArray, moment: FloatArray) -> FloatArray:
    """The wrench rows ``[fx fy fz mx my mz]`` (n, 6) of force (n, 3) and moment (n, 3): the
    layout of the stored oracle arrays, the forces CSV (after ``t``) and the metrics."""
    return np.hstack([np.asarray(force, float).reshape(-1, 3), np.asarray(moment, float).reshape(-1, 3)])


def split_wrench(wrench: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Force (n, 3) and moment (n, 3) of wrench rows (n, 6) (:func:`stack_wrench`'s inverse)."""
    w = np.asarray(wrench, float)
    if w.ndim != 2 or w.shape[1] != 6:
        raise ValueError(f"wrench rows have 6 columns (fx fy fz mx my mz), got shape {w.shape}")
    return w[:, :3], w[:, 3:]


class SeriesFormatError(FieldError):
    """A trajectory or forces table is malformed. ``field`` names the offending column."""


@dataclass(frozen=True)
class Trajectory:
    """Joint trajectory on a time grid: t (n,), q (n, ndof), qd (n, ndof), tau (n, ndof) or None,
    and the contact body's pose and twist relative to the headrest, ``pose`` (n, 6) with the
    columns :data:`~alcove.science.geometry.POSE_COLUMNS`, or None.

    ``model`` (optional) is the task model's pose as a function of the joint state: given, the
    pose is computed from it (unless ``pose`` is given too) and :meth:`resample` recomputes it at
    the new samples; without it, :meth:`resample` interpolates the pose columns linearly like
    the joint columns.
    """

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    tau: FloatArray | None = None
    pose: FloatArray | None = None
    model: PoseFunction | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, float)
        q = np.asarray(self.q, float)
        qd = np.asarray(self.qd, float)
        if q.ndim == 1:
            q = q[:, None]
        if qd.ndim == 1:
            qd = qd[:, None]
        tau = None if self.tau is None else np.asarray(self.tau, float)
        if tau is not None and tau.ndim == 1:
            tau = tau[:, None]
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "qd", qd)
        object.__setattr__(self, "tau", tau)
        validate_time(t, "t")
        for name, arr in (("q", q), ("qd", qd)) + ((("tau", tau),) if tau is not None else ()):
            if arr.shape[0] != t.shape[0]:
                raise SeriesFormatError(name, f"has {arr.shape[0]} rows but t has {t.shape[0]}")
            if arr.shape[1] != q.shape[1]:
                raise SeriesFormatError(name, f"has {arr.shape[1]} columns, expected {q.shape[1]}")
            _check_finite(arr, name)
        pose = self.pose
        if pose is None and self.model is not None:
            pose = self.model(q, qd)
        if pose is not None:
            pose = np.asarray(pose, float)
            if pose.ndim != 2 or pose.shape != (t.shape[0], len(POSE_COLUMNS)):
                raise SeriesFormatError(
                    "pose",
                    f"has shape {pose.shape}, expected ({t.shape[0]}, {len(POSE_COLUMNS)}) ({', '.join(POSE_COLUMNS)})",
                )
            for j, name in enumerate(POSE_COLUMNS):
                _check_finite(pose[:, j], name)
        object.__setattr__(self, "pose", pose)

    def with_model(self, model: PoseFunction) -> Trajectory:
        """The same joint motion with its pose computed from ``model`` (and recomputed on resampling)."""
        return Trajectory(self.t, self.q, self.qd, self.tau, None, model)

    @property
    def ndof(self) -> int:
        return int(self.q.shape[1])

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def resample(self, t_new: FloatArray) -> Trajectory:
        """Linear interpolation onto ``t_new`` (must lie within the time span)."""
        t_new = np.asarray(t_new, float)
        if t_new.min() < self.t[0] - 1e-12 or t_new.max() > self.t[-1] + 1e-12:
            raise SeriesFormatError("t", "resampling grid leaves the trajectory's time span")

        def interp(a: FloatArray) -> FloatArray:
            return np.stack([np.interp(t_new, self.t, a[:, j]) for j in range(a.shape[1])], -1)

        tau = None if self.tau is None else interp(self.tau)
        if self.model is not None:
            return Trajectory(t_new, interp(self.q), interp(self.qd), tau, None, self.model)
        pose = None if self.pose is None else interp(self.pose)
        return Trajectory(t_new, interp(self.q), interp(self.qd), tau, pose)

    def window(self, t0: float, t1: float) -> Trajectory:
        m = (self.t >= t0 - 1e-12) & (self.t <= t1 + 1e-12)
        return Trajectory(
            self.t[m],
            self.q[m],
            self.qd[m],
            None if self.tau is None else self.tau[m],
            None if self.pose is None else self.pose[m],
            self.model,
        )

    # ---- CSV -------------------------------------------------------------------
    def header(self) -> list[str]:
        n = self.ndof
        cols = ["t"] + [f"q_{i}" for i in range(n)] + [f"qd_{i}" for i in range(n)]
        if self.tau is not None:
            cols += [f"tau_{i}" for i in range(n)]
        if self.pose is not None:
            cols += list(POSE_COLUMNS)
        return cols

    def to_array(self) -> FloatArray:
        parts = [self.t[:, None], self.q, self.qd] + ([self.tau] if self.tau is not None else [])
        if self.pose is not None:
            parts.append(self.pose)
        return np.hstack(parts)

    def to_csv(self, path: str | Path | None = None) -> str:
        text = _write_csv(self.header(), self.to_array())
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_csv(cls, source: str | Path | io.TextIOBase, model: PoseFunction | None = None) -> Trajectory:
        """Read a trajectory CSV. Without pose columns, ``model`` (the head-neck-1dof preset's pose,
        :func:`alcove.science.geometry.preset_pose_function`) computes the pose; a file of several
        joints needs the pose columns."""
        header, data = _read_csv(source)
        if not header or header[0] != "t":
            raise SeriesFormatError("t", "the first column must be 't'")
        q_cols = _indexed(header, "q")
        qd_cols = _indexed(header, "qd")
        tau_cols = _indexed(header, "tau")
        if not q_cols:
            raise SeriesFormatError("q_0", "missing: a trajectory needs columns q_0..q_{n-1}")
        n = len(q_cols)
        if len(qd_cols) != n:
            raise SeriesFormatError(
                f"qd_{len(qd_cols)}" if len(qd_cols) < n else "qd", f"expected {n} velocity columns qd_0..qd_{n - 1}"
            )
        if tau_cols and len(tau_cols) != n:
            raise SeriesFormatError("tau", f"expected {n} torque columns tau_0..tau_{n - 1} or none")
        known = (
            {"t"}
            | {f"q_{i}" for i in range(n)}
            | {f"qd_{i}" for i in range(n)}
            | {f"tau_{i}" for i in range(len(tau_cols))}
            | set(POSE_COLUMNS)
        )
        unknown = [c for c in header if c not in known]
        if unknown:
            raise SeriesFormatError(unknown[0], "unknown column")
        given = [c for c in POSE_COLUMNS if c in header]
        if given and len(given) != len(POSE_COLUMNS):
            missing = next(c for c in POSE_COLUMNS if c not in header)
            raise SeriesFormatError(missing, f"missing: give all pose columns {','.join(POSE_COLUMNS)} or none")
        if not given and n != 1:
            raise SeriesFormatError(
                POSE_COLUMNS[0],
                f"missing: a trajectory of {n} joints needs the pose columns {','.join(POSE_COLUMNS)} "
                "(only a 1-joint file of the head-neck-1dof preset may leave them out)",
            )
        col = {c: j for j, c in enumerate(header)}

        def take(names: list[str] | tuple[str, ...]) -> FloatArray:
            return data[:, [col[c] for c in names]]

        tau = take([f"tau_{i}" for i in range(n)]) if tau_cols else None
        pose = take(POSE_COLUMNS) if given else None
        q, qd = take([f"q_{i}" for i in range(n)]), take([f"qd_{i}" for i in range(n)])
        return cls(data[:, 0], q, qd, tau, pose, None if given else model)


@dataclass(frozen=True)
class ForceSeries:
    """Contact force (n, 3) and moment (n, 3) on the head in the headrest frame over t (n,)."""

    t: FloatArray
    force: FloatArray
    moment: FloatArray

    def __post_init__(self) -> None:
        t = np.asarray(self.t, float)
        f = np.asarray(self.force, float).reshape(-1, 3)
        m = np.asarray(self.moment, float).reshape(-1, 3)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "force", f)
        object.__setattr__(self, "moment", m)
        validate_time(t, "t")
        for name, arr in (("force", f), ("moment", m)):
            if arr.shape[0] != t.shape[0]:
                raise SeriesFormatError(name, f"has {arr.shape[0]} rows but t has {t.shape[0]}")
        for j, c in enumerate(FORCE_COLUMNS):
            _check_finite((f if j < 3 else m)[:, j % 3], c)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @classmethod
    def from_wrench(cls, t: FloatArray, wrench: FloatArray) -> ForceSeries:
        return cls(t, *split_wrench(wrench))

    @property
    def wrench(self) -> FloatArray:
        """(n, 6) rows ``[fx fy fz mx my mz]``."""
        return stack_wrench(self.force, self.moment)

    def to_array(self) -> FloatArray:
        return np.hstack([self.t[:, None], self.wrench])

    def to_csv(self, path: str | Path | None = None) -> str:
        text = _write_csv(["t", *FORCE_COLUMNS], self.to_array())
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_csv(cls, source: str | Path | io.TextIOBase) -> ForceSeries:
        header, data = _read_csv(source)
        expected = ["t", *FORCE_COLUMNS]
        for c in expected:
            if c not in header:
                raise SeriesFormatError(c, "missing column (expected header t,fx,fy,fz,mx,my,mz)")
        unknown = [c for c in header if c not in expected]
        if unknown:
            raise SeriesFormatError(unknown[0], "unknown column (expected header t,fx,fy,fz,mx,my,mz)")
        col = {c: j for j, c in enumerate(header)}
        return cls(
            data[:, col["t"]],
            data[:, [col[c] for c in FORCE_COLUMNS[:3]]],
            data[:, [col[c] for c in FORCE_COLUMNS[3:]]],
        )

    @property
    def peak_force(self) -> float:
        return float(np.max(np.linalg.norm(self.force, axis=1))) if len(self) else 0.0


def validate_time(t: FloatArray, name: str = "t") -> None:
    if t.ndim != 1:
        raise SeriesFormatError(name, "must be one-dimensional")
    if t.shape[0] < 2:
        raise SeriesFormatError(name, f"needs at least 2 samples, got {t.shape[0]}")
    _check_finite(t, name)
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0)) + 1
        raise SeriesFormatError(name, f"time must increase strictly (row {i + 1}: {t[i]!r} after {t[i - 1]!r})")


def _check_finite(arr: FloatArray, name: str) -> None:
    bad = ~np.isfinite(arr)
    if np.any(bad):
        row = int(np.argwhere(bad)[0][0])
        raise SeriesFormatError(name, f"non-finite value (NaN or inf) at data row {row + 1}")


def _indexed(header: list[str], prefix: str) -> list[str]:
    pat = re.compile(rf"^{prefix}_(\d+)$")
    idx = sorted(int(m.group(1)) for c in header if (m := pat.match(c)))
    if idx and idx != list(range(len(idx))):
        missing = sorted(set(range(max(idx) + 1)) - set(idx))
        raise SeriesFormatError(
            f"{prefix}_{missing[0] if missing else idx[-1]}", "columns must be numbered 0..n-1 without gaps or repeats"
        )
    return [f"{prefix}_{i}" for i in idx]


def _read_csv(source: str | Path | io.TextIOBase) -> tuple[list[str], FloatArray]:
    if isinstance(source, (str, Path)):
        path = Path(source)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise SeriesFormatError("file", f"{path} does not exist") from None
        except UnicodeDecodeError:
            raise SeriesFormatError("file", f"{path} is not a UTF-8 text file") from None
    else:
        text = source.read()
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    if not rows:
        raise SeriesFormatError("header", "the file is empty")
    header = [c.strip() for c in rows[0]]
    if len(set(header)) != len(header):
        dup = next(c for c in header if header.count(c) > 1)
        raise SeriesFormatError(dup, "duplicate column")
    body = rows[1:]
    if not body:
        raise SeriesFormatError("rows", "the file has a header but no data rows")
    data = np.empty((len(body), len(header)))
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise SeriesFormatError(f"row {i + 2}", f"has {len(r)} fields, the header has {len(header)}")
        for j, c in enumerate(r):
            try:
                data[i, j] = float(c)
            except ValueError:
                raise SeriesFormatError(header[j], f"not a number at data row {i + 1}: {c!r}") from None
    return header, data


def _write_csv(header: list[str], data: FloatArray) -> str:
    out = io.StringIO()
    out.write(",".join(header) + "\n")
    np.savetxt(out, data, delimiter=",", fmt="%.17g")
    return out.getvalue()
