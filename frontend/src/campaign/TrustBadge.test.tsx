import { describe, expect, it } from "vitest";
import { render, screen } from "@testing-library/react";
import { TrustBadge } from "./ForcesPanel";
import { toPoints, type SeriesRow } from "../api/series";

const row = (k: number, trusted: boolean | null, reasons: string[] = []): SeriesRow =>
  ({
    iteration_index: k,
    force_rmse: 1,
    moment_rmse: 0.1,
    ocp_trusted: trusted,
    ocp_trust: trusted === null ? null : { trusted, reasons },
  }) as unknown as SeriesRow;

describe("trust badge of an iteration's OCP solution", () => {
  it("warns with the reason when the solution relies on force outside the data", () => {
    const reason = "ghost force: the surrogate predicts 38.3 N with the head 7.8 mm clear of the cushion";
    const points = toPoints([row(1, true), row(2, false, [reason]), row(3, null)], []);
    const { rerender } = render(<TrustBadge point={points[1]} />);
    expect(screen.getByTestId("trust-badge").textContent).toContain(reason);
    rerender(<TrustBadge point={points[0]} />);
    expect(screen.queryByTestId("trust-badge")).toBeNull();
    rerender(<TrustBadge point={points[2]} />); // not assessed (older iterations): no claim either way
    expect(screen.queryByTestId("trust-badge")).toBeNull();
  });
});
