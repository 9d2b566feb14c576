"""`alcove ocp solve|tasks|show`: the real console script once, the rest in process."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.ocp.task_spec import task_preset
from alcove.science.series import Trajectory
from alcove_worker.cli.main import app

ALCOVE = str(Path(sys.executable).with_name("alcove"))
runner = CliRunner()


def test_solve_writes_the_trajectory_and_a_json_summary(tmp_path):
    proc = subprocess.run(
        [
            ALCOVE,
            "ocp",
            "solve",
            "--task",
            "head-headrest-2phase",
            "--contact",
            "aux",
            "--intervals",
            "40",
            "--out",
            "traj.csv",
            "--json",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["status"] == "Solve_Succeeded" and summary["converged"] is True
    for key in ("iterations", "cost", "wall_time_s", "constraint_violation"):
        assert key in summary
    text = (tmp_path / "traj.csv").read_text()
    assert text.splitlines()[0] == "t,q_0,qd_0,tau_0,head_x,head_z,head_angle,head_vx,head_vz,head_omega"
    traj = Trajectory.from_csv(tmp_path / "traj.csv")
    assert len(traj) == 81 and traj.t[-1] == pytest.approx(2.0)
    assert traj.q[0, 0] == pytest.approx(DEFAULT_PRESET.theta0) and traj.q.max() > DEFAULT_PRESET.theta_contact


def test_task_file_and_no_contact(tmp_path):
    shown = runner.invoke(app, ["ocp", "show", "--task", "head-headrest-2phase"])
    assert shown.exit_code == 0
    data = json.loads(shown.stdout)
    data["phases"][0]["intervals"] = data["phases"][1]["intervals"] = 20
    (tmp_path / "task.json").write_text(json.dumps(data))
    res = runner.invoke(
        app,
        [
            "ocp",
            "solve",
            "--task-file",
            str(tmp_path / "task.json"),
            "--contact",
            "none",
            "--out",
            str(tmp_path / "t.csv"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert "Solve_Succeeded" in res.stdout
    # without the headrest nothing stops the head: it never rests beyond first contact
    assert Trajectory.from_csv(tmp_path / "t.csv").q[-1, 0] < DEFAULT_PRESET.theta_contact
    assert "head-headrest-2phase" in runner.invoke(app, ["ocp", "tasks"]).stdout


def test_not_converged_exits_1_and_says_so(tmp_path):
    res = runner.invoke(
        app, ["ocp", "solve", "--intervals", "20", "--max-iter", "2", "--json", "--out", str(tmp_path / "t.csv")]
    )
    assert res.exit_code == 1
    summary = json.loads(res.stdout)
    assert summary["converged"] is False and summary["status"] == "Maximum_Iterations_Exceeded"
    assert len(summary["attempts"]) == 3  # bounded retries with the other initial guesses
    assert "did not converge" in res.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--contact", "bogus"], "error: contact: unknown contact model"),
        (["--contact", "model:/nonexistent.json"], "error: contact: model file"),
        (["--task", "nope"], "error: task: unknown task preset"),
        (["--task-file", "/nonexistent.json"], "error: task-file:"),
        (["--task", "/nonexistent.json"], "error: task: /nonexistent.json does not exist"),
    ],
)
def test_bad_input_exits_2_naming_the_field(tmp_path, args, message):
    res = runner.invoke(app, ["ocp", "solve", "--out", str(tmp_path / "t.csv"), *args])
    assert res.exit_code == 2
    assert message in res.stderr
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("where, message", [("missing/t.csv", "error: out: directory"), (".", "is a directory")])
def test_unwritable_out_is_rejected_before_solving(tmp_path, where, message):
    res = runner.invoke(app, ["ocp", "solve", "--out", str(tmp_path / where)])
    assert res.exit_code == 2
    assert message in res.stderr
    assert not (tmp_path / "missing").exists()


def test_show_prints_a_chain_presets_model():
    """`alcove ocp show TASK` prints the task with its whole model (links and joints of a chain)."""
    res = runner.invoke(app, ["ocp", "show", "head-headrest-2dof"])
    assert res.exit_code == 0, res.stderr
    chain = json.loads(res.stdout)
    assert chain["name"] == "head-headrest-2dof" and chain["model"]["preset"] == "head-neck-2dof"
    assert len(chain["model"]["chain"]["links"]) == len(chain["model"]["chain"]["joints"]) == 2


def test_bad_task_file_names_the_field(tmp_path):
    data = json.loads(runner.invoke(app, ["ocp", "show"]).stdout)
    data["phases"][1]["w_T"] = -1
    (tmp_path / "task.json").write_text(json.dumps(data))
    res = runner.invoke(
        app, ["ocp", "solve", "--task-file", str(tmp_path / "task.json"), "--out", str(tmp_path / "t.csv")]
    )
    assert res.exit_code == 2
    assert "error: phases.1.w_T: " in res.stderr


def test_solve_with_a_trained_surrogate_artifact(tmp_path):
    """--contact model:FILE goes through the surrogate's CasADi export into the contact slot."""
    from alcove.science.surrogate.artifact import save_artifact
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    model = train_surrogate(
        preliminary_pool(DEFAULT_PRESET, samples=400, chunks=4), SurrogateConfig(max_epochs=5), seed=0
    ).model
    artifact = save_artifact(model, tmp_path / "model")
    res = runner.invoke(
        app,
        [
            "ocp",
            "solve",
            "--contact",
            f"model:{artifact}",
            "--intervals",
            "20",
            "--out",
            str(tmp_path / "t.csv"),
            "--json",
        ],
    )
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["contact"] == f"model:{artifact}" and summary["converged"] is True
    assert len(Trajectory.from_csv(tmp_path / "t.csv")) == 41


@pytest.mark.slow
def test_ghost_force_solution_is_flagged_untrusted(tmp_path, ghost_case):
    """The issue's ghost-force case: the hovering rest is reported, on stderr and in the JSON."""
    from alcove.science.geometry import signed_gap
    from alcove.science.surrogate.artifact import save_artifact
    from alcove.science.surrogate.dataset import save_pool_dir

    model, pool = ghost_case
    save_artifact(model, tmp_path / "m")
    save_pool_dir(pool, tmp_path / "pool")
    args = [
        "ocp",
        "solve",
        "--contact",
        f"model:{tmp_path / 'm'}",
        "--intervals",
        "20",
        "--out",
        str(tmp_path / "t.csv"),
    ]
    res = runner.invoke(app, [*args, "--pool", str(tmp_path / "pool"), "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["trusted"] is False and summary["trust_reasons"][0].startswith("ghost force")
    assert "warning: untrusted solution: ghost force" in res.stderr
    trust = summary["trust"]
    assert trust["open_gap_max_force"] > 10.0 and trust["open_gap_at_gap"] > 0.002
    assert trust["max_pool_distance"] is not None and trust["ensemble_size"] == 4
    rest = Trajectory.from_csv(tmp_path / "t.csv").q[-20:, 0]
    assert signed_gap(DEFAULT_PRESET, rest).min() > 0.002  # hovering: clear of the cushion
    # bad trust-region input names the field, before solving
    for extra, message in (
        (["--trust-region-max-std", "-1"], "trust-region-max-std: must be a positive number"),
        (["--pool", str(tmp_path / "nope")], "pool:"),
    ):
        bad = runner.invoke(app, [*args, *extra])
        assert bad.exit_code == 2 and message in bad.stderr
    aux = runner.invoke(app, ["ocp", "solve", "--out", str(tmp_path / "a.csv"), "--trust-region-max-std", "5"])
    assert aux.exit_code == 2 and "trust-region-max-std: needs a surrogate contact model" in aux.stderr
    # the trust region (start before the band where the members disagree, tests/science/surrogate/test_trust.py):
    # the std stays within the bound and the head no longer hovers on the ghost force
    from alcove.science.ocp.task_spec import TASK_PRESETS

    task_file = tmp_path / "task.json"
    task_file.write_text(json.dumps({**TASK_PRESETS["head-headrest-2phase"], "initial": {"q": [0.06], "qd": None}}))
    bounded = runner.invoke(
        app, [*args, "--task-file", str(task_file), "--trust-region-max-std", "2", "--json"], catch_exceptions=False
    )
    assert bounded.exit_code == 0, bounded.output
    out = json.loads(bounded.stdout)
    assert out["trust_region_max_std"] == 2.0 and out["trust"]["max_std"] <= 2.0 * (1 + 1e-6)


EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tasks"


@pytest.mark.parametrize("option", ["--task-file", "--task"])
def test_solve_a_task_file_with_a_chain_model(tmp_path, option):
    """The 2-DOF example task solves from the CLI (``--task-file F`` or ``--task F.json``); the CSV has
    one q/qd/tau column per joint and the head's pose in the headrest frame (the chain's kinematics
    at the joint columns)."""
    out = tmp_path / "t.csv"
    res = runner.invoke(
        app, ["ocp", "solve", option, str(EXAMPLES / "head-headrest-2dof.json"), "--out", str(out), "--json"]
    )
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["converged"]
    header = "t,q_0,q_1,qd_0,qd_1,tau_0,tau_1,head_x,head_z,head_angle,head_vx,head_vz,head_omega"
    assert out.read_text().splitlines()[0] == header
    traj = Trajectory.from_csv(out)
    assert traj.q.shape == (201, 2)
    chain = task_preset("head-headrest-2dof").chain()
    np.testing.assert_allclose(traj.pose, chain.head_pose(traj.q, traj.qd), rtol=0, atol=1e-14)


def test_a_bad_chain_in_a_task_file_names_the_field(tmp_path):
    data = json.loads((EXAMPLES / "user-chain-3link.json").read_text())
    data["model"]["chain"]["links"][1]["mass"] = -2.0
    (tmp_path / "task.json").write_text(json.dumps(data))
    res = runner.invoke(
        app, ["ocp", "solve", "--task-file", str(tmp_path / "task.json"), "--out", str(tmp_path / "t.csv")]
    )
    assert res.exit_code == 2
    assert "error: model.chain.links.1.mass: " in res.stderr
    res = runner.invoke(
        app,
        [
            "ocp",
            "solve",
            "--task-file",
            str(EXAMPLES / "head-headrest-2dof.json"),
            "--contact",
            "model:x.pt",
            "--out",
            str(tmp_path / "t.csv"),
        ],
    )
    assert res.exit_code == 2  # chains take surrogate contacts too: the file is checked
    assert res.stderr == "error: contact: model file 'x.pt' does not exist\n"
