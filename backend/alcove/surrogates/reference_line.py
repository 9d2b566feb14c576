"""The best-possible line of a validation suite: what a model could know at each oracle budget.

A suite with ``reference_motions`` n (``SuiteSpec``) has n more motions, the first n of its core
box's space-filling sequence (:func:`alcove.science.press_family.sequence_motion`), replayed by the
oracle with the suite's other motions and never scored. Once the suite is complete, for each budget
B of :func:`alcove.science.validation_suite.reference_budgets` (4, 8, 16, ... and n) an ensemble of
the default surrogate configuration is trained from scratch on the first B of those replays
alone (FE data only: no preliminary data) and scored on the suite's core motions like a model
version. A campaign's curves show the line at those oracle budgets: the error its models could
reach with the same number of oracle calls spent on motions spread over the suite's range.

The line is computed once per suite (shared like the suite) by the suite's evaluation job
(``alcove.default.validation_evaluate``: :func:`alcove.surrogates.validation.evaluate_suite`, then
:func:`compute_reference_line`), and stored as ``validation_suites.reference``.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from alcove.models import SuiteStatus, ValidationSuite
from alcove.science.series import split_wrench

log = logging.getLogger(__name__)

#: the training seed of the reference models (the suite's seed is the motions')
REFERENCE_SEED = 0


def reference_line(
    reference: list[dict[str, Any]],
    scored: list[dict[str, Any]],
    budgets: list[int],
    kinematics: Any,
    preset: Any,
    seed: int = REFERENCE_SEED,
    config: Any = None,
) -> dict[str, Any]:
    """The line from the reference replays (``reference``, the succeeded ones in sequence order;
    arrays t, q, qd, f) and the scored motions ``scored``: per budget, the metrics row of a model
    trained on the first ``budget`` replays (:func:`alcove.surrogates.validation._metrics`), with
    training seed ``seed``; ``config``: the surrogate configuration (default: alcove's)."""
    import numpy as np

    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.dataset import PoolDataset
    from alcove.science.surrogate.training import train_surrogate
    from alcove.surrogates.validation import _metrics

    config = SurrogateConfig() if config is None else config
    pool = [
        PoolDataset(
            name=f"reference-{i}",
            t=np.asarray(a["t"]),
            q=np.asarray(a["q"]),
            qd=np.asarray(a["qd"]),
            force=split_wrench(a["f"])[0],
            moment=split_wrench(a["f"])[1],
        )
        for i, a in enumerate(reference)
    ]
    points = []
    for b in budgets:
        t0 = time.perf_counter()
        model = train_surrogate(pool[:b], config, seed=seed, preset=preset, kinematics=kinematics).model
        m = _metrics(model, scored, kinematics)
        points.append(
            {
                "budget": b,
                "force_rmse": m["force_rmse"],
                "moment_rmse": m["moment_rmse"],
                "components": m["components"],
                "calibration": m["calibration"],
                "train_s": time.perf_counter() - t0,
            }
        )
    return {
        "points": points,
        "protocol": {
            "surrogate": "default configuration, trained from scratch",
            "seed": seed,
            "ensemble_size": config.ensemble_size,
            "normal_force": config.normal_force,  # a stored line without it was trained with the shared net
            "data": "the first B reference replays only (no preliminary data)",
        },
    }


def compute_reference_line(suite_id: int) -> bool:
    """Compute and store a complete suite's line if it asks for one and has none yet; whether it
    wrote one (a concurrent job that wrote first wins; both compute the same line)."""
    from alcove.db import open_transaction, run_transaction
    from alcove.science.ocp.task_spec import ModelSpec
    from alcove.science.validation_suite import ChainSuiteModel, SuiteSpec, reference_budgets, suite_model_from_dict
    from alcove.surrogates.validation import _suite_arrays, suite_kinematics

    with open_transaction() as s:
        suite = s.get(ValidationSuite, suite_id)
        if suite is None or suite.status != SuiteStatus.complete.value or suite.reference is not None:
            return False
        spec = SuiteSpec.from_dict(suite.spec)
        if spec.reference_motions == 0:
            return False
        arrays = _suite_arrays(s, suite_id)
        kinematics = suite_kinematics(suite)
        model = suite_model_from_dict(suite.preset)
    preset = ModelSpec.model_validate(model.model).oracle_preset() if isinstance(model, ChainSuiteModel) else model
    reference = [a for a in arrays if a["part"] == "reference"]
    scored = [a for a in arrays if a["part"] != "reference"]
    # a failed reference motion (the oracle refused it) shortens the line to the replays there are
    budgets = [b for b in reference_budgets(spec.reference_motions) if b <= len(reference)]
    t0 = time.perf_counter()
    line = reference_line(reference, scored, budgets, kinematics, preset)
    line["replays"] = len(reference)
    line["wall_time_s"] = time.perf_counter() - t0

    def store(s: Any) -> bool:
        row = s.get(ValidationSuite, suite_id, with_for_update=True)
        if row is None or row.reference is not None:
            return False
        row.reference = line
        return True

    wrote = bool(run_transaction(store))
    log.info("validation suite %d: best-possible line %s", suite_id, "stored" if wrote else "already stored")
    return wrote
