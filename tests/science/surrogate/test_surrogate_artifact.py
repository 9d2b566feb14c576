"""Self-contained artifact: JSON + TorchScript, loads without a database, same predictions."""

import json

import numpy as np
import pytest
import torch

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics
from alcove.science.surrogate.artifact import ArtifactError, load_artifact, save_artifact
from alcove.science.surrogate.features import features
from alcove.science.surrogate.training import predict_arrays


@pytest.mark.filterwarnings("ignore:.*torch.jit.load.*:DeprecationWarning")
def test_round_trip_is_exact(tmp_path, trained_smooth):
    model = trained_smooth.model
    root = save_artifact(model, tmp_path / "model", lineage={"campaign": 7, "iteration": 3, "pool_version": 4})
    assert sorted(p.name for p in root.iterdir()) == ["force.pt", "moment.pt", "surrogate.json"]
    doc = json.loads((root / "surrogate.json").read_text())
    assert doc["networks"]["force"]["hidden"] == [6, 6, 4] and doc["networks"]["moment"]["hidden"] == [6, 6, 6, 4]
    assert doc["lineage"]["campaign"] == 7 and doc["lineage"]["seed"] == 0 and "metrics" in doc["lineage"]
    assert len(doc["feature_names"]) == 19
    loaded = load_artifact(root)
    for a, b in zip(model.force_net.parameters(), loaded.force_net.parameters(), strict=False):
        assert torch.equal(a, b)
    q = np.linspace(0.05, 0.43, 30)
    qd = np.linspace(-2, 2, 30)
    f0, m0 = predict_arrays(model, q, qd)
    f1, m1 = predict_arrays(loaded, q, qd)
    assert np.array_equal(f0, f1) and np.array_equal(m0, m1)
    assert loaded.preset == DEFAULT_PRESET and loaded.config == model.config
    # TorchScript: raw features in, physical force/moment out
    x = torch.as_tensor(features(relative_kinematics(DEFAULT_PRESET, q, qd)))
    force_ts = torch.jit.load(str(root / "force.pt"))
    moment_ts = torch.jit.load(str(root / "moment.pt"))
    with torch.no_grad():
        np.testing.assert_allclose(force_ts(x).numpy(), f0, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(moment_ts(x).numpy(), m0, rtol=1e-13, atol=1e-12)


def test_bad_artifacts_give_clear_errors(tmp_path, trained_smooth):
    with pytest.raises(ArtifactError, match=r"^model: .* does not exist"):
        load_artifact(tmp_path / "nothing")
    root = save_artifact(trained_smooth.model, tmp_path / "m")
    doc = json.loads((root / "surrogate.json").read_text())
    (root / "surrogate.json").write_text("{not json")
    with pytest.raises(ArtifactError, match=r"^surrogate.json: not valid JSON"):
        load_artifact(root)
    for mutate, match in [
        (lambda d: d.update(format="other"), "^format: expected"),
        (lambda d: d.update(format_version=99), "^format_version: unsupported"),
        (lambda d: d["networks"]["force"]["layers"].pop(), "^networks.force.layers: has 3 layers"),
        (lambda d: d["networks"]["moment"]["layers"][0].update(bias=[0.0]), "^networks.moment.layers.0: weight"),
        (lambda d: d.pop("normalization"), "^normalization: missing"),
        (lambda d: d["config"].update(batch_size=0), "^batch_size: "),
    ]:
        bad = json.loads(json.dumps(doc))
        mutate(bad)
        (root / "surrogate.json").write_text(json.dumps(bad))
        with pytest.raises((ArtifactError, ValueError), match=match):
            load_artifact(root)
