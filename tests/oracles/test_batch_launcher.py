"""The batch launcher of command oracles: the catalogue's launcher fields (errors at the field),
the job script, and oracle calls as real Slurm jobs (``.ci/slurm-up``; skipped without Slurm,
a failure under CI): a call's result, and a call that attaches to the job an interrupted
earlier call left running instead of submitting again."""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from alcove.science.oracles.command import CatalogueError, CommandOracleSpec, load_command_catalogue
from alcove.science.oracles.command.batch import JOB_TIMES, MemoryBook, job_times, write_job_script
from alcove.science.oracles.command.launcher import LauncherSpec
from alcove.science.oracles.command.oracle import CommandOracle
from alcove.science.series import Trajectory
from tests.oracles.slurm import SOLVER, slurm_is_up


def trajectory(n: int = 41) -> Trajectory:
    t = np.linspace(0.0, 0.4, n)
    q = 0.2 * np.sin(np.pi * t / 0.4)
    return Trajectory(t=t, q=q[:, None], qd=np.gradient(q, t)[:, None])


@pytest.mark.parametrize(
    ("launcher", "field", "reason"),
    [
        ('{scheduler: slurm, partition: "a b"}', "launcher.partition", "no blanks or quotes"),
        ("{scheduler: slurm, cpus_per_task: 0}", "launcher.cpus_per_task", "greater than or equal to 1"),
        ("{scheduler: slurm, time_limit_s: -5}", "launcher.time_limit_s", "greater than 0"),
        ("{scheduler: local, partition: debug}", "launcher.partition", "only for a batch scheduler"),
        ("{scheduler: sge}", "launcher.scheduler", "'local', 'slurm', 'pbs' or 'lsf'"),
        ('{scheduler: slurm, directives: {qos: "a;b c"}}', "launcher.directives", "no blanks or quotes"),
        ('{scheduler: slurm, modules: ["x y"]}', "launcher.modules", "module 'x y'"),
        ('{scheduler: slurm, env: {"1X": v}}', "launcher.env", "environment variable name '1X'"),
        ("{scheduler: slurm, memory: 3}", "launcher.memory", "Extra inputs are not permitted"),
    ],
)
def test_launcher_fields_are_checked_with_the_field_named(tmp_path: Path, launcher: str, field: str, reason: str):
    path = tmp_path / "catalogue.yaml"
    path.write_text(f"command_oracles:\n  solver:\n    argv: [x]\n    launcher: {launcher}\n")
    with pytest.raises(CatalogueError) as err:
        load_command_catalogue(path)
    assert str(err.value).startswith(f"command_oracles.solver.{field}: "), str(err.value)
    assert reason in str(err.value)


def test_an_entry_without_launcher_runs_locally_and_a_slurm_entry_keeps_its_resources(tmp_path: Path):
    path = tmp_path / "catalogue.yaml"
    path.write_text(
        "command_oracles:\n"
        "  here: {argv: [x]}\n"
        "  there:\n"
        "    argv: [x]\n"
        "    launcher: {scheduler: slurm, partition: short, cpus_per_task: 4, memory_mb: 2000,\n"
        "               env: {SCRATCH: '{catalogue_dir}/scratch'}, directives: {qos: normal}}\n"
    )
    catalogue = load_command_catalogue(path)
    assert not catalogue["here"].launcher.is_batch
    there = catalogue["there"].launcher
    assert (there.scheduler, there.partition, there.cpus_per_task, there.memory_mb) == ("slurm", "short", 4, 2000)
    assert there.env == {"SCRATCH": f"{tmp_path.resolve()}/scratch"}


@pytest.mark.parametrize(
    ("scheduler", "expected", "submit"),
    [
        (
            "slurm",
            ["#SBATCH --cpus-per-task=8", "#SBATCH --ntasks=2", '#SBATCH --partition="short"', "#SBATCH --time=1:0:0"],
            ["sbatch", "--no-requeue"],
        ),
        (
            "pbs",
            ["#PBS -l select=1:ncpus=16:mpiprocs=2", "#PBS -q short", "#PBS -A crash-sim", "#PBS -l walltime=1:0:0"],
            ["qsub", "-r", "n"],
        ),
        ("lsf", ["#BSUB -n 16", '#BSUB -R "span[ptile=16]"', '#BSUB -q "short"', "#BSUB -W 1:0"], ["bsub", "-rn"]),
    ],
)
def test_each_scheduler_is_asked_for_the_launchers_cpus_per_process_and_no_rerun(
    tmp_path: Path, scheduler: str, expected: list[str], submit: list[str]
):
    """The submit script PSI/J's executor writes for an entry (no scheduler needed): 2 processes of
    8 CPUs each on one node are 16 CPUs on every scheduler (PSI/J's own PBS and LSF scripts ask for
    one CPU per process, which would pin a threaded solver to one core), and the job is submitted as
    not rerunnable, so a node failure fails the call instead of running the program again unseen."""
    import io

    from psij import Job

    from alcove.science.oracles.command.batch import _job_spec, executor_for

    launcher = LauncherSpec(
        scheduler=scheduler, partition="short", account="crash-sim", time_limit_s=3600, tasks=2, cpus_per_task=8
    )
    executor = executor_for(launcher, tmp_path / f"{scheduler}-scripts")
    job = Job(_job_spec(tmp_path, tmp_path / "job.sh", launcher, 3600, "alcove-render"))
    script = io.StringIO()
    executor.generate_submit_script(job, executor._create_script_context(job), script)
    lines = script.getvalue().splitlines()
    for line in expected:
        assert any(x.startswith(line) for x in lines), f"{line!r} not in:\n{script.getvalue()}"
    assert executor.get_submit_command(job, tmp_path / "x.job")[:-1] == submit


def test_the_job_script_quotes_every_value_and_records_start_end_and_exit_code(tmp_path: Path):
    launcher = LauncherSpec(scheduler="slurm", cpus_per_task=3, env={"NOTE": "a b; $(rm -rf /)"})
    argv = [sys.executable, "-c", "import os; print(os.environ['NOTE'], os.environ['ALCOVE_JOB_CPUS']); exit(4)"]
    script = write_job_script(tmp_path, argv, {"NOTE": "a b; $(rm -rf /)"}, launcher)
    assert f"export NOTE={shlex.quote('a b; $(rm -rf /)')}" in script.read_text()
    done = subprocess.run(["/bin/bash", str(script)], capture_output=True)
    assert done.returncode == 4
    assert (tmp_path / "stdout.log").read_text() == "a b; $(rm -rf /) 3\n"
    started, ended, code = job_times(tmp_path)
    assert started is not None and ended is not None and started <= ended and code == 4
    assert (tmp_path / JOB_TIMES).exists()


@pytest.fixture
def slurm_spec(tmp_path: Path) -> CommandOracleSpec:
    why = slurm_is_up()
    if why is not None:
        pytest.skip(why)
    return CommandOracleSpec(
        name="sleepy",
        argv=[sys.executable, str(SOLVER), "1"],
        timeout_s=60,
        workdir_root=tmp_path / "jobs",
        launcher=LauncherSpec(scheduler="slurm", poll_s=0.2, env={"SLEEPY_RUN_LOG": str(tmp_path / "runs.log")}),
    )


def test_an_oracle_call_runs_as_a_slurm_job(slurm_spec: CommandOracleSpec, tmp_path: Path):
    book = MemoryBook()
    result = CommandOracle(slurm_spec).run(trajectory(), batch_book=book)
    assert result.ok, result.failure_reason
    assert result.forces is not None and np.all(result.forces.wrench == 0.0)
    job = result.diagnostics["batch_job"]
    assert (job["scheduler"], job["state"], job["exit_code"]) == ("slurm", "completed", 0)
    assert job["submitted_at"] <= job["started_at"] <= job["ended_at"]
    assert [j.job_id for j in book.jobs] == [job["job_id"]]
    assert (tmp_path / "runs.log").read_text().split()[0] == job["job_id"]  # SLURM_JOB_ID of the program


class WorkerGone(BaseException):
    """Stands for a worker that stops while its job runs (the job runs on in Slurm)."""


def test_a_call_attaches_to_the_job_an_interrupted_call_left_running(slurm_spec: CommandOracleSpec, tmp_path: Path):
    book = MemoryBook()
    oracle = CommandOracle(slurm_spec)

    def gone_once_running() -> bool:
        if book.jobs and book.jobs[-1].state == "running":
            raise WorkerGone
        return False

    with pytest.raises(WorkerGone):
        oracle.run(trajectory(), cancel=gone_once_running, batch_book=book)
    assert [j.state for j in book.jobs] == ["running"]
    result = oracle.run(trajectory(), batch_book=book)
    assert result.ok, result.failure_reason
    assert [(j.job_id, j.state) for j in book.jobs] == [(result.diagnostics["batch_job"]["job_id"], "completed")]
    assert len((tmp_path / "runs.log").read_text().splitlines()) == 1  # the program ran once


def test_the_3d_ccx_oracle_runs_as_a_slurm_job_with_the_jobs_cpus_as_threads(tmp_path: Path):
    """fe-headrest-3d-ccx with a Slurm launcher (the catalogue's ``launchers`` section): alcove's
    driver runs as the job and takes its thread count from the job's CPUs. A motion that never
    reaches the cushion needs no ccx (zero force), so this runs where ccx is not installed."""
    why = slurm_is_up()
    if why is not None:
        pytest.skip(why)
    from alcove.science.oracles.command.catalogue import load_builtin_launchers
    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle, CcxHeadrestParams
    from tests.science.oracles.test_ccx_oracle import COARSE, short_motion

    path = tmp_path / "catalogue.yaml"
    path.write_text(
        "command_oracles: {}\n"
        "launchers:\n"
        f"  fe-headrest-3d-ccx: {{scheduler: slurm, cpus_per_task: 2, poll_s: 0.2, job_root: '{tmp_path}'}}\n"
    )
    launcher = load_builtin_launchers(path)["fe-headrest-3d-ccx"]
    oracle = CcxHeadrestOracle(CcxHeadrestParams(**COARSE), launcher=launcher)
    book = MemoryBook()
    result = oracle.run(short_motion(0.10, 0.20), batch_book=book)
    assert result.ok, result.failure_reason
    assert result.forces is not None and np.all(result.forces.wrench == 0.0)
    assert result.diagnostics["batch_job"]["state"] == "completed" and len(book.jobs) == 1
    assert result.diagnostics["solver"]["threads"] == 2


def test_a_launcher_for_a_type_that_runs_no_program_is_refused(tmp_path: Path):
    from alcove.science.oracles.command.catalogue import load_builtin_launchers

    path = tmp_path / "catalogue.yaml"
    path.write_text("command_oracles: {}\nlaunchers:\n  aux-penalty: {scheduler: slurm}\n")
    with pytest.raises(CatalogueError, match=r"^launchers.aux-penalty: not a built-in type that runs a program"):
        load_builtin_launchers(path)
    path.write_text("command_oracles: {}\nlaunchers:\n  fe-headrest-3d-ccx: {scheduler: slurm, nodes: 0}\n")
    with pytest.raises(CatalogueError, match=r"^launchers.fe-headrest-3d-ccx.nodes: "):
        load_builtin_launchers(path)


def test_a_submission_answer_without_a_job_id_is_a_failure_naming_it(slurm_spec: CommandOracleSpec, monkeypatch):
    """The scheduler's output is checked: an sbatch that answers without a job id fails the call
    with that answer named, instead of following a job that does not exist."""
    from alcove.science.oracles.command import batch

    executor = batch.executor_for(slurm_spec.launcher, slurm_spec.workdir_root / ".alcove-psij")  # type: ignore[operator]
    monkeypatch.setattr(executor, "job_id_from_submit_output", lambda out: "sbatch: error: try again later")
    with pytest.raises(batch.SchedulerFailure, match=r"holds no job id: 'sbatch: error: try again later'"):
        CommandOracle(slurm_spec).run(trajectory(), batch_book=MemoryBook())


def test_a_job_killed_over_its_memory_limit_fails_its_call_naming_the_limit(slurm_spec: CommandOracleSpec):
    """The program holds 300 MB in a job that asked for 50 MB: Slurm kills it (OverMemoryKill,
    .ci/slurm-up) and the call fails naming the memory limit, not as a missing output."""
    from alcove.science.oracles.command.batch import SchedulerFailure

    spec = slurm_spec.model_copy(
        update={
            "argv": [*slurm_spec.argv[:2], "20", "hog:300"],
            "launcher": slurm_spec.launcher.model_copy(update={"memory_mb": 50}),
        }
    )
    book = MemoryBook()
    with pytest.raises(SchedulerFailure, match=r"^slurm job \d+: the scheduler ended the job: "):
        CommandOracle(spec).run(trajectory(), batch_book=book)
    assert [j.state for j in book.jobs] == ["failed"]
    assert "over its memory limit of 50 MB" in str(book.jobs[0].reason)
