"""The ``command`` oracle: catalogue, safe template rendering, a real external program and its failures."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics
from alcove.science.oracles.aux_penalty import AuxPenaltyOracle, AuxPenaltyParams
from alcove.science.oracles.base import OracleCancelled, OracleInputError
from alcove.science.oracles.command import (
    TEMPLATE_PLACEHOLDERS,
    CatalogueError,
    CommandOracle,
    CommandOracleSpec,
    load_command_catalogue,
    params_model,
    render_template,
    template_values,
)
from alcove.science.oracles.registry import build_oracle
from alcove.science.series import ForceSeries, Trajectory

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "command-oracle"
FAILING = str(EXAMPLES / "failing_solver.py")


def push_and_release(n: int = 201) -> Trajectory:
    t = np.linspace(0.0, 1.0, n)
    return Trajectory(t, DEFAULT_PRESET.theta0 + 0.15 * np.sin(np.pi * t), 0.15 * np.pi * np.cos(np.pi * t))


def failing(mode: str, tmp_path: Path, timeout_s: float = 30.0) -> CommandOracle:
    spec = CommandOracleSpec(
        name=f"broken-{mode}", argv=[sys.executable, FAILING, mode], timeout_s=timeout_s, workdir_root=tmp_path / "runs"
    )
    return CommandOracle(spec)


def process_is_gone(pid: int, wait_s: float = 3.0) -> bool:
    """True once ``pid`` has exited (a zombie waiting for init to reap it counts as gone)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except FileNotFoundError:
            return True
        if state in ("Z", "X"):
            return True
        time.sleep(0.05)
    return False


# ---- catalogue ---------------------------------------------------------------------------------
def test_example_catalogue_loads_with_paths_resolved():
    catalogue = load_command_catalogue(EXAMPLES / "catalogue.yaml")
    assert set(catalogue) == {"aux-replay", "fe-replay", "lsdyna-headrest"}
    aux = catalogue["aux-replay"]
    assert aux.argv == [sys.executable, str(EXAMPLES / "replay_with_alcove.py"), "aux-penalty"]
    lsdyna = catalogue["lsdyna-headrest"]
    assert lsdyna.template == EXAMPLES / "lsdyna" / "headrest.k.tmpl"
    assert lsdyna.rendered_file_name == "headrest.k"
    assert lsdyna.env["PYTHON"] == sys.executable


@pytest.mark.parametrize(
    ("text", "field", "reason"),
    [
        ("command_oracles: [1, 2]", "command_oracles", "top-level mapping"),
        ("command_oracles:\n  a: {argv: [x]\n", "catalogue", "not valid YAML (line"),
        (
            "command_oracles:\n  dyna: {argv: 'lsdyna i=x.k; rm -rf /'}",
            "command_oracles.dyna.argv",
            "not a shell string",
        ),
        ("command_oracles:\n  dyna: {argv: []}", "command_oracles.dyna.argv", "at least 1 item"),
        ("command_oracles:\n  aux-penalty: {argv: [x]}", "command_oracles.aux-penalty", "built-in oracle type"),
        ("command_oracles:\n  dyna: {argv: [x], timeout_s: -5}", "command_oracles.dyna.timeout_s", "greater than 0"),
        (
            "command_oracles:\n  dyna: {argv: [x], output_file: ../../etc/passwd}",
            "command_oracles.dyna.output_file",
            "plain file name",
        ),
        (
            "command_oracles:\n  dyna: {argv: [x], input_file: stderr.log}",
            "command_oracles.dyna.input_file",
            "plain file name",
        ),
        (
            "command_oracles:\n  dyna: {argv: [x], input_file: out.csv, output_file: out.csv}",
            "command_oracles.dyna",
            "would both be",
        ),
        (
            "command_oracles:\n  dyna: {argv: [x], template: nowhere.k.tmpl}",
            "command_oracles.dyna.template",
            "does not exist",
        ),
        ("command_oracles:\n  dyna: {argv: [x], shell: true}", "command_oracles.dyna.shell", "Extra inputs"),
        ("command_oracles:\n  Dyna Run: {argv: [x]}", "command_oracles.Dyna Run.name", "lower-case"),
        (
            "command_oracles:\n  dyna: {argv: [x], parameters: {t_end: {default: 1}}}",
            "command_oracles.dyna.parameters",
            "reserved",
        ),
        (
            "command_oracles:\n  dyna: {argv: [x], parameters: {e: {default: 5, maximum: 1}}}",
            "command_oracles.dyna.parameters.e",
            "outside",
        ),
    ],
)
def test_catalogue_errors_name_the_entry_and_key(tmp_path, text, field, reason):
    path = tmp_path / "catalogue.yaml"
    path.write_text(text)
    with pytest.raises(CatalogueError) as info:
        load_command_catalogue(path)
    assert info.value.field == field
    assert reason in info.value.reason


def test_missing_catalogue_file(tmp_path):
    with pytest.raises(CatalogueError, match=r"^catalogue: .*does not exist"):
        load_command_catalogue(tmp_path / "nope.yaml")
    with pytest.raises(CatalogueError, match=r"^catalogue: cannot read .*: Is a directory"):
        load_command_catalogue(tmp_path)


# ---- templates ---------------------------------------------------------------------------------
def parse_curve(text: str) -> np.ndarray:
    return np.array([[float(line[:20]), float(line[20:40])] for line in text.splitlines()])


def test_placeholders_describe_motion_exactly():
    traj = push_and_release()
    spec = CommandOracleSpec(name="x", argv=["x"])
    values = template_values(traj, DEFAULT_PRESET, params_model(spec)(), spec)
    assert set(values) == set(TEMPLATE_PLACEHOLDERS)
    np.testing.assert_allclose(parse_curve(values["motion_curve"]), np.stack([traj.t, traj.q[:, 0]], -1), rtol=1e-11)
    # the head origin = start pose + displacement curves, compared with the shared geometry
    kin = relative_kinematics(DEFAULT_PRESET, traj.q[:, 0], traj.qd[:, 0])
    x = float(values["head_x0"]) + parse_curve(values["head_x_curve"])[:, 1]
    z = float(values["head_z0"]) + parse_curve(values["head_z_curve"])[:, 1]
    np.testing.assert_allclose(np.stack([x, z], -1), kin.r_rel[:, [0, 2]], atol=1e-12)
    assert float(values["head_x0_mm"]) == pytest.approx(1e3 * float(values["head_x0"]))
    # rotation about y_H of the head relative to H: start value + curve = -(theta - tilt) = kin.angle * -1
    rot = float(values["head_rotation0"]) + parse_curve(values["head_rotation_curve"])[:, 1]
    np.testing.assert_allclose(rot, -kin.angle, atol=1e-12)
    assert float(values["head_rotation0_deg"]) == pytest.approx(np.degrees(float(values["head_rotation0"])))
    assert values["t_end"] == "1" and values["n_samples"] == "201" and values["dt_out"] == "0.0025"


def test_template_renders_inertly():
    values = {"t_end": "1", "dt_out": "0.0025"}
    hostile = (
        "$(touch pwned); `touch pwned` | rm -rf ~ && ${HOME} > /dev/null\n"
        "{{ __import__('os').system('touch pwned') }} {{t_end.__class__}} {{ t_end | attr('x') }}\n"
        "{% for x in y %}{0.__class__}{}%s {t_end}\n"
        "end {{t_end}} {{   dt_out   }}\n"
    )
    rendered = render_template(hostile, values)
    assert rendered == hostile.replace("{{t_end}}", "1").replace("{{   dt_out   }}", "0.0025")
    assert not Path("pwned").exists()


def test_template_substitution_is_single_pass():
    assert render_template("{{ a }}", {"a": "{{ b }}", "b": "X"}) == "{{ b }}"


def test_unknown_placeholder_is_an_error_with_its_line():
    with pytest.raises(OracleInputError, match=r"^template: unknown placeholder '\{\{ t_ends \}\}' on line 2"):
        render_template("*KEYWORD\n{{ t_ends }}\n", {"t_end": "1"})


def test_example_lsdyna_template_renders_for_a_trajectory():
    spec = load_command_catalogue(EXAMPLES / "catalogue.yaml")["lsdyna-headrest"]
    traj = push_and_release(n=401)
    values = template_values(traj, DEFAULT_PRESET, params_model(spec)(), spec)
    deck = render_template(spec.template.read_text(), values)
    assert "{{" not in deck
    assert deck.startswith("*KEYWORD") and deck.rstrip().endswith("*END")
    assert deck.count(values["head_x_curve"]) == 1
    assert f"ROTATE,0.0,1.0,0.0,0.0,0.0,0.0,{values['head_rotation0_deg']}" in deck


# ---- runs of a real external program ----------------------------------------------------------
def test_external_program_reproduces_the_in_process_oracle(tmp_path):
    catalogue = load_command_catalogue(EXAMPLES / "catalogue.yaml")
    traj = push_and_release()
    oracle = build_oracle("aux-replay", {"k": 1.2e7, "keep_workdir": True}, catalogue=catalogue)
    result = oracle.run(traj)
    assert result.ok, result.failure_reason
    reference = AuxPenaltyOracle(AuxPenaltyParams(k=1.2e7)).run(traj)
    np.testing.assert_array_equal(result.forces.t, traj.t)
    np.testing.assert_allclose(result.forces.force, reference.forces.force, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(result.forces.moment, reference.forces.moment, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(result.kinematics.r_rel, reference.kinematics.r_rel, atol=1e-14)
    assert result.diagnostics["max_penetration_m"] == pytest.approx(reference.diagnostics["max_penetration_m"])
    assert result.diagnostics["exit_code"] == 0
    workdir = Path(result.diagnostics["workdir"])
    assert json.loads((workdir / "params.json").read_text()) == {"dt_out": 0.0025, "k": 1.2e7}
    np.testing.assert_array_equal(Trajectory.from_csv(workdir / "trajectory.csv").q, traj.q)


def test_workdir_is_removed_after_success(tmp_path):
    spec = CommandOracleSpec(
        name="aux", argv=[sys.executable, str(EXAMPLES / "replay_with_alcove.py")], workdir_root=tmp_path / "runs"
    )
    result = CommandOracle(spec).run(push_and_release(21))
    assert result.ok, result.failure_reason
    assert "workdir" not in result.diagnostics
    assert list((tmp_path / "runs").iterdir()) == []


@pytest.mark.parametrize(
    ("mode", "reason"),
    [
        ("exit-code", "exited with code 3: solver: element 42 has a negative volume"),
        ("signal", "killed by signal SIGSEGV"),
        ("no-output", "output: the command exited with code 0 but wrote no forces.csv"),
        ("malformed", "output: forces.csv is malformed: mz: missing column"),
        ("nan", "output: forces.csv is malformed: fx: non-finite value"),
        ("short", "output: forces.csv covers t = [0, 0.475] s but the trajectory spans [0, 1] s"),
    ],
)
def test_failures_are_reported_and_the_workdir_is_kept(tmp_path, mode, reason):
    result = failing(mode, tmp_path).run(push_and_release(41))
    assert not result.ok and result.forces is None
    assert result.failure_reason.startswith(f"command oracle 'broken-{mode}': ")
    assert reason in result.failure_reason
    workdir = Path(result.diagnostics["workdir"])
    assert (workdir / "trajectory.csv").is_file() and workdir.parent == tmp_path / "runs"


def test_timeout_kills_the_whole_process_group(tmp_path):
    start = time.monotonic()
    result = failing("hang", tmp_path, timeout_s=1.0).run(push_and_release(11))
    assert time.monotonic() - start < 10
    assert not result.ok and "timeout: the command ran longer than 1 s and was killed" in result.failure_reason
    child = int((Path(result.diagnostics["workdir"]) / "child.pid").read_text())
    assert process_is_gone(child)


def test_cancel_terminates_the_process_group(tmp_path):
    oracle = failing("hang", tmp_path)
    pid_file: list[Path] = []

    def cancel() -> bool:  # cancel once the solver's child is running
        pid_file[:] = list((tmp_path / "runs").glob("*/child.pid"))
        return bool(pid_file) and pid_file[0].read_text() != ""

    with pytest.raises(OracleCancelled):
        oracle.run(push_and_release(11), cancel=cancel)
    assert process_is_gone(int(pid_file[0].read_text()))


def test_program_that_cannot_start(tmp_path):
    spec = CommandOracleSpec(name="ghost", argv=[str(tmp_path / "no-such-solver")], workdir_root=tmp_path)
    result = CommandOracle(spec).run(push_and_release(11))
    assert not result.ok and "cannot start" in result.failure_reason and "No such file" in result.failure_reason


def test_user_input_is_validated(tmp_path):
    catalogue = load_command_catalogue(EXAMPLES / "catalogue.yaml")
    with pytest.raises(OracleInputError, match=r"^params\.k: Input should be less than or equal to 1000000000"):
        build_oracle("aux-replay", {"k": 1e12}, catalogue=catalogue)
    with pytest.raises(OracleInputError, match=r"^params\.argv: Extra inputs"):
        build_oracle("aux-replay", {"argv": ["sh", "-c", "touch pwned"]}, catalogue=catalogue)
    locked = {"locked": CommandOracleSpec(name="locked", argv=["x"], allow_user_template=False)}
    with pytest.raises(OracleInputError, match=r"^params.template: .*does not accept user templates"):
        build_oracle("locked", {"template": "*KEYWORD"}, catalogue=locked)
    with pytest.raises(OracleInputError, match=r"^head_x: a trajectory of 2 joints needs the contact body.s pose"):
        CommandOracle(locked["locked"]).run(Trajectory(np.linspace(0, 1, 3), np.zeros((3, 2)), np.zeros((3, 2))))


def test_user_template_with_shell_text_reaches_the_solver_verbatim(tmp_path):
    """A user's template is only written to a file: the solver sees it as text, nothing runs it."""
    spec = CommandOracleSpec(
        name="cat",
        argv=[
            sys.executable,
            "-c",
            "import shutil; shutil.copy('deck.k', 'seen.k'); "
            "open('forces.csv','w').write('t,fx,fy,fz,mx,my,mz\\n0,0,0,0,0,0,0\\n1,0,0,0,0,0,0\\n')",
        ],
        input_file="deck.k",
        workdir_root=tmp_path,
    )
    template = "$(touch pwned) `touch pwned`; {{ __import__('os').system('touch pwned') }} end={{ t_end }}\n"
    result = CommandOracle(spec, params_model(spec)(template=template, keep_workdir=True)).run(push_and_release(11))
    assert result.ok, result.failure_reason
    workdir = Path(result.diagnostics["workdir"])
    assert (workdir / "seen.k").read_text() == template.replace("{{ t_end }}", "1")
    assert not list(tmp_path.rglob("pwned"))


# ---- LS-DYNA post-processing example ----------------------------------------------------------
def test_lsdyna_postprocessing_converts_units_and_moment_reference(tmp_path):
    """Wrench about the model origin in N, mm -> alcove's wrench about the head origin in N, m."""
    traj = push_and_release()
    traj.to_csv(tmp_path / "trajectory.csv")
    truth = AuxPenaltyOracle().run(traj)
    r_head = truth.kinematics.r_rel
    moment_about_origin_nmm = 1e3 * (truth.forces.moment + np.cross(r_head, truth.forces.force))
    ForceSeries(traj.t, truth.forces.force, moment_about_origin_nmm).to_csv(tmp_path / "head_wrench.csv")
    script = EXAMPLES / "lsdyna" / "to_forces_csv.py"
    args = ["head_wrench.csv", "--trajectory", "trajectory.csv", "--out", "forces.csv", "--length-unit", "mm"]
    subprocess.run([sys.executable, str(script), *args], cwd=tmp_path, check=True, env={**os.environ})
    back = ForceSeries.from_csv(tmp_path / "forces.csv")
    assert np.abs(1e-3 * moment_about_origin_nmm - truth.forces.moment).max() > 1.0  # the shift matters [N m]
    np.testing.assert_allclose(back.force, truth.forces.force, atol=1e-12)
    np.testing.assert_allclose(back.moment, truth.forces.moment, atol=1e-9)


def test_every_placeholder_is_documented():
    doc = (EXAMPLES.parents[1] / "docs" / "external-solvers.md").read_text()
    missing = [name for name in TEMPLATE_PLACEHOLDERS if "{{ " + name + " }}" not in doc]
    assert not missing


def test_declared_parameters_are_validated_numbers_and_placeholders():
    spec = CommandOracleSpec(
        name="x", argv=["x"], parameters={"foam_scale": {"default": 1.5, "minimum": 0.5, "maximum": 2.0}}
    )
    model = params_model(spec)
    traj = push_and_release(11)
    assert template_values(traj, DEFAULT_PRESET, model(), spec)["foam_scale"] == "1.5"
    assert (
        render_template("s={{ foam_scale }}", template_values(traj, DEFAULT_PRESET, model(foam_scale=2), spec)) == "s=2"
    )
    for bad in (2.5, float("nan"), "1; rm -rf /"):
        with pytest.raises(OracleInputError, match=r"^params.foam_scale: "):
            build_oracle("x", {"foam_scale": bad}, catalogue={"x": spec})


@pytest.mark.slow
def test_fe_oracle_as_an_external_program_agrees_with_the_in_process_run():
    """The issue's example: a small script calling the FE oracle in a subprocess (entry fe-replay)."""
    t = np.linspace(0.0, 0.02, 9)
    traj = Trajectory(t, DEFAULT_PRESET.theta_contact + 0.5 * t, np.full_like(t, 0.5))  # pushing into the cushion
    in_process = build_oracle("fe-headrest-2d", {}).run(traj)
    external = build_oracle("fe-replay", {}, catalogue=load_command_catalogue(EXAMPLES / "catalogue.yaml")).run(traj)
    assert external.ok == in_process.ok
    if in_process.ok:
        assert in_process.forces.peak_force > 0
        np.testing.assert_allclose(external.forces.force, in_process.forces.force, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(external.forces.moment, in_process.forces.moment, rtol=1e-9, atol=1e-9)
        assert external.diagnostics["max_penetration_m"] == pytest.approx(in_process.diagnostics["max_penetration_m"])
    else:
        assert in_process.failure_reason in external.failure_reason
