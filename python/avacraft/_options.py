"""Checking SMAC's and AVACraft's options: a value the engine does not implement raises a
ValueError naming the option, the value and what is supported, so no option is ever ignored
silently (a PyMARL config asking for something else fails loudly instead of training on a
different problem)."""

from __future__ import annotations

from typing import Any, Iterable

from ._avacraft import AvacraftError

OPPONENTS = ("builtin", "aggressive", "defensive", "focus", "random")


def unsupported(option: str, value: Any, supported: str) -> AvacraftError:
    return AvacraftError(f"{option}={value!r} is not supported: {supported}")


def require(option: str, value: Any, allowed: Iterable[Any], why: str) -> None:
    """`value` must equal one of `allowed` (compared with ==; ints and floats alike)."""
    allowed = list(allowed)
    for a in allowed:
        if type(a) is bool or type(value) is bool:
            if type(a) is type(value) and a == value:
                return
        elif a == value:
            return
    shown = ", ".join(repr(a) for a in allowed)
    raise unsupported(option, value, f"{why} (supported: {shown})")


def positive_int(option: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise unsupported(option, value, "a positive integer is needed")
    return value


def positive_number(option: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise unsupported(option, value, "a positive number is needed")
    return float(value)


def probability(option: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= 1:
        raise unsupported(option, value, "a probability in [0, 1]")
    return float(value)


def fov_actions(conic_fov: Any, num_fov_actions: Any) -> int:
    """SMACv2's `conic_fov` and `num_fov_actions` as the engine's look-action count (0: off)."""
    if not boolean("conic_fov", conic_fov):
        return 0
    n = num_fov_actions
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= 64 or n % 2:
        raise unsupported("num_fov_actions", n, "with conic_fov, an even number of look actions from 2 to 64 (SMACv2's default 12)")
    return n


def boolean(option: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise unsupported(option, value, "True or False")
    return value


def opponent(value: Any) -> str | None:
    if value is None:
        return None
    if value not in OPPONENTS:
        raise unsupported("opponent", value, "one of " + ", ".join(OPPONENTS) + " (or None: the scenario's default)")
    return value


def seed(option: str, value: Any) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
        raise unsupported(option, value, "an integer in 0..2**64 or None")
    return value


def number(option: str, value: Any) -> float:
    """Any real number (the engine refuses the ones it cannot use, naming the option)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise unsupported(option, value, "a number")
    return float(value)


def smac_reward(
    *, sparse: bool, only_positive: Any, negative_scale: Any, death_value: Any, win: Any, defeat: Any, scale: Any, scale_rate: Any
) -> dict[str, Any]:
    """SMAC's reward keywords, type-checked, as the engine's options of the same names (the
    engine refuses values it cannot use, naming them). Under the sparse reward SMAC reads none
    of the dense settings, so they are left at the engine's defaults there."""
    values = {
        "reward_only_positive": boolean("reward_only_positive", only_positive),
        "reward_negative_scale": number("reward_negative_scale", negative_scale),
        "reward_death_value": number("reward_death_value", death_value),
        "reward_win": number("reward_win", win),
        "reward_defeat": number("reward_defeat", defeat),
        "reward_scale": boolean("reward_scale", scale),
        "reward_scale_rate": number("reward_scale_rate", scale_rate),
    }
    return {} if sparse else values
