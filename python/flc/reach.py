"""Sound reachability of the paper FLC's discrete-time closed loop: where no contact is possible
(``docs/safety-evidence.md``, section 4).

What it computes. For a *box* of starts (follower speed, lead speed, bumper-to-bumper gap, lead
deceleration, each an interval) it steps the closed loop of the simulator in interval arithmetic,
all boxes of a batch at once (NumPy, one row per box or branch path), and decides:

* **certified**: for every start in the box, every lead deceleration in the box and every range
  error allowed (below), the gap stays above :data:`CONTACT_MARGIN` at every physics step up to
  the horizon (and, with ``property="arch"``, ``gap >= 10 + 1.4 v_follower`` at every step);
* **not certified**: the lower bound reached the limit. That does *not* mean unsafe: interval
  arithmetic over-approximates.

Refinement instead of hulls. Interval hulls lose the correlation between the branch of Eq. (5)
(``delta_d <= -0.3`` m per frame) and the state. Here a frame whose ``delta_d`` interval straddles
the threshold because of the box's width (not the range noise) stops that box, and the box is
bisected (along its widest dimension relative to :data:`SPLIT_SCALE`) and run again, down to
``max_depth`` bisections. A box that fails its gap bound is bisected too. Where the straddle is
irreducible (the per-frame noise alone can move ``delta_d`` across the threshold, or the depth
budget is spent) the path *forks*: one row per branch, each with the whole state (sound: every
member of the state takes one of the two branches); beyond ``max_paths`` rows per box the two
branches' outputs are hulled (also sound).

The model, step for step as the simulator (``crates/flc-sim/src/sim/mod.rs``: sense, then act):

* the lead (``lead::LeadDriver::step`` with one ``brake`` phase to 0 from t = 0): its demand is
  ``-decel + resistance(v)`` until its speed is at most 0.01 m/s, then the hold loop
  ``clamp(-3 v, -3, 2) + resistance(v)``; through its own vehicle model (as the follower's);
* a LiDAR frame every ``round(1 / (rate_hz physics_dt))`` physics steps from t = 0, on the state
  at the start of the step; the paper FLC (``flc_core::flc::FallbackController::step``, Eqs.
  (2)-(5), first frame ``steady``) sets the held speed command;
* the follower: the PI speed controller with anti-windup, clamps and the stop hold
  (``vehicle::SpeedController::step``), the actuator (dead time as a FIFO of physics steps starting
  idle, exact first-order lag, traction / power / brake limits), drag and rolling resistance, speed
  floored at 0 (``vehicle::Vehicle::step``); the displacement ``(v + v_new) / 2 dt``.

Assumptions (what a certificate does *not* cover):

* **range error**: the distance the law gets at frame k is ``gap_k + b + n_k`` with a bias
  ``|b| <= bias`` constant over the run (it cancels in ``delta_d``) and a per-frame error
  ``|n_k| <= noise``; the lead is detected at every frame (no dropout, ghost, latency or jitter).
  The simulator's Gaussian range noise is unbounded: a run is covered while its detector's errors
  stay within these bounds (:func:`check_sample` measures them on the cross-check's runs);
* straight driving: the follower's displacement is its path length (the simulator steers by pure
  pursuit of the detected lead; the cross-check measures the deviation);
* the lead brakes with a constant deceleration in the box's interval from t = 0 (the simulator's
  brake phase), not an arbitrary profile;
* no controller other than the paper FLC; its own state at the start: no previous distance; the
  follower's actuator idle, integrator empty;
* rounding: every state bound is widened outward by :data:`WIDEN` (relative and absolute) at every
  physics step. Each bound is a composition of at most a few dozen floating-point operations on
  magnitudes below 10^3 (rounding error below 1e-11) and the law's cosine is evaluated at its
  interval's ends (it is monotone there, ``_law``); the simulator's own rounding of the positions
  (below 1e-9 m over 10^4 steps) is inside the widening of the gap. Contact in the simulator is
  rapier's (f32 geometry): :data:`CONTACT_MARGIN` covers it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
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
        if lid["latency_frames"] != 0 or lid["jitter"] != 0 or lid["scan_drop_prob"] != 0 or lid["dropout_prob"] != 0:
            raise ValueError("reach: the LiDAR must have no latency, jitter or dropout (not modelled)")
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
# Interval helpers on arrays (lo, hi)


def _widen(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, a = WIDEN
    return lo - (np.abs(lo) * r + a), hi + (np.abs(hi) * r + a)


def _resistance(vm: VehicleModel, v: np.ndarray) -> np.ndarray:
    """``VehicleParams::resistance``: 0 at v <= 0, else drag v² + rolling (nondecreasing)."""
    return np.where(v > 0, vm.drag * v * v + vm.rolling, 0.0)


def _law_ends(flc: Mapping[str, Any], x: np.ndarray, shift: float) -> np.ndarray:
    """Eq. (5) ``x (shift - cos(pi x / bound_t))`` with the negative multiplier, at points ``x``.
    Nondecreasing on [-bound_t, bound_t] for shift >= 1 (derivative ``shift - cos(u) + u sin(u)
    >= 0`` for ``|u| <= pi``), so an interval's image is its ends' images."""
    a = x * (shift - np.cos(np.pi * x / flc["bound_t"]))
    return np.where(a < 0, a * flc["negative_multiplier"], a)


def _law(flc: Mapping[str, Any], lo: np.ndarray, hi: np.ndarray, braking: bool) -> tuple[np.ndarray, np.ndarray]:
    """``a`` of Eq. (5) for ``dist_s`` in [lo, hi] (already clipped) on one branch, padded for the
    rounding of the cosine and the product."""
    if braking:
        o = float(flc["override_dist"])
        mode = flc["dist_override"]
        if mode == "min":
            lo, hi = np.minimum(lo, o), np.minimum(hi, o)
        elif mode == "replace":
            lo, hi = np.full_like(lo, o), np.full_like(hi, o)
        shift = float(flc["shift_brake"])
    else:
        shift = float(flc["shift_normal"])
    alo, ahi = _law_ends(flc, lo, shift), _law_ends(flc, hi, shift)
    pad = 1e-13 * (1.0 + np.abs(alo)), 1e-13 * (1.0 + np.abs(ahi))
    return alo - pad[0], ahi + pad[1]


def _desired(flc: Mapping[str, Any], v: np.ndarray) -> np.ndarray:
    """Eqs. (2)-(4): ``D_d + F_shift = T_G v + B_gap + max(0, v) min(cap, gain v / C)``,
    nondecreasing in v >= 0."""
    scale = np.minimum(flc["scale_gain"] * v / flc["c"], flc["scale_cap"])
    return flc["time_gap"] * v + flc["base_gap"] + np.maximum(v, 0.0) * scale


# ---------------------------------------------------------------------------------------------
# The batch stepper


@dataclass
class Outcome:
    """One box's verdict."""

    box: Box
    depth: int
    certified: bool
    #: The least lower bound of the checked quantity over its paths (gap, or the ARCH margin), m.
    least: float
    #: Why not certified: "" (certified), "bound", "ambiguous" (split wanted), "invalid" (an input
    #: out of the law's valid range), "paths".
    reason: str = ""
    paths: int = 1


_STATE = ("v", "vl", "gap", "act", "actl", "integ", "cmd", "e", "dgap")


@dataclass
class _Rows:
    box: np.ndarray  # index into the batch's boxes
    decel: tuple[np.ndarray, np.ndarray]
    s: dict[str, list[np.ndarray]]  # name -> [lo, hi]
    ring: list[np.ndarray]  # follower FIFO lo, hi (rows x n)
    ringl: list[np.ndarray]
    done: np.ndarray  # lead's brake phase finished: 0 no, 1 some members, 2 all

    def take(self, idx: np.ndarray) -> "_Rows":
        return _Rows(
            box=self.box[idx],
            decel=(self.decel[0][idx], self.decel[1][idx]),
            s={k: [v[0][idx], v[1][idx]] for k, v in self.s.items()},
            ring=[self.ring[0][idx], self.ring[1][idx]],
            ringl=[self.ringl[0][idx], self.ringl[1][idx]],
            done=self.done[idx],
        )

    @staticmethod
    def cat(a: "_Rows", b: "_Rows") -> "_Rows":
        c = np.concatenate
        return _Rows(
            box=c([a.box, b.box]),
            decel=(c([a.decel[0], b.decel[0]]), c([a.decel[1], b.decel[1]])),
            s={k: [c([a.s[k][0], b.s[k][0]]), c([a.s[k][1], b.s[k][1]])] for k in a.s},
            ring=[c([a.ring[0], b.ring[0]]), c([a.ring[1], b.ring[1]])],
            ringl=[c([a.ringl[0], b.ringl[0]]), c([a.ringl[1], b.ringl[1]])],
            done=c([a.done, b.done]),
        )


def _vehicle_step(vm: VehicleModel, ring: list[np.ndarray], k: int, demand: tuple[np.ndarray, np.ndarray],
                  act: list[np.ndarray], v: list[np.ndarray], dt: float) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``Vehicle::step`` on intervals. Returns (actuator, v_new, step = v_new - v, displacement)."""
    n = vm.dead_steps
    if n > 0:
        j = k % n
        dlo, dhi = ring[0][:, j].copy(), ring[1][:, j].copy()
        ring[0][:, j], ring[1][:, j] = demand
    else:
        dlo, dhi = demand
    a = vm.alpha
    alo = (1.0 - a) * act[0] + a * dlo
    ahi = (1.0 - a) * act[1] + a * dhi
    vlo, vhi = v

    def limit(x: np.ndarray, vv: np.ndarray) -> np.ndarray:
        cap = np.minimum(vm.max_accel, vm.max_power / (vm.mass * np.maximum(vv, 1.0)))
        return np.where(x >= 0, np.minimum(x, cap), np.maximum(x, -vm.max_brake))

    aclo, achi = limit(alo, vhi), limit(ahi, vlo)  # nondecreasing in x, nonincreasing in v
    dvlo = (aclo - _resistance(vm, vhi)) * dt
    dvhi = (achi - _resistance(vm, vlo)) * dt
    # v_new = max(f(v) + a dt, 0) with f(v) = v - resistance(v) dt: f is increasing on v > 0
    # (1 - 2 drag v dt > 0), f(0) = 0 and f(0+) = -rolling dt; its exact range, not v and the
    # resistance taken apart (which lets a standing vehicle's upper speed creep).
    f_lo = np.where(vlo > 0, vlo - _resistance(vm, vlo) * dt, np.where(vhi > 0, -vm.rolling * dt, 0.0))
    f_hi = np.where(vhi > 0, np.maximum(vhi - _resistance(vm, vhi) * dt, np.where(vlo <= 0, 0.0, -np.inf)), 0.0)
    vnlo, vnhi = np.maximum(f_lo + aclo * dt, 0.0), np.maximum(f_hi + achi * dt, 0.0)
    stlo, sthi = np.maximum(dvlo, -vhi), np.maximum(dvhi, -vlo)
    dlo_, dhi_ = 0.5 * (vlo + vnlo) * dt, 0.5 * (vhi + vnhi) * dt
    return (alo, ahi), (vnlo, vnhi), (stlo, sthi), (dlo_, dhi_)


def _frame(m: Model, rows: _Rows, n_ok: np.ndarray, b_ok: np.ndarray) -> None:
    """One frame of the paper FLC (``FallbackController::step``) on every row: the held speed
    command and the speed controller's error ``e = cmd - v``. ``n_ok`` / ``b_ok``: the rows'
    members may take the normal / braking branch of Eq. (5) (both: the hull of the two)."""
    flc, S = m.flc, rows.s
    err = m.bias + m.noise
    v0, v1 = S["v"]
    d0, d1 = S["gap"][0] - err, S["gap"][1] + err
    # Eqs. (2)-(4): dist_s = LF_dist - D_d - F_shift, D_d + F_shift nondecreasing in v.
    b = float(flc["bound_t"])
    ds0 = np.clip(d0 - _desired(flc, v1), -b, b)
    ds1 = np.clip(d1 - _desired(flc, v0), -b, b)
    an0, an1 = _law(flc, ds0, ds1, braking=False)
    ab0, ab1 = _law(flc, ds0, ds1, braking=True)
    both = n_ok & b_ok
    a0 = np.where(both, np.minimum(an0, ab0), np.where(b_ok, ab0, an0))
    a1 = np.where(both, np.maximum(an1, ab1), np.where(b_ok, ab1, an1))
    g = float(flc["command_gain"])
    ga0, ga1 = g * a0, g * a1
    vmax = float(flc["max_speed"])
    cmd0, cmd1 = np.clip(v0 + ga0, 0.0, vmax), np.clip(v1 + ga1, 0.0, vmax)
    # e = clamp(v + g a, 0, vmax) - v = max(g a, -v) below vmax: v taken once.
    below = v1 + ga1 < vmax
    e0 = np.where(below, np.maximum(ga0, -v1), cmd0 - v1)
    e1 = np.where(below, np.maximum(ga1, -v0), cmd1 - v0)
    S["cmd"], S["e"] = [cmd0, cmd1], [e0, e1]
    S["dgap"] = [np.zeros_like(v0), np.zeros_like(v0)]


def _physics(m: Model, rows: _Rows, k: int, lead_cmd: tuple[np.ndarray, np.ndarray]) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """One physics step of both vehicles; returns the follower's and the lead's displacement."""
    S = rows.s
    e0, e1 = S["e"]
    i0, i1 = S["integ"]
    c0, c1 = S["cmd"]
    v0, v1 = S["v"]
    L, kp, kidt = m.integral_limit, m.kp, m.ki * m.dt
    ma, md = m.sc_max_accel, m.sc_max_decel
    # SpeedController::step: candidate, anti-windup (raw is nondecreasing in e and the integral).
    k0, k1 = np.clip(i0 + kidt * e0, -L, L), np.clip(i1 + kidt * e1, -L, L)
    raw0, raw1 = kp * e0 + k0, kp * e1 + k1
    every, none = (raw1 < ma) & (raw0 > -md), (raw0 >= ma) | (raw1 <= -md)
    n0 = np.where(every, k0, np.where(none, i0, np.minimum(k0, i0)))
    n1 = np.where(every, k1, np.where(none, i1, np.maximum(k1, i1)))
    dem0, dem1 = np.clip(kp * e0 + n0, -md, ma), np.clip(kp * e1 + n1, -md, ma)
    # A stop request at standstill holds the brake and empties the integrator.
    maybe, sure = (c0 <= 0) & (v0 < 0.1), (c1 <= 0) & (v1 < 0.1)
    hold = -min(md, 2.0)
    dem0 = np.where(sure, hold, np.where(maybe, np.minimum(dem0, hold), dem0))
    dem1 = np.where(sure, hold, np.where(maybe, np.maximum(dem1, hold), dem1))
    n0 = np.where(sure, 0.0, np.where(maybe, np.minimum(n0, 0.0), n0))
    n1 = np.where(sure, 0.0, np.where(maybe, np.maximum(n1, 0.0), n1))
    S["integ"] = [n0, n1]
    act, vn, st, disp = _vehicle_step(m.follower, rows.ring, k, (dem0, dem1), S["act"], S["v"], m.dt)
    S["act"], S["v"] = list(act), list(vn)
    # e = cmd - v_new: the held command minus the new speed, two over-approximations intersected.
    S["e"] = [np.maximum(e0 - st[1], c0 - vn[1]), np.minimum(e1 - st[0], c1 - vn[0])]
    actl, vln, _, displ = _vehicle_step(m.lead, rows.ringl, k, lead_cmd, S["actl"], S["vl"], m.dt)
    S["actl"], S["vl"] = list(actl), list(vln)
    return disp, displ


def _lead_command(m: Model, rows: _Rows) -> tuple[np.ndarray, np.ndarray]:
    """``LeadDriver::step`` for one brake phase to 0: ``-decel + resistance(v)`` until the speed
    is at most 0.01 m/s, then the hold loop ``clamp(-3 v, -3, 2) + resistance(v)``."""
    vl0, vl1 = rows.s["vl"]
    d = rows.done
    rows.done = np.where((d == 2) | (vl1 <= 0.01), 2, np.where((d == 1) | (vl0 <= 0.01), 1, 0)).astype(np.int8)
    d = rows.done
    r0, r1 = _resistance(m.lead, vl0), _resistance(m.lead, vl1)
    b0, b1 = -rows.decel[1] + r0, -rows.decel[0] + r1
    # The hold loop h(v) = clamp(-3 v, -3, 2) + resistance(v): h(0) = 0, h(0+) = rolling, then
    # decreasing up to v = 1 and increasing beyond: its exact range over [vl0, vl1].
    def h(v: np.ndarray) -> np.ndarray:
        return np.clip(-3.0 * v, -3.0, 2.0) + _resistance(m.lead, v)

    h0 = np.minimum(np.minimum(h(vl0), h(vl1)), h(np.clip(1.0, vl0, vl1)))
    h1 = np.maximum(np.maximum(h(vl0), h(vl1)), np.where((vl0 <= 0) & (vl1 > 0), m.lead.rolling, -np.inf))
    lo = np.where(d == 0, b0, np.where(d == 2, h0, np.minimum(b0, h0)))
    hi = np.where(d == 0, b1, np.where(d == 2, h1, np.maximum(b1, h1)))
    return lo, hi


def _run_batch(m: Model, boxes: Sequence[Box], horizon: float, prop: str, split_ok: np.ndarray,
               max_paths: int) -> list[tuple[bool, float, str, int]]:
    """Runs the boxes in lockstep; per box (certified, least bound, reason, paths). ``split_ok[i]``:
    box i is stopped at an ambiguity its width causes (it will be bisected)."""
    nb = len(boxes)
    thr = float(m.flc["brake_threshold"])

    def col(f: Any) -> np.ndarray:
        return np.array([f(b) for b in boxes], dtype=float)

    z = np.zeros(nb)
    nf, nl = max(m.follower.dead_steps, 1), max(m.lead.dead_steps, 1)
    rows = _Rows(
        box=np.arange(nb),
        decel=(col(lambda b: b.decel[0]), col(lambda b: b.decel[1])),
        s={
            "v": [col(lambda b: b.v[0]), col(lambda b: b.v[1])],
            "vl": [col(lambda b: b.lead_speed()[0]), col(lambda b: b.lead_speed()[1])],
            "gap": [col(lambda b: b.gap[0]), col(lambda b: b.gap[1])],
            **{k: [z.copy(), z.copy()] for k in ("act", "actl", "integ", "cmd", "e", "dgap")},
        },
        ring=[np.zeros((nb, nf)), np.zeros((nb, nf))],
        ringl=[np.zeros((nb, nl)), np.zeros((nb, nl))],
        done=np.zeros(nb, dtype=np.int8),
    )
    least = np.full(nb, np.inf)
    failed = np.zeros(nb, dtype=bool)
    reason = np.array([""] * nb, dtype=object)
    paths = np.ones(nb, dtype=int)
    flc = m.flc
    err = m.bias + m.noise

    def bound(r: _Rows) -> np.ndarray:
        g = r.s["gap"][0]
        val = g - CONTACT_MARGIN
        if prop == "arch":
            val = np.minimum(val, g - 10.0 - 1.4 * r.s["v"][1])
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
            invalid = (S["gap"][0] - err < 0) | (S["gap"][1] + err > flc["max_distance"]) | (S["v"][1] > flc["max_speed"])
            rows, _ = drop(rows, invalid, "invalid")
            if k == 0:
                # First frame "steady": Delta_d = 0, the normal branch.
                n_ok = np.ones(rows.box.size, dtype=bool)
                b_ok = ~n_ok
            else:
                q0, q1 = rows.s["dgap"]
                # Delta_d = gap_k - gap_(k-1) + n_k - n_(k-1): the bias cancels.
                n_ok, b_ok = q1 + 2 * m.noise > thr, q0 - 2 * m.noise <= thr
                amb = n_ok & b_ok
                stop = amb & (q0 <= thr) & (q1 > thr) & split_ok[rows.box]
                if stop.any():
                    rows, keep = drop(rows, stop, "ambiguous")
                    n_ok, b_ok = n_ok[keep], b_ok[keep]
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
                        paths[:] = np.maximum(paths, np.bincount(rows.box, minlength=nb))
            if rows.box.size:
                _frame(m, rows, n_ok, b_ok)
        if rows.box.size == 0:
            break
        lead_cmd = _lead_command(m, rows)
        (f0, f1), (l0, l1) = _physics(m, rows, k, lead_cmd)
        S = rows.s
        S["gap"] = [S["gap"][0] + l0 - f1, S["gap"][1] + l1 - f0]
        S["dgap"] = [S["dgap"][0] + l0 - f1, S["dgap"][1] + l1 - f0]
        for name in S:
            S[name] = list(_widen(*S[name]))
        rows, _ = drop(rows, bound(rows), "bound")
    return [(not failed[i], float(least[i]), str(reason[i]), int(paths[i])) for i in range(nb)]


def certify(m: Model, boxes: Iterable[Box], horizon: float = 15.0, prop: str = "contact", max_depth: int = 6,
            max_paths: int = 16, batch: int = 4096, budget: int = 100_000,
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
        res = _run_batch(m, [b for b, _ in chunk], horizon, prop, np.array([d < max_depth for _, d in chunk]), max_paths)
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
