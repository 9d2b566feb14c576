"""Portable exports of a model version: serialised CasADi Functions and ONNX graphs (docs/exports.md).

Written next to ``surrogate.json`` by :func:`write_exports`; none needs alcove to be used:

``force.casadi``, ``moment.casadi``
    ``casadi.Function.load``: inputs ``q``, ``qd`` (ndof x 1), output ``force`` / ``moment``
    (3 x 1, headrest frame, SI units), the ensemble mean; float64 weights, the kinematics and
    the 19 features included (the same expression the OCP uses, :mod:`.casadi_contact`).
``force_std.casadi``, ``moment_std.casadi`` (K > 1)
    The same inputs, outputs ``std`` and ``var`` (3 x 1): the members' standard deviation and variance.
``history_step.casadi`` (feature set ``history``)
    The history states' update (:mod:`.history`): inputs ``z`` (3 x 1, the states at the previous
    sample), ``q``, ``qd`` (the next sample's state; ``features`` (19 x 1) for a chain) and ``dt``
    [s], output ``z_next``; a model of this feature set takes ``z`` as a third input (after ``q``
    and ``qd``; for a chain its inputs are the 22 ``features`` of ``feature_names``). The first
    sample's states are the steady ones: ``(ramp(p_0), v_y0, v_z0)``, the ramp of its indentation
    and its slip velocity (:func:`.history.steady_history`).
``history_step.onnx`` (feature set ``history``)
    The same update as ONNX: inputs ``z`` (n x 3), ``features`` (n x 19, the next sample's) and
    ``dt`` (n x 1), output ``z_next`` (n x 3); the contact point's indentation and slip velocity
    are computed from the features (r, v, the first two columns of T, omega).
``force.onnx``, ``moment.onnx``
    ONNX (opset 18, float64): input ``features`` (n x 19, or n x 22 with history states; raw, in
    the order of ``surrogate.json``'s ``feature_names``), outputs ``mean`` (n x 3) and, for K > 1, ``std``
    (n x 3). Built node by node from the weights (MatMul, Add, softplus as
    ``Relu(x) + Log(1 + Exp(-|x|))``) and checked with onnxruntime against PyTorch when written.

The ``gated`` architecture's output layer (:mod:`.gated`) is in every file: the CasADi files
take it from :mod:`.casadi_contact`; the ONNX graph computes the signed gap from the features
``r_x``, ``T_00``, ``T_20`` and the head profile of ``surrogate.json``'s preset, the gate
(``Min(Max(.., 0), 1)`` and the quintic smoothstep) and the softplus of fx, per member.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np

from alcove.science.arrays import FloatArray
from alcove.science.geometry import relative_kinematics_symbolic
from alcove.science.surrogate.casadi_contact import _mean_var, _state_features, member_wrenches_symbolic
from alcove.science.surrogate.features import N_FEATURES
from alcove.science.surrogate.gated import R_X, T_00, T_20, Gate
from alcove.science.surrogate.history import N_HISTORY, contact_point_motion_symbolic, history_step_symbolic
from alcove.science.surrogate.mlp import Member, SurrogateModel

NETS = {"force": slice(0, 3), "moment": slice(3, 6)}
ONNX_OPSET = 18
ONNX_RTOL = 1e-6  # checked at export: relative to max(1, |torch output|)


class ExportError(RuntimeError):
    """An export does not reproduce the model; ``field`` names the file."""

    def __init__(self, field: str, reason: str):
        self.field, self.reason = field, reason
        super().__init__(f"{field}: {reason}")


def casadi_net_functions(model: SurrogateModel) -> dict[str, ca.Function]:
    """File stem -> Function: ``force``, ``moment`` (mean) and, for K > 1, ``force_std``, ``moment_std``;
    of ``(q, qd)`` for the 1-DOF preset, of the 19 ``features`` (:mod:`.features`) for a chain model."""
    history = model.config.features == "history"
    if model.ndof == 1:  # the 1-DOF preset: functions of the joint state (q, qd) and the history states
        q, qd, feats = _state_features(model, model.preset, None)
        inputs, names = [q, qd], ["q", "qd"]
        if history:
            z = ca.SX.sym("z", N_HISTORY)
            inputs, names, feats = [q, qd, z], ["q", "qd", "z"], ca.vertcat(feats, z)
    else:  # a chain: functions of the features of the head's pose (the chain's kinematics are the task's)
        feats = ca.SX.sym("features", len(model.config.input_names))
        inputs, names = [feats], ["features"]
    mean, var = _mean_var(member_wrenches_symbolic(model, feats))
    out: dict[str, ca.Function] = {"history_step": history_step_function(model)} if history else {}
    for net, rows in NETS.items():
        out[net] = ca.Function(net, inputs, [mean[rows]], names, [net])
        if model.ensemble_size > 1:
            v = var[rows]
            out[f"{net}_std"] = ca.Function(f"{net}_std", inputs, [ca.sqrt(v), v], names, ["std", "var"])
    return out


def history_step_function(model: SurrogateModel) -> ca.Function:
    """``(z, q, qd, dt) -> z_next`` (``(z, features, dt)`` for a chain): the history states' update
    of :func:`.history.history_step_symbolic` at the next sample's state."""
    z, dt = ca.SX.sym("z", N_HISTORY), ca.SX.sym("dt")
    if model.ndof == 1:
        q, qd = ca.SX.sym("q"), ca.SX.sym("qd")
        kin = relative_kinematics_symbolic(model.preset, q, qd)
        state, names = [q, qd], ["q", "qd"]
    else:  # the head's kinematics from its 19 features: r, v, the first two columns of T, omega
        f = ca.SX.sym("features", N_FEATURES)
        c0, c1 = f[6:9], f[9:12]
        kin = (f[0:3], f[3:6], ca.horzcat(c0, c1, ca.cross(c0, c1)), f[12:15])
        state, names = [f], ["features"]
    p, v = contact_point_motion_symbolic(model.preset, *kin)
    z_next = history_step_symbolic(z, p, v, dt, model.config.history)
    return ca.Function("history_step", [z, *state, dt], [z_next], ["z", *names, "dt"], ["z_next"])


def _onnx_gate(g: _Graph, gate: Gate) -> str:
    """The gate (n x 1) of the gated architecture from the raw features (module docstring)."""
    pr, gp = gate.profile, gate.params

    def column(i: int) -> str:
        return g.op("Gather", "features", g.const([i], np.int64), axis=1)

    c, s, rx = column(T_00), column(T_20), column(R_X)
    radius = g.op(
        "Sqrt",
        g.op(
            "Add",
            g.op("Mul", g.op("Mul", c, c), g.const(pr.ax**2)),
            g.op("Mul", g.op("Mul", s, s), g.const(pr.az**2)),
        ),
    )
    gap = g.op(
        "Sub", g.op("Sub", g.op("Add", rx, g.op("Mul", c, g.const(pr.cx))), g.op("Mul", s, g.const(pr.cz))), radius
    )
    t = g.op("Div", g.op("Sub", g.const(gp.open_gap), gap), g.const(gp.blend))
    t = g.op("Min", g.op("Max", t, g.const(0.0)), g.const(1.0))
    poly = g.op(
        "Add", g.op("Sub", g.const(10.0), g.op("Mul", t, g.const(15.0))), g.op("Mul", g.op("Mul", t, t), g.const(6.0))
    )
    return g.op("Mul", g.op("Mul", g.op("Mul", t, t), t), poly)


def _onnx_gated_output(g: _Graph, net: str, out: str, gate_node: str, width: float) -> str:
    """``gate * (softplus_w(fx), fy, fz)`` (force) or ``gate * out`` (moment)."""
    if net == "force":

        def cols(a: int, b: int) -> str:
            return g.op("Slice", out, g.const([a], np.int64), g.const([b], np.int64), g.const([1], np.int64))

        fx = g.op("Div", cols(0, 1), g.const(width))
        fx = g.op("Mul", g.activation("softplus", fx), g.const(width))
        out = g.op("Concat", fx, cols(1, 3), axis=1)
    return g.op("Mul", out, gate_node)


def _onnx_member(g: _Graph, m: Member, net: str, gate: Gate | None = None, gate_node: str | None = None) -> str:
    """Node names of one member's net: raw features -> physical output (n x 3)."""
    mlp = getattr(m, f"{net}_net")
    norm = getattr(m, f"{net}_norm")
    h = g.op("Div", g.op("Sub", "features", g.const(m.input_norm.mean)), g.const(m.input_norm.divisor))
    linears = mlp.linears()
    for i, lin in enumerate(linears):
        w = lin.weight.detach().double().numpy().T
        h = g.op("Add", g.op("MatMul", h, g.const(w)), g.const(lin.bias.detach().double().numpy()))
        if i < len(linears) - 1:
            h = g.activation(mlp.activation, h)
    out = g.op("Add", g.op("Mul", h, g.const(norm.scale)), g.const(norm.mean))
    if gate is None or gate_node is None:
        return out
    return _onnx_gated_output(g, net, out, gate_node, gate.params.force_width)


class _Graph:
    """A small ONNX graph builder (float64 constants as initializers)."""

    def __init__(self) -> None:
        self.nodes: list[object] = []
        self.inits: list[object] = []
        self.n = 0

    def _name(self, prefix: str) -> str:
        self.n += 1
        return f"{prefix}_{self.n}"

    def const(self, a: FloatArray | float | list[int], dtype: object = np.float64) -> str:
        from onnx import numpy_helper

        name = self._name("c")
        self.inits.append(numpy_helper.from_array(np.asarray(a, dtype=dtype), name))  # type: ignore[call-overload]
        return name

    def op(self, kind: str, *inputs: str, out: str | None = None, **attrs: int) -> str:
        from onnx import helper

        name = out or self._name(kind.lower())
        self.nodes.append(helper.make_node(kind, list(inputs), [name], **attrs))  # type: ignore[arg-type]
        return name

    def activation(self, kind: str, x: str) -> str:
        if kind == "softplus":  # max(x, 0) + log(1 + exp(-|x|)), exact for all x in float64
            tail = self.op("Log", self.op("Add", self.op("Exp", self.op("Neg", self.op("Abs", x))), self.const(1.0)))
            return self.op("Add", self.op("Relu", x), tail)
        if kind == "tanh":
            return self.op("Tanh", x)
        return self.op("Sigmoid", x)


def onnx_model(model: SurrogateModel, net: str) -> bytes:
    """The serialised ONNX graph of ``net`` (``force`` or ``moment``), see the module docstring."""
    import onnx
    from onnx import TensorProto, helper

    g = _Graph()
    gate = model.gate
    gate_node = None if gate is None else _onnx_gate(g, gate)
    outs = [_onnx_member(g, m, net, gate, gate_node) for m in model.members]
    outputs = [helper.make_tensor_value_info("mean", TensorProto.DOUBLE, ["n", 3])]
    if len(outs) == 1:
        g.op("Identity", outs[0], out="mean")
    else:
        axis0 = g.const([0], np.int64)
        stacked = g.op("Concat", *[g.op("Unsqueeze", o, axis0) for o in outs], axis=0)
        mean = g.op("ReduceMean", stacked, axis0, keepdims=0, out="mean")
        dev = g.op("Sub", stacked, g.op("Unsqueeze", mean, axis0))
        g.op("Sqrt", g.op("ReduceMean", g.op("Mul", dev, dev), axis0, keepdims=0), out="std")
        outputs.append(helper.make_tensor_value_info("std", TensorProto.DOUBLE, ["n", 3]))
    graph = helper.make_graph(
        g.nodes,  # type: ignore[arg-type]
        f"alcove_{net}",
        [helper.make_tensor_value_info("features", TensorProto.DOUBLE, ["n", len(model.config.input_names)])],
        outputs,
        initializer=g.inits,  # type: ignore[arg-type]
    )
    proto = helper.make_model(graph, opset_imports=[helper.make_opsetid("", ONNX_OPSET)], producer_name="alcove")
    proto.ir_version = 8
    onnx.checker.check_model(proto)
    data: bytes = proto.SerializeToString()
    return data


def onnx_history_step(model: SurrogateModel) -> bytes:
    """The serialised ONNX graph of the history states' update (module docstring)."""
    import onnx
    from onnx import TensorProto, helper

    g = _Graph()
    bx, bz = model.preset.profile.back_point()
    cfg = model.config.history

    def col(source: str, i: int) -> str:
        return g.op("Gather", source, g.const([i], np.int64), axis=1)

    def mul(a: str, b: str) -> str:
        return g.op("Mul", a, b)

    def sub(a: str, b: str) -> str:
        return g.op("Sub", a, b)

    def add(a: str, b: str) -> str:
        return g.op("Add", a, b)

    r_x = col("features", 0)
    v = [col("features", i) for i in range(3, 6)]
    c0 = [col("features", i) for i in range(6, 9)]
    c1 = [col("features", i) for i in range(9, 12)]
    w = [col("features", i) for i in range(12, 15)]
    c2 = [  # the third column of T: c0 x c1
        sub(mul(c0[1], c1[2]), mul(c0[2], c1[1])),
        sub(mul(c0[2], c1[0]), mul(c0[0], c1[2])),
        sub(mul(c0[0], c1[1]), mul(c0[1], c1[0])),
    ]
    arm = [add(mul(c0[i], g.const(bx)), mul(c2[i], g.const(bz))) for i in range(3)]
    indentation = g.op("Neg", add(r_x, arm[0]))
    slip_y = add(v[1], sub(mul(w[2], arm[0]), mul(w[0], arm[2])))
    slip_z = add(v[2], sub(mul(w[0], arm[1]), mul(w[1], arm[0])))
    width = cfg.indentation_ramp
    x = sub(indentation, col("z", 0))
    zero = g.const(0.0)
    ramped = g.op(
        "Where",
        g.op("LessOrEqual", x, zero),
        zero,
        g.op(
            "Where",
            g.op("Less", x, g.const(width)),
            g.op("Div", mul(x, x), g.const(2.0 * width)),
            sub(x, g.const(width / 2.0)),
        ),
    )
    a = g.op("Div", "dt", g.const(cfg.slip_time_constant))
    one_plus_a = add(a, g.const(1.0))
    filtered = [g.op("Div", add(col("z", i), mul(a, slip)), one_plus_a) for i, slip in ((1, slip_y), (2, slip_z))]
    g.op("Concat", add(col("z", 0), ramped), *filtered, axis=1, out="z_next")
    double = TensorProto.DOUBLE
    graph = helper.make_graph(
        g.nodes,  # type: ignore[arg-type]
        "alcove_history_step",
        [
            helper.make_tensor_value_info("z", double, ["n", N_HISTORY]),
            helper.make_tensor_value_info("features", double, ["n", N_FEATURES]),
            helper.make_tensor_value_info("dt", double, ["n", 1]),
        ],
        [helper.make_tensor_value_info("z_next", double, ["n", N_HISTORY])],
        initializer=g.inits,  # type: ignore[arg-type]
    )
    proto = helper.make_model(graph, opset_imports=[helper.make_opsetid("", ONNX_OPSET)], producer_name="alcove")
    onnx.checker.check_model(proto)
    data: bytes = proto.SerializeToString()
    return data


def check_onnx_history_step(model: SurrogateModel, data: bytes) -> float:
    """Largest ``|onnx - alcove| / max(1, |alcove|)`` of the update along a reproducible press
    (every branch of the ramp, slip both ways); raises :class:`ExportError` above :data:`ONNX_RTOL`."""
    import onnxruntime as ort

    from alcove.science.geometry import relative_kinematics
    from alcove.science.surrogate.features import features
    from alcove.science.surrogate.history import history_states

    preset = model.preset
    t = np.linspace(0.0, 1.0, 201)
    q = preset.theta_min + (preset.theta_max - preset.theta_min) * (0.5 - 0.5 * np.cos(3 * np.pi * t))
    qd = (preset.theta_max - preset.theta_min) * 1.5 * np.pi * np.sin(3 * np.pi * t)
    kin = relative_kinematics(preset, q, qd)
    want = history_states(preset, kin, t, model.config.history)
    session = ort.InferenceSession(data, providers=["CPUExecutionProvider"])
    (got,) = session.run(
        None, {"z": want[:-1], "features": features(kin)[1:], "dt": np.diff(t)[:, None].astype(np.float64)}
    )
    err = float(np.max(np.abs(got - want[1:]) / np.maximum(1.0, np.abs(want[1:]))))
    if not err <= ONNX_RTOL:
        raise ExportError("history_step.onnx", f"differs from alcove by {err:.3g} (relative), above {ONNX_RTOL:g}")
    return err


def check_onnx(model: SurrogateModel, net: str, data: bytes, x: FloatArray) -> float:
    """Largest ``|onnx - torch| / max(1, |torch|)`` of the mean and std at raw features ``x``; raises
    :class:`ExportError` above :data:`ONNX_RTOL`."""
    import onnxruntime as ort

    session = ort.InferenceSession(data, providers=["CPUExecutionProvider"])
    got = session.run(None, {"features": np.ascontiguousarray(x, dtype=np.float64)})
    p = model.predict_ensemble(x)
    want = [getattr(p, net), getattr(p, f"{net}_std")][: len(got)]
    err = max(float(np.max(np.abs(g - w) / np.maximum(1.0, np.abs(w)))) for g, w in zip(got, want, strict=True))
    if not err <= ONNX_RTOL:
        raise ExportError(f"{net}.onnx", f"differs from PyTorch by {err:.3g} (relative), above {ONNX_RTOL:g}")
    return err


def write_exports(model: SurrogateModel, root: Path, check_features: FloatArray | None = None) -> list[str]:
    """Write the CasADi and ONNX files into ``root``; returns their names. The ONNX graphs are
    checked with onnxruntime at ``check_features`` (default: the input standardisation's mean
    +- 3 scale, 64 reproducible random rows)."""
    written = []
    for stem, fn in casadi_net_functions(model).items():
        fn.save(str(root / f"{stem}.casadi"))
        written.append(f"{stem}.casadi")
    if check_features is None:
        rng = np.random.default_rng(0)
        norm = model.input_norm
        check_features = norm.mean + 3.0 * norm.divisor * rng.uniform(-1.0, 1.0, (64, len(norm.mean)))
    for net in NETS:
        data = onnx_model(model, net)
        check_onnx(model, net, data, check_features)
        (root / f"{net}.onnx").write_bytes(data)
        written.append(f"{net}.onnx")
    if model.config.features == "history":
        data = onnx_history_step(model)
        check_onnx_history_step(model, data)
        (root / "history_step.onnx").write_bytes(data)
        written.append("history_step.onnx")
    return written


__all__ = [
    "ONNX_OPSET",
    "ONNX_RTOL",
    "ExportError",
    "casadi_net_functions",
    "check_onnx",
    "check_onnx_history_step",
    "history_step_function",
    "onnx_history_step",
    "onnx_model",
    "write_exports",
]
