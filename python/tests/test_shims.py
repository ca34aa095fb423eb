"""The `smac` and `smacv2` shim packages (python/shims/): EPyMARL's SMAC and SMACv2 wrapper
code paths, as `python src/main.py --env-config=sc2 with env_args.map_name=3s5z` and
`--env-config=sc2v2 with env_args.map_name=protoss_5_vs_5` run them, on AVACraft's env.
The shims are imported from their source folders (as `pip install ./python/shims/smac`
installs them); EPyMARL's calls are written out here, not vendored."""

import os
import sys

import numpy as np
import pytest

import avacraft
from conftest import random_actions

SHIMS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "shims")

# EPyMARL's src/config/envs/sc2.yaml env_args (map_name and seed come from the command line),
# after its __check_and_prepare_smac_kwargs removed common_reward and reward_scalarisation.
SC2_YAML = dict(
    continuing_episode=False, difficulty="7", game_version=None, move_amount=2, obs_all_health=True,
    obs_instead_of_state=False, obs_last_action=False, obs_own_health=True, obs_pathing_grid=False,
    obs_terrain_height=False, obs_timestep_number=False, reward_death_value=10, reward_defeat=0,
    reward_negative_scale=0.5, reward_only_positive=True, reward_scale=True, reward_scale_rate=20,
    reward_sparse=False, reward_win=200, replay_dir="", replay_prefix="", state_last_action=False,
    state_timestep_number=False, step_mul=8, heuristic_ai=False, heuristic_rest=False, debug=False,
)


@pytest.fixture
def shims():
    """The shim packages on the path, and the modules they load dropped afterwards."""
    saved = {k: v for k, v in sys.modules.items() if k.split(".")[0] in ("smac", "smacv2")}
    for k in saved:
        del sys.modules[k]
    sys.path[:0] = [os.path.join(SHIMS, "smac"), os.path.join(SHIMS, "smacv2")]
    try:
        yield
    finally:
        del sys.path[:2]
        for k in [k for k in sys.modules if k.split(".")[0] in ("smac", "smacv2")]:
            del sys.modules[k]
        sys.modules.update(saved)


def epymarl_smac_episode(map_name, seed, rng):
    """EPyMARL's SMACWrapper (src/envs/smac_wrapper.py): construct, reset, step to the end."""
    from smac.env import StarCraft2Env

    env = StarCraft2Env(map_name=map_name, seed=seed, **SC2_YAML)
    episode_limit = env.episode_limit
    info = env.get_env_info()
    obss, _ = env.reset()
    assert len(obss) == info["n_agents"] and len(obss[0]) == info["obs_shape"] == env.get_obs_size()
    assert len(env.get_state()) == info["state_shape"] == env.get_state_size()
    assert env.get_total_actions() == info["n_actions"]
    terminated, steps = False, 0
    while not terminated:
        rews, terminated, step_info = env.step(random_actions(env.get_avail_actions(), rng))
        obss = env.get_obs()
        steps += 1
    env.close()
    return info, episode_limit, steps, step_info


def test_smac_names_through_the_smac_shim_are_smacs_maps(shims, rng):
    import smac

    assert smac.__avacraft__
    # SMAC's registry: agents, enemies, limit; sizes by SMAC's formulas (no obs last action,
    # EPyMARL's state_last_action False).
    # 3s5z: 4 moves + 8 enemies x 8 + 7 allies x 8 + own 4 = 128; state 8 x 7 + 8 x 6 = 104.
    for name, agents, enemies, limit, obs, state in [
        ("3s5z", 8, 8, 150, 128, 104),
        ("3m", 3, 3, 60, 30, 21),
        ("2s_vs_1sc", 2, 1, 300, 17, 13),
    ]:
        info, episode_limit, steps, step_info = epymarl_smac_episode(name, 1, rng)
        assert (info["n_agents"], info["n_actions"], info["episode_limit"], episode_limit) == (agents, 6 + enemies, limit, limit), name
        assert (info["obs_shape"], info["state_shape"]) == (obs, state), name
        assert 1 <= steps <= limit
        assert {"battle_won", "dead_allies", "dead_enemies"} <= set(step_info)


def test_smac_shim_refuses_a_name_that_is_no_map(shims):
    from smac.env import StarCraft2Env

    with pytest.raises(avacraft.AvacraftError, match="4m"):
        StarCraft2Env(map_name="4m", seed=1, **SC2_YAML)


def test_smac_shim_subclass_base_and_module_paths(shims):
    from smac.env import MultiAgentEnv, StarCraft2Env
    from smac.env.starcraft2.starcraft2 import StarCraft2Env as Deep

    assert StarCraft2Env is avacraft.StarCraft2Env is Deep
    # SMAC's base class, with its interface's methods, for code that subclasses it; the
    # environment has every one of them.
    for method in ("step", "reset", "get_obs", "get_state", "get_avail_actions", "get_env_info", "close"):
        assert callable(getattr(MultiAgentEnv, method, None)), method
    interface = [m for m in vars(MultiAgentEnv) if not m.startswith("_")]
    assert [m for m in interface if not callable(getattr(StarCraft2Env, m, None))] == []


def test_epymarl_sc2v2_protoss_5_vs_5_through_the_smacv2_shim(shims, rng):
    """EPyMARL's smacv2_wrapper.load_scenario: protoss_5_vs_5.yaml's env_args into SMACv2's
    capability wrapper, imported by SMACv2's module path."""
    from smacv2.env.starcraft2.wrapper import StarCraftCapabilityEnvWrapper

    env_args = dict(
        SC2_YAML, map_name="10gen_protoss", conic_fov=False, use_unit_ranges=True, min_attack_range=2,
        obs_own_pos=True, num_fov_actions=12, state_last_action=True,
        capability_config={
            "n_units": 5, "n_enemies": 5,
            "team_gen": {"dist_type": "weighted_teams", "unit_types": ["stalker", "zealot", "colossus"],
                         "weights": [0.45, 0.45, 0.1], "observe": True},
            "start_positions": {"dist_type": "surrounded_and_reflect", "p": 0.5, "map_x": 32, "map_y": 32},
        },
    )
    env_args.pop("heuristic_rest")
    env = StarCraftCapabilityEnvWrapper(seed=3, **env_args)
    assert env.episode_limit == 200
    info = env.get_env_info()
    assert (info["n_agents"], info["n_actions"]) == (5, 11)
    obss, _ = env.reset()
    terminated, steps = False, 0
    while not terminated:
        _, terminated, step_info = env.step(random_actions(env.get_avail_actions(), rng))
        steps += 1
    assert 1 <= steps <= 200 and "battle_won" in step_info
    env.close()
