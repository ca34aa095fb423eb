"""The environment options are the engine's `EnvOptions`, written once: both constructors of the
compiled module (and their type stubs) take exactly its fields, in its order, with its
defaults, so an option added to the engine cannot be left out of one of them."""

from __future__ import annotations

import ast
import inspect
import json
from pathlib import Path

from avacraft import _avacraft

NAMES, DEFAULTS = _avacraft.env_options()
DEFAULTS = json.loads(DEFAULTS)


def options_of(params: list[inspect.Parameter], lead: list[str]) -> list[inspect.Parameter]:
    names = [p.name for p in params]
    assert names[: len(lead)] == lead, names
    return params[len(lead) :]


def test_names_are_the_engine_fields():
    assert NAMES == list(DEFAULTS), "EnvOptions::NAMES and its serde fields differ"
    assert "step_mul" in NAMES and "data" in NAMES


def test_both_constructors_take_the_options_with_their_defaults():
    for cls, lead in ((_avacraft.Env, ["scenario", "seed"]), (_avacraft.VecEnv, ["scenario", "seeds", "threads"])):
        params = options_of(list(inspect.signature(cls).parameters.values()), lead)
        assert [p.name for p in params] == NAMES, cls.__name__
        for p in params:
            want = DEFAULTS[p.name]
            assert p.default == want, f"{cls.__name__}({p.name}={p.default!r}): the engine's default is {want!r}"


def test_the_stubs_list_the_same_options():
    stub = ast.parse((Path(_avacraft.__file__).parent / "_avacraft.pyi").read_text())
    seen = {}
    for node in stub.body:
        if isinstance(node, ast.ClassDef) and node.name in ("Env", "VecEnv"):
            init = next(f for f in node.body if isinstance(f, ast.FunctionDef) and f.name == "__init__")
            seen[node.name] = [a.arg for a in init.args.args[1:]]
    assert seen["Env"] == ["scenario", "seed", *NAMES]
    assert seen["VecEnv"] == ["scenario", "seeds", "threads", *NAMES]


def test_a_bad_option_is_named():
    import pytest

    with pytest.raises(_avacraft.AvacraftError, match="data"):
        _avacraft.Env("3m", data="brood_war")
    with pytest.raises(_avacraft.AvacraftError, match="reward"):
        _avacraft.Env("3m", reward="shaped")
    with pytest.raises(_avacraft.AvacraftError, match="weapon_period"):
        _avacraft.Env("3m", weapon_period="later")
