import "@testing-library/jest-dom/vitest";
import { afterEach, vi } from "vitest";
import { cleanup } from "@testing-library/react";

// Plotly needs a real browser (canvas, SVG layout); component tests check the data handed to it.
vi.mock("plotly.js-basic-dist-min", () => ({
  default: {
    react: vi.fn(() => Promise.resolve()),
    purge: vi.fn(),
    Plots: { resize: vi.fn() },
  },
}));

afterEach(() => {
  cleanup();
  localStorage.clear();
});
