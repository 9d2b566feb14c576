"""The whole product over HTTP against real PostgreSQL + Redis with a real worker process:
create a task, an oracle (aux-penalty, fast) and a surrogate config, create and start a
campaign with few OCP intervals, watch iterations appear through incremental polling,
then download the pool (Parquet + CSV), the model (JSON artifact and zip with TorchScript,
built by the worker on queue artifacts: 202 with the build, polled until ready, then the zip)
and the export zip, and load them."""

from __future__ import annotations

import io
import json
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.helpers import download_when_built, make_account

pytestmark = [pytest.mark.integration, pytest.mark.slow]

API = "/api/v1"


@pytest.fixture
def live(tmp_path: Path, fresh_pg_url: str, redis_url: str, api_settings: None, monkeypatch: pytest.MonkeyPatch):
    """The API (in this process) and a worker process sharing PostgreSQL and Redis."""
    from alcove.app import create_app
    from alcove.jobs import reset_sender
    from alcove.settings import get_settings
    from tests.procs import alcove_env, running, unique, wait_until, worker_ready

    prefix = unique("alcove-api") + ":"
    settings = {
        "database_url": fresh_pg_url,  # workers take up every unfinished job in their database
        "broker_url": redis_url,
        "broker_key_prefix": prefix,
        "data_dir": str(tmp_path / "data"),
        "artifact_builds": "1",  # one build at a time: the model zip and the export below queue for it
    }
    for k, v in settings.items():
        monkeypatch.setenv(f"ALCOVE_{k.upper()}", v)
    get_settings.cache_clear()
    reset_sender()
    env = alcove_env(**settings)
    with running(
        [
            "worker",
            "--queues",
            "ocp,oracle,train,default,artifacts",
            "--concurrency",
            "2",
            "--name",
            unique("api-life"),
        ],
        env,
        tmp_path / "worker.log",
    ) as worker:
        wait_until(lambda: worker_ready(worker), 90, "worker ready", worker)
        yield TestClient(create_app(get_settings().model_copy(update={"static_dir": tmp_path}))), worker
    get_settings.cache_clear()
    reset_sender()


def test_full_campaign_lifecycle_over_http(live) -> None:
    from alcove.settings import get_settings
    from tests.procs import db_rows

    client, worker = live
    me = make_account("member", "life")
    h = me.headers

    def ok(r, code: int = 200):
        assert r.status_code == code, (r.status_code, r.text[:2000])
        return r.json() if "json" in r.headers.get("content-type", "") else r

    task = ok(client.post(f"{API}/tasks/presets/head-headrest-2phase/copy", json={"name": "poc"}, headers=h), 201)
    oracle = ok(
        client.post(f"{API}/oracles", json={"name": "aux", "type": "aux-penalty", "params": {}}, headers=h), 201
    )
    surrogate = ok(
        client.post(
            f"{API}/surrogate-configs",
            json={"name": "quick", "spec": {"max_epochs": 60, "ensemble_size": 2}},
            headers=h,
        ),
        201,
    )
    body = {
        "name": "lifecycle",
        "task_id": task["id"],
        "oracle_id": oracle["id"],
        "surrogate_config_id": surrogate["id"],
        "seed": 3,
        "preliminary": {"samples": 400, "chunks": 4},
        "settings": {
            "ocp_intervals": 20,
            "replay_dt": 0.01,
            "validation_motions": 2,
            "validation_reference_motions": 0,
        },
        "stopping": {"max_iterations": 2},
        "start": True,
    }
    campaign = ok(client.post(f"{API}/campaigns", json=body, headers=h), 201)
    cid = campaign["id"]
    assert campaign["campaign"]["status"] in ("queued", "running")

    # poll like the dashboard: only new iterations each time
    seen: dict[int, dict] = {}
    after = None
    deadline = time.monotonic() + 600
    status = None
    while time.monotonic() < deadline:
        fresh = ok(
            client.get(f"{API}/campaigns/{cid}/metrics", params={} if after is None else {"after": after}, headers=h)
        )
        assert all(after is None or m["iteration_index"] > after for m in fresh)
        for m in fresh:
            seen[m["iteration_index"]] = m
        if seen:
            after = max(seen)
        status = ok(client.get(f"{API}/campaigns/{cid}", headers=h))["campaign"]["status"]
        if status in ("completed", "failed", "cancelled"):
            break
        time.sleep(1.0)
    assert status == "completed", worker.output()[-4000:]
    fresh = ok(client.get(f"{API}/campaigns/{cid}/metrics", params={"after": after}, headers=h))
    for m in fresh:
        seen[m["iteration_index"]] = m
    assert sorted(seen) == [1, 2] and all(np.isfinite(m["force_rmse"]) for m in seen.values())
    detail = ok(client.get(f"{API}/campaigns/{cid}", headers=h))
    assert detail["campaign"]["stop_reason"] == "max_iterations" and detail["latest_metrics"]["iteration_index"] == 2

    # the curves of one iteration: the RMSE recomputed from them is the reported one
    curves = ok(client.get(f"{API}/campaigns/{cid}/iterations/2/curves", headers=h))
    f_true, f_pred = np.array(curves["f_true"]), np.array(curves["f_pred"])
    assert f_true.shape == f_pred.shape == (len(curves["t"]), 6)
    # the RMSE of the force error vector (docs/concepts.md)
    assert np.sqrt(np.mean(np.sum((f_true[:, :3] - f_pred[:, :3]) ** 2, axis=1))) == pytest.approx(
        seen[2]["force_rmse"], rel=1e-6
    )
    # the trajectory part carries the replayed motion's torque on the same grid
    tau = np.array(curves["tau"])
    assert tau.shape == np.array(curves["q"]).shape and np.all(np.isfinite(tau)) and np.abs(tau).max() > 0

    # the iteration's whole OCP solution: both phases on the OCP grid (20 intervals per phase);
    # at the OCP nodes of the replayed phase the replayed motion (interpolated through the
    # nodes, on the 0.01 s grid) is the solution itself
    traj = ok(client.get(f"{API}/campaigns/{cid}/iterations/2/trajectory", headers=h))
    t, q, tau_ocp = np.array(traj["t"]), np.array(traj["q"]), np.array(traj["tau"])
    assert (
        [p["name"] for p in traj["phases"]] == ["approach", "rest"]
        and len(t) == 2 * 20 + 1
        and q.shape == tau_ocp.shape == (41, 1)
    )
    assert (
        t[-1] - t[0]
        == pytest.approx(traj["duration"])
        == pytest.approx(sum(p["duration"] for p in traj["phases"]))
        == pytest.approx(2.0)
    )
    assert traj["replay_phases"] == 1 and traj["replay_t_end"] == pytest.approx(1.0) == pytest.approx(curves["t"][-1])
    assert traj["solver"]["converged"] and traj["solver"]["iterations"] > 0 and np.isfinite(traj["solver"]["cost"])
    ct, cq = np.array(curves["t"]), np.array(curves["q"])
    replayed = np.flatnonzero(t <= traj["replay_t_end"] + 1e-9)
    at = [int(np.argmin(np.abs(ct - t[i]))) for i in replayed]
    np.testing.assert_allclose(ct[at], t[replayed], atol=1e-9)
    np.testing.assert_allclose(cq[at], q[replayed], atol=1e-7)
    np.testing.assert_allclose(tau[at], tau_ocp[replayed], atol=1e-7)
    assert client.get(f"{API}/campaigns/{cid}/iterations/0/trajectory", headers=h).status_code == 404

    jobs = ok(client.get(f"{API}/campaigns/{cid}/jobs", headers=h))
    assert {(j["iteration"], j["step"]) for j in jobs} >= {(0, "preliminary"), (1, "train"), (2, "append")}
    assert all(j["status"] == "succeeded" and j["worker_name"] for j in jobs)

    # pool versions: lineage and downloads
    pools = ok(client.get(f"{API}/campaigns/{cid}/pool-versions", headers=h))
    assert [p["version"] for p in pools] == [0, 1, 2]
    assert pools[2]["parent_id"] == pools[1]["id"] and pools[1]["parent_id"] == pools[0]["id"]
    import pyarrow.parquet as pq

    parquet = client.get(f"{API}/campaigns/{cid}/pool-versions/2/download", params={"format": "parquet"}, headers=h)
    table = pq.read_table(io.BytesIO(parquet.content))
    assert table.num_rows == pools[2]["n_samples"]
    csv = client.get(f"{API}/campaigns/{cid}/pool-versions/2/download", params={"format": "csv"}, headers=h)
    lines = csv.text.strip().splitlines()
    assert len(lines) - 1 == pools[2]["n_samples"] and lines[0].startswith("dataset_id,")
    np.testing.assert_allclose(
        [float(x.split(",")[table.column_names.index("fx")]) for x in lines[1:]], table.column("fx").to_numpy()
    )

    # model versions: JSON artifact and the zip (TorchScript) load to the same model
    models = ok(client.get(f"{API}/campaigns/{cid}/model-versions", headers=h))
    assert [m["version"] for m in models] == [1, 2] and models[1]["parent_model_id"] in (None, models[0]["id"])
    assert models[1]["pool_version_id"] == pools[1]["id"]
    doc = ok(client.get(f"{API}/campaigns/{cid}/model-versions/2/artifact", headers=h))
    # the zips are built by the worker (queue artifacts): the model's and the export's downloads,
    # asked at once, are two builds (202) run one after the other in the one build slot (the second
    # job finds the slot taken and runs again, then builds what the first did not store)
    first = client.get(f"{API}/campaigns/{cid}/model-versions/2/artifact.zip", headers=h)
    assert first.status_code == 202 and first.json()["models_total"] == 1, first.text
    export_first = client.get(f"{API}/campaigns/{cid}/export", params={"pool_format": "csv"}, headers=h)
    assert export_first.status_code == 202 and export_first.json()["models_total"] == 2, export_first.text
    most_running, deadline = 0, time.monotonic() + 240
    while time.monotonic() < deadline:
        statuses = [r[0] for r in db_rows(get_settings().database_url, "SELECT status FROM artifact_builds")]
        most_running = max(most_running, statuses.count("running"))
        if all(st in ("ready", "failed") for st in statuses):
            break
        time.sleep(0.05)
    assert statuses == ["ready", "ready"] and most_running == 1, (statuses, most_running, worker.output()[-4000:])
    assert "retry" in worker.output().lower()  # the second job found the slot taken
    zipped = download_when_built(client, f"{API}/campaigns/{cid}/model-versions/2/artifact.zip", h)
    assert zipped.status_code == 200, zipped.text[:2000]
    import torch

    from alcove.science.surrogate.artifact import load_artifact, model_from_dict

    folder = Path(worker.log).parent / "model"
    with zipfile.ZipFile(io.BytesIO(zipped.content)) as zf:
        assert {"surrogate.json", "force.pt", "moment.pt", "force.casadi", "force.onnx"} <= set(zf.namelist())
        zf.extractall(folder)
    x = np.random.default_rng(0).normal(size=(7, 19))
    from_zip, from_json = load_artifact(folder), model_from_dict(doc)
    np.testing.assert_allclose(from_zip.predict_features(x)[0], from_json.predict_features(x)[0])
    scripted = torch.jit.load(str(folder / "force.pt"))
    assert scripted(torch.as_tensor(x, dtype=torch.float64)).shape == (7, 3)

    export = download_when_built(client, f"{API}/campaigns/{cid}/export", h, params={"pool_format": "csv"})
    assert export.status_code == 200, export.text[:2000]
    names = zipfile.ZipFile(io.BytesIO(export.content)).namelist()
    assert (
        f"campaign-{cid}/metrics.csv" in names
        and f"campaign-{cid}/pool/version-0002.csv" in names
        and f"campaign-{cid}/models/model-0002.zip" in names
    )
    meta = json.loads(zipfile.ZipFile(io.BytesIO(export.content)).read(f"campaign-{cid}/campaign.json"))
    assert meta["campaign"]["id"] == cid
