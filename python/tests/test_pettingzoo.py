"""The PettingZoo ParallelEnv: PettingZoo's own API, seed and state tests, PvP, modes."""

import numpy as np
import pytest

# PettingZoo is one of the tests' requirements (python3 -m pip install pettingzoo gymnasium):
# without it this module fails to import, it is not skipped.
from pettingzoo.test import parallel_api_test, parallel_seed_test

import avacraft
from avacraft import AvacraftError


@pytest.mark.parametrize("scenario", ["3m_vlm", "MMM_vs_MMM"])
@pytest.mark.parametrize("mode", ["features", "rgb"])
def test_parallel_api(scenario, mode):
    env = avacraft.parallel_env(scenario, obs_mode=mode, seed=1, screen_size=(64, 48), minimap_size=(16, 16))
    parallel_api_test(env, num_cycles=1000)


@pytest.mark.parametrize("scenario", ["3m_vlm", "MMM_vs_MMM"])
def test_parallel_seed(scenario):
    parallel_seed_test(lambda: avacraft.parallel_env(scenario, obs_mode="features"), num_cycles=200)


def test_pvp_has_both_teams_and_pve_one():
    pvp = avacraft.parallel_env("MMM_vs_MMM", seed=0)
    assert any(a.startswith("team1_") for a in pvp.possible_agents) and any(a.startswith("team2_") for a in pvp.possible_agents)
    pve = avacraft.parallel_env("3m_vlm", seed=0)
    assert pve.possible_agents == ["agent_0", "agent_1", "agent_2"]


def play(env, seed, rng):
    obs, infos = env.reset(seed=seed)
    trace = []
    while env.agents:
        assert env.state_space.contains(env.state())
        for a in env.agents:
            assert env.observation_space(a).contains(obs[a]), a
        actions = {a: env.action_space(a).sample(mask=obs[a]["action_mask"]) for a in env.agents}
        live = list(env.agents)
        obs, rew, term, trunc, infos = env.step(actions)
        assert set(obs) == set(rew) == set(term) == set(trunc) == set(infos) == set(live)
        gone = {a for a in live if term[a] or trunc[a]}
        assert set(env.agents) == set(live) - gone
        trace.append((sorted(rew.items()), sorted(term.items())))
    return trace, infos


def test_episodes_end_and_dead_agents_leave():
    env = avacraft.parallel_env("3m_vlm", seed=3)
    for a in env.possible_agents:
        env.action_space(a).seed(0)
    trace, infos = play(env, 3, None)
    assert trace and all("battle_won" in i for i in infos.values())


def test_same_seed_same_episode():
    def run():
        env = avacraft.parallel_env("MMM_vs_MMM")
        for i, a in enumerate(env.possible_agents):
            env.action_space(a).seed(i)
        return play(env, 5, None)[0]

    assert run() == run()


def test_hybrid_and_vlm_modes():
    env = avacraft.parallel_env("3m_vlm", obs_mode="hybrid", seed=0, screen_size=(80, 60))
    obs, _ = env.reset()
    o = obs["agent_0"]
    assert o["observation"].dtype == np.float32 and o["screen"].shape == (60, 80, 3) and o["action_mask"].dtype == np.int8
    env = avacraft.parallel_env("3m_vlm", obs_mode="vlm", seed=0, vlm_size=(320, 180))
    obs, _ = env.reset()
    o = obs["agent_1"]
    assert o["observation"].shape == (180, 320, 3) and o["observation"].dtype == np.uint8
    assert isinstance(o["text"], str) and isinstance(o["units"], list) and o["units"][0]["tag"] >= 1
    assert env.observation_space("agent_1").contains(o)
    env.step({a: 1 for a in env.agents})


def test_invalid_actions():
    env = avacraft.parallel_env("3m_vlm", seed=0)
    env.reset()
    # Attacking an enemy out of range: unavailable at the start. By default it becomes stop.
    _, _, _, _, infos = env.step({"agent_0": 6, "agent_1": 1, "agent_2": 1})
    assert infos["agent_0"]["invalid_action"] == 6 and "invalid_action" not in infos["agent_1"]
    with pytest.raises(AvacraftError, match="agent_0: action 99 is out of range"):
        env.step({"agent_0": 99, "agent_1": 1, "agent_2": 1})
    with pytest.raises(AvacraftError, match="no action for agent_2"):
        env.step({"agent_0": 1, "agent_1": 1})
    with pytest.raises(AvacraftError, match="unknown agents"):
        env.step({"agent_0": 1, "agent_1": 1, "agent_2": 1, "agent_9": 1})
    with pytest.raises(AvacraftError, match="integer"):
        env.step({"agent_0": 1.0, "agent_1": 1, "agent_2": 1})
    strict = avacraft.parallel_env("3m_vlm", seed=0, invalid_action="raise")
    strict.reset()
    with pytest.raises(AvacraftError, match=r"agent_0: action 6 is not available now \(available: \[1, 2, 3, 4, 5\]\)"):
        strict.step({"agent_0": 6, "agent_1": 1, "agent_2": 1})


@pytest.mark.parametrize(
    "kwargs,words",
    [
        (dict(obs_mode="pixels"), ["obs_mode", "pixels", "features", "vlm"]),
        (dict(opponent="nobody"), ["opponent", "nobody"]),
        (dict(reward="shaped"), ["reward", "shaped"]),
        (dict(screen_size=(0, 10)), ["screen_size", "0"]),
        (dict(invalid_action="ignore"), ["invalid_action", "ignore"]),
    ],
)
def test_bad_options(kwargs, words):
    with pytest.raises(AvacraftError) as e:
        avacraft.parallel_env("3m_vlm", **kwargs)
    for w in words:
        assert w in str(e.value)


def test_render_rgb_array():
    env = avacraft.parallel_env("3m_vlm", seed=0, render_mode="rgb_array", screen_size=(64, 48))
    env.reset()
    assert env.render().shape == (48, 64, 3)
