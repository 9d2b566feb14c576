"""Scenarios (a task as a distribution), acquisition strategies and the headrest offset.

Laws, not recorded numbers: every draw lies within its range; the draws of one range are
uniform (Kolmogorov-Smirnov against U(low, high), p > 1e-3 on a fixed seed); the same
(seed, iteration) draws the same scenario and other seeds or iterations draw other ones; a task
without ranges is its own and only scenario (the same object, so the paper's case is bit for
bit today's); moving the headrest by d along its normal shifts the head's x_H coordinate by
exactly -d (round-off: 1e-15 m) and so the oracles' penetration by +d; tilting it by D about its
origin (where the head first touched it) opens a penetration of (rho / 2) D^2 at theta_contact,
rho = az^2 / ax the profile's radius of curvature there, whichever way it tilts.
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import settings as hyp_settings
from hypothesis import strategies as st
from scipy import stats

from alcove.science.geometry import HeadNeckPreset, first_contact_angle, relative_kinematics, signed_gap
from alcove.science.ocp import acquisition
from alcove.science.ocp import scenarios as sc
from alcove.science.ocp.task_spec import TASK_PRESETS, TaskSpecError, parse_task, task_preset
from alcove.science.oracles.aux_penalty import AuxPenaltyParams, penetration

PRESET = "head-headrest-scenarios"


def spec_with(ranges: list[dict]) -> dict:
    data = copy.deepcopy(TASK_PRESETS[PRESET])
    data["ranges"] = ranges
    return data


def test_the_preset_validates_and_its_nominal_scenario_is_the_papers_task():
    task = task_preset(PRESET)
    assert [r.parameter for r in task.ranges or []] == ["initial.q.0", "initial.qd.0", "model.headrest_offset"]
    paper = task_preset("head-headrest-2phase")
    nominal = sc.nominal(task)
    assert nominal.ranges is None
    exclude = {"name", "description"}
    assert nominal.model_dump(exclude=exclude) == paper.model_dump(exclude=exclude)


def test_draws_lie_within_their_ranges_and_are_uniform():
    task = task_preset(PRESET)
    draws = [sc.draw(task, seed=3, iteration=k) for k in range(1, 301)]
    for r in task.ranges or []:
        values = np.array([d.values[r.parameter] for d in draws])
        assert values.min() >= r.low and values.max() <= r.high
        # uniform on [low, high]: KS test, p above 1e-3 (fixed seed: the test cannot flake)
        p = stats.kstest(values, stats.uniform(loc=r.low, scale=r.high - r.low).cdf).pvalue
        assert p > 1e-3, (r.parameter, p)
    # the drawn values are what the concrete task solves
    d = draws[0]
    assert d.task.ranges is None
    assert d.task.initial.q == [d.values["initial.q.0"]]
    assert d.task.initial.qd == [d.values["initial.qd.0"]]
    assert d.task.model.headrest_offset == d.values["model.headrest_offset"]
    assert d.task.preset().headrest_offset == d.values["model.headrest_offset"]


@pytest.mark.parametrize(
    ("shape", "reference"),
    [
        # normal (mean 0.2, std 0.03) truncated to [0.15, 0.30]: SciPy's truncnorm
        (
            {"distribution": "normal", "mean": 0.2, "std": 0.03},
            stats.truncnorm((0.15 - 0.2) / 0.03, (0.3 - 0.2) / 0.03, 0.2, 0.03),
        ),
        # triangular on [0.15, 0.30] peaking at 0.25: SciPy's triang with c = (mode - low) / (high - low)
        ({"distribution": "triangular", "mode": 0.25}, stats.triang((0.25 - 0.15) / 0.15, loc=0.15, scale=0.15)),
    ],
)
def test_draws_follow_their_declared_distribution(shape, reference):
    """300 draws of a normal (truncated) or triangular range: each inside [low, high], and the
    sample passes a Kolmogorov-Smirnov test against the declared distribution (p > 1e-3, fixed
    seed) while failing it against the uniform one (p < 1e-3): the shape is really used."""
    task = parse_task(spec_with([{"parameter": "initial.q.0", "low": 0.15, "high": 0.30, **shape}]))
    values = np.array([sc.draw(task, seed=5, iteration=k).values["initial.q.0"] for k in range(1, 301)])
    assert values.min() >= 0.15 and values.max() <= 0.30
    assert stats.kstest(values, reference.cdf).pvalue > 1e-3
    assert stats.kstest(values, stats.uniform(loc=0.15, scale=0.15).cdf).pvalue < 1e-3
    # the stored spec keeps the shape; a uniform range dumps as it did before shapes existed
    (stored,) = task.model_dump(mode="json")["ranges"]
    assert stored == {"parameter": "initial.q.0", "low": 0.15, "high": 0.30, **shape}
    assert task_preset(PRESET).model_dump(mode="json")["ranges"] == TASK_PRESETS[PRESET]["ranges"]


def test_draws_are_reproducible_per_seed_and_iteration():
    task = task_preset(PRESET)
    assert sc.draw(task, 11, 4).values == sc.draw(task, 11, 4).values
    assert sc.draw(task, 11, 4).task == sc.draw(task, 11, 4).task
    assert sc.draw(task, 11, 4).values != sc.draw(task, 12, 4).values
    assert sc.draw(task, 11, 4).values != sc.draw(task, 11, 5).values
    assert sc.draw(task, 11, 4, slot=1).values != sc.draw(task, 11, 4).values
    assert [s.values for s in sc.preview(task, 11, 3)] == [sc.draw(task, 11, k).values for k in (1, 2, 3)]


def test_a_task_without_ranges_is_its_only_scenario():
    paper = task_preset("head-headrest-2phase")
    assert paper.ranges is None
    for seed, k in [(0, 1), (5, 17)]:
        drawn = sc.draw(paper, seed, k)
        assert drawn.task is paper and drawn.values == {}
    assert sc.nominal(paper) is paper
    assert sc.from_json(paper, None) is paper
    assert sc.from_json(paper, {"values": {}}) is paper
    empty = parse_task({**TASK_PRESETS["head-headrest-2phase"], "ranges": []})
    assert sc.draw(empty, 0, 1).task is empty
    # the paper strategy solves the task as written, also when it has ranges
    task = task_preset(PRESET)
    (chosen,) = acquisition.strategy("paper").candidates(task, 0, 1, 1)
    assert chosen.task == sc.nominal(task) and chosen.values == {}
    (drawn,) = acquisition.strategy("random-scenarios").candidates(task, 9, 2, 1)
    assert drawn.values == sc.draw(task, 9, 2).values


def test_a_stored_scenario_gives_back_its_task():
    task = task_preset(PRESET)
    drawn = sc.draw(task, 2, 7)
    stored = drawn.to_json()
    assert stored == {"seed": 2, "iteration": 7, "slot": 0, "values": drawn.values}
    assert sc.from_json(task, stored) == drawn.task


@pytest.mark.parametrize(
    ("ranges", "field", "words"),
    [
        ([{"parameter": "initial.q.0", "low": 0.15, "high": 0.5}], "ranges.0.high", "joint range"),
        ([{"parameter": "initial.q.0", "low": 0.3, "high": 0.15}], "ranges.0.high", "at least low"),
        ([{"parameter": "model.mass", "low": 4, "high": 5}], "ranges.0.parameter", "cannot be varied"),
        # a dataset does not record the headrest's placement angle (not done)
        ([{"parameter": "model.theta_contact", "low": 0.3, "high": 0.32}], "ranges.0.parameter", "cannot be varied"),
        # a tilt stays within MAX_TILT_DEVIATION = 0.05 rad of the task's own (0.31 rad)
        ([{"parameter": "model.tilt", "low": 0.25, "high": 0.32}], "ranges.0.low", "model.tilt = 0.25 rad"),
        ([{"parameter": "model.tilt", "low": 0.3, "high": 0.3601}], "ranges.0.high", "within +-0.05 rad"),
        ([{"parameter": "phases.2.duration", "low": 0.5, "high": 1}], "ranges.0.low", "2 phases"),
        ([{"parameter": "phases.0.duration", "low": 0.0, "high": 1}], "ranges.0.low", "phases.0.duration"),
        ([{"parameter": "model.headrest_offset", "low": -0.05, "high": 0}], "ranges.0.low", "headrest_offset"),
        ([{"parameter": "final.q.0", "low": 0.2, "high": 0.3}], "ranges.0.low", "no final.q"),
        ([{"parameter": "initial.q.1", "low": 0.2, "high": 0.3}], "ranges.0.low", "joint index 1"),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3}] * 2,
            "ranges.1.parameter",
            "twice",
        ),
        ([{"parameter": "initial.q.0", "low": 0.2, "high": float("inf")}], "ranges.0.high", "finite"),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "distribution": "normal", "std": 0.1}],
            "ranges.0.mean",
            "required with distribution normal",
        ),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "distribution": "normal", "mean": 0.4, "std": 0.1}],
            "ranges.0.mean",
            "within [low, high]",
        ),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "distribution": "normal", "mean": 0.25, "std": 0}],
            "ranges.0.std",
            "greater than 0",
        ),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "mode": 0.25}],
            "ranges.0.mode",
            "only with distribution triangular",
        ),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "distribution": "triangular"}],
            "ranges.0.mode",
            "required",
        ),
        (
            [{"parameter": "initial.q.0", "low": 0.2, "high": 0.3, "distribution": "beta"}],
            "ranges.0.distribution",
            "uniform",
        ),
    ],
)
def test_invalid_ranges_name_the_field(ranges, field, words):
    with pytest.raises(TaskSpecError) as err:
        parse_task(spec_with(ranges))
    assert err.value.field == field
    assert words in err.value.reason


def test_a_free_initial_velocity_cannot_be_ranged():
    data = spec_with([{"parameter": "initial.qd.0", "low": 0, "high": 0.5}])
    data["initial"] = {"velocity": "free"}
    with pytest.raises(TaskSpecError) as err:
        parse_task(data)
    assert err.value.field == "ranges.0.parameter" and "free" in err.value.reason


def test_unknown_strategy_and_batches_are_refused():
    with pytest.raises(ValueError, match="unknown 'greedy'"):
        acquisition.strategy("greedy")
    with pytest.raises(ValueError, match="batch: strategy 'paper'"):
        acquisition.strategy("paper").candidates(task_preset(PRESET), 0, 1, 4)


def test_a_batch_draws_distinct_reproducible_scenarios_slot_by_slot():
    """random-scenarios with q = 4: slot j of the batch is the scenario one ocp job draws for slot
    j alone (what the fanned-out jobs solve), the same on every call, and the slots differ."""
    strategy, task = acquisition.strategy("random-scenarios"), task_preset(PRESET)
    batch = strategy.candidates(task, 7, 3, 4)
    assert [b.to_json() for b in batch] == [strategy.scenario(task, 7, 3, j).to_json() for j in range(4)]
    assert [b.to_json() for b in batch] == [b.to_json() for b in strategy.candidates(task, 7, 3, 4)]
    assert len({json.dumps(b.to_json()["values"], sort_keys=True) for b in batch}) == 4


# ----------------------------------------------------------------------------- the headrest offset


@pytest.mark.parametrize("offset", [-0.005, 0.002, 0.005])
def test_a_headrest_offset_moves_the_headrest_along_its_normal(offset):
    nominal, moved = HeadNeckPreset(), HeadNeckPreset(headrest_offset=offset)
    theta = np.linspace(0.05, 0.42, 40)
    qd = np.full_like(theta, 0.3)
    a, b = relative_kinematics(nominal, theta, qd), relative_kinematics(moved, theta, qd)
    # the head is `offset` closer along x_H, nothing else changes (1e-15 m: round-off)
    np.testing.assert_allclose(b.r_rel[:, 0] - a.r_rel[:, 0], -offset, rtol=0, atol=1e-15)
    np.testing.assert_allclose(b.r_rel[:, 2], a.r_rel[:, 2], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(b.v_rel, a.v_rel)
    np.testing.assert_array_equal(b.T_rel, a.T_rel)
    np.testing.assert_allclose(signed_gap(moved, theta) - signed_gap(nominal, theta), -offset, rtol=0, atol=1e-15)
    # the oracles' penetration grows by the offset (aux-penalty: p = -x_H of its contact point)
    params = AuxPenaltyParams()
    deeper = penetration(moved, params, b)[0] - penetration(nominal, params, a)[0]
    np.testing.assert_allclose(deeper, offset, rtol=0, atol=1e-15)
    # first contact: where the gap closes (1e-12 m), earlier for a headrest moved toward the head
    theta_c = first_contact_angle(moved)
    assert abs(signed_gap(moved, theta_c)[0]) < 1e-12
    assert (theta_c < nominal.theta_contact) == (offset > 0)


def _brute_gap(preset: HeadNeckPreset, theta: np.ndarray) -> np.ndarray:
    """The gap by brute force, independent of the closed form and of the kinematics: the least
    distance along the headrest normal (cos tilt, sin tilt) from its origin to 40,001 points of
    the profile ellipse placed in the world at each head angle (sampling error < 2e-9 m)."""
    from alcove.science.geometry import rot2

    pr = preset.profile
    s = np.linspace(0.0, 2.0 * np.pi, 40_001)
    pts = np.stack([pr.cx + pr.ax * np.cos(s), pr.cz + pr.az * np.sin(s)], -1)
    n = np.array([np.cos(preset.tilt), np.sin(preset.tilt)])
    o = preset.headrest_origin
    return np.array([((preset.head_origin_world(th) + pts @ rot2(th).T - o) @ n).min() for th in theta])


@pytest.mark.parametrize("tilt_change", [-0.05, 0.03])
def test_a_headrest_tilt_turns_the_headrest_about_its_origin_and_the_features_follow(tilt_change):
    """A dataset recorded with a scenario's headrest tilt: its training features (pool_features
    with the moved headrest) are relative to the tilted headrest. The gap read back from them is
    the brute-force gap of the tilted geometry (1e-8 m); at theta_contact the head now penetrates
    the tilted cushion by (rho / 2) D^2 (0.1 % relative: the next term is O(D^4)), so the contact
    onset comes earlier for either sign of D."""
    from alcove.science.surrogate.dataset import PoolDataset
    from alcove.science.surrogate.gated import gap_from_features
    from alcove.science.surrogate.training import moved_headrest, pool_features, preset_kinematics

    nominal = HeadNeckPreset()
    tilted = HeadNeckPreset(tilt=nominal.tilt + tilt_change)
    theta = np.linspace(0.2, 0.42, 23)
    zeros = np.zeros((theta.size, 3))
    data = PoolDataset("press", np.arange(theta.size) * 0.01, theta, np.full_like(theta, 0.3), zeros, zeros)
    recorded = PoolDataset(
        "press", data.t, data.q, data.qd, zeros, zeros, headrest_offset=0.0, headrest_tilt=tilted.tilt
    )
    x = pool_features([data, recorded], preset_kinematics(nominal), moved_headrest(nominal))
    x_nominal, x_tilted = np.split(x, 2)
    expected = _brute_gap(tilted, theta)
    np.testing.assert_allclose(gap_from_features(x_tilted, nominal.profile), expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(signed_gap(tilted, theta), expected, rtol=0, atol=1e-8)
    # the untilted features would be another geometry (here by more than 0.1 mm somewhere)
    assert np.max(np.abs(gap_from_features(x_nominal, nominal.profile) - expected)) > 1e-4
    # the relative orientation turns by -D: cos(theta - tilt) (round-off 1e-15)
    from alcove.science.surrogate.gated import T_00

    np.testing.assert_allclose(x_tilted[:, T_00], np.cos(theta - tilted.tilt), rtol=0, atol=1e-15)
    # contact onset: the head touched the untilted headrest at theta_contact; tilted about that
    # point, the cushion is penetrated there by (rho / 2) D^2, rho = az^2 / ax at the back point
    pr = nominal.profile
    depth = -signed_gap(tilted, nominal.theta_contact)[0]
    assert depth == pytest.approx(0.5 * pr.az**2 / pr.ax * tilt_change**2, rel=1e-3)
    onset = first_contact_angle(tilted)
    assert abs(_brute_gap(tilted, np.array([onset]))[0]) < 1e-8
    assert onset < nominal.theta_contact


def test_a_recorded_tilt_changes_the_content_key_and_no_tilt_keeps_it():
    from alcove.pool.repository import content_key
    from alcove.science.surrogate.dataset import PoolDataset

    sha = "ab" * 32
    assert content_key(sha, {"headrest_offset": 0.0}) == sha  # as before tilts were recorded
    assert content_key(sha, {"headrest_offset": 0.0, "headrest_tilt": 0.31}) == f"{sha}@headrest_tilt=0.31"
    assert content_key(sha, {"headrest_offset": 0.002, "headrest_tilt": 0.33}) == (
        f"{sha}@headrest_offset=0.002@headrest_tilt=0.33"
    )
    z = np.zeros((2, 3))
    plain = PoolDataset("d", np.arange(2.0), np.zeros(2), np.zeros(2), z, z, headrest_offset=0.0)
    tilted = PoolDataset("d", np.arange(2.0), np.zeros(2), np.zeros(2), z, z, headrest_offset=0.0, headrest_tilt=0.31)
    # the digest without a tilt is the one of before tilts were recorded: arrays, shapes, offset
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    for a in (plain.t, plain.q, plain.qd, plain.force, plain.moment):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(str(np.shape(a)).encode())
    h.update(repr(0.0).encode())
    assert plain.content_key == h.hexdigest()
    assert tilted.content_key != plain.content_key


def test_a_tilt_range_within_its_bound_draws_tilted_scenarios():
    from alcove.science.ocp.scenario_ranges import MAX_TILT_DEVIATION

    task = parse_task(spec_with([{"parameter": "model.tilt", "low": 0.31 - MAX_TILT_DEVIATION, "high": 0.36}]))
    d = sc.draw(task, 3, 1)
    assert 0.26 <= d.values["model.tilt"] <= 0.36
    assert d.task.preset().tilt == d.values["model.tilt"] and d.task.preset().theta_contact == 0.31


def test_no_offset_is_the_papers_headrest_bit_for_bit():
    assert HeadNeckPreset(headrest_offset=0.0).headrest_origin.tobytes() == HeadNeckPreset().headrest_origin.tobytes()
    assert first_contact_angle(HeadNeckPreset()) == HeadNeckPreset().theta_contact


def test_a_chain_task_ranges_its_initial_state_from_the_chains_own_pose():
    """A chain task without an explicit initial state: a ranged joint angle starts from the
    chain's q0 (the other joints keep theirs), every draw is a valid task; a headrest offset
    (a head-neck-1dof parameter) is refused for a chain, naming the field."""
    import json
    from pathlib import Path

    spec = json.loads((Path(__file__).parents[3] / "examples/tasks/head-headrest-2dof.json").read_text())
    base = parse_task(spec)
    q0 = [j.q0 for j in base.model.chain.joints]
    spec["ranges"] = [{"parameter": "initial.q.1", "low": q0[1] - 0.02, "high": q0[1] + 0.02}]
    task = parse_task(spec)
    for scenario in sc.preview(task, seed=4, n=5):
        drawn = sc.apply_values(task, scenario.values)
        assert drawn.initial.q[0] == q0[0]  # not ranged: the chain's own starting angle
        assert q0[1] - 0.02 <= drawn.initial.q[1] <= q0[1] + 0.02
    spec["ranges"] = [{"parameter": "model.headrest_offset", "low": -0.005, "high": 0.005}]
    with pytest.raises(TaskSpecError, match=r"model\.headrest_offset"):
        parse_task(spec)


# ----------------------------------------------------------------------------- the batch selection rule


def test_select_batch_takes_the_highest_scores_no_two_picks_too_close():
    scores, x = [1.0, 5.0, 3.0, 4.0], [[0.0], [0.05], [0.5], [0.9]]
    assert [p.slot for p in acquisition.select_batch(scores, x, 3, 0.1)] == [1, 3, 2]
    # 2 is 0.45 from 3 and 0 is 0.05 from 1: too close at 0.5
    assert [p.slot for p in acquisition.select_batch(scores, x, 3, 0.5)] == [1, 3]
    assert [p.slot for p in acquisition.select_batch(scores, x, 1, 0.0)] == [1]
    # a candidate whose OCP did not converge (None) is never picked; ties go to the lower slot
    assert [p.slot for p in acquisition.select_batch([None, 2.0, 2.0], [[0], [0.3], [0.6]], 3, 0)] == [1, 2]
    # the stopping rule: the highest score below the threshold asks the oracle nothing
    assert acquisition.select_batch(scores, x, 3, 0.1, threshold=5.5) == []
    assert [p.slot for p in acquisition.select_batch(scores, x, 1, 0.1, threshold=5.0)] == [1]
    with pytest.raises(ValueError, match="features"):
        acquisition.select_batch(scores, x[:2], 2, 0.1)


def test_explain_selection_says_why_each_candidate_was_or_was_not_picked():
    """Hand-worked case, q = 2, min_distance 0.5: slot 1 (5.0) is the top pick; slot 3 (4.0,
    0.85 from slot 1) the second; slot 2 (3.0) comes after the batch is full; slot 0 (1.0) too;
    slot 4 never converged. With q = 3, slot 2 is 0.4 from pick 2 (slot 3): too close; slot 0 is
    0.05 from pick 1: too close."""
    scores, x = [1.0, 5.0, 3.0, 4.0, None], [[0.0], [0.05], [0.5], [0.9], [0.3]]
    v = acquisition.explain_selection(scores, x, 2, 0.5)
    assert [(w.rank, w.pick, w.code) for w in v] == [
        (4, None, "batch-full"),
        (1, 0, "picked-top"),
        (3, None, "batch-full"),
        (2, 1, "picked-far"),
        (None, None, "not-converged"),
    ]
    assert v[3].nearest_pick == 0 and v[3].distance == pytest.approx(0.85)
    v = acquisition.explain_selection(scores, x, 3, 0.5)
    assert [w.code for w in v] == ["too-close", "picked-top", "too-close", "picked-far", "not-converged"]
    assert (v[2].nearest_pick, v[2].distance) == (1, pytest.approx(0.4)) and "pick 2 (slot 3)" in v[2].reason
    assert (v[0].nearest_pick, v[0].distance) == (0, pytest.approx(0.05))
    # the stopping rule: every scored candidate is below-threshold, nothing picked
    v = acquisition.explain_selection(scores, x, 2, 0.5, threshold=6.0)
    assert [w.code for w in v] == ["below-threshold"] * 4 + ["not-converged"]
    # the explanation is select_batch's decision, pick for pick
    v = acquisition.explain_selection(scores, x, 2, 0.5)
    picks = acquisition.select_batch(scores, x, 2, 0.5)
    assert [(p.slot, p.reason) for p in picks] == [(1, v[1].reason), (3, v[3].reason)]


@given(
    st.lists(st.tuples(st.floats(0, 10), st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=12),
    st.integers(1, 5),
    st.floats(0, 0.8),
)
@hyp_settings(max_examples=200, deadline=None)
def test_select_batch_is_the_greedy_max_score_rule_with_a_minimum_distance(cands, q, d_min):
    """Picks are at most q, pairwise at least d_min apart, in descending score; and every
    candidate left out was either outranked by q picks or too close to a pick scoring at least
    as high (greedy: nothing better was skipped), or has score 0 (no contact: never picked)."""
    scores = [c[0] for c in cands]
    x = np.array([c[1:] for c in cands])
    picks = [p.slot for p in acquisition.select_batch(scores, x.tolist(), q, d_min)]
    assert len(picks) <= q and len(set(picks)) == len(picks)
    assert [scores[j] for j in picks] == sorted((scores[j] for j in picks), reverse=True)
    for a in picks:
        for b in picks:
            assert a == b or np.linalg.norm(x[a] - x[b]) >= d_min
    assert all(scores[j] > 0 for j in picks)
    if len(picks) < q:
        for j in set(range(len(cands))) - set(picks):
            assert scores[j] == 0 or any(scores[p] >= scores[j] and np.linalg.norm(x[p] - x[j]) < d_min for p in picks)


def test_candidates_without_contact_are_never_picked_even_when_the_batch_is_not_full():
    """Score 0 means the candidate's OCP solution never touches the headrest (no contact
    phase): its replay holds no contact force to learn, so it is skipped even when fewer than q
    candidates are in contact, and an iteration whose candidates all miss picks nothing."""
    scores, x = [0.0, 2.0, 0.0, 1.0, None], [[0.0], [0.2], [0.4], [0.6], [0.8]]
    v = acquisition.explain_selection(scores, x, 4, 0.1)
    assert [(w.rank, w.pick, w.code) for w in v] == [
        (3, None, "no-contact"),
        (1, 0, "picked-top"),
        (4, None, "no-contact"),
        (2, 1, "picked-far"),
        (None, None, "not-converged"),
    ]
    assert "never touches the headrest" in v[0].reason
    assert [p.slot for p in acquisition.select_batch(scores, x, 4, 0.1)] == [1, 3]
    assert acquisition.select_batch([0.0, 0.0, None], [[0.0], [0.5], [1.0]], 2, 0.0) == []
    # a tiny but positive disagreement is contact: still picked
    assert [p.slot for p in acquisition.select_batch([0.0, 1e-9], [[0.0], [1.0]], 2, 0.0)] == [1]


def test_scenario_features_scale_each_range_to_the_unit_interval():
    task = task_preset(PRESET)
    lows = {r.parameter: r.low for r in task.ranges}
    highs = {r.parameter: r.high for r in task.ranges}
    assert acquisition.scenario_features(task, lows) == [0.0] * len(task.ranges)
    assert acquisition.scenario_features(task, highs) == [1.0] * len(task.ranges)
