"""The oracle registry: built-in types (lazily imported), catalogue entries, validation and schemas."""

from pathlib import Path

import numpy as np
import pytest

from alcove.science.geometry import HeadNeckPreset
from alcove.science.oracles import builtin
from alcove.science.oracles.aux_penalty import AuxPenaltyOracle, AuxPenaltyParams
from alcove.science.oracles.base import OracleInputError
from alcove.science.oracles.command import CommandOracle, CommandOracleSpec, load_command_catalogue
from alcove.science.oracles.registry import (
    ORACLE_TYPES,
    OracleTypeUnavailable,
    build_oracle,
    list_oracle_types,
    params_json_schema,
)
from alcove.science.series import Trajectory

CATALOGUE = Path(__file__).resolve().parents[3] / "examples" / "command-oracle" / "catalogue.yaml"


def test_builtin_types_and_their_entries():
    assert set(ORACLE_TYPES) == {"fe-headrest-2d", "fe-headrest-3d-ccx", "aux-penalty"}
    model, factory = ORACLE_TYPES["aux-penalty"]
    assert model is AuxPenaltyParams
    preset = HeadNeckPreset(theta_contact=0.33)
    oracle = factory(AuxPenaltyParams(k=1e7), preset)
    assert isinstance(oracle, AuxPenaltyOracle) and oracle.params.k == 1e7 and oracle.preset is preset
    with pytest.raises(KeyError):
        ORACLE_TYPES["lsdyna"]


def test_build_oracle_validates_parameters_and_names_the_field():
    oracle = build_oracle("aux-penalty", {"k": 1.2e7, "r_sp": [-0.1, 0.0, -0.03]})
    assert oracle.type_name == "aux-penalty"
    assert oracle.params.k == 1.2e7 and oracle.params.r_sp == (-0.1, 0.0, -0.03)
    assert build_oracle("aux-penalty", None).params == AuxPenaltyParams()
    cases = [
        ({"k": 0}, "params.k", "greater than 0"),
        ({"k": "stiff"}, "params.k", "valid number"),
        ({"stiffness": 1.0}, "params.stiffness", "Extra inputs"),
        ({"r_sp": [0.0, 0.0]}, "params.r_sp.2", "Field required"),
    ]
    for params, field, reason in cases:
        with pytest.raises(OracleInputError) as info:
            build_oracle("aux-penalty", params)
        assert info.value.field == field and reason in info.value.reason
    with pytest.raises(OracleInputError, match=r"^params: must be a JSON object"):
        build_oracle("aux-penalty", [1.0])  # type: ignore[arg-type]


def test_unknown_type_lists_the_known_ones():
    with pytest.raises(
        OracleInputError,
        match=r"^oracle: unknown oracle type 'lsdyna'; known: aux-penalty, fe-headrest-2d, fe-headrest-3d-ccx "
        r"\(command oracles",
    ):
        build_oracle("lsdyna", {})
    catalogue = load_command_catalogue(CATALOGUE)
    with pytest.raises(
        OracleInputError,
        match=r"known: aux-penalty, fe-headrest-2d, fe-headrest-3d-ccx, aux-replay, fe-replay, lsdyna-headrest$",
    ):
        build_oracle("lsdyna", {}, catalogue=catalogue)


def test_command_oracles_come_from_the_catalogue_by_name():
    catalogue = load_command_catalogue(CATALOGUE)
    oracle = build_oracle("aux-replay", {"k": 2e6, "dt_out": 0.005}, catalogue=catalogue)
    assert isinstance(oracle, CommandOracle) and oracle.spec is catalogue["aux-replay"]
    assert oracle.params.k == 2e6 and oracle.params.dt_out == 0.005
    rows = {row["name"]: row for row in list_oracle_types(catalogue)}
    assert rows["aux-replay"]["kind"] == "command" and rows["aux-penalty"]["kind"] == "builtin"
    assert rows["lsdyna-headrest"]["description"].startswith("LS-DYNA")
    assert rows["aux-replay"]["available"] is True  # {python}
    ghost = {"ghost": CommandOracleSpec(name="ghost", argv=["/opt/no-such-solver/bin/dyna"])}
    (row,) = [r for r in list_oracle_types(ghost) if r["kind"] == "command"]
    assert (
        row["available"] is False
        and row["unavailable_reason"] == "/opt/no-such-solver/bin/dyna is not an executable program on this machine"
    )


def test_json_schemas_for_the_ui():
    schema = params_json_schema("aux-penalty")
    assert set(schema["properties"]) == {"k", "d0", "p_ref", "r_sp"}
    assert schema["additionalProperties"] is False
    assert schema["properties"]["k"]["exclusiveMinimum"] == 0
    command = params_json_schema("aux-replay", load_command_catalogue(CATALOGUE))
    assert set(command["properties"]) == {"template", "dt_out", "keep_workdir", "k"}
    assert command["properties"]["k"]["minimum"] == 1e4 and command["properties"]["k"]["maximum"] == 1e9
    assert command["additionalProperties"] is False  # argv, env, ... can never be set by a user


def test_missing_builtin_implementation_is_a_clear_error_and_does_not_break_the_others(monkeypatch):
    broken = builtin.BuiltinType(
        "alcove.science.oracles.not_there", "NotThereOracle", "NotThereParams", "a type whose module is missing"
    )
    monkeypatch.setitem(builtin.BUILTIN_TYPES, "not-there", broken)
    with pytest.raises(
        OracleTypeUnavailable,
        match=r"^oracle: type 'not-there' is not available: cannot import alcove\.science\.oracles\.not_there",
    ):
        build_oracle("not-there", {})
    rows = {row["name"]: row for row in list_oracle_types()}
    assert rows["not-there"]["available"] is False and "cannot import" in rows["not-there"]["unavailable_reason"]
    assert rows["aux-penalty"]["available"] is True
    t = np.linspace(0, 1, 11)
    assert build_oracle("aux-penalty", {}).run(Trajectory(t, np.full(11, 0.3), np.zeros(11))).ok


def test_fe_headrest_type_builds_the_fe_oracle():
    oracle = build_oracle("fe-headrest-2d", {})
    assert oracle.type_name == "fe-headrest-2d"
    assert params_json_schema("fe-headrest-2d")["type"] == "object"
