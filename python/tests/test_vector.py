"""The vector environment: shapes, equality with single environments, thread independence."""

import numpy as np
import pytest

from avacraft import AvacraftError, Env, VecEnv
from conftest import random_actions


def rollout(vec, steps, seed):
    rng = np.random.default_rng(seed)
    obs, state, avail = vec.reset()
    out = []
    for _ in range(steps):
        acts = np.stack([random_actions(a, rng) for a in avail])
        obs, state, avail, reward, term, trunc, info = vec.step(acts)
        out.append((obs.copy(), state.copy(), avail.copy(), reward.copy(), term.copy(), trunc.copy(), info["seed"].copy()))
    return out


def test_shapes():
    vec = VecEnv("2s3z_vlm", num_envs=4, threads=2)
    info = vec.env_info
    obs, state, avail = vec.reset()
    assert obs.shape == (4, info["n_agents"], info["obs_shape"]) and obs.dtype == np.float32
    assert state.shape == (4, info["state_shape"]) and avail.shape == (4, info["n_agents"], info["n_actions"])
    acts = np.ones((4, info["n_agents"]), dtype=np.int64)
    obs, state, avail, reward, term, trunc, infos = vec.step(acts)
    assert reward.shape == term.shape == trunc.shape == (4,) and term.dtype == bool
    assert set(infos) == {"battle_won", "dead_allies", "dead_enemies", "episode_limit", "seed"}


def test_independent_of_thread_count():
    seeds = [3, 1, 4, 1, 5, 9]
    one = rollout(VecEnv("3m_vlm", seeds=seeds, threads=1), 150, 0)
    two = rollout(VecEnv("3m_vlm", seeds=seeds, threads=2), 150, 0)
    for a, b in zip(one, two):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)
    assert any(step[4].any() for step in one), "some episode should have ended (auto-reset)"


def test_matches_single_environments():
    seeds = [10, 11, 12]
    vec = VecEnv("3m_vlm", seeds=seeds, threads=2)
    singles = [Env("3m_vlm", seed=s) for s in seeds]
    rng = np.random.default_rng(1)
    obs, state, avail = vec.reset()
    ended = 0
    for step in range(150):
        for i, e in enumerate(singles):
            assert np.array_equal(obs[i], e.obs()) and np.array_equal(state[i], e.state()) and np.array_equal(avail[i], e.avail())
        acts = np.stack([random_actions(a, rng) for a in avail])
        obs, state, avail, reward, term, trunc, info = vec.step(acts)
        # Gymnasium's same-step autoreset: the final observation only on steps that ended one.
        assert ("final_obs" in info) == bool((term | trunc).any())
        for i, e in enumerate(singles):
            r, _, t, tr, _ = e.step(acts[i])
            assert np.isclose(reward[i], r) and term[i] == t and trunc[i] == tr
            if t or tr:
                ended += 1
                assert info["_final_obs"][i]
                assert np.array_equal(info["final_obs"][i], e.obs()) and np.array_equal(info["final_state"][i], e.state())
                assert np.array_equal(info["final_avail"][i], e.avail())
                e.reset(int(info["seed"][i]))
            elif "final_obs" in info:
                assert not info["_final_obs"][i]
    assert ended > 0, "some episode should have ended"


def test_declares_gymnasium_autoreset_mode():
    from gymnasium.vector import AutoresetMode

    assert VecEnv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP


def test_errors():
    vec = VecEnv("3m_vlm", num_envs=2)
    vec.reset()
    with pytest.raises(ValueError, match=r"shape \[2, 2\] given, \[2, 3\] needed"):
        vec.step(np.ones((2, 2), dtype=np.int64))
    with pytest.raises(TypeError, match="dtype float"):
        vec.step(np.ones((2, 3)))
    with pytest.raises(AvacraftError, match=r"environment 1: agent 0: action 7 is not available"):
        vec.step(np.array([[1, 1, 1], [7, 1, 1]]))
    with pytest.raises(AvacraftError, match="num_envs or seeds"):
        VecEnv("3m_vlm")
    with pytest.raises(AvacraftError, match="threads"):
        VecEnv("3m_vlm", num_envs=2, threads=0)
    with pytest.raises(AvacraftError, match="at least one seed"):
        VecEnv("3m_vlm", seeds=[])
    with pytest.raises(AvacraftError, match="unknown scenario `nope`"):
        VecEnv("nope", num_envs=1)
