"""Templates of input decks: plain ``{{ name }}`` substitution and the values for a trajectory.

The placeholders and their meaning are part of the file contract
(:data:`.contract.TEMPLATE_PLACEHOLDERS`); an entry's declared parameters are placeholders
too. Values meant for fixed-format keyword cards fit in 10 characters (:func:`card_number`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset
from alcove.science.oracles.base import OracleInputError, posed_trajectory
from alcove.science.oracles.command.contract import TRAJECTORY_FILE
from alcove.science.oracles.command.spec import CommandOracleParams, CommandOracleSpec
from alcove.science.series import Trajectory

PLACEHOLDER = re.compile(r"\{\{\s*([A-Za-z_][A-Za-z0-9_]*)\s*\}\}")


def render_template(text: str, values: Mapping[str, str]) -> str:
    """Replace ``{{ name }}`` by ``values[name]``; nothing else in ``text`` is interpreted.

    Only plain names are placeholders. An unknown name is an error (a typo would otherwise
    reach the solver); any other text, including ``{{ expression }}``, ``${VAR}``, ``$(...)``
    or backquotes, is copied verbatim. Substitution is a single pass: inserted values are
    never rendered again.
    """
    for match in PLACEHOLDER.finditer(text):
        if match.group(1) not in values:
            line = text.count("\n", 0, match.start()) + 1
            known = ", ".join(sorted(values))
            raise OracleInputError(
                "template", f"unknown placeholder {match.group(0)!r} on line {line} (known: {known})"
            )
    return PLACEHOLDER.sub(lambda m: values[m.group(1)], text)


def curve_lines(t: FloatArray, y: FloatArray) -> str:
    """Curve data as LS-DYNA *DEFINE_CURVE data cards (two 20-character fields per line)."""
    return "\n".join(f"{a:20.12e}{b:20.12e}" for a, b in zip(t, y, strict=True))


def card_number(value: float, width: int = 10) -> str:
    """``value`` with as many significant digits (at most 12) as fit in ``width`` characters.

    Fixed-format keyword cards (LS-DYNA: 10-character fields; also the limit of a value in a
    comma-separated free-format card) cannot hold 12 significant digits.
    """
    v = float(value)
    for digits in range(12, 0, -1):
        text = format(v, f".{digits}g")
        if len(text) <= width:
            return text
    raise ValueError(f"{v!r} does not fit in {width} characters")


def si_number(value: float) -> str:
    """``value`` with 12 significant digits (for SI values that are not card fields)."""
    return format(float(value), ".12g")


def template_values(
    trajectory: Trajectory, preset: HeadNeckPreset, params: CommandOracleParams, spec: CommandOracleSpec
) -> dict[str, str]:
    """The values of the fixed placeholders (and the entry's parameters) for one trajectory.

    SI values (``head_x0``, ``theta_start``, ...) have 12 significant digits; the values meant
    for card fields (mm, degrees, times, ``dt_out`` and the entry's parameters) fit in 10
    characters (:func:`card_number`).
    """
    t = trajectory.t
    pose = posed_trajectory(trajectory, preset).pose
    assert pose is not None
    x, z, angle = pose[:, 0], pose[:, 1], pose[:, 2]
    tilt = angle + preset.tilt  # the head's absolute backward tilt (theta for the head-neck-1dof preset)
    rotation0 = -float(angle[0])
    values = {
        "motion_curve": curve_lines(t, tilt),
        "head_x_curve": curve_lines(t, x - x[0]),
        "head_z_curve": curve_lines(t, z - z[0]),
        "head_rotation_curve": curve_lines(t, angle[0] - angle),
        "head_x0": si_number(x[0]),
        "head_z0": si_number(z[0]),
        "head_x0_mm": card_number(1e3 * x[0]),
        "head_z0_mm": card_number(1e3 * z[0]),
        "head_rotation0": si_number(rotation0),
        "head_rotation0_deg": card_number(np.degrees(rotation0)),
        "theta_start": si_number(tilt[0]),
        "headrest_tilt": si_number(preset.tilt),
        "t_start": card_number(t[0]),
        "t_end": card_number(t[-1]),
        "duration": card_number(t[-1] - t[0]),
        "n_samples": str(len(t)),
        "dt_out": card_number(params.dt_out),
        "trajectory_file": TRAJECTORY_FILE,
        "output_file": spec.output_file,
    }
    values.update({key: card_number(getattr(params, key)) for key in spec.parameters})
    return values


__all__ = ["PLACEHOLDER", "card_number", "curve_lines", "render_template", "si_number", "template_values"]
