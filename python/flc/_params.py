"""Keyword arguments -> validated JSON for the Rust core (private)."""
from __future__ import annotations

import json
import math
from typing import Any, Mapping

from ._flc import ParameterError, default_params


def defaults(component: str) -> dict[str, Any]:
    """The Rust defaults (the paper's values) of a component as a dict."""
    return json.loads(default_params(component))


def check_value(name: str, value: Any, expected: Any) -> None:
    """Rejects wrong types and non-finite numbers at the call, naming the parameter."""
    if isinstance(expected, bool):
        if not isinstance(value, bool):
            raise ParameterError(f"`{name}`: expected bool, got {type(value).__name__}")
    elif isinstance(expected, (int, float)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(f"`{name}`: expected a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise ParameterError(f"`{name}`: must be finite, got {value}")
        if isinstance(expected, int) and not isinstance(expected, bool) and isinstance(value, float) and not value.is_integer():
            raise ParameterError(f"`{name}`: expected an integer, got {value}")
    elif isinstance(expected, dict):
        if not isinstance(value, Mapping):
            raise ParameterError(f"`{name}`: expected a mapping, got {type(value).__name__}")
        for k, v in value.items():
            check_value(f"{name}.{k}", v, expected.get(k, v))
    elif isinstance(expected, str):
        if not isinstance(value, (str, dict)):
            raise ParameterError(f"`{name}`: expected a string, got {type(value).__name__}")


def params_json(component: str, overrides: Mapping[str, Any]) -> str:
    """Merges keyword overrides into the defaults; unknown names raise ParameterError."""
    base = defaults(component)
    for name, value in overrides.items():
        if name not in base:
            known = ", ".join(sorted(base))
            raise ParameterError(f"`{name}`: unknown parameter of {component}; known: {known}")
        check_value(name, value, base[name])
        if isinstance(base[name], dict) and isinstance(value, Mapping):
            merged = dict(base[name])
            merged.update(value)
            base[name] = merged
        else:
            base[name] = value
    return json.dumps(base, allow_nan=False)
