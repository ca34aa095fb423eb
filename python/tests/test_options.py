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


def test_the_wrappers_take_every_option():
    """`avacraft.VecEnv`, the PettingZoo env and `StarCraft2Env` name each engine option as a
    keyword (their own spelling where SMAC's or a friendlier one differs), so none is out of a
    wrapper's reach."""
    from avacraft.pettingzoo_env import AvacraftParallelEnv
    from avacraft.smac import StarCraft2Env
    from avacraft.vector import VecEnv

    # The wrappers' spellings of options they take under another name or as two keywords.
    spelled = {"reward": {"reward", "reward_sparse"}, "fov_actions": {"conic_fov", "num_fov_actions"}}
    for cls in (VecEnv, AvacraftParallelEnv, StarCraft2Env):
        params = set(inspect.signature(cls).parameters)
        for name in NAMES:
            if name == "time_limit_loops" or name == "step_mul":
                assert name in params or cls is StarCraft2Env, (cls.__name__, name)
                continue
            assert params & spelled.get(name, {name}), f"{cls.__name__} has no keyword for the engine option {name!r}"


def test_the_vector_and_pettingzoo_envs_play_the_options_game():
    """The experiments reach the game through the wrappers: corridor under the surround, or with
    weapon periods from the shot, plays other games than under the engine's defaults (the Void
    data gives its Zealots and Zerglings Liberty's numbers, so it is checked by its error), and a
    bad value is named."""
    import numpy as np
    import pytest

    from avacraft.pettingzoo_env import AvacraftParallelEnv
    from avacraft.vector import VecEnv

    def states(**kw):
        env = VecEnv("corridor", seeds=[5], threads=1, opponent="focus", passive_allies=False, **kw)
        _, _, avail = env.reset()
        out = []
        for _ in range(30):
            # Stop where it is available (the Zealots stand and the Zerglings come), else no-op.
            acts = np.where(np.asarray(avail)[..., 1] > 0, 1, 0).astype(np.int64)
            obs, _, avail, *_ = env.step(acts)
            out.append(np.asarray(obs).copy())
        return np.stack(out)

    base = states()
    assert not np.array_equal(base, states(weapon_period="shot"))
    assert not np.array_equal(base, states(melee_surround=True))
    assert np.array_equal(base, states()) and np.array_equal(base, states(data="liberty"))
    with pytest.raises(_avacraft.AvacraftError, match="data"):
        VecEnv("corridor", num_envs=1, data="brood_war")
    with pytest.raises(_avacraft.AvacraftError, match="melee_surround"):
        VecEnv("corridor", num_envs=1, melee_surround="yes")
    with pytest.raises(_avacraft.AvacraftError, match="weapon_period"):
        AvacraftParallelEnv("corridor", obs_mode="features", weapon_period="later")
