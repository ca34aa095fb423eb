"""AVACraft: a StarCraft II micro-combat benchmark for multi-agent RL and VLM agents, with its
own deterministic simulator (no game binary).

- `StarCraft2Env`: SMAC's interface, for PyMARL/EPyMARL code unchanged.
- `parallel_env`: a PettingZoo `ParallelEnv` in the features, rgb, hybrid or vlm mode
  (needs `pettingzoo` and `gymnasium`: the `pettingzoo` extra).
- `VecEnv`: many environments on a thread pool, numpy arrays out.
- `MarlPolicy`: a policy trained by `avacraft train`, acting for a team's agents from SMAC
  observations (`act`) or `parallel_env` observations (`act_parallel`), as in Rust.
- `Ava`: the paper's VLM agent on an OpenAI-compatible endpoint, a recording or a stand-in,
  with every model call recorded and costed.
- `AvacraftError`: bad input (a `ValueError`).
"""

from __future__ import annotations

from typing import Any

from ._avacraft import AvacraftError, Env, Snapshot, __version__, scenario_info, scenario_names
from .ava import Ava
from .marl import MarlPolicy
from .smac import StarCraft2Env
from .smacv2 import StarCraftCapabilityEnvWrapper
from .types import Action, Command, UnitInfo
from .vector import VecEnv

__all__ = [
    "Action",
    "Ava",
    "AvacraftError",
    "Command",
    "Env",
    "MarlPolicy",
    "Snapshot",
    "StarCraft2Env",
    "StarCraftCapabilityEnvWrapper",
    "UnitInfo",
    "VecEnv",
    "__version__",
    "parallel_env",
    "scenario_info",
    "scenario_names",
]


def parallel_env(scenario: str = "3m_vlm", obs_mode: str = "features", opponent: Any = None, seed: Any = None, **kwargs: Any) -> Any:
    """A PettingZoo `ParallelEnv` (`avacraft.pettingzoo_env.AvacraftParallelEnv`); imported on
    first use so `import avacraft` needs neither pettingzoo nor gymnasium."""
    from .pettingzoo_env import parallel_env as make

    return make(scenario, obs_mode, opponent, seed, **kwargs)
