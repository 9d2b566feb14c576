import { useId } from "react";
import { X_AXES, type XAxis } from "../lib/xaxis";

/** Iteration / oracle calls / wall time: the x axis of the RMSE, validation and calibration plots. */
export function XAxisSwitch({ value, onChange }: { value: XAxis; onChange: (v: XAxis) => void }) {
  const name = useId();
  return (
    <fieldset className="segmented" data-testid="x-axis" data-value={value}>
      <legend className="muted">x axis</legend>
      {X_AXES.map(([key, label]) => (
        <label key={key} className="field-inline">
          <input type="radio" name={name} value={key} checked={value === key} onChange={() => onChange(key)} /> {label}
        </label>
      ))}
    </fieldset>
  );
}
