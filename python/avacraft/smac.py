"""SMAC's `StarCraft2Env` over AVACraft's engine, so PyMARL/EPyMARL code runs unchanged
(`from avacraft import StarCraft2Env` in place of `from smac.env import StarCraft2Env`).

The method names, return types and info keys are SMAC's (`oxwhirl/smac`,
`smac/env/starcraft2/starcraft2.py`). Every keyword PyMARL's `sc2.yaml` passes is accepted;
a value the engine does not implement raises `AvacraftError` (a `ValueError`) naming it.
"""

from __future__ import annotations

import json
import logging
import os
import random
import time
from typing import Any, Optional

import numpy as np

from . import _options as opt
from ._avacraft import AvacraftError, Env, Snapshot

log = logging.getLogger("avacraft")

# SMAC records its replays at the window size; frames of a GIF this large would be tens of
# megabytes each, so the recording uses a screen of this size (the aspect of 1920x1200).
REPLAY_SIZE = (480, 300)


def _json_scalar(x: Any) -> Any:
    """numpy scalars in typed actions (tags taken from arrays) as plain numbers."""
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"{type(x).__name__} is not a number, string, list or dict")


class StarCraft2Env:
    """SMAC's multi-agent environment on an AVACraft scenario.

    `map_name` is a built-in scenario (`avacraft.scenario_names()`) or a scenario TOML file.
    SMAC's keywords keep SMAC's defaults; AVACraft's own options are keyword-only:

    - `opponent`: the PvE opponent ("builtin", "aggressive", "defensive", "focus",
      "random"; None: the scenario's default, the built-in AI emulation on SMAC's maps).
    - `full_vision`: turn fog of war off (SMAC's features have fog on top of the sight rule).
    - `abilities`: unit abilities in the game (casts, autocasts); `ability_actions`: append
      ability slots to the actions and observations (SMAC has none; off by default).
    - `passive_allies`: SMAC's passive allied units (on by default: `EnvConfig::smac()`).
    - `cooldown_jitter`: StarCraft II's random attack delay (on).
    - `weapon_period`: where a weapon's period is counted from: "attack" (the engine's
      reading, the default) or "shot" (from the damage point: an experiment, docs/smac.md).
    - `melee_surround`: the surround experiment (off): melee units walk round those already
      at their target to a free place beside it (docs/smac.md).
    - `state_agent`: the MAPPO repository's agent-specific state (its `use_state_agent`) in
      place of SMAC's: `get_state()` is every agent's row one after another, each every unit
      as seen from that agent with its own features and id; `get_state_agent(i)` gives one.
    - `episode_limit`: time limit in steps (None: the scenario's); `time_limit_loops` in
      game loops.
    - `prob_obs_enemy`, `action_mask`: SMACv2's extended partial observability (an enemy
      first seen by one agent stays in each teammate's observation with this probability;
      1: off) and its switch for the range mask on attack actions (False: any living enemy
      the team sees may be attacked). SMACv2's EPO configs use 0.0 and False.
    - `conic_fov`, `num_fov_actions`: SMACv2's conic fields of view: `num_fov_actions` look
      actions (even, 12 by default) after the moves turn each agent's view, which then sees
      and attacks only within a cone of 360/num_fov_actions degrees; the look direction
      joins the agent's own features and each ally's state row. The cone is the geometric
      one (SMACv2's slope test also admits points behind an agent looking east or west).
    """

    def __init__(
        self,
        map_name: str = "8m",
        step_mul: int = 8,
        move_amount: int = 2,
        difficulty: str = "7",
        game_version: Optional[str] = None,
        seed: Optional[int] = None,
        continuing_episode: bool = True,
        obs_all_health: bool = True,
        obs_own_health: bool = True,
        obs_last_action: bool = False,
        obs_pathing_grid: bool = False,
        obs_terrain_height: bool = False,
        obs_instead_of_state: bool = False,
        obs_timestep_number: bool = False,
        state_last_action: bool = True,
        state_timestep_number: bool = False,
        reward_sparse: bool = False,
        reward_only_positive: bool = True,
        reward_death_value: float = 10,
        reward_win: float = 200,
        reward_defeat: float = 0,
        reward_negative_scale: float = 0.5,
        reward_scale: bool = True,
        reward_scale_rate: float = 20,
        replay_dir: str = "",
        replay_prefix: str = "",
        window_size_x: int = 1920,
        window_size_y: int = 1200,
        heuristic_ai: bool = False,
        heuristic_rest: bool = False,
        debug: bool = False,
        *,
        data: Optional[str] = None,
        opponent: Optional[str] = None,
        full_vision: bool = False,
        abilities: bool = True,
        ability_actions: bool = False,
        passive_allies: bool = True,
        cooldown_jitter: bool = True,
        episode_limit: Optional[int] = None,
        time_limit_loops: Optional[int] = None,
        prob_obs_enemy: float = 1.0,
        action_mask: bool = True,
        conic_fov: bool = False,
        num_fov_actions: int = 12,
        weapon_period: str = "attack",
        melee_surround: bool = False,
        state_agent: bool = False,
    ) -> None:
        self.map_name = map_name
        self._step_mul = opt.positive_int("step_mul", step_mul)
        opt.require("move_amount", move_amount, [2], "the engine moves 2 units per directional action, as SMAC's default")
        opt.require("difficulty", str(difficulty), ["7"], "the engine emulates the built-in AI at SMAC's difficulty 7 (VeryHard)")
        opt.require("game_version", game_version, [None], "there is no game binary: the engine simulates StarCraft II's unit data itself")
        opt.require("obs_all_health", obs_all_health, [True], "observations always carry every unit's health (SMAC's default)")
        opt.require("obs_own_health", obs_own_health, [True], "observations always carry the agent's own health (SMAC's default)")
        opt.require("obs_last_action", obs_last_action, [False], "allies' last actions are not in the observation (SMAC's default)")
        opt.require("obs_pathing_grid", obs_pathing_grid, [False], "no pathing-grid features (SMAC's default)")
        opt.require("obs_terrain_height", obs_terrain_height, [False], "no terrain-height features (SMAC's default)")
        # SMAC's own script plays the agents (the engine's `smac-heuristic`); step() then
        # takes actions only as SMAC does, for their count.
        self.heuristic_ai = opt.boolean("heuristic_ai", heuristic_ai)
        self.heuristic_rest = opt.boolean("heuristic_rest", heuristic_rest)
        self.reward_sparse = opt.boolean("reward_sparse", reward_sparse)
        reward_options = opt.smac_reward(
            sparse=self.reward_sparse,
            only_positive=reward_only_positive,
            negative_scale=reward_negative_scale,
            death_value=reward_death_value,
            win=reward_win,
            defeat=reward_defeat,
            scale=reward_scale,
            scale_rate=reward_scale_rate,
        )
        # SMAC scales the sparse reward too (+1 or -1 divided by max_reward / rate); the
        # engine's sparse reward is the paper's plain +1 / -1, so that scale is applied here.
        self._sparse_rate = None
        if self.reward_sparse and opt.boolean("reward_scale", reward_scale):
            self._sparse_rate = opt.positive_number("reward_scale_rate", reward_scale_rate)
        self.continuing_episode = opt.boolean("continuing_episode", continuing_episode)
        self.obs_instead_of_state = opt.boolean("obs_instead_of_state", obs_instead_of_state)
        self.obs_timestep_number = opt.boolean("obs_timestep_number", obs_timestep_number)
        self.state_last_action = opt.boolean("state_last_action", state_last_action)
        self.state_timestep_number = opt.boolean("state_timestep_number", state_timestep_number)
        self.state_agent = opt.boolean("state_agent", state_agent)
        if self.state_agent and (self.obs_instead_of_state or not self.state_last_action):
            raise AvacraftError(
                "state_agent=True: the MAPPO repository's agent-specific state carries last actions and is read in place of "
                "the observations; it takes neither obs_instead_of_state=True nor state_last_action=False"
            )
        self.debug = opt.boolean("debug", debug)
        self.window_size = (opt.positive_int("window_size_x", window_size_x), opt.positive_int("window_size_y", window_size_y))
        self.replay_dir = replay_dir or ""
        self.replay_prefix = replay_prefix or ""
        if not isinstance(self.replay_dir, (str, os.PathLike)):
            raise opt.unsupported("replay_dir", replay_dir, "a directory path")
        self._seed = opt.seed("seed", seed)
        if self._seed is None:
            self._seed = random.randrange(2**31)
        if episode_limit is not None and time_limit_loops is not None:
            raise AvacraftError("give episode_limit (steps) or time_limit_loops (game loops), not both")
        if episode_limit is not None:
            time_limit_loops = opt.positive_int("episode_limit", episode_limit) * self._step_mul
        elif time_limit_loops is not None:
            time_limit_loops = opt.positive_int("time_limit_loops", time_limit_loops)
        self._env = Env(
            map_name,
            seed=self._seed,
            step_mul=self._step_mul,
            reward="sparse" if self.reward_sparse else "dense",
            opponent=opt.opponent(opponent),
            full_vision=opt.boolean("full_vision", full_vision),
            passive_allies=opt.boolean("passive_allies", passive_allies),
            cooldown_jitter=opt.boolean("cooldown_jitter", cooldown_jitter),
            abilities=opt.boolean("abilities", abilities),
            ability_actions=opt.boolean("ability_actions", ability_actions),
            time_limit_loops=time_limit_loops,
            prob_obs_enemy=opt.probability("prob_obs_enemy", prob_obs_enemy),
            action_mask=opt.boolean("action_mask", action_mask),
            fov_actions=opt.fov_actions(conic_fov, num_fov_actions),
            data=data,
            weapon_period=weapon_period,
            melee_surround=opt.boolean("melee_surround", melee_surround),
            state_agent=self.state_agent,
            **reward_options,
        )
        info = self._env.env_info(1)
        self.n_agents: int = info["n_agents"]
        self.n_actions: int = info["n_actions"]
        self.episode_limit: int = info["episode_limit"]
        self._obs_size: int = info["obs_shape"]
        self._state_size: int = info["state_shape"]
        self.n_enemies: int = len(self._env.agent_tags(2))
        self._episode_count = 0
        self._episode_steps = 0
        self._total_steps = 0
        self.battles_won = 0
        self.battles_game = 0
        self.timeouts = 0
        self.force_restarts = 0
        if self.replay_dir:
            self._env.record(REPLAY_SIZE)

    # -- episodes -------------------------------------------------------------------------

    def reset(self) -> tuple[list[np.ndarray], np.ndarray]:
        """Starts an episode (episode k of this environment uses seed `seed() + k`);
        returns SMAC's `(get_obs(), get_state())`."""
        self._env.reset((self._seed + self._episode_count) % 2**64)
        self._episode_count += 1
        self._episode_steps = 0
        return self.get_obs(), self.get_state()

    def step(self, actions: Any) -> tuple[float, bool, dict[str, Any]]:
        """One step with one action index per agent (a list, a numpy array or a tensor);
        returns SMAC's `(reward, terminated, info)`. Raises `AvacraftError` naming the agent
        and its available actions for an index out of range or unavailable, and for a wrong
        number of actions; nothing is applied then."""
        if type(actions) is not list and not isinstance(actions, np.ndarray):
            actions = np.asarray(actions)
        if self.heuristic_ai:
            if len(actions) != self.n_agents:
                raise AvacraftError(f"actions: {len(actions)} given, {self.n_agents} agents")
            r, terminated, truncated, info = self._env.step_heuristic(self.heuristic_rest)
            return self._account(r, terminated, truncated, info, actions)
        r, terminated, truncated, info = self._env.step_smac(actions)
        return self._account(r, terminated, truncated, info, actions)

    def get_vlm_obs(self, size: tuple[int, int] = (1920, 1080)) -> dict[str, Any]:
        """What a VLM agent sees: `{"image": HxWx3 uint8 screenshot, "text": str, "units": [dict]}`
        (see `avacraft.UnitInfo` for a unit's keys)."""
        return {"image": self._env.screenshot(size[0], size[1]), "text": self._env.text(), "units": self._env.units()}

    def step_typed(self, actions: list[dict[str, Any]]) -> tuple[float, bool, dict[str, Any]]:
        """A step with typed actions (see `avacraft.Action`), e.g.
        `[{"unit": 1, "command": {"kind": "attack", "target": 4}}]`; units not named keep
        their orders. A malformed action raises `AvacraftError` naming the action and field;
        actions the game refuses are listed in `info["refused"]` as `{index: reason}`."""
        refused = self._env.submit_typed(json.dumps(actions, default=_json_scalar))
        r, _, terminated, truncated, _ = self._env.advance()
        info = self._env.info(1)
        del info["episode_limit"]
        out = self._account(r, terminated, truncated, info, actions)
        out[2]["refused"] = {i: why for i, why in enumerate(refused) if why is not None}
        return out

    def _account(self, r: float, terminated: bool, truncated: bool, info: dict[str, Any], actions: Any) -> tuple[float, bool, dict[str, Any]]:
        self._episode_steps += 1
        self._total_steps += 1
        if terminated or truncated:
            self.battles_game += 1
            if info["battle_won"]:
                self.battles_won += 1
            if truncated:
                self.timeouts += 1
                if self.continuing_episode:
                    info["episode_limit"] = True
        if self._sparse_rate is not None and r != 0:
            r = r / (self._env.max_reward(1) / self._sparse_rate)
        if self.debug:
            log.debug("step %d: actions %s reward %.4f info %s", self._episode_steps, actions, r, info)
        return r, terminated or truncated, info

    # -- observations ---------------------------------------------------------------------

    def get_obs(self) -> list[np.ndarray]:
        """Every agent's observation (float32 vectors of `get_obs_size()`)."""
        if self.obs_timestep_number:
            t = np.full((self.n_agents, 1), self._episode_steps / self.episode_limit, dtype=np.float32)
            return list(np.concatenate([self._env.obs(1), t], axis=1))
        return self._env.obs_list(1)

    def get_obs_agent(self, agent_id: int) -> np.ndarray:
        obs = self._env.obs_agent(agent_id)
        if self.obs_timestep_number:
            obs = np.append(obs, np.float32(self._episode_steps / self.episode_limit))
        return obs

    def get_obs_size(self) -> int:
        return self._obs_size + int(self.obs_timestep_number)

    def get_state(self) -> np.ndarray:
        """SMAC's global state (float32, `get_state_size()`). With `state_agent=True`, the MAPPO
        repository's agent-specific state: every agent's row one after another (`get_state_agent`
        gives one)."""
        if self.obs_instead_of_state:
            return np.concatenate(self.get_obs(), axis=0).astype(np.float32)
        state = self._env.state(1)
        if not self.state_last_action:
            state = state[: self._state_size - self.n_agents * self.n_actions]
        if self.state_timestep_number:
            state = np.append(state, np.float32(self._episode_steps / self.episode_limit))
        return state

    def get_state_agent(self, agent_id: int) -> np.ndarray:
        """Agent `agent_id`'s row of the agent-specific state (`state_agent=True`; the MAPPO
        repository's `get_state_agent`, without its timestep feature)."""
        if not self.state_agent:
            raise AvacraftError("get_state_agent: this environment was made without state_agent=True")
        if isinstance(agent_id, bool) or not isinstance(agent_id, (int, np.integer)) or not 0 <= agent_id < self.n_agents:
            raise opt.unsupported("agent_id", agent_id, f"an agent index from 0 to {self.n_agents - 1}")
        i = int(agent_id)
        w = self._state_size // self.n_agents
        return self._env.state(1)[i * w : (i + 1) * w]

    def get_state_size(self) -> int:
        if self.obs_instead_of_state:
            return self.get_obs_size() * self.n_agents
        size = self._state_size
        if not self.state_last_action:
            size -= self.n_agents * self.n_actions
        return size + int(self.state_timestep_number)

    def get_avail_actions(self) -> list[list[int]]:
        return self._env.avail(1).tolist()

    def get_avail_agent_actions(self, agent_id: int) -> list[int]:
        return self._env.avail_agent(agent_id).tolist()

    def get_total_actions(self) -> int:
        return self.n_actions

    def get_env_info(self) -> dict[str, int]:
        return {
            "state_shape": self.get_state_size(),
            "obs_shape": self.get_obs_size(),
            "n_actions": self.n_actions,
            "n_agents": self.n_agents,
            "episode_limit": self.episode_limit,
        }

    def get_stats(self) -> dict[str, float]:
        """SMAC's running statistics (PyMARL logs them)."""
        return {
            "battles_won": self.battles_won,
            "battles_game": self.battles_game,
            "battles_draw": self.timeouts,
            "win_rate": self.battles_won / self.battles_game if self.battles_game else 0.0,
            "timeouts": self.timeouts,
            "restarts": self.force_restarts,
        }

    # -- the rest of SMAC's interface -----------------------------------------------------

    def render(self, mode: str = "human") -> np.ndarray:
        """`mode="rgb_array"`: the whole battlefield as team 1 sees it, a
        `window_size_y x window_size_x x 3` uint8 array."""
        if mode == "rgb_array":
            return self._env.screen(self.window_size[0], self.window_size[1])
        if mode == "human":
            raise NotImplementedError("render(mode='human') needs a window; AVACraft renders off-screen: use render(mode='rgb_array')")
        raise opt.unsupported("mode", mode, "'rgb_array' (or 'human', which is not implemented)")

    def close(self) -> None:
        """Nothing to shut down: there is no game process."""

    def seed(self, seed: Optional[int] = None) -> int:
        """SMAC's `seed()` returns the seed; with an argument it sets the seed the next
        episodes start from (episode k after it uses `seed + k`)."""
        if seed is not None:
            self._seed = opt.seed("seed", seed)
            self._episode_count = 0
        return self._seed

    def save_replay(self) -> str:
        """Writes the last episode as an animated GIF in `replay_dir` (SMAC writes an
        SC2Replay there); returns its path."""
        if not self.replay_dir:
            raise AvacraftError("save_replay() needs replay_dir: pass StarCraft2Env(..., replay_dir='some/dir') so frames are recorded")
        os.makedirs(self.replay_dir, exist_ok=True)
        stamp = time.strftime("%Y-%m-%d-%H-%M-%S")
        prefix = self.replay_prefix or str(self.map_name).replace(os.sep, "_")
        path = os.path.join(self.replay_dir, f"{prefix}_{stamp}_{self._episode_count}.gif")
        frames = self._env.save_video(path, 100)
        log.info("replay saved to %s (%d frames)", path, frames)
        return path

    def snapshot(self) -> tuple[Snapshot, int, int]:
        """A copy of the episode to come back to with `restore` (look-ahead, forks)."""
        return (self._env.snapshot(), self._episode_steps, self._episode_count)

    def restore(self, snap: tuple[Snapshot, int, int]) -> None:
        s, steps, count = snap
        self._env.restore(s)
        self._episode_steps, self._episode_count = steps, count

    def full_restart(self) -> None:
        self._episode_count = 0

    @property
    def env(self) -> Env:
        """The engine environment underneath (VLM observations, typed actions, frames)."""
        return self._env

    def __repr__(self) -> str:
        return f"StarCraft2Env(map_name={self.map_name!r}, n_agents={self.n_agents}, n_actions={self.n_actions})"
