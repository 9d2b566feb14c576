"""The campaign state machine, without Celery or a database."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from alcove.campaigns.config import RunSettings, StoppingRules, strategy_problem
from alcove.campaigns.machine.state_machine import (
    Cancel,
    Decision,
    InvalidTransition,
    IterationRecord,
    Outcome,
    Pause,
    Resume,
    RetryStep,
    Slots,
    Start,
    State,
    StepFinished,
    StepRef,
    stop_reason,
    transition,
)
from alcove.models import CampaignStatus as S
from alcove.models import StepName as N

LOOP = [N.train, N.ocp, N.oracle, N.evaluate, N.append]


def run_loop(iterations: int, *, stop_at: int | None = None) -> list[StepRef]:
    """Drive the machine through a campaign; returns every enqueued step in order."""
    state = State(S.draft)
    d = transition(state, Start(StepRef(0, N.preliminary)))
    sent = list(d.enqueue)
    while d.enqueue:
        ref = d.enqueue[0]
        reason = "max_iterations" if ref.step is N.append and ref.iteration == (stop_at or iterations) else None
        d = transition(State(d.status), StepFinished(ref, Outcome.succeeded, reason))
        sent += d.enqueue
    assert d.status is S.completed and d.stop_reason == "max_iterations"
    return sent


def test_a_campaign_runs_preliminary_then_the_five_steps_of_every_iteration_in_order() -> None:
    sent = run_loop(3)
    assert sent == [StepRef(0, N.preliminary)] + [StepRef(k, s) for k in (1, 2, 3) for s in LOOP]


def test_step_refs_refuse_a_preliminary_step_outside_iteration_zero_and_the_loop_steps_in_it() -> None:
    with pytest.raises(ValueError, match="preliminary"):
        StepRef(2, N.preliminary)
    with pytest.raises(ValueError, match="train"):
        StepRef(0, N.train)


def test_a_fork_starts_with_the_train_step_after_its_source_iteration() -> None:
    d = transition(State(S.draft), Start(StepRef(5, N.train)))
    assert d.status is S.queued and d.enqueue == (StepRef(5, N.train),)


def test_only_a_draft_starts() -> None:
    for status in set(S) - {S.draft}:
        with pytest.raises(InvalidTransition, match="start"):
            transition(State(status), Start(StepRef(0, N.preliminary)))


def test_pause_lets_the_running_step_finish_then_parks_the_next_step_until_resume() -> None:
    d = transition(State(S.running), Pause())
    assert d.status is S.pausing and d.pause_requested and not d.enqueue
    d = transition(State(S.pausing, pause_requested=True), StepFinished(StepRef(1, N.ocp), Outcome.succeeded))
    assert d.status is S.paused and d.enqueue == () and d.pending == StepRef(1, N.oracle)
    d = transition(State(S.paused), Resume((StepRef(1, N.oracle),)))
    assert d.status is S.running and d.enqueue == (StepRef(1, N.oracle),)


def test_resume_while_still_pausing_forgets_the_request_and_sends_nothing() -> None:
    d = transition(State(S.pausing, pause_requested=True), Resume())
    assert d.status is S.running and not d.pause_requested and d.enqueue == ()


def test_cancel_is_cooperative_when_a_step_runs_and_immediate_otherwise() -> None:
    d = transition(State(S.running), Cancel(step_running=True))
    assert d.status is S.cancelling and d.cancel_requested and not d.is_terminal
    d = transition(State(S.cancelling, cancel_requested=True), StepFinished(StepRef(2, N.train), Outcome.succeeded))
    assert d.status is S.cancelled and d.enqueue == () and d.stop_reason == "cancelled"
    for status in (S.draft, S.queued, S.paused):
        d = transition(State(status), Cancel(step_running=False))
        assert d.status is S.cancelled and d.is_terminal
    for status in S.terminal():
        with pytest.raises(InvalidTransition):
            transition(State(status), Cancel(step_running=False))


def test_a_failed_ocp_or_oracle_under_policy_continue_skips_to_append_and_the_loop_goes_on() -> None:
    for step, skipped in ((N.ocp, [N.oracle, N.evaluate]), (N.oracle, [N.evaluate])):
        d = transition(State(S.running), StepFinished(StepRef(4, step), Outcome.iteration_failed, error="x"))
        assert d.status is S.running
        assert d.enqueue == (StepRef(4, N.append),)
        assert d.skip == tuple(StepRef(4, s) for s in skipped)
        d = transition(State(S.running), StepFinished(StepRef(4, N.append), Outcome.succeeded))
        assert d.enqueue == (StepRef(5, N.train),)


def test_a_step_failure_under_policy_stop_fails_the_campaign_and_retry_resumes_it() -> None:
    d = transition(State(S.running), StepFinished(StepRef(3, N.oracle), Outcome.failed, error="oracle exploded"))
    assert d.status is S.failed and d.error == "oracle exploded" and d.stop_reason == "error" and d.enqueue == ()
    d = transition(State(S.failed), RetryStep(StepRef(3, N.oracle)))
    assert d.status is S.running and d.enqueue == (StepRef(3, N.oracle),)
    with pytest.raises(InvalidTransition, match="retry"):
        transition(State(S.running), RetryStep(StepRef(3, N.oracle)))


def test_train_and_append_cannot_fail_an_iteration_only_the_campaign() -> None:
    for step in (N.train, N.append):
        d = transition(State(S.running), StepFinished(StepRef(2, step), Outcome.iteration_failed))
        assert d.status is S.failed


def test_a_finished_step_of_a_terminal_campaign_is_refused() -> None:
    for status in S.terminal():
        with pytest.raises(InvalidTransition):
            transition(State(status), StepFinished(StepRef(1, N.train), Outcome.succeeded))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["ok", "fail_ocp", "fail_oracle", "pause", "resume"]), min_size=1, max_size=60))
def test_whatever_happens_each_iteration_ends_in_exactly_one_append_and_steps_never_go_backwards(
    script: list[str],
) -> None:
    state = State(S.draft)
    d = transition(state, Start(StepRef(0, N.preliminary)))
    state, pending, order = State(d.status), list(d.enqueue), []
    appends: dict[int, int] = {}
    waiting = None
    for action in script:
        if action == "pause" and state.status in (S.queued, S.running):
            state = State(transition(state, Pause()).status, pause_requested=True)
            continue
        if action == "resume" and state.status is S.paused:
            d = transition(state, Resume((waiting,) if waiting else ()))
            state, pending, waiting = State(d.status), list(d.enqueue), None
            continue
        if not pending:
            continue
        ref = pending.pop(0)
        order.append(ref)
        outcome = Outcome.succeeded
        if (action == "fail_ocp" and ref.step is N.ocp) or (action == "fail_oracle" and ref.step is N.oracle):
            outcome = Outcome.iteration_failed
        d = transition(state, StepFinished(ref, outcome))
        if ref.step is N.append:
            appends[ref.iteration] = appends.get(ref.iteration, 0) + 1
        state, pending, waiting = State(d.status), list(d.enqueue), d.pending or waiting
        assert len(pending) <= 1
    assert all(n == 1 for n in appends.values())
    assert order == sorted(order, key=lambda r: (r.iteration, [N.preliminary, *LOOP].index(r.step)))
    assert sorted(appends) == list(range(1, len(appends) + 1))


# ----------------------------------------------------------------------------- stopping rules


def hist(*pairs: tuple[float, float]) -> list[IterationRecord]:
    return [IterationRecord(k + 1, f, m) for k, (f, m) in enumerate(pairs)]


def test_max_iterations_fires_at_the_iteration_index() -> None:
    rules = StoppingRules(max_iterations=3)
    assert stop_reason(rules, 2, hist((5, 1), (4, 1)), 0.0) is None
    assert stop_reason(rules, 3, hist((5, 1), (4, 1), (3, 1)), 0.0) == "max_iterations"


def test_target_rmse_needs_every_target_that_is_set() -> None:
    rules = StoppingRules(max_iterations=None, target_force_rmse=1.0, target_moment_rmse=0.1)
    assert stop_reason(rules, 1, hist((0.9, 0.2)), 0.0) is None
    assert stop_reason(rules, 2, hist((0.9, 0.2), (0.9, 0.05)), 0.0) == "target_rmse"
    only_force = StoppingRules(max_iterations=None, target_force_rmse=1.0)
    assert stop_reason(only_force, 1, hist((0.99, 50.0)), 0.0) == "target_rmse"


def test_target_rmse_looks_only_at_the_iteration_that_just_finished() -> None:
    """A failed iteration has no metrics; an older good RMSE must not stop the campaign."""
    rules = StoppingRules(max_iterations=None, target_force_rmse=1.0)
    assert stop_reason(rules, 2, hist((0.5, 0.1)), 0.0) is None


def test_plateau_fires_when_the_last_window_does_not_beat_the_best_before_it() -> None:
    rules = StoppingRules(max_iterations=None, plateau_window=3, plateau_tolerance=0.05)
    improving = hist((10, 1), (8, 1), (6, 1), (4, 1), (2, 1))
    assert stop_reason(rules, 5, improving, 0.0) is None
    flat = hist((10, 1), (5, 1), (5.2, 1), (4.9, 1), (5.1, 1))
    assert stop_reason(rules, 5, flat, 0.0) == "plateau"
    assert stop_reason(rules, 3, flat[:3], 0.0) is None  # not enough history yet


def test_max_oracle_calls_fires_once_the_calls_reach_the_budget() -> None:
    rules = StoppingRules(max_iterations=None, max_oracle_calls=64)
    assert stop_reason(rules, 15, hist((1, 1)), 0.0, oracle_calls=63) is None
    assert stop_reason(rules, 16, hist((1, 1)), 0.0, oracle_calls=64) == "oracle_calls"
    assert stop_reason(rules, 14, hist((1, 1)), 0.0, oracle_calls=66) == "oracle_calls"  # a batch overshoots
    assert StoppingRules(max_iterations=None, max_oracle_calls=1).max_oracle_calls == 1  # a rule on its own
    with pytest.raises(ValueError, match="max_oracle_calls"):
        StoppingRules(max_oracle_calls=0)


def test_ensemble_disagreement_needs_an_ensemble_of_two() -> None:
    """An ensemble of one has no spread: ensemble-disagreement would score every candidate 0."""
    ed = RunSettings(strategy="ensemble-disagreement", batch=2, candidates=4)
    problem = strategy_problem(ed, 1)
    assert problem is not None and "no disagreement" in problem and "ensemble_size 1" in problem
    assert strategy_problem(ed, 2) is None
    assert strategy_problem(RunSettings(strategy="random-scenarios", batch=2), 1) is None
    assert strategy_problem(RunSettings(), 1) is None


def test_oracle_budget_fires_on_the_total_oracle_wall_time() -> None:
    rules = StoppingRules(max_iterations=100, oracle_budget_s=60.0)
    assert stop_reason(rules, 4, hist((1, 1)), 59.9) is None
    assert stop_reason(rules, 4, hist((1, 1)), 60.0) == "oracle_budget"


def test_stopping_rules_need_at_least_one_rule() -> None:
    with pytest.raises(ValueError, match="at least one stopping rule"):
        StoppingRules(max_iterations=None)


# ----------------------------------------------------------------------------- batch fan-out / fan-in


class _Row:
    def __init__(self, step: str, slot: int, status: str) -> None:
        self.step, self.slot, self.status = step, slot, status


@settings(max_examples=150, deadline=None)
@given(
    q=st.integers(1, 5),
    cap=st.one_of(st.none(), st.integers(1, 3)),
    script=st.lists(
        st.tuples(st.sampled_from(["ok", "fail", "pause", "resume"]), st.integers(0, 20)), min_size=0, max_size=40
    ),
)
def test_a_batch_fans_out_and_back_in_exactly_once_whatever_the_order(
    q: int, cap: int | None, script: list[tuple[str, int]]
) -> None:
    """Iteration 1 of a random-scenarios campaign with q slots and an oracle cap: its jobs end in
    any order, some fail, the campaign is paused and resumed in between (a claimed job of a
    pausing campaign parks its step, as the protocol does). The rows play the database and
    :func:`slots_of_rows` reads them as the completing transaction does. Whatever happens: each slot's
    ocp and oracle job runs once (nothing is redone), never more than ``cap`` oracle jobs are
    queued or running, ``evaluate`` runs iff some pick produced data and after every pick ended,
    and the iteration reaches exactly one ``append``."""
    from alcove.campaigns.machine.slots import slots_of_rows

    rows: dict[tuple[str, int], str] = {}
    queue: list[StepRef] = []
    ran: list[StepRef] = []
    state = State(S.running)

    def oracles_busy() -> int:
        return sum(st_ in ("queued", "running") for (step, _), st_ in rows.items() if step == "oracle")

    def apply(d: Any) -> None:
        nonlocal state
        for r in d.skip:
            rows[(r.step.value, r.slot)] = "skipped"
        for r in ((d.pending,) if d.pending else ()) + d.wait:
            if rows.get((r.step.value, r.slot), "pending") == "pending":
                rows[(r.step.value, r.slot)] = "pending"
        for r in d.enqueue:
            rows[(r.step.value, r.slot)] = "queued"
            queue.append(r)
        state = State(d.status, pause_requested=d.pause_requested)
        assert cap is None or oracles_busy() <= cap

    def room() -> int | None:
        return None if cap is None else max(0, cap - oracles_busy())

    def resume() -> None:
        pending = [StepRef(1, N(step), slot) for (step, slot), st_ in sorted(rows.items()) if st_ == "pending"]
        oracles = [r for r in pending if r.step is N.oracle]
        n = room()
        if n is not None and len(oracles) > n:
            pending = [r for r in pending if r.step is not N.oracle] + oracles[:n]
        apply(transition(state, Resume(tuple(pending))))

    def finish(i: int, ok: bool) -> None:
        ref = queue.pop(i % len(queue))
        if state.pause_requested or state.status in (S.pausing, S.paused):  # the claim parks it
            rows[(ref.step.value, ref.slot)] = "pending"
            if not any(s_ in ("queued", "running") for s_ in rows.values()):  # the last busy one: paused
                apply(Decision(S.paused))
            return
        ran.append(ref)
        outcome = Outcome.succeeded if ok or ref.step not in (N.ocp, N.oracle) else Outcome.iteration_failed
        rows[(ref.step.value, ref.slot)] = "succeeded" if outcome is Outcome.succeeded else "failed"
        if ref.step is N.append:
            return
        slots = Slots()
        if ref.step in (N.ocp, N.oracle):
            slot_rows = [_Row(s, j, v) for (s, j), v in rows.items() if s in ("ocp", "oracle")]
            slots = slots_of_rows(slot_rows, ref, q, room())
        if ref.step is N.evaluate:  # the pick rows all ended before it was sent
            assert all(v not in ("pending", "queued", "running") for (s, _), v in rows.items() if s != "evaluate")
        apply(transition(state, StepFinished(ref, outcome, slots=slots)))

    apply(transition(state, StepFinished(StepRef(1, N.train), Outcome.succeeded, slots=Slots(ocp_slots=q))))
    for action, i in script:
        if action == "pause" and state.status is S.running:
            apply(transition(state, Pause()))
        elif action == "resume" and state.status in (S.paused, S.pausing):
            resume()
        elif action in ("ok", "fail") and queue:
            finish(i, action == "ok")
    for _ in range(100):  # then everything succeeds until the iteration is appended
        if state.status in (S.paused, S.pausing) and not queue:
            resume()
        if not queue:
            break
        finish(0, True)
    assert [r.step for r in ran].count(N.append) == 1, ran
    for step in (N.ocp, N.oracle):
        slots = [r.slot for r in ran if r.step is step]
        assert len(slots) == len(set(slots)), f"{step.value} slot run twice: {ran}"
    assert sorted(r.slot for r in ran if r.step is N.ocp) == list(range(q))
    ocp_ok = {j for j in range(q) if rows[("ocp", j)] == "succeeded"}
    assert {r.slot for r in ran if r.step is N.oracle} == ocp_ok
    some_data = any(rows.get(("oracle", j)) == "succeeded" for j in range(q))
    assert (N.evaluate in [r.step for r in ran]) == some_data
    assert [r.step for r in ran][-1] is N.append


def test_a_streak_of_failed_iterations_stops_but_is_not_a_rule_on_its_own() -> None:
    rules = StoppingRules(max_iterations=200)
    assert rules.max_failed_streak == 10  # on by default
    assert stop_reason(rules, 12, hist((1, 1)), 0.0, failed_streak=9) is None
    assert stop_reason(rules, 12, hist((1, 1)), 0.0, failed_streak=10) == "failed_streak"
    assert stop_reason(rules.model_copy(update={"max_failed_streak": None}), 12, [], 0.0, failed_streak=50) is None
    with pytest.raises(ValueError, match="at least one stopping rule"):
        StoppingRules(max_iterations=None, max_failed_streak=3)  # a safety net cannot end a campaign by itself
    with pytest.raises(ValueError, match="max_failed_streak"):
        StoppingRules(max_failed_streak=0)
