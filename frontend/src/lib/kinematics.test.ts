import { describe, expect, it } from "vitest";
import fixture from "./kinematics.fixture.json";
import { contactPoint, headInHeadrest, oneDofAsChain, pose, resolveModel, signedGap } from "./kinematics";

// The backend's numbers (scripts/kinematics_fixture.py; tests/test_kinematics_fixture.py keeps the
// file current). Threshold: 1e-10 m / rad, float round-off of the same formulas (a wrong
// convention or parameter is off by mm or more).
const TOL = 1e-10;
type State = (typeof fixture.cases)[number]["states"][number];

function expectClose(actual: number[], expected: number[], what: string) {
  expect(actual.length, what).toBe(expected.length);
  actual.forEach((v, i) => expect(Math.abs(v - expected[i]), `${what}[${i}]: ${v} vs ${expected[i]}`).toBeLessThan(TOL));
}

describe("forward kinematics against the backend's", () => {
  for (const c of fixture.cases) {
    it(c.name, () => {
      const chain = resolveModel(c.model as Record<string, unknown>);
      expect(chain).not.toBeNull();
      expectClose(chain!.headrest.origin, c.headrest.origin, "headrest origin");
      expect(Math.abs(chain!.headrest.tilt - c.headrest.tilt)).toBeLessThan(TOL);
      for (const s of c.states as State[]) {
        const p = pose(chain!, s.q);
        expectClose(p.joints.flat(), s.joints.flat(), `joints at q=${s.q}`);
        expectClose(p.coms.flat(), s.coms.flat(), `COGs at q=${s.q}`);
        expectClose([...p.head.origin, p.head.angle], [...s.head_origin, s.head_angle], `head frame at q=${s.q}`);
        const h = headInHeadrest(chain!, s.q);
        expectClose([h.x, h.z, h.angle], s.head_in_headrest, `head in H at q=${s.q}`);
        expectClose([signedGap(chain!, s.q)], [s.gap], `gap at q=${s.q}`);
      }
    });
  }

  it("the contact point lies on the headrest plane when the gap is zero (the headrest placed by touch_q)", () => {
    const c = fixture.cases.find((x) => x.name === "head-neck-2dof")!;
    const chain = resolveModel(c.model as Record<string, unknown>)!;
    const touch = (c.model as { chain: { headrest: { touch_q: number[] } } }).chain.headrest.touch_q;
    expect(Math.abs(signedGap(chain, touch))).toBeLessThan(TOL);
    const p = contactPoint(chain, touch);
    expectClose(p, chain.headrest.origin, "contact point at touch_q");
  });
});

describe("the 1-DOF model as a user-defined chain", () => {
  for (const name of ["head-neck-1dof", "head-neck-1dof, headrest moved and tilted"]) {
    it(`${name}: the same kinematics and the same gap`, () => {
      const c = fixture.cases.find((x) => x.name === name)!;
      const asChain = oneDofAsChain(c.model as Record<string, unknown>)!;
      expect(asChain.preset).toBe("chain");
      const chain = resolveModel(asChain)!;
      for (const s of c.states as State[]) {
        expectClose(pose(chain, s.q).joints.flat(), s.joints.flat(), "joints");
        expectClose([signedGap(chain, s.q)], [s.gap], "gap");
      }
    });
  }
});

describe("an incomplete model draws nothing (the form says why)", () => {
  it("a chain link without a number, a missing headrest", () => {
    const c = fixture.cases.find((x) => x.name === "head-neck-2dof")!;
    const model = structuredClone(c.model) as { chain: { links: { com: unknown }[]; headrest: Record<string, unknown> } };
    model.chain.links[1].com = [Number.NaN, 0.06];
    expect(resolveModel(model as unknown as Record<string, unknown>)).toBeNull();
    const other = structuredClone(c.model) as { chain: { headrest: Record<string, unknown> } };
    other.chain.headrest = { tilt: 0.3, origin: null, touch_q: null };
    expect(resolveModel(other as unknown as Record<string, unknown>)).toBeNull();
  });
});
