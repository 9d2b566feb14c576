"""Fault injection for tests: slow, failing or quarantined steps on demand.

Not part of any public interface. A process honours a fault plan only when it was started
with ``ALCOVE_TESTING=true`` and ``ALCOVE_FAULT_PLAN=<file>``; a process given a fault plan
without the testing setting refuses to start (see :class:`alcove.settings.Settings`). The
plan is a JSON file that tests write and workers re-read when it changes::

    {"campaigns": {"12": {"train": {"sleep_s": 2, "iterations": [2]},
                          "oracle": {"raise_attempts": 99}},
                   "*": {"ocp": {"ipopt_max_iter": 1, "iterations": [1]}}}}

(``"*"``: every campaign without an entry of its own.)
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from alcove.settings import get_settings


class StepFault(BaseModel):
    """What goes wrong in one step of one campaign (in the iterations listed, or all)."""

    model_config = ConfigDict(extra="forbid")

    sleep_s: float = Field(0.0, ge=0, le=600, description="sleep this long before computing (cancellable)")
    sleep_attempts: int | None = Field(
        None, ge=1, description="sleep only in attempts up to this number (default: every attempt)"
    )
    raise_attempts: int = Field(0, ge=0, description="attempts up to this number raise an error")
    ipopt_max_iter: int | None = Field(None, ge=0, description="ocp: IPOPT's iteration limit (1: does not converge)")
    gate_fail: bool = Field(False, description="oracle: the quality gate quarantines the result")
    iterations: list[int] | None = Field(None, description="only these iterations (default: all)")
    slots: list[int] | None = Field(None, description="only these slots of a fanned-out step (default: all)")


class FaultPlan(BaseModel):
    model_config = ConfigDict(extra="forbid")

    campaigns: dict[str, dict[str, StepFault]] = Field(
        default_factory=dict, description='campaign id (or "*": any other campaign) -> step name -> fault'
    )


class _PlanFile:
    """The plan file, re-read when its modification time changes."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._key: tuple[str, int, int, int] | None = None
        self._plan = FaultPlan()

    def read(self, path: Path) -> FaultPlan:
        try:
            st = path.stat()
            key = (str(path), st.st_mtime_ns, st.st_ino, st.st_size)
        except FileNotFoundError:
            return FaultPlan()
        with self._lock:
            if key != self._key:
                self._plan = FaultPlan.model_validate(json.loads(path.read_text() or "{}"))
                self._key = key
            return self._plan


_PLAN = _PlanFile()


def fault_for(campaign_id: int, step: str, iteration: int, slot: int = 0) -> StepFault | None:
    """The fault a test injected into this step, or None (always None outside tests)."""
    settings = get_settings()
    if not settings.testing or settings.fault_plan is None:
        return None
    plan = _PLAN.read(settings.fault_plan).campaigns
    fault = plan.get(str(campaign_id), plan.get("*", {})).get(step)
    if fault is None or (fault.iterations is not None and iteration not in fault.iterations):
        return None
    if fault.slots is not None and slot not in fault.slots:
        return None
    return fault


def inject(campaign: int | str, steps: dict[str, dict[str, Any]] | None) -> None:
    """Set (or with None remove) the faults of one campaign in this test process's plan file,
    which the process and its workers read (tests only)."""
    settings = get_settings()
    if not settings.testing or settings.fault_plan is None:
        raise RuntimeError("fault injection needs ALCOVE_TESTING=true and ALCOVE_FAULT_PLAN (test processes only)")
    path = settings.fault_plan
    plan = _PLAN.read(path).model_dump(exclude_defaults=True)
    campaigns = dict(plan.get("campaigns", {}))
    if steps is None:
        campaigns.pop(str(campaign), None)
    else:
        campaigns[str(campaign)] = steps
    new = FaultPlan.model_validate({"campaigns": campaigns})
    tmp = path.with_suffix(".tmp")
    tmp.write_text(new.model_dump_json(exclude_defaults=True))
    tmp.replace(path)
