import { afterEach, beforeEach, describe, expect, it } from "vitest";
import { act, render, screen } from "@testing-library/react";
import { MemoryRouter, useLocation } from "react-router-dom";
import { XAxisSwitch } from "../components/XAxisSwitch";
import { isXAxis } from "./xaxis";
import { useBoolParam, useStringParam } from "./urlState";

/**
 * These tests dispatch events as a browser does, outside React's act(): act() would flush the
 * router's transition before the test looks, hiding what a user on a busy machine sees between
 * the event and the transition's commit.
 */
declare global {
  var IS_REACT_ACT_ENVIRONMENT: boolean | undefined;
}
let actEnvironment: boolean | undefined;
beforeEach(() => {
  actEnvironment = globalThis.IS_REACT_ACT_ENVIRONMENT;
});
afterEach(() => {
  globalThis.IS_REACT_ACT_ENVIRONMENT = actEnvironment;
});

function Search() {
  return <span data-testid="search">{useLocation().search}</span>;
}

function Controls() {
  const [raw, setX] = useStringParam("x", "iteration");
  const [log, setLog] = useBoolParam("log", true);
  const [q, setQ] = useStringParam("q");
  return (
    <>
      <XAxisSwitch value={isXAxis(raw) ? raw : "iteration"} onChange={setX} />
      <label>
        <input type="checkbox" checked={log} onChange={(e) => setLog(e.target.checked)} /> log axis
      </label>
      <label>
        search <input value={q} onChange={(e) => setQ(e.target.value)} />
      </label>
      <Search />
    </>
  );
}

function renderControls(search = "") {
  render(
    <MemoryRouter initialEntries={[`/campaigns/1${search}`]}>
      <Controls />
    </MemoryRouter>,
  );
  globalThis.IS_REACT_ACT_ENVIRONMENT = false;
}

/** Let the router's transition commit. */
async function settle() {
  globalThis.IS_REACT_ACT_ENVIRONMENT = true;
  await act(async () => {
    await new Promise((r) => setTimeout(r, 20));
  });
  globalThis.IS_REACT_ACT_ENVIRONMENT = false;
}

/** A keystroke as the browser applies it (the native setter: React's own would hide the change). */
function typeKey(input: HTMLInputElement, key: string) {
  Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value")!.set!.call(input, input.value + key);
  input.dispatchEvent(new Event("input", { bubbles: true }));
}

describe("controls that write URL state", () => {
  it("a radio shows the user's choice as soon as the click's event ends", async () => {
    renderControls();
    const oracle = screen.getByLabelText("oracle calls") as HTMLInputElement;
    oracle.click();
    expect(oracle.checked).toBe(true);
    expect(screen.getByTestId("x-axis").dataset.value).toBe("oracle");
    await settle();
    expect(oracle.checked).toBe(true);
    expect(screen.getByTestId("search").textContent).toBe("?x=oracle");
  });

  it("a checkbox keeps its new state while the navigation is pending", async () => {
    renderControls();
    const box = screen.getByLabelText("log axis") as HTMLInputElement;
    expect(box.checked).toBe(true);
    box.click();
    expect(box.checked).toBe(false);
    await settle();
    expect(box.checked).toBe(false);
    expect(screen.getByTestId("search").textContent).toBe("?log=0");
  });

  it("keys typed faster than the navigation commits are all kept", async () => {
    renderControls();
    const input = screen.getByLabelText("search") as HTMLInputElement;
    for (const key of "head") typeKey(input, key);
    expect(input.value).toBe("head");
    await settle();
    expect(input.value).toBe("head");
    expect(screen.getByTestId("search").textContent).toBe("?q=head");
  });

  it("the shown value follows the URL when the URL changes by itself", async () => {
    function Both() {
      const [x, setX] = useStringParam("x", "iteration");
      const [, setOther] = useStringParam("x", "iteration");
      return (
        <>
          <span data-testid="x">{x}</span>
          <button onClick={() => setOther("wall")}>elsewhere</button>
          <button onClick={() => setX("oracle")}>here</button>
        </>
      );
    }
    render(
      <MemoryRouter initialEntries={["/c?x=oracle"]}>
        <Both />
      </MemoryRouter>,
    );
    expect(screen.getByTestId("x").textContent).toBe("oracle");
    await act(async () => screen.getByText("elsewhere").click());
    expect(screen.getByTestId("x").textContent).toBe("wall");
    await act(async () => screen.getByText("here").click());
    expect(screen.getByTestId("x").textContent).toBe("oracle");
  });
});
