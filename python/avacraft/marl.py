"""Trained MARL policies (checkpoints of `avacraft train`) acting from Python.

`MarlPolicy(dir)` runs the checkpoint's agent network for all agents of a team at once, each
with its own GRU state and last action, greedy over the available actions: the actions
`avacraft episode --agent marl:DIR` takes in Rust, so a Python loop plays the same episodes.

    policy = avacraft.MarlPolicy("runs/qmix-3m")
    env = avacraft.StarCraft2Env("3m_vlm")
    env.reset(); policy.reset()
    done = False
    while not done:
        _, done, info = env.step(policy.act(env.get_obs(), env.get_avail_actions()))

With `parallel_env` observations (features or hybrid mode): `env.step(policy.act_parallel(obs))`.

An image checkpoint (`policy.obs` is `rgb`, `hybrid` or `vision-text`) reads frames rendered
from the game, which the SMAC API does not hand out: `policy.act_env(env)` renders them as
training's test episodes did and returns team 1's actions (any checkpoint plays this way):

    policy = avacraft.MarlPolicy.baseline("2s3z_vlm", "mappo-rgb")
    while not done:
        _, done, info = env.step(policy.act_env(env))
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from ._avacraft import AvacraftError
from ._avacraft import MarlPolicy as _MarlPolicy
from ._avacraft import baseline_dir

_NAME = re.compile(r"^(?:team(\d+)_)?agent_(\d+)$")


class MarlPolicy(_MarlPolicy):
    """A checkpoint directory of `avacraft train` (`agent.safetensors`, `config.json`).

    Properties: `scenario` (trained on), `algo`, `n_agents`, `obs_size`, `n_actions`.
    Call `reset()` when an episode starts. `play(env, seed)` plays an episode of an `Env`
    with the Rust agent (`avacraft_marl::MarlAgent`) instead: the reference for a Python loop.
    """

    @classmethod
    def baseline(cls, scenario: str, name: str = "qmix") -> "MarlPolicy":
        """The shipped baseline `name` (`qmix`, `mappo`, ...) of `scenario`: the policy
        `--agent baseline:NAME` plays (from `$AVACRAFT_BASELINES`, else the repository's
        `baselines/`). Raises `AvacraftError` naming what is shipped when it is not."""
        return cls(baseline_dir(scenario, name))

    def act(self, obs: Any, avail: Any, team: int = 1) -> np.ndarray:
        """Greedy actions (int64, one per agent) from every agent's SMAC observation (a list
        of vectors or an `n_agents x obs_size` array, as `StarCraft2Env.get_obs()`) and mask
        (`get_avail_actions()`); dead agents included, in agent order. Advances the agents'
        GRU states: call once per step. `team=2` plays team 2 of a PvP scenario: the network,
        trained as team 1, sees and acts in the mirror image (east and west swapped)."""
        return super().act(np.ascontiguousarray(obs, dtype=np.float32), np.ascontiguousarray(avail, dtype=np.uint8), team)

    def act_env(self, env: Any) -> np.ndarray:
        """Greedy actions (int64, one per agent of team 1, dead ones' no-op included) for the
        next step of `env` (an `Env`, or a `StarCraft2Env` or `parallel_env`, whose `.env` is
        used), read in the checkpoint's own observation mode: an image checkpoint's frames are
        rendered from the game. Hidden states are kept apart from `act`'s; `reset()` clears
        both. Image checkpoints play team 1 of PvE scenarios only."""
        return super().act_env(getattr(env, "env", env))

    def act_parallel(self, observations: dict[str, dict[str, Any]], team: int = 1) -> dict[str, int]:
        """Actions for a PettingZoo `parallel_env` step from its observation dict (features or
        hybrid mode: `"observation"` holds the SMAC features). Agents missing from the dict
        (dead ones leave) act as SMAC's dead agents do, on zero features with only the no-op
        available, so every agent's state advances as in `act`. In PvP, `team` picks whose
        agents (`team<t>_agent_<i>`) this policy plays."""
        n = self.n_agents
        obs = np.zeros((n, self.obs_size), dtype=np.float32)
        avail = np.zeros((n, self.n_actions), dtype=np.uint8)
        avail[:, 0] = 1
        names: dict[int, str] = {}
        for name, o in observations.items():
            m = _NAME.match(name)
            if m is None:
                raise AvacraftError(f"{name!r}: not a parallel_env agent name (agent_<i> or team<t>_agent_<i>)")
            if m.group(1) is not None and int(m.group(1)) != team:
                continue
            i = int(m.group(2))
            if i >= n:
                raise AvacraftError(f"{name}: the policy plays {n} agents (trained on {self.scenario})")
            features = np.asarray(o["observation"])
            if features.shape != (self.obs_size,):
                raise AvacraftError(
                    f"{name}: observation of shape {features.shape}, SMAC features of {self.obs_size} needed "
                    "(parallel_env obs_mode 'features' or 'hybrid')"
                )
            obs[i] = features
            avail[i] = np.asarray(o["action_mask"])
            names[i] = name
        actions = self.act(obs, avail, team)
        return {name: int(actions[i]) for i, name in sorted(names.items())}
