/**
 * Forward kinematics of a task's planar model, for pictures (the task editor's drawing, the
 * playback of solved trajectories). The same conventions and formulas as the backend
 * (alcove.science.multibody.PlanarChain, alcove.science.ocp.chain_model, alcove.science.geometry):
 * world x forward, z up; angles are backward tilts; link i has the absolute angle
 * phi_i = base.angle + q_0 + ... + q_i; a point (x, z) of a frame with angle phi at p lies at
 * p + (x cos phi - z sin phi, x sin phi + z cos phi). Checked against the backend's numbers in
 * kinematics.fixture.json (written by scripts/kinematics_fixture.py; tests/test_kinematics_fixture.py
 * keeps it current).
 */

export type Vec2 = [number, number];

export interface Profile {
  cx: number;
  cz: number;
  ax: number;
  az: number;
}

/** The shared elliptic occipital profile (alcove.science.geometry.HeadProfile; the fixture checks it). */
export const DEFAULT_PROFILE: Profile = { cx: 0.0, cz: -0.05, ax: 0.095, az: 0.11 };

export interface ResolvedLink {
  name: string;
  mass: number;
  com: Vec2;
  inertia_com: number;
  length: number;
}

export interface ResolvedJoint {
  name: string;
  q_min: number;
  q_max: number;
  q0: number;
}

/** A model as a planar chain with every number resolved (the headrest origin too). */
export interface Chain {
  links: ResolvedLink[];
  joints: ResolvedJoint[];
  base: { x: number; z: number; angle: number };
  contactLink: number;
  /** head frame origin in the contact link's frame; null: the link's COG */
  contactOrigin: Vec2 | null;
  contactAngle: number;
  profile: Profile;
  headrest: { origin: Vec2; tilt: number };
}

export interface Pose {
  /** every joint and the end of the last link (n + 1 points) */
  joints: Vec2[];
  /** every link's COG */
  coms: Vec2[];
  /** the head (contact body) frame: world origin and absolute angle */
  head: { origin: Vec2; angle: number };
}

type Json = Record<string, unknown>;

const num = (v: unknown): number => (typeof v === "number" && Number.isFinite(v) ? v : Number.NaN);
const vec = (v: unknown): Vec2 | null => (Array.isArray(v) && v.length === 2 ? [num(v[0]), num(v[1])] : null);
const finite = (...xs: number[]) => xs.every(Number.isFinite);

export function rotate(phi: number, [x, z]: Vec2): Vec2 {
  const c = Math.cos(phi);
  const s = Math.sin(phi);
  return [x * c - z * s, x * s + z * c];
}
const add = (a: Vec2, b: Vec2): Vec2 => [a[0] + b[0], a[1] + b[1]];

/** The 1-DOF preset's parameters with the backend's defaults for the ones not given. */
const ONE_DOF_DEFAULTS = {
  mass: 5.0,
  com_distance: 0.12,
  inertia_joint: 0.1,
  theta_min: 0.032,
  theta_max: 0.432,
  theta0: 0.232,
  torque_limit: 30.0,
  gravity: 9.81,
  theta_contact: 0.31,
  tilt: 0.31,
  headrest_offset: 0.0,
};

export const isChainModel = (model: Json | undefined): boolean => ((model?.preset as string | undefined) ?? "head-neck-1dof") !== "head-neck-1dof";

/**
 * A task's `model` (as the spec holds it) resolved to a chain; null while a number needed for
 * the picture is missing or not a number (the form shows why).
 */
export function resolveModel(model: Json | undefined): Chain | null {
  if (!model) return null;
  return isChainModel(model) ? resolveChain(model.chain as Json | undefined) : resolveOneDof(model);
}

function resolveOneDof(model: Json): Chain | null {
  const p = Object.fromEntries(Object.entries(ONE_DOF_DEFAULTS).map(([k, d]) => [k, model[k] === undefined || model[k] === null ? d : num(model[k])])) as typeof ONE_DOF_DEFAULTS;
  if (!finite(...Object.values(p))) return null;
  const d = p.com_distance;
  const chain: Chain = {
    links: [{ name: "head", mass: p.mass, com: [0, d], inertia_com: p.inertia_joint - p.mass * d * d, length: d }],
    joints: [{ name: "C7/T1", q_min: p.theta_min, q_max: p.theta_max, q0: p.theta0 }],
    base: { x: 0, z: 0, angle: 0 },
    contactLink: 0,
    contactOrigin: null,
    contactAngle: 0,
    profile: DEFAULT_PROFILE,
    headrest: { origin: [0, 0], tilt: p.tilt },
  };
  // the head's back point at theta_contact, moved by headrest_offset along the normal x_H
  const head = pose(chain, [p.theta_contact]).head;
  const back = add(head.origin, rotate(head.angle, [DEFAULT_PROFILE.cx - DEFAULT_PROFILE.ax, DEFAULT_PROFILE.cz]));
  chain.headrest.origin = add(back, [p.headrest_offset * Math.cos(p.tilt), p.headrest_offset * Math.sin(p.tilt)]);
  return chain;
}

function resolveChain(spec: Json | undefined): Chain | null {
  if (!spec || !Array.isArray(spec.links) || !Array.isArray(spec.joints) || !spec.links.length) return null;
  const links: ResolvedLink[] = (spec.links as Json[]).map((l) => ({
    name: String(l?.name ?? ""),
    mass: num(l?.mass),
    com: vec(l?.com) ?? [Number.NaN, Number.NaN],
    inertia_com: num(l?.inertia_com),
    length: l?.length === undefined ? 0 : num(l.length),
  }));
  const joints: ResolvedJoint[] = (spec.joints as Json[]).map((j) => ({ name: String(j?.name ?? ""), q_min: num(j?.q_min), q_max: num(j?.q_max), q0: num(j?.q0) }));
  if (joints.length !== links.length || !links.every((l) => finite(l.length, ...l.com))) return null;
  const base = (spec.base ?? {}) as Json;
  const body = (spec.contact_body ?? {}) as Json;
  const pr = (body.profile ?? {}) as Json;
  const profile: Profile = {
    cx: pr.cx === undefined ? DEFAULT_PROFILE.cx : num(pr.cx),
    cz: pr.cz === undefined ? DEFAULT_PROFILE.cz : num(pr.cz),
    ax: pr.ax === undefined ? DEFAULT_PROFILE.ax : num(pr.ax),
    az: pr.az === undefined ? DEFAULT_PROFILE.az : num(pr.az),
  };
  const link = body.link === undefined || body.link === null ? links.length - 1 : num(body.link);
  const hr = (spec.headrest ?? {}) as Json;
  const chain: Chain = {
    links,
    joints,
    base: { x: base.x === undefined ? 0 : num(base.x), z: base.z === undefined ? 0 : num(base.z), angle: base.angle === undefined ? 0 : num(base.angle) },
    contactLink: link,
    contactOrigin: body.origin === undefined || body.origin === null ? null : vec(body.origin),
    contactAngle: body.angle === undefined ? 0 : num(body.angle),
    profile,
    headrest: { origin: [0, 0], tilt: num(hr.tilt) },
  };
  if (!Number.isInteger(link) || link < 0 || link >= links.length || (body.origin != null && chain.contactOrigin === null)) return null;
  if (!finite(chain.base.x, chain.base.z, chain.base.angle, chain.contactAngle, chain.headrest.tilt, ...Object.values(profile)) || !(profile.ax > 0 && profile.az > 0)) return null;
  const origin = vec(hr.origin);
  if (origin && finite(...origin)) chain.headrest.origin = origin;
  else if (Array.isArray(hr.touch_q) && hr.touch_q.length === links.length && hr.touch_q.every((v) => Number.isFinite(num(v)))) chain.headrest.origin = touchingPoint(chain, hr.touch_q.map(num));
  else return null;
  return chain;
}

/** Joint positions, COGs and the head frame at the joint pose q. */
export function pose(chain: Chain, q: readonly number[]): Pose {
  let joint: Vec2 = [chain.base.x, chain.base.z];
  let phi = chain.base.angle;
  const joints: Vec2[] = [joint];
  const coms: Vec2[] = [];
  let head: Pose["head"] | null = null;
  chain.links.forEach((link, i) => {
    phi += q[i] ?? 0;
    coms.push(add(joint, rotate(phi, link.com)));
    if (i === chain.contactLink) head = { origin: add(joint, rotate(phi, chain.contactOrigin ?? link.com)), angle: phi + chain.contactAngle };
    joint = add(joint, rotate(phi, [0, link.length]));
    joints.push(joint);
  });
  return { joints, coms, head: head ?? { origin: joint, angle: phi } };
}

/** The head frame in the headrest frame H: (x along the normal x_H, z along the surface, tilt relative to the headrest). */
export function headInHeadrest(chain: Chain, q: readonly number[]): { x: number; z: number; angle: number } {
  const { origin, angle } = pose(chain, q).head;
  const [x, z] = rotate(-chain.headrest.tilt, [origin[0] - chain.headrest.origin[0], origin[1] - chain.headrest.origin[1]]);
  return { x, z, angle: angle - chain.headrest.tilt };
}

/** The profile point nearest the headrest (smallest x_H) in the head frame, for the head at relative tilt a. */
function nearestProfilePoint(profile: Profile, a: number): Vec2 {
  const c = Math.cos(a);
  const s = Math.sin(a);
  const norm = Math.hypot(profile.ax * c, profile.az * s);
  return [profile.cx - (profile.ax * profile.ax * c) / norm, profile.cz + (profile.az * profile.az * s) / norm];
}

/** World point of the head profile at the joint pose q where the head touches the undeformed headrest (headrest.touch_q). */
function touchingPoint(chain: Chain, q: readonly number[]): Vec2 {
  const { origin, angle } = pose(chain, q).head;
  return add(origin, rotate(angle, nearestProfilePoint(chain.profile, angle - chain.headrest.tilt)));
}

/** The profile point nearest the headrest, in the world: where the contact force acts in the picture. */
export function contactPoint(chain: Chain, q: readonly number[]): Vec2 {
  return touchingPoint(chain, q);
}

/** Signed gap [m] between the head profile and the undeformed headrest plane (> 0: clear; < 0: the cushion is pressed in). */
export function signedGap(chain: Chain, q: readonly number[]): number {
  const { x, angle: a } = headInHeadrest(chain, q);
  const { cx, cz, ax, az } = chain.profile;
  const c = Math.cos(a);
  const s = Math.sin(a);
  return x + c * cx - s * cz - Math.hypot(ax * c, az * s);
}

/** The whole head profile (ellipse) in world coordinates, n points. */
export function profileOutline(chain: Chain, q: readonly number[], n = 72): Vec2[] {
  const { origin, angle } = pose(chain, q).head;
  const { cx, cz, ax, az } = chain.profile;
  return Array.from({ length: n }, (_, i) => {
    const s = (2 * Math.PI * i) / n;
    return add(origin, rotate(angle, [cx + ax * Math.cos(s), cz + az * Math.sin(s)]));
  });
}

/** A vector given in the headrest frame H (e.g. the contact force fx, fz) in world coordinates. */
export function headrestToWorld(chain: Chain, v: Vec2): Vec2 {
  return rotate(chain.headrest.tilt, v);
}

/** The initial joint pose of a task: initial.q where given, else the model's (theta0, the joints' q0). */
export function initialPose(chain: Chain, initialQ: unknown): number[] {
  const q0 = chain.joints.map((j) => j.q0);
  if (Array.isArray(initialQ) && initialQ.length === q0.length && initialQ.every((v) => typeof v === "number" && Number.isFinite(v))) return initialQ as number[];
  return q0;
}

/**
 * The head-neck-1dof model as a user-defined chain (preset "chain") with the same kinematics and
 * dynamics: one link with the head's mass, its COG at com_distance, the inertia about the COG,
 * the joint range; the headrest through the same point (touch_q = theta_contact, or its origin
 * when the headrest is moved).
 */
export function oneDofAsChain(model: Json): Json | null {
  const chain = resolveOneDof(model);
  if (!chain) return null;
  const p = { ...ONE_DOF_DEFAULTS, ...Object.fromEntries(Object.entries(model).filter(([, v]) => typeof v === "number")) } as typeof ONE_DOF_DEFAULTS;
  const [link] = chain.links;
  const [joint] = chain.joints;
  return {
    preset: "chain",
    chain: {
      links: [{ name: "head", mass: link.mass, com: link.com, inertia_com: link.inertia_com, length: link.length }],
      joints: [{ name: "C7/T1", q_min: joint.q_min, q_max: joint.q_max, q0: joint.q0, torque_limit: p.torque_limit, stiffness: 0, q_rest: 0, damping: 0 }],
      gravity: p.gravity,
      base: { x: 0, z: 0, angle: 0 },
      contact_body: { link: null, origin: null, angle: 0, profile: { ...DEFAULT_PROFILE } },
      headrest: p.headrest_offset ? { tilt: p.tilt, origin: chain.headrest.origin, touch_q: null, surface: "plane" } : { tilt: p.tilt, origin: null, touch_q: [p.theta_contact], surface: "plane" },
    },
  };
}

/** Bounds [xmin, zmin, xmax, zmax] of points. */
export function bounds(points: Vec2[]): [number, number, number, number] {
  let b: [number, number, number, number] = [Infinity, Infinity, -Infinity, -Infinity];
  for (const [x, z] of points) if (Number.isFinite(x) && Number.isFinite(z)) b = [Math.min(b[0], x), Math.min(b[1], z), Math.max(b[2], x), Math.max(b[3], z)];
  return b;
}
