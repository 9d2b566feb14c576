"""What a campaign step's compute gets (:mod:`alcove.campaigns.run.steps`): the campaign, the step's
reference, the config version it runs under, and its run (cancellation, faults, worker)."""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from alcove.campaigns.config import CampaignConfig
from alcove.campaigns.machine.state_machine import StepRef
from alcove.jobs.step_contract import StepRun
from alcove.models import Campaign
from alcove.science.ocp import acquisition
from alcove.science.ocp.scenarios import Scenario
from alcove.science.ocp.task_spec import TaskSpec
from alcove.tasks.service import load_task


@dataclass
class StepContext:
    campaign_id: int
    ref: StepRef
    config: CampaignConfig
    run: StepRun

    @property
    def k(self) -> int:
        return self.ref.iteration

    def before_compute(self) -> None:
        """Test processes only: the fault a test injected (a sleep, an error)."""
        self.run.before_compute(self.ref.step.value)

    def task(self, s: Session, c: Campaign) -> TaskSpec:
        """The task as written (its ranges, if any, left aside by the steps that use its preset:
        preliminary data, training and the validation suite are the nominal task's)."""
        return load_task(s, c.task_version_id, self.config.settings.ocp_intervals)

    def scenario(self, s: Session, c: Campaign) -> Scenario:
        """The scenario ocp slot ``ref.slot`` of iteration k solves under the campaign's strategy
        (seeded by the campaign seed, k and the slot: a re-run or re-delivered step draws the same one)."""
        return acquisition.strategy(self.config.settings.strategy).scenario(
            self.task(s, c), c.seed, self.k, self.ref.slot
        )
