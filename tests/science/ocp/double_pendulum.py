"""One double pendulum for the chain tests: its parameters and its textbook equations, written out
by hand (Spong, Hutchinson & Vidyasagar, Robot Modeling and Control, the two-link arm) in relative
angles measured from the upward vertical, V = m1 g c1 cos q1 + m2 g (l1 cos q1 + c2 cos(q1 + q2))."""

import numpy as np

from alcove.science.multibody import Link, PlanarChain

G = 9.81
M1, M2, L1, C1, C2, I1, I2 = 2.0, 1.0, 0.5, 0.25, 0.3, 0.04, 0.02


def double_pendulum() -> PlanarChain:
    """The two links above as an alcove chain (wide joint ranges, gravity G)."""
    return PlanarChain((Link(M1, C1, I1, L1), Link(M2, C2, I2, 0.6)), (-10, -10), (10, 10), (10, 10), gravity=G)


def textbook_mass_matrix(q2: float) -> np.ndarray:
    m11 = I1 + I2 + M1 * C1**2 + M2 * (L1**2 + C2**2 + 2 * L1 * C2 * np.cos(q2))
    m12 = I2 + M2 * (C2**2 + L1 * C2 * np.cos(q2))
    return np.array([[m11, m12], [m12, I2 + M2 * C2**2]])


def textbook_rhs(_t: float, x: np.ndarray) -> list[float]:
    """The state derivative [w1, w2, qdd1, qdd2] of the hand-written equations."""
    q1, q2, w1, w2 = x
    h = -M2 * L1 * C2 * np.sin(q2)
    coriolis = np.array([h * (2 * w1 * w2 + w2**2), -h * w1**2])
    gravity = np.array(
        [M1 * G * C1 * np.sin(q1) + M2 * G * (L1 * np.sin(q1) + C2 * np.sin(q1 + q2)), M2 * G * C2 * np.sin(q1 + q2)]
    )
    acc = np.linalg.solve(textbook_mass_matrix(q2), gravity - coriolis)
    return [w1, w2, acc[0], acc[1]]
