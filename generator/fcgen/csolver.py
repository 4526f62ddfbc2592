"""The ctypes binding of a built solver library: ``CSolver`` implements the closed-loop ``Controller`` protocol
(``kind = "c"``) exactly as ``ReferenceController`` does for the Python reference, plus thin wrappers of the C API
for tests and verification. One process shares one static workspace per loaded library: loading the same ``.so``
twice gives the same solver state. Building the library is ``fcgen.build``'s job.
"""

from __future__ import annotations

import ctypes
import math
from pathlib import Path

import numpy as np

from .build import build
from .codegen.consistency import read_macros
from .contract import (
    EXIT_CODES,
    HOST_TICKS_PER_SECOND,
    STATUS_FIELDS,
    STATUS_INTS,
    STATUS_REALS,
    STATUS_STRUCTS,
    Status,
    StepResult,
)
from .road import Road
from .solver_folder import FolderLike, SolverFolder, as_folder, solver_name


class CSolver:
    """ctypes binding of a generated solver's shared library (timed with the library's host clock)."""

    kind = "c"

    def __init__(
        self,
        lib_path: Path | str,
        header: Path | str | None = None,
        init: bool = True,
        clock: str = "wall",
        folder: SolverFolder | None = None,
    ):
        """Load a solver library; ``init=False`` leaves a freshly loaded library zero-initialized (no init call).
        ``clock``: ``"wall"`` (monotonic) or ``"cpu"`` (the thread's CPU time: no preemption by other loads).
        ``folder``: the library's solver folder as read already (its name and sizes), else the ``header`` given or
        the ``<name>_solver.h`` found above the library is read."""
        lib_path = Path(lib_path)
        if clock not in ("wall", "cpu"):
            raise ValueError(f"clock = {clock!r} is invalid: allowed 'wall' or 'cpu'")
        if folder is not None:
            self.name, self.sizes = folder.name, dict(folder.sizes)
        else:
            self.name = lib_path.name[len("lib") : -len(".so")]
            self.sizes = read_macros(Path(header) if header else self._find_header(lib_path), self.name)
        s = self.sizes
        self.N, self.nx, self.nu = s["N"], s["NX"], s["NU"]
        self.n_opp, self.n_opp_par = s["NOPP"], s["NOPP_PAR"]
        self.n, self.m, self.nnz_A = s["QP_N"], s["QP_M"], s["QP_NNZ_A"]
        self.dtype = np.float32 if s.get("USE_FLOAT") else np.float64
        self._real = ctypes.c_float if s.get("USE_FLOAT") else ctypes.c_double
        self._status_cls, self._status_layout = STATUS_STRUCTS[bool(s.get("USE_FLOAT"))]
        self.ticks_per_second = HOST_TICKS_PER_SECOND  # of the host clocks given to set_clock below
        self.lib = ctypes.CDLL(str(lib_path.resolve()))
        self._declare()
        if init:
            self.init()
        self._f("set_clock")(
            ctypes.cast(self._f("host_clock" if clock == "wall" else "host_cpu_clock"), ctypes.c_void_p)
        )

    @staticmethod
    def _find_header(lib_path: Path) -> Path:
        for d in (lib_path.parent, *lib_path.parents):
            try:
                return d / f"{solver_name(d)}_solver.h"
            except FileNotFoundError:
                continue
        raise FileNotFoundError(f"no *_solver.h above {lib_path}")

    @classmethod
    def from_dir(cls, folder: FolderLike, verify: bool = False, clock: str = "wall", **build_kw) -> CSolver:
        """Build a generated folder (a :class:`~.solver_folder.SolverFolder`, or its path: read once) and load it."""
        folder = as_folder(folder)
        return cls(build(folder, verify=verify, **build_kw), clock=clock, folder=folder)

    # -- ctypes plumbing ------------------------------------------------------------------------------------------
    def _f(self, fn: str):
        f = self._fns.get(fn)
        return f if f is not None else getattr(self.lib, f"{self.name}_{fn}")

    def _declare(self) -> None:
        """Argument and result types of the C API; array arguments are passed as plain addresses (``_ptr``)."""
        R, PR, I = self._real, ctypes.c_void_p, ctypes.c_int
        PPR = ctypes.POINTER(ctypes.POINTER(self._real))
        self._fns: dict = {}
        sig = {
            "init": ([], I),
            "set_clock": ([ctypes.c_void_p], None),
            "set_state": ([PR], I),
            "set_road": ([R, R, I, PR, PR, PR, PR], I),
            "set_opponents": ([PR], I),
            "prepare": ([], I),
            "set_road_bounds": ([PR, PR], I),
            "set_opponent_shapes": ([PR], I),
            "set_reference": ([R, R], I),
            "set_reference_stages": ([PR, PR], I),
            "set_obstacle_margins": ([PR], I),
            "feedback": ([], I),
            "get_u0": ([PR], I),
            "get_states": ([PR], I),
            "get_controls": ([PR], I),
            "max_slack": ([], R),
            "get_status": ([ctypes.c_void_p], I),
            "reset": ([], None),
            "has_guess": ([], I),
            "get_qp": ([PPR] * 7, I),
            "get_opp_params": ([PR], I),
            "host_clock": ([], ctypes.c_uint32),
            "host_cpu_clock": ([], ctypes.c_uint32),
        }
        for fn, (args, res) in sig.items():
            f = self._f(fn)
            f.argtypes, f.restype = args, res
            self._fns[fn] = f
        self._status = self._status_cls()
        self._status_addr = ctypes.addressof(self._status)
        self._u0 = np.zeros(self.nu, dtype=self.dtype)
        self._u0_addr = self._u0.ctypes.data
        self._inputs: dict[str, tuple[np.ndarray, int]] = {}

    @staticmethod
    def _ptr(a: np.ndarray) -> int:
        """The address of a contiguous array of the solver's real type (the caller keeps ``a`` alive over the call)."""
        return a.ctypes.data

    def _arr(self, v, n: int | None = None) -> np.ndarray:
        a = np.ascontiguousarray(np.asarray(v, dtype=self.dtype).ravel())
        if n is not None and a.size != n:
            raise ValueError(f"expected {n} values, got {a.size}")
        return a

    def _input(self, key: str, v, n: int | None = None) -> int:
        """Copy ``v`` (converted to the solver's real type, as ``_arr``) into the preallocated input buffer ``key``;
        returns the buffer's address (no array or pointer object per call; the C side copies its inputs)."""
        a = np.asarray(v).ravel()
        if n is not None and a.size != n:
            raise ValueError(f"expected {n} values, got {a.size}")
        buf = self._inputs.get(key)
        if buf is None or buf[0].size != a.size:
            arr = np.empty(a.size, dtype=self.dtype)
            buf = self._inputs[key] = (arr, arr.ctypes.data)
        buf[0][...] = a
        return buf[1]

    # -- thin API -------------------------------------------------------------------------------------------------
    def init(self) -> int:
        return self._f("init")()

    def set_state(self, x0) -> int:
        return self._fns["set_state"](self._input("x0", x0, 5))

    def set_road(self, road: Road) -> int:
        """set_road, then (a road with a drivable band) set_road_bounds."""
        n, inp = road.size, self._input
        rc = self._fns["set_road"](
            road.s0,
            road.ds,
            n,
            inp("kappa", road.kappa, n),
            inp("phi", road.phi, n),
            inp("gx", road.gx, n),
            inp("gy", road.gy, n),
        )
        if rc or road.n_min is None:
            return rc
        return self.set_road_bounds(road.n_min, road.n_max)

    def set_road_bounds(self, n_min, n_max) -> int:
        n = int(np.asarray(n_min).size)
        return self._fns["set_road_bounds"](self._input("nmin", n_min, n), self._input("nmax", n_max, n))

    def set_reference(self, v_ref: float, n_ref: float) -> int:
        return self._fns["set_reference"](v_ref, n_ref)

    def set_reference_stages(self, v_ref, n_ref) -> int:  # N+1 values each; None passes NULL
        v, n = (None if a is None else self._input(key, a, self.N + 1) for key, a in (("vref", v_ref), ("nref", n_ref)))
        return self._fns["set_reference_stages"](v, n)

    def set_obstacle_margins(self, margins) -> int:  # N+1 values; None passes NULL
        return self._fns["set_obstacle_margins"](
            None if margins is None else self._input("margin", margins, self.N + 1)
        )

    def set_opponent_shapes(self, shapes) -> int:
        return self._fns["set_opponent_shapes"](self._input("shape", shapes, self.n_opp * self.sizes["NOPP_SHAPE"]))

    def set_road_raw(self, s0: float, ds: float, kappa, phi, gx, gy) -> int:
        k, p, x, y = (self._arr(a) for a in (kappa, phi, gx, gy))
        return self._fns["set_road"](s0, ds, int(k.size), k.ctypes.data, p.ctypes.data, x.ctypes.data, y.ctypes.data)

    def set_opponents(self, params) -> int:
        return self._fns["set_opponents"](self._input("opp", params, (self.N + 1) * self.n_opp * self.n_opp_par))

    def prepare(self) -> int:
        return self._fns["prepare"]()

    def feedback(self) -> int:
        return self._fns["feedback"]()

    def reset(self) -> None:
        self._f("reset")()

    def has_guess(self) -> bool:
        return bool(self._fns["has_guess"]())

    def u0(self) -> np.ndarray:
        self._fns["get_u0"](self._u0_addr)
        return self._u0.astype(float)

    def states(self) -> np.ndarray:
        x = np.zeros((self.N + 1) * self.nx, dtype=self.dtype)
        self._f("get_states")(self._ptr(x))
        return x.reshape(self.N + 1, self.nx).astype(float)

    def controls(self) -> np.ndarray:
        u = np.zeros(self.N * self.nu, dtype=self.dtype)
        self._f("get_controls")(self._ptr(u))
        return u.reshape(self.N, self.nu).astype(float)

    def max_slack(self) -> float:
        return float(self._fns["max_slack"]())

    def status(self) -> Status:
        """The C status; its phase durations (ticks of the host clock) in seconds, as ``Status`` keeps them."""
        st = self._status
        self._fns["get_status"](self._status_addr)
        tps = self.ticks_per_second
        return Status(
            **{f: getattr(st, f) for f in STATUS_INTS + STATUS_REALS},
            time_prepare=st.ticks_prepare / tps,
            time_feedback=st.ticks_feedback / tps,
        )

    def get_qp(self) -> dict[str, np.ndarray]:
        """Copies of the QP data: q, l, u, A_x, P_x, z (the backend's primal solution), y (dual guess)."""
        ptrs = [ctypes.POINTER(self._real)() for _ in range(7)]
        self._f("get_qp")(*[ctypes.byref(p) for p in ptrs])
        lens = (self.n, self.m, self.m, self.nnz_A, self.n, self.n, self.m)
        keys = ("q", "l", "u", "A_x", "P_x", "z", "y")
        return {k: np.ctypeslib.as_array(p, shape=(n,)).astype(float) for k, p, n in zip(keys, ptrs, lens)}

    def get_opp_params(self) -> np.ndarray:
        """The opponents' part of the last prepare's stage parameters, shape (N+1, NOPP * NOPP_STAGE)."""
        n = self.n_opp * self.sizes["NOPP_STAGE"]
        p = np.zeros(max(1, (self.N + 1) * n), dtype=self.dtype)
        self._f("get_opp_params")(self._ptr(p))
        return p[: (self.N + 1) * n].astype(float).reshape(self.N + 1, n)

    @staticmethod
    def code_name(code: int) -> str:
        return EXIT_CODES[code] if 0 <= code < len(EXIT_CODES) else f"unknown({code})"

    # -- Controller protocol ----------------------------------------------------------------------------------------
    def prepare_phase(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> int:
        """Inputs, then the preparation phase, in the same order as ``ReferenceController``; returns the exit code."""
        rc = self.set_road(road)
        rc = rc or self.set_opponents(opp)
        if not rc and not self.has_guess():
            rc = self.set_state(x0)
        return rc or self.prepare()

    def feedback_phase(self, x0: np.ndarray, rc: int = 0) -> StepResult:
        """The measured state, then the feedback phase; ``rc``: the exit code of ``prepare_phase``."""
        rc = rc or self.set_state(x0)
        rc = rc or self.feedback()
        st = self.status()
        if rc:  # the control get_u0 gives after an error: the fallback (unusable QP) or the last one (rejected)
            return StepResult(
                self.u0(),
                rc,
                st.qp_status,
                st.qp_iter,
                st.time_prepare,
                st.time_feedback,
                math.nan,
                st.plan_reaction,
                st.a_lat_guard,
            )
        return StepResult(
            self.u0(),
            0,
            st.qp_status,
            st.qp_iter,
            st.time_prepare,
            st.time_feedback,
            self.max_slack(),
            st.plan_reaction,
            st.a_lat_guard,
        )

    def step(self, x0: np.ndarray, road: Road, opp: np.ndarray) -> StepResult:
        """One RTI sample, the same calls in the same order as ``ReferenceController.step``."""
        return self.feedback_phase(x0, self.prepare_phase(x0, road, opp))

    def plan(self) -> tuple[np.ndarray, np.ndarray]:
        """The planned trajectory of the last solution: states (N+1, nx), controls (N, nu)."""
        return self.states(), self.controls()

    def window_stepper(self, road: Road, samples: int):
        """For a closed loop's samples on one road: ``step(x0, s_start, opp)``, the same as
        ``self.step(x0, road.window(s_start, samples), opp)`` (the same C calls in the same order with the same
        values, the same results and errors) without building the window or converting inputs per call (a road with a
        drivable band: on the built window): set_road is given the road's own arrays at the window's offset
        (converted to the solver's real type once), the state and the opponents are copied into preallocated
        buffers, the status is read from its struct.

        A subclass that overrides a part of ``step`` (``QpRecorder``) or an instance with a replaced method gets
        ``step`` on a built window."""
        if road.n_min is not None or self._step_replaced():
            return lambda x0, s_start, opp: self.step(x0, road.window(s_start, samples), opp)
        arrays = [np.ascontiguousarray(a, dtype=self.dtype) for a in (road.kappa, road.phi, road.gx, road.gy)]
        ak, ap, ax, ay = (a.ctypes.data for a in arrays)
        size, r_s0, r_ds, item = road.size, road.s0, road.ds, np.dtype(self.dtype).itemsize
        state, opponents, xptr, optr = self._window_inputs()
        q = self._quick_fns()
        set_road, set_opponents, set_state, has_guess = (
            q["set_road"],
            q["set_opponents"],
            q["set_state"],
            q["has_guess"],
        )
        prepare, feedback, result, floor = (
            self._fns["prepare"],
            self._fns["feedback"],
            self._result_reader(),
            math.floor,
        )

        def step(x0: np.ndarray, s_start: float, opp: np.ndarray) -> StepResult:
            i0 = int(floor((s_start - r_s0) / r_ds))
            if i0 < 0 or i0 + samples > size or samples < 2:
                road.window(s_start, samples)  # raises its ValueError
            off = i0 * item
            # prepare_phase
            rc = set_road(r_s0 + i0 * r_ds, r_ds, samples, ak + off, ap + off, ax + off, ay + off)
            if not rc:
                opponents(opp)
                rc = set_opponents(optr)
            copied = False
            if not rc and not has_guess():
                copied = state(x0)
                rc = set_state(xptr)
            rc = rc or prepare()
            # feedback_phase
            if not rc:
                copied = copied or state(x0)
                rc = set_state(xptr)
            rc = rc or feedback()
            return result(rc)

        step.road_arrays = arrays  # type: ignore[attr-defined]  # the arrays whose addresses set_road gets live as long as the function
        return step

    def _step_replaced(self) -> bool:
        """Whether a method ``step`` calls is overridden by a subclass or replaced on this instance."""
        return any(m in self.__dict__ or getattr(type(self), m) is not getattr(CSolver, m) for m in _STEP_PARTS)

    def _window_inputs(self):
        """``window_stepper``'s inputs: ``state(x0)`` and ``opponents(opp)`` copy into the preallocated buffers (as
        ``_input`` does, the same checks), and the buffers' fixed addresses as ctypes pointers."""
        o_shape = (self.N + 1, self.n_opp, self.n_opp_par)
        n_opp = math.prod(o_shape)
        self._input("x0", np.zeros(5), 5)
        self._input("opp", np.zeros(n_opp), n_opp)
        (xbuf, xaddr), (obuf, oaddr) = self._inputs["x0"], self._inputs["opp"]
        obuf3, ndarray = obuf.reshape(o_shape), np.ndarray

        def state(x0) -> bool:  # _input("x0", x0, 5)
            if type(x0) is ndarray and x0.shape == (5,):
                xbuf[...] = x0
                return True
            xa = np.asarray(x0).ravel()
            if xa.size != 5:
                raise ValueError(f"expected 5 values, got {xa.size}")
            xbuf[...] = xa
            return True

        def opponents(opp) -> None:  # _input("opp", opp, n_opp)
            if type(opp) is ndarray and opp.shape == o_shape:
                obuf3[...] = opp
                return
            o = np.asarray(opp).ravel()
            if o.size != n_opp:
                raise ValueError(f"expected {n_opp} values, got {o.size}")
            obuf[...] = o

        return state, opponents, ctypes.c_void_p(xaddr), ctypes.c_void_p(oaddr)

    def _result_reader(self):
        """``result(rc)``: a sample's ``StepResult`` after its feedback (status struct and u0 read in one call each,
        the slack only when the sample succeeded), as ``feedback_phase`` gives it."""
        q = self._quick_fns()
        get_status, get_u0, max_slack = q["get_status"], q["get_u0"], q["max_slack"]
        st_ptr, u0_ptr = ctypes.c_void_p(self._status_addr), ctypes.c_void_p(self._u0_addr)
        st, u0, nan = self._status, self._u0, math.nan
        unpack, tps = self._status_layout.unpack_from, self.ticks_per_second
        i_status, i_iter, i_prep, i_fb, i_react, i_guard = (
            STATUS_FIELDS.index(k)
            for k in ("qp_status", "qp_iter", "ticks_prepare", "ticks_feedback", "plan_reaction", "a_lat_guard")
        )

        def result(rc: int) -> StepResult:
            get_status(st_ptr)
            get_u0(u0_ptr)
            v = unpack(st)
            return StepResult(
                u0.astype(float),
                rc,
                v[i_status],
                v[i_iter],
                v[i_prep] / tps,
                v[i_fb] / tps,
                nan if rc else max_slack(),
                v[i_react],
                v[i_guard],
            )

        return result

    def _quick_fns(self) -> dict:
        """The short C calls of a sample (inputs, status, u0, slack) bound through ``ctypes.PyDLL``: the same functions
        and types without releasing and taking the GIL around each call (prepare and feedback still release it)."""
        q = self.__dict__.get("_quick")
        if q is None:
            lib = ctypes.PyDLL(self.lib._name)
            q = {}
            for fn in ("set_road", "set_opponents", "set_state", "has_guess", "get_status", "get_u0", "max_slack"):
                g = getattr(lib, f"{self.name}_{fn}")
                g.argtypes, g.restype = self._fns[fn].argtypes, self._fns[fn].restype
                q[fn] = g
            self._quick = q
        return q


#: the methods ``CSolver.step`` calls (``window_stepper`` calls their C functions directly unless one is replaced)
_STEP_PARTS = (
    "step",
    "prepare_phase",
    "feedback_phase",
    "set_road",
    "set_opponents",
    "set_state",
    "has_guess",
    "prepare",
    "feedback",
    "status",
    "u0",
    "max_slack",
)


class QpRecorder(CSolver):
    """A C solver in closed loop that keeps every warm-started QP it solved (get_qp's data and solution, plus
    ``y_warm``: the previous duals shifted one sample by the problem's ``QpLayout``, the warm start the backend was
    given)."""

    def __init__(self, lib, layout):
        super().__init__(lib)
        self.layout, self.qps = layout, []

    def prepare_phase(self, x0, road, opp):
        self._warm, self._y_prev = self.has_guess(), self.get_qp()["y"]
        return super().prepare_phase(x0, road, opp)

    def feedback_phase(self, x0, rc=0):
        r = super().feedback_phase(x0, rc)
        if self._warm and rc == 0:
            self.qps.append({**self.get_qp(), "y_warm": self.layout.shift_duals(self._y_prev)})
        return r
