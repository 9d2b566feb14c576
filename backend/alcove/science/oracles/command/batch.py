"""One oracle call as a batch-scheduler job: submit, wait without computing, re-attach, cancel.

The submission and the polling of the scheduler are PSI/J's (``psij-python``: one interface
to Slurm, PBS and LSF, attaching to a job by its scheduler id, cancelling). alcove writes a
small job script into the job folder (:func:`write_job_script`: the entry's environment and
modules, then the program, recording when it started and ended) and PSI/J submits it with
the entry's resources.

The caller keeps a :class:`BatchJobBook` of the jobs it submitted (the campaign stores it
with the oracle step): a job the book still holds as queued, running or completed is attached
to instead of submitted again, so a worker restarted while its jobs run finds them.

Outcomes: the program's own exit code is handled like a local run's (the caller reads the
outputs or reports the exit code); a job the scheduler ended (time limit, memory, node
failure, preemption, cancelled outside alcove) raises :class:`SchedulerFailure` naming the
reason, which a campaign retries per its oracle policy.
"""

from __future__ import annotations

import contextlib
import re
import shlex
import tempfile
import threading
import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from datetime import timedelta
from pathlib import Path
from typing import Any, Protocol

from alcove.science.oracles.base import CancelCheck, OracleCancelled
from alcove.science.oracles.command.contract import STDERR_FILE, STDOUT_FILE
from alcove.science.oracles.command.launcher import LauncherSpec
from alcove.science.oracles.command.process import ProcessOutcome, tail

JOB_SCRIPT = "alcove-job.sh"
JOB_TIMES = "alcove-job-times.txt"
#: consecutive failed polls of the scheduler (squeue, qstat, bjobs) after which the call fails
#: (its job is kept in the book: the next attempt attaches to it again)
POLL_ERROR_LIMIT = 30
#: a scheduler's job id as the submission command prints it (Slurm 4711 or 4711_3, PBS 4711.server)
JOB_ID = re.compile(r"^[A-Za-z0-9_.\-\[\]@]{1,64}$")
SLURM_JOB_ID = re.compile(r"^\d+(_\d+)?$")
WAIT_SECONDS = 0.25  # how often a waiting call looks at its cancel flag (a status change wakes it at once)


@dataclass
class BatchJob:
    """A batch job of one oracle call as the book records it. ``state``: ``queued``, ``running``,
    ``completed`` (ended, outputs not yet collected), ``failed``, ``cancelled``; times are Unix
    seconds (submitted: when alcove submitted it; started and ended: the job's own clock)."""

    scheduler: str
    job_id: str
    workdir: str
    state: str = "queued"
    reason: str | None = None
    submitted_at: float | None = None
    started_at: float | None = None
    ended_at: float | None = None
    exit_code: int | None = None

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


class BatchJobBook(Protocol):
    """Where the caller keeps an oracle call's batch jobs (the campaign: with its oracle step)."""

    def earlier(self) -> BatchJob | None:
        """A job an earlier attempt of this call submitted that may still give its result
        (queued, running or completed), else None."""

    def record(self, job: BatchJob) -> None:
        """Store the job's current state (called at submission and at every change)."""


@dataclass
class MemoryBook:
    """A book kept in memory (one process: the command line, the tests)."""

    jobs: list[BatchJob] = field(default_factory=list)

    def earlier(self) -> BatchJob | None:
        live = [j for j in self.jobs if j.state in ("queued", "running", "completed")]
        return live[-1] if live else None

    def record(self, job: BatchJob) -> None:
        if job not in self.jobs:
            self.jobs.append(job)


class SchedulerFailure(RuntimeError):
    """The scheduler ended the job or could not be asked about it; the message names why."""


# ----------------------------------------------------------------------------- scheduler states

#: Slurm's compact job states that end a job for a reason of the scheduler (not the program)
SLURM_ENDED_BY_SCHEDULER = {
    "TO": "the scheduler killed the job at its time limit",
    "OOM": "the job ran out of memory and was killed",
    "NF": "a node of the job failed",
    "BF": "the job's node failed to start it",
    "PR": "the job was preempted",
    "DL": "the job missed its deadline",
    "RV": "the job was revoked",
    "CA": "the job was cancelled outside alcove",
}


def psij_version() -> Any:
    from packaging.version import Version
    from psij.version import VERSION

    return Version(VERSION)


def _slurm_executor_class() -> Any:
    from psij import JobState, JobStatus
    from psij.executors.batch.batch_scheduler_executor import check_status_exit_code
    from psij.executors.batch.slurm import SlurmJobExecutor

    class SlurmExecutor(SlurmJobExecutor):
        """PSI/J's Slurm executor, with the scheduler's own state code kept in the status
        (``metadata["native_state"]``: TO, OOM, NF, ...) and tolerant of states and reasons
        PSI/J does not list."""

        _NAME_ = "slurm"
        _VERSION_ = psij_version()

        def parse_status_output(self, exit_code: int, out: str) -> dict[str, Any]:
            check_status_exit_code("squeue", exit_code, out)
            statuses: dict[str, Any] = {}
            for line in out.splitlines()[1:]:
                cols = line.split()
                if len(cols) < 2:
                    continue
                native_id, code = cols[0], cols[1]
                reason = cols[2] if len(cols) > 2 else ""
                state = SlurmJobExecutor._STATE_MAP.get(code, JobState.ACTIVE)
                message = SLURM_ENDED_BY_SCHEDULER.get(code) if state.final else None
                if state == JobState.FAILED and message is None:
                    message = SlurmJobExecutor._REASONS_MAP.get(reason, reason or None)
                statuses[native_id] = JobStatus(
                    state, message=message, metadata={"native_state": code, "native_reason": reason}
                )
            return statuses

        def get_submit_command(self, job: Any, submit_file_path: Path) -> list[str]:
            # a job whose node fails is not requeued by Slurm (by default it would run again
            # later in the same folder, unseen by alcove): it ends as NF, its call fails naming
            # the node failure, and the oracle's retry policy decides (a new job, a new folder)
            return ["sbatch", "--no-requeue", str(submit_file_path.absolute())]

        def get_status_command(self, native_ids: Collection[str]) -> list[str]:
            ids = [i for i in native_ids if SLURM_JOB_ID.match(i)]  # one bad id would fail the query for all
            return ["squeue", "-O", "JobArrayID,StateCompact,Reason", "-t", "all"] + (
                ["-j", ",".join(ids)] if ids else ["--me"]
            )

    return SlurmExecutor


#: PBS Pro's chunk line as PSI/J writes it: one CPU per MPI process
PBS_SELECT = re.compile(r"^(#PBS -l select=\d+):ncpus=(\d+):mpiprocs=(\d+)", re.MULTILINE)
#: LSF's slot count as PSI/J writes it: one slot per process
LSF_SLOTS = re.compile(r"^#BSUB -n (\d+)$", re.MULTILINE)


def _cores(job: Any) -> int:
    resources = job.spec.resources if job.spec is not None else None
    return int(getattr(resources, "cpu_cores_per_process", None) or 1)


def _pbs_executor_class() -> Any:
    import io

    from psij.executors.batch.pbs import PBSJobExecutor

    class PBSExecutor(PBSJobExecutor):
        """PSI/J's PBS Pro executor, asking for the launcher's CPUs per process: PSI/J's chunk
        has ``ncpus`` = processes per node (a threaded solver would get one core), here it is
        processes per node x ``cpus_per_task``; and jobs are not rerunnable (``-r n``: a job
        whose node fails fails its call, and the oracle's retry policy decides)."""

        _NAME_ = "pbs"
        _VERSION_ = psij_version()

        def generate_submit_script(self, job: Any, context: dict[str, object], submit_file: Any) -> None:
            buffer = io.StringIO()
            super().generate_submit_script(job, context, buffer)
            cores = _cores(job)

            def chunk(m: re.Match[str]) -> str:
                return f"{m.group(1)}:ncpus={int(m.group(3)) * cores}:mpiprocs={m.group(3)}"

            submit_file.write(PBS_SELECT.sub(chunk, buffer.getvalue()))

        def get_submit_command(self, job: Any, submit_file_path: Path) -> list[str]:
            return ["qsub", "-r", "n", str(submit_file_path.absolute())]

    return PBSExecutor


def _lsf_executor_class() -> Any:
    import io

    from psij.executors.batch.lsf import LsfJobExecutor

    class LsfExecutor(LsfJobExecutor):
        """PSI/J's LSF executor, asking for the launcher's CPUs per process: PSI/J's ``-n`` is
        one slot per process, here processes x ``cpus_per_task`` slots, each process's slots on
        one host (``span[ptile=...]``); and jobs are not rerunnable (``-rn``)."""

        _NAME_ = "lsf"
        _VERSION_ = psij_version()

        def generate_submit_script(self, job: Any, context: dict[str, object], submit_file: Any) -> None:
            buffer = io.StringIO()
            super().generate_submit_script(job, context, buffer)
            cores = _cores(job)
            text = buffer.getvalue()
            if cores > 1:
                resources = job.spec.resources
                per_node = max(1, int(resources.computed_processes_per_node or 1))

                def slots(m: re.Match[str]) -> str:
                    return f'#BSUB -n {int(m.group(1)) * cores}\n#BSUB -R "span[ptile={per_node * cores}]"'

                text = LSF_SLOTS.sub(slots, text)
            submit_file.write(text)

        def get_submit_command(self, job: Any, submit_file_path: Path) -> list[str]:
            return ["bsub", "-rn", str(submit_file_path.absolute())]

    return LsfExecutor


_executors: dict[tuple[str, float, str], Any] = {}
_executors_lock = threading.Lock()


def executor_for(launcher: LauncherSpec, script_dir: Path) -> Any:
    """The PSI/J executor of this process for a scheduler (one queue-polling thread each)."""
    key = (launcher.scheduler, launcher.poll_s, str(script_dir))
    with _executors_lock:
        executor = _executors.get(key)
        if executor is None:
            from psij.executors.batch.batch_scheduler_executor import BatchSchedulerExecutorConfig

            config = BatchSchedulerExecutorConfig(
                work_directory=script_dir,
                queue_polling_interval=launcher.poll_s,  # type: ignore[arg-type]
                initial_queue_polling_delay=min(launcher.poll_s, 1.0),  # type: ignore[arg-type]
                queue_polling_error_threshold=POLL_ERROR_LIMIT,
            )
            classes = {"slurm": _slurm_executor_class, "pbs": _pbs_executor_class, "lsf": _lsf_executor_class}
            executor = classes[launcher.scheduler]()(url=None, config=config)
            _executors[key] = executor
    return executor


# ----------------------------------------------------------------------------- the job


def job_root(launcher: LauncherSpec, workdir_root: Path | None) -> Path:
    """Where job folders are made: a folder the compute nodes see."""
    return launcher.job_root or workdir_root or Path(tempfile.gettempdir())


def write_job_script(workdir: Path, argv: Sequence[str], env: Mapping[str, str], launcher: LauncherSpec) -> Path:
    """The script a batch job runs: into the job folder, the entry's environment and modules,
    the program (its output to ``stdout.log`` and ``stderr.log``), its start and end times and
    exit code in :data:`JOB_TIMES`; exits with the program's code. Every value is quoted."""
    lines = [
        "#!/bin/bash",
        "# the batch job of one alcove oracle call: runs the command oracle's program in this folder",
        f"cd {shlex.quote(str(workdir))} || exit 111",
        f'printf "started %s\\n" "$(date +%s.%N)" >> {JOB_TIMES}',
    ]
    threads = str(launcher.cpus_per_task)
    lines += [f"export ALCOVE_JOB_CPUS={threads}", f"export OMP_NUM_THREADS=${{OMP_NUM_THREADS:-{threads}}}"]
    lines += [f"export {name}={shlex.quote(value)}" for name, value in env.items()]
    lines += [f"module load {shlex.quote(name)} || exit 112" for name in launcher.modules]
    lines += [
        " ".join(shlex.quote(a) for a in argv) + f" > {STDOUT_FILE} 2> {STDERR_FILE} < /dev/null",
        "code=$?",
        f'printf "ended %s %s\\n" "$(date +%s.%N)" "$code" >> {JOB_TIMES}',
        'exit "$code"',
    ]
    path = workdir / JOB_SCRIPT
    path.write_text("\n".join(lines) + "\n")
    path.chmod(0o755)
    return path


def job_times(workdir: Path) -> tuple[float | None, float | None, int | None]:
    """When the job's program started and ended (its own clock) and its exit code, as far as known."""
    started = ended = code = None
    try:
        text = (workdir / JOB_TIMES).read_text()
    except OSError:
        return None, None, None
    for line in text.splitlines():
        parts = line.split()
        try:
            if parts[:1] == ["started"] and len(parts) >= 2:
                started = float(parts[1])
            elif parts[:1] == ["ended"] and len(parts) >= 3:
                ended, code = float(parts[1]), int(parts[2])
        except ValueError:
            continue
    return started, ended, code


def _job_spec(workdir: Path, script: Path, launcher: LauncherSpec, time_limit_s: float, name: str) -> Any:
    from psij import JobAttributes, JobSpec, ResourceSpecV1

    resources = ResourceSpecV1(
        node_count=launcher.nodes if launcher.nodes > 1 else None,
        process_count=launcher.tasks,
        cpu_cores_per_process=launcher.cpus_per_task,
        memory=launcher.memory_mb * 1024 * 1024 if launcher.memory_mb else None,
    )
    attributes = JobAttributes(
        duration=timedelta(seconds=max(1, round(time_limit_s))),
        queue_name=launcher.partition,
        account=launcher.account,
        custom_attributes={f"{launcher.scheduler}.{k}": v for k, v in launcher.directives.items()} or None,
    )
    return JobSpec(
        name=name[:60],
        executable="/bin/bash",
        arguments=(["-l"] if launcher.modules else []) + [str(script)],
        directory=workdir,
        stdout_path=workdir / "batch-stdout.log",
        stderr_path=workdir / "batch-stderr.log",
        inherit_environment=True,
        resources=resources,
        attributes=attributes,
        launcher="single",
    )


def run_batch_job(
    *,
    launcher: LauncherSpec,
    workdir: Path,
    argv: Sequence[str],
    env: Mapping[str, str],
    time_limit_s: float,
    name: str,
    script_dir: Path,
    book: BatchJobBook,
    attach_to: BatchJob | None,
    cancel: CancelCheck | None,
    cancelled_message: str,
) -> tuple[ProcessOutcome, BatchJob]:
    """Submit the program as a batch job in ``workdir`` (already staged), or attach to
    ``attach_to`` (a job of an earlier attempt), and wait until it ends; ``script_dir`` holds
    PSI/J's submit scripts and exit-code files (the same for every attempt). Returns how the
    program ended (as for a local run) and the job. Raises :class:`SchedulerFailure` when the
    scheduler refused or ended the job, :class:`OracleCancelled` after cancelling it."""
    from psij import Job, JobState, SubmitException

    executor = executor_for(launcher, script_dir)
    script = workdir / JOB_SCRIPT
    if attach_to is None:
        script = write_job_script(workdir, argv, env, launcher)
    job = Job(_job_spec(workdir, script, launcher, time_limit_s, name))
    if attach_to is not None:
        record = attach_to
        executor.attach(job, record.job_id)
    else:
        try:
            executor.submit(job)
        except SubmitException as exc:
            raise SchedulerFailure(f"the {launcher.scheduler} scheduler refused the job: {_one_line(exc)}") from None
        if not JOB_ID.match(str(job.native_id or "")):
            with contextlib.suppress(Exception):  # whatever was submitted, if anything, could not be followed
                executor.cancel(job)
            raise SchedulerFailure(
                f"the {launcher.scheduler} scheduler's answer to the submission holds no job id: {job.native_id!r}"
            )
        record = BatchJob(launcher.scheduler, str(job.native_id), str(workdir), "queued", submitted_at=time.time())
        book.record(record)
    while True:
        status = job.status
        if status.state == JobState.ACTIVE and record.state == "queued":
            record.state = "running"
            record.started_at = job_times(workdir)[0] or time.time()
            book.record(record)
        if status.state.final:
            break
        if cancel is not None and cancel():
            executor.cancel(job)
            record.state, record.reason, record.ended_at = "cancelled", "cancelled with the campaign", time.time()
            book.record(record)
            raise OracleCancelled(f"{cancelled_message}; {launcher.scheduler} job {record.job_id} cancelled")
        job.wait(timeout=timedelta(seconds=WAIT_SECONDS))
    return _ended(job, record, launcher, workdir, book)


def _ended(
    job: Any, record: BatchJob, launcher: LauncherSpec, workdir: Path, book: BatchJobBook
) -> tuple[ProcessOutcome, BatchJob]:
    from psij import JobState

    status = job.status
    started, ended, code = job_times(workdir)
    record.started_at = started or record.started_at
    record.ended_at = ended or time.time()
    record.exit_code = code if code is not None else status.exit_code
    native = (status.metadata or {}).get("native_state")
    native_reason = (status.metadata or {}).get("native_reason")
    # the job script records the program's end: a failed job without it, or whose program was
    # SIGKILLed (what a scheduler's memory enforcement sends), was ended from outside
    sigkilled = record.exit_code == 128 + 9
    killed = status.state in (JobState.FAILED, JobState.CANCELED) and (
        (ended is None and record.exit_code is None) or sigkilled
    )
    if native in SLURM_ENDED_BY_SCHEDULER or killed:
        message = status.message or f"the job ended as {status.state}"
        if native == "TO":
            message += f" ({_limit_text(job)})"
        elif native is not None and native not in SLURM_ENDED_BY_SCHEDULER:
            memory = f"over its memory limit of {launcher.memory_mb} MB, " if launcher.memory_mb else ""
            how = "its program was killed (SIGKILL)" if sigkilled else "it ended before its program finished"
            message = (
                f"the scheduler ended the job: {how} (state {native}, {native_reason}): "
                f"{memory}or it could not be started; see the scheduler's log of job {record.job_id}"
            )
        polling_failed = native is None and "poll" in message.lower()
        if not polling_failed:  # a job the worker could not ask about may still run: attach to it again
            record.state, record.reason = ("cancelled" if native == "CA" else "failed"), message
            book.record(record)
        raise SchedulerFailure(f"{launcher.scheduler} job {record.job_id}: {_one_line(message)}")
    if record.exit_code not in (0, None):
        record.state, record.reason = "failed", f"the program exited with code {record.exit_code}"
        book.record(record)
        last = tail(workdir / STDERR_FILE, lines=1)
        return ProcessOutcome(
            record.exit_code, f"the command exited with code {record.exit_code}" + (f": {last}" if last else "")
        ), record
    record.state = "completed"
    book.record(record)
    return ProcessOutcome(0 if record.exit_code is None else record.exit_code), record


def _limit_text(job: Any) -> str:
    duration = job.spec.attributes.duration if job.spec is not None and job.spec.attributes else None
    return f"time limit {duration}" if duration is not None else "its time limit"


def _one_line(value: object) -> str:
    text = " ".join(str(value).split())
    return text[:500]


__all__ = [
    "JOB_SCRIPT",
    "JOB_TIMES",
    "BatchJob",
    "BatchJobBook",
    "MemoryBook",
    "SchedulerFailure",
    "executor_for",
    "job_root",
    "job_times",
    "run_batch_job",
    "write_job_script",
]
