"""Acquisition strategies: which scenario(s) an active-learning iteration solves.

A strategy maps ``(task, campaign seed, iteration k, batch size q)`` to the q scenarios the
iteration's OCP solves with the current surrogate; the oracle then replays each solved
trajectory. Everything is seeded by the campaign seed and k, so a step re-run by another worker
(or a re-delivered job) solves the same scenario.

Implemented:

* ``paper``: the nominal task every iteration, no exploration (the paper's loop, exactly); q = 1.
* ``random-scenarios``: q scenarios ``(seed, k, slot)``, slot = 0 .. q-1, drawn uniformly from
  the task's ranges (:func:`alcove.science.ocp.scenarios.draw`); a task without ranges gives the
  nominal task. The campaign solves each in its own ``ocp`` job (slot) and replays each in its
  own ``oracle`` job (:meth:`Strategy.scenario` draws one slot's scenario on its own).

* ``ensemble-disagreement`` (query by committee): C candidate scenarios drawn as
  ``random-scenarios`` draws them (slots 0 .. C-1), each solved with the ensemble mean in its own
  ``ocp`` job and scored by the ensemble's disagreement over its contact phase (the largest
  ensemble force std |sigma_F| [N] at the solution's midpoints in contact, the OCP's trust
  diagnostic ``max_std_contact``; 0 without contact); :func:`select_batch` then picks at most q of
  them, the highest scores first, no two closer than ``min_distance`` in the scenarios' feature
  space (:func:`scenario_features`: each ranged parameter scaled to [0, 1] over its range);
  candidates with score 0 (no contact) are never picked.

* ``press-family``: no OCP; the oracle replays prescribed motions of the task's press family
  (:mod:`alcove.science.press_family`: press, dwell, partial unload, re-load, return), q per
  iteration, the next motions of the family's space-filling sequence
  (:func:`alcove.science.press_family.sequence_motion`, seeded by the campaign seed). The
  scenario is the nominal task (its headrest); the motion is stored with the slot's candidate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Protocol

import numpy as np

from alcove.science.ocp.scenarios import Scenario, draw, nominal

if TYPE_CHECKING:
    from alcove.science.ocp.task_spec import TaskSpec

StrategyName = Literal["paper", "random-scenarios", "ensemble-disagreement", "press-family"]
STRATEGIES: tuple[StrategyName, ...] = ("paper", "random-scenarios", "ensemble-disagreement", "press-family")


class Strategy(Protocol):
    @property
    def name(self) -> StrategyName: ...

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        """The scenarios iteration ``iteration`` of a campaign with ``seed`` solves (``q`` of them)."""
        ...

    def scenario(self, task: TaskSpec, seed: int, iteration: int, slot: int) -> Scenario:
        """Slot ``slot`` of :meth:`candidates` on its own (what one ocp job solves)."""
        ...


@dataclass(frozen=True)
class Paper:
    """The nominal task, every iteration (ranges ignored)."""

    name: StrategyName = "paper"

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        if q != 1:
            raise ValueError(f"batch: strategy 'paper' replays one trajectory per iteration (q = 1), got {q}")
        return [Scenario(task=nominal(task))]

    def scenario(self, task: TaskSpec, seed: int, iteration: int, slot: int) -> Scenario:
        if slot != 0:
            raise ValueError(f"slot: strategy 'paper' has slot 0 only, got {slot}")
        return Scenario(task=nominal(task))


@dataclass(frozen=True)
class RandomScenarios:
    """q scenarios drawn uniformly from the task's ranges, seeded by (seed, iteration, slot)."""

    name: StrategyName = "random-scenarios"

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        if q < 1:
            raise ValueError(f"batch: q must be at least 1, got {q}")
        return [draw(task, seed, iteration, slot) for slot in range(q)]

    def scenario(self, task: TaskSpec, seed: int, iteration: int, slot: int) -> Scenario:
        if slot < 0:
            raise ValueError(f"slot: must be >= 0, got {slot}")
        return draw(task, seed, iteration, slot)


@dataclass(frozen=True)
class EnsembleDisagreement(RandomScenarios):
    """C candidates drawn as :class:`RandomScenarios` draws them; the campaign scores them and
    picks q with :func:`select_batch`."""

    name: StrategyName = "ensemble-disagreement"


@dataclass(frozen=True)
class PressFamilyMotions(RandomScenarios):
    """The nominal task in every slot: what the oracle replays is a prescribed motion of the press
    family, not an OCP's optimum (the campaign draws the motion, :func:`family_motion_index`)."""

    name: StrategyName = "press-family"

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        if q < 1:
            raise ValueError(f"batch: q must be at least 1, got {q}")
        return [self.scenario(task, seed, iteration, slot) for slot in range(q)]

    def scenario(self, task: TaskSpec, seed: int, iteration: int, slot: int) -> Scenario:
        if slot < 0:
            raise ValueError(f"slot: must be >= 0, got {slot}")
        return Scenario(task=nominal(task), seed=seed, iteration=iteration, slot=slot)


def family_motion_index(used: Sequence[int], slot: int) -> int:
    """The press family's sequence index of a slot: the motions after the last one an earlier
    iteration used (``used``: their indices; none: from 0), one per slot, so the campaign's motions
    are a prefix of the sequence whatever the batch sizes were."""
    return (max(used) + 1 if used else 0) + slot


def strategy(name: str) -> Strategy:
    """The strategy called ``name``; ValueError naming the known ones otherwise."""
    if name == "paper":
        return Paper()
    if name == "random-scenarios":
        return RandomScenarios()
    if name == "ensemble-disagreement":
        return EnsembleDisagreement()
    if name == "press-family":
        return PressFamilyMotions()
    raise ValueError(f"strategy: unknown {name!r}; known: {', '.join(STRATEGIES)}")


def scenario_features(task: TaskSpec, values: dict[str, float]) -> list[float]:
    """A scenario's point in the feature space of the diversity rule: each of the task's ranged
    parameters scaled to [0, 1] over its range (declaration order; a range of zero width: 0)."""
    out = []
    for r in task.ranges or []:
        width = r.high - r.low
        out.append(float((values[r.parameter] - r.low) / width) if width > 0 else 0.0)
    return out


@dataclass(frozen=True)
class Pick:
    slot: int  # the candidate (ocp slot)
    reason: str


#: Why a candidate was or was not picked (:func:`explain_selection`):
#: ``picked-top`` the highest score; ``picked-far`` the next highest score at least
#: ``min_distance`` from every earlier pick; ``not-converged`` its OCP did not converge (no
#: score); ``below-threshold`` the highest score of all is below the stopping threshold, so
#: nothing is picked; ``too-close`` closer than ``min_distance`` to an earlier pick;
#: ``batch-full`` q picks were made before its turn (not in the top q); ``no-contact`` its score is
#: 0: its OCP solution never touches the headrest, so its replay would teach the contact model
#: nothing (never picked, also when fewer than q candidates are in contact).
VerdictCode = Literal[
    "picked-top", "picked-far", "not-converged", "below-threshold", "too-close", "batch-full", "no-contact"
]


@dataclass(frozen=True)
class Verdict:
    """One candidate's outcome in :func:`explain_selection`."""

    rank: int | None  # by descending score (ties: lower slot), 1 = highest; None: no score
    pick: int | None  # pick order (0 = first pick); None: not picked
    code: VerdictCode
    reason: str
    nearest_pick: int | None = None  # the pick (order) nearest to it when it was considered
    distance: float | None = None  # its distance to that pick in feature space


def explain_selection(
    scores: Sequence[float | None],
    features: Sequence[Sequence[float]],
    q: int,
    min_distance: float,
    threshold: float | None = None,
) -> list[Verdict]:
    """Per candidate (in the order given), its rank and whether and why :func:`select_batch`
    picks it: candidates are taken by descending score (ties: the lower slot); the first is
    picked; each next one is picked if its Euclidean distance in ``features`` to every pick
    already made is at least ``min_distance``, else skipped (``too-close``); once q are picked
    the rest are ``batch-full``. A candidate without a finite score (its OCP did not converge)
    is never picked, nor one whose score is 0 (no contact along its solution: ``no-contact``),
    so an iteration may pick fewer than q, or none. With ``threshold``: nothing is picked when
    the highest score is below it."""
    if q < 1:
        raise ValueError(f"batch: q must be at least 1, got {q}")
    if min_distance < 0:
        raise ValueError(f"min_distance: must be >= 0, got {min_distance}")
    if len(scores) != len(features):
        raise ValueError(f"features: {len(features)} rows for {len(scores)} candidates")
    out: list[Verdict | None] = [None] * len(scores)
    for j, sc in enumerate(scores):
        if sc is None or not np.isfinite(sc):
            out[j] = Verdict(None, None, "not-converged", "its OCP did not converge: not scored, never picked")
    scored = sorted(
        ((float(sc), j) for j, sc in enumerate(scores) if sc is not None and np.isfinite(sc)),
        key=lambda p: (-p[0], p[1]),
    )
    top = scored[0][0] if scored else None
    x = np.asarray(features, float).reshape(len(scores), -1)
    picks: list[int] = []  # candidate indices, in pick order
    below_threshold = threshold is not None and top is not None and top < threshold
    for rank, (sc, j) in enumerate(scored, start=1):
        if below_threshold:
            out[j] = Verdict(
                rank,
                None,
                "below-threshold",
                f"disagreement {sc:.4g} N; the highest, {top:.4g} N, is below the stopping threshold "
                f"{threshold:g} N: nothing is picked",
            )
            continue
        if sc <= 0.0:
            out[j] = Verdict(
                rank,
                None,
                "no-contact",
                "disagreement 0: its OCP solution never touches the headrest, its replay would not teach "
                "the contact model: never picked",
            )
            continue
        if len(picks) == q:
            out[j] = Verdict(rank, None, "batch-full", f"disagreement {sc:.4g} N: not in the top q = {q} (batch full)")
            continue
        dists = [float(np.linalg.norm(x[j] - x[p])) for p in picks]
        near_i = int(np.argmin(dists)) if dists else None
        near = dists[near_i] if near_i is not None else None
        if near_i is not None and near is not None and near < min_distance:
            out[j] = Verdict(
                rank,
                None,
                "too-close",
                f"disagreement {sc:.4g} N, but {near:.3g} from pick {near_i + 1} (slot {picks[near_i]}) "
                f"< min_distance {min_distance:g}",
                near_i,
                near,
            )
            continue
        reason = f"disagreement {sc:.4g} N (rank {len(picks) + 1})"
        if near is not None:
            reason += f"; nearest pick at {near:.3g} >= {min_distance:g}"
        out[j] = Verdict(rank, len(picks), "picked-far" if picks else "picked-top", reason, near_i, near)
        picks.append(j)
    return [v for v in out if v is not None]


def select_batch(
    scores: Sequence[float | None],
    features: Sequence[Sequence[float]],
    q: int,
    min_distance: float,
    threshold: float | None = None,
) -> list[Pick]:
    """At most ``q`` candidates to replay, in pick order (:func:`explain_selection`). Candidates
    are taken by descending score (ties: the lower slot); one is skipped if its Euclidean
    distance in ``features`` to a pick already made is below ``min_distance``. A candidate
    without a score (its OCP did not converge) is never picked, nor one with score 0 (its
    solution never touches the headrest). With ``threshold``: no pick at all when the highest
    score is below it (the uncertainty stopping rule). Fewer than q picks when too few candidates
    are in contact or far enough apart."""
    verdicts = explain_selection(scores, features, q, min_distance, threshold)
    picked = sorted((v.pick, j, v.reason) for j, v in enumerate(verdicts) if v.pick is not None)
    return [Pick(j, reason) for _, j, reason in picked]


__all__ = [
    "STRATEGIES",
    "EnsembleDisagreement",
    "Paper",
    "Pick",
    "RandomScenarios",
    "Strategy",
    "StrategyName",
    "Verdict",
    "VerdictCode",
    "explain_selection",
    "scenario_features",
    "select_batch",
    "strategy",
]
