"""Acquisition strategies: which scenario(s) an active-learning iteration solves (issue 17).

A strategy maps ``(task, campaign seed, iteration k, batch size q)`` to the q scenarios the
iteration's OCP solves with the current surrogate; the oracle then replays each solved
trajectory. Everything is seeded by the campaign seed and k, so a step re-run by another worker
(or a re-delivered job) solves the same scenario.

Implemented (q = 1):

* ``paper``: the nominal task every iteration, no exploration (the paper's loop, exactly).
* ``random-scenarios``: scenario ``(seed, k, slot)`` drawn uniformly from the task's ranges
  (:func:`alcove.science.ocp.scenarios.draw`); a task without ranges gives the nominal task.

Not yet (see docs/active-learning.md): q > 1 (the slots are already in the seed stream) and
``ensemble-disagreement``, which needs candidate solves and the ensemble's scores: it will
propose C candidates with :meth:`Strategy.candidates` and pick q of them from their scores.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Protocol

from alcove.science.ocp.scenarios import Scenario, draw, nominal

if TYPE_CHECKING:
    from alcove.science.ocp.task_spec import TaskSpec

StrategyName = Literal["paper", "random-scenarios"]
STRATEGIES: tuple[StrategyName, ...] = ("paper", "random-scenarios")


class Strategy(Protocol):
    @property
    def name(self) -> StrategyName: ...

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        """The scenarios iteration ``iteration`` of a campaign with ``seed`` solves (``q`` of them)."""
        ...


@dataclass(frozen=True)
class Paper:
    """The nominal task, every iteration (ranges ignored)."""

    name: StrategyName = "paper"

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        _check_batch(q)
        return [Scenario(task=nominal(task))]


@dataclass(frozen=True)
class RandomScenarios:
    """q scenarios drawn uniformly from the task's ranges, seeded by (seed, iteration, slot)."""

    name: StrategyName = "random-scenarios"

    def candidates(self, task: TaskSpec, seed: int, iteration: int, q: int) -> list[Scenario]:
        _check_batch(q)
        return [draw(task, seed, iteration, slot) for slot in range(q)]


def _check_batch(q: int) -> None:
    if q != 1:  # the campaign's fan-out to q oracle jobs is the next increment
        raise ValueError(f"batch size q = {q}: only q = 1 is implemented")


def strategy(name: str) -> Strategy:
    """The strategy called ``name``; ValueError naming the known ones otherwise."""
    if name == "paper":
        return Paper()
    if name == "random-scenarios":
        return RandomScenarios()
    raise ValueError(f"strategy: unknown {name!r}; known: {', '.join(STRATEGIES)}")


__all__ = ["STRATEGIES", "Paper", "RandomScenarios", "Strategy", "StrategyName", "strategy"]
