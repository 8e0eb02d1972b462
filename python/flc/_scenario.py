"""Scenarios: load TOML, build from a dict, presets with keyword overrides (typed facade)."""
from __future__ import annotations

import copy
import json
import os
from typing import Any, Mapping, Optional, Union

from . import _flc
from ._flc import ScenarioError

#: The type of an OpenSCENARIO parameter value in :attr:`Scenario.params`.
ParamValue = Union[float, int, bool, str]

#: Sections of a scenario (from the Rust ``Scenario``); a keyword ``<section>_<key>`` overrides
#: ``[section] key``.
SECTIONS: tuple[str, ...] = tuple(_flc.section_names())

#: Controller names accepted by ``controller=`` (the Rust controller registry, in its order;
#: ``docs/scenarios.md``, ``docs/baselines.md``).
CONTROLLERS: tuple[str, ...] = tuple(_flc.controller_names())


def _overrides_json(overrides: Mapping[str, Any]) -> str:
    # A list of [name, value] pairs: the overrides apply in keyword order.
    return json.dumps([[name, value] for name, value in overrides.items()], allow_nan=True)


def _key_path(key: str) -> list[Union[str, int]]:
    """``lidar_rate_hz`` / ``lidar.rate_hz`` / ``lead.phases[2].decel`` as a path into the dict."""
    path: list[Union[str, int]] = []
    for part in _flc.resolve_key(key).split("."):
        name, _, rest = part.partition("[")
        path.append(name)
        while rest:
            index, _, rest = rest.partition("]")
            path.append(int(index))
            rest = rest.lstrip("[")
    return path


def _param_text(v: Any) -> str:
    # Parameter values as OpenSCENARIO writes them: booleans as true/false, numbers as repr.
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


class Scenario:
    """One closed-loop run, as the simulator's scenario file (``docs/scenarios.md``).

    Build with :meth:`paper`, :meth:`load` or :meth:`from_dict`; override fields by keyword:
    ``lidar_rate_hz=10`` sets ``[lidar] rate_hz``, ``**{"follower.vehicle.max_brake": 7.0}`` any
    nested key. Units are SI except keys ending in ``_kmh``.
    """

    def __init__(self, data: Mapping[str, Any]) -> None:
        if not isinstance(data, Mapping):
            raise TypeError(f"Scenario: `data` must be a dict shaped like a scenario file, got {type(data).__name__} {data!r:.60}")
        # Validate through Rust: unknown keys / out-of-range values raise ScenarioError naming the key.
        self._json = _flc.check_scenario(json.dumps(dict(data), allow_nan=True))
        self._data: dict[str, Any] = json.loads(self._json)
        self._params: dict[str, ParamValue] = {}

    @classmethod
    def _patched(cls, scenario_json: str, overrides: Mapping[str, Any], where: str = "Scenario.from_dict", params: tuple[str, ...] = ()) -> "Scenario":
        # The one key-patch mechanism (Rust `Scenario::with_overrides`): validated, errors name the
        # key; a keyword that is no scenario key at all is a TypeError, as for any function.
        s = cls.__new__(cls)
        try:
            s._json = _flc.apply_overrides(scenario_json, _overrides_json(overrides))
        except TypeError as e:
            own = f"its parameters are {', '.join(params)}; " if params else ""
            raise TypeError(f"{where}() got an {e} ({own}other keywords set scenario keys)") from None
        s._data = json.loads(s._json)
        s._params = {}
        return s

    @classmethod
    def paper(cls, speed_kmh: float = 50.0, controller: str = "flc", preset: str = "realistic", **overrides: Any) -> "Scenario":
        """The paper's experiment at ``speed_kmh`` (km/h) with ``controller`` in
        :data:`CONTROLLERS` ("flc", "pid", "pipeline", a baseline under identical sensing:
        "idm", "acc", "rss", "carla-behavior", "gipps", the robust FLC "flc-robust" (v2; v1 is "flc-robust-v1"; v2 with wheel odometry is "flc-robust-odo"), or the UN R157
        reference driver "careful-driver", which sees the ground truth) and ``preset`` in
        {"realistic", "paper"}."""
        if isinstance(speed_kmh, bool) or not isinstance(speed_kmh, (int, float)):
            raise TypeError(f"Scenario.paper(): `speed_kmh` must be a number (km/h), got {type(speed_kmh).__name__} {speed_kmh!r:.40}")
        for name, value in (("controller", controller), ("preset", preset)):
            if not isinstance(value, str):
                raise TypeError(f"Scenario.paper(): `{name}` must be a str, got {type(value).__name__} {value!r:.40}")
        return cls._patched(
            _flc.paper_scenario(float(speed_kmh), controller, preset), overrides, "Scenario.paper", ("speed_kmh", "controller", "preset")
        )

    @classmethod
    def paper_tracking(cls, controller: str = "flc", preset: str = "paper", **overrides: Any) -> "Scenario":
        """The curved-route run of the paper's tracking errors (Sec. IV, Fig. 3a), as
        ``cargo run --release --bin scenario`` prints them under its table: the lead accelerates to
        50 km/h through the curves, covers 1600 m and stops; ``controller`` follows from 7 m (the
        PID with working V2V). Its metrics ``rot_error_deg`` / ``trans_error_m`` are the errors."""
        return cls._patched(_flc.paper_tracking_scenario(controller, preset), overrides, "Scenario.paper_tracking", ("controller", "preset"))

    @classmethod
    def brakedemo(cls, **overrides: Any) -> "Scenario":
        """The platoon brake demo (``scenarios/platoon-brakedemo.toml``, ``docs/platoon.md``): the lead
        and 7 followers at 120 km/h, the lead brakes at -6 m/s² after 20 s; three variants
        (:meth:`variants`): ``pid-v2v``, ``flc``, ``pipeline-outage``. Keyword overrides as in
        :meth:`from_dict` (e.g. ``platoon_followers=15``)."""
        return cls._patched(_flc.brakedemo_scenario(), overrides, "Scenario.brakedemo")

    @classmethod
    def load(
        cls,
        path: Union[str, "os.PathLike[str]"],
        params: Optional[Mapping[str, Any]] = None,
        *,
        ego: Optional[str] = None,
        ego_mode: str = "controller",
        road: str = "file",
        traffic_dynamics: str = "kinematic",
        controller: Optional[str] = None,
        strict: bool = False,
        **overrides: Any,
    ) -> "Scenario":
        """Read a scenario file: TOML, or ASAM OpenSCENARIO ``.xosc`` (``docs/openscenario.md``).

        For ``.xosc``: ``params`` sets parameters (as ``scenario --param NAME=VALUE``), ``ego``
        names the entity flc drives, ``ego_mode="scripted"`` makes it follow its storyboard (as
        esmini does), ``road="straight"`` replaces a missing road, ``traffic_dynamics="vehicle"``
        moves the scripted entities through their vehicle models, ``controller`` overrides the
        file's controller, ``strict=True`` refuses what only esmini accepts (its expression
        extensions such as ``pi`` and ``sin``, a negative dynamics value, a value its
        declaration's constraints forbid) instead of warning. A distribution file has several
        runs: use :meth:`load_all`.
        Keyword ``overrides`` patch the result as in :meth:`from_dict`.
        """
        runs = cls.load_all(
            path,
            params,
            ego=ego,
            ego_mode=ego_mode,
            road=road,
            traffic_dynamics=traffic_dynamics,
            controller=controller,
            strict=strict,
            **overrides,
        )
        if len(runs) != 1:
            raise ScenarioError(f"{os.fspath(path)}: {len(runs)} runs (a distribution): use Scenario.load_all")
        return runs[0]

    @classmethod
    def load_all(
        cls,
        path: Union[str, "os.PathLike[str]"],
        params: Optional[Mapping[str, Any]] = None,
        *,
        ego: Optional[str] = None,
        ego_mode: str = "controller",
        road: str = "file",
        traffic_dynamics: str = "kinematic",
        controller: Optional[str] = None,
        strict: bool = False,
        **overrides: Any,
    ) -> "list[Scenario]":
        """Every run of a scenario file: one for TOML and ``.xosc`` files, one per combination of
        an OpenSCENARIO ``ParameterValueDistribution`` (its parameter values in
        :attr:`params`). Arguments as :meth:`load`."""
        p = os.fspath(path)
        if not p.lower().endswith(".xosc"):
            if params:
                raise ScenarioError("`params`: only OpenSCENARIO (.xosc) files take parameters")
            if controller is not None:
                # For TOML files `controller` is the scenario key, overridden like any other.
                overrides = {"controller": controller, **overrides}
            return [cls._patched(_flc.load_scenario(p), overrides, "Scenario.load")]
        pairs = [(str(k), _param_text(v)) for k, v in (params or {}).items()]
        out = []
        for scenario_json, values in _flc.import_openscenario(p, pairs, ego, ego_mode, road, traffic_dynamics, controller, strict):
            s = cls._patched(scenario_json, overrides, "Scenario.load")
            s._params = {str(k): v for k, v in json.loads(values)}
            out.append(s)
        return out

    @property
    def params(self) -> "dict[str, ParamValue]":
        """The OpenSCENARIO parameter values this run was imported with (distributions; empty
        otherwise), typed by their declarations: ``double`` a float, ``integer`` /
        ``unsignedInt`` / ``unsignedShort`` an int, ``boolean`` a bool, ``string`` / ``dateTime``
        a str."""
        return dict(self._params)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], **overrides: Any) -> "Scenario":
        """Build from a dict shaped like the TOML file (missing keys take their defaults), with
        keyword overrides (``lidar_rate_hz=10``, ``**{"follower.vehicle.max_brake": 7.0}``,
        ``lead_decel=6.0`` = the deceleration of every brake phase of the lead)."""
        if not isinstance(data, Mapping):
            raise TypeError(f"Scenario.from_dict: `data` must be a dict shaped like a scenario file, got {type(data).__name__} {data!r:.60}")
        if not overrides:
            return cls(data)
        return cls._patched(json.dumps(dict(data), allow_nan=True), overrides)

    def replace(self, **overrides: Any) -> "Scenario":
        """A copy with fields overridden by keyword (as in :meth:`from_dict`)."""
        s = Scenario._patched(self._json, overrides, "Scenario.replace")
        s._params = dict(self._params)
        return s

    def variants(self) -> list["Scenario"]:
        """The scenarios to run for this one: each of its ``[[variants]]`` (with ``variant`` set to
        its name), or ``[self]`` without any (as ``scenario --config`` does)."""
        return [Scenario(json.loads(j)) for j in _flc.expand_variants(self._json)]

    @property
    def variant(self) -> Optional[str]:
        v = self._data.get("variant")
        return None if v is None else str(v)

    def to_dict(self) -> dict[str, Any]:
        """The full scenario (every key, defaults filled in)."""
        return copy.deepcopy(self._data)

    def to_json(self) -> str:
        """The full scenario as JSON."""
        return self._json

    @property
    def name(self) -> str:
        return str(self._data.get("name", ""))

    @property
    def controller(self) -> str:
        return str(self._data.get("controller", ""))

    @property
    def seed(self) -> int:
        return int(self._data.get("seed", 0))

    @property
    def speed_kmh(self) -> Optional[float]:
        v = self._data.get("speed_kmh")
        return None if v is None else float(v)

    def __getitem__(self, key: str) -> Any:
        node: Any = self._data
        for part in _key_path(key):
            node = node[part]
        return copy.deepcopy(node)

    def __repr__(self) -> str:
        v = "" if self.variant is None else f", variant={self.variant!r}"
        return f"Scenario(name={self.name!r}, controller={self.controller!r}, seed={self.seed}{v})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scenario) and self._data == other._data

    def __reduce__(self) -> Any:
        # Picklable (for concurrent.futures executors): rebuilt and re-validated from its JSON.
        return (_scenario_from_json, (self._json,))


def _scenario_from_json(text: str) -> Scenario:
    return Scenario(json.loads(text))
