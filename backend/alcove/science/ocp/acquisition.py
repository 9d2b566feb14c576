"""Acquisition strategies: which scenario(s) an active-learning iteration solves (issue 17).

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

Not yet (see docs/active-learning.md): ``ensemble-disagreement``, which needs candidate solves
and the ensemble's scores: it will propose C candidates and pick q of them from their scores.
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


def strategy(name: str) -> Strategy:
    """The strategy called ``name``; ValueError naming the known ones otherwise."""
    if name == "paper":
        return Paper()
    if name == "random-scenarios":
        return RandomScenarios()
    raise ValueError(f"strategy: unknown {name!r}; known: {', '.join(STRATEGIES)}")


__all__ = ["STRATEGIES", "Paper", "RandomScenarios", "Strategy", "StrategyName", "strategy"]
