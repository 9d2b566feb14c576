"""`python -m bench.run`: a figure that fails is reported in the table and the JSON with its
error, the other figures are still measured, and the run exits 1."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import harness, run


def test_a_failing_figure_is_reported_and_the_others_still_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.setattr(harness, "FIGURES", [])
    monkeypatch.setattr(run, "FIGURES", harness.FIGURES)
    monkeypatch.setattr(run, "load_figures", lambda: None)
    setup_calls = []

    def broken_setup() -> None:
        setup_calls.append(1)
        raise ConnectionError("server did not answer")

    harness.figure("fine before", "s", reps=2)(lambda ctx: 1.5)
    harness.figure("shares a broken setup A", "s", setup=broken_setup)(lambda ctx: 1.0)
    harness.figure("shares a broken setup B", "s", setup=broken_setup)(lambda ctx: 1.0)
    harness.figure("raises in a repetition", "ms", target=5.0)(lambda ctx: 1 / 0)
    harness.figure("fine after", "ms", target=5.0, reps=3)(lambda ctx: 2.0)

    out = tmp_path / "results.json"
    assert run.main(["--out", str(out)]) == 1
    rows = {r["figure"]: r for r in json.loads(out.read_text())["figures"]}
    assert (
        rows["fine before"]["median"] == 1.5
        and rows["fine after"]["median"] == 2.0
        and rows["fine after"]["within_target"] is True
    )
    assert (
        rows["shares a broken setup A"]["error"]
        == rows["shares a broken setup B"]["error"]
        == "ConnectionError: server did not answer"
    )
    assert setup_calls == [1]  # a failed setup is not run again for the figures that share it
    assert rows["raises in a repetition"]["error"] == "ZeroDivisionError: division by zero"
    assert rows["raises in a repetition"]["median"] is None and "error" not in rows["fine after"]
    printed = capsys.readouterr().out
    assert "ERROR" in printed and "3 figure(s) failed" in printed
