"""SMAC's interface: episodes, shapes, seeds, time-outs, options, replays, snapshots."""

import numpy as np
import pytest

import avacraft
from avacraft import AvacraftError, StarCraft2Env
from conftest import random_actions


def play(env, rng, max_steps=10_000):
    """An episode with random available actions: rewards, observations, the last info."""
    obs, state = env.reset()
    rewards, trace = [], [np.concatenate(obs)]
    for _ in range(max_steps):
        r, terminated, info = env.step(random_actions(env.get_avail_actions(), rng))
        rewards.append(r)
        trace.append(np.concatenate(env.get_obs()))
        if terminated:
            return rewards, trace, info
    raise AssertionError("episode did not end")


@pytest.mark.parametrize("name", ["3m_vlm", "2s3z_vlm"])
def test_shapes_match_env_info(name):
    env = StarCraft2Env(map_name=name, seed=3)
    info = env.get_env_info()
    assert set(info) == {"state_shape", "obs_shape", "n_actions", "n_agents", "episode_limit"}
    obs, state = env.reset()
    assert len(obs) == info["n_agents"] == env.n_agents
    assert all(o.shape == (info["obs_shape"],) and o.dtype == np.float32 for o in obs)
    assert state.shape == (info["state_shape"],) and state.dtype == np.float32
    assert np.array_equal(env.get_obs_agent(1), obs[1])
    avail = env.get_avail_actions()
    assert len(avail) == info["n_agents"] and all(len(a) == info["n_actions"] for a in avail)
    assert env.get_avail_agent_actions(0) == avail[0]
    assert env.get_total_actions() == info["n_actions"]
    assert env.get_obs_size() == info["obs_shape"] and env.get_state_size() == info["state_shape"]


def test_smac_sizes_of_3m():
    # SMAC's own numbers for 3m (smac_layout.md): SMAC's map under SMAC's name, and the
    # paper's 3m_vlm, which has the same armies and a 300 s limit.
    info = StarCraft2Env(map_name="3m").get_env_info()
    assert (info["n_actions"], info["obs_shape"], info["state_shape"], info["episode_limit"]) == (9, 30, 48, 60)
    info = StarCraft2Env(map_name="3m_vlm").get_env_info()
    assert (info["n_actions"], info["obs_shape"], info["state_shape"], info["episode_limit"]) == (9, 30, 48, 840)


def test_every_smac_map_loads_by_its_smac_name():
    names = avacraft.scenario_names()
    for name, agents, limit in [("3s5z", 8, 150), ("corridor", 6, 400), ("27m_vs_30m", 27, 180), ("2c_vs_64zg", 2, 400)]:
        assert name in names
        info = StarCraft2Env(map_name=name).get_env_info()
        assert (info["n_agents"], info["episode_limit"]) == (agents, limit), name


@pytest.mark.parametrize("name", ["3m_vlm", "2s3z_vlm"])
def test_random_episodes_play_to_the_end(name, rng):
    env = StarCraft2Env(map_name=name, seed=1)
    for _ in range(3):
        rewards, _, info = play(env, rng)
        assert set(info) >= {"battle_won", "dead_allies", "dead_enemies"}
        assert all(np.isfinite(rewards)) and min(rewards) >= 0  # SMAC's reward_only_positive
        ended_in_game = info["dead_allies"] == env.n_agents or info["dead_enemies"] == env.n_enemies
        assert ended_in_game or info.get("episode_limit")
        if info["battle_won"]:
            assert info["dead_enemies"] == env.n_enemies
    stats = env.get_stats()
    assert stats["battles_game"] == 3 and 0 <= stats["win_rate"] <= 1


def test_dead_agents_only_have_noop(rng):
    env = StarCraft2Env(map_name="3m_vlm", seed=2)
    env.reset()
    dead_seen = 0
    while True:
        r, terminated, info = env.step(random_actions(env.get_avail_actions(), rng))
        if terminated:
            break
        for agent, alive in enumerate(env.env.alive()):
            if not alive:
                dead_seen += 1
                assert env.get_avail_agent_actions(agent) == [1] + [0] * (env.n_actions - 1)
                assert not env.get_obs_agent(agent).any()
    assert dead_seen > 0, "no agent died before the episode ended: nothing was checked"


def test_time_out_terminates_with_episode_limit():
    env = StarCraft2Env(map_name="3m_vlm", seed=1, episode_limit=3)
    assert env.get_env_info()["episode_limit"] == 3
    env.reset()
    infos = []
    for _ in range(3):
        r, terminated, info = env.step([1, 1, 1])  # everyone stops: nobody fights
        infos.append((terminated, info))
    assert [t for t, _ in infos] == [False, False, True]
    assert "episode_limit" not in infos[0][1]
    assert infos[-1][1]["episode_limit"] is True and infos[-1][1]["battle_won"] is False
    assert env.get_stats()["timeouts"] == 1
    # SMAC's continuing_episode=False leaves the key out (PyMARL's sc2.yaml passes False).
    smac = StarCraft2Env(map_name="3m_vlm", seed=1, episode_limit=2, continuing_episode=False)
    smac.reset()
    smac.step([1, 1, 1])
    _, terminated, info = smac.step([1, 1, 1])
    assert terminated and "episode_limit" not in info
    with pytest.raises(AvacraftError, match="episode is over"):
        smac.step([1, 1, 1])


def test_same_seed_same_trajectory(rng):
    a = StarCraft2Env(map_name="2s3z_vlm", seed=7)
    b = StarCraft2Env(map_name="2s3z_vlm", seed=7)
    ra, ta, _ = play(a, np.random.default_rng(5))
    rb, tb, _ = play(b, np.random.default_rng(5))
    assert ra == rb
    assert len(ta) == len(tb) and all(np.array_equal(x, y) for x, y in zip(ta, tb))
    c = StarCraft2Env(map_name="2s3z_vlm", seed=8)
    rc, tc, _ = play(c, np.random.default_rng(5))
    assert rc != ra or any(not np.array_equal(x, y) for x, y in zip(ta, tc))


def test_seed_get_and_set(rng):
    env = StarCraft2Env(map_name="3m_vlm", seed=11)
    assert env.seed() == 11
    first, _ = env.reset()
    env.reset()
    assert env.seed(11) == 11  # back to episode 0 of seed 11
    again, _ = env.reset()
    assert all(np.array_equal(x, y) for x, y in zip(first, again))
    assert isinstance(StarCraft2Env(map_name="3m_vlm").seed(), int)


def test_sparse_reward_and_scale_rate(rng):
    # Unscaled, SMAC's sparse reward is +1 / -1 / 0 (scaled: below).
    env = StarCraft2Env(map_name="3m_vlm", seed=4, reward_sparse=True, reward_scale=False)
    rewards, _, info = play(env, rng)
    assert set(rewards[:-1]) <= {0.0}
    assert rewards[-1] == (1.0 if info["battle_won"] else (0.0 if info.get("episode_limit") or info["dead_allies"] < 3 else -1.0))
    # reward_scale_rate scales the dense reward linearly.
    a = StarCraft2Env(map_name="3m_vlm", seed=4)
    b = StarCraft2Env(map_name="3m_vlm", seed=4, reward_scale_rate=10)
    ra, _, _ = play(a, np.random.default_rng(1))
    rb, _, _ = play(b, np.random.default_rng(1))
    assert np.allclose(np.array(ra) / 2, rb)


def test_state_and_obs_options():
    base = StarCraft2Env(map_name="3m_vlm", seed=1)
    env = StarCraft2Env(map_name="3m_vlm", seed=1, state_last_action=False, state_timestep_number=True, obs_timestep_number=True)
    obs, state = env.reset()
    assert state.shape == (env.get_state_size(),) == (48 - 3 * 9 + 1,)
    assert obs[0].shape == (env.get_obs_size(),) == (31,)
    both = StarCraft2Env(map_name="3m_vlm", seed=1, obs_instead_of_state=True)
    obs, state = both.reset()
    assert np.array_equal(state, np.concatenate(obs)) and both.get_state_size() == 90
    assert base.get_env_info()["state_shape"] == 48


def test_the_agent_specific_state(rng):
    """`state_agent=True`: the MAPPO repository's agent-specific state, every agent's row one
    after another; each row ends in the agent's one-hot id, and the game is the one played
    without the option."""
    env = StarCraft2Env(map_name="2s3z", seed=4, state_agent=True)
    plain = StarCraft2Env(map_name="2s3z", seed=4)
    n = env.n_agents
    # 2s3z: 5 agents and enemies, 11 actions, shields and two type bits a side.
    row = 4 * (8 + 1 + 2 + 11) + 5 * (8 + 1 + 2) + 4 + (7 + 1 + 2 + 11) + n
    assert env.get_state_size() == n * row == env.get_env_info()["state_shape"]
    assert plain.get_state_size() != env.get_state_size()
    _, state = env.reset()
    plain.reset()
    for _ in range(5):
        acts = random_actions(env.get_avail_actions(), rng)
        assert env.get_avail_actions() == plain.get_avail_actions()
        env.step(acts)
        plain.step(acts)
        assert all(np.array_equal(a, b) for a, b in zip(env.get_obs(), plain.get_obs()))
    state = env.get_state()
    rows = [env.get_state_agent(i) for i in range(n)]
    assert np.array_equal(np.concatenate(rows), state)
    for i, r in enumerate(rows):
        assert list(r[-n:]) == [1.0 if k == i else 0.0 for k in range(n)]
    with pytest.raises(AvacraftError, match="agent_id"):
        env.get_state_agent(n)
    with pytest.raises(AvacraftError, match="state_agent"):
        plain.get_state_agent(0)
    with pytest.raises(AvacraftError, match="state_last_action"):
        StarCraft2Env(map_name="2s3z", state_agent=True, state_last_action=False)


def test_pymarl_sc2_yaml_keys_are_accepted():
    # PyMARL's src/config/envs/sc2.yaml env_args.
    args = dict(
        continuing_episode=False, difficulty="7", game_version=None, map_name="3m_vlm", move_amount=2, obs_all_health=True,
        obs_instead_of_state=False, obs_last_action=False, obs_own_health=True, obs_pathing_grid=False,
        obs_terrain_height=False, obs_timestep_number=False, reward_death_value=10, reward_defeat=0,
        reward_negative_scale=0.5, reward_only_positive=True, reward_scale=True, reward_scale_rate=20, reward_sparse=False,
        reward_win=200, replay_dir="", replay_prefix="", state_last_action=True, state_timestep_number=False, step_mul=8,
        seed=1, heuristic_ai=False, heuristic_rest=False, debug=False, window_size_x=1920, window_size_y=1200,
    )
    env = StarCraft2Env(**args)
    assert env.get_env_info()["n_agents"] == 3


@pytest.mark.parametrize(
    "key,value,words",
    [
        ("difficulty", "3", ["difficulty", "'3'", "'7'"]),
        ("obs_last_action", True, ["obs_last_action", "True", "False"]),
        ("obs_pathing_grid", True, ["obs_pathing_grid"]),
        ("reward_only_positive", 0, ["reward_only_positive", "True or False"]),
        ("reward_win", -5, ["reward_win", "-5", "0 or more"]),
        ("reward_death_value", "10", ["reward_death_value", "a number"]),
        ("reward_scale_rate", 0, ["reward_scale_rate", "above 0"]),
        ("reward_negative_scale", "half", ["reward_negative_scale", "a number"]),
        ("move_amount", 3, ["move_amount", "3", "2"]),
        ("game_version", "4.10", ["game_version", "4.10"]),
        ("heuristic_ai", 1, ["heuristic_ai", "True or False"]),
        ("step_mul", 0, ["step_mul", "positive"]),
        ("opponent", "nobody", ["opponent", "nobody", "builtin"]),
        ("reward_scale", 1, ["reward_scale", "True or False"]),
    ],
)
def test_unsupported_option_values_raise(key, value, words):
    with pytest.raises(ValueError) as e:
        StarCraft2Env(map_name="3m_vlm", **{key: value})
    assert isinstance(e.value, AvacraftError)
    for w in words:
        assert w in str(e.value)


def _reward_battle_by_hand(env: StarCraft2Env, actions_of, *, neg: float, only_positive: bool, death: float, win: float, defeat: float, rate):
    """Plays an episode and checks each step's reward against SMAC's `reward_battle` and the
    end terms of its `step`, computed here from the units' life and shields (a unit gone
    from the full-vision list is dead). Returns whether the episode was won."""
    env.reset()
    units = env._env.units()
    prev = {u["tag"]: u["hp"] + u["shield"] for u in units}
    team = {u["tag"]: u["team"] for u in units}
    max_reward = sum(u["max_hp"] + u["max_shield"] + death for u in units if u["team"] == 2) + win
    assert env._env.max_reward(1) == pytest.approx(max_reward)
    while True:
        r, done, info = env.step(actions_of(env))
        now = {u["tag"]: u["hp"] + u["shield"] for u in env._env.units()}
        d_enemy = d_deaths = d_ally = 0.0
        for tag in list(prev):
            hp = now.get(tag)
            if team[tag] == 1:
                if hp is None:
                    d_deaths -= 0.0 if only_positive else death * neg
                    d_ally += prev[tag] * neg
                else:
                    d_ally += neg * (prev[tag] - hp)
            elif hp is None:
                d_deaths += death
                d_enemy += prev[tag]
            else:
                d_enemy += prev[tag] - hp
            if hp is None:
                del prev[tag]
            else:
                prev[tag] = hp
        want = abs(d_enemy + d_deaths) if only_positive else d_enemy + d_deaths - d_ally
        allies, enemies = (sum(team[t] == k for t in prev) for k in (1, 2))
        if done and info["battle_won"]:
            want += win
        elif done and allies == 0 and enemies > 0:
            want += defeat
        if rate is not None:
            want /= max_reward / rate
        assert r == pytest.approx(want, rel=1e-4, abs=1e-4), (env._episode_steps, r, want)
        if done:
            return info["battle_won"]


@pytest.mark.parametrize("only_positive,neg,rate", [(True, 0.5, 20), (False, 0.5, 20), (False, 1.5, None)])
def test_the_reward_settings_pay_as_smac_computes(only_positive, neg, rate):
    kw = dict(
        reward_only_positive=only_positive, reward_negative_scale=neg, reward_scale=rate is not None, reward_scale_rate=rate or 20,
        reward_death_value=7, reward_win=150, reward_defeat=-3,
    )
    check = dict(neg=neg, only_positive=only_positive, death=7, win=150, defeat=-3, rate=rate)
    rng = np.random.default_rng(0)

    def pick(env):
        return [int(rng.choice(np.flatnonzero(a))) for a in env.get_avail_actions()]

    # Random agents lose SMAC's 3m; SMAC's own script wins it.
    lost = StarCraft2Env(map_name="3m", seed=5, full_vision=True, **kw)
    assert not _reward_battle_by_hand(lost, pick, **check)
    won = StarCraft2Env(map_name="3m", seed=6, full_vision=True, heuristic_ai=True, **kw)
    assert _reward_battle_by_hand(won, lambda env: [0] * env.n_agents, **check)


def test_the_sparse_reward_is_scaled_as_smac_scales_it():
    # SMAC divides its sparse +1 by max_reward / reward_scale_rate as well (3m: 3 Marines of
    # 45 life, 10 a kill, 200 a win: 365).
    for scale, want in ((True, 20 / 365), (False, 1.0)):
        env = StarCraft2Env(map_name="3m", seed=6, full_vision=True, heuristic_ai=True, reward_sparse=True, reward_scale=scale)
        env.reset()
        total = 0.0
        while True:
            r, done, info = env.step([0] * env.n_agents)
            total += r
            if done:
                break
        assert info["battle_won"] and total == pytest.approx(want), (scale, total)


def test_unknown_keyword_and_scenario():
    with pytest.raises(TypeError):
        StarCraft2Env(map_name="3m_vlm", no_such_option=1)
    with pytest.raises(AvacraftError) as e:
        StarCraft2Env(map_name="4m")
    assert "4m" in str(e.value) and "3m_vlm" in str(e.value) and "2s3z_vlm" in str(e.value)


def test_scenario_file_by_path(tmp_path):
    import glob
    import os

    files = glob.glob(os.path.join(os.path.dirname(__file__), "..", "..", "engine", "scenarios", "3m_vlm.toml"))
    assert files, "engine/scenarios/3m_vlm.toml is not two folders above the tests: run them from the repository"
    env = StarCraft2Env(map_name=files[0], seed=1)
    assert env.get_env_info() == StarCraft2Env(map_name="3m_vlm").get_env_info()
    bad = tmp_path / "bad.toml"
    bad.write_text("this is = not [ a scenario")
    with pytest.raises(AvacraftError, match="bad.toml"):
        StarCraft2Env(map_name=str(bad))


def test_bad_actions_name_what_is_wrong():
    env = StarCraft2Env(map_name="3m_vlm", seed=1)
    env.reset()
    with pytest.raises(AvacraftError, match="2 actions given for 3 agents"):
        env.step([1, 1])
    with pytest.raises(AvacraftError, match=r"agent 1: action 9 is out of range \(0\.\.9\)"):
        env.step([1, 9, 1])
    with pytest.raises(AvacraftError, match=r"agent 0: action -1 is out of range"):
        env.step([-1, 1, 1])
    with pytest.raises(AvacraftError, match=r"agent 2: action 6 is not available now \(available: \[1, 2, 3, 4, 5\]\)"):
        env.step([1, 1, 6])
    with pytest.raises(AvacraftError, match=r"agent 0: action 0 is not available"):
        env.step([0, 1, 1])
    with pytest.raises(TypeError, match="dtype float"):
        env.step(np.array([1.0, 1.0, 1.0]))
    with pytest.raises(TypeError, match="float"):
        env.step([1, 1.5, 1])
    with pytest.raises(TypeError, match="integer"):
        env.step(["a", "b", "c"])
    with pytest.raises(TypeError, match="integer"):
        env.step("111")
    with pytest.raises(TypeError, match="string"):
        env.env.step("111")
    with pytest.raises(ValueError, match=r"shape \[1, 3\] given, \[3\] needed"):
        env.step(np.ones((1, 3), dtype=np.int64))
    with pytest.raises(AvacraftError, match="out of range"):
        env.get_obs_agent(3)
    with pytest.raises(AvacraftError, match="out of range"):
        env.get_avail_agent_actions(-1)
    # Nothing was applied by the refused steps.
    assert env.env.steps == 0
    env.step(np.array([1, 1, 1], dtype=np.int32))  # any integer dtype
    assert env.env.steps == 1


def test_render_rgb_array_and_human():
    env = StarCraft2Env(map_name="3m_vlm", seed=1, window_size_x=320, window_size_y=200)
    env.reset()
    img = env.render(mode="rgb_array")
    assert img.shape == (200, 320, 3) and img.dtype == np.uint8 and img.std() > 0
    with pytest.raises(NotImplementedError, match="rgb_array"):
        env.render()
    with pytest.raises(ValueError, match="rgb_array"):
        env.render(mode="ansi")
    env.close()


def test_save_replay_writes_a_gif(tmp_path, rng):
    env = StarCraft2Env(map_name="3m_vlm", seed=1, replay_dir=str(tmp_path), replay_prefix="run")
    _, trace, _ = play(env, rng)
    path = env.save_replay()
    data = open(path, "rb").read()
    assert path.startswith(str(tmp_path)) and path.endswith(".gif") and data[:6] in (b"GIF89a", b"GIF87a")
    # One frame per step plus the first: count the GIF image descriptors' graphic control blocks.
    assert data.count(b"\x21\xf9\x04") == len(trace)
    with pytest.raises(AvacraftError, match="replay_dir"):
        StarCraft2Env(map_name="3m_vlm").save_replay()


def test_snapshot_and_restore(rng):
    env = StarCraft2Env(map_name="2s3z_vlm", seed=3)
    env.reset()
    for _ in range(5):
        env.step(random_actions(env.get_avail_actions(), rng))
    snap = env.snapshot()
    actions = [random_actions(env.get_avail_actions(), np.random.default_rng(9))]
    first = [env.step(actions[0])[0], env.get_state().copy()]
    env.restore(snap)
    second = [env.step(actions[0])[0], env.get_state().copy()]
    assert first[0] == second[0] and np.array_equal(first[1], second[1])


def test_vlm_observation_and_typed_actions():
    env = StarCraft2Env(map_name="3m_vlm", seed=1, full_vision=True)
    env.reset()
    vlm = env.get_vlm_obs(size=(320, 180))
    assert vlm["image"].shape == (180, 320, 3) and vlm["image"].dtype == np.uint8
    assert isinstance(vlm["text"], str) and "Marine" in vlm["text"]
    units = vlm["units"]
    assert {u["tag"] for u in units} == {1, 2, 3, 4, 5, 6}
    assert {"tag", "name", "type", "team", "own", "x", "y", "grid", "hp", "max_hp", "order"} <= set(units[0])
    own = [u["tag"] for u in units if u["own"]]
    enemy = [u["tag"] for u in units if not u["own"]]
    r, terminated, info = env.step_typed(
        [
            {"unit": own[0], "command": {"kind": "attack", "target": enemy[0]}},
            {"unit": own[1], "command": {"kind": "move_grid", "x": 2, "y": 3}},
            {"unit": own[2], "command": "stop"},
            {"unit": own[2], "command": {"kind": "attack", "target": own[0]}},  # refused: friendly
        ]
    )
    assert set(info["refused"]) == {3} and "friendly" in info["refused"][3]
    after = {u["tag"]: u for u in env.env.units()}
    assert after[own[0]]["order"] == {"kind": "attack", "target": enemy[0]}
    assert after[own[1]]["order"]["kind"] == "move"


@pytest.mark.parametrize(
    "action,words",
    [
        ({"unit": 1, "command": {"kind": "attak", "target": 4}}, ["action 0", "attak", "attack"]),
        ({"unit": 1, "command": {"kind": "attack"}}, ["action 0", "target"]),
        ({"unit": 1, "command": {"kind": "move_grid", "x": "a", "y": 1}}, ["action 0", "invalid type"]),
        ({"unit": 0, "command": "stop"}, ["action 0", "unit", "tag"]),
        ({"command": "stop"}, ["action 0", "unit"]),
        ({"unit": 1}, ["action 0", "command"]),
        ({"unit": 1, "command": "stop", "extra": 1}, ["action 0", "extra"]),
        ({"unit": 1, "command": {"kind": "move_dir", "dir": "north"}}, ["action 0", "north", "up"]),
        ("stop", ["action 0", "not a dict"]),
    ],
)
def test_bad_typed_actions_raise(action, words):
    env = StarCraft2Env(map_name="3m_vlm", seed=1)
    env.reset()
    with pytest.raises(AvacraftError) as e:
        env.step_typed([{"unit": 2, "command": "stop"}, action][1:])
    for w in words:
        assert w in str(e.value), str(e.value)
    assert env.env.steps == 0


def test_scenario_helpers():
    assert "3m_vlm" in avacraft.scenario_names() and "MMM_vs_MMM" in avacraft.scenario_names()
    assert avacraft.scenario_info("MMM_vs_MMM")["mode"] == "pvp"
    assert avacraft.scenario_info("3m_vlm")["units"] == (3, 3)


def test_the_surround_experiment_changes_the_melee_fight():
    # corridor's Zealots against Zerglings under SMAC's heuristic: with the experiment on,
    # Zerglings walk round those at their target, so the same seeds play other games.
    def games(surround: bool) -> list:
        env = StarCraft2Env(map_name="corridor", heuristic_ai=True, melee_surround=surround, seed=9000)
        out = []
        for _ in range(3):
            env.reset()
            terminated, steps, ret = False, 0, 0.0
            while not terminated:
                actions = [1 if env.get_avail_agent_actions(a)[1] else 0 for a in range(env.n_agents)]
                reward, terminated, _ = env.step(actions)
                steps, ret = steps + 1, ret + reward
            out.append((steps, round(ret, 4)))
        env.close()
        return out
    off = games(False)
    assert games(False) == off
    assert games(True) != off
    with pytest.raises(AvacraftError, match="melee_surround"):
        StarCraft2Env(map_name="corridor", melee_surround="yes")


def test_heuristic_ai_plays_smacs_script():
    # SMAC's heuristic (each agent on its nearest enemy until it dies) wins 2s3z here 99
    # times in 100 (eval/smac/heuristic.csv); the actions given are not played.
    def wins(heuristic: bool) -> int:
        env = StarCraft2Env(map_name="2s3z", heuristic_ai=heuristic, seed=9000)
        won = 0
        for _ in range(4):
            env.reset()
            terminated, info = False, {}
            while not terminated:
                # Stop for the living, no-op for the dead: SMAC's valid actions.
                actions = [1 if env.get_avail_agent_actions(a)[1] else 0 for a in range(env.n_agents)]
                _, terminated, info = env.step(actions)
            won += info["battle_won"]
        env.close()
        return won
    assert wins(True) >= 3
    assert wins(False) == 0
    env = StarCraft2Env(map_name="2s3z", heuristic_ai=True)
    env.reset()
    with pytest.raises(AvacraftError, match="actions: 2 given, 5 agents"):
        env.step([1, 1])
    # The state's last actions are the heuristic's (attacks), not the stops passed in.
    env.step([1] * env.n_agents)
    n = env.n_agents * env.n_actions
    last = np.asarray(env.get_state())[-n:].reshape(env.n_agents, env.n_actions)
    attack_base = env.n_actions - 5
    assert (last.argmax(axis=1) >= attack_base).all() and (last.sum(axis=1) == 1).all()
