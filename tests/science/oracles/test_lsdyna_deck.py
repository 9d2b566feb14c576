"""The worked LS-DYNA example renders to a deck LS-DYNA can read (nobody has LS-DYNA here).

The example template (examples/command-oracle/lsdyna/headrest.k.tmpl) is rendered for the
reference motion (401 samples) and read back with a small reader that applies the keyword
format rules: ``*KEYWORD`` first and ``*END`` last, every line within 80 columns, fixed-format
cards of 10-character fields (comma-separated free format: at most as many values as the
card has fields, each no wider than its field), ``*DEFINE_CURVE`` data as two 20-character
fields per point. The curves must hold the trajectory's points in order, in the deck's units
(s; m scaled to mm by SFO = 1000; rad), and reproduce the head pose of the shared geometry.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics
from alcove.science.oracles.command import (
    card_number,
    load_command_catalogue,
    params_model,
    render_template,
    template_values,
)
from alcove.science.oracles.fe_headrest import reference_motion

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "command-oracle"

# card layout per keyword: "text" (title / file name, 80 characters), "N" (N fields of 10),
# "curve" (the *DEFINE_CURVE header: 7 fields, then data points until the next keyword),
# "option" (*DEFINE_TRANSFORMATION: a word, then 7 fields), "*" (the previous kind repeats)
LAYOUT = {
    "*KEYWORD": [],
    "*END": [],
    "*TITLE": ["text"],
    "*INCLUDE": ["text"],
    "*INCLUDE_TRANSFORM": ["text", 7, 1, 5, 1],
    "*DEFINE_TRANSFORMATION": [1, "option", "*"],
    "*BOUNDARY_PRESCRIBED_MOTION_RIGID": [8, "*"],
    "*DEFINE_CURVE": ["curve"],
    "*DEFINE_CURVE_TITLE": ["text", "curve"],
    "*CONTROL_TERMINATION": [5],
    "*DATABASE_RCFORC": [2],
    "*DATABASE_NCFORC": [2],
    "*DATABASE_GLSTAT": [2],
    "*DATABASE_SLEOUT": [2],
}


class DeckError(AssertionError):
    pass


def fields(line: str, n: int, width: int = 10) -> list[float | None]:
    """Numbers of one card (None = blank field), fixed or comma-separated free format."""
    if "," in line:
        parts = line.split(",")
        if len(parts) > n:
            raise DeckError(f"{len(parts)} values on a card of {n} fields: {line!r}")
        if any(len(p.strip()) > width for p in parts):
            raise DeckError(f"a value is wider than its {width}-character field: {line!r}")
    else:
        if line[n * width :].strip():
            raise DeckError(f"text beyond the card's {n} fields: {line!r}")
        parts = [line[i * width : (i + 1) * width] for i in range(n)]
    out: list[float | None] = []
    for p in parts:
        p = p.strip()
        if not p:
            out.append(None)
            continue
        try:
            out.append(float(p))
        except ValueError:
            raise DeckError(f"not a number {p!r} in {line!r}") from None
    return out + [None] * (n - len(out))


def read_deck(deck: str) -> list[tuple[str, list]]:
    """Keyword blocks with their parsed cards; raises DeckError on a format violation."""
    lines = deck.splitlines()
    for i, line in enumerate(lines, 1):
        if len(line) > 80:
            raise DeckError(f"line {i} has {len(line)} columns (at most 80): {line!r}")
        if "\t" in line or not line.isascii():
            raise DeckError(f"line {i}: tabs or non-ASCII characters")
    cards = [line for line in lines if line.strip() and not line.startswith("$")]
    if cards[0].strip() != "*KEYWORD" or cards[-1].strip() != "*END" or sum(c.startswith("*END") for c in cards) != 1:
        raise DeckError("the deck must start with *KEYWORD and end with a single *END")
    blocks: list[tuple[str, list]] = []
    for line in cards:
        if line.startswith("*"):
            keyword = line.strip().upper()
            if keyword not in LAYOUT:
                raise DeckError(f"keyword {keyword} is not known to this reader")
            blocks.append((keyword, []))
            continue
        keyword, parsed = blocks[-1]
        layout = LAYOUT[keyword]
        k = len(parsed)
        kind = layout[k] if k < len(layout) else layout[-1]
        if kind == "*":
            kind = layout[-2]
        if k > 0 and parsed and isinstance(parsed[-1], tuple) and parsed[-1][0] == "curve":
            parsed[-1][1].append(fields(line, 2, width=20))  # a data point
            continue
        if k >= len(layout) and layout[-1] != "*":
            raise DeckError(f"too many cards for {keyword}: {line!r}")
        if kind == "text":
            parsed.append(line)
        elif kind == "curve":
            parsed.append(("curve", [], fields(line, 7)))
        elif kind == "option":
            word, _, rest = line.partition(",")
            if word.strip().upper() not in ("ROTATE", "TRANSL", "SCALE", "POINT", "POS6N", "POS6P", "MIRROR"):
                raise DeckError(f"unknown transformation option in {line!r}")
            parsed.append((word.strip().upper(), fields(rest, 7)))
        else:
            parsed.append(fields(line, kind))
    for keyword, parsed in blocks:
        needed = [k for k in LAYOUT[keyword] if k != "*"]
        if len(parsed) < len(needed):
            raise DeckError(f"{keyword} is missing cards")
    return blocks


def curves(blocks) -> dict[int, dict]:
    out = {}
    for keyword, parsed in blocks:
        if keyword.startswith("*DEFINE_CURVE"):
            _, points, header = parsed[-1]
            lcid, _sidr, sfa, sfo, offa, offo, _dattyp = header
            assert lcid is not None and lcid == int(lcid) and int(lcid) not in out
            data = np.array(points, dtype=float)
            assert not np.isnan(data).any(), "a curve point is missing a value"
            out[int(lcid)] = {
                "sfa": sfa or 1.0,
                "sfo": sfo or 1.0,
                "offa": offa or 0.0,
                "offo": offo or 0.0,
                "data": data,
            }
    return out


@pytest.fixture(scope="module")
def rendered():
    spec = load_command_catalogue(EXAMPLES / "catalogue.yaml")["lsdyna-headrest"]
    trajectory = reference_motion()
    values = template_values(trajectory, DEFAULT_PRESET, params_model(spec)(), spec)
    return trajectory, values, render_template(spec.template.read_text(), values)


def test_rendered_deck_is_keyword_input_within_80_columns(rendered):
    _, _, deck = rendered
    assert "{{" not in deck
    blocks = read_deck(deck)
    names = [k for k, _ in blocks]
    for needed in (
        "*INCLUDE",
        "*INCLUDE_TRANSFORM",
        "*DEFINE_TRANSFORMATION",
        "*BOUNDARY_PRESCRIBED_MOTION_RIGID",
        "*CONTROL_TERMINATION",
        "*DATABASE_NCFORC",
    ):
        assert needed in names


def test_motion_curves_hold_the_trajectory_in_order_and_in_the_decks_units(rendered):
    trajectory, _, deck = rendered
    blocks = read_deck(deck)
    cv = curves(blocks)
    t = trajectory.t
    kin = relative_kinematics(DEFAULT_PRESET, trajectory.q[:, 0], trajectory.qd[:, 0])
    for lcid in (100, 101, 102, 103):
        data = cv[lcid]["data"]
        assert data.shape == (401, 2)  # every output sample of the 1 s motion
        assert cv[lcid]["sfa"] == 1.0 and cv[lcid]["offa"] == 0.0 and cv[lcid]["offo"] == 0.0  # time in s
        assert np.all(np.diff(data[:, 0]) > 0)
        np.testing.assert_allclose(data[:, 0], t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cv[100]["data"][:, 1], trajectory.q[:, 0], atol=1e-12)  # theta [rad]
    # placement (mm, deg) and displacement curves (m x SFO = 1000 -> mm) give the head origin in H
    header = dict(blocks)["*DEFINE_TRANSFORMATION"]
    (rotate, r), (transl, tr) = header[1], header[2]
    assert (rotate, transl) == ("ROTATE", "TRANSL") and r[:6] == [0.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    assert cv[101]["sfo"] == cv[102]["sfo"] == 1000.0
    x_mm = tr[0] + cv[101]["sfo"] * cv[101]["data"][:, 1]
    z_mm = tr[2] + cv[102]["sfo"] * cv[102]["data"][:, 1]
    np.testing.assert_allclose(x_mm, 1e3 * kin.r_rel[:, 0], atol=1e-4)  # 0.1 um
    np.testing.assert_allclose(z_mm, 1e3 * kin.r_rel[:, 2], atol=1e-4)
    assert 10.0 < np.ptp(x_mm) < 100.0  # the head travels some cm: mm, not m or um
    # rotation about y: start angle [deg] + curve [rad, SFO = 1] = -(theta - tilt)
    assert cv[103]["sfo"] == 1.0
    rotation = math.radians(r[6]) + cv[103]["data"][:, 1]
    np.testing.assert_allclose(rotation, -kin.angle, atol=1e-7)
    # the zero curve covers the run
    assert cv[104]["data"][0, 0] <= t[0] and cv[104]["data"][-1, 0] >= t[-1] and np.all(cv[104]["data"][:, 1] == 0)


def test_prescribed_motion_and_run_control_refer_to_the_rendered_curves(rendered):
    trajectory, _, deck = rendered
    blocks = read_deck(deck)
    cv = curves(blocks)
    by_name = dict(blocks)
    motion = by_name["*BOUNDARY_PRESCRIBED_MOTION_RIGID"]
    dofs = {}
    for pid, dof, vad, lcid, sf, *_ in motion:
        assert pid == 1 and vad == 2 and sf == 1.0  # rigid head, displacement
        assert int(lcid) in cv
        dofs[int(dof)] = int(lcid)
    assert dofs == {1: 101, 3: 102, 6: 103, 2: 104, 5: 104, 7: 104}  # x, z, rotation about y; the rest held
    assert by_name["*CONTROL_TERMINATION"][0][0] == pytest.approx(trajectory.t[-1])  # ENDTIM [s]
    for output in ("*DATABASE_RCFORC", "*DATABASE_NCFORC", "*DATABASE_GLSTAT", "*DATABASE_SLEOUT"):
        assert by_name[output][0][0] == 0.0025  # the paper's output interval [s]
    tranid = by_name["*DEFINE_TRANSFORMATION"][0][0]
    assert by_name["*INCLUDE_TRANSFORM"][4][0] == tranid
    assert by_name["*INCLUDE_TRANSFORM"][0].strip() == "head_model.k"


def test_the_reader_rejects_what_ls_dyna_would_not_read():
    ok = "*KEYWORD\n*DEFINE_CURVE\n       101         0       1.0    1000.0\n" + f"{0.0:20.12e}{1.0:20.12e}\n*END\n"
    read_deck(ok)
    with pytest.raises(DeckError, match="at most 80"):
        read_deck(ok.replace("*DEFINE_CURVE\n", "*DEFINE_CURVE\n$" + "x" * 80 + "\n"))
    with pytest.raises(DeckError, match="wider than its 10-character field"):
        read_deck(ok.replace("       101         0       1.0    1000.0", "101,0,1.0,1000.00000000001"))
    with pytest.raises(DeckError, match="not a number"):
        read_deck(ok.replace("       101         0", "         101       0"))  # a value across a field boundary
    with pytest.raises(DeckError, match="start with \\*KEYWORD"):
        read_deck(ok.replace("*END\n", ""))


def test_card_numbers_fit_their_field():
    for v in (1.0, 0.0025, -95.123456789012, 12345.6789012, -4.58366236105e-3, 1e-12, 0.674999999999):
        text = card_number(v)
        assert len(text) <= 10 and float(text) == pytest.approx(v, rel=1e-5)
