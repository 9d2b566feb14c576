"""Scenarios (a task as a distribution), acquisition strategies and the headrest offset.

Laws, not recorded numbers: every draw lies within its range; the draws of one range are
uniform (Kolmogorov-Smirnov against U(low, high), p > 1e-3 on a fixed seed); the same
(seed, iteration) draws the same scenario and other seeds or iterations draw other ones; a task
without ranges is its own and only scenario (the same object, so the paper's case is bit for
bit today's); moving the headrest by d along its normal shifts the head's x_H coordinate by
exactly -d (round-off: 1e-15 m) and so the oracles' penetration by +d.
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
        # the training features would use the wrong headrest for data simulated with another tilt (not done)
        ([{"parameter": "model.tilt", "low": 0.3, "high": 0.32}], "ranges.0.parameter", "cannot be varied"),
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
    as high (greedy: nothing better was skipped)."""
    scores = [c[0] for c in cands]
    x = np.array([c[1:] for c in cands])
    picks = [p.slot for p in acquisition.select_batch(scores, x.tolist(), q, d_min)]
    assert len(picks) <= q and len(set(picks)) == len(picks)
    assert [scores[j] for j in picks] == sorted((scores[j] for j in picks), reverse=True)
    for a in picks:
        for b in picks:
            assert a == b or np.linalg.norm(x[a] - x[b]) >= d_min
    if len(picks) < q:
        for j in set(range(len(cands))) - set(picks):
            assert any(scores[p] >= scores[j] and np.linalg.norm(x[p] - x[j]) < d_min for p in picks)


def test_scenario_features_scale_each_range_to_the_unit_interval():
    task = task_preset(PRESET)
    lows = {r.parameter: r.low for r in task.ranges}
    highs = {r.parameter: r.high for r in task.ranges}
    assert acquisition.scenario_features(task, lows) == [0.0] * len(task.ranges)
    assert acquisition.scenario_features(task, highs) == [1.0] * len(task.ranges)
