"""What a domain's step function and the campaign's job protocol share.

A campaign step (train, ocp, oracle, ...) is computed by its domain (``surrogates``,
``solving``, ``oracles``, ``pool``) in one entry point that takes a :class:`StepRun` and
plain inputs, computes outside any transaction, and returns a :class:`StepOutput` whose
``write`` stores the domain's rows in the transaction that completes the step. The
protocol (``alcove.campaigns.run.protocol``) claims, calls, completes and enqueues the next step;
a domain never imports it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy.orm import Session

from alcove.jobs.faults import StepFault


@dataclass(frozen=True)
class IterationRef:
    """The iteration a step's rows belong to."""

    campaign_id: int
    iteration_id: int
    index: int
    slot: int = 0  # which of the iteration's parallel jobs of the step (ocp: candidate, oracle: pick)


#: Stores a step's results (in the completing transaction); returns what the step row records.
WriteRows = Callable[[Session, IterationRef], dict[str, Any]]


@dataclass
class StepOutput:
    write: WriteRows
    compute_s: float = 0.0


class StepCancelled(RuntimeError):
    """The campaign's cancel flag was seen during the step."""


class StepPaused(RuntimeError):
    """The campaign is pausing and the step gave its work back (an oracle call's batch job,
    cancelled rather than left queued or running for the whole pause): the step waits, pending,
    for the resume, which runs it again."""


class UnusableResult(RuntimeError):
    """The step ran but its result cannot be used (an OCP that did not converge, an oracle
    result the quality gate quarantined): not retried; the campaign's on-failure policy
    decides. ``write`` records what happened."""

    def __init__(self, reason: str, write: WriteRows | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.write = write


class FailedAttempt(RuntimeError):
    """An exception of the step's computation, with the rows its attempt leaves (an oracle
    run marked failed). Retried like any exception."""

    def __init__(self, cause: BaseException, write: WriteRows) -> None:
        super().__init__(f"{type(cause).__name__}: {cause}")
        self.cause = cause
        self.write = write


@dataclass
class StepRun:
    """What a step function gets besides its inputs: which attempt this is, on which worker,
    the cooperative cancel flag (check it between epochs, Newton steps, ...), in a test
    process only the fault a test injected (:mod:`alcove.jobs.faults`), and whether the campaign
    is pausing (work that would wait through the pause, a queued batch job, gives itself back)."""

    attempt: int = 1
    worker: str = "local"
    cancel_flag: Callable[[], bool] = field(default=lambda: False)
    fault: StepFault | None = None
    pause_flag: Callable[[], bool] = field(default=lambda: False)

    def cancelled(self) -> bool:
        return self.cancel_flag()

    def pausing(self) -> bool:
        return self.pause_flag()

    def check_cancel(self) -> None:
        if self.cancel_flag():
            raise StepCancelled("step cancelled")

    def before_compute(self, step: str) -> None:
        """Test processes only: the injected fault's (cancellable) sleep and error."""
        fault = self.fault
        if fault is None:
            return
        sleeps = fault.sleep_attempts is None or self.attempt <= fault.sleep_attempts
        end = time.monotonic() + (fault.sleep_s if sleeps else 0.0)
        while time.monotonic() < end:
            self.check_cancel()
            time.sleep(0.05)
        if self.attempt <= fault.raise_attempts:
            raise RuntimeError(f"fault injection: {step} raises on attempt {self.attempt}")


def is_bad_input(err: BaseException) -> bool:
    """Errors that name a field (the science modules' input errors) will not go away on retry."""
    return isinstance(err, ValueError) and hasattr(err, "field")


def is_cancellation(err: BaseException) -> bool:
    """A cancellation raised by science code (which cannot import this module)."""
    return isinstance(err, StepCancelled) or type(err).__name__ in ("OracleCancelled", "TrainingCancelled")
