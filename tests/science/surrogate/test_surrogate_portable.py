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
