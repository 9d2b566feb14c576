"""The CalculiX input deck of the 3D headrest model, written from a head motion.

Everything is in the headrest frame H, in SI units (m, N, Pa, s). The deck holds

* the foam block (C3D8, :mod:`.mesh`) as ``*HYPERFOAM`` with the shared foam law
  (nu_i = beta_i / (1 + 2 beta_i)), its back face fixed (the rigid headrest bar);
* the head: one layer of C3D8 on the back cap of its ellipsoid, a ``*RIGID BODY`` whose
  reference node sits at the head COG (the head frame origin) and whose rotation node
  carries the rotation about y_H;
* penalty contact, node-to-surface (default) or surface-to-surface (the foam's front
  face the slave, the head the master) with Coulomb friction (``*SURFACE INTERACTION``, ``*SURFACE BEHAVIOR``,
  ``*FRICTION``);
* one quasi-static ``*STATIC`` step (NLGEOM) whose step time runs over the simulated
  window; the reference node's x/z displacements and the rotation follow ``*AMPLITUDE``
  curves (``*BOUNDARY, AMPLITUDE=``); increments end at every output time
  (``*TIME POINTS``) and the reaction forces of the reference node (the force), the
  rotation node (the moment about the reference node) and of the back face are printed
  to the ``.dat`` file at those times.

The model is rate independent (the foam is elastic, friction is Coulomb): time is a
load parameter, which lets the step begin with an approach when the head starts in contact.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from io import StringIO

import numpy as np

from alcove.science.arrays import FloatArray, IndexArray
from alcove.science.oracles.fe_headrest_3d.mesh import FoamBlock, HexMesh

JOB_NAME = "headrest"
JOB_FILE = "job.json"  # what the driver needs besides the deck (output times, COG path, back-face nodes)
LOG_FILE = "ccx.log"
OUTPUT_FILE = "forces.csv"
DIAGNOSTICS_FILE = "diagnostics.json"
REF_NODE_SET = "HEADREF"
ROT_NODE_SET = "HEADROT"
BACK_NODE_SET = "BACK"
HEAD_LAYER = 0.004  # m, thickness of the head's (rigid) element layer


@dataclass(frozen=True)
class FoamMaterial:
    """``*HYPERFOAM`` terms: (mu_i [Pa], alpha_i, nu_i)."""

    terms: tuple[tuple[float, float, float], ...]

    @classmethod
    def from_beta(cls, terms: tuple[tuple[float, float, float], ...]) -> FoamMaterial:
        return cls(tuple((mu, a, b / (1.0 + 2.0 * b)) for mu, a, b in terms))


@dataclass(frozen=True)
class Contact:
    penalty: float  # Pa/m
    friction: float  # -
    stick_slope: float  # Pa/m
    formulation: str = "node-to-surface"  # or "surface-to-surface" (ccx's face-to-face penalty contact)
    tension: float = 1.0  # Pa, ccx's sigma_inf: the (tiny) tension far from the surface


@dataclass(frozen=True)
class HeadMotion:
    """Prescribed rigid motion of the head's reference node over the step time.

    ``tau`` (k,) step times from 0; ``ux``, ``uz`` (k,) displacements of the reference node
    from its place in the deck; ``rot_y`` (k,) rotation about y_H from its orientation in the
    deck [rad]; ``output_tau`` the step times of the outputs.
    """

    tau: FloatArray
    ux: FloatArray
    uz: FloatArray
    rot_y: FloatArray
    output_tau: FloatArray


#: ccx's q_u^alpha in ``*CONTROLS, PARAMETERS=FIELD``: the force [N] that ccx's relative
#: residual criteria are taken of (instead of the average force, ~0 when contact begins)
FORCE_SCALE = 10.0
RESIDUAL_CRITERION = 0.005  # R_n: largest residual 0.05 N (with a small enough correction)


@dataclass(frozen=True)
class StepControl:
    initial: float
    maximum: float
    minimum: float
    max_increments: int = 100000
    residual_floor: float = FORCE_SCALE * 1e-8  # N; ccx's default R_l = 1e-8
    late_residual: float = FORCE_SCALE * 0.02  # N; ccx's default R_P = 0.02 (after I_P = 9 iterations)
    solver: str = "SPOOLES"  # ccx's SOLVER= of *STATIC (Debian's build: SPOOLES, ITERATIVE SCALING/CHOLESKY)


@dataclass
class Deck:
    """The deck text and what the reader needs to interpret its output."""

    text: str
    ref_node: int  # 1-based
    rot_node: int
    back_nodes: IndexArray  # 1-based ids
    back_coordinates: FloatArray  # (n, 3)
    counts: dict[str, int] = field(default_factory=dict)


def _number(value: float) -> str:
    return format(float(value), ".10g")


def _write_nodes(out: StringIO, nodes: FloatArray, first: int) -> None:
    for i, (x, y, z) in enumerate(nodes):
        out.write(f"{first + i}, {_number(x)}, {_number(y)}, {_number(z)}\n")


def _write_elements(out: StringIO, elements: IndexArray, first_element: int, first_node: int) -> None:
    for i, conn in enumerate(elements):
        out.write(f"{first_element + i}, " + ", ".join(str(first_node + int(n)) for n in conn) + "\n")


def _write_ids(out: StringIO, ids: IndexArray) -> None:
    for start in range(0, len(ids), 16):
        out.write(", ".join(str(int(i)) for i in ids[start : start + 16]) + "\n")


def _write_pairs(out: StringIO, t: FloatArray, y: FloatArray) -> None:
    for a, b in zip(t, y, strict=True):
        out.write(f"{_number(a)}, {_number(b)}\n")


def write_deck(
    block: FoamBlock,
    head: HexMesh,
    head_reference: tuple[float, float, float],
    material: FoamMaterial,
    contact: Contact,
    motion: HeadMotion,
    control: StepControl,
    foam_element: str = "C3D8",
) -> Deck:
    """The deck of the model; ``head`` is placed in H already, ``head_reference`` is its COG in H."""
    out = StringIO()
    n_foam = block.mesh.nodes.shape[0]
    n_head = head.nodes.shape[0]
    head_first = n_foam + 1
    ref_node = n_foam + n_head + 1
    rot_node = ref_node + 1
    m_foam = block.mesh.elements.shape[0]
    out.write("** alcove fe-headrest-3d-ccx: head (rigid ellipsoid) on a hyperfoam headrest cushion, SI units\n")
    out.write("*NODE, NSET=NFOAM\n")
    _write_nodes(out, block.mesh.nodes, 1)
    out.write("*NODE, NSET=NHEAD\n")
    _write_nodes(out, head.nodes, head_first)
    out.write(f"*NODE, NSET={REF_NODE_SET}\n{ref_node}, " + ", ".join(_number(c) for c in head_reference) + "\n")
    out.write(f"*NODE, NSET={ROT_NODE_SET}\n{rot_node}, " + ", ".join(_number(c) for c in head_reference) + "\n")
    out.write(f"*ELEMENT, TYPE={foam_element}, ELSET=FOAM\n")
    _write_elements(out, block.mesh.elements, 1, 1)
    out.write("*ELEMENT, TYPE=C3D8, ELSET=HEAD\n")
    _write_elements(out, head.elements, m_foam + 1, head_first)
    back = block.back_nodes + 1
    out.write(f"*NSET, NSET={BACK_NODE_SET}\n")
    _write_ids(out, back)
    out.write("*SURFACE, NAME=SFOAM, TYPE=ELEMENT\n")
    for e in block.front_elements:
        out.write(f"{int(e) + 1}, S4\n")
    out.write("*SURFACE, NAME=SHEAD, TYPE=ELEMENT\n")
    for e in range(head.elements.shape[0]):
        out.write(f"{m_foam + 1 + e}, S2\n")
    out.write("*MATERIAL, NAME=FOAM\n")
    terms = material.terms
    if len(terms) == 1:  # ccx 2.20 crashes (in its solver) on *HYPERFOAM, N=1: two equal halves, the same W
        terms = ((0.5 * terms[0][0], terms[0][1], terms[0][2]),) * 2
    out.write(f"*HYPERFOAM, N={len(terms)}\n")
    values = [v for mu, a, _ in terms for v in (mu, a)] + [nu for _, _, nu in terms]
    for start in range(0, len(values), 8):
        out.write(", ".join(_number(v) for v in values[start : start + 8]) + "\n")
    out.write("*SOLID SECTION, ELSET=FOAM, MATERIAL=FOAM\n")
    out.write("*MATERIAL, NAME=HEADMAT\n*ELASTIC\n1e10, 0.3\n")
    out.write("*SOLID SECTION, ELSET=HEAD, MATERIAL=HEADMAT\n")
    out.write(f"*RIGID BODY, ELSET=HEAD, REF NODE={ref_node}, ROT NODE={rot_node}\n")
    out.write("*SURFACE INTERACTION, NAME=HEADFOAM\n*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n")
    out.write(f"{_number(contact.penalty)}, {_number(contact.tension)}\n")
    if contact.friction > 0:
        out.write(f"*FRICTION\n{_number(contact.friction)}, {_number(contact.stick_slope)}\n")
    kind = "SURFACE TO SURFACE" if contact.formulation == "surface-to-surface" else "NODE TO SURFACE"
    out.write(f"*CONTACT PAIR, INTERACTION=HEADFOAM, TYPE={kind}\nSFOAM, SHEAD\n")
    for name, values_ in (("HX", motion.ux), ("HZ", motion.uz), ("HRY", motion.rot_y)):
        out.write(f"*AMPLITUDE, NAME={name}\n")
        _write_pairs(out, motion.tau, values_)
    out.write("*TIME POINTS, NAME=OUT\n")
    for start in range(0, len(motion.output_tau), 8):
        out.write(", ".join(_number(v) for v in motion.output_tau[start : start + 8]) + "\n")
    out.write("*BOUNDARY\n")
    out.write(f"{BACK_NODE_SET}, 1, 3, 0\n")
    out.write(f"{ref_node}, 2, 2, 0\n{rot_node}, 1, 1, 0\n{rot_node}, 3, 3, 0\n")
    out.write(f"*STEP, NLGEOM, INC={control.max_increments}\n*STATIC, SOLVER={control.solver}\n")
    out.write(
        f"{_number(control.initial)}, {_number(motion.tau[-1])}, {_number(control.minimum)}, "
        f"{_number(control.maximum)}\n"
    )
    # absolute tolerances (q_u = 10 N: largest residual 0.05 N with a correction below 1 % of
    # the increment's displacement, or 0.01 N whatever the correction while the average force is
    # below 0.01 N): ccx's defaults are relative to the average force and to the increment's
    # displacement, both ~0 when contact begins, and never converge there. R_l: a residual below
    # ``residual_floor`` is equilibrium whatever the correction; without it, where the head barely
    # moves (a dwell, a turn, a cut-back increment) the correction's round-off and stick-slip
    # noise (~1e-7 m) exceeds 1 % of the increment's displacement and ccx cuts back to its minimum
    # increment although the residual is ~1e-4 N (docs/fe-oracle.md, "Robust convergence").
    # R_P: the residual criterion from the 10th iteration on (``late_residual``); with R_l at least
    # as large, an increment whose residual keeps alternating between two values of 0.1-0.3 N (a few
    # nodes flipping between stick and slip) ends there instead of being cut back after 10-17
    # iterations (docs/fe-oracle.md, "Where the iterations go")
    out.write(
        "*CONTROLS, PARAMETERS=FIELD, FIELD=DISPLACEMENT\n"
        f"{_number(RESIDUAL_CRITERION)}, 0.01, 0.0, {_number(FORCE_SCALE)}, "
        f"{_number(control.late_residual / FORCE_SCALE)}, 1e-3, 1e-3, "
        f"{_number(control.residual_floor / FORCE_SCALE)}\n"
    )
    out.write("*BOUNDARY, AMPLITUDE=HX\n" + f"{ref_node}, 1, 1, 1.0\n")
    out.write("*BOUNDARY, AMPLITUDE=HZ\n" + f"{ref_node}, 3, 3, 1.0\n")
    out.write("*BOUNDARY, AMPLITUDE=HRY\n" + f"{rot_node}, 2, 2, 1.0\n")
    out.write(f"*NODE PRINT, NSET={REF_NODE_SET}, TIME POINTS=OUT\nRF, U\n")
    out.write(f"*NODE PRINT, NSET={ROT_NODE_SET}, TIME POINTS=OUT\nRF, U\n")
    out.write(f"*NODE PRINT, NSET={BACK_NODE_SET}, TIME POINTS=OUT\nRF\n")
    out.write("*END STEP\n")
    counts = {
        "foam_nodes": n_foam,
        "foam_elements": m_foam,
        "head_nodes": n_head,
        "head_elements": int(head.elements.shape[0]),
        "contact_faces": int(block.front_elements.shape[0]),
    }
    return Deck(out.getvalue(), ref_node, rot_node, back, block.mesh.nodes[block.back_nodes], counts)


def place(points: FloatArray, origin: tuple[float, float], angle: float) -> FloatArray:
    """Head-frame points (n, 3) in H for a planar pose: origin (x, z) and tilt ``angle`` (R_y(-angle))."""
    c, s = np.cos(angle), np.sin(angle)
    x = origin[0] + c * points[:, 0] - s * points[:, 2]
    z = origin[1] + s * points[:, 0] + c * points[:, 2]
    placed: FloatArray = np.stack([x, points[:, 1], z], -1)
    return placed


__all__ = [
    "BACK_NODE_SET",
    "DIAGNOSTICS_FILE",
    "HEAD_LAYER",
    "JOB_FILE",
    "JOB_NAME",
    "LOG_FILE",
    "OUTPUT_FILE",
    "REF_NODE_SET",
    "ROT_NODE_SET",
    "Contact",
    "Deck",
    "FoamMaterial",
    "HeadMotion",
    "StepControl",
    "place",
    "write_deck",
]
