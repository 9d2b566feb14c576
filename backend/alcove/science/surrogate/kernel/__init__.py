"""The compiled training kernel (``train_step.c``): build, cache, load, and a NumPy-side wrapper.

The kernel runs a whole training epoch (forward, backpropagation and Adam for every batch)
in one call; see the C file's header for why and for its exact semantics. It is compiled
on first use with the machine's C compiler (``$CC``, else ``cc``/``gcc``) for the host CPU
(``-O3 -march=native``, OpenMP SIMD, glibc's vector ``exp``/``log``) into a per-user cache
(``$ALCOVE_KERNEL_CACHE``, else ``$XDG_CACHE_HOME/alcove/kernels``, else
``~/.cache/alcove/kernels``), about 0.5 s once; the file name hashes the source, the
compiler, the flags and the CPU's feature flags, so a cache shared between different
machines never hands one a binary built for another CPU.

``ALCOVE_TRAINING_KERNEL`` selects the implementation: ``auto`` (default: the C kernel when it
builds, else PyTorch), ``c`` (the C kernel or an error saying why it is unavailable),
``torch`` (the PyTorch implementation, :class:`..fused.FusedNets`). Both implement the same
training; they agree to rounding per step (tests compare them with autograd and
``torch.optim.Adam``) but not bit for bit over a whole training, so a model's lineage records
which one trained it. Either is bit-identical run after run on one machine.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import sysconfig
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from alcove.science.arrays import FloatArray, IntArray
from alcove.science.surrogate.mlp import MLP

SOURCE = Path(__file__).with_name("train_step.c")
ACTIVATIONS = {"softplus": 0, "tanh": 1, "sigmoid": 2}
KERNEL_ENV = "ALCOVE_TRAINING_KERNEL"
_P_DOUBLE = ctypes.POINTER(ctypes.c_double)
_P_INT32 = ctypes.POINTER(ctypes.c_int32)
_P_INT64 = ctypes.POINTER(ctypes.c_int64)


class KernelUnavailable(RuntimeError):
    """The C kernel cannot be built or loaded here (the reason is the message)."""


class KernelChoiceError(ValueError):
    """``ALCOVE_TRAINING_KERNEL`` asks for something this machine cannot do (``field``: the variable)."""

    def __init__(self, reason: str):
        self.field, self.reason = KERNEL_ENV, reason
        super().__init__(f"{KERNEL_ENV}: {reason}")


class _Net(ctypes.Structure):
    _fields_ = [
        ("n_layers", ctypes.c_int32),
        ("activation", ctypes.c_int32),
        ("y_col", ctypes.c_int32),
        ("active", ctypes.c_int32),
        ("widths", _P_INT32),
        ("params", _P_DOUBLE),
        ("grad", _P_DOUBLE),
        ("exp_avg", _P_DOUBLE),
        ("exp_avg_sq", _P_DOUBLE),
        ("steps", ctypes.c_int64),
    ]


def requested_kernel() -> str:
    """``auto``, ``c`` or ``torch`` from ``ALCOVE_TRAINING_KERNEL``."""
    value = os.environ.get(KERNEL_ENV, "auto").strip().lower() or "auto"
    if value not in ("auto", "c", "torch"):
        raise KernelChoiceError(f"{value!r} is not one of auto, c, torch")
    return value


def cache_dir() -> Path:
    if os.environ.get("ALCOVE_KERNEL_CACHE"):
        return Path(os.environ["ALCOVE_KERNEL_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "alcove" / "kernels"


def _compiler() -> str:
    candidates = [os.environ.get("CC", ""), (sysconfig.get_config_var("CC") or "").split(" ")[0], "cc", "gcc", "clang"]
    for c in candidates:
        if c and shutil.which(c):
            return str(shutil.which(c))
    raise KernelUnavailable("no C compiler found (set CC, or install gcc)")


def _cpu_flags() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("flags", "Features")):
                return line
    except OSError:
        pass
    return platform.processor() or platform.machine()


# tried in order: vectorised exp/log through libmvec for this CPU; then without libmvec (other
# C libraries); then without -march=native (compilers that do not know it)
_FLAG_SETS = [
    (["-O3", "-march=native", "-fno-math-errno", "-fopenmp-simd"], ["-lmvec", "-lm"]),
    (["-O3", "-march=native", "-fno-math-errno", "-DALCOVE_NO_LIBMVEC"], ["-lm"]),
    (["-O3", "-fno-math-errno", "-DALCOVE_NO_LIBMVEC"], ["-lm"]),
]


def _build(cc: str, out_dir: Path) -> Path:
    source = SOURCE.read_bytes()
    stat = os.stat(cc)
    errors = []
    for cflags, libs in _FLAG_SETS:
        key = hashlib.sha256(
            b"\0".join(
                [
                    source,
                    cc.encode(),
                    str((stat.st_size, stat.st_mtime_ns)).encode(),
                    " ".join(cflags + libs).encode(),
                    _cpu_flags().encode(),
                ]
            )
        ).hexdigest()[:20]
        target = out_dir / f"alcove_train_{key}.so"
        if target.exists():
            return target
        out_dir.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=target.name, suffix=".tmp", dir=out_dir)
        os.close(fd)
        try:
            cmd = [cc, *cflags, "-shared", "-fPIC", str(SOURCE), "-o", tmp, *libs]
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            if proc.returncode == 0:
                ctypes.CDLL(tmp)  # loads (libmvec present, CPU supports the code) before it is cached
                os.replace(tmp, target)  # atomic: concurrent builders each publish a complete file
                return target
            last_line = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else proc.returncode
            errors.append(f"{' '.join(cflags)}: {last_line}")
        except OSError as exc:
            errors.append(f"{' '.join(cflags)}: {exc}")
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    raise KernelUnavailable("the training kernel did not build: " + "; ".join(errors))


@lru_cache(maxsize=1)
def _load() -> ctypes.CDLL:
    cc = _compiler()
    try:
        path = _build(cc, cache_dir())
    except PermissionError:
        path = _build(cc, Path(tempfile.gettempdir()) / f"alcove-kernels-{os.getuid() if hasattr(os, 'getuid') else 0}")
    lib = ctypes.CDLL(str(path))
    common = (
        ctypes.c_int32,
        ctypes.POINTER(_Net),
        _P_DOUBLE,
        ctypes.c_int64,
        ctypes.c_int32,
        ctypes.c_int32,
        _P_INT64,
        ctypes.c_int64,
    )
    lib.alcove_gradient.argtypes = common
    lib.alcove_train_epoch.argtypes = (
        *common,
        ctypes.c_int64,
        ctypes.c_double,
        ctypes.c_double,
        ctypes.c_double,
        ctypes.c_double,
    )
    lib.alcove_forward.argtypes = [ctypes.POINTER(_Net), _P_DOUBLE, ctypes.c_int64, ctypes.c_int64, _P_DOUBLE]
    for fn in (lib.alcove_gradient, lib.alcove_train_epoch, lib.alcove_forward):
        fn.restype = ctypes.c_int
    return lib


def load_kernel() -> ctypes.CDLL:
    """The compiled kernel (built on first use), or :class:`KernelUnavailable` with the reason."""
    try:
        return _load()
    except KernelUnavailable:
        raise
    except Exception as exc:  # a compiler that crashed, a library that does not load, ...
        raise KernelUnavailable(f"the training kernel did not load: {exc}") from exc


def kernel_supports(nets: list[MLP]) -> str | None:
    """Why the kernel cannot train these nets (None: it can)."""
    for net in nets:
        if net.activation not in ACTIVATIONS:
            return f"activation {net.activation!r}"
        if any(p.dtype != torch.float64 for p in net.parameters()):
            return "dtype float32 (the kernel computes in float64)"
    return None


def _ptr(a: NDArray[Any], kind: type[ctypes._Pointer[Any]] = _P_DOUBLE) -> ctypes._Pointer[Any]:
    return a.ctypes.data_as(kind)


class KernelNets:
    """MLPs sharing their input, trained by the C kernel on a row-major float64 table.

    Table columns: the ``n_in`` standardised features first, each net's targets from its
    ``y_col``, the sample weight at ``w_col``. Parameters, gradients and Adam moments are
    NumPy vectors in ``nn.Linear`` order (weight, bias per layer) owned by this object.
    """

    def __init__(self, nets: list[MLP], y_cols: list[int], lib: ctypes.CDLL | None = None):
        reason = kernel_supports(nets)
        if reason:
            raise KernelUnavailable(f"the training kernel does not support {reason}")
        self.lib = lib or load_kernel()
        self.nets = nets
        self.n_in = nets[0].linears()[0].in_features
        self._keep: list[NDArray[np.int32]] = []
        self.params: list[FloatArray] = []
        self.grads: list[FloatArray] = []
        self.exp_avg: list[FloatArray] = []
        self.exp_avg_sq: list[FloatArray] = []
        self.structs = (_Net * len(nets))()
        for k, (net, y_col) in enumerate(zip(nets, y_cols, strict=False)):
            lins = net.linears()
            widths = np.array([lins[0].in_features, *[lin.out_features for lin in lins]], dtype=np.int32)
            params = parameters_to_vector(net.parameters()).detach().numpy().astype(np.float64, copy=True)
            grad, m, v = np.zeros_like(params), np.zeros_like(params), np.zeros_like(params)
            self._keep.append(widths)
            self.params.append(params)
            self.grads.append(grad)
            self.exp_avg.append(m)
            self.exp_avg_sq.append(v)
            self.structs[k] = _Net(
                len(lins),
                ACTIVATIONS[net.activation],
                y_col,
                1,
                _ptr(widths, _P_INT32),
                _ptr(params),
                _ptr(grad),
                _ptr(m),
                _ptr(v),
                0,
            )

    @property
    def steps(self) -> list[int]:
        return [int(s.steps) for s in self.structs]

    def active(self, k: int) -> bool:
        return bool(self.structs[k].active)

    def freeze(self, k: int) -> None:
        """Net ``k`` stops training; the others go on exactly as before."""
        self.structs[k].active = 0

    def _table(self, table: FloatArray, w_col: int) -> FloatArray:
        if table.dtype != np.float64 or not table.flags.c_contiguous or table.ndim != 2:
            raise ValueError("table: needs a C-contiguous float64 matrix")
        widest = max(s.y_col + self.nets[k].linears()[-1].out_features for k, s in enumerate(self.structs))
        if table.shape[1] < max(self.n_in, widest, w_col + 1):
            raise ValueError(f"table: {table.shape[1]} columns are too few for the nets' targets and the weight column")
        return table

    def _rows(self, rows: IntArray, n_rows: int) -> IntArray:
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        if rows.size and (rows.min() < 0 or rows.max() >= n_rows):
            raise IndexError(f"rows: indices must lie in [0, {n_rows})")
        return rows

    def gradient(self, table: FloatArray, w_col: int, rows: IntArray) -> None:
        """Set every active net's :attr:`grads` to the gradient of its loss on ``rows``."""
        table = self._table(table, w_col)
        rows = self._rows(rows, table.shape[0])
        rc = self.lib.alcove_gradient(
            len(self.nets), self.structs, _ptr(table), table.shape[1], self.n_in, w_col, _ptr(rows, _P_INT64), rows.size
        )
        if rc:
            raise MemoryError("the training kernel could not allocate its buffers")

    def train_epoch(
        self,
        table: FloatArray,
        w_col: int,
        order: IntArray,
        batch: int,
        lr: float,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
    ) -> None:
        """Batches of ``batch`` consecutive rows of ``order``, one Adam step of every active net after each."""
        table = self._table(table, w_col)
        order = self._rows(order, table.shape[0])
        rc = self.lib.alcove_train_epoch(
            len(self.nets),
            self.structs,
            _ptr(table),
            table.shape[1],
            self.n_in,
            w_col,
            _ptr(order, _P_INT64),
            order.size,
            int(batch),
            float(lr),
            float(betas[0]),
            float(betas[1]),
            float(eps),
        )
        if rc:
            raise MemoryError("the training kernel could not allocate its buffers")

    def forward(self, k: int, x: FloatArray) -> FloatArray:
        """Net ``k``'s outputs (n, n_out) for standardised inputs ``x`` (n, n_in)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] < self.n_in:
            raise ValueError(f"x: needs shape (n, {self.n_in}), got {x.shape}")
        out = np.empty((x.shape[0], self.nets[k].linears()[-1].out_features))
        if self.lib.alcove_forward(ctypes.byref(self.structs[k]), _ptr(x), x.shape[1], x.shape[0], _ptr(out)):
            raise MemoryError("the training kernel could not allocate its buffers")
        return out

    def weights(self, k: int) -> FloatArray:
        return self.params[k].copy()

    def store(self, k: int, flat: FloatArray | None = None) -> None:
        """Write net ``k``'s weights (default: the current ones) into the PyTorch module."""
        src = self.params[k] if flat is None else flat
        net = self.nets[k]
        with torch.no_grad():
            vector_to_parameters(torch.from_numpy(np.array(src, dtype=np.float64)), net.parameters())


__all__ = [
    "KERNEL_ENV",
    "KernelChoiceError",
    "KernelNets",
    "KernelUnavailable",
    "kernel_supports",
    "load_kernel",
    "requested_kernel",
]
