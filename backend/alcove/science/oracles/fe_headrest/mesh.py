"""Graded quadrilateral mesh of the cushion block (plane strain, headrest frame x-z).

The block occupies ``-thickness <= x <= 0`` (front face x = 0 is the undeformed cushion
surface, the plane x_H = 0) and ``z_bottom <= z <= z_bottom + height``. Elements are
``h_contact`` wide in the contact zone (along z) and at the front face, growing
geometrically to ``h_far`` toward the back face and the top and bottom ends.

Mesh, bilinear shape functions and 2x2 Gauss quadrature come from scikit-fem
(``MeshQuad.init_tensor``, ``CellBasis(ElementQuad1)``); the solver assembles from the
precomputed gradients with NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skfem import CellBasis, ElementQuad1, MeshQuad

from alcove.science.arrays import FloatArray, IndexArray

GROWTH = 1.3  # ratio of neighbouring element sizes in the graded parts


def graded_sizes(length: float, h_start: float, h_end: float, growth: float = GROWTH) -> FloatArray:
    """Element sizes covering ``length``, growing geometrically from ``h_start`` toward ``h_end``."""
    sizes: list[float] = []
    h, total = h_start, 0.0
    while total < length - 1e-12:
        sizes.append(h)
        total += h
        h = min(h * growth, h_end) if h_end >= h_start else max(h / growth, h_end)
    sizes_arr = np.array(sizes)
    n = max(1, len(sizes_arr) - (1 if total - length > 0.5 * sizes_arr[-1] else 0))
    sizes_arr = sizes_arr[:n]
    scaled: FloatArray = sizes_arr * (length / sizes_arr.sum())
    return scaled


def graded_axis(
    lo: float, hi: float, fine_lo: float, fine_hi: float, h_fine: float, h_far: float, growth: float = GROWTH
) -> FloatArray:
    """Node coordinates on [lo, hi]: uniform ``h_fine`` on [fine_lo, fine_hi], graded outside
    (neighbouring sizes in the ratio ``growth``, at most ``h_far``)."""
    fine_lo, fine_hi = max(lo, fine_lo), min(hi, fine_hi)
    n_fine = max(1, int(np.ceil((fine_hi - fine_lo) / h_fine - 1e-9)))
    nodes = list(np.linspace(fine_lo, fine_hi, n_fine + 1))
    if fine_lo > lo + 1e-12:
        below = np.cumsum(graded_sizes(fine_lo - lo, h_fine * growth, h_far, growth))
        nodes = list(fine_lo - below[::-1]) + nodes
        nodes[0] = lo
    if fine_hi < hi - 1e-12:
        above = np.cumsum(graded_sizes(hi - fine_hi, h_fine * growth, h_far, growth))
        nodes = nodes + list(fine_hi + above)
        nodes[-1] = hi
    return np.array(nodes)


@dataclass
class CushionMesh:
    """Mesh plus everything the assembly needs, computed once."""

    mesh: MeshQuad
    nodes: FloatArray  # (n_nodes, 2) reference coordinates (x, z)
    element_nodes: IndexArray  # (n_elements, 4)
    grad: FloatArray  # (n_elements, n_qp, 4, 2) shape-function gradients in the reference
    weights: FloatArray  # (n_elements, n_qp) quadrature weight x |det J| [m^2]
    back_nodes: IndexArray  # tied to the rigid headrest bar
    surface_nodes: IndexArray  # front face x = 0, candidate contact nodes, ordered along z
    surface_lengths: FloatArray  # tributary length of each surface node [m]
    thickness: float
    height: float

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.element_nodes.shape[0])

    @property
    def n_dofs(self) -> int:
        return 2 * self.n_nodes


def build_cushion_mesh(
    thickness: float,
    height: float,
    z_bottom: float,
    h_contact: float,
    h_far: float,
    contact_zone: tuple[float, float],
) -> CushionMesh:
    """Graded mesh of the cushion block; ``contact_zone`` = (z_lo, z_hi) of the fine part."""
    x = -np.cumsum(graded_sizes(thickness, h_contact, h_far))[::-1]
    x = np.concatenate([x, [0.0]])
    x[0] = -thickness
    z = graded_axis(z_bottom, z_bottom + height, contact_zone[0], contact_zone[1], h_contact, h_far)
    mesh = MeshQuad.init_tensor(x, z)
    basis = CellBasis(mesh, ElementQuad1(), intorder=2)
    element_nodes = np.asarray(basis.element_dofs).T.copy()
    grad = np.stack([basis.basis[a][0].grad for a in range(4)], 0)  # (4, 2, ne, nq)
    grad = np.ascontiguousarray(grad.transpose(2, 3, 0, 1))
    weights = np.asarray(basis.dx)
    nodes = mesh.p.T.copy()
    back = np.flatnonzero(np.isclose(nodes[:, 0], -thickness))
    surface = np.flatnonzero(np.isclose(nodes[:, 0], 0.0))
    surface = surface[np.argsort(nodes[surface, 1])]
    zs = nodes[surface, 1]
    lengths = np.zeros_like(zs)
    seg = np.diff(zs)
    lengths[:-1] += 0.5 * seg
    lengths[1:] += 0.5 * seg
    return CushionMesh(mesh, nodes, element_nodes, grad, weights, back, surface, lengths, thickness, height)
