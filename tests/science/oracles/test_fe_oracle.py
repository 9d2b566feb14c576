"""fe-headrest-2d oracle: the reference motion, sign and energy laws, rate dependence, statics,
convergence, frames, quality gate and bad input.

The reference motion (``alcove.science.oracles.fe_headrest.reference_motion``) follows the
paper's example run: rest at theta0 = 0.232 rad, first contact near t = 0.29 s, pressed in
firmly to theta = 0.43 rad at t = 0.65 s and eased back to theta = 0.33 rad (resting) at t = 1 s.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from pydantic import ValidationError

from alcove.science.geometry import DEFAULT_PRESET, head_pose_in_headrest, preset_pose
from alcove.science.oracles.base import OracleCancelled, OracleInputError
from alcove.science.oracles.fe_headrest import FEHeadrestOracle, FEHeadrestParams, reference_motion
from alcove.science.oracles.fe_headrest.oracle import profile_indentation
from alcove.science.series import SeriesFormatError, Trajectory

COARSE_DT = 0.005  # output interval for tests where the time step is not the point


def bump(theta_peak: float = 0.37, duration: float = 0.25, theta_base: float = 0.30, dt: float = 0.0025) -> Trajectory:
    """Press in and release: theta = base + (peak - base) sin^2(pi t / duration), from clear to clear."""
    t = np.arange(0.0, duration + dt / 2, dt)
    amp = theta_peak - theta_base
    return Trajectory(
        t,
        theta_base + amp * np.sin(np.pi * t / duration) ** 2,
        amp * np.pi / duration * np.sin(2 * np.pi * t / duration),
    )


@pytest.fixture(scope="module")
def reference_run():
    trajectory = reference_motion()
    result = FEHeadrestOracle().run(trajectory)
    return trajectory, result


def test_reference_motion_forces_are_of_the_papers_order_and_pass_the_gate(reference_run):
    trajectory, result = reference_run
    assert result.ok, result.failure_reason
    d = result.diagnostics
    f = result.forces
    assert len(f) == 401 and f.t[-1] == pytest.approx(1.0)
    assert d["first_contact_time_s"] == pytest.approx(0.29, abs=0.01)  # the paper: 0.29 s
    # the paper, for a firm push: peaks of order 100-300 N and 10-30 N m (moment about the head frame origin)
    assert 100.0 < d["peak_force_n"] < 300.0
    assert 10.0 <= d["peak_moment_nm"] < 30.0
    assert d["peak_moment_nm"] == pytest.approx(np.max(np.abs(f.moment[:, 1])))
    assert 5.0 < np.linalg.norm(f.force[-1]) < 60.0  # resting on the headrest: a few tens of N
    assert d["max_penetration_m"] < 1e-4  # far below the 1 mm bound and the ~8 mm indentation
    assert d["energy_balance_ok"] and d["bar_reaction_mismatch_n"] < 1e-3 * d["peak_force_n"]
    assert d["bar_moment_mismatch_nm"] < 1e-3 * d["peak_moment_nm"]  # moment balance with the bar
    assert d["newton_iterations_max"] <= 10
    # out-of-plane components vanish in a planar model
    assert np.all(f.force[:, 1] == 0) and np.all(f.moment[:, [0, 2]] == 0)
    # the kinematics returned are the ones replayed
    np.testing.assert_allclose(result.kinematics.angle, trajectory.q[:, 0] - DEFAULT_PRESET.tilt)


def test_no_force_before_contact_and_the_force_pushes_the_head_away(reference_run):
    trajectory, result = reference_run
    f = result.forces
    clear = profile_indentation(DEFAULT_PRESET.profile, preset_pose(DEFAULT_PRESET, trajectory.q, trajectory.qd)) == 0
    before = f.t < result.diagnostics["first_contact_time_s"]
    assert np.all(f.force[before] == 0) and np.all(f.moment[before] == 0)
    assert np.all(f.force[clear & before] == 0)
    touching = np.linalg.norm(f.force, axis=1) > 0
    assert np.all(f.force[touching, 0] > 0)  # fx > 0: away from the cushion
    # the moment is informative: not a fixed multiple of the force
    ratio = f.moment[touching, 1] / f.force[touching, 0]
    assert np.ptp(ratio) > 0.01


def test_energy_balance_work_equals_stored_plus_dissipated(reference_run):
    """Work done by the head = stored energy at the end + viscous + friction dissipation."""
    _, result = reference_run
    d = result.diagnostics
    assert d["dissipated_energy_j"] > 0
    assert d["work_by_head_j"] == pytest.approx(
        d["stored_energy_end_j"] + d["viscous_dissipation_j"] + d["friction_dissipation_j"], rel=0.02
    )


def test_no_force_after_separation_and_dissipation_vanishes_with_viscosity():
    """Press in and release without friction: dissipation >= 0, decreasing to 0 with viscosity."""
    trajectory = bump()
    dissipated = {}
    for eta in (1000.0, 100.0, 0.0):
        result = FEHeadrestOracle(FEHeadrestParams(viscosity=eta, friction=0.0, output_dt=COARSE_DT)).run(trajectory)
        assert result.ok, result.failure_reason
        d = result.diagnostics
        dissipated[eta] = d["dissipated_energy_j"]
        assert d["work_by_head_j"] == pytest.approx(
            d["stored_energy_end_j"] + d["viscous_dissipation_j"], rel=0.02, abs=1e-6
        )
        f = result.forces
        on_out = trajectory.resample(f.t)
        depth = profile_indentation(DEFAULT_PRESET.profile, preset_pose(DEFAULT_PRESET, on_out.q, on_out.qd))
        assert np.all(f.force[(depth == 0) & (f.t > 0.2)] == 0)  # separated: no force at all
        assert np.all(f.force[depth == 0] == 0)  # the head never pulls: no force when clear
    assert dissipated[1000.0] > dissipated[100.0] > 0
    assert abs(dissipated[0.0]) < 0.02 * dissipated[100.0]


def test_faster_indentation_gives_higher_force_at_equal_depth():
    slow = bump(duration=0.4)
    fast = bump(duration=0.2)
    params = FEHeadrestParams(viscosity=300.0, output_dt=COARSE_DT)
    r_slow, r_fast = FEHeadrestOracle(params).run(slow), FEHeadrestOracle(params).run(fast)
    # the same angles are visited at output k in the slow run and k/2 in the fast run; loading half
    k_slow = np.arange(10, 40, 2)
    k_fast = k_slow // 2
    np.testing.assert_allclose(
        slow.resample(r_slow.forces.t).q[k_slow, 0], fast.resample(r_fast.forces.t).q[k_fast, 0], atol=1e-12
    )
    touching = r_slow.forces.force[k_slow, 0] > 1.0
    assert touching.sum() >= 5
    assert np.all(r_fast.forces.force[k_fast, 0][touching] > r_slow.forces.force[k_slow, 0][touching])


def test_resting_head_is_carried_with_the_gravity_moment():
    """At rest with zero actuation the contact balances gravity, m g d sin(theta), about the joint,
    a little past first contact and with a force of a few tens of N."""
    p = DEFAULT_PRESET
    t = np.arange(0.0, 0.6 + 1e-9, COARSE_DT)
    theta = 0.305 + 0.08 * t  # slow push (0.08 rad/s), quasi-static
    params = FEHeadrestParams(viscosity=0.0, friction=0.0, output_dt=COARSE_DT)
    result = FEHeadrestOracle(params).run(Trajectory(t, theta, np.full_like(t, 0.08)))
    assert result.ok
    h = 1e-7
    r_plus, _ = head_pose_in_headrest(p, theta + h)
    r_minus, _ = head_pose_in_headrest(p, theta - h)
    dr_dtheta = (r_plus - r_minus) / (2 * h)
    F = result.forces.force[:, [0, 2]]
    # generalised force of the contact on theta (virtual work: F . dr - M_y dtheta)
    q_contact = np.einsum("ij,ij->i", F, dr_dtheta) - result.forces.moment[:, 1]
    q_gravity = p.mass * p.gravity * p.com_distance * np.sin(theta)
    balance = q_contact + q_gravity
    assert balance[0] > 0 and balance[-1] < 0  # gravity wins at first, the cushion wins later
    k = int(np.argmax(balance < 0))
    assert p.theta_contact < theta[k] < p.theta_contact + 0.05
    assert 5.0 < np.linalg.norm(F[k]) < 60.0
    assert q_contact[k] == pytest.approx(-q_gravity[k], rel=0.1)


@pytest.mark.slow
def test_peak_force_converges_in_mesh_and_time_step(reference_run):
    _, result = reference_run
    peak = result.diagnostics["peak_force_n"]
    window = reference_motion().window(0.275, 0.675)  # the peak is at 0.65 s; no contact before 0.29 s
    fine = FEHeadrestParams(element_size_contact=0.003, element_size_far=0.0075)
    half_dt = FEHeadrestParams(substeps=2)
    peak_fine = FEHeadrestOracle(fine).run(window).diagnostics["peak_force_n"]
    peak_half_dt = FEHeadrestOracle(half_dt).run(window).diagnostics["peak_force_n"]
    assert peak_fine == pytest.approx(peak, rel=0.05)
    assert peak_half_dt == pytest.approx(peak, rel=0.05)


def test_moment_reference_point_transforms_like_a_moment():
    trajectory = bump()
    base = FEHeadrestOracle(FEHeadrestParams(output_dt=COARSE_DT)).run(trajectory)
    about_headrest = FEHeadrestOracle(FEHeadrestParams(output_dt=COARSE_DT, moment_point_frame="headrest")).run(
        trajectory
    )
    r, _ = head_pose_in_headrest(DEFAULT_PRESET, trajectory.resample(base.forces.t).q[:, 0])
    F = base.forces.force
    expected = base.forces.moment[:, 1] + r[:, 1] * F[:, 0] - r[:, 0] * F[:, 2]  # M_c = M_o + (o - c) x F
    np.testing.assert_allclose(about_headrest.forces.moment[:, 1], expected, atol=1e-9 * np.abs(F).max())
    np.testing.assert_allclose(about_headrest.forces.force, F)


def test_slices_through_a_round_head_start_with_the_centre_and_stay_planar():
    trajectory = bump()
    one = FEHeadrestOracle(FEHeadrestParams(friction=0.0, output_dt=COARSE_DT)).run(trajectory)
    sliced = FEHeadrestOracle(FEHeadrestParams(friction=0.0, output_dt=COARSE_DT, slices=3)).run(trajectory)
    assert sliced.ok and sliced.diagnostics["slices"] == 3
    # the off-centre sections of an ellipsoidal head touch later and less deep: less force than
    # one central slice of the same total width (2 x head_half_breadth)
    width_ratio = 2 * FEHeadrestParams().head_half_breadth / FEHeadrestParams().out_of_plane_width
    assert (
        0.2 * width_ratio * one.diagnostics["peak_force_n"]
        < sliced.diagnostics["peak_force_n"]
        < width_ratio * one.diagnostics["peak_force_n"]
    )
    assert sliced.diagnostics["first_contact_time_s"] >= one.diagnostics["first_contact_time_s"]
    assert np.all(sliced.forces.force[:, 0] >= 0)


# ---- quality gate, cancellation and bad input ------------------------------------------


def test_soft_penalty_fails_the_penetration_gate_and_returns_no_data():
    result = FEHeadrestOracle(FEHeadrestParams(penalty=1e6)).run(bump())
    assert not result.ok and result.forces is None
    assert "penetration" in result.failure_reason
    assert result.diagnostics["max_penetration_m"] > 1e-3


def test_too_few_newton_iterations_fail_the_run():
    result = FEHeadrestOracle(FEHeadrestParams(newton_max_iterations=2, newton_tolerance=1e-12)).run(bump())
    assert not result.ok and result.forces is None and "Newton" in result.failure_reason


def test_a_step_newton_cannot_finish_is_cut_back_and_agrees_with_smaller_steps(monkeypatch):
    """A fast press and rebound (0.39 rad peak in 0.1 s): at the default time step one step of the
    unloading needs more Newton iterations than allowed. The step is cut back (halved, at most
    three times) and the run completes with its gates passed; its forces agree with a run whose
    every step is four times smaller (peak to 0.5 %, every sample within the default step's
    discretization error); a run whose steps all converge is unchanged, bit for bit."""
    from alcove.science.oracles.fe_headrest.solver import CushionSolver

    fast = bump(theta_peak=0.39, duration=0.1)
    monkeypatch.setattr(CushionSolver, "max_cutbacks", 0)
    without = FEHeadrestOracle().run(fast)
    assert not without.ok and "Newton did not converge" in without.failure_reason
    calm = FEHeadrestOracle().run(bump(theta_peak=0.39, duration=0.08))
    monkeypatch.undo()

    cut = FEHeadrestOracle().run(fast)
    assert cut.ok, cut.failure_reason
    assert cut.diagnostics["energy_balance_ok"]
    fine = FEHeadrestOracle(FEHeadrestParams(substeps=4)).run(fast)
    assert fine.ok, fine.failure_reason
    peak = np.abs(fine.forces.force).max()
    assert peak > 100.0  # a real press
    assert np.abs(cut.forces.force).max() == pytest.approx(peak, rel=0.005)
    # pointwise within the default step's own time-discretization error: 3.0 to 4.3 % of the peak
    # against four times smaller steps for the neighbouring presses whose steps all converge
    assert np.abs(cut.forces.force - fine.forces.force).max() <= 0.05 * peak
    again = FEHeadrestOracle().run(bump(theta_peak=0.39, duration=0.08))
    np.testing.assert_array_equal(again.forces.force, calm.forces.force)


def test_cancel_is_checked_between_steps():
    calls = []

    def cancel() -> bool:
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(OracleCancelled):
        FEHeadrestOracle().run(bump(), cancel=cancel)
    assert len(calls) == 4


def test_bad_trajectories_give_clear_errors():
    oracle = FEHeadrestOracle()
    t = np.linspace(0, 0.1, 41)
    # geometric range checks, naming the sample: beyond what the foam block can take ...
    press = np.where(t > 0.05, 0.7, 0.3)  # 0.7 rad: 28.9 mm into the 40 mm cushion, 24 mm allowed
    with pytest.raises(
        OracleInputError,
        match=r"^head_x: sample 21 \(t = 0.0525 s\): the head would indent the cushion by .* mm, "
        r"beyond what the foam block can take",
    ):
        oracle.run(Trajectory(t, press, np.zeros_like(t)))
    deep = FEHeadrestParams(cushion_thickness=0.02, element_size_contact=0.004, max_indentation_fraction=0.3)
    with pytest.raises(OracleInputError, match=r"^head_x: sample 0 \(t = 0 s\): .*beyond what the foam block"):
        FEHeadrestOracle(deep).run(Trajectory(t, np.full_like(t, 0.43), np.zeros_like(t)))
    # ... and the head leaving the modelled region: touching above the cushion's top face
    pose = preset_pose(DEFAULT_PRESET, np.full_like(t, 0.32), np.zeros_like(t))
    pose[7:, 1] += 0.2  # the head slides up along the surface, still 1 mm or so into it
    with pytest.raises(OracleInputError, match=r"^head_z: sample 7 \(t = 0.0175 s\): .*outside the modelled region"):
        oracle.run(Trajectory(t, np.full((t.size, 2), 0.3), np.zeros((t.size, 2)), pose=pose))
    with pytest.raises(OracleInputError, match=r"^head_x: a trajectory of 2 joints needs the contact body's pose"):
        oracle.run(Trajectory(t, np.full((t.size, 2), 0.3), np.zeros((t.size, 2))))
    theta = np.full_like(t, 0.3)
    theta[5] = np.nan
    with pytest.raises(OracleInputError, match=r"^q: non-finite"):
        oracle.run(SimpleNamespace(t=t, q=theta, qd=np.zeros_like(t)))
    with pytest.raises(OracleInputError, match=r"^t: time must increase"):
        oracle.run(SimpleNamespace(t=t[::-1], q=np.full_like(t, 0.3), qd=np.zeros_like(t)))
    with pytest.raises(OracleInputError, match=r"^t: .*shorter than one output interval"):
        oracle.run(Trajectory(np.array([0.0, 0.001]), np.array([0.3, 0.3]), np.zeros(2)))
    with pytest.raises(OracleInputError, match=r"^trajectory"):
        oracle.run(np.zeros((3, 3)))


def test_wrong_csv_columns_name_the_column(tmp_path):
    path = tmp_path / "traj.csv"
    path.write_text("t,q_0,qdot_0\n0,0.3,0\n0.1,0.3,0\n")
    with pytest.raises(SeriesFormatError) as err:
        Trajectory.from_csv(path)
    assert err.value.field in ("qd_0", "qd", "qdot_0")


@pytest.mark.parametrize(
    "bad",
    [
        {"cushion_thickness": 0.5},
        {"element_size_contact": 0.0},
        {"friction": -0.1},
        {"foam_mu": (1e4,), "foam_alpha": (2.0, 3.0), "foam_beta": (0.0,)},
        {"foam_mu": (-1e4,), "foam_alpha": (2.0,), "foam_beta": (0.0,)},
        {"contact_zone": (0.05, -0.05)},
        {"element_size_far": 0.002},
        {"moment_point_frame": "joint"},
        {"output_dt": 0.0},
        {"unknown_field": 1},
    ],
)
def test_parameters_out_of_range_are_rejected(bad):
    with pytest.raises(ValidationError):
        FEHeadrestParams(**bad)


def test_a_trajectory_starting_in_contact_starts_from_static_equilibrium():
    """Holding the head still inside the cushion from t = 0: the cushion is pre-loaded
    quasi-statically, so the force is constant (no viscous spike) and nothing is dissipated."""
    t = np.arange(0.0, 0.05 + 1e-9, 0.0025)
    result = FEHeadrestOracle(FEHeadrestParams(friction=0.0)).run(
        Trajectory(t, np.full_like(t, 0.36), np.zeros_like(t))
    )
    assert result.ok, result.failure_reason
    f = result.forces.force
    assert f[0, 0] > 10.0
    np.testing.assert_allclose(f, np.broadcast_to(f[0], f.shape), rtol=1e-5, atol=1e-6 * f[0, 0])
    d = result.diagnostics
    assert d["first_contact_time_s"] == 0.0 and d["stored_energy_start_j"] > 0
    assert abs(d["dissipated_energy_j"]) < 1e-6 * d["stored_energy_start_j"]


def test_cli_json_summary_reports_newton_iterations(tmp_path):
    """`alcove oracle run --oracle fe-headrest-2d --json` prints the Newton iterations (the CLI
    contract) from the oracle's own `newton_iterations` diagnostic, with the per-step maximum."""
    import json

    from typer.testing import CliRunner

    from alcove_worker.cli.main import app

    trajectory = bump()
    trajectory.to_csv(tmp_path / "traj.csv")
    (tmp_path / "params.json").write_text(json.dumps({"output_dt": COARSE_DT}))
    out = tmp_path / "forces.csv"
    args = [
        "oracle",
        "run",
        "--oracle",
        "fe-headrest-2d",
        "--params",
        str(tmp_path / "params.json"),
        "--trajectory",
        str(tmp_path / "traj.csv"),
        "--out",
        str(out),
        "--json",
    ]
    proc = CliRunner().invoke(app, args)
    assert proc.exit_code == 0, proc.output
    summary = json.loads(proc.stdout)
    direct = FEHeadrestOracle(FEHeadrestParams(output_dt=COARSE_DT)).run(trajectory).diagnostics
    assert direct["newton_iterations"] == direct["newton_iterations_total"] > 0
    assert summary["status"] == "ok" and summary["newton_iterations"] == direct["newton_iterations"]
    assert 1 <= summary["diagnostics"]["newton_iterations_max"] <= summary["newton_iterations"]
    assert summary["max_penetration_m"] > 0 and summary["dissipated_energy_j"] > 0 and summary["peak_force_n"] > 0


@pytest.mark.parametrize(
    "bad, field, reason",
    [
        ({"friction": -0.1}, "params.friction", "greater than or equal to 0"),
        ({"cushion_thickness": "thick"}, "params.cushion_thickness", "valid number"),
        ({"mesh": 0.003}, "params.mesh", "Extra inputs"),
        (
            {"element_size_contact": 0.004, "element_size_far": 0.002},
            "params.element_size_far",
            "must be at least element_size_contact (0.004 m)",
        ),
        (
            {"foam_mu": [1e4], "foam_alpha": [2.0, 3.0], "foam_beta": [0.0]},
            "params.foam_alpha",
            "needs one term per modulus in foam_mu (1), got 2",
        ),
    ],
)
def test_bad_parameters_through_the_registry_name_the_field(bad, field, reason):
    """What the CLI and the campaign API see: OracleInputError naming the parameter and the reason."""
    from alcove.science.oracles.registry import build_oracle

    with pytest.raises(OracleInputError) as info:
        build_oracle("fe-headrest-2d", bad)
    assert info.value.field == field and reason in info.value.reason
