"""User-defined planar open chains (pydantic) and the n-DOF model presets.

A :class:`ChainSpec` is the task-level description of a :class:`alcove.science.multibody.PlanarChain`:
1 to 6 rigid links with revolute joints (ranges, torque limits, optional springs and
dampers), gravity, the base pose, the contact body (the head: which link carries it, where
and at which tilt, and its elliptic occipital profile) and the headrest (tilt, and either its
origin or the pose at which the head first touches it). Conventions are those of
:mod:`alcove.science.multibody`: world x forward, z up, angles are backward tilts (positive
toward the headrest), ``q_0`` is measured from the base frame, ``q_i`` relative to link i-1.

Validation needs no CasADi: the kinematics the checks use (where the head is, whether it
starts inside the cushion) are a few lines of NumPy here, checked against the CasADi chain
in ``tests/science/ocp/test_chain_model.py``.

Presets (parameters and sources in docs/multibody.md):

* ``head-neck-2dof``: neck link T1 -> occipital condyles (C0/C1) and the head, joints C7/T1
  and C0/C1;
* ``trunk-neck-head-3dof``: trunk (hip -> T1), neck and head, joints hip, C7/T1, C0/C1.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from alcove.science.arrays import FloatArray
from alcove.science.geometry import GRAVITY, HeadProfile, rot2
from alcove.science.spec_checks import quantity

if TYPE_CHECKING:
    from alcove.science.multibody import PlanarChain

MAX_LINKS = 6
JOINT_LIMIT = math.pi / 2  # rad: relative joint angles of a planar body chain
MAX_TORQUE = 200.0  # N m (same bound as the task's torque bounds)

Length = Annotated[float, quantity("coordinate in a link frame", "m", ge=-2, le=2)]
WorldCoordinate = Annotated[float, quantity("world coordinate", "m", ge=-5, le=5)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class LinkSpec(_Strict):
    """A rigid link: mass, COG in the link frame, inertia about the COG, length to the next joint."""

    name: str = ""
    mass: Annotated[float, quantity("link mass", "kg", gt=0, le=200, why="a whole adult trunk is about 30-40 kg")]
    com: tuple[Length, Length] = Field(
        description="COG (x forward, z along the link from its joint) in the link frame [m], each -2 to 2"
    )
    inertia_com: Annotated[float, quantity("moment of inertia about the COG (pitch)", "kg m^2", ge=0, le=50)]
    length: Annotated[
        float, quantity("distance from the link's joint to the next joint", "m", ge=0, le=2, why="0 for the last link")
    ] = 0.0


class JointSpec(_Strict):
    """A revolute joint at the proximal end of its link (angle relative to the previous link)."""

    name: str = ""
    q_min: Annotated[float, quantity("lower joint limit", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT)]
    q_max: Annotated[float, quantity("upper joint limit", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT, why="above q_min")]
    q0: Annotated[
        float, quantity("initial joint angle", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT, why="within q_min..q_max")
    ]
    torque_limit: Annotated[
        float, quantity("joint torque limit", "N m", gt=0, le=MAX_TORQUE, why="an adult neck's largest is 30-60 N m")
    ]
    stiffness: Annotated[float, quantity("passive joint stiffness", "N m/rad", ge=0, le=1e4)] = 0.0
    q_rest: Annotated[
        float, quantity("angle at which the joint spring is relaxed", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT)
    ] = 0.0
    damping: Annotated[float, quantity("passive joint damping", "N m s/rad", ge=0, le=1e3)] = 0.0


class BaseSpec(_Strict):
    """Pose of the base frame (the first joint) in the world."""

    x: Annotated[float, quantity("base joint x (forward)", "m", ge=-5, le=5)] = 0.0
    z: Annotated[float, quantity("base joint z (up)", "m", ge=-5, le=5)] = 0.0
    angle: Annotated[
        float, quantity("base frame backward tilt (added to q_0)", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT)
    ] = 0.0


class ProfileSpec(_Strict):
    """The elliptic occipital profile in the contact body frame (defaults: the shared head profile)."""

    cx: Annotated[float, quantity("profile centre x", "m", ge=-0.5, le=0.5)] = HeadProfile.cx
    cz: Annotated[float, quantity("profile centre z", "m", ge=-0.5, le=0.5)] = HeadProfile.cz
    ax: Annotated[float, quantity("profile semi-axis front-back", "m", gt=0, le=0.5)] = HeadProfile.ax
    az: Annotated[float, quantity("profile semi-axis up-down", "m", gt=0, le=0.5)] = HeadProfile.az

    def to_profile(self) -> HeadProfile:
        return HeadProfile(self.cx, self.cz, self.ax, self.az)


class ContactBodySpec(_Strict):
    """The contact body (head): the link carrying it, its frame in that link's frame, its profile."""

    link: int | None = Field(
        None,
        ge=0,
        le=MAX_LINKS - 1,
        strict=True,
        description=f"index of the link carrying the head [-], 0 to {MAX_LINKS - 1} (0: the first link); "
        "null = the last link",
    )
    origin: tuple[Length, Length] | None = Field(
        None, description="head frame origin (x, z) in the link frame [m]; null = the link's COG"
    )
    angle: Annotated[float, quantity("head frame tilt relative to the link", "rad", ge=-math.pi, le=math.pi)] = 0.0
    profile: ProfileSpec = Field(default_factory=ProfileSpec)


class HeadrestSpec(_Strict):
    """The headrest: a plane (the undeformed cushion surface) with outward normal x_H."""

    tilt: Annotated[float, quantity("headrest inclination (backward)", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT)]
    origin: tuple[WorldCoordinate, WorldCoordinate] | None = Field(
        None, description="world (x, z) of a point of the cushion surface [m]; give this or touch_q"
    )
    touch_q: list[Annotated[float, quantity("joint angle", "rad", ge=-JOINT_LIMIT, le=JOINT_LIMIT)]] | None = Field(
        None,
        description="joint pose [rad], one per joint, at which the head profile first touches the undeformed "
        "headrest (the surface is placed through that point); give this or origin",
    )
    surface: Literal["plane"] = Field("plane", description="shape of the undeformed cushion surface (a plane)")


def _fail(field: str, reason: str) -> None:
    raise ValueError(f"{field}: {reason}")


class ChainSpec(_Strict):
    """A planar open chain of 1 to 6 links (one joint per link)."""

    links: list[LinkSpec] = Field(min_length=1, max_length=MAX_LINKS)
    joints: list[JointSpec] = Field(min_length=1, max_length=MAX_LINKS)
    gravity: Annotated[
        float, quantity("gravitational acceleration", "m/s^2", ge=0, le=100, why="0 is weightless, 100 is about 10 g")
    ] = GRAVITY
    base: BaseSpec = Field(default_factory=BaseSpec)
    contact_body: ContactBodySpec = Field(default_factory=ContactBodySpec)
    headrest: HeadrestSpec

    @model_validator(mode="after")
    def _consistent(self) -> ChainSpec:
        n = len(self.links)
        if len(self.joints) != n:
            _fail("model.chain.joints", f"expected {n} joints (one per link), got {len(self.joints)}")
        for j, joint in enumerate(self.joints):
            if not joint.q_min < joint.q_max:
                _fail(f"model.chain.joints.{j}.q_max", f"must exceed q_min ({joint.q_max:g} <= {joint.q_min:g} rad)")
            if not joint.q_min <= joint.q0 <= joint.q_max:
                _fail(
                    f"model.chain.joints.{j}.q0",
                    f"{joint.q0:g} rad lies outside the joint range [{joint.q_min:g}, {joint.q_max:g}] rad",
                )
        link = self.contact_body.link
        if link is not None and not 0 <= link < n:
            _fail("model.chain.contact_body.link", f"must be a link index 0..{n - 1}, got {link}")
        hr = self.headrest
        if (hr.origin is None) == (hr.touch_q is None):
            _fail("model.chain.headrest", "give exactly one of origin and touch_q")
        if hr.touch_q is not None:
            if len(hr.touch_q) != n:
                _fail("model.chain.headrest.touch_q", f"expected {n} value(s) (one per joint), got {len(hr.touch_q)}")
            for j, (v, joint) in enumerate(zip(hr.touch_q, self.joints, strict=True)):
                if not joint.q_min <= v <= joint.q_max:
                    _fail(
                        f"model.chain.headrest.touch_q.{j}",
                        f"{v:g} rad lies outside the joint range [{joint.q_min:g}, {joint.q_max:g}] rad",
                    )
        gap = self.head_gap(self.q0)
        if not gap > 0:
            _fail(
                "model.chain.joints",
                f"the head starts inside the cushion at q0 (gap {gap * 1e3:.3g} mm): move the headrest or the pose",
            )
        return self

    # ---- resolved numbers ------------------------------------------------------------
    @property
    def ndof(self) -> int:
        return len(self.links)

    @property
    def q0(self) -> FloatArray:
        return np.array([j.q0 for j in self.joints])

    @property
    def q_min(self) -> FloatArray:
        return np.array([j.q_min for j in self.joints])

    @property
    def q_max(self) -> FloatArray:
        return np.array([j.q_max for j in self.joints])

    @property
    def torque_limits(self) -> FloatArray:
        return np.array([j.torque_limit for j in self.joints])

    @property
    def contact_link(self) -> int:
        return self.ndof - 1 if self.contact_body.link is None else self.contact_body.link

    # ---- NumPy kinematics (validation; the OCP uses the CasADi chain) ----------------
    def head_pose_world(self, q: FloatArray) -> tuple[FloatArray, float]:
        """World (x, z) of the head frame origin and its absolute tilt at the joint pose q."""
        q = np.asarray(q, float)
        joint = np.array([self.base.x, self.base.z])
        phi = self.base.angle
        for i, link in enumerate(self.links):
            phi += q[i]
            if i == self.contact_link:
                local = self.contact_body.origin if self.contact_body.origin is not None else link.com
                return joint + rot2(phi) @ np.asarray(local, float), phi + self.contact_body.angle
            joint = joint + rot2(phi) @ np.array([0.0, link.length])
        raise AssertionError("contact link index checked by the validator")

    def headrest_origin(self) -> FloatArray:
        """World (x, z) of the headrest frame origin (given, or the touching point at touch_q)."""
        hr = self.headrest
        if hr.origin is not None:
            return np.asarray(hr.origin, float)
        pos, phi = self.head_pose_world(np.asarray(hr.touch_q, float))
        pr = self.contact_body.profile
        a = phi - hr.tilt
        c, s = math.cos(a), math.sin(a)
        norm = math.hypot(pr.ax * c, pr.az * s)
        # the profile point farthest along -x_H (minimizes x_H, see geometry.signed_gap)
        cos_s, sin_s = -pr.ax * c / norm, pr.az * s / norm
        point = np.array([pr.cx + pr.ax * cos_s, pr.cz + pr.az * sin_s])
        origin: FloatArray = pos + rot2(phi) @ point
        return origin

    def head_gap(self, q: FloatArray) -> float:
        """Signed gap [m] between the head profile and the undeformed headrest plane (> 0: clear)."""
        pos, phi = self.head_pose_world(q)
        beta = self.headrest.tilt
        r = rot2(-beta) @ (pos - self.headrest_origin())
        pr = self.contact_body.profile
        a = phi - beta
        c, s = math.cos(a), math.sin(a)
        return float(r[0] + c * pr.cx - s * pr.cz - math.hypot(pr.ax * c, pr.az * s))

    def to_chain(self) -> PlanarChain:
        from alcove.science.multibody import Headrest, Link, PlanarChain

        o = self.headrest_origin()
        return PlanarChain(
            links=tuple(Link(lk.mass, lk.com[1], lk.inertia_com, lk.length, lk.com[0]) for lk in self.links),
            q_min=tuple(self.q_min),
            q_max=tuple(self.q_max),
            torque_limit=tuple(self.torque_limits),
            gravity=self.gravity,
            base=(self.base.x, self.base.z),
            headrest=Headrest((float(o[0]), float(o[1])), self.headrest.tilt),
            base_angle=self.base.angle,
            stiffness=tuple(j.stiffness for j in self.joints),
            q_rest=tuple(j.q_rest for j in self.joints),
            damping=tuple(j.damping for j in self.joints),
            contact_link=self.contact_link,
            contact_origin=self.contact_body.origin,
            contact_angle=self.contact_body.angle,
            profile=self.contact_body.profile.to_profile(),
        )


# ---- presets --------------------------------------------------------------------------
# Sources and the reasoning behind every number: docs/multibody.md ("assumed" where no
# source gives it). Angles are backward tilts (toward the headrest).
_NECK = {"name": "neck (T1 -> C0/C1)", "mass": 1.5, "com": [0.0, 0.0675], "inertia_com": 0.0023, "length": 0.135}
_HEAD = {"name": "head", "mass": 4.5, "com": [0.016, 0.060], "inertia_com": 0.023, "length": 0.0}
_T1 = {
    "name": "C7/T1",
    "q_min": -0.72,
    "q_max": 0.72,
    "torque_limit": 30.0,
    "stiffness": 10.0,
    "damping": 0.5,
}
_C0 = {
    "name": "C0/C1",
    "q_min": -0.35,
    "q_max": 0.35,
    "q0": 0.0,
    "torque_limit": 30.0,
    "stiffness": 10.0,
    "damping": 0.5,
}

CHAIN_PRESETS: dict[str, dict[str, Any]] = {
    "head-neck-2dof": {
        "links": [_NECK, _HEAD],
        "joints": [{**_T1, "q0": 0.232, "q_rest": 0.232}, _C0],
        "contact_body": {"link": 1, "origin": None},
        "headrest": {"tilt": 0.31, "touch_q": [0.31, 0.0]},
    },
    "trunk-neck-head-3dof": {
        "links": [
            {"name": "trunk (hip -> T1)", "mass": 31.7, "com": [0.0, 0.293], "inertia_com": 1.16, "length": 0.603},
            _NECK,
            _HEAD,
        ],
        "joints": [
            # assumed: the seat back as a stiff torsional spring at the hip, relaxed so that it
            # carries the gravity moment at q0 (44.9 N m); damping ratio about 0.3
            {
                "name": "hip",
                "q_min": 0.2,
                "q_max": 0.5,
                "q0": 0.35,
                "torque_limit": 200.0,
                "stiffness": 1000.0,
                "q_rest": 0.305,
                "damping": 50.0,
            },
            {**_T1, "q0": -0.118, "q_rest": -0.118},
            _C0,
        ],
        "contact_body": {"link": 2, "origin": None},
        "headrest": {"tilt": 0.31, "touch_q": [0.35, -0.04, 0.0]},
    },
}


def chain_preset(name: str) -> dict[str, Any]:
    """The chain definition (JSON-ready) of an n-DOF model preset."""
    import copy

    return copy.deepcopy(CHAIN_PRESETS[name])


__all__ = [
    "CHAIN_PRESETS",
    "BaseSpec",
    "ChainSpec",
    "ContactBodySpec",
    "HeadrestSpec",
    "JointSpec",
    "LinkSpec",
    "ProfileSpec",
    "chain_preset",
]
