"""The oracles and the surrogate's features read the contact body's pose, never a joint angle.

Checked against the geometry, not against numbers of a previous run:

* the 1-DOF preset's pose (NumPy geometry) is the pose of its planar chain (CasADi), and the
  relative kinematics rebuilt from the pose are the old q-driven kinematics bit for bit;
* a two-joint chain held straight (second joint at 0) whose head sits where the preset's does
  *is* the 1-DOF preset: driven by its pose, every oracle gives the forces of the old
  q-driven path on the preset (thresholds stated at each comparison);
* the trajectory CSV carries the pose columns, and an old joint-only 1-DOF file still reads.
"""

import numpy as np
import pytest

from alcove.science.geometry import (
    DEFAULT_PRESET,
    POSE_COLUMNS,
    kinematics_from_pose,
    pose_from_kinematics,
    preset_pose,
    preset_pose_function,
    relative_kinematics,
)
from alcove.science.multibody import Headrest, Link, PlanarChain
from alcove.science.oracles.aux_penalty import AuxPenaltyOracle, AuxPenaltyParams, aux_penalty_wrench
from alcove.science.oracles.command.template import template_values
from alcove.science.oracles.fe_headrest import FEHeadrestOracle, FEHeadrestParams
from alcove.science.series import SeriesFormatError, Trajectory
from alcove.science.surrogate.features import features, pose_features

P = DEFAULT_PRESET


def press(n: int = 201) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """theta0 + 0.15 sin(pi t) on [0, 0.5]: the head meets the headrest near t = 0.25 s and presses in."""
    t = np.linspace(0.0, 0.5, n)
    return t, P.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t)


def straight_two_joint_chain() -> PlanarChain:
    """Neck (6 cm) + head whose COG sits 6 cm further along: with q_1 = 0 the head is the
    preset's (COG 12 cm from C7/T1 on the same axis, the same profile and headrest)."""
    o = P.headrest_origin
    return PlanarChain(
        links=(Link(1.0, 0.03, 0.001, 0.06), Link(P.mass, 0.06, P.inertia_com, 0.0)),
        q_min=(P.theta_min, -0.3),
        q_max=(P.theta_max, 0.3),
        torque_limit=(30.0, 30.0),
        headrest=Headrest((float(o[0]), float(o[1])), P.tilt),
        profile=P.profile,
    )


def test_the_1dof_pose_is_the_chains_and_rebuilds_the_old_kinematics_bit_for_bit():
    _, theta, theta_dot = press()
    pose = preset_pose(P, theta, theta_dot)
    # the NumPy geometry and the CasADi chain agree to round-off (1e-12 m, rad)
    np.testing.assert_allclose(PlanarChain.from_preset(P).head_pose(theta, theta_dot), pose, rtol=0, atol=1e-12)
    old = relative_kinematics(P, theta, theta_dot)
    new = kinematics_from_pose(pose)
    for name in ("r_rel", "v_rel", "T_rel", "omega_rel"):
        np.testing.assert_array_equal(getattr(new, name), getattr(old, name))
    np.testing.assert_array_equal(pose_features(pose), features(old))
    np.testing.assert_allclose(pose_from_kinematics(old), pose, rtol=0, atol=1e-15)
    # the head angle is the tilt relative to the headrest, its rate the joint rate
    np.testing.assert_array_equal(pose[:, 2], theta - P.tilt)
    np.testing.assert_array_equal(pose[:, 5], theta_dot)


def test_a_straight_two_joint_chain_has_the_presets_pose():
    _, theta, theta_dot = press()
    chain = straight_two_joint_chain()
    q = np.stack([theta, np.zeros_like(theta)], -1)
    qd = np.stack([theta_dot, np.zeros_like(theta)], -1)
    np.testing.assert_allclose(chain.head_pose(q, qd), preset_pose(P, theta, theta_dot), rtol=0, atol=1e-12)


def two_joint_trajectory() -> Trajectory:
    t, theta, theta_dot = press()
    q = np.stack([theta, np.zeros_like(theta)], -1)
    qd = np.stack([theta_dot, np.zeros_like(theta)], -1)
    return Trajectory(t, q, qd, model=straight_two_joint_chain().head_pose)


def test_aux_penalty_driven_by_a_chains_pose_gives_the_old_q_driven_forces():
    t, theta, theta_dot = press()
    force, moment = aux_penalty_wrench(P, AuxPenaltyParams(), relative_kinematics(P, theta, theta_dot))
    assert force[:, 0].max() > 50.0  # the motion presses in: the comparison is not of zeros
    res = AuxPenaltyOracle().run(two_joint_trajectory())
    # the pose agrees to 1e-12 m; the penalty force k p^2 (k = 6e6 N/m^2, p ~ 5 mm) to 1e-6 N
    np.testing.assert_allclose(res.forces.force, force, rtol=0, atol=1e-6)
    np.testing.assert_allclose(res.forces.moment, moment, rtol=0, atol=1e-7)
    # and a 1-joint trajectory without pose columns is the preset's, bit for bit
    joint_only = AuxPenaltyOracle().run(Trajectory(t, theta, theta_dot))
    np.testing.assert_array_equal(joint_only.forces.force, force)
    np.testing.assert_array_equal(joint_only.forces.moment, moment + 0.0)


def test_fe_oracle_driven_by_a_chains_pose_gives_the_old_q_driven_forces():
    params = FEHeadrestParams(output_dt=0.005)
    t, theta, theta_dot = press()
    old = FEHeadrestOracle(params).run(Trajectory(t, theta, theta_dot))  # joint-only: the preset's pose
    new = FEHeadrestOracle(params).run(two_joint_trajectory())
    assert old.ok and new.ok, (old.failure_reason, new.failure_reason)
    assert old.diagnostics["peak_force_n"] > 50.0
    # inputs equal to 1e-12 m; Newton converged to its tolerance from there: 1e-6 of the peak
    scale = old.diagnostics["peak_force_n"]
    np.testing.assert_allclose(new.forces.force, old.forces.force, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(new.forces.moment, old.forces.moment, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(pose_from_kinematics(new.kinematics), pose_from_kinematics(old.kinematics), atol=1e-12)


def test_command_template_values_come_from_the_pose():
    from alcove.science.oracles.command.spec import CommandOracleParams, CommandOracleSpec

    spec, params = CommandOracleSpec(name="x", argv=["true"]), CommandOracleParams()
    t, theta, theta_dot = press()
    old = template_values(Trajectory(t, theta, theta_dot), P, params, spec)
    new = template_values(two_joint_trajectory(), P, params, spec)
    assert set(old) == set(new)
    for key in old:
        if key.endswith("_curve"):
            a = np.array([[float(v) for v in line.split()] for line in old[key].splitlines()])
            b = np.array([[float(v) for v in line.split()] for line in new[key].splitlines()])
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)
        elif old[key] != new[key]:  # numbers written with 12 (or 10-character) digits
            assert float(new[key]) == pytest.approx(float(old[key]), rel=1e-9, abs=1e-12), key


def test_trajectory_csv_carries_the_pose_and_old_files_still_read(tmp_path):
    traj = two_joint_trajectory()
    text = traj.to_csv(tmp_path / "chain.csv")
    assert text.splitlines()[0] == "t,q_0,q_1,qd_0,qd_1," + ",".join(POSE_COLUMNS)
    back = Trajectory.from_csv(tmp_path / "chain.csv")
    np.testing.assert_array_equal(back.pose, traj.pose)
    # an old 1-DOF file: joint columns only; the pose comes from the head-neck-1dof preset
    t, theta, theta_dot = press()
    Trajectory(t, theta, theta_dot).to_csv(tmp_path / "old.csv")
    old = Trajectory.from_csv(tmp_path / "old.csv", model=preset_pose_function(P))
    np.testing.assert_array_equal(old.pose, preset_pose(P, theta, theta_dot))
    # a file of several joints must carry the pose; partial pose columns are refused
    lines = text.splitlines()
    cut = [",".join(row.split(",")[:5]) for row in lines]
    (tmp_path / "no-pose.csv").write_text("\n".join(cut) + "\n")
    with pytest.raises(SeriesFormatError, match=r"^head_x: missing: a trajectory of 2 joints needs the pose"):
        Trajectory.from_csv(tmp_path / "no-pose.csv")
    partial = [",".join(row.split(",")[:-1]) for row in lines]
    (tmp_path / "partial.csv").write_text("\n".join(partial) + "\n")
    with pytest.raises(SeriesFormatError, match=r"^head_omega: missing: give all pose columns"):
        Trajectory.from_csv(tmp_path / "partial.csv")


def test_resampling_recomputes_the_pose_from_the_model_or_interpolates_the_columns():
    traj = two_joint_trajectory()
    grid = np.linspace(0.0, 0.5, 77)
    with_model = traj.resample(grid)
    np.testing.assert_allclose(
        with_model.pose, straight_two_joint_chain().head_pose(with_model.q, with_model.qd), rtol=0, atol=1e-15
    )
    columns_only = Trajectory(traj.t, traj.q, traj.qd, pose=traj.pose).resample(grid)
    for j in range(6):
        np.testing.assert_allclose(columns_only.pose[:, j], np.interp(grid, traj.t, traj.pose[:, j]), atol=1e-15)


def test_ccx_deck_amplitudes_come_from_the_pose():
    """The 3D oracle's rigid-body amplitude curves (x_H, z_H, rotation) and head placement: a chain's
    pose gives the deck of the old q-driven path (numbers written with 12 digits or fewer)."""
    from alcove.science.oracles.fe_headrest_3d import CcxHeadrestOracle

    oracle = CcxHeadrestOracle()
    t, theta, theta_dot = press()
    old_files, old_job = oracle.job_files(oracle._validated(Trajectory(t, theta, theta_dot)))
    new_files, new_job = oracle.job_files(oracle._validated(two_joint_trajectory()))
    assert old_job["first_simulated"] == new_job["first_simulated"] and old_job["tau"] == new_job["tau"]
    np.testing.assert_allclose(new_job["cog"], old_job["cog"], rtol=0, atol=1e-12)
    old_lines, new_lines = (f["headrest.inp"].splitlines() for f in (old_files, new_files))
    assert len(old_lines) == len(new_lines) > 100
    differ = [(a, b) for a, b in zip(old_lines, new_lines, strict=True) if a != b]
    for a, b in differ:  # only last-digit round-off in numeric fields
        fa, fb = (np.array([float(x) for x in line.split(",") if x.strip()]) for line in (a, b))
        np.testing.assert_allclose(fb, fa, rtol=1e-9, atol=1e-12)


def test_a_pose_alone_starting_in_contact_is_preloaded_along_the_normal_to_the_same_state():
    """Held still 10 mm or so into the cushion from t = 0. The 1-DOF joint trajectory is preloaded
    along the head's own path, the same pose given alone along the cushion normal: without
    friction the cushion is elastic during the preload, so both reach the same equilibrium
    (force to 1e-4 of its value: Newton's tolerance over two different paths)."""
    t = np.arange(0.0, 0.05 + 1e-9, 0.0025)
    params = FEHeadrestParams(friction=0.0)
    joint = FEHeadrestOracle(params).run(Trajectory(t, np.full_like(t, 0.36), np.zeros_like(t)))
    pose = preset_pose(P, np.full_like(t, 0.36), np.zeros_like(t))
    alone = FEHeadrestOracle(params).run(Trajectory(t, np.zeros((t.size, 3)), np.zeros((t.size, 3)), pose=pose))
    assert joint.ok and alone.ok, (joint.failure_reason, alone.failure_reason)
    f0 = joint.forces.force[0]
    assert f0[0] > 10.0
    np.testing.assert_allclose(alone.forces.force, joint.forces.force, rtol=0, atol=1e-4 * np.linalg.norm(f0))
    np.testing.assert_allclose(alone.forces.moment, joint.forces.moment, rtol=0, atol=1e-4 * np.linalg.norm(f0))
    d = alone.diagnostics
    assert abs(d["dissipated_energy_j"]) < 1e-6 * d["stored_energy_start_j"]
    assert d["stored_energy_start_j"] == pytest.approx(joint.diagnostics["stored_energy_start_j"], rel=1e-4)
