"""The paper's auxiliary penalty model and the ``aux-penalty`` oracle.

Hand-computed values are evaluated in the paper's units (N, mm, s: k = 6 N/mm^2,
d0 = 0.1 N s/mm, p_ref = 2 mm) and compared with the SI implementation.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError
from scipy.spatial.transform import Rotation

from alcove.science.geometry import DEFAULT_PRESET, RelativeKinematics, relative_kinematics, rot2
from alcove.science.oracles.aux_penalty import AuxPenaltyOracle, AuxPenaltyParams, aux_penalty_wrench, penetration
from alcove.science.oracles.base import OracleCancelled, OracleInputError
from alcove.science.series import Trajectory


def point_kinematics(p_m: np.ndarray, pdot_m_s: np.ndarray) -> RelativeKinematics:
    """Head frame aligned with H, its origin at penetration p and rate pdot (contact point at the origin)."""
    n = len(p_m)
    return RelativeKinematics(
        r_rel=np.stack([-p_m, np.zeros(n), np.zeros(n)], -1),
        v_rel=np.stack([-pdot_m_s, np.zeros(n), np.zeros(n)], -1),
        T_rel=np.broadcast_to(np.eye(3), (n, 3, 3)).copy(),
        omega_rel=np.zeros((n, 3)),
    )


def paper_force_n(p_mm: float, pdot_mm_s: float) -> float:
    """The paper's formula in its own units, gated."""
    f = 6.0 * p_mm**2 + pdot_mm_s * 0.1 * (1.0 - math.exp(-abs(p_mm) / 2.0))
    return f if (p_mm > 0 and f > 0) else 0.0


# (p [mm], pdot [mm/s], force [N] worked out by hand)
HAND_CASES = [
    (3.0, 50.0, 57.884),  # 54 + 5 (1 - e^-1.5)
    (2.0, 0.0, 24.0),  # static: 6 * 2^2
    (0.5, -10.0, 1.2788),  # unloading, still pushing: 1.5 - (1 - e^-0.25)
    (1.0, -200.0, 0.0),  # f = 6 - 20 (1 - e^-0.5) = -1.87 < 0: gated (non-sticking)
    (-1.0, 100.0, 0.0),  # f > 0 but no penetration: gated
    (0.0, 300.0, 0.0),  # touching: p = 0 is not contact
]


def test_hand_computed_values_in_paper_units_match_si_implementation():
    p_mm, pdot_mm_s, expected = map(np.array, zip(*HAND_CASES, strict=False))
    kin = point_kinematics(p_mm * 1e-3, pdot_mm_s * 1e-3)
    force, moment = aux_penalty_wrench(DEFAULT_PRESET, AuxPenaltyParams(r_sp=(0.0, 0.0, 0.0)), kin)
    np.testing.assert_allclose(force[:, 0], expected, atol=5e-4)
    np.testing.assert_allclose(force[:, 0], [paper_force_n(a, b) for a, b, _ in HAND_CASES], rtol=1e-12)
    assert np.all(force[:, 1:] == 0)
    assert np.all(moment == 0)  # the point is the moment reference point


def test_si_defaults_are_the_paper_values_converted():
    params = AuxPenaltyParams()
    assert params.k == pytest.approx(6.0 / 1e-6)  # 6 N/mm^2 = 6e6 N/m^2
    assert params.d0 == pytest.approx(0.1 / 1e-3)  # 0.1 N s/mm = 100 N s/m
    assert params.p_ref == pytest.approx(2e-3)


def test_gate_needs_both_penetration_and_positive_force():
    p = np.linspace(-2e-3, 4e-3, 61)
    for pdot in (-0.5, -0.05, 0.0, 0.05):
        force, _ = aux_penalty_wrench(
            DEFAULT_PRESET, AuxPenaltyParams(r_sp=(0, 0, 0)), point_kinematics(p, np.full_like(p, pdot))
        )
        fx = force[:, 0]
        assert np.all(fx >= 0)  # non-sticking: never pulls the head toward the cushion
        assert np.all(fx[p <= 0] == 0)
        raw = 6e6 * p**2 + pdot * 100 * (1 - np.exp(-np.abs(p) / 2e-3))
        np.testing.assert_array_equal(fx > 0, (p > 0) & (raw > 0))


def test_moment_is_lever_arm_cross_force_in_headrest_frame():
    theta = 0.37  # beyond first contact (0.31)
    kin = relative_kinematics(DEFAULT_PRESET, np.array([theta]), np.array([0.4]))
    params = AuxPenaltyParams()
    force, moment = aux_penalty_wrench(DEFAULT_PRESET, params, kin)
    bx, bz = DEFAULT_PRESET.profile.back_point()
    a = theta - DEFAULT_PRESET.tilt
    arm_z = math.sin(a) * bx + math.cos(a) * bz  # z_H of the back point relative to the head origin
    fx = force[0, 0]
    assert fx > 0
    # M = r x F with F = (fx, 0, 0): (0, arm_z fx, -arm_y fx), arm_y = 0
    np.testing.assert_allclose(moment[0], [0.0, arm_z * fx, 0.0], atol=1e-12)
    assert moment[0, 1] < 0  # the contact point is below the head's COG


def test_quasi_static_penetration_from_world_geometry():
    """No force before first contact; beyond it F = k p^2 n with p measured in the world frame by hand."""
    preset = DEFAULT_PRESET
    theta = np.linspace(preset.theta_min, preset.theta_max, 41)
    kin = relative_kinematics(preset, theta, np.zeros_like(theta))
    force, _ = aux_penalty_wrench(preset, AuxPenaltyParams(), kin)
    normal_world = np.array([math.cos(preset.tilt), math.sin(preset.tilt)])  # x_H in world (x, z)
    d = preset.com_distance
    back = preset.profile.back_point()
    p_hand = []
    for th in theta:
        point = np.array([-d * math.sin(th), d * math.cos(th)]) + rot2(th) @ back
        p_hand.append(-(point - preset.headrest_origin) @ normal_world)
    p_hand = np.array(p_hand)
    np.testing.assert_allclose(force[:, 0], np.where(p_hand > 0, 6e6 * p_hand**2, 0.0), rtol=1e-9, atol=1e-9)
    assert np.all(force[theta < preset.theta_contact - 1e-9] == 0)
    assert np.all(force[theta > preset.theta_contact + 1e-9, 0] > 0)
    assert np.all(np.diff(force[theta > preset.theta_contact, 0]) > 0)  # deeper -> harder


def mirror_kinematics(kin: RelativeKinematics, S: np.ndarray) -> RelativeKinematics:
    """Reflect a motion by S (a reflection that keeps the normal x_H): vectors S v, rotations S T S,
    axial vectors det(S) S w."""
    return RelativeKinematics(
        r_rel=kin.r_rel @ S.T,
        v_rel=kin.v_rel @ S.T,
        T_rel=S @ kin.T_rel @ S,
        omega_rel=np.linalg.det(S) * kin.omega_rel @ S.T,
    )


@pytest.mark.parametrize("S", [np.diag([1.0, -1.0, 1.0]), np.diag([1.0, 1.0, -1.0])], ids=["y-mirror", "z-mirror"])
def test_mirrored_motion_mirrors_force_and_moment(S):
    rng = np.random.default_rng(4)
    n = 200
    kin = RelativeKinematics(
        r_rel=rng.normal([-0.004, 0.0, 0.0], [0.003, 0.02, 0.02], (n, 3)),
        v_rel=rng.normal(0, 0.1, (n, 3)),
        T_rel=Rotation.from_rotvec(rng.normal(0, 0.1, (n, 3))).as_matrix(),
        omega_rel=rng.normal(0, 1.0, (n, 3)),
    )
    r_sp = np.array([0.004, 0.03, -0.02])  # off both symmetry planes: my and mz are both nonzero
    force, moment = aux_penalty_wrench(DEFAULT_PRESET, AuxPenaltyParams(r_sp=tuple(r_sp)), kin)
    assert 20 < np.count_nonzero(force[:, 0]) < n  # both contact and no contact are exercised
    assert np.all(np.abs(moment[force[:, 0] > 0, 1:]) > 0)
    force_m, moment_m = aux_penalty_wrench(
        DEFAULT_PRESET, AuxPenaltyParams(r_sp=tuple(S @ r_sp)), mirror_kinematics(kin, S)
    )
    np.testing.assert_allclose(force_m, force @ S.T, atol=1e-9)
    np.testing.assert_allclose(moment_m, np.linalg.det(S) * moment @ S.T, atol=1e-9)


def push_and_release(n: int = 801, amplitude: float = 0.15) -> Trajectory:
    """theta = theta0 + a sin(pi t) on [0, 1]: the head meets the headrest, pushes in and leaves it."""
    t = np.linspace(0.0, 1.0, n)
    theta0 = DEFAULT_PRESET.theta0
    return Trajectory(t, theta0 + amplitude * np.sin(np.pi * t), amplitude * np.pi * np.cos(np.pi * t))


def test_oracle_returns_planar_wrench_on_trajectory_grid():
    traj = push_and_release()
    result = AuxPenaltyOracle().run(traj)
    assert result.ok and result.failure_reason is None
    np.testing.assert_array_equal(result.forces.t, traj.t)
    f, m = result.forces.force, result.forces.moment
    assert np.all(f[:, 1:] == 0) and np.all(m[:, [0, 2]] == 0)  # the planar motion is its own y-mirror
    in_contact = f[:, 0] > 0
    theta = traj.q[:, 0]
    assert not in_contact[
        theta < DEFAULT_PRESET.theta_contact
    ].any()  # no force before first contact / after separation
    assert in_contact.any() and result.diagnostics["contact_samples"] == in_contact.sum()
    assert result.diagnostics["first_contact_t"] == traj.t[in_contact][0]
    assert result.diagnostics["newton_iterations"] is None
    p, _ = penetration(DEFAULT_PRESET, AuxPenaltyParams(), result.kinematics)
    assert result.diagnostics["max_penetration_m"] == pytest.approx(p.max())
    assert result.forces.peak_force == pytest.approx(6e6 * p.max() ** 2, rel=1e-3)  # the peak is near rest (pdot ~ 0)


def test_dissipation_is_nonnegative_and_vanishes_without_damping():
    traj = push_and_release(n=4001)
    stored_peak = 6e6 * AuxPenaltyOracle().run(traj).diagnostics["max_penetration_m"] ** 3 / 3
    energies = [
        AuxPenaltyOracle(AuxPenaltyParams(d0=d0)).run(traj).diagnostics["dissipated_energy_j"]
        for d0 in (0.0, 50.0, 100.0, 200.0)
    ]
    assert abs(energies[0]) < 1e-6 * stored_peak  # elastic only: the work is given back
    assert 0 < energies[1] < energies[2] < energies[3]


@settings(max_examples=25, deadline=None)
@given(
    amplitudes=st.lists(st.floats(0.0, 0.03), min_size=3, max_size=3),  # theta stays in [0.24, 0.42]
    frequencies=st.lists(st.floats(0.5, 4.0), min_size=3, max_size=3),
    d0=st.floats(0.0, 1000.0),
)
def test_dissipation_never_negative_for_any_motion(amplitudes, frequencies, d0):
    t = np.linspace(0.0, 1.0, 4001)
    w = 2 * np.pi * np.array(frequencies)
    a = np.array(amplitudes)
    theta = 0.33 + np.sin(np.outer(t, w)) @ a  # around first contact (0.31)
    theta_dot = np.cos(np.outer(t, w)) @ (a * w)
    result = AuxPenaltyOracle(AuxPenaltyParams(d0=d0)).run(Trajectory(t, theta, theta_dot))
    work_scale = 6e6 * result.diagnostics["max_penetration_m"] ** 3 / 3 + 1e-12
    assert result.diagnostics["dissipated_energy_j"] >= -1e-4 * work_scale


def test_bad_input_names_the_field():
    t = np.linspace(0, 1, 5)
    with pytest.raises(OracleInputError, match=r"^head_x: a trajectory of 2 joints needs the contact body's pose"):
        AuxPenaltyOracle().run(Trajectory(t, np.full((5, 2), 0.2), np.zeros((5, 2))))
    with pytest.raises(OracleInputError, match=r"^head_angle: non-finite value .* at data row 3"):
        pose = np.zeros((5, 6))
        pose[2, 2] = np.nan
        AuxPenaltyOracle().run(SimpleNamespace(t=t, q=np.full((5, 2), 0.2), qd=np.zeros((5, 2)), pose=pose))
    with pytest.raises(ValidationError, match="k"):
        AuxPenaltyParams(k=-1.0)
    with pytest.raises(ValidationError, match="extra"):
        AuxPenaltyParams(stiffness=1.0)
    with pytest.raises(OracleCancelled):
        AuxPenaltyOracle().run(push_and_release(11), cancel=lambda: True)
