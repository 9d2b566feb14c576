"""Hexahedral meshes of the 3D headrest model: the graded foam block and the rigid head cap.

Coordinates are in the headrest frame H (m): the block occupies ``-thickness <= x <= 0``
(front face x = 0, the undeformed cushion surface), ``|y| <= width / 2`` and
``z_bottom <= z <= z_bottom + height``. Elements are ``h_contact`` in the contact zone
(in y and z) and at the front face, growing geometrically toward ``h_far`` at the back face
(ratio 1.3, the graded axes of ``fe-headrest-2d``) and toward the block's edges (ratio ``growth``).

The head is the back cap of an ellipsoid (semi-axes ``ax``, ``by``, ``az`` about the
centre ``(cx, 0, cz)`` of the head frame): one layer of hexahedra whose outer faces are
the contact surface, made rigid by the deck (``*RIGID BODY``).

Node numbering follows C3D8: nodes 1-4 one face counterclockwise seen from outside
opposite to nodes 5-8; face S2 is nodes 5-8-7-6, S4 is 2-6-7-3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from alcove.science.arrays import FloatArray, IndexArray
from alcove.science.oracles.fe_headrest.mesh import GROWTH, graded_axis, graded_sizes


@dataclass(frozen=True)
class HexMesh:
    """Nodes (n, 3) and C3D8 connectivity (m, 8) as 0-based indices."""

    nodes: FloatArray
    elements: IndexArray


@dataclass(frozen=True)
class FoamBlock:
    """The graded foam block, its back-face nodes and its front-face elements (face S4)."""

    mesh: HexMesh
    back_nodes: IndexArray
    front_elements: IndexArray
    shape: tuple[int, int, int]  # elements along x, y, z


def block_axes(
    thickness: float,
    width: float,
    height: float,
    z_bottom: float,
    h_contact: float,
    h_far: float,
    contact_half_width: float,
    contact_zone: tuple[float, float],
    growth: float = GROWTH,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Node coordinates along x (graded from the front face), y and z (fine in the contact zone,
    growing by ``growth`` outside it)."""
    x = -np.cumsum(graded_sizes(thickness, h_contact, h_far))[::-1]
    x = np.concatenate([x, [0.0]])
    x[0] = -thickness
    half = 0.5 * width
    y_lo, y_hi = on_lattice(-contact_half_width, contact_half_width, h_contact, -half, half)
    y = graded_axis(-half, half, y_lo, y_hi, h_contact, h_far, growth)
    z_lo, z_hi = on_lattice(contact_zone[0], contact_zone[1], h_contact, z_bottom, z_bottom + height)
    z = graded_axis(z_bottom, z_bottom + height, z_lo, z_hi, h_contact, h_far, growth)
    return x, y, z


def on_lattice(lo: float, hi: float, h: float, bound_lo: float, bound_hi: float) -> tuple[float, float]:
    """The zone [lo, hi] widened to multiples of ``h`` (within the bounds), so that its uniform
    nodes include 0 when 0 lies in it: the first-contact point y_H = z_H = 0 is a front-face node
    (node-to-surface contact begins when a foam node touches the head)."""
    k_lo, k_hi = np.floor(lo / h + 1e-9), np.ceil(hi / h - 1e-9)
    if k_lo * h < bound_lo - 1e-12:
        k_lo += 1
    if k_hi * h > bound_hi + 1e-12:
        k_hi -= 1
    if k_hi <= k_lo:  # a zone narrower than one element: keep it as given
        return lo, hi
    return float(k_lo * h), float(k_hi * h)


def structured_hexes(nx: int, ny: int, nz: int) -> IndexArray:
    """C3D8 connectivity of an (nx, ny, nz)-element grid whose node (i, j, k) has index i + (nx+1)(j + (ny+1)k)."""
    grid = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    i, j, k = (g.ravel(order="F") for g in grid)

    def node(di: int, dj: int, dk: int) -> IndexArray:
        out: IndexArray = (i + di) + (nx + 1) * ((j + dj) + (ny + 1) * (k + dk))
        return out

    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    return np.stack([node(*c) for c in corners], -1)


def foam_block(x: FloatArray, y: FloatArray, z: FloatArray) -> FoamBlock:
    """The block on the tensor grid x (back to front), y, z; element (i, j, k) at index i + nx (j + ny k)."""
    nx, ny, nz = len(x) - 1, len(y) - 1, len(z) - 1
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    nodes = np.stack([X.ravel(order="F"), Y.ravel(order="F"), Z.ravel(order="F")], -1)
    elements = structured_hexes(nx, ny, nz)
    back = np.flatnonzero(np.isclose(nodes[:, 0], x[0]))
    front = np.arange(nx - 1, nx * ny * nz, nx)  # i = nx - 1: the layer at the front face
    return FoamBlock(HexMesh(nodes, elements), back, front, (nx, ny, nz))


def ellipsoid_cap(
    centre: tuple[float, float],
    semi_axes: tuple[float, float, float],
    azimuth: float,
    elevation: tuple[float, float],
    element_size: float,
    layer: float,
) -> HexMesh:
    """One layer of hexahedra on the back cap of an ellipsoid, in head-frame coordinates (x, y, z).

    The cap spans ``|u| <= azimuth`` (toward +-y) and ``elevation[0] <= v <= elevation[1]``
    (toward +-z) around the -x axis, on the surface ``(cx - ax cos u cos v, by sin u cos v,
    cz + az sin v)``; the inner nodes lie ``layer`` inside along the centre direction. The
    outer faces are face S2 of every element.
    """
    cx, cz = centre
    ax, by, az = semi_axes
    mean = (ax * by * az) ** (1.0 / 3.0)
    nu = max(2, int(np.ceil(2 * azimuth * mean / element_size)))
    nv = max(2, int(np.ceil((elevation[1] - elevation[0]) * mean / element_size)))
    u = np.linspace(-azimuth, azimuth, nu + 1)
    v = np.linspace(elevation[0], elevation[1], nv + 1)
    U, V = (g.ravel(order="F") for g in np.meshgrid(u, v, indexing="ij"))
    outer = np.stack([-ax * np.cos(U) * np.cos(V), by * np.sin(U) * np.cos(V), az * np.sin(V)], -1)
    radius = np.linalg.norm(outer, axis=1, keepdims=True)
    inner = outer * (1.0 - layer / radius)
    offset = np.array([cx, 0.0, cz])
    nodes = np.concatenate([inner, outer]) + offset  # layer index k = 0 inner, 1 outer
    elements = structured_hexes(nu, nv, 1)
    # u, v, outward must be right-handed for a positive Jacobian; here (-x side) it is
    # left-handed, so mirror the element in u (swap nodes 1<->2, 4<->3, 5<->6, 8<->7)
    elements = elements[:, [1, 0, 3, 2, 5, 4, 7, 6]]
    return HexMesh(nodes, elements)


def hex_volumes_positive(mesh: HexMesh) -> bool:
    """Every element has a positive volume at its centre (checks the node order)."""
    p = mesh.nodes[mesh.elements]  # (m, 8, 3)
    dxi = (p[:, [1, 2, 6, 5]] - p[:, [0, 3, 7, 4]]).mean(1)
    deta = (p[:, [3, 2, 6, 7]] - p[:, [0, 1, 5, 4]]).mean(1)
    dzeta = (p[:, 4:] - p[:, :4]).mean(1)
    return bool(np.all(np.einsum("ij,ij->i", np.cross(dxi, deta), dzeta) > 0))


__all__ = [
    "FoamBlock",
    "HexMesh",
    "block_axes",
    "ellipsoid_cap",
    "foam_block",
    "hex_volumes_positive",
    "on_lattice",
    "structured_hexes",
]
