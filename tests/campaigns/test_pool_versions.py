"""Pool versions: membership chain and the worker's per-process training-pool cache."""

from __future__ import annotations

from typing import Any

import numpy as np


def test_training_pool_from_cached_parent_equals_a_fresh_read(sqlite_campaign_db: str, monkeypatch: Any) -> None:
    """Version k built from the cached version k-1 plus k's new rows is the same pool, in the
    same order, as reading version k whole; a version is never served for another one."""
    from alcove.campaigns.presets import local_user
    from alcove.db import run_transaction
    from alcove.db.migrate import upgrade
    from alcove.models import PoolVersion
    from alcove.pool import repository as pool_repo
    from alcove.pool import service as pool_service
    from tests.synthetic import synthesize_campaign

    upgrade()

    def build(s: Any) -> list[int]:
        c = synthesize_campaign(s, local_user(s).id, iterations=4, pool_samples=20)
        return [pv.id for pv in s.query(PoolVersion).filter_by(campaign_id=c.id).order_by(PoolVersion.version)]

    ids = run_transaction(build)

    def load_all(s: Any) -> list[list[Any]]:
        return [pool_service.load_training_pool(s, s.get(PoolVersion, i)) for i in ids]

    whole_reads: list[int] = []
    read_whole = pool_repo.members
    monkeypatch.setattr(pool_repo, "members", lambda s, i: whole_reads.append(i) or read_whole(s, i))
    pool_service._pool_cache.clear()
    chained = run_transaction(load_all)  # each version after the first comes from its cached parent
    assert whole_reads == ids[:1]
    fresh = []
    for i in ids:
        pool_service._pool_cache.clear()
        fresh.append(run_transaction(lambda s, i=i: pool_service.load_training_pool(s, s.get(PoolVersion, i))))
    for k, (a, b) in enumerate(zip(chained, fresh, strict=False)):
        assert [d.name for d in a] == [d.name for d in b]
        assert len(a) == k + 1
        for da, db in zip(a, b, strict=False):
            np.testing.assert_array_equal(da.force, db.force)
            np.testing.assert_array_equal(da.q, db.q)

    # membership rows: version k has k+1 members, the last one added in it
    def members(s: Any) -> list[list[tuple[int, bool]]]:
        return [[(m.position, m.added_in_this_version) for m, _ in pool_repo.members(s, i)] for i in ids]

    for k, rows in enumerate(run_transaction(members)):
        assert rows == [(j, j == k) for j in range(k + 1)]
    # a cached entry whose content hash does not match the row is not used
    key = next(iter(pool_service._pool_cache))
    pool_service._pool_cache[key] = ("not-the-hash", [])
    again = run_transaction(lambda s: pool_service.load_training_pool(s, s.get(PoolVersion, key[1])))
    assert len(again) > 0


def test_equal_arrays_with_a_moved_headrest_are_different_pool_content(sqlite_campaign_db: str) -> None:
    """The pool version's content hash covers what training reads: the same arrays against a
    headrest moved by a scenario (features are computed against it) give a different hash; an
    offset of 0 or none gives the bare array hash, sha256 over the members' array hashes, as
    pools stored before offsets existed have it."""
    import hashlib

    from alcove.campaigns.presets import local_user
    from alcove.db import run_transaction
    from alcove.db.migrate import upgrade
    from alcove.models import Iteration
    from alcove.pool import service as pool_service
    from tests.synthetic import synthesize_campaign

    upgrade()
    n = 30
    t = np.linspace(0, 1, n)
    arrays = {"t": t, "q": 0.2 + 0.1 * t[:, None], "qd": np.full((n, 1), 0.1), "f": np.outer(t, np.arange(6.0))}

    def versions(s: Any) -> dict[str, str]:
        c = synthesize_campaign(s, local_user(s).id, iterations=1, pool_samples=10)
        last = s.query(Iteration).filter_by(campaign_id=c.id).order_by(Iteration.index.desc()).first()
        hashes: dict[str, str] = {}
        for k, (label, meta) in enumerate(
            [
                ("none", None),
                ("zero", {"headrest_offset": 0.0}),
                ("+3mm", {"headrest_offset": 0.003}),
                ("-3mm", {"headrest_offset": -0.003}),
            ]
        ):
            it = Iteration(campaign_id=c.id, index=10 + k, config_version_id=last.config_version_id, status="succeeded")
            s.add(it)
            s.flush()
            it_id = it.id
            ds = pool_service.store_dataset(
                s, **arrays, origin="oracle", name=f"d{label}", campaign_id=c.id, iteration_id=it_id, meta=meta
            )
            pv = pool_service.create_version(
                s, campaign_id=c.id, iteration_id=it_id, version=10 + k, parent=None, new_datasets=[ds]
            )
            hashes[label] = pv.content_hash
            hashes["sha"] = ds.content_sha256
        return hashes

    h = run_transaction(versions)
    bare = hashlib.sha256(h["sha"].encode()).hexdigest()
    assert h["none"] == h["zero"] == bare
    assert len({h["none"], h["+3mm"], h["-3mm"]}) == 3
