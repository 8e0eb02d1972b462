"""Sound reachability of the paper FLC's discrete-time closed loop: where no contact is possible
(``docs/safety-evidence.md``, section 4). ``python -m flc.reach {map,arch,check} --out FILE``.

What it computes. For a *box* of starts (follower speed, lead speed, bumper-to-bumper gap, lead
deceleration, each an interval) it steps the simulator's closed loop on affine forms (:class:`AF`:
a centre, one coefficient per symbol, an independent remainder), all boxes of a batch at once
(NumPy, one row per box or branch path), and decides:

* **certified**: for every start in the box, every lead deceleration in the box and every range
  error of the model (below), the gap stays above :data:`CONTACT_MARGIN` at every physics step up
  to the horizon (and, with ``prop="arch"``, ``gap >= 10 + 1.4 v_follower`` at every step);
* **not certified**: a lower bound reached its limit. That does *not* mean unsafe: the forms
  over-approximate.

The symbols are the box's dimensions and the range error's bias (:data:`K0`); at every frame
each form's remainder becomes a symbol of its own (:func:`_lift`, so that ``e = v_cmd - v`` and
the gap's changes cancel it later), and the least weighty columns are folded back. Every
nonlinearity is its chord plus a proven error bound (:func:`law`, :func:`desired`,
:func:`resistance`, :func:`_pwl` for the clamps and overrides), or its exact range where that is
narrower (all of them are nondecreasing).

The branch of Eq. (5) (``Delta_d <= -0.3`` m per frame). Where the interval of ``Delta_d`` allows
both branches the path *forks*, and each fork is refined to the members that take its branch
(:func:`_contract`: the linear constraint narrows the symbols' ranges). Beyond ``max_paths`` rows
per box they are merged pairwise (:func:`_merge`, their affine hull), and beyond that the two
branches' outputs are hulled: all sound. A box that fails is bisected (:meth:`Box.split`) and its
halves run again, down to ``max_depth`` bisections (:func:`certify`).

The model, step for step as the simulator (``crates/flc-sim/src/sim/mod.rs``: sense, then act):

* the lead (``lead::LeadDriver::step`` with one ``brake`` phase to 0 from t = 0): its demand is
  ``-decel + resistance(v)`` until its speed is at most 0.01 m/s, then the hold loop
  ``clamp(-3 v, -3, 2) + resistance(v)``; through its own vehicle model (as the follower's);
* a LiDAR frame every ``round(1 / (rate_hz physics_dt))`` physics steps from t = 0, on the state
  at the start of the step. The scan at t = 0 finds no lead (the simulator's bodies enter its
  query pipeline with the first physics step): the law cruises at the set speed, the follower's
  initial speed (``NoTargetCruise``); from the next frame the paper FLC
  (``flc_core::flc::FallbackController::step``, Eqs. (2)-(5), first frame ``steady``) sets the
  held speed command;
* the follower: the PI speed controller with anti-windup, clamps and the stop hold
  (``vehicle::SpeedController::step``), the actuator (dead time as a FIFO of physics steps starting
  idle, exact first-order lag, traction / power / brake limits), drag and rolling resistance, speed
  floored at 0 (``vehicle::Vehicle::step``); the displacement ``(v + v_new) / 2 dt``.

Assumptions (what a certificate does *not* cover):

* **range error**: the distance the law gets at frame k is ``gap_k + b + n_k`` with a bias
  ``|b| <= bias`` constant over the run (it cancels in ``Delta_d``) and a per-frame error
  ``|n_k| <= noise`` (:data:`BIAS`, :data:`NOISE` for the documents' certificates); the lead is
  detected at every later frame (no dropout, ghost, latency or jitter). The simulator's Gaussian
  range noise is unbounded: its noise-free LiDAR is what the documents' certificates cover, and
  :func:`crosscheck` measures its errors;
* straight driving: the follower's displacement is its path length (the simulator steers by pure
  pursuit of the detected lead; :func:`crosscheck` measures the lateral offset);
* the lead brakes with a constant deceleration in the box's interval from t = 0 (the simulator's
  brake phase), not an arbitrary profile;
* no controller other than the paper FLC; no previous distance at the start; the follower's
  actuator idle, its integrator empty;
* rounding: every state bound is widened outward by :data:`WIDEN` (relative and absolute) at every
  physics step. Each bound is a composition of at most a few dozen floating-point operations on
  magnitudes below 10^3 (rounding error below 1e-11); the chords' ends are padded for the
  rounding of the functions there; the simulator's own rounding of the positions (below 1e-9 m
  over 10^4 steps) is inside the widening of the gap. Contact in the simulator is rapier's (f32
  geometry): :data:`CONTACT_MARGIN` covers it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Optional, Sequence

import numpy as np

#: ``flc_sim::units::G``.
G = 9.81
#: The gap must stay above this, m (rapier's f32 contact geometry; ~1e-4 m at 2 km).
CONTACT_MARGIN = 0.01
#: Outward widening of every bound per physics step: (relative, absolute).
WIDEN = (1e-12, 1e-9)
#: Bisection scales of the box's dimensions (follower speed m/s, lead speed m/s, gap m, lead
#: deceleration m/s²): the widest dimension relative to these is split.
SPLIT_SCALE = (1.0, 1.0, 4.0, 1.0)
DIMS = ("v", "vl", "gap", "decel")


@dataclass(frozen=True)
class VehicleModel:
    """``flc_sim::VehicleParams`` as the longitudinal dynamics need it."""

    dead_steps: int
    alpha: float
    max_accel: float
    max_brake: float
    max_power: float
    mass: float
    drag: float  # 0.5 rho cd A / m
    rolling: float  # rolling_resistance * g

    @classmethod
    def from_params(cls, veh: Mapping[str, Any], dt: float) -> "VehicleModel":
        lag = float(veh["lag"])
        return cls(
            dead_steps=int(round(float(veh["dead_time"]) / dt)),
            alpha=(1.0 - math.exp(-dt / lag)) if lag > 0 else 1.0,
            max_accel=float(veh["max_accel"]),
            max_brake=float(veh["max_brake"]),
            max_power=float(veh["max_power"]),
            mass=float(veh["mass"]),
            drag=0.5 * float(veh["air_density"]) * float(veh["drag_cd"]) * float(veh["frontal_area"]) / float(veh["mass"]),
            rolling=float(veh["rolling_resistance"]) * G,
        )


@dataclass(frozen=True)
class Model:
    """The constants of the closed loop (read from a scenario's dictionary, :meth:`from_dict`)."""

    flc: Mapping[str, Any]
    kp: float
    ki: float
    integral_limit: float
    sc_max_accel: float
    sc_max_decel: float
    follower: VehicleModel
    lead: VehicleModel
    dt: float
    frame_steps: int
    bias: float = 0.0
    noise: float = 0.0

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], bias: float = 0.0, noise: float = 0.0) -> "Model":
        """From ``Scenario.to_dict()``; refuses what the model does not cover."""
        f = d["flc"]
        if d["controller"] != "flc":
            raise ValueError(f"reach: the model is the paper FLC (controller = \"flc\"), got {d['controller']!r}")
        if f["first_frame"] != "steady":
            raise ValueError("reach: flc.first_frame must be \"steady\"")
        if not f["clip_dist_s"] or f["shift_normal"] < 1 or f["shift_brake"] < 1:
            raise ValueError("reach: Eq. (5) is monotone only with clip_dist_s = true and shifts >= 1")
        lid = d["lidar"]
        if (lid["latency_frames"] != 0 or lid["jitter"] != 0 or lid["scan_drop_prob"] != 0 or lid["dropout_prob"] != 0
                or lid.get("dropout_at_max_range", 0) != 0 or lid.get("faults")):
            raise ValueError("reach: the LiDAR must have no latency, jitter, dropout or faults (not modelled)")
        fo = d["follower"]
        if fo.get("set_speed") is not None:
            raise ValueError("reach: follower.set_speed must be unset (the law cruises at the initial speed until its first target)")
        if fo.get("perception", "lidar") != "lidar" or fo.get("distance_offset") is not None:
            raise ValueError("reach: the law must read the LiDAR's bumper-to-bumper distance (perception = \"lidar\", no distance_offset)")
        dt = float(d["physics_dt"])
        frame = 1.0 / (float(lid["rate_hz"]) * dt)
        if abs(frame - round(frame)) > 1e-9:
            raise ValueError("reach: the LiDAR period must be a whole number of physics steps")
        sp = d["follower"]["speed_controller"]
        return cls(
            flc=dict(f),
            kp=float(sp["kp"]),
            ki=float(sp["ki"]),
            integral_limit=float(sp["integral_limit"]),
            sc_max_accel=float(sp["max_accel"]),
            sc_max_decel=float(sp["max_decel"]),
            follower=VehicleModel.from_params(d["follower"]["vehicle"], dt),
            lead=VehicleModel.from_params(d["lead"]["vehicle"], dt),
            dt=dt,
            frame_steps=int(round(frame)),
            bias=float(bias),
            noise=float(noise),
        )

    @classmethod
    def from_scenario(cls, sc: Any, bias: float = 0.0, noise: float = 0.0) -> "Model":
        return cls.from_dict(sc.to_dict(), bias=bias, noise=noise)


@dataclass(frozen=True)
class Box:
    """Start intervals: follower speed ``v``, lead speed ``vl`` (m/s), gap (m), lead deceleration
    ``decel`` (m/s², positive). ``same_speed``: the lead starts at the follower's speed (then
    ``vl`` is ``v``; the model treats them as two intervals, which over-approximates)."""

    v: tuple[float, float]
    gap: tuple[float, float]
    decel: tuple[float, float]
    vl: Optional[tuple[float, float]] = None

    def lead_speed(self) -> tuple[float, float]:
        return self.v if self.vl is None else self.vl

    def dims(self) -> list[tuple[float, float]]:
        return [self.v, self.lead_speed(), self.gap, self.decel]

    def split(self) -> tuple["Box", "Box"]:
        dims = self.dims()
        w = [(hi - lo) / s for (lo, hi), s in zip(dims, SPLIT_SCALE)]
        if self.vl is None:
            w[1] = -1.0  # one speed for both: split v
        k = int(np.argmax(w))
        lo, hi = dims[k]
        m = 0.5 * (lo + hi)
        out = []
        for part in ((lo, m), (m, hi)):
            d = list(dims)
            d[k] = part
            out.append(Box(v=d[0], gap=d[2], decel=d[3], vl=None if self.vl is None else d[1]))
        return out[0], out[1]

    def to_json(self) -> dict[str, Any]:
        return {"v": list(self.v), "vl": list(self.lead_speed()), "gap": list(self.gap), "decel": list(self.decel)}


# ---------------------------------------------------------------------------------------------
# Affine forms: x = c + sum_j G_j eps_j + [-r, r], eps_j in [-1, 1] the box's start dimensions
# (shared by every quantity of a row: this keeps the correlations intervals lose), r >= 0 the
# error of every linearisation so far (independent of everything: added, never cancelled).

#: The start box's symbols: follower start speed, lead start speed, gap, lead deceleration,
#: the range error's constant bias.
K0 = 5
#: The symbols in use now (the start box's plus the remainders lifted at the frames, reduced
#: to at most ``max_symbols``): shared by every form of a batch.
_K = [K0]


@dataclass
class AF:
    """Affine forms of N rows: centre ``c`` (N,), generators ``G`` (N, K), radius ``r`` (N,)."""

    c: np.ndarray
    G: np.ndarray
    r: np.ndarray

    @staticmethod
    def const(x: Any, n: int) -> "AF":
        return AF(np.broadcast_to(np.asarray(x, dtype=float), (n,)).copy(), np.zeros((n, _K[0])), np.zeros(n))

    @staticmethod
    def interval(lo: np.ndarray, hi: np.ndarray) -> "AF":
        return AF(0.5 * (lo + hi), np.zeros((lo.size, _K[0])), np.maximum(0.5 * (hi - lo), 0.0))

    def rad(self) -> np.ndarray:
        return np.abs(self.G).sum(axis=1) + self.r

    def lo(self) -> np.ndarray:
        return self.c - self.rad()

    def hi(self) -> np.ndarray:
        return self.c + self.rad()

    def __add__(self, o: Any) -> "AF":
        if isinstance(o, AF):
            return AF(self.c + o.c, self.G + o.G, self.r + o.r)
        return AF(self.c + o, self.G, self.r)

    def __sub__(self, o: Any) -> "AF":
        if isinstance(o, AF):
            return AF(self.c - o.c, self.G - o.G, self.r + o.r)
        return AF(self.c - o, self.G, self.r)

    def __neg__(self) -> "AF":
        return AF(-self.c, -self.G, self.r)

    def scale(self, s: Any) -> "AF":
        s = np.asarray(s, dtype=float)
        return AF(self.c * s, self.G * (s[..., None] if s.ndim else s), self.r * np.abs(s))

    def plus_radius(self, d: Any) -> "AF":
        return AF(self.c, self.G, self.r + d)

    def take(self, idx: np.ndarray) -> "AF":
        return AF(self.c[idx], self.G[idx], self.r[idx])

    @staticmethod
    def cat(a: "AF", b: "AF") -> "AF":
        return AF(np.concatenate([a.c, b.c]), np.concatenate([a.G, b.G]), np.concatenate([a.r, b.r]))

    def widen(self) -> "AF":
        rel, ab = WIDEN
        return AF(self.c, self.G, self.r + rel * (np.abs(self.c) + self.rad()) + ab)


def where(mask: np.ndarray, a: AF, b: AF) -> AF:
    return AF(np.where(mask, a.c, b.c), np.where(mask[:, None], a.G, b.G), np.where(mask, a.r, b.r))


def hull(a: AF, b: AF) -> AF:
    """Either ``a`` or ``b``: their mean plus half of ``|a - b|``'s bound."""
    d = a - b
    mean = AF(0.5 * (a.c + b.c), 0.5 * (a.G + b.G), 0.5 * (a.r + b.r) + 0.5 * np.maximum(np.abs(d.lo()), np.abs(d.hi())))
    box = AF.interval(np.minimum(a.lo(), b.lo()), np.maximum(a.hi(), b.hi()))
    # Both are sound; the narrower is kept (the mean keeps correlation, the box is tight).
    return where(box.r < mean.r, box, mean)


def _chord(x: AF, f: Any, err: np.ndarray) -> AF:
    """``f(x)`` as the chord of ``f`` over x's range plus ``err`` (a bound of ``|f - chord|``
    there) and the rounding of ``f`` at the ends."""
    lo, hi = x.lo(), x.hi()
    flo, fhi = f(lo), f(hi)
    w = hi - lo
    wide = w > 1e-9
    alpha = np.where(wide, (fhi - flo) / np.where(wide, w, 1.0), 0.0)
    beta = flo - alpha * lo
    # Narrow ranges: a constant with the ends' spread.
    pad = 1e-12 * (1.0 + np.abs(flo) + np.abs(fhi)) + np.where(wide, 0.0, np.abs(fhi - flo))
    out = (x.scale(alpha) + beta).plus_radius(np.abs(err) + pad + np.abs(alpha) * 1e-15 * (np.abs(lo) + np.abs(hi)))
    return _narrower(out, flo, fhi)


def _narrower(out: AF, flo: np.ndarray, fhi: np.ndarray) -> AF:
    """Every ``f`` linearised here is nondecreasing: where its range ``[f(lo), f(hi)]`` is
    narrower than the linearisation's remainder alone, the range (without correlation) is used."""
    pad = 1e-12 * (1.0 + np.abs(flo) + np.abs(fhi))
    rng = AF.interval(flo - pad, fhi + pad)
    return where(rng.r < out.r, rng, out)


def _pwl(x: AF, f: Any, breaks: Sequence[float]) -> AF:
    """A piecewise-linear ``f`` (kinks at ``breaks``): the chord, its error the largest deviation
    at the range's ends and the kinks inside it (exact for piecewise-linear functions)."""
    lo, hi = x.lo(), x.hi()
    w = hi - lo
    wide = w > 1e-9
    flo, fhi = f(lo), f(hi)
    alpha = np.where(wide, (fhi - flo) / np.where(wide, w, 1.0), 0.0)
    err = np.where(wide, 0.0, np.abs(fhi - flo))
    for b in breaks:
        inside = (lo < b) & (b < hi)
        dev = np.abs(f(np.full_like(lo, b)) - (flo + alpha * (b - lo)))
        err = np.maximum(err, np.where(inside, dev, 0.0))
    out = (x.scale(alpha) + (flo - alpha * lo)).plus_radius(err + 1e-12 * (1.0 + np.abs(flo) + np.abs(fhi)))
    return _narrower(out, flo, fhi)


def clip(x: AF, a: float, b: float) -> AF:
    lo, hi = x.lo(), x.hi()
    inside = (lo >= a) & (hi <= b)
    out = _pwl(x, lambda t: np.clip(t, a, b), (a, b))
    n = lo.size
    # Wholly beyond a bound: exactly that bound (the clamp's result is the constant itself).
    return where(inside, x, where(hi <= a, AF.const(a, n), where(lo >= b, AF.const(b, n), out)))


def _resistance(vm: VehicleModel, v: np.ndarray) -> np.ndarray:
    """``VehicleParams::resistance``: 0 at v <= 0, else drag v² + rolling (nondecreasing)."""
    return np.where(v > 0, vm.drag * v * v + vm.rolling, 0.0)


def resistance(vm: VehicleModel, v: AF) -> AF:
    """Smooth for v > 0 (a quadratic: chord error ``drag w² / 4``); a range touching 0 (where the
    rolling resistance jumps) as its interval."""
    lo, hi = v.lo(), v.hi()
    w = hi - lo
    smooth = _chord(v, lambda t: _resistance(vm, t), vm.drag * w * w / 4.0)
    return where(lo > 0, smooth, AF.interval(_resistance(vm, lo), _resistance(vm, hi)))


def _law_at(flc: Mapping[str, Any], x: np.ndarray, shift: float) -> np.ndarray:
    a = x * (shift - np.cos(np.pi * x / flc["bound_t"]))
    return np.where(a < 0, a * flc["negative_multiplier"], a)


def law(flc: Mapping[str, Any], ds: AF, shift: float) -> AF:
    """Eq. (5) with the negative multiplier on ``dist_s`` in [-bound_t, bound_t]:
    ``a(x) = x (shift - cos(k x))``, ``k = pi / bound_t``; ``|a''| = |2 k sin(k x) + k² x cos(k x)|
    <= min(k (2 + pi), 3 k² |x|)`` there, times the multiplier on x < 0; a kink at 0 of slope jump
    ``(multiplier - 1)(shift - 1)``. Chord error: ``M w² / 8 + J w / 4``."""
    k = np.pi / float(flc["bound_t"])
    mult = max(float(flc["negative_multiplier"]), 1.0)
    lo, hi = ds.lo(), ds.hi()
    w = hi - lo
    # |sin(k x)| <= k |x|: also |a''| <= 3 k² |x|, much smaller near dist_s = 0.
    M = mult * np.minimum(k * (2.0 + np.pi), 3.0 * k * k * np.maximum(np.abs(lo), np.abs(hi)))
    J = abs((float(flc["negative_multiplier"]) - 1.0) * (shift - 1.0))
    err = M * w * w / 8.0 + np.where((lo < 0) & (hi > 0), J * w / 4.0, 0.0)
    return _chord(ds, lambda t: _law_at(flc, t, shift), err)


def desired(flc: Mapping[str, Any], v: AF) -> AF:
    """Eqs. (2)-(4): ``D_d + F_shift = T_G v + B_gap + v min(cap, gain v / C)`` (v >= 0): a
    quadratic (second derivative ``2 gain / C``) up to ``v* = cap C / gain``, linear beyond, a
    concave kink of slope drop ``cap`` at ``v*``."""
    g, cap, c = float(flc["scale_gain"]), float(flc["scale_cap"]), float(flc["c"])

    def f(t: np.ndarray) -> np.ndarray:
        return flc["time_gap"] * t + flc["base_gap"] + np.maximum(t, 0.0) * np.minimum(g * t / c, cap)

    lo, hi = v.lo(), v.hi()
    w = hi - lo
    vs = cap * c / g
    err = (2.0 * g / c) * w * w / 8.0 + np.where((lo < vs) & (hi > vs), cap * w / 4.0, 0.0)
    return _chord(v, f, err)


# ---------------------------------------------------------------------------------------------
# The batch stepper


@dataclass
class Outcome:
    """One box's verdict."""

    box: Box
    depth: int
    certified: bool
    #: The least lower bound of the checked quantity over its paths (gap above the contact
    #: margin, or the ARCH margin), m.
    least: float
    #: Why not certified: "" (certified), "bound", "ambiguous" (split wanted), "invalid" (an input
    #: out of the law's valid range).
    reason: str = ""
    paths: int = 1


#: The state widened at every physics step (the speed command is held between frames: not
#: recomputed, not widened).
_STATE = ("v", "vl", "gap", "act", "actl", "integ", "dgap")


@dataclass
class _Rows:
    box: np.ndarray
    decel: AF
    s: dict[str, AF]
    ring: list[AF]  # the follower's dead-time FIFO, one AF per slot
    ringl: list[AF]
    done: np.ndarray  # the lead's brake phase finished: 0 for no member, 1 some, 2 all

    def take(self, idx: np.ndarray) -> "_Rows":
        return _Rows(self.box[idx], self.decel.take(idx), {k: v.take(idx) for k, v in self.s.items()},
                     [x.take(idx) for x in self.ring], [x.take(idx) for x in self.ringl], self.done[idx])

    @staticmethod
    def cat(a: "_Rows", b: "_Rows") -> "_Rows":
        return _Rows(np.concatenate([a.box, b.box]), AF.cat(a.decel, b.decel), {k: AF.cat(a.s[k], b.s[k]) for k in a.s},
                     [AF.cat(x, y) for x, y in zip(a.ring, b.ring)], [AF.cat(x, y) for x, y in zip(a.ringl, b.ringl)],
                     np.concatenate([a.done, b.done]))


def _vehicle_step(vm: VehicleModel, ring: list[AF], k: int, demand: AF, act: AF, v: AF, dt: float) -> tuple[AF, AF, AF]:
    """``Vehicle::step``: dead time (FIFO), lag, limits, resistance, speed floored at 0. Returns
    (actuator, v_new, displacement)."""
    n = vm.dead_steps
    if n > 0:
        j = k % n
        delayed, ring[j] = ring[j], demand
    else:
        delayed = demand
    act = act.scale(1.0 - vm.alpha) + delayed.scale(vm.alpha)
    alo, ahi, vlo, vhi = act.lo(), act.hi(), v.lo(), v.hi()
    cap_min = np.minimum(vm.max_accel, vm.max_power / (vm.mass * np.maximum(vhi, 1.0)))

    def lim(x: np.ndarray, vv: np.ndarray) -> np.ndarray:
        cap = np.minimum(vm.max_accel, vm.max_power / (vm.mass * np.maximum(vv, 1.0)))
        return np.where(x >= 0, np.minimum(x, cap), np.maximum(x, -vm.max_brake))

    free = (alo >= -vm.max_brake) & (ahi <= cap_min)
    braking = ahi <= 0
    a_act = where(free, act, where(braking, _pwl(act, lambda t: np.maximum(t, -vm.max_brake), (-vm.max_brake,)),
                                   AF.interval(lim(alo, vhi), lim(ahi, vlo))))
    # v_new = max(v - resistance(v) dt + a dt, 0); at a range touching 0 the exact range of
    # f(v) = v - resistance(v) dt (increasing on v > 0, f(0) = 0, f(0+) = -rolling dt).
    moving = vlo > 0
    f_lo = np.where(vhi > 0, -vm.rolling * dt, 0.0)
    f_hi = np.where(vhi > 0, np.maximum(vhi - _resistance(vm, vhi) * dt, 0.0), 0.0)
    f = where(moving, v - resistance(vm, v).scale(dt), AF.interval(f_lo, f_hi))
    raw = f + a_act.scale(dt)
    v_new = where(raw.lo() >= 0, raw, _pwl(raw, lambda t: np.maximum(t, 0.0), (0.0,)))
    disp = (v + v_new).scale(0.5 * dt)
    return act, v_new, disp


def _frame(m: Model, rows: _Rows, n_ok: np.ndarray, b_ok: np.ndarray) -> None:
    """One frame of the paper FLC (``FallbackController::step``): the held speed command. ``n_ok``
    / ``b_ok``: the row's members may take the normal / braking branch of Eq. (5)."""
    flc, S = m.flc, rows.s
    v = S["v"]
    # LF_dist = gap + b + n: the bias b is the last start symbol (constant over the run), the
    # per-frame error n a fresh radius.
    bias = AF.const(0.0, v.c.size)
    bias.G[:, K0 - 1] = m.bias
    d = (S["gap"] + bias).plus_radius(m.noise)
    b = float(flc["bound_t"])
    ds = clip(d - desired(flc, v), -b, b)
    an = law(flc, ds, float(flc["shift_normal"]))
    o = float(flc["override_dist"])
    mode = flc["dist_override"]
    if mode == "min":
        dso = where(ds.hi() <= o, ds, _pwl(ds, lambda t: np.minimum(t, o), (o,)))
    elif mode == "replace":
        dso = AF.const(o, v.c.size)
    else:
        dso = ds
    ab = law(flc, clip(dso, -b, b), float(flc["shift_brake"]))
    a = where(n_ok & b_ok, hull(an, ab), where(b_ok, ab, an))
    S["cmd"] = clip(v + a.scale(float(flc["command_gain"])), 0.0, float(flc["max_speed"]))
    S["dgap"] = AF.const(0.0, v.c.size)


def _lead_command(m: Model, rows: _Rows) -> AF:
    """``LeadDriver::step`` for one brake phase to 0: ``-decel + resistance(v)`` until the speed
    is at most 0.01 m/s, then the hold loop ``h(v) = clamp(-3 v, -3, 2) + resistance(v)``."""
    vl = rows.s["vl"]
    vl0, vl1 = vl.lo(), vl.hi()
    d = rows.done
    rows.done = np.where((d == 2) | (vl1 <= 0.01), 2, np.where((d == 1) | (vl0 <= 0.01), 1, 0)).astype(np.int8)
    d = rows.done
    brake = resistance(m.lead, vl) - rows.decel

    def h(t: np.ndarray) -> np.ndarray:
        return np.clip(-3.0 * t, -3.0, 2.0) + _resistance(m.lead, t)

    # h(0) = 0, h(0+) = rolling, decreasing up to v = 1, increasing beyond: its exact range.
    h0 = np.minimum(np.minimum(h(vl0), h(vl1)), h(np.clip(1.0, vl0, vl1)))
    h1 = np.maximum(np.maximum(h(vl0), h(vl1)), np.where((vl0 <= 0) & (vl1 > 0), m.lead.rolling, -np.inf))
    hold = AF.interval(h0, h1)
    return where(d == 0, brake, where(d == 2, hold, hull(brake, hold)))


def _physics(m: Model, rows: _Rows, k: int) -> tuple[AF, AF]:
    """One physics step of both vehicles (``SpeedController::step`` and ``Vehicle::step``);
    returns the follower's and the lead's displacement."""
    S = rows.s
    lead_cmd = _lead_command(m, rows)
    v, cmd, integ = S["v"], S["cmd"], S["integ"]
    e = cmd - v
    L, kp, kidt = m.integral_limit, m.kp, m.ki * m.dt
    ma, md = m.sc_max_accel, m.sc_max_decel
    cand = clip(integ + e.scale(kidt), -L, L)
    raw = e.scale(kp) + cand
    rlo, rhi = raw.lo(), raw.hi()
    every, none = (rhi < ma) & (rlo > -md), (rlo >= ma) | (rhi <= -md)
    integ = where(every, cand, where(none, integ, hull(cand, integ)))
    dem = clip(e.scale(kp) + integ, -md, ma)
    # A stop request at standstill holds the brake and empties the integrator.
    maybe = (cmd.lo() <= 0) & (v.lo() < 0.1)
    sure = (cmd.hi() <= 0) & (v.hi() < 0.1)
    n = v.c.size
    hold = AF.const(-min(md, 2.0), n)
    zero = AF.const(0.0, n)
    dem = where(sure, hold, where(maybe, hull(dem, hold), dem)).widen()
    S["integ"] = where(sure, zero, where(maybe, hull(integ, zero), integ))
    S["act"], S["v"], disp = _vehicle_step(m.follower, rows.ring, k, dem, S["act"], v, m.dt)
    S["actl"], S["vl"], displ = _vehicle_step(m.lead, rows.ringl, k, lead_cmd.widen(), S["actl"], S["vl"], m.dt)
    return disp, displ


def _start(m: Model, boxes: Sequence[Box]) -> _Rows:
    """The rows of ``boxes`` at t = 0 (the symbols: the start box's only)."""
    nb = len(boxes)
    _K[0] = K0

    def form(dim: int, sym: int) -> AF:
        lo = np.array([b.dims()[dim][0] for b in boxes], dtype=float)
        hi = np.array([b.dims()[dim][1] for b in boxes], dtype=float)
        G = np.zeros((nb, K0))
        G[:, sym] = 0.5 * (hi - lo)
        # The centre's rounding: the half-width is widened by an ulp-scale amount.
        return AF(0.5 * (lo + hi), G, 1e-15 * (np.abs(lo) + np.abs(hi)))

    same = np.array([b.vl is None for b in boxes])
    v = form(0, 0)
    vl_own = form(1, 1)
    vl = where(same, v, vl_own)  # one speed for both: the same symbol
    zero = AF.const(0.0, nb)
    s = {"v": v, "vl": vl, "gap": form(2, 2), "act": zero, "actl": zero, "integ": zero, "cmd": zero, "dgap": zero}
    return _Rows(np.arange(nb), form(3, 3), s, [zero] * max(m.follower.dead_steps, 1),
                 [zero] * max(m.lead.dead_steps, 1), np.zeros(nb, dtype=np.int8))


def _forms(rows: _Rows) -> list[tuple[Any, Any]]:
    """Every form of the rows as (container, key)."""
    out: list[tuple[Any, Any]] = [(rows, "decel")]
    out += [(rows.s, k) for k in sorted(rows.s)]
    out += [(rows.ring, j) for j in range(len(rows.ring))]
    out += [(rows.ringl, j) for j in range(len(rows.ringl))]
    return out


def _get(c: Any, k: Any) -> AF:
    return getattr(c, k) if isinstance(k, str) and not isinstance(c, dict) else c[k]


def _set(c: Any, k: Any, v: AF) -> None:
    if isinstance(k, str) and not isinstance(c, dict):
        setattr(c, k, v)
    else:
        c[k] = v


def _lift(rows: _Rows, max_symbols: int) -> None:
    """Zonotope order reduction over the whole state: every form's remainder radius becomes a new
    symbol of its own (so that later differences of correlated quantities cancel it, as they
    cancel the start box's symbols), then the columns beyond ``max_symbols`` with the least
    weight ``sum_i |G_ij|`` over the state are folded back into the radii (their interval hull:
    sound). The start box's symbols are always kept. (Girard's criterion, which folds first the
    columns that touch one quantity only, would fold every fresh remainder at once.)"""
    slots = _forms(rows)
    fs = [_get(c, k) for c, k in slots]
    n, D = rows.box.size, len(fs)
    Gs = np.stack([f.G for f in fs], axis=1)  # (n, D, K)
    R = np.stack([f.r for f in fs], axis=1)  # (n, D)
    G = np.concatenate([Gs, np.zeros((n, D, D))], axis=2)
    G[:, np.arange(D), Gs.shape[2] + np.arange(D)] = R
    kt = G.shape[2]
    newr = np.zeros((n, D))
    if kt > max_symbols:
        a = np.abs(G)
        score = a.sum(axis=1)  # (n, kt): the columns' weight over the whole state
        score[:, :K0] = np.inf
        keep = np.sort(np.argsort(score, axis=1)[:, kt - max_symbols:], axis=1)  # (n, max_symbols)
        kept = np.take_along_axis(G, keep[:, None, :], axis=2)
        newr = a.sum(axis=2) - np.abs(kept).sum(axis=2)
        G = kept
    _K[0] = G.shape[2]
    for j, (c, k) in enumerate(slots):
        _set(c, k, AF(fs[j].c.copy(), G[:, j, :].copy(), np.maximum(newr[:, j], 0.0)))


def _contract(rows: _Rows, idx: np.ndarray, f: AF, t: float, upper: bool) -> None:
    """Refines rows ``idx`` to the members with ``f <= t`` (``upper``) or ``f >= t``: each
    symbol's range is narrowed to what the constraint allows with every other term at its worst
    (one pass of constraint propagation on the linear constraint), and the narrowed range is
    substituted (``eps_j = m_j + h_j eps_j'``) into every form of the row. Sound: only members
    that violate the constraint are removed."""
    if idx.size == 0:
        return
    sgn = 1.0 if upper else -1.0
    c, G, r = sgn * f.c[idx], sgn * f.G[idx], f.r[idx]
    tt = sgn * t
    S = np.abs(G).sum(axis=1) + r  # (n,)
    slack = (tt - c + S)[:, None] - np.abs(G)  # g_j eps_j <= slack_j
    with np.errstate(divide="ignore", invalid="ignore"):
        b = slack / G
    lo = np.where(G < 0, np.maximum(b, -1.0), -1.0)
    hi = np.where(G > 0, np.minimum(b, 1.0), 1.0)
    ok = (hi >= lo) & np.isfinite(lo) & np.isfinite(hi)
    lo, hi = np.where(ok, lo, -1.0), np.where(ok, hi, 1.0)
    # Outward by an ulp-scale margin (the division's rounding).
    lo, hi = np.maximum(lo - 1e-12, -1.0), np.minimum(hi + 1e-12, 1.0)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    for cont, key in _forms(rows):
        x = _get(cont, key)
        x.c[idx] = x.c[idx] + (x.G[idx] * mid).sum(axis=1)
        x.G[idx] = x.G[idx] * half


def _merge(rows: _Rows, nb: int, max_paths: int) -> _Rows:
    """Keeps at most ``max_paths // 2`` rows per box once a box has more than ``max_paths``: rows
    of the box, ordered by their follower speed's centre, are merged pairwise (every form's
    affine hull; the lead's phase flag "some" where they differ). Sound: the merged row contains
    both."""
    cnt = np.bincount(rows.box, minlength=nb)
    over = np.nonzero(cnt > max_paths)[0]
    if over.size == 0:
        return rows
    keep = np.ones(rows.box.size, dtype=bool)
    for b in over:
        idx = np.nonzero(rows.box == b)[0]
        while idx.size > max(max_paths // 2, 1):
            order = idx[np.argsort(rows.s["v"].c[idx], kind="stable")]
            a, c = order[0:-1:2], order[1::2]
            for cont, key in _forms(rows):
                x = _get(cont, key)
                h = hull(x.take(a), x.take(c))
                x.c[a], x.G[a], x.r[a] = h.c, h.G, h.r
            rows.done[a] = np.where(rows.done[a] == rows.done[c], rows.done[a], 1)
            keep[c] = False
            idx = np.setdiff1d(idx, c)
    return rows.take(np.nonzero(keep)[0])


def _run_batch(m: Model, boxes: Sequence[Box], horizon: float, prop: str, split_ok: np.ndarray,
               max_paths: int, max_symbols: int = 96, merge: bool = True) -> list[tuple[bool, float, str, int]]:
    """Runs the boxes in lockstep; per box (certified, least bound, reason, paths). ``split_ok[i]``:
    box i is stopped at a branch ambiguity its width causes (it will be bisected)."""
    nb = len(boxes)
    thr = float(m.flc["brake_threshold"])
    flc = m.flc
    err = m.bias + m.noise
    _K[0] = K0
    rows = _start(m, boxes)
    least = np.full(nb, np.inf)
    failed = np.zeros(nb, dtype=bool)
    reason = np.array([""] * nb, dtype=object)
    paths = np.ones(nb, dtype=int)

    def bound(r: _Rows) -> np.ndarray:
        val = r.s["gap"].lo() - CONTACT_MARGIN
        if prop == "arch":
            val = np.minimum(val, (r.s["gap"] - r.s["v"].scale(1.4)).lo() - 10.0)
        np.minimum.at(least, r.box, val)
        return val <= 0

    def drop(r: _Rows, bad: np.ndarray, why: str) -> tuple[_Rows, np.ndarray]:
        if bad.any():
            ids = np.unique(r.box[bad])
            fresh = ids[~failed[ids]]
            failed[fresh] = True
            reason[fresh] = why
        keep = ~failed[r.box]
        return (r if keep.all() else r.take(np.nonzero(keep)[0])), keep

    rows, _ = drop(rows, bound(rows), "bound")
    steps = int(math.ceil(horizon / m.dt - 1e-9))
    for k in range(steps):
        if rows.box.size == 0:
            break
        if k % m.frame_steps == 0:
            S = rows.s
            invalid = (S["gap"].lo() - err < 0) | (S["gap"].hi() + err > flc["max_distance"]) | (S["v"].hi() > flc["max_speed"])
            rows, _ = drop(rows, invalid, "invalid")
            if k == 0:
                # The scan at t = 0 finds no lead in the simulator (the bodies enter its query
                # pipeline with the first physics step): no target yet, the law cruises at the
                # set speed, the follower's initial speed (``NoTargetCruise``).
                rows.s["cmd"] = AF(rows.s["v"].c.copy(), rows.s["v"].G.copy(), rows.s["v"].r.copy())
                rows, _ = drop(rows, bound(rows), "bound")
                n_ok = b_ok = None
            elif k == m.frame_steps:
                # The first frame with a lead: "steady", Delta_d = 0, the normal branch.
                n_ok = np.ones(rows.box.size, dtype=bool)
                b_ok = ~n_ok
            else:
                q0, q1 = rows.s["dgap"].lo(), rows.s["dgap"].hi()
                # Delta_d = gap_k - gap_(k-1) + n_k - n_(k-1): the bias cancels.
                n_ok, b_ok = q1 + 2 * m.noise > thr, q0 - 2 * m.noise <= thr
                stop = n_ok & b_ok & (q0 <= thr) & (q1 > thr) & split_ok[rows.box]
                if stop.any():
                    rows, keep = drop(rows, stop, "ambiguous")
                    n_ok, b_ok = n_ok[keep], b_ok[keep]
                amb = n_ok & b_ok
                if amb.any() and merge:
                    rows = _merge(rows, nb, max_paths)
                    q0, q1 = rows.s["dgap"].lo(), rows.s["dgap"].hi()
                    n_ok, b_ok = q1 + 2 * m.noise > thr, q0 - 2 * m.noise <= thr
                    amb = n_ok & b_ok
                if amb.any():
                    # Irreducible (the noise) or no depth left: fork within the budget, else hull.
                    cnt = np.bincount(rows.box, minlength=nb)
                    extra = np.bincount(rows.box[amb], minlength=nb)
                    fork = amb & (cnt + extra <= max_paths)[rows.box]
                    if fork.any():
                        idx = np.nonzero(fork)[0]
                        rows = _Rows.cat(rows, rows.take(idx))
                        n_ok = np.concatenate([n_ok, np.zeros(idx.size, dtype=bool)])
                        b_ok = np.concatenate([b_ok, np.ones(idx.size, dtype=bool)])
                        b_ok[idx] = False  # the originals take the normal branch, the twins braking
                        # Each path refined to the members that take its branch.
                        twins = np.arange(rows.box.size - idx.size, rows.box.size)
                        dg = rows.s["dgap"]
                        _contract(rows, idx, dg, thr - 2 * m.noise, upper=False)
                        _contract(rows, twins, rows.s["dgap"], thr + 2 * m.noise, upper=True)
                        paths[:] = np.maximum(paths, np.bincount(rows.box, minlength=nb))
            if rows.box.size and n_ok is not None and b_ok is not None:
                _lift(rows, max_symbols)
                _frame(m, rows, n_ok, b_ok)
        if rows.box.size == 0:
            break
        disp, displ = _physics(m, rows, k)
        S = rows.s
        S["gap"] = S["gap"] + displ - disp
        S["dgap"] = S["dgap"] + displ - disp
        for name in _STATE:
            S[name] = S[name].widen()
        rows, _ = drop(rows, bound(rows), "bound")
    return [(not failed[i], float(least[i]), str(reason[i]), int(paths[i])) for i in range(nb)]


def certify(m: Model, boxes: Iterable[Box], horizon: float = 15.0, prop: str = "contact", max_depth: int = 6,
            max_paths: int = 16, batch: int = 4096, budget: int = 100_000, split_ambiguous: bool = False,
            progress: Optional[Any] = None) -> list[Outcome]:
    """Refines ``boxes`` by bisection (down to ``max_depth`` bisections of a start box, at most
    ``budget`` box runs in all) and returns the leaves with their verdicts. ``prop``:
    ``"contact"`` (gap above :data:`CONTACT_MARGIN`) or ``"arch"`` (also
    ``gap >= 10 + 1.4 v_follower``)."""
    if prop not in ("contact", "arch"):
        raise ValueError(f"reach: prop must be \"contact\" or \"arch\", got {prop!r}")
    todo = [(b, 0) for b in boxes]
    out: list[Outcome] = []
    runs = 0
    while todo:
        chunk, todo = todo[:batch], todo[batch:]
        runs += len(chunk)
        res = _run_batch(m, [b for b, _ in chunk], horizon, prop, np.array([split_ambiguous and d < max_depth for _, d in chunk]), max_paths)
        for (b, d), (ok, least, why, npaths) in zip(chunk, res):
            if ok:
                out.append(Outcome(b, d, True, least, "", npaths))
            elif d < max_depth and runs + len(todo) + 2 <= budget:
                todo.extend((h, d + 1) for h in b.split())
            else:
                out.append(Outcome(b, d, False, least, why or "bound", npaths))
        if progress is not None:
            progress(len(out), len(todo))
    return out


# ---------------------------------------------------------------------------------------------
# The certificates of the documentation: the (speed, gap) map, the ARCH-COMP ACC initial set,
# and the simulator's cross-check.

#: The range-error model of the certificates: a constant bias within +-1 cm and a per-frame
#: error within +-0.1 mm. The simulator's noise-free LiDAR (``lidar.range_noise_std = 0``, ray
#: casts in f32) stays within 1e-5 m of the true gap (measured by :func:`crosscheck`); its
#: default Gaussian noise (0.02 m) is *not* covered.
BIAS = 0.01
NOISE = 1e-4
#: The map: start speeds (m/s; the lead starts at the follower's speed), gaps (m), the start
#: box around each node (speed, gap widths), the lead's deceleration interval, the horizon (s).
MAP_SPEEDS = tuple(float(v) for v in range(8, 33, 4))
MAP_GAPS = tuple(float(g) for g in range(8, 65, 8))
MAP_CELL = (0.05, 0.25)
MAP_DECEL = (5.95, 6.0)
MAP_HORIZON = 20.0
#: Bisections of a map's start box at most (each box is split along its widest dimension).
MAP_DEPTH = 6
#: The ARCH-COMP ACC benchmark's initial set (``flc.arch_acc``) and horizon.
ARCH_HORIZON = 5.0


def start_scenario(v: float, gap: float, decel: float, vl: Optional[float] = None, horizon: float = MAP_HORIZON,
                   controller: str = "flc", rate_hz: float = 20.0, noise_std: float = 0.0, seed: int = 1) -> Any:
    """The simulator's scenario of one start: both vehicles at speed (the lead at ``vl``, default
    ``v``) ``gap`` m apart, the lead braking at ``decel`` to a stop from t = 0; the realistic
    vehicle; the noise-free LiDAR unless ``noise_std``."""
    from ._scenario import Scenario

    return Scenario.paper(
        90.0, controller, "realistic", seed=seed,
        **{
            "name": "reach-start",
            "duration": float(horizon),
            "lidar.rate_hz": float(rate_hz),
            "lidar.range_noise_std": float(noise_std),
            "lead.initial_speed": float(v if vl is None else vl),
            "follower.initial_speed": float(v),
            "follower.initial_gap": float(gap),
            "lead.phases": [{"kind": "brake", "decel": float(decel), "speed": 0.0}],
        },
    )


def paper_model(bias: float = BIAS, noise: float = NOISE, rate_hz: float = 20.0) -> Model:
    """The paper FLC's closed loop as :func:`start_scenario` configures it."""
    return Model.from_scenario(start_scenario(20.0, 30.0, 6.0, rate_hz=rate_hz), bias=bias, noise=noise)


def _leaves(out: Sequence[Outcome]) -> list[dict[str, Any]]:
    return [{**o.box.to_json(), "certified": o.certified, "least": o.least, "reason": o.reason, "depth": o.depth,
             "paths": o.paths} for o in out]


def certified_map(m: Model, speeds: Sequence[float] = MAP_SPEEDS, gaps: Sequence[float] = MAP_GAPS,
                  cell: tuple[float, float] = MAP_CELL, decel: tuple[float, float] = MAP_DECEL,
                  horizon: float = MAP_HORIZON, max_depth: int = MAP_DEPTH) -> dict[str, Any]:
    """Per node (speed, gap): the start box ``[v, v + cell[0]] x [gap, gap + cell[1]] x decel``
    refined to ``max_depth`` bisections (certified when every leaf is), and the point start
    ``(v, gap, decel[1])`` (certified for every range error of the model)."""
    nodes = [(v, g) for v in speeds for g in gaps]
    boxes = [Box(v=(v, v + cell[0]), gap=(g, g + cell[1]), decel=decel) for v, g in nodes]
    out = certify(m, boxes, horizon=horizon, max_depth=max_depth, batch=512)
    points = certify(m, [Box(v=(v, v), gap=(g, g), decel=(decel[1], decel[1])) for v, g in nodes], horizon=horizon,
                     max_depth=0, batch=512)
    rows = []
    for (v, g), b, p in zip(nodes, boxes, points):
        leaves = [o for o in out if b.v[0] <= o.box.v[0] and o.box.v[1] <= b.v[1] and b.gap[0] <= o.box.gap[0] and o.box.gap[1] <= b.gap[1]]
        # The certified leaves only (each a certificate of its own; the cross-check samples them).
        rows.append({"speed": v, "gap": g, "box": b.to_json(), "box_certified": all(o.certified for o in leaves),
                     "box_least": min(o.least for o in leaves), "leaves_refined": len(leaves),
                     "leaves": _leaves([o for o in leaves if o.certified]),
                     "point_certified": p.certified, "point_least": p.least})
    return {"model": _model_json(m), "horizon": horizon, "cell": list(cell), "decel": list(decel), "max_depth": max_depth,
            "nodes": rows}


def arch_certificate(m: Model, max_depth: int = 4) -> dict[str, Any]:
    """The ARCH-COMP ACC initial set (``flc.arch_acc``: gap 79-100 m, lead 32-32.2 m/s, ego
    30-30.2 m/s, lead -2 m/s², 5 s) against ``D_rel >= 10 + 1.4 v_ego`` (and no contact)."""
    from . import arch_acc

    box = Box(v=arch_acc.EGO_SPEED, vl=arch_acc.LEAD_SPEED, gap=arch_acc.GAP, decel=(2.0, 2.0))
    out = certify(m, [box], horizon=ARCH_HORIZON, prop="arch", max_depth=max_depth)
    return {"model": _model_json(m), "horizon": ARCH_HORIZON, "box": box.to_json(), "certified": all(o.certified for o in out),
            "least": min(o.least for o in out), "leaves": _leaves(out)}


def _model_json(m: Model) -> dict[str, Any]:
    return {"bias": m.bias, "noise": m.noise, "dt": m.dt, "frame_steps": m.frame_steps, "contact_margin": CONTACT_MARGIN,
            "widen": list(WIDEN)}


def samples(box: Mapping[str, Any], n: int, rng: np.random.Generator) -> list[tuple[float, float, float, float]]:
    """The box's corners and ``n`` uniform points in it: (v, vl, gap, decel)."""
    dims = [box["v"], box["vl"], box["gap"], box["decel"]]

    def four(xs: Sequence[float]) -> tuple[float, float, float, float]:
        return (float(xs[0]), float(xs[1]), float(xs[2]), float(xs[3]))

    pts = [four([d[i] for d, i in zip(dims, idx)]) for idx in np.ndindex(2, 2, 2, 2)]
    pts += [four([rng.uniform(lo, hi) for lo, hi in dims]) for _ in range(n)]
    return list(dict.fromkeys(pts))


def crosscheck(boxes: Sequence[Mapping[str, Any]], n: int = 4, seed: int = 1, horizon: float = MAP_HORIZON,
               rate_hz: float = 20.0, same_speed: bool = True, prop: str = "contact") -> dict[str, Any]:
    """Simulates starts inside every box (its corners and ``n`` random points) with the simulator
    (``flc.sweep``, noise-free LiDAR) and reports the collisions (there must be none), the least
    simulated gap, the least margin of the checked quantity over the box's certified lower bound
    ``least`` (``prop``: the gap above the contact margin, or also the ARCH property; a negative
    margin is a soundness bug) and
    the largest range error the detector made (``detected_distance`` against the gap at the
    frame), which the error model must cover."""
    from ._run import sweep

    rng = np.random.default_rng(seed)
    pts: list[tuple[int, tuple[float, float, float, float]]] = []
    for i, b in enumerate(boxes):
        for p in samples(b, n, rng):
            if same_speed:
                p = (p[0], p[0], p[2], p[3])
            pts.append((i, p))
    scs = [start_scenario(v, g, a, vl=vl, horizon=horizon, rate_hz=rate_hz) for _, (v, vl, g, a) in pts]
    runs = sweep(scs)
    collisions, least_gap, margin, err, lateral, missed = [], math.inf, math.inf, 0.0, 0.0, 0
    for (i, p), r in zip(pts, runs):
        if r.metrics["collision"]:
            collisions.append({"box": i, "start": p})
        gap = float(r.metrics["min_gap"])
        least_gap = min(least_gap, gap)
        s = r.series
        det, g = np.asarray(s["detected_distance"]), np.asarray(s["gap"])
        # The checked quantity as the reachability bounds it (its lower bound is "least").
        q = gap - CONTACT_MARGIN
        if prop == "arch":
            q = min(q, float(np.min(g - 10.0 - 1.4 * np.asarray(s["follower_speed"]))))
        margin = min(margin, q - boxes[i]["least"])
        # Row k is the state after physics step k; a frame at the start of step k (k a multiple
        # of the frame's steps) saw the gap of row k - 1: compare only those rows.
        fs = int(round(1.0 / (rate_hz * float(scs[0].to_dict()["physics_dt"]))))
        ks = np.arange(fs, det.size, fs)
        ok = np.isfinite(det[ks])
        # The model: no lead at the scan of t = 0 (rows 0 .. fs-1), one at every later frame.
        missed += int(np.sum(~ok)) + int(np.sum(np.isfinite(det[:fs])))
        e = det[ks][ok] - g[ks - 1][ok]
        err = max(err, float(np.max(np.abs(e))) if e.size else 0.0)
        lateral = max(lateral, float(np.max(np.abs(np.asarray(s["lateral_offset"])))))
    return {"runs": len(runs), "collisions": collisions, "least_gap": least_gap, "least_margin": margin, "max_range_error": err,
            "max_lateral_offset": lateral, "frames_not_as_modelled": missed}


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m flc.reach {map,arch,check} --out FILE``: the certified map, the ARCH-COMP
    certificate, or the simulator's cross-check of a map file."""
    import argparse
    import json

    ap = argparse.ArgumentParser(prog="python -m flc.reach", description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("what", choices=("map", "arch", "check"))
    ap.add_argument("--out", required=True, help="the JSON file to write (check: the map file to update)")
    ap.add_argument("--samples", type=int, default=4)
    a = ap.parse_args(argv)
    if a.what == "map":
        data = certified_map(paper_model())
    elif a.what == "arch":
        data = arch_certificate(paper_model(rate_hz=10.0))
    else:
        with open(a.out) as f:
            data = json.load(f)
        data.pop("crosscheck", None)
        if "nodes" in data:
            # The certified boxes' leaves and the certified single starts (zero-width boxes).
            boxes = [dict(l) for nd in data["nodes"] for l in nd["leaves"] if l["certified"]]
            top = data["decel"][1]
            boxes += [{"v": [nd["speed"]] * 2, "vl": [nd["speed"]] * 2, "gap": [nd["gap"]] * 2, "decel": [top, top],
                       "least": nd["point_least"]} for nd in data["nodes"] if nd["point_certified"]]
            data["crosscheck"] = crosscheck(boxes, n=a.samples, horizon=data["horizon"])
        else:
            boxes = [dict(l) for l in data["leaves"] if l["certified"]]
            data["crosscheck"] = crosscheck(boxes, n=a.samples, horizon=data["horizon"], rate_hz=10.0, same_speed=False,
                                            prop="arch")
    with open(a.out, "w") as f:
        json.dump(data, f, indent=1, sort_keys=True)
        f.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
