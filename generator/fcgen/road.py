"""Road data, random roads, C1-consistent interpolants (numpy and CasADi from one formula), Frenet transforms.

A road is data: samples of ``kappa``, ``phi_gamma``, ``gamma_x``, ``gamma_y`` on a uniform grid ``s0 + i ds``.
Between samples ``kappa`` is linear, ``phi_gamma`` cubic Hermite with slope ``kappa`` (so exactly the integral of the
linear ``kappa``), and ``gamma`` cubic Hermite with slopes ``[cos, sin](phi_gamma)``.

Reproducible on every CPU: the numpy side (random roads, the centre-line integration, the Frenet transforms that
give the solvers' opponent poses) uses only elementwise ``+ - * /`` (correctly rounded IEEE operations: the same bits
whatever numpy's SIMD width), accumulations in a fixed order (``np.cumsum``, sums of shifted slices written out) and
libm's ``sin``/``cos`` through the ``math`` module (``libm_cos``/``libm_sin``). Never numpy's transcendental ufuncs
(``np.sin``, ``np.cos``, ...: per-CPU SIMD kernels, e.g. SVML on AVX-512), nor dot products, ``@``,
``np.convolve`` or LAPACK (BLAS/SIMD kernels chosen per CPU, each summing in its own order): a road or an opponent
pose that moves in its last bit from one machine to another moves every solver output after it, and golden suites
recorded on one machine would fail on another.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from .contract import INPUT_RANGES
from .dsl import Bounds

# --- CPU-independent elementwise trigonometry ---------------------------------------------------


def _libm(fn, x):
    a = np.asarray(x, dtype=float)
    if a.ndim == 0:
        return np.float64(fn(float(a)))
    return np.fromiter(map(fn, a.ravel().tolist()), float, a.size).reshape(a.shape)


def libm_cos(x):
    """cos of every element of ``x`` by libm (``math.cos``): not numpy's per-CPU SIMD kernels (float64 array, or
    ``np.float64`` for a scalar)."""
    return _libm(math.cos, x)


def libm_sin(x):
    """sin of every element of ``x`` by libm (``math.sin``), as ``libm_cos``."""
    return _libm(math.sin, x)


# 10-point Gauss-Legendre rule on [-1, 1]: the positive nodes and their weights, correctly rounded (from a 60-digit
# Newton iteration on P_10; their leading 15 digits are Abramowitz-Stegun's table 25.4). Constants, not
# ``np.polynomial.legendre.leggauss`` (LAPACK eigenvalues: last bits per BLAS kernel).
_GL10_HALF = (
    (0.1488743389816312108848260, 0.2955242247147528701738930),
    (0.4333953941292471907992659, 0.2692667193099963550912269),
    (0.6794095682990244062343274, 0.2190863625159820439955349),
    (0.8650633666889845107320967, 0.1494513491505805931457763),
    (0.9739065285171717200779640, 0.0666713443086881375935688),
)
GL10_NODES = np.array([-x for x, _ in reversed(_GL10_HALF)] + [x for x, _ in _GL10_HALF])
GL10_WEIGHTS = np.array([w for _, w in reversed(_GL10_HALF)] + [w for _, w in _GL10_HALF])


# --- the one interpolation formula (works on floats, numpy arrays and CasADi SX) ----------------


def _hermite(tau, h, y0, y1, m0, m1):
    """Cubic Hermite value and d/ds on a segment of length h at local coordinate tau in [0, 1]."""
    t2 = tau * tau
    t3 = t2 * tau
    val = (2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + tau) * h * m0 + (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * h * m1
    der = (
        (6 * t2 - 6 * tau) * y0
        + (3 * t2 - 4 * tau + 1) * h * m0
        + (-6 * t2 + 6 * tau) * y1
        + (3 * t2 - 2 * tau) * h * m1
    ) / h
    return val, der


def _segment(tau, h, k0, k1, p0, p1, x0, x1, y0, y1, c0, c1, s0, s1):
    """Road quantities on one segment: kappa, phi_gamma, gamma_x, gamma_y and the tangent [gx', gy'];
    ``c0, c1, s0, s1``: cos and sin of phi_gamma at the segment's two ends."""
    kappa = (1 - tau) * k0 + tau * k1
    phi, _ = _hermite(tau, h, p0, p1, k0, k1)
    gx, dgx = _hermite(tau, h, x0, x1, c0, c1)
    gy, dgy = _hermite(tau, h, y0, y1, s0, s1)
    return kappa, phi, gx, gy, dgx, dgy


# --- road data ----------------------------------------------------------------------------------


class LeftRoad(ValueError):
    """A road window asked for beyond the road's stretch: the state it is for has left the road (a closed loop ends
    there: ``sim.closedloop.run_closed_loop``)."""


class FrenetSingular(LeftRoad):
    """A state at the road's centre of curvature (``1 - n kappa <= FRENET_MIN``), where its Frenet coordinates are
    singular: it has left the road."""


FRENET_MIN = 0.1
"""The smallest ``1 - n kappa`` the closed loop's plant steps a Frenet state from (``FrenetSingular``): on the paper's
roads it is 0.5 and more inside the band (|n| <= 10 m, |kappa| <= 0.05 1/m); from 0.04 a state 56 m off the road
jumped 316 m back in one sample."""


@dataclass(frozen=True, eq=False)
class Road:
    """Road samples on the uniform grid ``s0 + i ds``, i = 0..M-1; optionally the drivable band at each sample,
    ``n_min`` (right edge, m) < ``n_max`` (left edge): the ego's lateral bounds there (None: the problem's
    ``Bounds.n_min``/``n_max`` everywhere)."""

    s0: float
    ds: float
    kappa: np.ndarray
    phi: np.ndarray
    gx: np.ndarray
    gy: np.ndarray
    n_min: np.ndarray | None = None
    n_max: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = len(self.kappa)
        if m < 2 or any(len(a) != m for a in (self.phi, self.gx, self.gy)):
            raise ValueError("road: kappa, phi_gamma, gamma_x, gamma_y must have the same length >= 2")
        ds_lo, ds_hi = INPUT_RANGES.ds_min, INPUT_RANGES.ds_max
        if not ds_lo <= self.ds <= ds_hi:
            raise ValueError(f"road.ds = {self.ds!r} is invalid: allowed in [{ds_lo}, {ds_hi}] m (the C's set_road)")
        for name in ("kappa", "phi", "gx", "gy"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"road.{name} contains NaN or infinite values")
        if (self.n_min is None) != (self.n_max is None):
            raise ValueError("road: n_min and n_max are given together or not at all")
        if self.n_min is not None:
            lo, hi = np.asarray(self.n_min, dtype=float), np.asarray(self.n_max, dtype=float)
            if lo.shape != (m,) or hi.shape != (m,):
                raise ValueError(f"road: n_min and n_max must have one value per sample ({m})")
            if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
                raise ValueError("road.n_min/n_max contain NaN or infinite values")
            bad = np.flatnonzero(~(lo < hi))
            if bad.size:
                i = int(bad[0])
                raise ValueError(
                    f"road.n_min[{i}] = {float(lo[i])!r} is invalid: allowed < n_max[{i}] = {float(hi[i])!r}"
                )
            object.__setattr__(self, "n_min", lo)
            object.__setattr__(self, "n_max", hi)

    @classmethod
    def from_curvature(cls, kappa, ds: float, s0: float = 0.0, x0=(0.0, 0.0, 0.0)) -> Road:
        """Integrate the centre line from (x, y, phi) = x0 for piecewise-linear curvature samples.

        ``phi`` is exact (trapezoid of a linear function); ``gamma`` uses 10-point Gauss-Legendre per segment: libm
        trig and the weighted sum over the 10 points in node order (CPU-independent, see the module docstring).
        """
        kappa = np.asarray(kappa, dtype=float)
        m = len(kappa)
        phi = np.empty(m)
        phi[0] = x0[2]
        phi[1:] = x0[2] + np.cumsum(ds * 0.5 * (kappa[:-1] + kappa[1:]))
        tau = 0.5 * (GL10_NODES + 1.0)
        w = 0.5 * GL10_WEIGHTS
        k0, k1 = kappa[:-1, None], kappa[1:, None]
        ph = phi[:-1, None] + ds * (k0 * tau + 0.5 * (k1 - k0) * (tau * tau))
        c, sn = libm_cos(ph), libm_sin(ph)
        dx, dy = c[:, 0] * w[0], sn[:, 0] * w[0]
        for q in range(1, len(w)):
            dx = dx + c[:, q] * w[q]
            dy = dy + sn[:, q] * w[q]
        dx, dy = ds * dx, ds * dy
        gx = np.concatenate([[x0[0]], x0[0] + np.cumsum(dx)])
        gy = np.concatenate([[x0[1]], x0[1] + np.cumsum(dy)])
        return cls(float(s0), float(ds), kappa, phi, gx, gy)

    @property
    def size(self) -> int:
        return len(self.kappa)

    @property
    def s(self) -> np.ndarray:
        return self.s0 + self.ds * np.arange(self.size)

    @property
    def s_end(self) -> float:
        return self.s0 + self.ds * (self.size - 1)

    def window(self, s_start: float, samples: int) -> Road:
        """The sub-road of ``samples`` samples starting at the last grid point at or before ``s_start``."""
        i0 = math.floor((s_start - self.s0) / self.ds)
        if i0 < 0 or i0 + samples > self.size:
            raise LeftRoad(
                f"road window [{s_start:.1f}, +{samples} samples] is outside the road [{self.s0:.1f}, {self.s_end:.1f}]"
            )
        if samples < 2:
            raise ValueError("road: kappa, phi_gamma, gamma_x, gamma_y must have the same length >= 2")
        sl = slice(i0, i0 + samples)
        # a window of a checked road is a checked road: built without __post_init__'s per-sample checks (the closed
        # loop takes one window per sample)
        win = object.__new__(Road)
        for name, value in (
            ("s0", self.s0 + i0 * self.ds),
            ("ds", self.ds),
            ("kappa", self.kappa[sl].copy()),
            ("phi", self.phi[sl].copy()),
            ("gx", self.gx[sl].copy()),
            ("gy", self.gy[sl].copy()),
            ("n_min", None if self.n_min is None else self.n_min[sl].copy()),
            ("n_max", None if self.n_max is None else self.n_max[sl].copy()),
        ):
            object.__setattr__(win, name, value)
        return win

    def band_at(self, s: float) -> tuple[float, float] | None:
        """The drivable band ``(n_min, n_max)`` at ``s``: linear between samples (held beyond the ends); None without
        per-sample bounds. The solver's formula (Python and C alike): a + tau (b - a) on the segment of s."""
        if self.n_min is None or self.n_max is None:
            return None
        t = (s - self.s0) / self.ds
        i = min(max(math.floor(t), 0), self.size - 2)
        tau = min(max(t - i, 0.0), 1.0)
        lo, hi = self.n_min, self.n_max
        return (float(lo[i] + tau * (lo[i + 1] - lo[i])), float(hi[i] + tau * (hi[i + 1] - hi[i])))

    # -- numpy evaluation ------------------------------------------------------------------------
    def _locate(self, s):
        t = (np.asarray(s, dtype=float) - self.s0) / self.ds
        i = np.clip(np.floor(t), 0, self.size - 2).astype(int)
        return i, t - i

    @cached_property
    def _tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """cos and sin of phi_gamma at the samples (libm; computed on first use; the arrays are not to be changed)."""
        c, s = libm_cos(self.phi), libm_sin(self.phi)
        c.flags.writeable = s.flags.writeable = False
        return c, s

    def eval(self, s):
        """kappa, phi_gamma, gamma_x, gamma_y, gamma_x', gamma_y' at s (numpy, vectorized)."""
        i, tau = self._locate(s)
        c, sn = self._tangents
        return _segment(
            tau,
            self.ds,
            self.kappa[i],
            self.kappa[i + 1],
            self.phi[i],
            self.phi[i + 1],
            self.gx[i],
            self.gx[i + 1],
            self.gy[i],
            self.gy[i + 1],
            c[i],
            c[i + 1],
            sn[i],
            sn[i + 1],
        )

    def to_cartesian(self, s, n, alpha):
        """Inverse Frenet transform F^-1: (s, n, alpha) -> (x, y, phi)."""
        _, phi_g, gx, gy, _, _ = self.eval(s)
        return gx - n * libm_sin(phi_g), gy + n * libm_cos(phi_g), phi_g + alpha

    def project(self, x, y, s_guess=None, tol: float = 1e-12, max_iter: int = 30):
        """s* = argmin ||p - gamma(s)||^2 by Newton from a guess (nearest sample if none); vectorized."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if s_guess is None:
            d2 = (self.gx[None, :] - np.atleast_1d(x)[:, None]) ** 2 + (
                self.gy[None, :] - np.atleast_1d(y)[:, None]
            ) ** 2
            s_guess = self.s[np.argmin(d2, axis=1)].reshape(x.shape)
        s = np.array(s_guess, dtype=float) + np.zeros_like(x)
        for _ in range(max_iter):
            # foot point: (gamma(s) - p) . e_t(s) = 0 with e_t = [cos, sin](phi_gamma), the tangent F^-1 uses,
            # so F(F^-1(.)) is exact; it is the argmin's first-order condition up to interpolation error.
            kappa, phi_g, gx, gy, dx, dy = self.eval(s)
            c, sn = libm_cos(phi_g), libm_sin(phi_g)
            ex, ey = gx - x, gy - y
            g = ex * c + ey * sn
            dg = dx * c + dy * sn + kappa * (-ex * sn + ey * c)
            step = g / np.where(dg > 0.05, dg, 1.0)
            s = s - step
            if np.all(np.abs(step) < tol * np.maximum(1.0, np.abs(s))):
                break
        return s if s.ndim else float(s)

    def to_frenet(self, x, y, phi, s_guess=None):
        """Forward Frenet transform F: (x, y, phi) -> (s, n, alpha) by local projection; alpha = phi - phi_road with
        ``phi``'s whole turns (the exact inverse of ``to_cartesian``; a solver's state takes ``wrap_angle`` of it)."""
        s = self.project(x, y, s_guess)
        _, phi_g, gx, gy, _, _ = self.eval(s)
        n = -(x - gx) * libm_sin(phi_g) + (y - gy) * libm_cos(phi_g)
        return s, n, phi - phi_g


def wrap_angle(a):
    """``a`` (rad; a scalar or an array) less its whole turns, in [-pi, pi]; a value already there unchanged (bit for
    bit)."""
    if np.ndim(a) == 0:
        return a if abs(a) <= math.pi else math.remainder(float(a), 2.0 * math.pi)
    a = np.asarray(a, dtype=float)
    return np.where(np.abs(a) <= math.pi, a, np.remainder(a + math.pi, 2.0 * math.pi) - math.pi)


def curve_speed(road: Road, s: float, a_lat: float, decel: float, v_max: float) -> float:
    """The largest speed at ``s`` from which braking at ``decel`` reaches every sample ahead (from one ds behind) no
    faster than ``sqrt(a_lat / |kappa|)``: ``sqrt(min(v_max^2, min_i a_lat / |kappa_i| + 2 decel max(s_i - s, 0)))``.

    The generated C's ``curve_speed`` does the same operations in the same order (bit-equal in double)."""
    ss = road.s0 + np.arange(len(road.kappa)) * road.ds
    d = ss - s
    k = np.abs(road.kappa)
    use = (d >= -road.ds) & (k > 0.0)
    v2 = a_lat / k[use] + (2.0 * decel) * np.maximum(d[use], 0.0)
    return math.sqrt(min(v_max * v_max, float(np.min(v2, initial=math.inf))))


def curve_reference(
    road: Road,
    s0: float,
    times: Sequence[float],
    v_set: float | Sequence[float] | np.ndarray,
    a_lat: float,
    decel: float,
    v_max: float,
    along: bool = True,
    stages: bool = False,
) -> tuple[list[float], list[float]]:
    """The reference along the horizon that brakes for the bends ahead: per node k, ``v_k = min(v_set_k,
    curve_speed(s_k))`` at ``s_k``, with ``s_0 = s0`` and ``s_k = s_(k-1) + (t_k - t_(k-1)) v_(k-1)``; ``along =
    False``: the curve speed at the plan's start only, ``v_k = min(v_set_k, curve_speed(s0))`` and ``s_k = s0 + t_k
    v_0`` (one ``v_set`` for every node) or as along (``stages``: a per-node ``v_set``, ``set_reference_stages``).

    A speed capped only at the plan's start asks for that speed over the whole horizon, and the plan then brakes
    for a bend through its a_lat rows; per node it brakes through the tracking cost. The C's ``curve_reference``
    does the same operations in the same order."""
    s_ref, v_ref = [], []
    s, v, t_prev, c = float(s0), 0.0, 0.0, 0.0
    v_sets = [v_set] * len(times) if isinstance(v_set, float | int) else list(v_set)
    for k, t in enumerate(times):
        if k > 0:
            s = s + (t - t_prev) * v if (along or stages) else float(s0) + t * v
        if along or k == 0:
            c = curve_speed(road, s, a_lat, decel, v_max)
        v = c if c < v_sets[k] else v_sets[k]
        s_ref.append(s)
        v_ref.append(v)
        t_prev = t
    return s_ref, v_ref


def random_road(
    seed: int | Sequence[int],
    length: float = 1600.0,
    ds: float = 2.0,
    kappa_max: float = 0.05,
    knot_spacing: float = 25.0,
    s0: float = 0.0,
) -> Road:
    """Seeded random road: uniform curvature knots, linearly interpolated and smoothed (|kappa| <= kappa_max).

    ``seed`` is anything ``numpy.random.default_rng`` takes (an int, or a list of ints for derived seeds).
    """
    rng = np.random.default_rng(seed)
    knots = rng.uniform(-kappa_max, kappa_max, math.ceil(length / knot_spacing) + 3)
    s = np.arange(math.ceil(length / ds) + 1) * ds
    s_knots = np.arange(len(knots)) * knot_spacing
    raw = np.interp(s, s_knots, knots)
    width = max(1, round(knot_spacing / ds) | 1)  # odd moving-average width: a convex combination
    padded = np.pad(raw, width // 2, mode="edge")
    # the moving average as a sum of shifted slices in a fixed order (not np.convolve: a BLAS dot product per
    # output, summed in the order of the CPU's kernel)
    acc = padded[: len(s)].copy()
    for k in range(1, width):
        acc += padded[k : k + len(s)]
    return Road.from_curvature(acc / width, ds, s0)


def min_self_distance(road: Road, min_arc: float, s_max: float | None = None) -> float:
    """Smallest planar distance between two road samples more than ``min_arc`` apart along the road.

    Only samples with ``s <= s_max`` count (default: all). ``inf`` when no two samples are that far apart.
    """
    keep = road.s <= (road.s_end if s_max is None else s_max)
    s, x, y = road.s[keep], road.gx[keep], road.gy[keep]
    far = np.abs(s[:, None] - s[None, :]) > min_arc
    if not far.any():
        return math.inf
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    return float(math.sqrt(np.min(d2[far])))


def straight_road(length: float = 1600.0, ds: float = 2.0, s0: float = 0.0) -> Road:
    return Road.from_curvature(np.zeros(math.ceil(length / ds) + 1), ds, s0)


# --- CasADi: the same formula on a short local window of samples ---------------------------------


def check_frenet(x: np.ndarray, p: np.ndarray) -> None:
    """Raise ``FrenetSingular`` where the Frenet state ``x`` is at the road's centre of curvature: 1 - n kappa <=
    ``FRENET_MIN``, kappa the sample at the start of ``x``'s segment in the packed window ``p`` that starts one sample
    behind it (``p[3]``, ``RoadWindowParams``)."""
    gap = 1.0 - x.item(1) * p.item(3)
    if gap <= FRENET_MIN:
        raise FrenetSingular(
            f"the ego at s = {x.item(0):.2f} m, n = {x.item(1):.2f} m reached the road's centre of curvature "
            f"(1 - n kappa = {gap:.3f})"
        )


@dataclass(frozen=True)
class RoadWindowParams:
    """Layout of a local road window inside a stage's parameter vector: [s_w0, ds, kappa, phi, gx, gy]."""

    samples: int

    @property
    def size(self) -> int:
        return 2 + 4 * self.samples

    def pack(self, road: Road, i0: int) -> np.ndarray:
        return self.pack_into(np.empty(self.size), road, i0)

    def pack_into(self, out: np.ndarray, road: Road, i0: int) -> np.ndarray:
        """``pack`` into a preallocated vector ``out`` (size ``self.size``); returns ``out``."""
        K = self.samples
        if i0 < 0 or i0 + K > road.size:
            raise LeftRoad(f"road window [{i0}, +{K} samples] is outside the road's {road.size} samples")
        out[0], out[1] = road.s0 + i0 * road.ds, road.ds
        for j, a in enumerate((road.kappa, road.phi, road.gx, road.gy)):
            out[2 + j * K : 2 + (j + 1) * K] = a[i0 : i0 + K]
        return out


def casadi_road(s, p, samples: int):
    """kappa, phi_gamma, gamma_x, gamma_y (and the tangent) at symbolic s from a window parameter vector p."""
    tau, ends = window_segment(s, p, samples, 4)
    (k0, k1), (p0, p1), (x0, x1), (y0, y1) = ends
    return _segment(tau, p[1], k0, k1, p0, p1, x0, x1, y0, y1, ca.cos(p0), ca.cos(p1), ca.sin(p0), ca.sin(p1))


def window_segment(s, p, samples: int, arrays: int):
    """The segment of symbolic s in a window vector p = [s_w0, ds, arrays x samples values]: its local coordinate
    tau in [0, 1] and, per array, the values at the segment's two ends (selected without branches)."""
    K = samples
    s_w0, ds = p[0], p[1]
    arr = [p[2 + j * K : 2 + (j + 1) * K] for j in range(arrays)]
    t = (s - s_w0) / ds
    i = ca.fmin(ca.fmax(ca.floor(t), 0), K - 2)
    tau = t - i

    def pick(a, off):
        return sum((i == j) * a[j + off] for j in range(K - 1))

    return tau, [(pick(a, 0), pick(a, 1)) for a in arr]


def casadi_to_cartesian(s, n, alpha, p, samples: int):
    """F^-1 on symbolic (s, n, alpha) with a window parameter vector."""
    _, phi_g, gx, gy, _, _ = casadi_road(s, p, samples)
    return gx - n * ca.sin(phi_g), gy + n * ca.cos(phi_g), phi_g + alpha


def band_outside(road: Road, b: Bounds) -> str | None:
    """Where ``road``'s drivable band (if it has one) leaves the problem's ``Bounds``: the first such sample as a
    one-line message, or None."""
    if road.n_min is None or road.n_max is None:
        return None
    for name, a, ok in (("n_min", road.n_min, road.n_min >= b.n_min), ("n_max", road.n_max, road.n_max <= b.n_max)):
        if not np.all(ok):
            i = int(np.flatnonzero(~ok)[0])
            return (
                f"road.{name}[{i}] = {float(a[i])!r} is outside the problem's "
                f"band: allowed in [{b.n_min}, {b.n_max}] (Bounds.n_min, n_max)"
            )
    return None
