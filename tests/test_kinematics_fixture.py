"""The web UI draws chains and plays trajectories back with its own forward kinematics
(frontend/src/lib/kinematics.ts); Vitest checks it against frontend/src/lib/kinematics.fixture.json,
the backend's numbers for every model preset and two user-defined models. This test keeps that
file current: it recomputes it with the backend (scripts/kinematics_fixture.py) and compares.
Regenerate with ``.venv/bin/python scripts/kinematics_fixture.py``."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _script() -> Any:
    spec = importlib.util.spec_from_file_location("kinematics_fixture", REPO / "scripts" / "kinematics_fixture.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _numbers(x: Any) -> list[float]:
    if isinstance(x, dict):
        return [v for k in sorted(x) for v in _numbers(x[k])]
    if isinstance(x, list):
        return [v for item in x for v in _numbers(item)]
    return [float(x)] if isinstance(x, (int, float)) and not isinstance(x, bool) else []


def _shape(x: Any) -> Any:
    """The structure with numbers replaced (names, keys, lengths stay)."""
    if isinstance(x, dict):
        return {k: _shape(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_shape(v) for v in x]
    return "#" if isinstance(x, (int, float)) and not isinstance(x, bool) else x


def test_the_frontend_kinematics_fixture_is_what_the_backend_computes() -> None:
    script = _script()
    stored = json.loads(script.FIXTURE.read_text())
    fresh = json.loads(json.dumps(script.fixture()))
    assert _shape(stored) == _shape(fresh), "regenerate: .venv/bin/python scripts/kinematics_fixture.py"
    # threshold: 1e-12 m / rad (float round-off of the same formulas; a changed model moves mm)
    np.testing.assert_allclose(_numbers(stored), _numbers(fresh), rtol=0, atol=1e-12)


def test_the_fixture_covers_every_model_preset_and_poses_in_and_out_of_contact() -> None:
    from alcove.science.ocp.task_spec import ModelSpec

    stored = json.loads(_script().FIXTURE.read_text())
    presets = set(ModelSpec.model_fields["preset"].annotation.__args__) - {"chain"}  # type: ignore[union-attr]
    names = {c["name"] for c in stored["cases"]}
    assert presets <= names
    assert any(c["model"]["preset"] == "chain" for c in stored["cases"])
    gaps = [s["gap"] for c in stored["cases"] for s in c["states"]]
    assert min(gaps) < 0 < max(gaps)  # the drawing is checked with the head clear and pressed in
