"""A batch iteration's parallel slots: their fan-out, their fan-in, and the oracle jobs the
campaign's concurrency cap lets start.

An iteration of a batch strategy runs several ``ocp`` jobs (slot j solves candidate scenario j)
and several ``oracle`` jobs (slot i replays pick i). Each job completes its own step row in its
own transaction, which holds the campaign's row lock (:func:`alcove.campaigns.run.protocol.run_step`),
so completions are serialised: :func:`slots_after` reads the sibling rows in that transaction and
exactly one completion sees no sibling open, the fan-in, which alone creates the next step
(``evaluate`` or ``append``; the step rows are unique per (iteration, step, slot), so a second
creation could not happen anyway). Duplicate deliveries claim nothing
(:func:`alcove.campaigns.repository.claim_step`), and a job lost with its worker is re-queued
alone by the reconciler: the other slots keep their results.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Protocol

from sqlalchemy.orm import Session

from alcove.campaigns import candidate_queries
from alcove.campaigns import repository as repo
from alcove.campaigns.config import RunSettings, config_from_version
from alcove.campaigns.machine.state_machine import Outcome, Slots, StepRef
from alcove.models import Campaign, CampaignConfigVersion, Iteration, StepName, StepStatus

OPEN = (StepStatus.pending.value, StepStatus.queued.value, StepStatus.running.value)


def ocp_slots(settings: RunSettings) -> int:
    """How many ocp jobs an iteration fans out into under ``settings``."""
    if settings.strategy == "ensemble-disagreement":
        return settings.candidates
    return settings.batch if settings.strategy in ("random-scenarios", "press-family") else 1


def selects(settings: RunSettings) -> bool:
    """Whether the strategy picks among its solved candidates (else ocp slot j feeds oracle slot j)."""
    return settings.strategy == "ensemble-disagreement"


def select_picks(s: Session, c: Campaign, it: Iteration, settings: RunSettings) -> tuple[int, ...]:
    """The fan-in of a selecting strategy's candidate solves: pick at most q of the iteration's
    candidates (:func:`alcove.science.ocp.acquisition.select_batch`), write the picks on their
    rows (oracle slot i replays the candidate picked i-th) and return their ocp slots. Runs once,
    in the transaction of the last candidate's completion."""
    from alcove.science.ocp.acquisition import select_batch

    cands = candidate_queries.candidates(s, it.id)
    cv = s.get(CampaignConfigVersion, it.config_version_id)
    assert cv is not None
    threshold = config_from_version(cv).stopping.min_disagreement
    scores = [cand.score if cand.converged else None for cand in cands]
    width = max((len(cand.features or []) for cand in cands), default=0)
    features = [list(cand.features or [0.0] * width) for cand in cands]
    picks = select_batch(scores, features, settings.batch, settings.min_distance, threshold)
    by_slot = {cand.slot: cand for cand in cands}
    for i, pk in enumerate(picks):
        row = by_slot[cands[pk.slot].slot]
        row.pick, row.pick_reason = i, pk.reason
    s.flush()
    return tuple(cands[pk.slot].slot for pk in picks)


def iteration_settings(s: Session, it: Iteration) -> RunSettings:
    cv = s.get(CampaignConfigVersion, it.config_version_id)
    assert cv is not None
    return RunSettings.model_validate(cv.settings)


def oracle_room(s: Session, c: Campaign, settings: RunSettings) -> int | None:
    """Oracle jobs the campaign may send now under its concurrency cap (None: no cap)."""
    cap = settings.max_concurrent_oracle_jobs
    return None if cap is None else max(0, cap - repo.active_oracle_steps(s, c.id))


def waiting_steps(s: Session, c: Campaign) -> list[StepRef]:
    """The steps of ``c`` to send when it runs again (a resume, an admission): the pending rows of
    its last iteration that has any (oracle slots: as many as the concurrency cap allows; the rest
    stay pending until running ones end)."""
    rows = repo.steps_of_campaign(s, c.id, [StepStatus.pending.value])
    if not rows:
        return []
    k = rows[-1][0]
    refs = [StepRef(i, StepName(row.step), row.slot) for i, row in rows if i == k]
    it = repo.get_iteration(s, c.id, k)
    assert it is not None
    room = oracle_room(s, c, iteration_settings(s, it))
    oracles = [r for r in refs if r.step is StepName.oracle]
    if room is not None and len(oracles) > room:
        refs = [r for r in refs if r.step is not StepName.oracle] + oracles[:room]
    return refs


class SlotRow(Protocol):
    """What :func:`slots_of_rows` reads of a step row (an ``IterationStep``, or a test's stand-in)."""

    step: str
    slot: int
    status: str


def slots_of_rows(rows: Sequence[SlotRow], ref: StepRef, ocp_slots: int, room: int | None) -> Slots:
    """The :class:`Slots` of ocp/oracle step ``ref`` that just ended, from the iteration's ocp and
    oracle rows (``ref``'s own row already carries its final status) and ``room``, the oracle
    jobs the concurrency cap allows to start now (None: no cap). Pure: the state-machine tests
    drive it with rows of their own."""
    this = next(r for r in rows if r.step == ref.step.value and r.slot == ref.slot)
    others = [r for r in rows if r is not this]
    release: tuple[int, ...] = ()
    if ref.step is StepName.oracle:  # oracle slots parked by the cap (or a pause that was lifted)
        release = tuple(sorted(r.slot for r in others if r.step == "oracle" and r.status == "pending"))
    return Slots(
        ocp_slots=ocp_slots,
        open=sum(r.status in OPEN for r in others),
        busy=sum(r.status in (StepStatus.queued.value, StepStatus.running.value) for r in others),
        oracle_ok=sum(r.step == "oracle" and r.status == StepStatus.succeeded.value for r in others),
        oracle_room=room,
        release=release,
    )


def slots_after(s: Session, c: Campaign, it: Iteration, ref: StepRef, outcome: Outcome) -> Slots:
    """The :class:`Slots` of the step ``ref`` that just ended with ``outcome`` (its row already
    carries its final status), read in the completing transaction."""
    settings = iteration_settings(s, it)
    if ref.step is StepName.train:
        return Slots(ocp_slots=ocp_slots(settings))
    if ref.step not in (StepName.ocp, StepName.oracle):
        return Slots()
    rows = repo.slot_steps(s, it.id, [StepName.ocp.value, StepName.oracle.value])
    slots = slots_of_rows(rows, ref, ocp_slots(settings), oracle_room(s, c, settings))
    if ref.step is StepName.ocp and selects(settings):
        picks = select_picks(s, c, it, settings) if slots.open == 0 else ()
        slots = replace(slots, selects=True, picks=picks)
    return slots
