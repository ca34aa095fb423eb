"""SMACv2's interface on the procedural scenarios: its wrapper, its configs, EPyMARL's calls,
and the same draw and episode as Rust for the same seed."""

import copy
import os
import sys
import tomllib

import numpy as np
import pytest

import avacraft
import avacraft.smacv2
from conftest import random_actions

HERE = os.path.dirname(os.path.abspath(__file__))
GOLDEN = os.path.join(HERE, "..", "..", "tests", "golden", "trajectories.toml")


def sc2_gen(race, n=5, m=5):
    """The capability_config of SMACv2's sc2_gen_<race>.yaml (EPyMARL's <race>_<n>_vs_<m>.yaml)."""
    teams = {
        "protoss": (["stalker", "zealot", "colossus"], [0.45, 0.45, 0.1], []),
        "terran": (["marine", "marauder", "medivac"], [0.45, 0.45, 0.1], ["medivac"]),
        "zerg": (["zergling", "baneling", "hydralisk"], [0.45, 0.1, 0.45], ["baneling"]),
    }
    types, weights, exceptions = teams[race]
    return {
        "n_units": n,
        "n_enemies": m,
        "team_gen": {
            "dist_type": "weighted_teams",
            "unit_types": types,
            "exception_unit_types": exceptions,
            "weights": weights,
            "observe": True,
        },
        "start_positions": {"dist_type": "surrounded_and_reflect", "p": 0.5, "n_enemies": m, "map_x": 32, "map_y": 32},
    }


# The env_args of SMACv2's sc2_gen_*.yaml besides the capability config.
ENV_ARGS = dict(
    continuing_episode=False,
    difficulty="7",
    game_version=None,
    move_amount=2,
    obs_all_health=True,
    obs_instead_of_state=False,
    obs_last_action=False,
    obs_own_health=True,
    obs_pathing_grid=False,
    obs_terrain_height=False,
    obs_timestep_number=False,
    reward_death_value=10,
    reward_defeat=0,
    reward_negative_scale=0.5,
    reward_only_positive=True,
    reward_scale=True,
    reward_scale_rate=20,
    reward_sparse=False,
    reward_win=200,
    replay_dir="",
    replay_prefix="",
    conic_fov=False,
    use_unit_ranges=True,
    min_attack_range=2,
    obs_own_pos=True,
    num_fov_actions=12,
    state_last_action=True,
    state_timestep_number=False,
    step_mul=8,
    heuristic_ai=False,
    debug=False,
    prob_obs_enemy=1.0,
    action_mask=True,
)


@pytest.mark.parametrize(
    "race,n,m,obs,state,actions",
    [("protoss", 5, 5, 92, 130, 11), ("terran", 5, 5, 82, 120, 11), ("zerg", 10, 11, 170, 306, 17), ("terran", 10, 11, 170, 306, 17)],
)
def test_the_wrapper_has_smacv2_sizes_and_plays(race, n, m, obs, state, actions, rng):
    config = sc2_gen(race, n, m)
    before = copy.deepcopy(config)
    env = avacraft.StarCraftCapabilityEnvWrapper(capability_config=config, map_name=f"10gen_{race}", seed=3, **ENV_ARGS)
    assert config == before, "the caller's config is not modified"
    info = env.get_env_info()
    assert (info["n_agents"], info["obs_shape"], info["state_shape"], info["n_actions"], info["cap_shape"]) == (n, obs, state, actions, 3)
    assert info["episode_limit"] == env.episode_limit == 200
    assert len(env.get_obs_feature_names()) == obs and len(env.get_state_feature_names()) == state
    for _ in range(3):
        o, s = env.reset()
        assert len(o) == n and all(x.shape == (obs,) for x in o) and s.shape == (state,)
        caps = env.get_capabilities()
        assert caps.shape == (n * 3,) and np.allclose(caps.reshape(n, 3).sum(axis=1), 1.0), "one unit type per agent"
        terminated = False
        while not terminated:
            _, terminated, info = env.step(random_actions(env.get_avail_actions(), rng))
        assert isinstance(info["battle_won"], bool)
    assert env.get_stats()["battles_game"] == 3


def test_the_config_and_the_built_in_scenario_draw_the_same_units():
    a = avacraft.StarCraftCapabilityEnvWrapper(capability_config=sc2_gen("zerg"), map_name="10gen_zerg", seed=11)
    b = avacraft.StarCraft2Env("zerg_5_vs_5", seed=11)
    for _ in range(4):
        a.reset()
        b.reset()
        assert a.env.env.units(1) == b.env.units(1) and a.env.env.units(2) == b.env.units(2)
        assert np.array_equal(a.get_state(), b.get_state())
    kinds = {u["type"] for u in b.env.units(1)}
    assert kinds <= {"Zergling", "Hydralisk", "Baneling"}


def test_an_episode_replays_the_pinned_rust_trajectory():
    """tests/it/golden.rs plays the same case in Rust and pins its hash: equal hashes mean the
    same draw and the same episode from Python."""
    with open(GOLDEN, "rb") as f:
        pinned = {e["case"]: e for e in tomllib.load(f)["episode"]}
    case = pinned["protoss_5_vs_5 seed 4 highest-index vs default"]
    env = avacraft.Env("protoss_5_vs_5", seed=4, reward="sparse", passive_allies=False, data="legacy")
    n = env.env_info()["n_agents"]
    while not env.done:
        avail = np.asarray(env.avail())
        env.step([int(np.flatnonzero(avail[a])[-1]) for a in range(n)])
    assert env.steps == case["steps"]
    assert f"{env.trajectory_hash:016x}" == case["trajectory_hash"]


def test_epymarl_sc2v2_calls_run_unchanged(rng):
    """What EPyMARL's smacv2_wrapper.py does, through SMACv2's module names."""
    saved = {k: v for k, v in sys.modules.items() if k.startswith("smacv2")}
    try:
        avacraft.smacv2.install()
        from smacv2.env.starcraft2.wrapper import StarCraftCapabilityEnvWrapper

        env_args = dict(ENV_ARGS, capability_config=sc2_gen("protoss"), map_name="10gen_protoss")
        env = StarCraftCapabilityEnvWrapper(**env_args)
        assert env.episode_limit == 200
        info = env.get_env_info()
        for key in ("n_agents", "n_actions", "state_shape", "obs_shape", "episode_limit"):
            assert isinstance(info[key], int)
        obs, _ = env.reset()
        terminated, steps = False, 0
        while not terminated:
            rew, terminated, step_info = env.step(random_actions(env.get_avail_actions(), rng))
            obs, state = env.get_obs(), env.get_state()
            steps += 1
        assert steps <= 200 and {"battle_won", "dead_allies", "dead_enemies"} <= set(step_info)
        assert env.get_stats()["battles_game"] == 1
        env.close()
    finally:
        for k in [k for k in sys.modules if k.startswith("smacv2")]:
            del sys.modules[k]
        sys.modules.update(saved)


@pytest.mark.parametrize(
    "change,says",
    [
        (lambda c: c["team_gen"].update(weights=[0.5, 0.4, 0.2]), "generate.weights"),
        (lambda c: c["team_gen"].update(unit_types=["stalker", "zealot", "dragoon"]), "['unit_types'][2]"),
        (lambda c: c["start_positions"].update(p=1.5), "generate.p"),
        (lambda c: c.pop("n_units"), "['n_units']"),
        (lambda c: c.update(attack={"dist_type": "per_agent_uniform"}), "stochastic"),
        (lambda c: c["team_gen"].update(dist_type="all_teams"), "weighted_teams"),
    ],
)
def test_bad_configs_name_the_key(change, says):
    config = sc2_gen("protoss")
    change(config)
    with pytest.raises(avacraft.AvacraftError) as e:
        avacraft.StarCraftCapabilityEnvWrapper(capability_config=config, map_name="10gen_protoss")
    assert says in str(e.value), str(e.value)


@pytest.mark.parametrize("key,value", [("fully_observable", True), ("obs_own_pos", False)])
def test_unimplemented_options_are_refused(key, value):
    with pytest.raises(avacraft.AvacraftError, match=key):
        avacraft.StarCraftCapabilityEnvWrapper(capability_config=sc2_gen("terran"), map_name="10gen_terran", **{key: value})


def test_conic_fields_of_view_play_with_smacv2_sizes(rng):
    """SMACv2's conic_fov with its 12 look actions: the sizes grow as SMACv2's (look actions
    after the moves, the direction in the own features and each ally's state row), a look
    turns the agent's direction, and odd counts are refused with the key named."""
    args = dict(ENV_ARGS, conic_fov=True, num_fov_actions=12)
    env = avacraft.StarCraftCapabilityEnvWrapper(capability_config=sc2_gen("protoss"), map_name="10gen_protoss", seed=5, **args)
    info = env.get_env_info()
    assert (info["obs_shape"], info["state_shape"], info["n_actions"]) == (92 + 2, 130 + 5 * 2 + 5 * 12, 11 + 12)
    assert len(env.get_obs_feature_names()) == info["obs_shape"] and len(env.get_state_feature_names()) == info["state_shape"]
    names = env.get_obs_feature_names()
    fx, fy = names.index("own_fov_x"), names.index("own_fov_y")
    obs, _ = env.reset()
    assert all((o[fx], o[fy]) == (1.0, 0.0) for o in obs), "agents start looking east"
    turned = 0
    for _ in range(2):
        env.reset()
        terminated = False
        while not terminated:
            avail = np.asarray(env.get_avail_actions())
            alive = avail[:, 0] == 0
            assert np.all(avail[alive, 6:18] == 1), "every look action is available to a living agent"
            actions = random_actions(avail, rng)
            _, terminated, _ = env.step(actions)
            if terminated:
                break
            for a, (o, act) in enumerate(zip(env.get_obs(), actions)):
                if 6 <= act < 18 and np.any(o):
                    angle = 2 * np.pi * (act - 6) / 12
                    assert np.allclose((o[fx], o[fy]), (np.cos(angle), np.sin(angle)), atol=1e-6), (a, act, o[fx], o[fy])
                    turned += 1
    assert turned > 0
    with pytest.raises(avacraft.AvacraftError, match="num_fov_actions"):
        avacraft.StarCraftCapabilityEnvWrapper(capability_config=sc2_gen("protoss"), map_name="10gen_protoss", **dict(args, num_fov_actions=7))


def test_the_epo_config_plays_with_extended_partial_observability(rng):
    """SMACv2's sc2_gen_protoss_epo.yaml (prob_obs_enemy 0, action_mask False): each enemy is
    in one agent's observation at most; and without the range mask, enemies beyond shoot
    range (the observation's can-attack bit off) may be attacked."""

    def make(**more):
        args = dict(ENV_ARGS, **more)
        return avacraft.StarCraftCapabilityEnvWrapper(capability_config=sc2_gen("protoss"), map_name="10gen_protoss", seed=4, **args)

    envs = {"epo": make(prob_obs_enemy=0.0, action_mask=False), "full": make(), "unmasked": make(action_mask=False)}
    names = envs["full"].get_obs_feature_names()
    rows = [[i for i, n in enumerate(names) if n.startswith(f"enemy_{e}_")] for e in range(5)]
    shared = {key: 0 for key in envs}
    beyond = {key: 0 for key in envs}
    for key, e in envs.items():
        for _ in range(3):
            e.reset()
            terminated = False
            while not terminated:
                obs, avail = e.get_obs(), e.get_avail_actions()
                for r in rows:
                    seen = sum(bool(np.any(o[r])) for o in obs)
                    shared[key] += seen > 1
                beyond[key] += sum(avail[a][6 + j] == 1 and obs[a][rows[j][0]] == 0 for a in range(5) for j in range(5))
                _, terminated, _ = e.step(random_actions(avail, rng))
    assert shared["epo"] == 0 and shared["full"] > 0, shared
    assert beyond["full"] == 0 and beyond["unmasked"] > 0, beyond
    with pytest.raises(avacraft.AvacraftError, match="prob_obs_enemy"):
        make(prob_obs_enemy=1.5)
    with pytest.raises(avacraft.AvacraftError, match="action_mask"):
        avacraft.StarCraft2Env("3m_vlm", action_mask="no")


def test_pettingzoo_and_vector_envs_play_procedural_scenarios(rng):
    env = avacraft.parallel_env("terran_5_vs_5", obs_mode="features")
    obs, _ = env.reset(seed=2)
    assert len(obs) == 5 and all(o["observation"].shape == (82,) for o in obs.values())
    steps = 0
    while env.agents:
        obs, _, _, _, _ = env.step({a: int(np.flatnonzero(obs[a]["action_mask"])[-1]) for a in env.agents})
        steps += 1
    assert 0 < steps <= 200
    vec = avacraft.VecEnv("protoss_5_vs_5", seeds=[5, 6, 7], threads=2)
    assert (vec.env_info["obs_shape"], vec.env_info["state_shape"]) == (92, 130)
    obs, state, avail = vec.reset()
    for i, seed in enumerate([5, 6, 7]):
        single = avacraft.Env("protoss_5_vs_5", seed=seed)
        assert np.array_equal(state[i], single.state()), f"env {i} draws seed {seed}'s units"
    ended = 0
    for _ in range(250):
        acts = np.stack([random_actions(a, rng) for a in avail])
        obs, state, avail, reward, term, trunc, info = vec.step(acts)
        ended += int(term.sum() + trunc.sum())
    assert ended > 0, "episodes end and reset to new draws"


def test_procedural_scenarios_are_listed_with_their_types():
    names = avacraft.scenario_names()
    assert "protoss_5_vs_5" in names and "zerg_20_vs_23" in names and "3m_vlm" in names
    assert avacraft.scenario_info("zerg_5_vs_5")["drawn_types"] == ["Zergling", "Hydralisk", "Baneling"]
    assert avacraft.scenario_info("3m_vlm")["drawn_types"] is None


def test_the_shipped_smacv2_baseline_plays_in_smacv2s_wrapper_as_in_rust():
    """baselines/protoss_5_vs_5/mappo (eval/plans/smacv2.toml, trained with units that acquire
    targets) acting on the wrapper's observations takes the Rust agent's actions on the
    built-in scenario: the wrapper's features are the ones it learned on."""
    policy = avacraft.MarlPolicy.baseline("protoss_5_vs_5", "mappo")
    assert (policy.scenario, policy.n_agents, policy.obs_size) == ("protoss_5_vs_5", 5, 92)
    won = 0
    for seed in (1001, 1002, 1003):
        # On the game the baseline trained on: the engine's legacy unit data.
        ref = policy.play(avacraft.Env("protoss_5_vs_5", reward="sparse", passive_allies=False, data="legacy"), seed)
        env = avacraft.StarCraftCapabilityEnvWrapper(
            capability_config=sc2_gen("protoss"), map_name="10gen_protoss", seed=seed, passive_allies=False, data="legacy"
        )
        env.reset()
        policy.reset()
        terminated, info, actions = False, {}, []
        while not terminated:
            a = policy.act(env.get_obs(), env.get_avail_actions())
            actions.append(a.tolist())
            _, terminated, info = env.step(a)
        assert actions == [[a if a >= 0 else 0 for a in step] for step in ref["actions"]], f"seed {seed}"
        assert info["battle_won"] == (ref["result"] == "win")
        won += ref["result"] == "win"
    # It won 0.85 of docs/simulator.md's 200 episodes from seed 1001.
    assert won >= 2
