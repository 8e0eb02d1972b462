"""What :func:`flc.run_suite` returns: the suites' reports as dicts with attributes and tables."""
from __future__ import annotations

from typing import Any, Iterable, Mapping, Optional, SupportsIndex, Union, overload

#: The fields of one result row (``flc_sim::suite::RunRecord``) that :meth:`SuiteReport.to_pandas`
#: puts first, before the run's metrics.
RESULT_FIELDS: tuple[str, ...] = ("case", "run", "controller", "outcome", "score", "below_reference", "test_speed")


def _pandas() -> Any:
    try:
        import pandas as pd
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_pandas() needs pandas: pip install 'flc[pandas]'") from e
    return pd


class SuiteReport(dict):  # type: ignore[type-arg]
    """One suite's report: the JSON of ``flc_sim::suite::SuiteReport`` (what ``scenario suite
    --out`` writes as ``<suite>.json``) as a ``dict``, its keys also attributes: ``name``,
    ``title``, ``source``, ``cases``, ``controllers`` (the careful driver first), ``summary``
    (one entry per controller: ``controller``, ``passed``, ``runs``, ``collisions``,
    ``below_reference``, ``ncap_score``) and ``results`` (one per run: ``case``, ``run``,
    ``controller``, ``outcome``, ``score``, ``below_reference``, ``test_speed``, ``metrics``).
    :meth:`to_pandas` gives the runs as a table, :meth:`summary_to_pandas` the summary."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(f"SuiteReport has no attribute or key {name!r}") from None

    def __dir__(self) -> Iterable[str]:
        return sorted(set(super().__dir__()) | {str(k) for k in self})

    def rows(self) -> list[dict[str, Any]]:
        """One flat dict per run: ``suite``, the fields of :data:`RESULT_FIELDS`, then every
        metric (the keys of :attr:`flc.RunResult.metrics`) as its own column."""
        out = []
        for r in self.get("results", []):
            row: dict[str, Any] = {"suite": self.get("name")}
            row.update({k: r.get(k) for k in RESULT_FIELDS})
            for k, v in (r.get("metrics") or {}).items():
                row[k if k not in row else f"metrics.{k}"] = v
            out.append(row)
        return out

    def to_pandas(self) -> Any:
        """The runs as a ``pandas.DataFrame``, one row per (case, run, controller): the columns of
        :meth:`rows` (needs pandas)."""
        return _pandas().DataFrame(self.rows())

    def summary_to_pandas(self) -> Any:
        """The summary as a ``pandas.DataFrame``, one row per controller with ``suite`` first
        (needs pandas)."""
        return _pandas().DataFrame([{"suite": self.get("name"), **s} for s in self.get("summary", [])])

    def __repr__(self) -> str:
        passed = ", ".join(f"{s['controller']} {s['passed']}/{s['runs']}" for s in self.get("summary", []))
        return f"SuiteReport({self.get('name')!r}: {passed})"


class SuiteResults(list):  # type: ignore[type-arg]
    """The reports of :func:`flc.run_suite`, one :class:`SuiteReport` per suite in run order (a
    ``list``: ``(report,) = flc.run_suite("r157")`` works); ``results["r157"]`` picks one by name;
    :meth:`to_pandas` / :meth:`summary_to_pandas` concatenate the suites' tables."""

    def __init__(self, reports: Iterable[Mapping[str, Any]] = ()) -> None:
        super().__init__(r if isinstance(r, SuiteReport) else SuiteReport(r) for r in reports)

    @overload
    def __getitem__(self, key: SupportsIndex) -> SuiteReport: ...
    @overload
    def __getitem__(self, key: slice) -> list[SuiteReport]: ...
    @overload
    def __getitem__(self, key: str) -> SuiteReport: ...
    def __getitem__(self, key: Union[SupportsIndex, slice, str]) -> Any:
        if isinstance(key, str):
            for r in self:
                if r.get("name") == key:
                    return r
            raise KeyError(f"no suite {key!r} in these results (suites: {', '.join(str(r.get('name')) for r in self)})")
        return super().__getitem__(key)

    @property
    def names(self) -> list[str]:
        """The suites' names, in order."""
        return [str(r.get("name")) for r in self]

    def rows(self) -> list[dict[str, Any]]:
        """:meth:`SuiteReport.rows` of every suite, in order."""
        return [row for r in self for row in r.rows()]

    def to_pandas(self) -> Any:
        """Every suite's runs as one ``pandas.DataFrame`` (``suite`` is the first column; needs
        pandas)."""
        return _pandas().DataFrame(self.rows())

    def summary_to_pandas(self) -> Any:
        """Every suite's summary as one ``pandas.DataFrame`` (needs pandas)."""
        pd = _pandas()
        frames = [r.summary_to_pandas() for r in self]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def __repr__(self) -> str:
        return f"SuiteResults([{', '.join(repr(r) for r in self)}])"


def controller_list(controllers: Optional[Union[str, Iterable[str]]]) -> Optional[list[str]]:
    """``controllers`` of :func:`flc.run_suite` as a list: a string is one controller (``"flc"``)
    or a comma-separated list as on the command line (``"flc,flc-robust"``); any other iterable
    must hold strings. Anything else raises ``TypeError`` naming the parameter."""
    if controllers is None:
        return None
    if isinstance(controllers, str):
        return [c.strip() for c in controllers.split(",")]
    if isinstance(controllers, (bytes, Mapping)) or not isinstance(controllers, Iterable):
        raise TypeError(f"run_suite(): `controllers` must be a controller name or a list of names, got {type(controllers).__name__}")
    out = list(controllers)
    bad = [c for c in out if not isinstance(c, str)]
    if bad:
        raise TypeError(f"run_suite(): `controllers` must hold controller names (str), got {type(bad[0]).__name__} {bad[0]!r}")
    return out
