"""The campaign as a pure state machine: ``transition(state, event) -> Decision``.

No database, no Celery: the service and the step executors load a :class:`State`, build
an event, ask :func:`transition` what happens, write the decision in their transaction and
enqueue ``decision.enqueue`` after the commit.

Iterations: iteration 0 has the single ``preliminary`` step (pool version 0); iteration
k >= 1 runs ``train -> ocp -> oracle -> evaluate -> append``. A fork starts at iteration
``source_iteration + 1`` with ``train``. An iteration whose OCP or oracle failed under the
policy "continue" skips to ``append`` (pool version k = pool version k-1, nothing new), so
every iteration still leaves exactly one pool version.

Stopping rules are checked when an iteration's ``append`` succeeded
(:func:`stop_reason`); the first rule that fires is recorded as the campaign's
``stop_reason``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

from alcove.errors import Conflict
from alcove.models.base import ITERATION_STEPS, CampaignStatus, StepName

S = CampaignStatus


class InvalidTransition(Conflict, ValueError):
    """The event is not allowed in the campaign's current state (409)."""

    def __init__(self, status: CampaignStatus | str, event: str, reason: str = ""):
        self.status = CampaignStatus(status)
        self.event = event
        super().__init__(f"cannot {event} a campaign that is {self.status.value}" + (f": {reason}" if reason else ""))


@dataclass(frozen=True, order=True)
class StepRef:
    """Step ``step`` of iteration ``iteration``; ``slot``: which of the iteration's parallel
    jobs of that step (``ocp``: the candidate, ``oracle``: the pick; 0 for the other steps)."""

    iteration: int
    step: StepName
    slot: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "step", StepName(self.step))
        if self.iteration < 0:
            raise ValueError(f"iteration: must be >= 0, got {self.iteration}")
        if self.slot < 0 or (self.slot and self.step not in (StepName.ocp, StepName.oracle)):
            raise ValueError(f"slot: {self.step.value} has no slot {self.slot} (only ocp and oracle fan out)")
        if (self.step is StepName.preliminary) != (self.iteration == 0):
            raise ValueError(
                f"step: {self.step.value} cannot run in iteration {self.iteration} (preliminary is iteration 0 only)"
            )

    def following(self) -> StepRef:
        """The step after this one when it succeeded."""
        if self.step in (StepName.preliminary, StepName.append):
            return StepRef(self.iteration + 1, StepName.train)
        return StepRef(self.iteration, ITERATION_STEPS[ITERATION_STEPS.index(self.step) + 1])

    def skipped_until_append(self) -> list[StepRef]:
        """Steps between this one and ``append`` (skipped after a failure under policy continue)."""
        i = ITERATION_STEPS.index(self.step)
        return [StepRef(self.iteration, s) for s in ITERATION_STEPS[i + 1 : -1]]

    def __str__(self) -> str:
        return f"{self.iteration}/{self.step.value}" + (f"[{self.slot}]" if self.slot else "")


class Outcome(str, Enum):
    succeeded = "succeeded"
    #: the iteration failed (OCP did not converge, oracle failed or was quarantined) and the
    #: policy says continue: the remaining steps are skipped up to ``append``
    iteration_failed = "iteration_failed"
    #: a failure whose policy is "stop" (or a step out of attempts): the campaign fails
    failed = "failed"
    #: the job saw the cancel flag and stopped
    cancelled = "cancelled"


# ----------------------------------------------------------------------------- events


@dataclass(frozen=True)
class Start:
    first: StepRef


@dataclass(frozen=True)
class Pause:
    pass


@dataclass(frozen=True)
class Resume:
    #: the steps waiting to run (several: parallel slots, as many as the concurrency cap allows;
    #: empty: a step is still running)
    waiting: tuple[StepRef, ...] = ()


@dataclass(frozen=True)
class Cancel:
    step_running: bool


@dataclass(frozen=True)
class Slots:
    """What the database says about the iteration's parallel slots when one of them finished
    (the completing transaction holds the campaign's lock, so completions are serialised and
    exactly one of them sees ``open == 0``: the fan-in).

    ``ocp_slots``: the number of ocp jobs a finished ``train`` fans out into (C candidates, or q);
    ``selects``: the strategy picks among the candidates once all are solved (else ocp slot j
    feeds oracle slot j); ``open``: ocp/oracle slots of the iteration not finished yet (this one
    excluded); ``picks``: at the fan-in of a selecting strategy, the candidates' ocp slots picked
    (oracle slot i replays ``picks[i]``); ``oracle_ok``: the other oracle slots that produced a
    dataset;
    ``oracle_room``: how many of the oracle jobs this completion makes necessary may be sent now
    (the campaign's concurrency cap, None: all; the rest wait ``pending``); ``release``: after an
    oracle slot ended, the waiting oracle slots the freed capacity starts; ``busy``: sibling slots
    queued or running (a pause waits for them)."""

    ocp_slots: int = 1
    selects: bool = False
    open: int = 0
    picks: tuple[int, ...] = ()
    oracle_ok: int = 0
    oracle_room: int | None = None
    release: tuple[int, ...] = ()
    busy: int = 0


@dataclass(frozen=True)
class StepFinished:
    ref: StepRef
    outcome: Outcome
    stop_reason: str | None = None  # set by the append step when a stopping rule fired
    error: str | None = None
    slots: Slots = field(default_factory=Slots)


@dataclass(frozen=True)
class RetryStep:
    ref: StepRef


Event = Start | Pause | Resume | Cancel | StepFinished | RetryStep


@dataclass(frozen=True)
class State:
    status: CampaignStatus
    pause_requested: bool = False
    cancel_requested: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", CampaignStatus(self.status))


@dataclass(frozen=True)
class Decision:
    status: CampaignStatus
    enqueue: tuple[StepRef, ...] = ()
    #: a step to create but leave pending (the campaign paused before it)
    pending: StepRef | None = None
    #: more steps to create pending (oracle picks beyond the concurrency cap; paused fan-outs)
    wait: tuple[StepRef, ...] = ()
    #: steps to mark skipped (after an iteration failure under policy continue)
    skip: tuple[StepRef, ...] = ()
    stop_reason: str | None = None
    pause_requested: bool = False
    cancel_requested: bool = False
    error: str | None = None
    events: tuple[str, ...] = field(default=())

    @property
    def is_terminal(self) -> bool:
        return self.status in CampaignStatus.terminal()


ACTIVE = frozenset({S.queued, S.running, S.pausing})


def transition(state: State, event: Event) -> Decision:
    """What ``event`` does to a campaign in ``state`` (raises :class:`InvalidTransition`)."""
    st = state.status
    match event:
        case Start(first):
            if st is not S.draft:
                raise InvalidTransition(st, "start", "only a draft campaign can be started")
            return Decision(S.queued, enqueue=(first,))
        case Pause():
            if st in (S.pausing, S.paused):
                return Decision(st, pause_requested=True)
            if st not in (S.queued, S.running):
                raise InvalidTransition(st, "pause")
            return Decision(S.pausing, pause_requested=True)
        case Resume(waiting):
            if st is S.pausing:  # a step is still running; forget the request (and start parallel
                return Decision(S.running, enqueue=waiting)  # slots a claim parked meanwhile)
            if st is not S.paused:
                raise InvalidTransition(st, "resume", "only a paused campaign can be resumed")
            return Decision(S.running, enqueue=waiting)
        case Cancel(step_running):
            if st in CampaignStatus.terminal():
                raise InvalidTransition(st, "cancel")
            if st is S.cancelling:
                return Decision(S.cancelling, cancel_requested=True)
            if step_running and st in (S.running, S.pausing, S.queued):
                return Decision(S.cancelling, cancel_requested=True)
            return Decision(S.cancelled, cancel_requested=True, stop_reason="cancelled")
        case RetryStep(ref):
            if st is not S.failed:
                raise InvalidTransition(st, "retry a step of", "only a failed campaign has a step to retry")
            return Decision(S.running, enqueue=(ref,))
        case StepFinished(ref, outcome, reason, error, slots):
            return _step_finished(state, ref, outcome, reason, error, slots)
    raise TypeError(f"unknown event {event!r}")


def _step_finished(
    state: State, ref: StepRef, outcome: Outcome, reason: str | None, error: str | None, slots: Slots
) -> Decision:
    st = state.status
    if st in CampaignStatus.terminal():
        raise InvalidTransition(st, f"finish step {ref} of")
    if state.cancel_requested or st is S.cancelling or outcome is Outcome.cancelled:
        return Decision(S.cancelled, stop_reason="cancelled", cancel_requested=True)
    if outcome is Outcome.failed:
        return Decision(S.failed, stop_reason="error", error=error or f"step {ref} failed")
    if outcome is Outcome.iteration_failed and ref.step in (StepName.preliminary, StepName.train, StepName.append):
        return Decision(S.failed, stop_reason="error", error=error or f"step {ref} failed")
    if ref.step is StepName.append and outcome is Outcome.succeeded and reason:
        return Decision(S.completed, stop_reason=reason)
    k = ref.iteration
    if ref.step is StepName.oracle and outcome is Outcome.succeeded:
        slots = replace(slots, oracle_ok=slots.oracle_ok + 1)  # this one's dataset
    nxt: tuple[StepRef, ...] = ()
    oracles: tuple[StepRef, ...] = ()  # oracle jobs to start, as many as the concurrency cap allows
    skip: tuple[StepRef, ...] = ()
    if ref.step is StepName.train:  # fan-out: one ocp job per candidate
        nxt = tuple(StepRef(k, StepName.ocp, j) for j in range(max(slots.ocp_slots, 1)))
    elif ref.step is StepName.ocp and not slots.selects:  # ocp slot j feeds oracle slot j
        if outcome is Outcome.succeeded:
            oracles = (StepRef(k, StepName.oracle, ref.slot),)
        else:
            skip = (StepRef(k, StepName.oracle, ref.slot),)
            nxt, skip = _fan_in(k, slots), skip + _skipped_evaluate(k, slots)
    elif ref.step is StepName.ocp:  # a selecting strategy: wait for every candidate, then pick
        if slots.open:
            pass
        elif slots.picks:
            oracles = tuple(StepRef(k, StepName.oracle, i) for i in range(len(slots.picks)))
        else:  # nothing worth asking the oracle: no data this iteration
            nxt, skip = (StepRef(k, StepName.append),), (StepRef(k, StepName.evaluate),)
    elif ref.step is StepName.oracle:
        oracles = tuple(StepRef(k, StepName.oracle, j) for j in slots.release)
        nxt, skip = _fan_in(k, slots), _skipped_evaluate(k, slots)
    else:
        nxt = (ref.following(),)
    n = len(oracles) if slots.oracle_room is None else max(0, min(slots.oracle_room, len(oracles)))
    start, wait = nxt + oracles[:n], oracles[n:]
    if state.pause_requested or st in (S.pausing, S.paused):
        if slots.busy:  # siblings still running: the campaign pauses when the last of them ends
            return Decision(S.pausing, wait=start + wait, skip=skip, pause_requested=True)
        return Decision(
            S.paused, pending=start[0] if start else None, wait=start[1:] + wait, skip=skip, pause_requested=False
        )
    return Decision(S.running, enqueue=start, wait=wait, skip=skip)


def _fan_in(k: int, slots: Slots) -> tuple[StepRef, ...]:
    """After an ocp (non-selecting) or oracle slot ended: nothing while others are open; then
    ``evaluate`` if some pick produced a dataset, else straight to ``append`` (no new data)."""
    if slots.open:
        return ()
    return (StepRef(k, StepName.evaluate),) if slots.oracle_ok else (StepRef(k, StepName.append),)


def _skipped_evaluate(k: int, slots: Slots) -> tuple[StepRef, ...]:
    return (StepRef(k, StepName.evaluate),) if not slots.open and not slots.oracle_ok else ()


# ----------------------------------------------------------------------------- stopping rules


@dataclass(frozen=True)
class IterationRecord:
    """What the stopping rules look at for one finished iteration (None: no metrics)."""

    iteration: int
    force_rmse: float | None
    moment_rmse: float | None


def stop_reason(
    rules: Any,
    iteration: int,
    history: Sequence[IterationRecord],
    oracle_wall_time_s: float,
    top_score: float | None = None,
    oracle_calls: int = 0,
    failed_streak: int = 0,
) -> str | None:
    """The first stopping rule that fires after iteration ``iteration`` finished, or None.

    ``rules`` has the fields of :class:`alcove.campaigns.schemas.StoppingRules`.
    ``history`` holds this campaign's finished iterations in order (the current one last).

    * ``target_rmse``: the latest force RMSE <= ``target_force_rmse`` and the latest moment
      RMSE <= ``target_moment_rmse`` (each only if set);
    * ``plateau``: over the last ``plateau_window`` iterations with metrics, the best force
      RMSE improved on the best before them by less than ``plateau_tolerance`` (relative);
    * ``oracle_budget``: the oracle's total wall time reached ``oracle_budget_s``;
    * ``oracle_calls``: the campaign's oracle calls ``oracle_calls`` (every oracle run, also
      failed attempts and the calls of failed iterations) reached ``max_oracle_calls``;
    * ``failed_streak``: the last ``failed_streak`` iterations (this one included) failed, at
      least ``max_failed_streak`` of them;
    * ``max_iterations``: iteration index ``iteration`` >= ``max_iterations``;
    * ``min_disagreement``: the iteration's highest candidate score ``top_score`` (strategy
      ensemble-disagreement) fell below ``min_disagreement`` (checked first: that iteration asked
      the oracle nothing).
    """
    if rules.min_disagreement is not None and top_score is not None and top_score < rules.min_disagreement:
        return "min_disagreement"
    latest = history[-1] if history and history[-1].iteration == iteration else None
    tf, tm = rules.target_force_rmse, rules.target_moment_rmse
    if latest is not None and (tf is not None or tm is not None):
        ok_f = tf is None or (latest.force_rmse is not None and latest.force_rmse <= tf)
        ok_m = tm is None or (latest.moment_rmse is not None and latest.moment_rmse <= tm)
        if ok_f and ok_m:
            return "target_rmse"
    window = rules.plateau_window
    if window:
        values = [h.force_rmse for h in history if h.force_rmse is not None and math.isfinite(h.force_rmse)]
        if len(values) > window:
            before, recent = min(values[:-window]), min(values[-window:])
            if before - recent <= rules.plateau_tolerance * before:
                return "plateau"
    if rules.oracle_budget_s is not None and oracle_wall_time_s >= rules.oracle_budget_s:
        return "oracle_budget"
    if rules.max_oracle_calls is not None and oracle_calls >= rules.max_oracle_calls:
        return "oracle_calls"
    if rules.max_failed_streak is not None and failed_streak >= rules.max_failed_streak:
        return "failed_streak"
    if rules.max_iterations is not None and iteration >= rules.max_iterations:
        return "max_iterations"
    return None


__all__ = [
    "Cancel",
    "Decision",
    "Event",
    "InvalidTransition",
    "IterationRecord",
    "Outcome",
    "Pause",
    "Resume",
    "RetryStep",
    "Slots",
    "Start",
    "State",
    "StepFinished",
    "StepRef",
    "stop_reason",
    "transition",
]
