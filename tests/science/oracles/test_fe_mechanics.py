"""fe-headrest-2d solver against known solutions: homogeneous compression, Hertz line contact, mirror symmetry."""

import numpy as np
import pytest

from alcove.science.oracles.fe_headrest.contact import PenaltyContact, RigidEllipse, RigidHalfPlane
from alcove.science.oracles.fe_headrest.foam import Hyperfoam
from alcove.science.oracles.fe_headrest.mesh import build_cushion_mesh
from alcove.science.oracles.fe_headrest.params import FEHeadrestParams
from alcove.science.oracles.fe_headrest.solver import CushionSolver, single_threaded_blas

DEFAULT = FEHeadrestParams()
FOAM = Hyperfoam(DEFAULT.foam_mu, DEFAULT.foam_alpha, DEFAULT.foam_beta)
PLATE_POSE_ANGLE = np.pi  # the half-plane body x <= 0 turned to face the cushion (normal -x_H)

MESHES = {
    "default-graded": {
        "thickness": 0.04,
        "height": 0.22,
        "z_bottom": -0.10,
        "h_contact": 0.006,
        "h_far": 0.015,
        "contact_zone": (-0.06, 0.07),
    },
    "coarse-skewed": {
        "thickness": 0.07,
        "height": 0.15,
        "z_bottom": -0.02,
        "h_contact": 0.011,
        "h_far": 0.03,
        "contact_zone": (0.0, 0.03),
    },
}


@pytest.mark.parametrize("mesh_name", MESHES)
@pytest.mark.parametrize("viscosity", [0.0, 500.0])
def test_flat_plate_compression_reproduces_the_foam_law_exactly(mesh_name, viscosity):
    """A frictionless rigid plate compresses the block homogeneously (beta = 0: no lateral
    bulging). The reaction per unit width equals height x nominal stress at the actual
    stretch (the plate position corrected by the penalty penetration), on any mesh; with
    viscosity, plus the backward-Euler Kelvin-Voigt stress lambda * eta * dE/dt."""
    spec = MESHES[mesh_name]
    mesh = build_cushion_mesh(**spec)
    solver = CushionSolver(mesh, FOAM, PenaltyContact(RigidHalfPlane(), mesh.surface_lengths, 5e8), viscosity=viscosity)
    dt = 0.01
    T, H = spec["thickness"], spec["height"]
    stretch_prev = 1.0
    with single_threaded_blas():
        for depth in [0.001, 0.004, 0.01, 0.02, 0.03]:
            depth *= T / 0.05
            res = solver.step((np.array([-depth, 0.0]), PLATE_POSE_ANGLE), dt)
            assert res.converged
            stretch = 1.0 - (depth - res.max_penetration) / T
            E, E_prev = 0.5 * (stretch**2 - 1), 0.5 * (stretch_prev**2 - 1)
            nominal = FOAM.uniaxial_nominal_stress(stretch) + stretch * viscosity * (E - E_prev) / dt
            assert res.force_on_body[0] == pytest.approx(-H * nominal, rel=1e-7)  # pushes the plate away (+x)
            assert abs(res.force_on_body[1]) < 1e-9 * res.force_on_body[0]
            np.testing.assert_allclose(res.bar_reaction, res.force_on_body, rtol=1e-7, atol=1e-9)
            assert res.bar_moment == pytest.approx(res.moment_on_body, rel=1e-6, abs=1e-9 * H * res.force_on_body[0])
            # homogeneous: every front node at the same depth, no vertical motion anywhere
            assert np.ptp(solver.u[0::2][mesh.surface_nodes]) < 1e-9 * depth
            assert np.max(np.abs(solver.u[1::2])) < 1e-9 * depth
            stretch_prev = stretch


def test_small_indentation_by_a_cylinder_agrees_with_hertz_line_contact():
    """Rigid cylinder (radius R) on a thick, nearly linear foam block, plane strain, frictionless.

    Hertz: half-width a = sqrt(4 P' R / (pi E*)), peak pressure p0 = sqrt(P' E* / (pi R)),
    E* = E / (1 - nu^2); valid for a << R, layer thickness >> a, small strain. Compared at
    the computed load P' (the depth is not determined by a half-space in 2D).
    """
    mu = 20e3
    law = Hyperfoam((mu,), (2.0,), (0.0,))  # small strain: E = 2 mu, nu = 0
    E_star = 2 * mu
    R = 0.1
    h = 0.0005
    mesh = build_cushion_mesh(
        thickness=0.12, height=0.3, z_bottom=-0.15, h_contact=h, h_far=0.012, contact_zone=(-0.012, 0.012)
    )
    solver = CushionSolver(mesh, law, PenaltyContact(RigidEllipse(0.0, 0.0, R, R), mesh.surface_lengths, 1e11))
    depth = 2.5e-4
    with single_threaded_blas():
        res = solver.step((np.array([R - depth, 0.0]), 0.0), 1.0)
    assert res.converged
    load = res.force_on_body[0]  # per unit width
    a_hertz = np.sqrt(4 * load * R / (np.pi * E_star))
    p0_hertz = np.sqrt(load * E_star / (np.pi * R))
    assert a_hertz / R < 0.05 and 10 * a_hertz < 0.12  # inside Hertz's range of validity
    z = mesh.nodes[mesh.surface_nodes, 1]
    pressure = res.pressure
    assert pressure.max() == pytest.approx(p0_hertz, rel=0.05)
    in_contact = z[pressure > 0]
    a_inner = min(-in_contact.min(), in_contact.max())  # last nodes in contact
    assert a_inner <= a_hertz * 1.05 and a_hertz <= a_inner + h + 0.05 * a_hertz
    # the pressure profile is the Hertz ellipse p0 sqrt(1 - z^2 / a^2) inside the contact
    inner = np.abs(z) < 0.8 * a_hertz
    np.testing.assert_allclose(pressure[inner], p0_hertz * np.sqrt(1 - (z[inner] / a_hertz) ** 2), atol=0.06 * p0_hertz)


def test_mirrored_motion_mirrors_the_forces():
    """A cushion symmetric about z = 0, an elliptic head and its mirror image (z -> -z) moved
    along mirrored paths with friction: fx is the same, fz and the moment change sign."""
    mesh = build_cushion_mesh(
        thickness=0.05, height=0.2, z_bottom=-0.1, h_contact=0.006, h_far=0.015, contact_zone=(-0.06, 0.06)
    )
    t = np.linspace(0, 0.1, 41)
    x = 0.095 - 0.006 * np.sin(np.pi * t / 0.1)  # press in 6 mm and release
    z = 0.01 + 0.1 * t  # while sliding up
    angle = 0.05 + 0.5 * t
    results = []
    with single_threaded_blas():
        for sign in (1.0, -1.0):
            body = RigidEllipse(0.0, sign * -0.035, 0.095, 0.11)
            solver = CushionSolver(
                mesh, FOAM, PenaltyContact(body, mesh.surface_lengths, 5e8, 0.4, 1e-5), viscosity=300.0
            )
            steps = [solver.step((np.array([x[k], sign * z[k]]), sign * angle[k]), t[1] - t[0]) for k in range(t.size)]
            assert all(s.converged for s in steps)
            results.append((np.array([s.force_on_body for s in steps]), np.array([s.moment_on_body for s in steps])))
    (f, m), (f_mirror, m_mirror) = results
    scale = np.abs(f).max()
    assert scale > 10.0  # a real contact happened (N per m width)
    np.testing.assert_allclose(f_mirror[:, 0], f[:, 0], atol=1e-6 * scale)
    np.testing.assert_allclose(f_mirror[:, 1], -f[:, 1], atol=1e-6 * scale)
    np.testing.assert_allclose(m_mirror, -m, atol=1e-6 * scale * 0.1)
    assert np.abs(f[:, 1]).max() > 0.05 * scale  # friction makes fz non-trivial
