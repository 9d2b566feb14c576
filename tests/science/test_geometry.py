"""Geometry and frames: the shared source of truth for head and headrest."""

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset, relative_kinematics, rot3_from_tilt
from alcove.science.series import ForceSeries, SeriesFormatError, Trajectory


def gap_of_profile(preset: HeadNeckPreset, theta: float) -> float:
    """Smallest signed distance (along x_H) of the head profile from the cushion surface."""
    kin = relative_kinematics(preset, np.array([theta]), np.array([0.0]))
    pts = preset.profile.points(4000)
    R = kin.T_rel[0][np.ix_([0, 2], [0, 2])]
    xz = kin.r_rel[0, [0, 2]] + pts @ R.T
    return float(xz[:, 0].min())


def test_first_contact_at_theta_contact():
    p = DEFAULT_PRESET
    assert gap_of_profile(p, p.theta_contact) == pytest.approx(0.0, abs=1e-7)
    assert gap_of_profile(p, p.theta0) > 0.005  # clear of the headrest at the start
    assert gap_of_profile(p, p.theta_contact + 0.05) < 0  # tilting further penetrates


def test_relative_kinematics_velocity_is_time_derivative():
    p = DEFAULT_PRESET
    th = np.linspace(0.1, 0.4, 50)
    thd = np.full_like(th, 0.7)
    kin = relative_kinematics(p, th, thd)
    h = 1e-6
    fd = (relative_kinematics(p, th + h * thd, thd).r_rel - relative_kinematics(p, th - h * thd, thd).r_rel) / (2 * h)
    np.testing.assert_allclose(kin.v_rel, fd, atol=1e-8)
    # distance from the joint is constant: the head origin rotates on a circle of radius d
    joint_h = relative_kinematics(p, np.array([0.0]), np.array([0.0])).r_rel[0] - rot3_from_tilt(-p.tilt) @ np.array(
        [0, 0, p.com_distance]
    )
    np.testing.assert_allclose(np.linalg.norm(kin.r_rel - joint_h, axis=1), p.com_distance, rtol=1e-12)
    assert np.allclose(kin.angle, th - p.tilt)
    assert np.all(kin.omega_rel[:, 1] == -thd)


def test_trajectory_csv_roundtrip_and_errors(tmp_path):
    t = np.linspace(0, 1, 11)
    tr = Trajectory(t, np.sin(t), np.cos(t), 0.1 * t)
    f = tmp_path / "a.csv"
    tr.to_csv(f)
    back = Trajectory.from_csv(f)
    np.testing.assert_array_equal(back.q, tr.q)
    assert f.read_text().splitlines()[0] == "t,q_0,qd_0,tau_0"
    f.write_text("t,q_0,qd_0\n0,1,2\n0,1,2\n")
    with pytest.raises(SeriesFormatError, match=r"^t: time must increase"):
        Trajectory.from_csv(f)
    f.write_text("t,q_0\n0,1\n1,2\n")
    with pytest.raises(SeriesFormatError, match="qd"):
        Trajectory.from_csv(f)
    f.write_text("t,fx,fy,fz,mx,my\n0,1,2,3,4,5\n")
    with pytest.raises(SeriesFormatError, match=r"^mz: missing"):
        ForceSeries.from_csv(f)
    f.write_text("t,fx,fy,fz,mx,my,mz\n0,1,2,3,4,5,nan\n1,1,2,3,4,5,6\n")
    with pytest.raises(SeriesFormatError, match=r"^mz: non-finite"):
        ForceSeries.from_csv(f)
