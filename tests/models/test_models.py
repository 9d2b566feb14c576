"""The schema on both backends: relationships, uniqueness (idempotent appends),
immutability of used versions, content-addressed arrays, password and token hashing."""

from __future__ import annotations

from datetime import timedelta

import numpy as np
import pytest
import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove import models as m
from alcove.db import arrays


def make_campaign(s: Session, *, email: str = "a@x.org") -> m.Campaign:
    user = m.User(email=email, role=m.Role.member.value)
    task = m.TaskDefinition(owner=user, name="t", latest_version=1)
    tv = m.TaskVersion(definition=task, version=1, spec={"phases": [1, 2]}, spec_hash=m.spec_hash({"phases": [1, 2]}))
    orc = m.OracleDefinition(owner=user, name="o", latest_version=1)
    ov = m.OracleVersion(definition=orc, version=1, oracle_type="aux-penalty", spec={}, spec_hash=m.spec_hash({}))
    sc = m.SurrogateConfigDefinition(owner=user, name="s", latest_version=1)
    sv = m.SurrogateConfigVersion(config=sc, version=1, spec={}, spec_hash=m.spec_hash({}))
    c = m.Campaign(
        owner=user,
        name="c",
        task_version=tv,
        oracle_version=ov,
        surrogate_config_version=sv,
        seed=2**40,
        stopping_rules={"max_iterations": 3},
    )
    s.add(c)
    s.flush()
    s.add(m.CampaignConfigVersion(campaign=c, version=1, surrogate_config_version=sv))
    s.flush()
    return c


def test_full_lineage_roundtrip(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    cfg = c.config_versions[0]
    it0 = m.Iteration(campaign=c, index=0, config_version=cfg)
    it1 = m.Iteration(campaign=c, index=1, config_version=cfg)
    s.add_all([it0, it1])
    s.flush()
    for name in m.ITERATION_STEPS:
        s.add(
            m.IterationStep(campaign_id=c.id, iteration=it1, step=name.value, queue="default", config_version_id=cfg.id)
        )
    f0 = {"t": np.linspace(0, 1, 11), "f": np.ones((11, 6))}
    h0 = arrays.put_arrays(s, f0)
    assert arrays.put_arrays(s, {"f": np.ones((11, 6)), "t": np.linspace(0, 1, 11)}) == h0  # stored once
    d0 = m.Dataset(origin="preliminary", content_sha256=h0, campaign_id=c.id, iteration_id=it0.id, n_samples=11)
    s.add(d0)
    s.flush()
    p0 = m.PoolVersion(campaign_id=c.id, iteration_id=it0.id, version=0, n_datasets=1, n_samples=11, content_hash=h0)
    p0.members.append(m.PoolVersionMember(dataset_id=d0.id, position=0, added_in_this_version=True))
    s.add(p0)
    s.flush()
    w = arrays.put_arrays(s, {"W0": np.zeros((6, 19))})
    mv = m.ModelVersion(
        campaign_id=c.id,
        iteration_id=it1.id,
        version=1,
        pool_version_id=p0.id,
        seed=7,
        architecture={"force": [19, 6, 6, 4, 3]},
        normalisation={},
        weights_sha256=w,
        code_version="0.1.0",
        library_versions={"torch": "2.13.0"},
    )
    s.add(mv)
    s.flush()
    run = m.OracleRun(campaign_id=c.id, iteration_id=it1.id, attempt=1, status="ok", wall_time_s=1.5)
    s.add(run)
    s.flush()
    h1 = arrays.put_arrays(s, {"t": np.arange(3.0), "f": np.zeros((3, 6))})
    d1 = m.Dataset(
        origin="oracle", content_sha256=h1, campaign_id=c.id, iteration_id=it1.id, oracle_run_id=run.id, n_samples=3
    )
    s.add(d1)
    s.flush()
    p1 = m.PoolVersion(
        campaign_id=c.id, iteration_id=it1.id, version=1, parent=p0, n_datasets=2, n_samples=14, content_hash="x" * 64
    )
    p1.members += [
        m.PoolVersionMember(dataset_id=d0.id, position=0),
        m.PoolVersionMember(dataset_id=d1.id, position=1, added_in_this_version=True),
    ]
    s.add(p1)
    curves = arrays.put_arrays(s, {"t": np.arange(3.0), "f_true": np.zeros((3, 6)), "f_pred": np.ones((3, 6))})
    s.add(
        m.IterationMetrics(
            campaign_id=c.id,
            iteration_id=it1.id,
            iteration_index=1,
            model_version_id=mv.id,
            force_rmse=1.0,
            moment_rmse=0.1,
            curves_sha256=curves,
        )
    )
    s.flush()
    s.expire_all()

    got = s.get(m.Campaign, c.id)
    assert got.seed == 2**40 and got.status == "draft" and got.created_at.tzinfo is not None
    assert [st.step for st in got.iterations[1].steps] == ["train", "ocp", "oracle", "evaluate", "append"]
    pv = s.scalars(sa.select(m.PoolVersion).where(m.PoolVersion.version == 1, m.PoolVersion.campaign_id == c.id)).one()
    assert [mem.dataset.origin for mem in pv.members] == ["preliminary", "oracle"]
    assert pv.parent.version == 0
    back = arrays.get_arrays(
        s,
        s.get(
            m.IterationMetrics,
            s.scalars(sa.select(m.IterationMetrics.id).where(m.IterationMetrics.campaign_id == c.id)).one(),
        ).curves_sha256,
    )
    np.testing.assert_array_equal(back["f_pred"], np.ones((3, 6)))
    assert s.get(m.ModelVersion, mv.id).pool_version.version == 0


def test_an_iteration_appends_at_most_once(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    it = m.Iteration(campaign=c, index=0, config_version=c.config_versions[0])
    s.add(it)
    s.flush()
    s.add(m.PoolVersion(campaign_id=c.id, iteration_id=it.id, version=0, content_hash="a" * 64))
    s.flush()
    with pytest.raises(sa.exc.IntegrityError), s.begin_nested():
        s.add(m.PoolVersion(campaign_id=c.id, iteration_id=it.id, version=1, content_hash="b" * 64))
        s.flush()


def test_a_dataset_is_in_a_pool_version_once(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    it = m.Iteration(campaign=c, index=0, config_version=c.config_versions[0])
    s.add(it)
    h = arrays.put_arrays(s, {"x": np.zeros(2)})
    d = m.Dataset(origin="upload", content_sha256=h, n_samples=2)
    s.add(d)
    s.flush()
    p = m.PoolVersion(campaign_id=c.id, iteration_id=it.id, version=0, content_hash=h)
    s.add(p)
    s.flush()
    s.add(m.PoolVersionMember(pool_version_id=p.id, dataset_id=d.id, position=0))
    s.flush()
    with pytest.raises(sa.exc.IntegrityError), s.begin_nested():
        s.execute(
            sa.insert(m.PoolVersionMember).values(
                pool_version_id=p.id, dataset_id=d.id, position=1, added_in_this_version=False
            )
        )


def test_step_names_and_statuses_are_checked(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    it = m.Iteration(campaign=c, index=1, config_version=c.config_versions[0])
    s.add(it)
    s.flush()
    s.add(m.IterationStep(campaign_id=c.id, iteration_id=it.id, step="train"))
    s.flush()
    with pytest.raises(sa.exc.IntegrityError), s.begin_nested():  # same step twice
        s.add(m.IterationStep(campaign_id=c.id, iteration_id=it.id, step="train"))
        s.flush()
    with pytest.raises(sa.exc.IntegrityError), s.begin_nested():
        s.add(m.IterationStep(campaign_id=c.id, iteration_id=it.id, step="dance"))
        s.flush()


def test_conditional_claim_is_exclusive(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    it = m.Iteration(campaign=c, index=1, config_version=c.config_versions[0])
    s.add(it)
    s.flush()
    step = m.IterationStep(campaign_id=c.id, iteration_id=it.id, step="ocp", status="queued")
    s.add(step)
    s.flush()

    def claim(token: str) -> int:
        return s.execute(
            sa.update(m.IterationStep)
            .where(m.IterationStep.id == step.id, m.IterationStep.status == "queued")
            .values(
                status="running",
                claim_token=token,
                attempts=m.IterationStep.attempts + 1,
                lease_until=m.utcnow() + timedelta(minutes=2),
            )
        ).rowcount

    assert claim("first") == 1
    assert claim("second") == 0


def test_used_versions_are_immutable(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    tv = c.task_version
    tv.spec = {"phases": [3]}  # not locked yet: allowed
    tv.spec_hash = m.spec_hash(tv.spec)
    tv.locked_at = m.utcnow()
    s.flush()
    tv.spec = {"phases": [4]}
    with pytest.raises(m.ImmutableRowError):
        s.flush()
    s.rollback()


def test_pool_versions_and_blobs_are_immutable(db_session: Session) -> None:
    s = db_session
    h = arrays.put_arrays(s, {"x": np.arange(4)})
    blob = s.get(m.Blob, h)
    blob.size_bytes = 1
    with pytest.raises(m.ImmutableRowError):
        s.flush()
    s.rollback()


def test_share_needs_exactly_one_object(db_session: Session) -> None:
    s = db_session
    c = make_campaign(s)
    other = m.User(email="b@x.org")
    s.add(other)
    s.flush()
    s.add(m.Share(user_id=other.id, campaign_id=c.id))
    s.flush()
    with pytest.raises(sa.exc.IntegrityError), s.begin_nested():
        s.add(m.Share(user_id=other.id))
        s.flush()


def test_passwords_and_tokens_are_hashed(db_session: Session) -> None:
    s = db_session
    u = m.User(email="c@x.org")
    u.set_password("correct horse")
    tok, secret = m.ApiToken.issue(u, name="laptop")
    s.add_all([u, tok])
    s.flush()
    assert u.password_hash.startswith("$argon2") and "correct" not in u.password_hash
    assert u.check_password("correct horse") and not u.check_password("wrong")
    assert secret not in (tok.token_hash, tok.token_prefix) and secret.startswith(tok.token_prefix)
    found = s.scalars(sa.select(m.ApiToken).where(m.ApiToken.token_hash == m.hash_token(secret))).one()
    assert found.user.email == "c@x.org" and found.is_valid()


def test_arrays_codec_is_deterministic_and_refuses_objects() -> None:
    a = {"q": np.random.default_rng(0).normal(size=(401, 1)), "t": np.linspace(0, 1, 401)}
    assert arrays.encode_arrays(a) == arrays.encode_arrays(dict(reversed(list(a.items()))))
    back = arrays.decode_arrays(arrays.encode_arrays(a))
    np.testing.assert_array_equal(back["q"], a["q"])
    with pytest.raises(ValueError):
        arrays.encode_arrays({"x": np.array([object()])})
