"""Portable exports: the CasADi and ONNX files load and match PyTorch in a process that never imports alcove."""

import json
import subprocess
import sys

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import relative_kinematics, signed_gap
from alcove.science.surrogate.artifact import save_artifact
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.features import features
from alcove.science.surrogate.portable import ExportError, check_onnx, onnx_model
from alcove.science.surrogate.training import train_surrogate

CASADI_TOL = 1e-10  # |casadi - torch| / max(1, |torch|), float64 weights on both sides
ONNX_RTOL = 1e-6  # |onnx - torch| / max(1, |torch|)

# runs in a fresh interpreter: casadi, onnxruntime and numpy only
_CONSUMER = r"""
import json, sys
import numpy as np
import casadi
import onnxruntime
root, data = sys.argv[1], json.load(open(sys.argv[2]))
q, qd, x = np.array(data["q"]), np.array(data["qd"]), np.array(data["features"])
out = {}
for net in ("force", "moment"):
    f = casadi.Function.load(f"{root}/{net}.casadi")
    out[net] = [np.array(f(q[i], qd[i])).ravel().tolist() for i in range(len(q))]
    if data["k"] > 1:
        s = casadi.Function.load(f"{root}/{net}_std.casadi")
        out[net + "_std"] = [np.array(s(q[i], qd[i])[0]).ravel().tolist() for i in range(len(q))]
    sess = onnxruntime.InferenceSession(f"{root}/{net}.onnx", providers=["CPUExecutionProvider"])
    res = sess.run(None, {"features": x})
    out[net + "_onnx"] = res[0].tolist()
    if data["k"] > 1:
        out[net + "_std_onnx"] = res[1].tolist()
assert not any(m == "alcove" or m.startswith("alcove.") for m in sys.modules), "alcove was imported"
print(json.dumps(out))
"""


@pytest.fixture(
    scope="module",
    params=[("paper", 1), ("paper", 3), ("gated", 1), ("gated", 3)],
    ids=["K=1", "K=3", "gated-K=1", "gated-K=3"],
)
def exported(request, smooth_pool, contact_pool, tmp_path_factory):
    architecture, k = request.param
    pool = contact_pool if architecture == "gated" else smooth_pool
    cfg = SurrogateConfig(max_epochs=5, batch_size=128, ensemble_size=k, architecture=architecture)
    model = train_surrogate(pool, cfg, seed=2).model
    root = tmp_path_factory.mktemp(f"export-{architecture}-{k}")
    save_artifact(model, root, exports=True)
    return model, root


def _states(n=40):
    rng = np.random.default_rng(3)
    q = rng.uniform(0.0, 0.5, n)
    qd = rng.uniform(-3.0, 3.0, n)
    q[0], q[1], qd[1] = P.tilt, P.tilt, 0.0  # alpha = 0 (head aligned with the headrest), at rest and moving
    q[2] = P.tilt + 1e-3  # the small-angle branch of alpha^2
    return q, qd


def test_exports_load_and_match_pytorch_without_alcove(exported, tmp_path):
    model, root = exported
    k = model.ensemble_size
    expected = sorted(
        ["force.casadi", "moment.casadi", "force.onnx", "moment.onnx", "force.pt", "moment.pt", "surrogate.json"]
        + (["force_std.casadi", "moment_std.casadi"] if k > 1 else [])
    )
    assert sorted(p.name for p in root.iterdir()) == expected
    q, qd = _states()
    x = features(relative_kinematics(P, q, qd))
    assert x[0, 17] == 0.0 and x[1, 17] == 0.0  # alpha_sq
    gap = signed_gap(P, q)
    assert (gap >= 0.002).sum() > 5 and (gap <= 0).sum() > 5  # states with the gap clearly open and closed
    data = tmp_path / "states.json"
    data.write_text(json.dumps({"q": q.tolist(), "qd": qd.tolist(), "features": x.tolist(), "k": k}))
    run = subprocess.run(
        [sys.executable, "-c", _CONSUMER, str(root), str(data)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout)
    p = model.predict_ensemble(x)
    for net in ("force", "moment"):
        want = {net: getattr(p, net), f"{net}_std": getattr(p, f"{net}_std")}
        for key in [net, f"{net}_std"] if k > 1 else [net]:
            scale = np.maximum(1.0, np.abs(want[key]))
            assert np.max(np.abs(np.array(got[key]) - want[key]) / scale) <= CASADI_TOL, key
            assert np.max(np.abs(np.array(got[key + "_onnx"]) - want[key]) / scale) <= ONNX_RTOL, key + " onnx"
            if model.architecture == "gated":  # exactly zero where the gap is clearly open, in every file
                for suffix in ("", "_onnx"):
                    assert np.all(np.array(got[key + suffix])[gap >= 0.002] == 0.0), key + suffix


def test_a_wrong_onnx_graph_is_refused(exported):
    model, _ = exported
    other = train_surrogate(
        __import__("conftest").make_smooth_pool(8, seed=9), SurrogateConfig(max_epochs=2, ensemble_size=1), seed=1
    ).model
    x = model.input_norm.mean + np.zeros((4, 19))
    with pytest.raises(ExportError, match=r"^force.onnx: differs from PyTorch"):
        check_onnx(model, "force", onnx_model(other, "force"), x)


# runs in a fresh interpreter: the history model's files along one motion, casadi, onnxruntime and numpy only
_HISTORY_CONSUMER = r"""
import json, sys
import numpy as np
import casadi
import onnxruntime
root, data = sys.argv[1], json.load(open(sys.argv[2]))
q, qd, t, x = (np.array(data[k]) for k in ("q", "qd", "t", "features"))
step = casadi.Function.load(f"{root}/history_step.casadi")
force = casadi.Function.load(f"{root}/force.casadi")
z = [np.array(data["z0"])]
for k in range(1, len(t)):
    z.append(np.array(step(z[-1], q[k], qd[k], t[k] - t[k - 1])).ravel())
out = {"z": np.array(z).tolist(), "force": [np.array(force(q[k], qd[k], z[k])).ravel().tolist() for k in range(len(t))]}
ostep = onnxruntime.InferenceSession(f"{root}/history_step.onnx", providers=["CPUExecutionProvider"])
zo = [np.array(data["z0"])[None, :]]
for k in range(1, len(t)):
    zo.append(ostep.run(None, {"z": zo[-1], "features": x[k : k + 1], "dt": np.array([[t[k] - t[k - 1]]])})[0])
zo = np.vstack(zo)
onet = onnxruntime.InferenceSession(f"{root}/force.onnx", providers=["CPUExecutionProvider"])
out["z_onnx"] = zo.tolist()
out["force_onnx"] = onet.run(None, {"features": np.hstack([x, zo])})[0].tolist()
assert not any(m == "alcove" or m.startswith("alcove.") for m in sys.modules), "alcove was imported"
print(json.dumps(out))
"""


def test_a_history_models_exports_carry_its_state_update_without_alcove(tmp_path):
    """The history states' update and the networks with the states as inputs, loaded in a process
    that never imports alcove, reproduce alcove's prediction along a press with a release:
    CasADi to 1e-10, ONNX to 1e-6 (relative to max(1, |value|))."""
    from alcove.science.press_family import PressFamily, family_motions
    from alcove.science.surrogate.dataset import PoolDataset
    from alcove.science.surrogate.history import history_states, steady_history
    from alcove.science.surrogate.training import predict_ensemble

    motions = [m.trajectory(0.005) for m in family_motions(PressFamily(), 6, 4, (P.theta_min, P.theta_max))]
    pool = []
    for i, tr in enumerate(motions[:5]):
        kin = relative_kinematics(P, tr.q[:, 0], tr.qd[:, 0])
        z = history_states(P, kin, tr.t, SurrogateConfig().history)
        force = np.column_stack([1e4 * z[:, 0], np.zeros(len(tr.t)), 20 * np.tanh(z[:, 2] / 5e-3)])
        pool.append(PoolDataset(f"m{i}", tr.t, tr.q, tr.qd, force, 0.01 * force))
    cfg = SurrogateConfig(max_epochs=5, batch_size=128, ensemble_size=2, features="history")
    model = train_surrogate(pool, cfg, seed=2, preset=P).model
    root = tmp_path / "model"
    save_artifact(model, root, exports=True)
    assert {"history_step.casadi", "history_step.onnx"} <= {p.name for p in root.iterdir()}
    tr = motions[5]
    kin = relative_kinematics(P, tr.q[:, 0], tr.qd[:, 0])
    want_z = history_states(P, kin, tr.t, model.config.history)
    data = tmp_path / "motion.json"
    payload = {"q": tr.q[:, 0], "qd": tr.qd[:, 0], "t": tr.t, "features": features(kin)}
    payload["z0"] = steady_history(P, kin, model.config.history)[0]
    data.write_text(json.dumps({k: np.asarray(v).tolist() for k, v in payload.items()}))
    run = subprocess.run(
        [sys.executable, "-c", _HISTORY_CONSUMER, str(root), str(data)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    got = json.loads(run.stdout)
    want_force = predict_ensemble(model, tr.q, tr.qd, t=tr.t).force
    assert want_z[:, 0].max() > 1e-3 and np.ptp(want_z[:, 2]) > 0  # it presses and slips
    for key, want, tol in (
        ("z", want_z, CASADI_TOL),
        ("force", want_force, CASADI_TOL),
        ("z_onnx", want_z, ONNX_RTOL),
        ("force_onnx", want_force, ONNX_RTOL),
    ):
        assert np.max(np.abs(np.array(got[key]) - want) / np.maximum(1.0, np.abs(want))) <= tol, key
