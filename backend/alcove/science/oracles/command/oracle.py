"""``CommandOracle``: runs one catalogue entry on a trajectory.

One run: render the deck (if the entry or the user gives a template), write the inputs of
the file contract into a fresh working directory, run the command, read its forces and
pass them through the quality gate. A non-zero exit code, a timeout, a missing, malformed
or too short output give ``OracleResult(ok=False)`` naming what failed; the working
directory is then kept and its path is in the diagnostics.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, ClassVar

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, kinematics_from_pose
from alcove.science.oracles.base import (
    SUMMARY_DIAGNOSTICS,
    CancelCheck,
    OracleCancelled,
    OracleInputError,
    OracleParams,
    OracleResult,
    posed_trajectory,
)
from alcove.science.oracles.command.batch import BatchJobBook, MemoryBook, job_root, run_batch_job
from alcove.science.oracles.command.contract import (
    CONTRACT_VARIABLES,
    STDERR_FILE,
    STDOUT_FILE,
    OutputError,
    read_forces,
    read_solver_diagnostics,
    run_environment,
    write_inputs,
)
from alcove.science.oracles.command.gate import forces_within_trajectory
from alcove.science.oracles.command.process import ProcessOutcome, run_process, tail
from alcove.science.oracles.command.spec import CommandOracleSpec, params_model
from alcove.science.oracles.command.template import render_template, template_values
from alcove.science.series import Trajectory


class CommandOracle:
    """Runs one catalogue entry on a trajectory (type name: the entry's name)."""

    type_name: ClassVar[str] = "command"

    def __init__(
        self,
        spec: CommandOracleSpec,
        params: OracleParams | None = None,
        preset: HeadNeckPreset = DEFAULT_PRESET,
    ):
        model = params_model(spec)
        self.spec = spec
        self.params = model.model_validate(params.model_dump() if params is not None else {})
        self.preset = preset
        if self.params.template is not None and not spec.allow_user_template:
            raise OracleInputError(
                "params.template", f"the command oracle '{spec.name}' does not accept user templates"
            )

    def run(
        self, trajectory: Trajectory, cancel: CancelCheck | None = None, batch_book: BatchJobBook | None = None
    ) -> OracleResult:
        """Run the entry on ``trajectory``. With a batch launcher the call is one batch job,
        kept in ``batch_book``: a job an earlier attempt submitted that the book still holds
        is attached to, not submitted again."""
        start = time.perf_counter()
        trajectory = posed_trajectory(trajectory, self.preset)
        deck = self._rendered_deck(trajectory)
        extra = self._extra_inputs(trajectory)
        if cancel is not None and cancel():
            raise OracleCancelled(f"command oracle '{self.spec.name}' cancelled before it started")
        book = batch_book if batch_book is not None else MemoryBook()
        earlier = book.earlier() if self.spec.launcher.is_batch else None
        if earlier is not None and Path(earlier.workdir).is_dir():
            workdir = Path(earlier.workdir)  # staged by the attempt that submitted the job
        else:
            earlier = None
            workdir = self._make_workdir()
            parameters = {
                "dt_out": self.params.dt_out,
                **{key: getattr(self.params, key) for key in self.spec.parameters},
            }
            write_inputs(workdir, trajectory, parameters, deck, self.spec.rendered_file_name)
            for name, text in extra.items():
                (workdir / name).write_text(text)
        diagnostics: dict[str, Any] = {"command": self.spec.name, **dict.fromkeys(SUMMARY_DIAGNOSTICS)}

        def failed(reason: str) -> OracleResult:
            diagnostics["workdir"] = str(workdir)
            diagnostics["stderr_tail"] = tail(workdir / STDERR_FILE)
            return OracleResult(
                False,
                None,
                None,
                diagnostics,
                time.perf_counter() - start,
                f"command oracle '{self.spec.name}': {reason}",
            )

        cancelled_message = f"command oracle '{self.spec.name}' cancelled (working directory {workdir})"
        if self.spec.launcher.is_batch:
            outcome = self._run_batch(workdir, book, earlier, cancel, cancelled_message, diagnostics)
        else:
            outcome = run_process(
                self.spec.argv,
                workdir,
                run_environment(workdir, self.spec.rendered_file_name, self.spec.output_file, self.spec.env),
                self.spec.timeout_s,
                workdir / STDOUT_FILE,
                workdir / STDERR_FILE,
                cancel,
                cancelled_message=cancelled_message,
            )
        diagnostics["exit_code"] = outcome.exit_code
        if outcome.failure is not None:
            return failed(outcome.failure)
        try:
            gate = forces_within_trajectory(
                read_forces(workdir, self.spec.output_file), trajectory, self.spec.output_file
            )
            diagnostics.update(read_solver_diagnostics(workdir))
        except OutputError as exc:
            return failed(f"output: {exc}")
        if gate.forces is None:
            return failed(f"output: {gate.failure}")
        forces = gate.forces
        sampled = trajectory.resample(forces.t.clip(trajectory.t[0], trajectory.t[-1]))
        assert sampled.pose is not None
        kinematics = kinematics_from_pose(sampled.pose)
        if self.params.keep_workdir:
            diagnostics["workdir"] = str(workdir)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
        return OracleResult(True, forces, kinematics, diagnostics, time.perf_counter() - start)

    @property
    def runs_as_batch_jobs(self) -> bool:
        return self.spec.launcher.is_batch

    def _run_batch(
        self,
        workdir: Path,
        book: BatchJobBook,
        earlier: Any,
        cancel: CancelCheck | None,
        cancelled_message: str,
        diagnostics: dict[str, Any],
    ) -> ProcessOutcome:
        """The program as one batch job (submitted, or the earlier attempt's attached to)."""
        launcher = self.spec.launcher
        contract_env = run_environment(workdir, self.spec.rendered_file_name, self.spec.output_file, {})
        env = {k: v for k, v in contract_env.items() if k in CONTRACT_VARIABLES}
        env.update(self.spec.env)
        env.update(launcher.env)
        outcome, job = run_batch_job(
            launcher=launcher,
            workdir=workdir,
            argv=self.spec.argv,
            env=env,
            time_limit_s=launcher.time_limit_s or self.spec.timeout_s,
            name=f"alcove-{self.spec.name}",
            script_dir=job_root(launcher, self.spec.workdir_root) / ".alcove-psij",
            book=book,
            attach_to=earlier,
            cancel=cancel,
            cancelled_message=cancelled_message,
        )
        diagnostics["batch_job"] = job.as_dict()
        return outcome

    def _rendered_deck(self, trajectory: Trajectory) -> str | None:
        text = self.params.template
        if text is None and self.spec.template is not None:
            text = self.spec.template.read_text()
        if text is None:
            return None
        return render_template(text, template_values(trajectory, self.preset, self.params, self.spec))

    def _extra_inputs(self, trajectory: Trajectory) -> dict[str, str]:
        """Further input files (name -> text) a built-in oracle on this machinery writes; none here."""
        return {}

    def _make_workdir(self) -> Path:
        root = (
            job_root(self.spec.launcher, self.spec.workdir_root)
            if self.spec.launcher.is_batch
            else self.spec.workdir_root
        )
        if root is not None:
            root.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f"alcove-{self.spec.name}-", dir=root))


__all__ = ["CommandOracle"]
