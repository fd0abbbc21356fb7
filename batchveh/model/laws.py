"""Motion laws: imposed wheel speed omega(t) in rad/s or steering angle alpha(t) in rad.

Each law is a pure JAX function `law(t, **params)` of time t in s. Its parameters
may be arrays, so a sweep varies them inside one compiled program; the law's kind
is static (it picks the function). `Law` pairs a kind with its parameters.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax.numpy as jnp

from batchveh.config import ConfigError, check_number


def constant(t, value):
    """y(t) = value."""
    return value + 0.0 * t


def ramp(t, start, stop, duration, delay=0.0):
    """Linear from `start` at t = delay to `stop` at t = delay + duration, then held (saturating)."""
    frac = jnp.clip((t - delay) / jnp.maximum(duration, 1e-12), 0.0, 1.0)
    return start + (stop - start) * frac


def unbounded_ramp(t, start, stop, duration):
    """The seed's ramp: reaches `stop` at t = duration and keeps growing at the same rate."""
    return start + (stop - start) * t / jnp.maximum(duration, 1e-12)


def sine(t, offset, amplitude, frequency, phase=0.0):
    """offset + amplitude * sin(2 pi frequency t + phase); frequency in Hz, phase in rad."""
    return offset + amplitude * jnp.sin(2 * jnp.pi * frequency * t + phase)


def table(t, times, values):
    """Piecewise linear through (times[i], values[i]); held flat outside the table."""
    return jnp.interp(t, jnp.asarray(times), jnp.asarray(values))


def smooth_step(t, start, stop, duration, delay=0.0):
    """Quintic step from `start` to `stop` over [delay, delay + duration]: zero speed and acceleration at both ends."""
    s = jnp.clip((t - delay) / jnp.maximum(duration, 1e-12), 0.0, 1.0)
    return start + (stop - start) * s**3 * (10 - 15 * s + 6 * s**2)


LAWS: dict[str, Callable[..., Any]] = {
    "constant": constant,
    "ramp": ramp,
    "unbounded_ramp": unbounded_ramp,
    "sine": sine,
    "table": table,
    "smooth_step": smooth_step,
}
# required parameters (beyond t) and optional ones with defaults
LAW_PARAMS: dict[str, tuple[tuple[str, ...], dict[str, float]]] = {
    "constant": (("value",), {}),
    "ramp": (("start", "stop", "duration"), {"delay": 0.0}),
    "unbounded_ramp": (("start", "stop", "duration"), {}),
    "sine": (("offset", "amplitude", "frequency"), {"phase": 0.0}),
    "table": (("times", "values"), {}),
    "smooth_step": (("start", "stop", "duration"), {"delay": 0.0}),
}


@dataclass(frozen=True)
class Law:
    """A motion law: its kind (static) and its parameters (numbers or, for tables, tuples)."""

    kind: str
    params: tuple[tuple[str, Any], ...]

    def __call__(self, t, **override):
        p = dict(self.params)
        p.update(override)
        return LAWS[self.kind](t, **p)

    def scaled(self, factor: float, keys: tuple[str, ...]) -> Law:
        """A copy with the value-like parameters `keys` multiplied by `factor` (unit changes)."""
        p = dict(self.params)
        for k in keys:
            if k in p:
                v = p[k]
                p[k] = tuple(x * factor for x in v) if isinstance(v, tuple) else v * factor
        return Law(self.kind, tuple(p.items()))


VALUE_KEYS = ("value", "start", "stop", "offset", "amplitude", "values")


def make_law(kind: str, **params: Any) -> Law:
    """Build a Law, filling optional parameters with defaults."""
    req, opt = LAW_PARAMS[kind]
    full = {**opt, **params}
    return Law(kind, tuple((k, full[k]) for k in (*req, *opt)))


def law_from_mapping(data: Any, where: str) -> Law:
    """Parse `{law: ramp, start: 0, stop: 1.4, duration: 3}` (or a bare number for a constant)."""
    if isinstance(data, (int, float)) and not isinstance(data, bool):
        return make_law("constant", value=check_number(data, {}, where))
    if not isinstance(data, dict) or "law" not in data:
        raise ConfigError(
            f"{where}: {data!r} is not a motion law; give a number or a mapping with "
            f"'law' (one of {', '.join(LAWS)}) and its parameters"
        )
    kind = data["law"]
    if kind not in LAWS:
        raise ConfigError(f"{where}.law: {kind!r} is not a motion law; allowed: {', '.join(LAWS)}")
    req, opt = LAW_PARAMS[kind]
    params = {k: v for k, v in data.items() if k != "law"}
    for k in params:
        if k not in req and k not in opt:
            raise ConfigError(f"{where}: unknown key {k!r} for law {kind!r}; allowed keys: {', '.join((*req, *opt))}")
    for k in req:
        if k not in params:
            raise ConfigError(f"{where}: law {kind!r} needs {k!r}; required: {', '.join(req)}")
    out = {}
    for k, v in params.items():
        if kind == "table":
            if not isinstance(v, list) or not v:
                raise ConfigError(f"{where}.{k}: {v!r} is not a non-empty list of numbers")
            out[k] = tuple(check_number(x, {}, f"{where}.{k}") for x in v)
        else:
            out[k] = check_number(v, {"ge": 0} if k in ("duration", "frequency") else {}, f"{where}.{k}")
    if kind == "table":
        if len(out["times"]) != len(out["values"]):
            raise ConfigError(f"{where}: times and values must have the same length")
        if any(b <= a for a, b in zip(out["times"][:-1], out["times"][1:], strict=True)):
            raise ConfigError(f"{where}.times: {list(out['times'])!r} must increase strictly")
    return make_law(kind, **out)
