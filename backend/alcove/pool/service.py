"""Pool versions and datasets: store, version, load for training, tabulate for export.

Arrays live in content-addressed blobs (:mod:`alcove.db.arrays`): ``t`` (n,), ``q``,
``qd`` (n, ndof) and ``f`` (n, 6: fx fy fz mx my mz in the headrest frame).
"""

from __future__ import annotations

import csv
import hashlib
import io
import threading
from typing import TYPE_CHECKING, Any

import numpy as np
from cachetools import LRUCache, cached
from sqlalchemy.orm import Session

from alcove.db.arrays import get_arrays, put_arrays
from alcove.errors import InvalidInput, NotFound
from alcove.models import Dataset, PoolVersion
from alcove.pool import repository as repo
from alcove.pool.schemas import PoolVersionRead
from alcove.science.series import split_wrench, stack_wrench

if TYPE_CHECKING:
    from alcove.science.surrogate.dataset import PoolDataset, StateRange

FORCE_COLUMNS = ("fx", "fy", "fz", "mx", "my", "mz")


@cached(LRUCache(maxsize=2048), key=lambda s, dataset: dataset.content_sha256, lock=threading.Lock())
def dataset_arrays(s: Session, dataset: Dataset) -> dict[str, np.ndarray]:
    """The arrays of a dataset (cached per process by content hash: blobs are immutable)."""
    return get_arrays(s, dataset.content_sha256)


def store_dataset(
    s: Session,
    *,
    t: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    f: np.ndarray,
    origin: str,
    name: str,
    campaign_id: int | None = None,
    iteration_id: int | None = None,
    oracle_run_id: int | None = None,
    owner_id: int | None = None,
    meta: dict[str, Any] | None = None,
) -> Dataset:
    q2 = np.asarray(q, float).reshape(len(t), -1)
    arrays = {
        "t": np.asarray(t, float),
        "q": q2,
        "qd": np.asarray(qd, float).reshape(q2.shape),
        "f": np.asarray(f, float).reshape(len(t), 6),
    }
    sha = put_arrays(s, arrays)
    ds = Dataset(
        origin=origin,
        content_sha256=sha,
        campaign_id=campaign_id,
        iteration_id=iteration_id,
        oracle_run_id=oracle_run_id,
        owner_id=owner_id,
        name=name,
        n_samples=len(t),
        n_trajectories=1,
        meta=meta or {},
    )
    s.add(ds)
    s.flush()
    return ds


def create_version(
    s: Session,
    *,
    campaign_id: int,
    iteration_id: int,
    version: int,
    parent: PoolVersion | None,
    new_datasets: list[Dataset],
) -> PoolVersion:
    """Pool version ``version`` = ``parent``'s members + ``new_datasets`` (a dataset that is
    already a member is not added again). The member rows are inserted in one executemany."""
    base = repo.member_summaries(s, parent.id) if parent is not None else []
    have = {i for i, _, _ in base}
    ordered = list(base)
    added: set[int] = set()
    for d in new_datasets:
        if d.id not in have:
            have.add(d.id)
            ordered.append((d.id, repo.content_key(d.content_sha256, d.meta), int(d.n_samples)))
            added.add(d.id)
    h = hashlib.sha256()
    for _, key, _ in ordered:
        h.update(key.encode())
    pv = PoolVersion(
        campaign_id=campaign_id,
        iteration_id=iteration_id,
        version=version,
        parent_id=parent.id if parent is not None else None,
        n_datasets=len(ordered),
        n_samples=int(sum(n for _, _, n in ordered)),
        content_hash=h.hexdigest(),
    )
    s.add(pv)
    s.flush()
    repo.add_members(s, pv.id, [(i, i in added) for i, _, _ in ordered])
    return pv


def _pool_name(d: Dataset) -> str:
    base = d.name or f"dataset-{d.id}"
    return f"{base}.{d.id}" if not base.endswith(f".{d.id}") else base


#: (database URL, pool version id) -> (content hash, datasets); the hash guards against a
#: different database that reuses the id (tests)
_POOL_CACHE_SIZE = 4
_pool_cache: LRUCache[tuple[str, int], tuple[str, list[PoolDataset]]] = LRUCache(maxsize=_POOL_CACHE_SIZE)
#: guards _pool_cache, which load_training_pool fills from its parent version's entry (more than a memo)
_pool_cache_lock = threading.Lock()


def _training_dataset(s: Session, d: Dataset) -> PoolDataset:
    from alcove.science.surrogate.dataset import PoolDataset

    a = dataset_arrays(s, d)
    origin = d.origin if d.origin in ("preliminary", "oracle", "upload") else "oracle"
    headrest = d.headrest  # a scenario's moved headrest, and its tilt where the scenario drew it
    return PoolDataset(
        _pool_name(d),
        a["t"],
        a["q"],
        a["qd"],
        *split_wrench(a["f"]),
        origin,
        headrest_offset=headrest.offset,
        headrest_tilt=headrest.tilt,
    )


def _cached_pool(url: str, pool_version_id: int, content_hash: str) -> list[PoolDataset] | None:
    with _pool_cache_lock:
        got = _pool_cache.get((url, pool_version_id))
    return got[1] if got is not None and got[0] == content_hash else None


def load_training_pool(s: Session, pool_version: PoolVersion) -> list[PoolDataset]:
    """The version's datasets as :class:`PoolDataset` objects (names unique: ``name.id``).

    Cached per process by pool version (versions are immutable): version k is built from a
    cached version k-1 plus the datasets k added, so a worker training iteration after
    iteration reads only the new rows, not the whole pool."""
    url = str(s.get_bind().engine.url)  # the bind is an Engine or a Connection; .engine is the Engine of either
    got = _cached_pool(url, pool_version.id, pool_version.content_hash)
    if got is not None:
        return list(got)
    out: list[PoolDataset] | None = None
    parent_row = s.get(PoolVersion, pool_version.parent_id) if pool_version.parent_id is not None else None
    parent = _cached_pool(url, parent_row.id, parent_row.content_hash) if parent_row is not None else None
    if parent is not None:
        out = parent + [_training_dataset(s, d) for d in repo.added_members(s, pool_version.id)]
        if len(out) != pool_version.n_datasets:  # not a pure extension of its parent: read it whole
            out = None
    if out is None:
        out = [_training_dataset(s, d) for _, d in repo.members(s, pool_version.id)]
    with _pool_cache_lock:
        _pool_cache[(url, pool_version.id)] = (pool_version.content_hash, out)
    return list(out)


def pool_table_columns(ndof: int) -> list[str]:
    return [
        "dataset_id",
        "dataset",
        "origin",
        "added_in_this_version",
        "t",
        *[f"q_{i}" for i in range(ndof)],
        *[f"qd_{i}" for i in range(ndof)],
        *FORCE_COLUMNS,
    ]


def pool_version_columns(s: Session, pool_version: PoolVersion) -> dict[str, list[Any]]:
    """One row per sample: dataset id/name/origin, t, q_i, qd_i, fx..mz."""
    cols: dict[str, list[Any]] | None = None
    for m, d in repo.members(s, pool_version.id):
        a = dataset_arrays(s, d)
        ndof = a["q"].shape[1]
        if cols is None:
            cols = {c: [] for c in pool_table_columns(ndof)}
        n = len(a["t"])
        cols["dataset_id"] += [d.id] * n
        cols["dataset"] += [d.name] * n
        cols["origin"] += [d.origin] * n
        cols["added_in_this_version"] += [bool(m.added_in_this_version)] * n
        cols["t"] += a["t"].tolist()
        for i in range(ndof):
            cols[f"q_{i}"] += a["q"][:, i].tolist()
            cols[f"qd_{i}"] += a["qd"][:, i].tolist()
        for j, c in enumerate(FORCE_COLUMNS):
            cols[c] += a["f"][:, j].tolist()
    return cols or {c: [] for c in pool_table_columns(1)}


def pool_version_table(s: Session, pool_version: PoolVersion, fmt: str = "csv") -> bytes:
    """The version's samples as CSV or Parquet bytes."""
    cols = pool_version_columns(s, pool_version)
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        buf = io.BytesIO()
        pq.write_table(pa.table(cols), buf)
        return buf.getvalue()
    if fmt != "csv":
        raise ValueError(f"format: expected csv or parquet, got {fmt!r}")
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    names = list(cols)
    w.writerow(names)
    for row in zip(*(cols[c] for c in names), strict=False):
        w.writerow([repr(v) if isinstance(v, float) else v for v in row])
    return out.getvalue().encode()


def state_range_of_task(spec: dict[str, Any]) -> StateRange:
    """The plausible joint angles and velocities of data for a task's model."""
    from alcove.science.geometry import MAX_ANGULAR_VELOCITY
    from alcove.science.ocp.task_spec import parse_task
    from alcove.science.surrogate.dataset import StateRange

    model = parse_task(spec).model
    if model.is_chain:  # the pool's data (joint columns q_0, qd_0) and features are 1-DOF so far
        raise InvalidInput.one(
            "task", f"its model {model.preset!r} is a chain; data sets take the head-neck-1dof preset only so far"
        )
    what = "the task's joint range theta_min..theta_max"
    return StateRange(model.theta_min, model.theta_max, MAX_ANGULAR_VELOCITY, what)


#: Distinct ``simulation`` labels (data sets) one upload may make: as many as ``chunks`` may.
MAX_UPLOAD_SIMULATIONS = 1000


def upload_preliminary_dataset(
    s: Session,
    owner_id: int,
    source: str | io.TextIOBase,
    name: str = "upload",
    chunks: int = 10,
    state: StateRange | None = None,
) -> list[Dataset]:
    """Store a preliminary-data CSV (columns ``[simulation,] [t,] q_i, qd_i, fx..mz``) as
    upload datasets; pass their ids as ``preliminary.dataset_ids`` of a campaign. Values are
    checked against ``state`` (a task's model range; default: what any model allows)."""
    from alcove.science.surrogate.dataset import check_plausible, load_preliminary_csv

    text = source if isinstance(source, io.TextIOBase) else io.StringIO(source)
    pool = load_preliminary_csv(
        text, origin="upload", chunks=chunks, prefix=name, max_simulations=MAX_UPLOAD_SIMULATIONS
    )
    check_plausible(pool, state)
    out = []
    for ds in pool:
        out.append(
            store_dataset(
                s,
                t=ds.t,
                q=ds.q,
                qd=ds.qd,
                f=stack_wrench(ds.force, ds.moment),
                origin="upload",
                name=ds.name,
                owner_id=owner_id,
                meta={"source": name},
            )
        )
    return out


def check_datasets_plausible(s: Session, datasets: list[Dataset], state: StateRange) -> None:
    """Stored datasets within ``state`` (and the force limits): :class:`PoolDataError`
    naming the column, the dataset and the row otherwise."""
    from alcove.science.surrogate.dataset import check_plausible

    check_plausible([_training_dataset(s, d) for d in datasets], state)


# ----------------------------------------------------------------------------- a campaign's pool versions


def campaign_versions(s: Session, campaign_id: int) -> list[PoolVersionRead]:
    """The pool versions a campaign made (lineage: ``parent_id``)."""
    return [PoolVersionRead.model_validate(p) for p in repo.own_versions(s, campaign_id)]


def campaign_version_table(s: Session, campaign_id: int, version: int, fmt: str = "csv") -> bytes:
    """Pool version ``version`` of a campaign as a table (a fork's early versions are its source's)."""
    pv = repo.version_of(s, campaign_id, version)
    if pv is None:
        raise NotFound("pool version", message=f"campaign {campaign_id} has no pool version {version}")
    return pool_version_table(s, pv, fmt)
