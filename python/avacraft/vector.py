"""Many environments of one scenario stepped together on a thread pool, for throughput.

Results are numpy arrays, environment-major. A finished environment restarts on its own:
the arrays after such a step hold the new episode's first observation, while `reward`,
`terminated`, `truncated` and the info arrays describe the step that ended the old one.
The GIL is released while the environments step, and the results depend on the seed list
only, never on the number of threads.

This is Gymnasium's same-step autoreset (`metadata["autoreset_mode"]`, Gymnasium 1.1+): on a
step that ended episodes, `info` also holds `final_obs`, `final_state` and `final_avail`
(what they ended on, valid where `info["_final_obs"]` is true), which a learner bootstraps a
time-out from.
"""

from __future__ import annotations

from typing import Any, Optional, Sequence

import numpy as np

from . import _options as opt
from ._avacraft import AvacraftError
from ._avacraft import VecEnv as _RawVecEnv

try:  # Gymnasium 1.1+ names the autoreset modes; without it, the mode's name as a string.
    from gymnasium.vector import AutoresetMode

    _SAME_STEP: Any = AutoresetMode.SAME_STEP
except ImportError:  # pragma: no cover - gymnasium is an optional dependency
    _SAME_STEP = "SameStep"


class VecEnv:
    """`VecEnv("3m_vlm", num_envs=64)` or `VecEnv("3m_vlm", seeds=[...])`; `threads=None` uses every
    core. Options are `StarCraft2Env`'s AVACraft options and SMAC's reward keywords (dense reward
    and SMAC's passive allies by default, as `StarCraft2Env`; `reward_scale` scales the dense
    reward only)."""

    metadata: dict[str, Any] = {"autoreset_mode": _SAME_STEP}

    def __init__(
        self,
        map_name: str,
        num_envs: Optional[int] = None,
        seeds: Optional[Sequence[int]] = None,
        threads: Optional[int] = None,
        *,
        seed: int = 0,
        step_mul: int = 8,
        reward_sparse: bool = False,
        opponent: Optional[str] = None,
        full_vision: bool = False,
        passive_allies: bool = True,
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
    ) -> None:
        if seeds is None:
            if num_envs is None:
                raise AvacraftError("give num_envs or seeds")
            n = opt.positive_int("num_envs", num_envs)
            base = opt.seed("seed", seed) or 0
            seeds = [base + i for i in range(n)]
        else:
            seeds = [opt.seed("seeds", s) for s in seeds]
            if num_envs is not None and num_envs != len(seeds):
                raise AvacraftError(f"num_envs={num_envs} but {len(seeds)} seeds given")
        if threads is not None:
            opt.positive_int("threads", threads)
        self._raw = _RawVecEnv(
            map_name,
            list(seeds),
            threads,
            step_mul=opt.positive_int("step_mul", step_mul),
            reward="sparse" if opt.boolean("reward_sparse", reward_sparse) else "dense",
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
                sparse=opt.boolean("reward_sparse", reward_sparse),
                only_positive=reward_only_positive,
                negative_scale=reward_negative_scale,
                death_value=reward_death_value,
                win=reward_win,
                defeat=reward_defeat,
                scale=reward_scale,
                scale_rate=reward_scale_rate,
            ),
        )
        self.seeds = list(seeds)
        self.num_envs: int = self._raw.num_envs
        self.threads: int = self._raw.threads
        info = self._raw.env_info()
        self.n_agents: int = info["n_agents"]
        self.n_actions: int = info["n_actions"]
        self.env_info: dict[str, int] = info

    def reset(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Restarts every environment from its seed: `(obs E x A x obs, state E x S, avail E x A x n_actions)`."""
        self._raw.reset()
        b = self._raw.buffers()
        return b["obs"], b["state"], b["avail"]

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """`actions`: `E x A` integer indices. Returns `(obs, state, avail, reward, terminated,
        truncated, info)`, info holding arrays `battle_won`, `dead_allies`, `dead_enemies`,
        `episode_limit` and `seed` (the episode each environment is in now), and when an
        episode ended, `final_obs`, `final_state`, `final_avail` and the mask `_final_obs`."""
        self._raw.step(actions)
        b = self._raw.buffers()
        info = {k: b[k] for k in ("battle_won", "dead_allies", "dead_enemies", "episode_limit", "seed")}
        if "final_obs" in b:
            info.update({k: b[k] for k in ("final_obs", "final_state", "final_avail")})
            info["_final_obs"] = b["terminated"] | b["truncated"]
        return b["obs"], b["state"], b["avail"], b["reward"], b["terminated"], b["truncated"], info

    def close(self) -> None:
        pass

    def __repr__(self) -> str:
        return f"VecEnv(num_envs={self.num_envs}, threads={self.threads}, n_agents={self.n_agents})"
