"""Work in progress, NOT a result: an interval over-approximation of the paper FLC's closed loop
(``docs/safety-evidence.md``, "Verified envelope: not achieved").

STATUS. It certifies a start box only when the box is a point and ``range_error = 0`` (then it is
one deterministic trajectory of the idealised loop: 50 km/h, gap 25 m, lead -6 m/s² gives a
least gap of 4.35 m where the simulator gives 4.78 m). Any box of positive width, or any range
error, fails within about a second of simulated time: plain intervals lose the correlation
between the branch of Eq. (5) (``delta_d <= -0.3 m`` per frame) and the state, so after the
first frame where ``delta_d`` straddles the threshold the "never braking" path carries every
member of the state while the lead brakes. Forking per branch (below) is sound but does not
refine the state to the members that take the branch. A per-frame independent range error is
also too pessimistic (the errors of ``delta_d`` telescope). What it needs: guards that refine
the state (zonotopes / Taylor models with constraint propagation), and an error model with
memory. Run: ``python tools/flc_interval_reach.py`` (prints the cases above).

Interval arithmetic with outward rounding (every operation widened by one ulp each side, so the
computed interval contains the exact real result) over the discrete-time closed loop, stepped
exactly as the simulator steps it:

* the law: the paper FLC (``flc_core::flc::Flc::step``, Eqs. (2)-(5)) at every LiDAR frame, with
  its parameters (``[flc]``), the first frame "steady" (``delta_d = 0``), both branches of Eq. (5)
  where ``delta_d`` straddles the threshold (their hull);
* the low-level speed controller (PI with anti-windup and clamps, ``flc_sim::SpeedController``)
  and the actuator (dead time as a FIFO of physics steps, first-order lag, traction / power /
  brake limits, drag and rolling resistance, speed floored at 0: ``flc_sim::Vehicle::step``) at
  every physics step;
* the lead: a constant deceleration ``a`` in ``[a_lo, a_hi]`` from t = 0 to a stop, its
  displacement per step integrated exactly.

**Assumptions** (what the certificate does *not* cover):

* the distance the law gets at a frame is the true bumper-to-bumper gap at that physics step
  within ``range_error`` (default 0.3 m: LiDAR noise, the detector's cells, the order of sensing
  and stepping within a step); every frame has a detection (no dropout, no ghost, no latency);
* frames every ``round(1 / (rate_hz * physics_dt))`` physics steps from t = 0;
* the follower drives straight along the lead's line (no steering, no lateral offset);
* the lead's deceleration is constant from t = 0 (not an arbitrary profile) and without the
  lead's own actuator response (the simulated lead ramps into its braking through its dead time
  and lag, so it stops later than this lead);
* the start: both vehicles at the same speed, the follower's actuator idle, its integrator empty,
  its speed command its speed (as the simulator starts a run).

**Claim** of a certified box (speed interval, gap interval, deceleration interval): for every
start in it and every lead and range error as above, the gap stays positive until the follower
stands still (the speed's upper bound reaches 0), within ``horizon`` s. Nothing is claimed after
that stop. A box whose gap's lower bound reaches 0 is split in two along its widest dimension (up
to ``depth`` times) and the halves tried again; what is left is "not certified" (which does not
mean unsafe: interval arithmetic over-approximates).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Optional

from flc import Scenario

_G = 9.81  # flc_sim::units::G


def _dn(x: float) -> float:
    return math.nextafter(x, -math.inf)


def _up(x: float) -> float:
    return math.nextafter(x, math.inf)


@dataclass(frozen=True)
class I:
    """A closed interval [lo, hi] of reals; operations round outward."""

    lo: float
    hi: float

    @staticmethod
    def pt(x: float) -> "I":
        return I(x, x)

    def __add__(self, o: Any) -> "I":
        o = o if isinstance(o, I) else I.pt(float(o))
        return I(_dn(self.lo + o.lo), _up(self.hi + o.hi))

    __radd__ = __add__

    def __neg__(self) -> "I":
        return I(-self.hi, -self.lo)

    def __sub__(self, o: Any) -> "I":
        o = o if isinstance(o, I) else I.pt(float(o))
        return self + (-o)

    def __rsub__(self, o: Any) -> "I":
        return (-self) + o

    def __mul__(self, o: Any) -> "I":
        o = o if isinstance(o, I) else I.pt(float(o))
        ps = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi)
        return I(_dn(min(ps)), _up(max(ps)))

    __rmul__ = __mul__

    def clamp(self, lo: float, hi: float) -> "I":
        return I(min(max(self.lo, lo), hi), min(max(self.hi, lo), hi))

    def max0(self) -> "I":
        return I(max(self.lo, 0.0), max(self.hi, 0.0))

    def hull(self, o: "I") -> "I":
        return I(min(self.lo, o.lo), max(self.hi, o.hi))

    def minimum(self, o: "I") -> "I":
        return I(min(self.lo, o.lo), min(self.hi, o.hi))

    def maximum(self, o: "I") -> "I":
        return I(max(self.lo, o.lo), max(self.hi, o.hi))


def _pad(x: float, rel: float = 4e-16) -> tuple[float, float]:
    # libm's cos / exp are within 1 ulp; a few ulps of margin each side.
    e = abs(x) * rel + 1e-300
    return _dn(x - e), _up(x + e)


@dataclass
class Model:
    """The constants of the closed loop, read from a scenario (the paper FLC's)."""

    # law (FlcParams)
    time_gap: float
    base_gap: float
    c: float
    scale_gain: float
    scale_cap: float
    bound_t: float
    brake_threshold: float
    shift_normal: float
    shift_brake: float
    override_dist: float
    dist_override: str
    negative_multiplier: float
    clip_dist_s: bool
    command_gain: float
    max_speed: float
    # speed controller
    kp: float
    ki: float
    integral_limit: float
    sc_max_accel: float
    sc_max_decel: float
    # vehicle
    dead_steps: int
    alpha: float
    max_accel: float
    max_brake: float
    max_power: float
    mass: float
    drag: float  # 0.5 rho cd A / m
    rolling: float  # rolling_resistance * g
    dt: float
    frame_steps: int
    range_error: float
    lead: dict[str, float]

    @classmethod
    def from_scenario(cls, sc: Scenario, range_error: float = 0.3) -> "Model":
        d = sc.to_dict()
        f, sp, veh = d["flc"], d["follower"]["speed_controller"], d["follower"]["vehicle"]
        if d["controller"] != "flc":
            raise ValueError(f"verify: the certificate is for the paper FLC (controller = \"flc\"), got {d['controller']!r}")
        if f["first_frame"] != "steady":
            raise ValueError("verify: flc.first_frame must be \"steady\"")
        if d["lidar"]["latency_frames"] != 0:
            raise ValueError("verify: lidar.latency_frames must be 0 (latency is not modelled)")
        dt = float(d["physics_dt"])
        frame = 1.0 / (float(d["lidar"]["rate_hz"]) * dt)
        if abs(frame - round(frame)) > 1e-9:
            raise ValueError("verify: the LiDAR period must be a whole number of physics steps")
        lag = float(veh["lag"])
        lv = d["lead"]["vehicle"]
        lead = {
            "dead_time": float(lv["dead_time"]), "lag": float(lv["lag"]), "max_brake": float(lv["max_brake"]),
            "drag": 0.5 * lv["air_density"] * lv["drag_cd"] * lv["frontal_area"] / lv["mass"], "rolling": lv["rolling_resistance"] * _G,
        }
        return cls(
            time_gap=f["time_gap"], base_gap=f["base_gap"], c=f["c"], scale_gain=f["scale_gain"], scale_cap=f["scale_cap"],
            bound_t=f["bound_t"], brake_threshold=f["brake_threshold"], shift_normal=f["shift_normal"], shift_brake=f["shift_brake"],
            override_dist=f["override_dist"], dist_override=f["dist_override"], negative_multiplier=f["negative_multiplier"],
            clip_dist_s=bool(f["clip_dist_s"]), command_gain=f["command_gain"], max_speed=f["max_speed"],
            kp=sp["kp"], ki=sp["ki"], integral_limit=sp["integral_limit"], sc_max_accel=sp["max_accel"], sc_max_decel=sp["max_decel"],
            dead_steps=int(round(float(veh["dead_time"]) / dt)),
            alpha=(1.0 - math.exp(-dt / lag)) if lag > 0 else 1.0,
            max_accel=veh["max_accel"], max_brake=veh["max_brake"], max_power=veh["max_power"], mass=veh["mass"],
            drag=0.5 * veh["air_density"] * veh["drag_cd"] * veh["frontal_area"] / veh["mass"],
            rolling=veh["rolling_resistance"] * _G,
            dt=dt, frame_steps=int(round(frame)), range_error=float(range_error), lead=lead,
        )

    # --- the law, Eqs. (2)-(5), on intervals -----------------------------------------------

    def _law_point(self, x: float, shift: float) -> tuple[float, float]:
        # a(x) = x (shift - cos(pi x / B)): nondecreasing on [-B, B] for shift >= 1 (derivative
        # shift - cos + (pi x / B) sin(pi x / B) >= 0). Padded by the rounding of the product and
        # of the cosine (absolute, as shift - cos cancels near 0).
        a = x * (shift - math.cos(math.pi * x / self.bound_t))
        e = abs(x) * (abs(shift) + 1.0) * 4e-15 + abs(a) * 4e-15
        lo, hi = _dn(a - e), _up(a + e)

        # The multiplier on the negative side, y -> y * m (y < 0) else y: nondecreasing.
        def g(y: float, rnd: Any) -> float:
            return rnd(y * self.negative_multiplier) if y < 0 else y

        return g(lo, _dn), g(hi, _up)

    def _law(self, dist_s: I, shift: float) -> I:
        lo, _ = self._law_point(dist_s.lo, shift)
        _, hi = self._law_point(dist_s.hi, shift)
        return I(lo, hi)

    def branches(self, delta_d: I) -> list[bool]:
        """The branches of Eq. (5) possible for ``delta_d`` (True: braking, ``delta_d <= thr``)."""
        out = []
        if delta_d.hi > self.brake_threshold:
            out.append(False)
        if delta_d.lo <= self.brake_threshold:
            out.append(True)
        return out

    def law_accel(self, d: I, v: I, delta_d: I, branch: Optional[bool] = None) -> I:
        """The law's acceleration output ``a`` for measured distance ``d``, own speed ``v`` and
        the change of distance ``delta_d``: on ``branch`` (True: braking) for the members of the
        state that take it, else the hull of the branches ``delta_d`` allows."""
        d_d = self.time_gap * v + self.base_gap
        # Scale_f = min(gain v / c, cap), F_shift = max(0, v) Scale_f: nondecreasing in v >= 0.
        scale = (self.scale_gain / self.c) * v
        scale = I(min(scale.lo, self.scale_cap), min(scale.hi, self.scale_cap))
        f_shift = v.max0() * scale
        raw = d - d_d - f_shift
        ds = raw.clamp(-self.bound_t, self.bound_t) if self.clip_dist_s else raw
        if not self.clip_dist_s or self.shift_normal < 1 or self.shift_brake < 1:
            raise ValueError("verify: the law's monotonicity needs clip_dist_s = true and shifts >= 1")
        out: Optional[I] = None
        allowed = self.branches(delta_d) if branch is None else [branch]
        if False in allowed:  # the normal branch
            out = self._law(ds, self.shift_normal)
        if True in allowed:  # the braking branch
            if self.dist_override == "min":
                b = ds.minimum(I.pt(self.override_dist))
            elif self.dist_override == "replace":
                b = I.pt(self.override_dist)
            else:
                b = ds
            a = self._law(b.clamp(-self.bound_t, self.bound_t), self.shift_brake)
            out = a if out is None else out.hull(a)
        assert out is not None
        return out

    # --- one physics step of the follower --------------------------------------------------

    def resistance(self, v: I) -> I:
        # 0 at v = 0 exactly, else drag v² + rolling: nondecreasing for v >= 0.
        lo = 0.0 if v.lo <= 0 else _dn(self.drag * v.lo * v.lo + self.rolling)
        hi = 0.0 if v.hi <= 0 else _up(_up(self.drag * v.hi * v.hi) + self.rolling)
        return I(max(lo, 0.0) if v.lo > 0 else 0.0, hi)


@dataclass
class Box:
    """Initial speed (m/s), gap (m) and lead deceleration (m/s², positive) intervals."""

    v: tuple[float, float]
    gap: tuple[float, float]
    decel: tuple[float, float]

    def split(self) -> tuple["Box", "Box"]:
        # Along the widest dimension, relative to the grid's natural scales (5 m/s, 10 m, 2 m/s²).
        w = [(self.v[1] - self.v[0]) / 5.0, (self.gap[1] - self.gap[0]) / 10.0, (self.decel[1] - self.decel[0]) / 2.0]
        k = w.index(max(w))
        iv = [self.v, self.gap, self.decel][k]
        m = 0.5 * (iv[0] + iv[1])
        a, b = list([self.v, self.gap, self.decel]), list([self.v, self.gap, self.decel])
        a[k], b[k] = (iv[0], m), (m, iv[1])
        return Box(*a), Box(*b)


def _lead_track(m: "Model", lead: dict[str, float], v0: float, decel: float, steps: int) -> list[float]:
    """The lead's displacement per physics step when it brakes with the demand ``-decel`` from
    t = 0 through its vehicle model (``flc_sim::Vehicle::step``: dead time FIFO starting idle,
    lag, brake limit, resistance, speed floored at 0), in floats."""
    n = int(round(lead["dead_time"] / m.dt))
    fifo = [0.0] * n
    alpha = (1.0 - math.exp(-m.dt / lead["lag"])) if lead["lag"] > 0 else 1.0
    act, v, out = 0.0, v0, []
    for _ in range(steps):
        fifo.append(-decel)
        delayed = fifo.pop(0)
        act += alpha * (delayed - act)
        a_act = max(act, -lead["max_brake"])  # a braking demand: never the drive branch
        r = (lead["drag"] * v * v + lead["rolling"]) if v > 0 else 0.0
        v_new = max(v + (a_act - r) * m.dt, 0.0)
        out.append(0.5 * (v + v_new) * m.dt)
        v = v_new
    return out


@dataclass
class _State:
    k: int
    v: I
    gap: I
    actuator: I
    fifo: list[I]
    integ: I
    e: I
    cmd_le0: bool
    first: bool
    dgap: I
    branch: Optional[bool] = None  # the branch forced at frame k (a fork), else free

    def copy(self, **kw: Any) -> "_State":
        d = dict(self.__dict__)
        d["fifo"] = list(self.fifo)
        d.update(kw)
        return _State(**d)


def reach(m: Model, box: Box, horizon: float = 15.0, max_paths: int = 4096) -> tuple[bool, float]:
    """Steps the interval closed loop from ``box`` for ``horizon`` s. Where a frame's ``delta_d``
    straddles the threshold of Eq. (5), the state forks: one path per branch (each path covers
    the members of the state that take its branch, so the paths together cover them all).
    Returns (certified, the gap's least lower bound over all paths): certified when the gap's
    lower bound stays positive on every path, with at most ``max_paths`` paths."""
    err = I(-m.range_error, m.range_error)
    steps = int(math.ceil(horizon / m.dt))
    lead_lo = _lead_track(m, m.lead, box.v[0], box.decel[1], steps)
    lead_hi = _lead_track(m, m.lead, box.v[1], box.decel[0], steps)
    start = _State(0, I(*box.v), I(*box.gap), I.pt(0.0), [I.pt(0.0)] * m.dead_steps, I.pt(0.0), I.pt(0.0), False, True, I.pt(0.0))
    stack = [start]
    paths = 1
    least = box.gap[0]
    while stack:
        st = stack.pop()
        v, gap, actuator, fifo, integ, e = st.v, st.gap, st.actuator, st.fifo, st.integ, st.e
        cmd_le0, first, dgap = st.cmd_le0, st.first, st.dgap
        forced = st.branch
        k = st.k
        while k < steps:
            if k % m.frame_steps == 0:
                d = gap + err
                if d.lo < 0:
                    return False, min(least, d.lo)
                # delta_d = d_k - d_(k-1): the gap's change over the frame (accumulated step by
                # step, so it does not take the gap's whole width twice) plus both frames' errors.
                delta = I.pt(0.0) if first else dgap + 2.0 * err
                if forced is None:
                    options = m.branches(delta)
                    if len(options) > 1:
                        paths += 1
                        if paths > max_paths:
                            return False, least
                        stack.append(_State(k, v, gap, actuator, list(fifo), integ, e, cmd_le0, first, dgap, options[1]))
                    forced = options[0]
                a = m.law_accel(d, v, delta, forced)
                forced = None
                first = False
                dgap = I.pt(0.0)
                cmd = (v + m.command_gain * a).clamp(0.0, m.max_speed)
                ga = m.command_gain * a
                if _up(v.hi + ga.hi) < m.max_speed:
                    # cmd = max(v + g a, 0), so e = cmd - v = max(g a, -v): v taken once.
                    e = I(max(ga.lo, -v.hi), max(ga.hi, -v.lo))
                else:
                    e = cmd - v
                cmd_le0 = cmd.lo <= 0.0
            # Speed controller (flc_sim::SpeedController::step)
            cand = (integ + (m.ki * m.dt) * e).clamp(-m.integral_limit, m.integral_limit)
            raw = m.kp * e + cand
            if raw.hi < m.sc_max_accel and raw.lo > -m.sc_max_decel:
                integ_new = cand
            elif raw.lo >= m.sc_max_accel or raw.hi <= -m.sc_max_decel:
                integ_new = integ
            else:
                integ_new = cand.hull(integ)
            demand = (m.kp * e + integ_new).clamp(-m.sc_max_decel, m.sc_max_accel)
            if cmd_le0 and v.lo < 0.1:
                # A stop request at standstill holds the brake (and empties the integrator).
                demand = demand.hull(I.pt(-min(m.sc_max_decel, 2.0)))
                integ_new = integ_new.hull(I.pt(0.0))
            integ = integ_new
            # Vehicle (flc_sim::Vehicle::step): dead time, lag, limits, resistance.
            if fifo:
                fifo.append(demand)
                delayed = fifo.pop(0)
            else:
                delayed = demand
            actuator = (1.0 - m.alpha) * actuator + m.alpha * delayed
            cap_lo = min(m.max_accel, _dn(m.max_power / (m.mass * max(v.hi, 1.0))))
            cap_hi = min(m.max_accel, _up(m.max_power / (m.mass * max(v.lo, 1.0))))
            lo_x, hi_x = actuator.lo, actuator.hi
            a_act = I(
                min(lo_x, cap_lo) if lo_x >= 0 else max(lo_x, -m.max_brake),
                min(hi_x, cap_hi) if hi_x >= 0 else max(hi_x, -m.max_brake),
            )
            dv = (a_act - m.resistance(v)) * m.dt
            # v_new = max(v + dv, 0) = v + step with step = max(dv, -v)
            step = I(max(dv.lo, -v.hi), max(dv.hi, -v.lo))
            v_new = (v + step).max0()
            d_f = (v + 0.5 * step) * m.dt
            # Lead displacement: nondecreasing in v0, nonincreasing in the demand (the model is
            # order-preserving: 1 - 2 drag v dt > 0); 1e-9 m per step covers the floats' rounding.
            d_l = I(lead_lo[k] - 1e-9, lead_hi[k] + 1e-9)
            gap = gap + d_l - d_f
            dgap = dgap + d_l - d_f
            # e = command - speed: the command is held, the speed moved by `step` (its interval,
            # not v_new - v of two intervals, which would add both widths).
            e = e - step
            v = v_new
            least = min(least, gap.lo)
            if gap.lo <= 0:
                return False, least
            k += 1
    return True, least


@dataclass
class Cell:
    box: Box
    certified: bool
    least_gap: float


def certify(m: Model, boxes: Iterable[Box], depth: int = 4, horizon: float = 15.0) -> list[Cell]:
    """Each box certified, or split up to ``depth`` times; the leaves with their verdicts."""
    out: list[Cell] = []
    todo = [(b, 0) for b in boxes]
    while todo:
        b, k = todo.pop(0)
        ok, least = reach(m, b, horizon)
        if ok or k >= depth:
            out.append(Cell(b, ok, least))
        else:
            todo.extend((h, k + 1) for h in b.split())
    return out


if __name__ == "__main__":
    for re_ in (0.0, 0.05):
        model = Model.from_scenario(Scenario.paper(50, "flc", "realistic"), range_error=re_)
        for v, g, a in [((13.8, 13.8), (25.0, 25.0), (6.0, 6.0)), ((13.8, 13.9), (25.0, 25.5), (5.5, 6.0)), ((25.0, 25.0), (40.0, 40.0), (6.0, 6.0))]:
            ok, least = reach(model, Box(v, g, a))
            print(f"range error {re_} m, speed {v} m/s, gap {g} m, lead decel {a} m/s²: certified {ok}, least gap bound {least:.3f} m")
