#!/usr/bin/env python3
"""Write the backend's kinematics of each model preset (and of two user-defined chains) for a few
joint poses into ``frontend/src/lib/kinematics.fixture.json``: the web UI's TypeScript forward
kinematics (``frontend/src/lib/kinematics.ts``, which draws the chain and plays trajectories
back) is tested against these numbers by Vitest, and ``tests/test_kinematics_fixture.py``
fails when the file no longer matches what the backend computes.

The numbers come from the CasADi chain the OCP uses (:class:`alcove.science.multibody.PlanarChain`:
joint positions, COGs, the contact body's pose, its pose in the headrest frame) and the signed
gap of :mod:`alcove.science.geometry` (1-DOF) or :mod:`alcove.science.ocp.chain_model` (chains).

    .venv/bin/python scripts/kinematics_fixture.py        # rewrite the file
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
FIXTURE = REPO / "frontend" / "src" / "lib" / "kinematics.fixture.json"

#: a user-defined chain exercising every option of the kinematics: base pose, a COG off the link
#: axis, the head on a middle link at a given origin and tilt, a custom profile, a headrest origin
CUSTOM_CHAIN: dict[str, Any] = {
    "preset": "chain",
    "chain": {
        "links": [
            {"name": "lower", "mass": 2.0, "com": [0.01, 0.05], "inertia_com": 0.004, "length": 0.11},
            {"name": "head", "mass": 4.0, "com": [0.02, 0.07], "inertia_com": 0.02, "length": 0.09},
            {"name": "tip", "mass": 0.5, "com": [0.0, 0.02], "inertia_com": 0.0005, "length": 0.0},
        ],
        "joints": [
            {"name": "a", "q_min": -0.5, "q_max": 0.6, "q0": 0.1, "torque_limit": 30.0},
            {"name": "b", "q_min": -0.4, "q_max": 0.4, "q0": 0.05, "torque_limit": 20.0},
            {"name": "c", "q_min": -0.3, "q_max": 0.3, "q0": 0.0, "torque_limit": 5.0},
        ],
        "base": {"x": 0.03, "z": 0.4, "angle": 0.12},
        "contact_body": {
            "link": 1,
            "origin": [0.015, 0.06],
            "angle": -0.1,
            "profile": {"cx": 0.005, "cz": -0.04, "ax": 0.09, "az": 0.105},
        },
        "headrest": {"tilt": 0.25, "origin": [-0.22, 0.55]},
    },
}

#: the head-neck-1dof preset with its headrest moved and tilted (a scenario's headrest)
MOVED_HEADREST: dict[str, Any] = {
    "preset": "head-neck-1dof",
    "tilt": 0.2,
    "theta_contact": 0.3,
    "headrest_offset": 0.004,
}


def _models() -> list[tuple[str, dict[str, Any]]]:
    from alcove.tasks.service import model_presets

    out = [(p["key"], p["model"]) for p in model_presets()]
    out.append(("head-neck-1dof, headrest moved and tilted", MOVED_HEADREST))
    out.append(("chain: base pose, head on a middle link, headrest origin", CUSTOM_CHAIN))
    return out


def _poses(lo: np.ndarray, hi: np.ndarray, q0: np.ndarray) -> list[np.ndarray]:
    rng = np.random.default_rng(18)
    return [q0, lo, hi, lo + rng.uniform(0, 1, lo.size) * (hi - lo)]


def _case(name: str, raw: dict[str, Any]) -> dict[str, Any]:
    from alcove.science.geometry import signed_gap
    from alcove.science.ocp.task_spec import ModelSpec

    model = ModelSpec.model_validate(raw)
    chain = model.to_chain()
    states = []
    for q in _poses(model.joint_min, model.joint_max, model.q_initial):
        qd = np.zeros_like(q)
        joints = [np.asarray(p, float).ravel().tolist() for p in chain.joint_positions(q)]
        coms = [np.asarray(p, float).ravel().tolist() for p in chain.com_positions(q)]
        origin, angle = chain.contact_pose_world(q)
        pose = chain.head_pose(q.reshape(1, -1), qd.reshape(1, -1))[0]
        gap = model.chain.head_gap(q) if model.chain is not None else float(signed_gap(model.to_preset(), q[0])[0])
        states.append(
            {
                "q": q.tolist(),
                "joints": joints,
                "coms": coms,
                "head_origin": np.asarray(origin, float).ravel().tolist(),
                "head_angle": float(angle),
                "head_in_headrest": pose[:3].tolist(),
                "gap": float(gap),
            }
        )
    return {
        "name": name,
        "model": model.model_dump(mode="json"),
        "headrest": {"origin": list(chain.headrest.origin), "tilt": chain.headrest.tilt},
        "states": states,
    }


def fixture() -> dict[str, Any]:
    return {
        "generated_by": "scripts/kinematics_fixture.py",
        "units": "m, rad; world x forward, z up; head_in_headrest = (head_x, head_z, head_angle) in H",
        "cases": [_case(name, raw) for name, raw in _models()],
    }


def main() -> None:
    FIXTURE.write_text(json.dumps(fixture(), indent=1) + "\n")
    print(f"wrote {FIXTURE.relative_to(REPO)}")


if __name__ == "__main__":
    main()
