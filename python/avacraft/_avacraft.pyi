"""Type stubs of the compiled module `avacraft._avacraft` (Rust, pyo3)."""

from os import PathLike
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

class AvacraftError(ValueError):
    """Bad input to an AVACraft environment: an unknown scenario or option, an action that
    cannot be taken (naming the agent and its available actions), an array of the wrong shape."""

_Indices = Union[Sequence[int], npt.NDArray[np.integer[Any]]]

def scenario_names() -> list[str]: ...
def env_options() -> tuple[list[str], str]:
    """The options `Env` and `VecEnv` take after their leading arguments, in order, and their
    defaults as a JSON object (the engine's `EnvOptions`)."""

def baseline_dir(scenario: str, name: str = "qmix") -> str:
    """The folder of the shipped baseline `name` of `scenario` (what `baseline:NAME` names).
    Raises `AvacraftError` naming the shipped runs when there is none."""

def scenario_info(scenario: str) -> dict[str, Any]:
    """{"name", "mode": "pve" | "pvp", "units": (team 1, team 2), "time_limit_loops", "drawn_types": the types a
    procedural scenario draws each unit from (None for a fixed scenario)}; `scenario` may also be a
    scenario's TOML text."""

def rust_loop_steps_per_s(scenario: str, steps: int, seed: int = 0) -> float:
    """Steps/s of a Rust loop doing obs + state + masks + random available actions + step."""

class Snapshot:
    """A saved episode state (`Env.snapshot()`)."""

    @property
    def steps(self) -> int: ...
    @property
    def state_hash(self) -> int: ...

class Env:
    """The engine's environment. Teams are 1 and 2; team 2 is played by agents in PvP only.
    Unit tags are 1-based."""

    def __init__(
        self,
        scenario: str,
        seed: int = 0,
        step_mul: int = 8,
        reward: str = "dense",
        opponent: Optional[str] = None,
        full_vision: bool = False,
        passive_allies: bool = True,
        cooldown_jitter: bool = True,
        abilities: bool = True,
        ability_actions: bool = False,
        time_limit_loops: Optional[int] = None,
        prob_obs_enemy: float = 1.0,
        action_mask: bool = True,
        fov_actions: int = 0,
        data: Optional[str] = None,
        weapon_period: str = "attack",
        melee_surround: bool = False,
        reward_only_positive: bool = True,
        reward_negative_scale: float = 0.5,
        reward_death_value: float = 10.0,
        reward_win: float = 200.0,
        reward_defeat: float = 0.0,
        reward_scale: bool = True,
        reward_scale_rate: float = 20.0,
        state_agent: bool = False,
    ) -> None: ...
    def max_reward(self, team: int = 1) -> float: ...
    def reset(self, seed: int) -> None: ...
    @property
    def scenario(self) -> str: ...
    @property
    def pvp(self) -> bool: ...
    @property
    def seed(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def done(self) -> bool: ...
    @property
    def trajectory_hash(self) -> int: ...
    @property
    def opponent(self) -> Optional[str]: ...
    def env_info(self, team: int = 1) -> dict[str, int]: ...
    def agent_tags(self, team: int = 1) -> list[int]: ...
    def alive(self, team: int = 1) -> list[bool]: ...
    def obs(self, team: int = 1) -> npt.NDArray[np.float32]:
        """n_agents x obs_shape."""
    def obs_list(self, team: int = 1) -> list[npt.NDArray[np.float32]]: ...
    def obs_agent(self, agent: int, team: int = 1) -> npt.NDArray[np.float32]: ...
    def state(self, team: int = 1) -> npt.NDArray[np.float32]: ...
    def avail(self, team: int = 1) -> npt.NDArray[np.uint8]:
        """n_agents x n_actions, 1 = available."""
    def avail_agent(self, agent: int, team: int = 1) -> npt.NDArray[np.uint8]: ...
    def step(self, actions: _Indices, actions2: Optional[_Indices] = None) -> tuple[float, float, bool, bool, Optional[str]]:
        """(reward team 1, reward team 2, terminated, truncated, outcome "win"/"loss"/"draw" or None)."""
    def step_smac(self, actions: _Indices) -> tuple[float, bool, bool, dict[str, Any]]:
        """PvE team 1: (reward, terminated, truncated, {battle_won, dead_allies, dead_enemies})."""
    def step_heuristic(self, rest: bool) -> tuple[float, bool, bool, dict[str, Any]]:
        """PvE team 1 played by SMAC's heuristic (`rest`: heuristic_rest); as step_smac."""
    def submit_typed(self, actions_json: str, team: int = 1) -> list[Optional[str]]:
        """JSON list of `avacraft.Action` dicts; returns per action None or why the game refused it."""
    def advance(self) -> tuple[float, float, bool, bool, Optional[str]]: ...
    def info(self, team: int = 1) -> dict[str, Any]:
        """battle_won, dead_allies, dead_enemies, episode_limit."""
    def screen(self, width: int = 160, height: int = 120, team: int = 1) -> npt.NDArray[np.uint8]:
        """height x width x 3."""
    def minimap(self, width: int = 32, height: int = 32, team: int = 1) -> npt.NDArray[np.uint8]: ...
    def screenshot(self, width: int = 1920, height: int = 1080, team: int = 1, highlights: Sequence[int] = ...) -> npt.NDArray[np.uint8]: ...
    def text(self, team: int = 1) -> str: ...
    def units(self, team: int = 1) -> list[dict[str, Any]]:
        """The unit list: `avacraft.UnitInfo` dicts."""
    def record(self, size: Optional[tuple[int, int]]) -> None: ...
    def save_video(self, path: Union[str, PathLike[str]], delay_ms: int = 100) -> int: ...
    def snapshot(self) -> Snapshot: ...
    def restore(self, snap: Snapshot) -> None: ...

class VecEnv:
    def __init__(
        self,
        scenario: str,
        seeds: Sequence[int],
        threads: Optional[int] = None,
        step_mul: int = 8,
        reward: str = "dense",
        opponent: Optional[str] = None,
        full_vision: bool = False,
        passive_allies: bool = True,
        cooldown_jitter: bool = True,
        abilities: bool = True,
        ability_actions: bool = False,
        time_limit_loops: Optional[int] = None,
        prob_obs_enemy: float = 1.0,
        action_mask: bool = True,
        fov_actions: int = 0,
        data: Optional[str] = None,
        weapon_period: str = "attack",
        melee_surround: bool = False,
        reward_only_positive: bool = True,
        reward_negative_scale: float = 0.5,
        reward_death_value: float = 10.0,
        reward_win: float = 200.0,
        reward_defeat: float = 0.0,
        reward_scale: bool = True,
        reward_scale_rate: float = 20.0,
        state_agent: bool = False,
    ) -> None: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def threads(self) -> int: ...
    def env_info(self) -> dict[str, int]: ...
    def reset(self) -> None: ...
    def step(self, actions: _Indices) -> None: ...
    def buffers(self) -> dict[str, npt.NDArray[Any]]: ...

class MarlPolicy:
    """A checkpoint of `avacraft train` acting greedily for a team's agents, with one GRU
    state and last action per agent (`avacraft.MarlPolicy` adds list inputs and `act_parallel`)."""

    def __init__(self, path: Union[str, PathLike[str]]) -> None:
        """Raises `AvacraftError` when the checkpoint is missing or cannot be read."""
    @property
    def scenario(self) -> str:
        """The scenario it was trained on."""
    @property
    def algo(self) -> str: ...
    @property
    def obs(self) -> str:
        """The observation mode it was trained on: features, rgb, hybrid or vision-text."""
    @property
    def n_agents(self) -> int: ...
    @property
    def obs_size(self) -> int: ...
    @property
    def n_actions(self) -> int: ...
    def reset(self) -> None:
        """Forgets the GRU states and last actions (an episode starts)."""
    def check_env(self, env: Env, team: int = 1) -> None:
        """Raises `AvacraftError` unless trained on `env`'s scenario with its team's sizes."""
    def act(self, obs: npt.NDArray[np.float32], avail: npt.NDArray[np.uint8], team: int = 1) -> npt.NDArray[np.int64]:
        """n_agents x obs_size features and n_agents x n_actions masks in, one greedy action per agent out."""
    def act_env(self, env: Env) -> npt.NDArray[np.int64]:
        """Team 1's greedy actions for `env`'s next step in the checkpoint's own observation mode
        (an image checkpoint's frames rendered from the game); hidden states apart from `act`'s."""
    def play(self, env: Env, seed: int) -> dict[str, Any]:
        """One episode of `env` from `seed` with the Rust agent (`avacraft episode --agent marl:DIR`, and in
        PvP `--agent2 marl:DIR`): {"result": "win" | "loss" | "draw", "steps", "trajectory_hash", "actions"}
        (and "actions2" in PvP)."""

class Ava:
    """The AVA agent over an `AvaSpec` given as JSON (`avacraft.Ava` builds it from keywords)."""

    def __init__(self, spec_json: str, record: Optional[str] = None) -> None:
        """Raises `AvacraftError` naming the setting that is wrong."""
    def spec_json(self) -> str: ...
    def play(self, env: Env, seed: int, team: int = 1) -> dict[str, Any]:
        """One episode with AVA as `team`: {"result", "steps", "trajectory_hash", "cost" (JSON)}."""
    def costs_json(self) -> str: ...
