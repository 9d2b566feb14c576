"""`alcove surrogate preliminary|train|predict`: pool folders, artifacts, campaigns, bad input."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.series import ForceSeries, Trajectory
from alcove_worker.cli.main import app

ALCOVE = str(Path(sys.executable).with_name("alcove"))
runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, list(args), catch_exceptions=False)


@pytest.fixture
def quick_config(tmp_path: Path) -> Path:
    path = tmp_path / "config.json"
    path.write_text(json.dumps({"max_epochs": 20, "batch_size": 256, "ensemble_size": 1}))
    return path


@pytest.fixture
def trajectory_csv(tmp_path: Path) -> Path:
    t = np.linspace(0.0, 1.0, 401)
    path = tmp_path / "traj.csv"
    Trajectory(
        t, DEFAULT_PRESET.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t), np.zeros_like(t)
    ).to_csv(path)
    return path


def test_preliminary_train_predict(tmp_path, quick_config, trajectory_csv):
    """A user builds a pool, trains (the real console script) and predicts from the CLI."""
    env = {k: v for k, v in os.environ.items() if k != "ALCOVE_DATABASE_URL"}

    def run(*a):
        return subprocess.run(
            [ALCOVE, "surrogate", *a], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
        )

    result = invoke("surrogate", "preliminary", "--out", str(tmp_path / "pool"), "--samples", "600", "--chunks", "6")
    assert result.exit_code == 0 and result.output.startswith("600 samples (")
    assert len(list((tmp_path / "pool").glob("preliminary-*.traj.csv"))) == 6
    # a hand-made addition: an oracle run's pair, as `alcove oracle run` writes it
    traj = Trajectory.from_csv(trajectory_csv)
    from alcove.science.oracles.aux_penalty import AuxPenaltyOracle

    traj.to_csv(tmp_path / "pool" / "run1.traj.csv")
    AuxPenaltyOracle().run(traj).forces.to_csv(tmp_path / "pool" / "run1.forces.csv")
    proc = run("train", "--pool", "pool", "--config", str(quick_config), "--out", "model", "--json")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["status"] == "ok" and summary["datasets"] == 7 and summary["epochs"] == {"force": 20, "moment": 20}
    assert set(summary["rmse"]["force"]) == {"train", "validation", "test"} and summary["wall_time_s"] > 0
    assert summary["ensemble_size"] == 1 and len(summary["members"]) == 1
    assert sum(summary["samples"].values()) == 600 + 401
    assert sorted(p.name for p in (tmp_path / "model").iterdir()) == [
        "force.casadi",
        "force.onnx",
        "force.pt",
        "moment.casadi",
        "moment.onnx",
        "moment.pt",
        "surrogate.json",
    ]
    result = invoke(
        "surrogate",
        "predict",
        "--model",
        str(tmp_path / "model"),
        "--trajectory",
        str(trajectory_csv),
        "--out",
        str(tmp_path / "pred.csv"),
    )
    assert result.exit_code == 0, result.output
    assert (tmp_path / "pred.csv").read_text().splitlines()[0] == "t,fx,fy,fz,mx,my,mz"
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.training import predict

    pred = ForceSeries.from_csv(tmp_path / "pred.csv")
    expected = predict(load_artifact(tmp_path / "model"), traj.t, traj.q, traj.qd)
    np.testing.assert_array_equal(pred.force, expected.force)
    np.testing.assert_array_equal(pred.moment, expected.moment)


def test_an_ensemble_writes_std_exports_and_std_columns(tmp_path, trajectory_csv):
    """K = 3 from a config file: std CasADi files next to the mean ones; predict adds fx_std..mz_std."""
    invoke("surrogate", "preliminary", "--out", str(tmp_path / "pool"), "--samples", "300", "--chunks", "4")
    (tmp_path / "cfg.json").write_text(json.dumps({"max_epochs": 5, "batch_size": 128, "ensemble_size": 3}))
    result = invoke(
        "surrogate", "train", "--pool", str(tmp_path / "pool"), "--config", str(tmp_path / "cfg.json"),
        "--out", str(tmp_path / "m"),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    names = {p.name for p in (tmp_path / "m").iterdir()}
    assert {"force_std.casadi", "moment_std.casadi", "force.casadi", "force.onnx", "moment.onnx"} <= names
    result = invoke(
        "surrogate", "predict", "--model", str(tmp_path / "m"), "--trajectory", str(trajectory_csv),
        "--out", str(tmp_path / "pred.csv"),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    lines = (tmp_path / "pred.csv").read_text().splitlines()
    assert lines[0] == "t,fx,fy,fz,mx,my,mz,fx_std,fy_std,fz_std,mx_std,my_std,mz_std"
    table = np.loadtxt(tmp_path / "pred.csv", delimiter=",", skiprows=1)
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.training import predict_ensemble

    traj = Trajectory.from_csv(trajectory_csv)
    p = predict_ensemble(load_artifact(tmp_path / "m"), traj.q, traj.qd)
    np.testing.assert_array_equal(table[:, 7:10], p.force_std)
    assert np.all(table[:, 7:] >= 0) and np.any(table[:, 7] > 0)


def test_the_gated_architecture_from_the_command_line(tmp_path, trajectory_csv):
    """`alcove surrogate train --pool DIR --config cfg.json --out MODEL` with "architecture": "gated"
    (the real console script): the artifact records it, the exports are written, and the prediction
    along a trajectory is exactly zero wherever the geometry says the gap is clearly open."""
    invoke("surrogate", "preliminary", "--out", str(tmp_path / "pool"), "--samples", "400", "--chunks", "4")
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"architecture": "gated", "max_epochs": 5, "batch_size": 128, "ensemble_size": 2}))
    env = {k: v for k, v in os.environ.items() if k != "ALCOVE_DATABASE_URL"}
    proc = subprocess.run(
        [ALCOVE, "surrogate", "train", "--pool", "pool", "--config", str(cfg), "--out", "model", "--json"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["ensemble_size"] == 2
    doc = json.loads((tmp_path / "model" / "surrogate.json").read_text())
    assert doc["config"]["architecture"] == "gated" and doc["architecture"]["name"] == "gated"
    names = {p.name for p in (tmp_path / "model").iterdir()}
    assert {"force.casadi", "force_std.casadi", "force.onnx", "moment.onnx", "force.pt"} <= names
    result = invoke(
        "surrogate", "predict", "--model", str(tmp_path / "model"), "--trajectory", str(trajectory_csv),
        "--out", str(tmp_path / "pred.csv"),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    from alcove.science.geometry import signed_gap

    table = np.loadtxt(tmp_path / "pred.csv", delimiter=",", skiprows=1)
    gap = signed_gap(DEFAULT_PRESET, Trajectory.from_csv(trajectory_csv).q[:, 0])
    assert (gap >= 0.002).sum() > 50 and (gap <= 0).sum() > 50  # open and closed phases
    assert np.all(table[gap >= 0.002, 1:] == 0.0) and np.all(table[:, 1] >= 0.0)


def test_same_seed_same_artifact(tmp_path, quick_config):
    invoke("surrogate", "preliminary", "--out", str(tmp_path / "pool"), "--samples", "300", "--chunks", "3")
    for name in ("a", "b"):
        result = invoke(
            "surrogate",
            "train",
            "--pool",
            str(tmp_path / "pool"),
            "--config",
            str(quick_config),
            "--seed",
            "5",
            "--out",
            str(tmp_path / name),
        )
        assert result.exit_code == 0, result.output
    docs = [json.loads((tmp_path / n / "surrogate.json").read_text()) for n in ("a", "b")]
    assert docs[0]["networks"] == docs[1]["networks"] and docs[0]["lineage"]["seed"] == 5


@pytest.mark.parametrize(
    "args, message",
    [
        (["train", "--out", "m"], "error: pool: give exactly one of --pool DIR and --campaign ID"),
        (
            ["train", "--pool", "nope", "--campaign", "1", "--out", "m"],
            "error: pool: give exactly one of --pool DIR and --campaign ID",
        ),
        (["train", "--pool", "nope", "--out", "m"], "error: pool: pool: nope is not a directory"),
        (
            ["train", "--pool", "empty", "--out", "m"],
            "error: pool: pool: empty holds no NAME.traj.csv + NAME.forces.csv pairs (the pool is empty)",
        ),
        (
            ["train", "--pool", "pool", "--config", "bad.json", "--out", "m"],
            "error: config: force.hidden.1: Input should be greater than or equal to 1",
        ),
        (
            ["train", "--pool", "pool", "--config", "arch.json", "--out", "m"],
            "error: config: architecture: Input should be 'paper' or 'gated'",
        ),
        (
            ["train", "--pool", "pool", "--config", "missing.json", "--out", "m"],
            "error: config: missing.json does not exist",
        ),
        (
            ["train", "--campaign", "1", "--database-url", "sqlite:///nowhere/x.db", "--out", "m"],
            "error: campaign: no database at sqlite:///nowhere/x.db (set ALCOVE_DATABASE_URL)",
        ),
        (
            ["predict", "--model", "nomodel", "--trajectory", "t.csv", "--out", "p.csv"],
            "error: model: nomodel does not exist",
        ),
        (["preliminary", "--out", "p2", "--samples", "1"], "error: samples: must be an integer >= 2, got 1"),
        (
            ["preliminary", "--out", "p2", "--velocity-bound", "-1"],
            "error: velocity-bound: must be a positive number, got -1.0",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "empty").mkdir()
    (tmp_path / "bad.json").write_text('{"force": {"hidden": [6, 0]}}')
    (tmp_path / "arch.json").write_text('{"architecture": "contact-aware"}')
    invoke("surrogate", "preliminary", "--out", "pool", "--samples", "40", "--chunks", "2")
    result = runner.invoke(app, ["surrogate", *args])
    assert result.exit_code == 2, result.output
    assert result.output.strip().splitlines()[-1] == message
    assert not (tmp_path / "m").exists()


def test_predict_rejects_a_trajectory_of_another_chain(tmp_path, quick_config):
    invoke("surrogate", "preliminary", "--out", str(tmp_path / "pool"), "--samples", "100", "--chunks", "2")
    invoke(
        "surrogate",
        "train",
        "--pool",
        str(tmp_path / "pool"),
        "--config",
        str(quick_config),
        "--out",
        str(tmp_path / "m"),
    )
    t = np.linspace(0, 1, 5)
    Trajectory(t, np.c_[t, t], np.c_[t, t], pose=np.zeros((5, 6))).to_csv(tmp_path / "two.csv")  # 2 joints
    result = runner.invoke(
        app,
        [
            "surrogate",
            "predict",
            "--model",
            str(tmp_path / "m"),
            "--trajectory",
            str(tmp_path / "two.csv"),
            "--out",
            str(tmp_path / "p.csv"),
        ],
    )
    assert result.exit_code == 2
    assert result.output.strip() == "error: trajectory: q: has 2 degrees of freedom, the model was trained on 1"


def test_train_on_a_campaign_pool(tmp_path, sqlite_url):
    """--campaign reads the latest pool version, the campaign's surrogate config, task geometry and seed."""
    from alcove import models as m
    from alcove.db.session import open_transaction
    from alcove.pool.service import create_version, store_dataset
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.surrogate.preliminary import preliminary_pool

    task_spec = task_preset("head-headrest-2phase").model_dump(mode="json")
    config_spec = {"max_epochs": 7, "batch_size": 128}
    with open_transaction(sqlite_url) as s:
        user = m.User(email="cli-surrogate@x.org", role=m.Role.member.value)
        tv = m.TaskVersion(
            definition=m.TaskDefinition(owner=user, name="t", latest_version=1),
            version=1,
            spec=task_spec,
            spec_hash=m.spec_hash(task_spec),
        )
        ov = m.OracleVersion(
            definition=m.OracleDefinition(owner=user, name="o", latest_version=1),
            version=1,
            oracle_type="aux-penalty",
            spec={},
            spec_hash=m.spec_hash({}),
        )
        sv = m.SurrogateConfigVersion(
            config=m.SurrogateConfigDefinition(owner=user, name="s", latest_version=1),
            version=1,
            spec=config_spec,
            spec_hash=m.spec_hash(config_spec),
        )
        c = m.Campaign(owner=user, name="c", task_version=tv, oracle_version=ov, surrogate_config_version=sv, seed=11)
        s.add(c)
        s.flush()
        cfg = m.CampaignConfigVersion(campaign=c, version=1, surrogate_config_version=sv)
        it0 = m.Iteration(campaign=c, index=0, config_version=cfg)
        s.add_all([cfg, it0])
        s.flush()
        datasets = [
            store_dataset(
                s,
                t=ds.t,
                q=ds.q,
                qd=ds.qd,
                f=np.hstack([ds.force, ds.moment]),
                origin="preliminary",
                name=ds.name,
                campaign_id=c.id,
                iteration_id=it0.id,
            )
            for ds in preliminary_pool(DEFAULT_PRESET, samples=200, chunks=4)
        ]
        create_version(s, campaign_id=c.id, iteration_id=it0.id, version=0, parent=None, new_datasets=datasets)
        campaign_id = c.id
    result = runner.invoke(
        app,
        [
            "surrogate",
            "train",
            "--campaign",
            str(campaign_id),
            "--database-url",
            sqlite_url,
            "--out",
            str(tmp_path / "m"),
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["seed"] == 11 and summary["datasets"] == 4 and summary["epochs"] == {"force": 7, "moment": 7}
    doc = json.loads((tmp_path / "m" / "surrogate.json").read_text())
    assert doc["lineage"]["campaign_id"] == campaign_id and doc["lineage"]["pool_version"] == 0
    assert doc["config"]["max_epochs"] == 7
    result = runner.invoke(
        app, ["surrogate", "train", "--campaign", "999999", "--database-url", sqlite_url, "--out", str(tmp_path / "n")]
    )
    assert result.exit_code == 2 and result.output.strip() == "error: campaign: no campaign with id 999999"


def test_a_pool_built_by_hand_from_the_real_ocp_and_oracle_commands(tmp_path, quick_config):
    """One active-learning iteration by hand, every step a real `alcove` process: the files that
    `alcove ocp solve` and `alcove oracle run` write are a pool pair as they stand."""
    env = {k: v for k, v in os.environ.items() if k != "ALCOVE_DATABASE_URL"}

    def alcove(*args: str) -> subprocess.CompletedProcess:
        proc = subprocess.run([ALCOVE, *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, f"alcove {' '.join(args)}: {proc.stderr}"
        return proc

    alcove("surrogate", "preliminary", "--out", "pool", "--samples", "400", "--chunks", "4")
    alcove("ocp", "solve", "--contact", "aux", "--intervals", "40", "--out", "pool/iter1.traj.csv")
    alcove(
        "oracle",
        "run",
        "--oracle",
        "aux-penalty",
        "--trajectory",
        "pool/iter1.traj.csv",
        "--out",
        "pool/iter1.forces.csv",
    )
    summary = json.loads(
        alcove("surrogate", "train", "--pool", "pool", "--config", str(quick_config), "--out", "model", "--json").stdout
    )
    replayed = ForceSeries.from_csv(tmp_path / "pool" / "iter1.forces.csv")
    assert summary["datasets"] == 5 and sum(summary["samples"].values()) == 400 + len(replayed.t)
    from alcove.science.surrogate.artifact import load_artifact

    assert "iter1" in load_artifact(tmp_path / "model").lineage["datasets"]
    # the model goes back into the OCP: the next iteration's solve, then its prediction
    alcove("ocp", "solve", "--contact", "model:model", "--intervals", "40", "--out", "iter2.traj.csv")
    alcove("surrogate", "predict", "--model", "model", "--trajectory", "iter2.traj.csv", "--out", "iter2.pred.csv")
    pred = ForceSeries.from_csv(tmp_path / "iter2.pred.csv")
    assert len(pred.t) == len(Trajectory.from_csv(tmp_path / "iter2.traj.csv").t) and np.all(np.isfinite(pred.force))


def test_compare_trains_both_architectures_and_scores_them_on_the_suite(tmp_path, monkeypatch):
    """`alcove surrogate compare`: the suite replayed here (aux-penalty, 2 motions) and saved, then read
    back with --suite; the table has both columns, the gated model predicts no force with the gap open."""
    monkeypatch.chdir(tmp_path)
    invoke("surrogate", "preliminary", "--out", "pool", "--samples", "300", "--chunks", "3")
    Path("cfg.json").write_text(json.dumps({"max_epochs": 5, "batch_size": 128, "ensemble_size": 1}))
    result = invoke(
        "surrogate", "compare", "--pool", "pool", "--oracle", "aux-penalty", "--motions", "2",
        "--config", "cfg.json", "--suite-out", "suite",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "ghost |F| max, gap open [N]" in result.output and "gated" in result.output and "history" in result.output
    assert "fz RMSE [N]" in result.output
    assert len(list(Path("suite").glob("*.forces.csv"))) == 2
    result = invoke(
        "surrogate", "compare", "--pool", "pool", "--suite", "suite", "--config", "cfg.json", "--json",
        "--models-out", "models",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    paper, gated, history = out["scores"]
    assert (paper["variant"], gated["variant"], history["variant"], out["suite_motions"]) == (
        "paper",
        "gated",
        "history",
        2,
    )
    assert history["features"] == "history" and history["fz_rmse"] is not None
    assert gated["ghost_force_max"] == 0.0 and gated["grid_ghost_force_max"] == 0.0
    assert paper["oracle_force_open_max"] == 0.0 and paper["n_open_samples"] > 0
    assert json.loads(Path("models/gated/surrogate.json").read_text())["architecture"]["name"] == "gated"
    assert json.loads(Path("models/history/surrogate.json").read_text())["config"]["features"] == "history"
    assert Path("models/history/history_step.casadi").exists()
    result = runner.invoke(app, ["surrogate", "compare", "--pool", "pool", "--suite", "suite", "--variants", "paper,x"])
    assert result.exit_code == 2 and "error: variants:" in result.output and "'x' is not one" in result.output
    result = runner.invoke(app, ["surrogate", "compare", "--pool", "pool", "--suite", "pool"])
    assert result.exit_code == 2 and "error: suite: is the pool itself" in result.output


def test_train_and_predict_on_a_chain_pool(tmp_path):
    """A pool of the 2-DOF task's own trajectories (OCP solutions replayed by aux-penalty, which reads
    the head's pose): `surrogate train --task head-headrest-2dof` trains on features of the head's
    pose, and `surrogate predict` reads a 2-joint trajectory's pose columns. The model must explain
    the data: its force RMSE on a trajectory of the pool below a third of the force's RMS."""
    pool = tmp_path / "pool"
    pool.mkdir()
    for n in (40, 50, 60, 70):
        traj = pool / f"ocp{n}.traj.csv"
        solved = runner.invoke(
            app, ["ocp", "solve", "--task", "head-headrest-2dof", "--intervals", str(n), "--out", str(traj)]
        )
        assert solved.exit_code == 0, solved.output
        ran = runner.invoke(
            app,
            [
                "oracle",
                "run",
                "--oracle",
                "aux-penalty",
                "--trajectory",
                str(traj),
                "--out",
                str(pool / f"ocp{n}.forces.csv"),
            ],
        )
        assert ran.exit_code == 0, ran.output
    (tmp_path / "cfg.json").write_text(json.dumps({"max_epochs": 300, "ensemble_size": 2, "batch_size": 128}))
    trained = runner.invoke(
        app,
        [
            "surrogate",
            "train",
            "--pool",
            str(pool),
            "--task",
            "head-headrest-2dof",
            "--config",
            str(tmp_path / "cfg.json"),
            "--out",
            str(tmp_path / "m"),
            "--json",
        ],
    )
    assert trained.exit_code == 0, trained.output
    assert json.loads(trained.stdout)["ensemble_size"] == 2
    import casadi as ca

    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.features import N_FEATURES

    # a chain model's CasADi exports take the 19 features of the head's pose and give the model's mean
    force_fn = ca.Function.load(str(tmp_path / "m" / "force.casadi"))
    assert force_fn.name_in() == ["features"] and force_fn.size1_in(0) == N_FEATURES
    model = load_artifact(tmp_path / "m")
    x = model.input_norm.mean + model.input_norm.divisor * np.linspace(-1, 1, N_FEATURES)
    mean = model.predict_ensemble(x[None, :])
    np.testing.assert_allclose(np.asarray(force_fn(x)).ravel(), mean.force[0], rtol=0, atol=1e-10)
    predicted = runner.invoke(
        app,
        [
            "surrogate",
            "predict",
            "--model",
            str(tmp_path / "m"),
            "--trajectory",
            str(pool / "ocp60.traj.csv"),
            "--out",
            str(tmp_path / "p.csv"),
        ],
    )
    assert predicted.exit_code == 0, predicted.output
    pred = np.genfromtxt(tmp_path / "p.csv", delimiter=",", names=True)
    true = ForceSeries.from_csv(pool / "ocp60.forces.csv")
    err = np.c_[pred["fx"], pred["fy"], pred["fz"]] - true.force
    rms = np.sqrt(np.mean(np.sum(true.force**2, axis=1)))
    rmse = np.sqrt(np.mean(np.sum(err**2, axis=1)))
    assert rms > 1.0 and rmse < rms / 3, (rmse, rms)
    # the 1-DOF command `surrogate preliminary` still refuses a chain task, naming it
    refused = runner.invoke(
        app, ["surrogate", "preliminary", "--out", str(tmp_path / "pre"), "--task", "head-headrest-2dof"]
    )
    assert refused.exit_code == 2 and "task:" in refused.output


def test_a_history_model_from_oracle_replays_alone_predicts_and_solves(tmp_path, monkeypatch):
    """The CLI contract of the history feature set: `surrogate train` with {"features": "history"}
    on a pool folder of oracle replays only (no preliminary data), `surrogate predict` computes the
    history states from the trajectory itself (as alcove's prediction along it), and `ocp solve
    --contact model:DIR` carries them in the OCP."""
    from alcove.science.oracles.aux_penalty import AuxPenaltyOracle
    from alcove.science.press_family import PressFamily, family_motions
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.training import predict_ensemble

    monkeypatch.chdir(tmp_path)
    Path("pool").mkdir()
    motions = family_motions(PressFamily(), 7, 11, (DEFAULT_PRESET.theta_min, DEFAULT_PRESET.theta_max))
    oracle = AuxPenaltyOracle()
    for i, m in enumerate(motions[:6]):
        tr = m.trajectory(0.005)
        tr.to_csv(Path(f"pool/press{i}.traj.csv"))
        oracle.run(tr).forces.to_csv(Path(f"pool/press{i}.forces.csv"))
    Path("cfg.json").write_text(json.dumps({"features": "history", "max_epochs": 20, "ensemble_size": 2}))
    result = invoke("surrogate", "train", "--pool", "pool", "--config", "cfg.json", "--seed", "3", "--out", "model")
    assert result.exit_code == 0, result.output
    model = load_artifact(Path("model"))
    assert model.config.features == "history"
    held = motions[6].trajectory(0.005)
    held.to_csv(Path("held.traj.csv"))
    result = invoke("surrogate", "predict", "--model", "model", "--trajectory", "held.traj.csv", "--out", "pred.csv")
    assert result.exit_code == 0, result.output
    got = np.loadtxt("pred.csv", delimiter=",", skiprows=1)
    want = predict_ensemble(model, held.q, held.qd, t=held.t)
    np.testing.assert_allclose(got[:, 1:4], want.force, rtol=1e-9, atol=1e-9)
    result = invoke("ocp", "solve", "--contact", "model:model", "--intervals", "40", "--out", "sol.traj.csv", "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output[result.output.index("{") :])["status"] == "Solve_Succeeded"
