/**
 * A number field that keeps exactly what the user types. The text is the field's own state:
 * every keystroke is read as a number for the form (and its checks), but the number is never
 * written back into the field while it still reads as the text, so "0.0005" typed key by key
 * stays "0.0005" (not "5"), and "1e308" stays "1e308". Text that is no number ("abc", "1e",
 * "--5") is handed to the form as it is, so the form's checks name it at the field.
 */
import { useState, type InputHTMLAttributes } from "react";

/** What a number field holds: a number, nothing (empty), or the text as typed when it is no number. */
export type NumberText = number | string | undefined;

// a decimal number as people type it: 12, -0.5, .5, 5., 1e-4, +2E3 (no hex, no "Infinity", no spaces inside)
const NUMBER = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

/** The typed text as the form's value: "" -> undefined, a number -> that number, anything else -> the text itself. */
export function readNumber(text: string): NumberText {
  const t = text.trim();
  if (t === "") return undefined;
  return NUMBER.test(t) ? Number(t) : text;
}

/** The text that shows a value given from outside (a preset, a loaded definition). */
export function numberText(value: unknown): string {
  return value === undefined || value === null ? "" : String(value);
}

function same(a: unknown, b: unknown): boolean {
  if ((a === undefined || a === null) && (b === undefined || b === null)) return true;
  return Object.is(a, b);
}

export interface NumberInputProps extends Omit<InputHTMLAttributes<HTMLInputElement>, "value" | "defaultValue" | "onChange" | "type"> {
  /** the form's value: a number, empty (undefined or null), or unreadable text */
  value: unknown;
  onChange: (value: NumberText) => void;
}

export function NumberInput({ value, onChange, ...rest }: NumberInputProps) {
  const [text, setText] = useState(() => numberText(value));
  const [shown, setShown] = useState<unknown>(value);
  // a value set elsewhere (a preset, a reset, a removed row): show it, unless it is what the text already reads
  if (!same(value, shown)) {
    setShown(value);
    if (!same(readNumber(text), value)) setText(numberText(value));
  }
  return (
    <input
      {...rest}
      type="text"
      autoComplete="off"
      spellCheck={false}
      value={text}
      onChange={(e) => {
        const next = e.target.value;
        const read = readNumber(next);
        setText(next);
        setShown(read);
        onChange(read);
      }}
    />
  );
}
