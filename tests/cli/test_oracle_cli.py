"""`alcove oracle run|list|schema`: the real console script for a few cases, the bad-input matrix in process."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.oracles.aux_penalty import AuxPenaltyOracle, AuxPenaltyParams
from alcove.science.series import ForceSeries, Trajectory
from alcove_worker.cli.main import app

ALCOVE = str(Path(sys.executable).with_name("alcove"))
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "command-oracle"


@pytest.fixture
def trajectory_csv(tmp_path: Path) -> Path:
    t = np.linspace(0.0, 1.0, 401)
    path = tmp_path / "traj.csv"
    Trajectory(t, DEFAULT_PRESET.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t)).to_csv(path)
    return path


def alcove(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "ALCOVE_COMMAND_ORACLES_FILE"}
    return subprocess.run([ALCOVE, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


# ---- the real console script --------------------------------------------------------------------
def test_run_aux_penalty_writes_forces_and_json_summary(tmp_path, trajectory_csv):
    (tmp_path / "params.json").write_text(json.dumps({"k": 1.2e7}))
    proc = alcove(
        "oracle",
        "run",
        "--oracle",
        "aux-penalty",
        "--params",
        "params.json",
        "--trajectory",
        "traj.csv",
        "--out",
        "forces.csv",
        "--json",
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    for key in (
        "status",
        "wall_time_s",
        "peak_force_n",
        "max_penetration_m",
        "dissipated_energy_j",
        "newton_iterations",
    ):
        assert key in summary
    assert summary["status"] == "ok" and summary["newton_iterations"] is None and summary["samples"] == 401
    assert (tmp_path / "forces.csv").read_text().splitlines()[0] == "t,fx,fy,fz,mx,my,mz"
    forces = ForceSeries.from_csv(tmp_path / "forces.csv")
    reference = AuxPenaltyOracle(AuxPenaltyParams(k=1.2e7)).run(Trajectory.from_csv(trajectory_csv))
    np.testing.assert_array_equal(forces.force, reference.forces.force)
    np.testing.assert_array_equal(forces.moment, reference.forces.moment)
    assert summary["peak_force_n"] == pytest.approx(reference.forces.peak_force)
    assert summary["max_penetration_m"] == pytest.approx(reference.diagnostics["max_penetration_m"])


def test_bad_input_is_one_line_exit_2_without_traceback(tmp_path, trajectory_csv):
    (tmp_path / "params.json").write_text('{"k": -1}')
    proc = alcove(
        "oracle",
        "run",
        "--oracle",
        "aux-penalty",
        "--params",
        "params.json",
        "--trajectory",
        "traj.csv",
        "--out",
        "forces.csv",
        cwd=tmp_path,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == "error: params.k: Input should be greater than 0"
    assert "Traceback" not in proc.stderr and not (tmp_path / "forces.csv").exists()


def test_failing_command_oracle_exits_1_and_writes_nothing(tmp_path, trajectory_csv):
    (tmp_path / "catalogue.yaml").write_text(
        "command_oracles:\n"
        f"  broken:\n    argv: ['{{python}}', '{EXAMPLES / 'failing_solver.py'}', 'exit-code']\n"
        f"    workdir_root: {tmp_path / 'runs'}\n"
    )
    proc = alcove(
        "oracle",
        "run",
        "--oracle",
        "broken",
        "--catalogue",
        "catalogue.yaml",
        "--trajectory",
        "traj.csv",
        "--out",
        "forces.csv",
        "--json",
        cwd=tmp_path,
    )
    assert proc.returncode == 1
    summary = json.loads(proc.stdout)
    assert summary["status"] == "failed" and "exited with code 3" in summary["failure_reason"]
    assert Path(summary["diagnostics"]["workdir"]).parent == tmp_path / "runs"
    assert proc.stderr.startswith("failed: command oracle 'broken': the command exited with code 3")
    assert not (tmp_path / "forces.csv").exists()


def test_command_oracle_from_the_settings_catalogue(tmp_path, trajectory_csv):
    env = {**os.environ, "ALCOVE_COMMAND_ORACLES_FILE": str(EXAMPLES / "catalogue.yaml")}
    proc = subprocess.run(
        [
            ALCOVE,
            "oracle",
            "run",
            "--oracle",
            "aux-replay",
            "--trajectory",
            "traj.csv",
            "--out",
            "forces.csv",
            "--json",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    reference = AuxPenaltyOracle().run(Trajectory.from_csv(trajectory_csv))
    assert summary["max_penetration_m"] == pytest.approx(
        reference.diagnostics["max_penetration_m"]
    )  # from the solver's diagnostics.json
    np.testing.assert_array_equal(ForceSeries.from_csv(tmp_path / "forces.csv").force, reference.forces.force)


# ---- in process: the bad-input matrix, list and schema -------------------------------------------
runner = CliRunner()


@pytest.fixture(autouse=True)
def no_settings_catalogue(monkeypatch):
    """The in-process cases must not see a catalogue configured on this machine."""
    from alcove.settings import get_settings

    monkeypatch.delenv("ALCOVE_COMMAND_ORACLES_FILE", raising=False)
    get_settings.cache_clear()
    yield
    get_settings.cache_clear()


def invoke(*args: str):
    return runner.invoke(app, list(args))


@pytest.mark.parametrize(
    ("setup", "args", "message"),
    [
        (lambda d: None, ["--oracle", "lsdyna"], "error: oracle: unknown oracle type 'lsdyna'"),
        (
            lambda d: (d / "p.json").write_text("{k: 1}"),
            ["--oracle", "aux-penalty", "--params", "p.json"],
            "error: params: p.json is not valid JSON",
        ),
        (
            lambda d: (d / "p.json").write_text("[1, 2]"),
            ["--oracle", "aux-penalty", "--params", "p.json"],
            "error: params: p.json must hold a JSON object",
        ),
        (
            lambda d: None,
            ["--oracle", "aux-penalty", "--params", "missing.json"],
            "error: params: missing.json does not exist",
        ),
        (
            lambda d: (d / "traj.csv").write_text("t,q_0,qd_0\n0,0.2,0\n0,0.3,0\n"),
            ["--oracle", "aux-penalty"],
            "error: trajectory: t: time must increase strictly",
        ),
        (
            lambda d: (d / "traj.csv").write_text("t,q_0,qd_0\n0,0.2,0\n1,nan,0\n"),
            ["--oracle", "aux-penalty"],
            "error: trajectory: q: non-finite value (NaN or inf) at data row 2",
        ),
        (
            lambda d: (d / "traj.csv").write_text("t,q_0,qdot_0\n0,0.2,0\n1,0.3,0\n"),
            ["--oracle", "aux-penalty"],
            "error: trajectory: qd_0: expected 1 velocity columns",
        ),
        (
            lambda d: (d / "traj.csv").write_text("t,q_0,q_1,qd_0,qd_1\n0,0.2,0,0,0\n1,0.3,0,0,0\n"),
            ["--oracle", "aux-penalty"],
            "error: trajectory: head_x: missing: a trajectory of 2 joints needs the pose columns",
        ),
        (
            lambda d: None,
            ["--oracle", "aux-penalty", "--trajectory", "nowhere.csv"],
            "error: trajectory: file: nowhere.csv does not exist",
        ),
        (
            lambda d: None,
            ["--oracle", "aux-penalty", "--out", "no/such/forces.csv"],
            "error: out: folder no/such does not exist",
        ),
        (
            lambda d: (d / "c.yaml").write_text("command_oracles:\n  x: {argv: 'rm -rf /'}\n"),
            ["--oracle", "x", "--catalogue", "c.yaml"],
            "error: catalogue: command_oracles.x.argv: must be a list",
        ),
        (
            lambda d: None,
            ["--oracle", "aux-replay"],
            "error: oracle: unknown oracle type 'aux-replay'; "
            "known: aux-penalty, fe-headrest-2d, fe-headrest-3d-ccx (command oracles need",
        ),
    ],
)
def test_bad_input_matrix(tmp_path, trajectory_csv, monkeypatch, setup, args, message):
    monkeypatch.chdir(tmp_path)
    setup(tmp_path)
    defaults = {"--trajectory": "traj.csv", "--out": "forces.csv"}
    full = ["oracle", "run", *args] + [x for k, v in defaults.items() if k not in args for x in (k, v)]
    result = invoke(*full)
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(message) and result.stderr.count("\n") == 1
    assert not (tmp_path / "forces.csv").exists()


def test_list_and_schema(tmp_path):
    result = invoke("oracle", "list", "--json", "--catalogue", str(EXAMPLES / "catalogue.yaml"))
    assert result.exit_code == 0
    rows = {row["name"]: row for row in json.loads(result.stdout)}
    assert {"aux-penalty", "fe-headrest-2d", "aux-replay", "lsdyna-headrest"} <= set(rows)
    assert rows["aux-penalty"]["available"] is True
    table = invoke("oracle", "list")
    assert table.exit_code == 0 and "aux-penalty" in table.stdout
    schema = invoke("oracle", "schema", "aux-penalty")
    assert schema.exit_code == 0 and set(json.loads(schema.stdout)["properties"]) == {"k", "d0", "p_ref", "r_sp"}
    command = invoke("oracle", "schema", "aux-replay", "--catalogue", str(EXAMPLES / "catalogue.yaml"))
    assert "keep_workdir" in json.loads(command.stdout)["properties"]
    unknown = invoke("oracle", "schema", "nope")
    assert unknown.exit_code == 2 and unknown.stderr.startswith("error: oracle: unknown oracle type 'nope'")
