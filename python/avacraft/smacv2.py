"""SMACv2's `StarCraftCapabilityEnvWrapper` over AVACraft's procedural scenarios, so SMACv2
code and EPyMARL's `sc2v2` runner work unchanged:

    from avacraft import StarCraftCapabilityEnvWrapper
    env = StarCraftCapabilityEnvWrapper(capability_config=cfg, map_name="10gen_protoss")

or, for code that imports SMACv2 itself (`from smacv2.env.starcraft2.wrapper import ...`):

    import avacraft.smacv2
    avacraft.smacv2.install()   # registers the `smacv2` module names

`capability_config` is SMACv2's (the content of its `sc2_gen_*.yaml` files): `n_units`,
`n_enemies`, `team_gen` (`weighted_teams`: `unit_types`, `weights`,
`exception_unit_types`, `observe`) and `start_positions` (`surrounded_and_reflect` with
`p`, `reflect_position` or `surrounded`; `map_x`, `map_y`). The config becomes a scenario
file's `[generate]` table, and the engine draws each episode's teams and start positions
from the episode's seed (SMACv2 draws from unseeded generators): an episode replays from
its seed, in Python as in Rust and deployed. The config dict is not modified.

Extended partial observability (`prob_obs_enemy`, with `action_mask=False` as SMACv2's
`sc2_gen_*_epo.yaml`) follows SMACv2's rules with one change: where an agent may not
observe an enemy, only that enemy's row of its observation is zeroed (SMACv2 zeroes every
enemy row built before it, oxwhirl/smacv2#50), and its draws come from the episode's seed.

Conic fields of view (`conic_fov`, `num_fov_actions`) follow SMACv2's actions and features,
with the geometric cone (see `avacraft.StarCraft2Env`).

Differences from SMACv2, each refused with a message when asked for: no stochastic
`attack` or `health` capabilities, and no `enemy_mask`.
"""

from __future__ import annotations

import json
import sys
import types
from typing import Any

import numpy as np

from ._avacraft import AvacraftError
from .smac import StarCraft2Env

# SMACv2's unit names and their one-hot order per race (`get_unit_type_id` on 10gen maps).
_RACES = {
    "protoss": ["stalker", "zealot", "colossus"],
    "terran": ["marine", "marauder", "medivac"],
    "zerg": ["zergling", "hydralisk", "baneling"],
}
_CAPITAL = {n: n.capitalize() for race in _RACES.values() for n in race}
_POSITIONS = {"surrounded_and_reflect", "reflect_position", "surrounded"}
# SMACv2's keywords with the only value the engine implements, and why.
_FIXED = {
    "fully_observable": (False, "observations follow each unit's sight"),
    "use_unit_ranges": (True, "procedural scenarios use each unit's own sight and shoot ranges (SMACv2's setting)"),
    "obs_own_pos": (True, "procedural scenarios' observations carry the agent's position (SMACv2's setting)"),
}


def _err(field: str, value: Any, expected: str) -> AvacraftError:
    return AvacraftError(f"capability_config{field} = {value!r}: {expected}")


def scenario_toml(capability_config: dict[str, Any], map_name: str = "10gen_protoss") -> str:
    """The scenario file (TOML text) SMACv2's `capability_config` describes on `map_name`."""
    if not isinstance(capability_config, dict):
        raise _err("", capability_config, "a dict (the capability_config of SMACv2's sc2_gen_*.yaml)")
    if not isinstance(map_name, str) or not map_name.startswith("10gen_") or map_name[6:] not in _RACES:
        raise AvacraftError(f"map_name = {map_name!r}: one of " + ", ".join(f"10gen_{r}" for r in _RACES))
    race = map_name[6:]
    known = {"n_units", "n_enemies", "team_gen", "start_positions"}
    for key in capability_config:
        if key in ("attack", "health", "enemy_mask"):
            raise _err(f"[{key!r}]", capability_config[key], "stochastic capabilities and enemy masks are not implemented")
        if key not in known:
            raise _err(f"[{key!r}]", capability_config[key], "unknown key (known: " + ", ".join(sorted(known)) + ")")
    n = {}
    for key in ("n_units", "n_enemies"):
        v = capability_config.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise _err(f"[{key!r}]", v, "a team size, 1 or more (SMACv2 needs it at the top level)")
        n[key] = v
    team = capability_config.get("team_gen")
    if not isinstance(team, dict):
        raise _err("['team_gen']", team, "a dict with dist_type 'weighted_teams'")
    if team.get("dist_type") != "weighted_teams":
        raise _err("['team_gen']['dist_type']", team.get("dist_type"), "'weighted_teams' (the only team distribution implemented)")
    names, weights = team.get("unit_types"), team.get("weights")
    if not isinstance(names, (list, tuple)) or not names:
        raise _err("['team_gen']['unit_types']", names, "a list of unit names")
    if not isinstance(weights, (list, tuple, np.ndarray)) or len(weights) != len(names):
        raise _err("['team_gen']['weights']", weights, f"one weight per unit type ({len(names)})")
    for i, u in enumerate(names):
        if u not in _RACES[race]:
            raise _err(f"['team_gen']['unit_types'][{i}]", u, f"a {race} unit of SMACv2: " + ", ".join(_RACES[race]))
    if team.get("observe", True) is not True:
        raise _err("['team_gen']['observe']", team.get("observe"), "True: unit types are always in the observation")
    exceptions = team.get("exception_unit_types", [])
    for i, u in enumerate(exceptions):
        if u not in _CAPITAL:
            raise _err(f"['team_gen']['exception_unit_types'][{i}]", u, "a SMACv2 unit name")
    # The type bits follow SMACv2's order for the race, whatever order the config lists.
    by_name = dict(zip(names, weights))
    order = [u for u in _RACES[race] if u in by_name]
    start = capability_config.get("start_positions", {"dist_type": "surrounded_and_reflect", "p": 0.5})
    if not isinstance(start, dict) or start.get("dist_type") not in _POSITIONS:
        raise _err("['start_positions']", start, "a dict with dist_type " + ", ".join(sorted(_POSITIONS)))
    size = []
    for key in ("map_x", "map_y"):
        v = start.get(key, 32)
        if isinstance(v, bool) or not isinstance(v, int) or not 8 <= v <= 512:
            raise _err(f"['start_positions'][{key!r}]", v, "a map size in cells, 8 to 512")
        size.append(v)
    lines = [
        f'name = "{map_name}_{n["n_units"]}_vs_{n["n_enemies"]}"',
        'mode = "pve"',
        f'description = "SMACv2 capability config on {map_name}."',
        f'source = "smacv2:{map_name}"',
        # SMACv2's maps depend on Mods/Liberty.SC2Mod: they run the Liberty unit data.
        'data = "liberty"',
        f"map_size = [{size[0]}, {size[1]}]",
        # SMACv2's episode limit on 10gen maps: 200 steps of 8 game loops.
        "time_limit_s = 71.4286",
        "units = []",
        "",
        "[generate]",
        f'n_units = {n["n_units"]}',
        f'n_enemies = {n["n_enemies"]}',
        "unit_types = " + json.dumps([_CAPITAL[u] for u in order]),
        "weights = " + json.dumps([float(by_name[u]) for u in order]),
        "exception_unit_types = " + json.dumps([_CAPITAL[u] for u in exceptions]),
    ]
    kind = start["dist_type"]
    lines.append(f'start_positions = "{"reflect" if kind == "reflect_position" else kind}"')
    if kind == "surrounded_and_reflect":
        p = start.get("p", 0.5)
        if isinstance(p, bool) or not isinstance(p, (int, float)):
            raise _err("['start_positions']['p']", p, "a probability in [0, 1]")
        lines.append(f"p = {float(p)!r}")
    return "\n".join(lines) + "\n"


class StarCraftCapabilityEnvWrapper:
    """SMACv2's wrapper: `StarCraftCapabilityEnvWrapper(capability_config=..., map_name=...,
    **StarCraft2Env keywords)`. Every method of `avacraft.StarCraft2Env` is reachable, as
    SMACv2's wrapper forwards to its env; `get_env_info()` adds `cap_shape`,
    `agent_features` and `enemy_features`, and `get_capabilities()` the unit-type one-hots."""

    def __init__(self, **kwargs: Any) -> None:
        if "capability_config" not in kwargs:
            raise AvacraftError("StarCraftCapabilityEnvWrapper needs capability_config= (SMACv2's team_gen and start_positions)")
        config = kwargs.pop("capability_config")
        map_name = kwargs.pop("map_name", "10gen_protoss")
        for key, (value, why) in _FIXED.items():
            if key in kwargs and kwargs.pop(key) is not value:
                raise AvacraftError(f"{key} must be {value}: {why}")
        attack_range = kwargs.pop("min_attack_range", 2)
        if attack_range != 2:
            raise AvacraftError(f"min_attack_range = {attack_range!r}: only 2 (SMACv2's default)")
        step = kwargs.pop("kill_unit_step_mul", 2)
        if isinstance(step, bool) or not isinstance(step, int) or step < 1:
            raise AvacraftError(f"kill_unit_step_mul = {step!r}: a number of game steps, 1 or more")
        kwargs.setdefault("continuing_episode", False)
        self.capability_config = config
        self.map_name = map_name
        self.env = StarCraft2Env(map_name=scenario_toml(config, map_name), **kwargs)
        self.env.map_name = map_name
        info = self.env.env.env_info(1)
        listed = set(config["team_gen"]["unit_types"])
        self._types: list[str] = [u for u in _RACES[map_name[6:]] if u in listed]
        self._shield = map_name == "10gen_protoss"
        self._fov = bool(kwargs.get("conic_fov", False))
        self.n_agents = info["n_agents"]
        self.n_enemies = config["n_enemies"]

    def __getattr__(self, name: str) -> Any:
        # As SMACv2's wrapper: anything else is the environment's.
        if name == "env":
            raise AttributeError(name)
        return getattr(self.env, name)

    def reset(self) -> tuple[list[np.ndarray], np.ndarray]:
        """A new episode, its teams and start positions drawn from its seed; `(obs, state)`."""
        return self.env.reset()

    def step(self, actions: Any) -> tuple[float, bool, dict[str, Any]]:
        return self.env.step(actions)

    def get_cap_size(self) -> int:
        return len(self._types)

    def get_capabilities_agent(self, agent_id: int) -> np.ndarray:
        """The agent's unit type as a one-hot in SMACv2's order (its capability features)."""
        obs = self.env.get_obs_agent(agent_id)
        tb = len(self._types)
        return np.asarray(obs[-tb:], dtype=np.float32)

    def get_capabilities(self) -> np.ndarray:
        return np.concatenate([self.get_capabilities_agent(a) for a in range(self.n_agents)]).astype(np.float32)

    def _ally_features(self) -> list[str]:
        names = ["health", "energy/cooldown", "rel_x", "rel_y"]
        fov = ["fov_x", "fov_y"] if self._fov else []
        return names + (["shield"] if self._shield else []) + fov + [f"type_{i}" for i in range(len(self._types))]

    def _enemy_features(self) -> list[str]:
        names = ["health", "rel_x", "rel_y"]
        return names + (["shield"] if self._shield else []) + [f"type_{i}" for i in range(len(self._types))]

    def get_obs_feature_names(self) -> list[str]:
        tb = [f"type_{i}" for i in range(len(self._types))]
        sh = ["shield"] if self._shield else []
        names = [f"move_{d}" for d in ("north", "south", "east", "west")]
        for e in range(self.n_enemies):
            names += [f"enemy_{e}_{f}" for f in ["available_to_attack", "distance", "relative_x", "relative_y", "health", *sh, *tb]]
        for a in range(self.n_agents - 1):
            names += [f"ally_{a}_{f}" for f in ["visible", "distance", "relative_x", "relative_y", "health", *sh, *tb]]
        fov = ["fov_x", "fov_y"] if self._fov else []
        names += [f"own_{f}" for f in ["health", *sh, "pos_x", "pos_y", *fov, *tb]]
        return names

    def get_state_feature_names(self) -> list[str]:
        names = [f"ally_{a}_{f}" for a in range(self.n_agents) for f in self._ally_features()]
        names += [f"enemy_{e}_{f}" for e in range(self.n_enemies) for f in self._enemy_features()]
        names += [f"ally_{a}_last_action_{i}" for a in range(self.n_agents) for i in range(self.env.n_actions)]
        return names

    def get_env_info(self) -> dict[str, Any]:
        info: dict[str, Any] = dict(self.env.get_env_info())
        info["cap_shape"] = self.get_cap_size()
        info["agent_features"] = self._ally_features()
        info["enemy_features"] = self._enemy_features()
        return info

    def __repr__(self) -> str:
        return f"StarCraftCapabilityEnvWrapper(map_name={self.map_name!r}, n_agents={self.n_agents}, n_enemies={self.n_enemies})"


def install() -> None:
    """Registers `smacv2`, `smacv2.env` and `smacv2.env.starcraft2.wrapper` as this module's
    names, so code written against SMACv2 (EPyMARL's `smacv2_wrapper.py`) imports AVACraft
    unchanged. Refuses if the real SMACv2 is already imported."""
    real = sys.modules.get("smacv2")
    if real is not None and not getattr(real, "__avacraft__", False):
        raise AvacraftError("the real smacv2 package is already imported: install() would shadow it")
    names = ["smacv2", "smacv2.env", "smacv2.env.starcraft2", "smacv2.env.starcraft2.wrapper", "smacv2.env.starcraft2.starcraft2"]
    for name in names:
        m = types.ModuleType(name, f"AVACraft's stand-in for {name}")
        m.__avacraft__ = True  # type: ignore[attr-defined]
        m.StarCraftCapabilityEnvWrapper = StarCraftCapabilityEnvWrapper  # type: ignore[attr-defined]
        m.StarCraft2Env = StarCraft2Env  # type: ignore[attr-defined]
        sys.modules[name] = m
    for parent, child in zip(names, names[1:]):
        setattr(sys.modules[parent], child.rsplit(".", 1)[1], sys.modules[child])


__all__ = ["StarCraftCapabilityEnvWrapper", "install", "scenario_toml"]
