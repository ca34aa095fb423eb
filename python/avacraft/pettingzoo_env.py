"""A PettingZoo `ParallelEnv` over AVACraft's engine, in the paper's four observation modes.

Every agent's observation is a dict with the SMAC action mask under `"action_mask"` (int8,
as `gymnasium.spaces.Discrete.sample(mask=...)` takes it) and, by mode:

- `"features"`: `"observation"` = the agent's SMAC feature vector (float32);
- `"rgb"`: `"observation"` = the team's screen (H x W x 3 uint8), `"minimap"` likewise;
- `"hybrid"`: `"observation"` = features, `"screen"` = the team's screen;
- `"vlm"`: `"observation"` = the annotated screenshot (H x W x 3 uint8), `"text"` = the
  battlefield description, `"units"` = the unit list (a list of dicts, `avacraft.UnitInfo`).

Actions are SMAC indices (`Discrete(n_actions)`). Agents are `agent_<i>` in PvE; in PvP both
teams play, as `team1_agent_<i>` and `team2_agent_<i>`. Dead agents leave `agents`.
"""

from __future__ import annotations

import random
from typing import Any, Optional

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover - exercised on machines without the extra
    raise ImportError(
        "avacraft.parallel_env needs pettingzoo and gymnasium: python3 -m pip install 'pettingzoo>=1.24' gymnasium "
        "(or install avacraft with its extra: python3 -m pip install './python[pettingzoo]')"
    ) from e

from . import _options as opt
from ._avacraft import AvacraftError, Env

OBS_MODES = ("features", "rgb", "hybrid", "vlm")
INVALID_ACTIONS = ("stop", "raise")


class UnitListSpace(gymnasium.Space):
    """The VLM unit list: a list of dicts (`avacraft.UnitInfo`). Not sampleable."""

    def __init__(self) -> None:
        super().__init__(None, None)

    def contains(self, x: Any) -> bool:
        return isinstance(x, list) and all(isinstance(u, dict) and "tag" in u for u in x)

    def sample(self, mask: Any = None, probability: Any = None) -> list:
        return []

    @property
    def is_np_flattenable(self) -> bool:
        return False


class AvacraftParallelEnv(ParallelEnv):
    metadata = {"render_modes": ["rgb_array"], "name": "avacraft_v0", "is_parallelizable": True}

    def __init__(
        self,
        scenario: str = "3m_vlm",
        obs_mode: str = "features",
        opponent: Optional[str] = None,
        seed: Optional[int] = None,
        *,
        step_mul: int = 8,
        reward: str = "sparse",
        full_vision: bool = False,
        passive_allies: bool = False,
        cooldown_jitter: bool = True,
        abilities: bool = True,
        ability_actions: bool = False,
        time_limit_loops: Optional[int] = None,
        prob_obs_enemy: float = 1.0,
        action_mask: bool = True,
        conic_fov: bool = False,
        num_fov_actions: int = 12,
        data: Optional[str] = None,
        weapon_period: str = "attack",
        melee_surround: bool = False,
        reward_only_positive: bool = True,
        reward_negative_scale: float = 0.5,
        reward_death_value: float = 10,
        reward_win: float = 200,
        reward_defeat: float = 0,
        reward_scale: bool = True,
        reward_scale_rate: float = 20,
        state_agent: bool = False,
        screen_size: tuple[int, int] = (160, 120),
        minimap_size: tuple[int, int] = (32, 32),
        vlm_size: tuple[int, int] = (1920, 1080),
        invalid_action: str = "stop",
        render_mode: Optional[str] = None,
    ) -> None:
        if obs_mode not in OBS_MODES:
            raise opt.unsupported("obs_mode", obs_mode, "one of " + ", ".join(OBS_MODES))
        if reward not in ("sparse", "dense"):
            raise opt.unsupported("reward", reward, "'sparse' (+1/-1/0, the paper's) or 'dense' (SMAC's shaped reward)")
        if invalid_action not in INVALID_ACTIONS:
            raise opt.unsupported(
                "invalid_action", invalid_action, "'stop' (an unavailable action becomes stop, flagged in infos) or 'raise'"
            )
        if render_mode not in (None, "rgb_array"):
            raise opt.unsupported("render_mode", render_mode, "None or 'rgb_array'")
        for name, size in (("screen_size", screen_size), ("minimap_size", minimap_size), ("vlm_size", vlm_size)):
            if not (isinstance(size, (tuple, list)) and len(size) == 2):
                raise opt.unsupported(name, size, "(width, height)")
            opt.positive_int(name, size[0])
            opt.positive_int(name, size[1])
        self.scenario, self.obs_mode, self.invalid_action, self.render_mode = scenario, obs_mode, invalid_action, render_mode
        self.screen_size, self.minimap_size, self.vlm_size = tuple(screen_size), tuple(minimap_size), tuple(vlm_size)
        self._base_seed = opt.seed("seed", seed)
        self._env = Env(
            scenario,
            seed=self._base_seed or 0,
            step_mul=opt.positive_int("step_mul", step_mul),
            reward=reward,
            opponent=opt.opponent(opponent),
            full_vision=opt.boolean("full_vision", full_vision),
            passive_allies=opt.boolean("passive_allies", passive_allies),
            cooldown_jitter=opt.boolean("cooldown_jitter", cooldown_jitter),
            abilities=opt.boolean("abilities", abilities),
            ability_actions=opt.boolean("ability_actions", ability_actions),
            time_limit_loops=None if time_limit_loops is None else opt.positive_int("time_limit_loops", time_limit_loops),
            prob_obs_enemy=opt.probability("prob_obs_enemy", prob_obs_enemy),
            action_mask=opt.boolean("action_mask", action_mask),
            fov_actions=opt.fov_actions(conic_fov, num_fov_actions),
            data=data,
            weapon_period=weapon_period,
            melee_surround=opt.boolean("melee_surround", melee_surround),
            state_agent=opt.boolean("state_agent", state_agent),
            **opt.smac_reward(
                sparse=reward == "sparse",
                only_positive=reward_only_positive,
                negative_scale=reward_negative_scale,
                death_value=reward_death_value,
                win=reward_win,
                defeat=reward_defeat,
                scale=reward_scale,
                scale_rate=reward_scale_rate,
            ),
        )
        self.pvp: bool = self._env.pvp
        self.teams = (1, 2) if self.pvp else (1,)
        self._info = {t: self._env.env_info(t) for t in self.teams}
        names = {t: [self._name(t, i) for i in range(self._info[t]["n_agents"])] for t in self.teams}
        self.possible_agents: list[str] = [a for t in self.teams for a in names[t]]
        # agent -> (team, index within its team)
        self._index = {a: (t, i) for t in self.teams for i, a in enumerate(names[t])}
        self._spaces = {a: (self._obs_space(self._index[a][0]), spaces.Discrete(self._info[self._index[a][0]]["n_actions"])) for a in self.possible_agents}
        state_size = sum(self._info[t]["state_shape"] for t in self.teams)
        self.state_space = spaces.Box(-np.inf, np.inf, (state_size,), np.float32)
        self.agents: list[str] = []
        self._episodes = 0
        self._next_seed: Optional[int] = self._base_seed

    def _name(self, team: int, i: int) -> str:
        return f"team{team}_agent_{i}" if self.pvp else f"agent_{i}"

    def _obs_space(self, team: int) -> spaces.Dict:
        info = self._info[team]
        mask = spaces.Box(0, 1, (info["n_actions"],), np.int8)
        feats = spaces.Box(-np.inf, np.inf, (info["obs_shape"],), np.float32)

        def image(size: tuple[int, int]) -> spaces.Box:
            return spaces.Box(0, 255, (size[1], size[0], 3), np.uint8)

        if self.obs_mode == "features":
            return spaces.Dict({"observation": feats, "action_mask": mask})
        if self.obs_mode == "rgb":
            return spaces.Dict({"observation": image(self.screen_size), "minimap": image(self.minimap_size), "action_mask": mask})
        if self.obs_mode == "hybrid":
            return spaces.Dict({"observation": feats, "screen": image(self.screen_size), "action_mask": mask})
        text = spaces.Text(max_length=1 << 20, min_length=0, charset=frozenset(chr(c) for c in range(32, 127)) | {"\n", "\u00b7"})
        return spaces.Dict({"observation": image(self.vlm_size), "text": text, "units": UnitListSpace(), "action_mask": mask})

    # The same space object on every call (PettingZoo's API test checks it): built once in
    # __init__, so action-space seeding sticks.
    def observation_space(self, agent: str) -> spaces.Dict:
        return self._spaces[agent][0]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._spaces[agent][1]

    # -- episodes -------------------------------------------------------------------------

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None) -> tuple[dict, dict]:
        """A new episode. With `seed`, episodes restart from it (episode k uses `seed + k`);
        without one, the next episode of the current sequence (a random one at first)."""
        if seed is not None:
            self._next_seed = opt.seed("seed", seed)
            self._episodes = 0
        if self._next_seed is None:
            self._next_seed = random.randrange(2**31)
        self._env.reset((self._next_seed + self._episodes) % 2**64)
        self._episodes += 1
        self.agents = list(self.possible_agents)
        obs = self._observe(self.agents)
        infos = {a: {} for a in self.agents}
        return obs, infos

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        if not self.agents:
            raise AvacraftError("every agent is done: call reset() first")
        unknown = [a for a in actions if a not in self._index]
        if unknown:
            raise AvacraftError(f"unknown agents {unknown}: agents are {self.possible_agents}")
        per_team = {}
        flagged: dict[str, int] = {}
        for t in self.teams:
            avail = self._env.avail(t)
            chosen = np.zeros(len(avail), dtype=np.int64)
            for i, mask in enumerate(avail):
                agent = self._name(t, i)
                if agent not in self.agents:
                    chosen[i] = 0  # dead: SMAC's no-op
                    continue
                if agent not in actions:
                    raise AvacraftError(f"no action for {agent}: every live agent needs one ({len(self.agents)} live)")
                a = actions[agent]
                if isinstance(a, (bool, float)) or not isinstance(a, (int, np.integer)) or isinstance(a, np.bool_):
                    raise AvacraftError(f"{agent}: an integer action index is needed, got {a!r}")
                a = int(a)
                if not 0 <= a < len(mask):
                    raise AvacraftError(f"{agent}: action {a} is out of range (0..{len(mask)})")
                if not mask[a]:
                    if self.invalid_action == "raise":
                        raise AvacraftError(f"{agent}: action {a} is not available now (available: {np.flatnonzero(mask).tolist()})")
                    flagged[agent] = a
                    a = 1  # stop: always available to a living unit
                chosen[i] = a
            per_team[t] = chosen
        r1, r2, terminated, truncated, _ = self._env.step(per_team[1], per_team.get(2))
        rewards = {1: r1, 2: r2}
        alive = {t: self._env.alive(t) for t in self.teams}
        live = self.agents
        obs = self._observe(live)
        team_info = {t: self._env.info(t) for t in self.teams}
        rew, term, trunc, infos = {}, {}, {}, {}
        for a in live:
            t, i = self._index[a]
            rew[a] = float(rewards[t])
            term[a] = bool(terminated or not alive[t][i])
            trunc[a] = bool(truncated)
            infos[a] = dict(team_info[t])
            if a in flagged:
                infos[a]["invalid_action"] = flagged[a]
        self.agents = [a for a in live if not (term[a] or trunc[a])]
        return obs, rew, term, trunc, infos

    def _observe(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for t in self.teams:
            mine = [a for a in agents if self._index[a][0] == t]
            if not mine:
                continue
            masks = self._env.avail(t).astype(np.int8)
            shared: dict[str, Any] = {}
            feats = None
            if self.obs_mode in ("features", "hybrid"):
                feats = self._env.obs(t)
            if self.obs_mode == "rgb":
                shared = {"observation": self._env.screen(*self.screen_size, t), "minimap": self._env.minimap(*self.minimap_size, t)}
            elif self.obs_mode == "hybrid":
                shared = {"screen": self._env.screen(*self.screen_size, t)}
            elif self.obs_mode == "vlm":
                shared = {"observation": self._env.screenshot(*self.vlm_size, t), "text": self._env.text(t), "units": self._env.units(t)}
            for a in mine:
                i = self._index[a][1]
                o = dict(shared)
                if feats is not None:
                    o["observation"] = feats[i]
                o["action_mask"] = masks[i]
                out[a] = o
        return out

    def state(self) -> np.ndarray:
        """SMAC's global state of team 1 (in PvP, team 1's then team 2's)."""
        return np.concatenate([self._env.state(t) for t in self.teams]).astype(np.float32, copy=False)

    def render(self) -> Optional[np.ndarray]:
        if self.render_mode == "rgb_array":
            return self._env.screen(*self.screen_size, 1)
        return None

    def close(self) -> None:
        pass

    @property
    def env(self) -> Env:
        """The engine environment underneath (typed actions, text, frames)."""
        return self._env


def parallel_env(scenario: str = "3m_vlm", obs_mode: str = "features", opponent: Optional[str] = None, seed: Optional[int] = None, **kwargs: Any) -> AvacraftParallelEnv:
    """A PettingZoo `ParallelEnv` of `scenario` (see `AvacraftParallelEnv`)."""
    return AvacraftParallelEnv(scenario, obs_mode, opponent, seed, **kwargs)
