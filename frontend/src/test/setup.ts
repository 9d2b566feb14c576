import "@testing-library/jest-dom/vitest";
import { afterEach, vi } from "vitest";
import { cleanup } from "@testing-library/react";

// Plotly needs a real browser (canvas, SVG layout); component tests check the data handed to it.
vi.mock("plotly.js-basic-dist-min", () => ({
  default: {
    // like Plotly, give the element `on` so the wrapper can register its click handler; tests
    // call el.__plotly.plotly_click(...) to click a point
    react: vi.fn((el: HTMLElement & { on?: unknown; removeAllListeners?: unknown; __plotly?: Record<string, (e: unknown) => void> }) => {
      el.__plotly ??= {};
      el.on = (name: string, fn: (e: unknown) => void) => void (el.__plotly![name] = fn);
      el.removeAllListeners = (name: string) => void delete el.__plotly![name];
      return Promise.resolve();
    }),
    relayout: vi.fn(() => Promise.resolve()),
    purge: vi.fn(),
    Plots: { resize: vi.fn() },
  },
}));

afterEach(() => {
  cleanup();
  localStorage.clear();
});
