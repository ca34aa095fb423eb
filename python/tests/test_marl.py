"""`avacraft.MarlPolicy`: a checkpoint of `avacraft train` acting from Python plays the episodes
the Rust agent (`avacraft episode --agent marl:DIR`) plays. The checkpoint is the committed
launch/policies/3m_vlm; nothing here depends on how well it plays."""

import pathlib

import numpy as np
import pytest

import avacraft

POLICY = pathlib.Path(__file__).resolve().parents[2] / "launch" / "policies" / "3m_vlm"


def reference(policy, seed):
    """The Rust agent's episode on `avacraft episode`'s settings (sparse reward, no passive
    allies), and the environment at its end."""
    env = avacraft.Env("3m_vlm", reward="sparse", passive_allies=False)
    return policy.play(env, seed), env


def smac_episode(policy, seed, frames=False):
    """An episode of a SMAC loop with the policy (`frames`: acting through `act_env`): the
    actions of every step, the result, the environment at its end."""
    env = avacraft.StarCraft2Env("3m_vlm", seed=seed, reward_sparse=True, passive_allies=False)
    env.reset()
    policy.reset()
    done, info, actions = False, {}, []
    while not done:
        avail = env.get_avail_actions()
        a = policy.act_env(env) if frames else policy.act(env.get_obs(), avail)
        assert a.dtype == np.int64 and all(avail[i][x] for i, x in enumerate(a))
        actions.append(a.tolist())
        _, done, info = env.step(a)
    return actions, info, env.env


def test_a_smac_loop_plays_the_rust_agents_episodes_action_for_action():
    policy = avacraft.MarlPolicy(POLICY)
    assert (policy.scenario, policy.n_agents, policy.n_actions) == ("3m_vlm", 3, 9)
    for seed in (1, 2, 3):
        actions, info, env = smac_episode(policy, seed)
        ref, ref_env = reference(policy, seed)
        # A dead unit gets no order from the Rust agent (-1) and the no-op from a SMAC loop.
        assert actions == [[a if a >= 0 else 0 for a in step] for step in ref["actions"]], f"seed {seed}"
        assert env.steps == ref["steps"] == len(actions)
        assert env.units() == ref_env.units(), "the same units, positions and health at the end"
        assert info["battle_won"] == (ref["result"] == "win")


def test_parallel_env_observations_play_the_same_episodes():
    policy = avacraft.MarlPolicy(POLICY)
    env = avacraft.parallel_env("3m_vlm", obs_mode="features")
    for seed in (4, 5):
        obs, _ = env.reset(seed=seed)
        policy.reset()
        while env.agents:
            obs, _, _, _, infos = env.step(policy.act_parallel(obs))
            assert not any("invalid_action" in i for i in infos.values())
        # The same SMAC actions as the SMAC loop's, so the same trajectory hash.
        _, _, smac = smac_episode(policy, seed)
        assert env.env.trajectory_hash == smac.trajectory_hash, f"seed {seed}"
        ref, ref_env = reference(policy, seed)
        assert (env.env.steps, env.env.units()) == (ref["steps"], ref_env.units())


def test_a_fresh_reset_replays_the_episode_and_state_carries_across_steps():
    policy = avacraft.MarlPolicy(POLICY)
    env = avacraft.Env("3m_vlm", seed=1)
    env.reset(7)
    first = [policy.act(env.obs(), env.avail()).tolist() for _ in range(3)]
    policy.reset()
    again = [policy.act(env.obs(), env.avail()).tolist() for _ in range(3)]
    assert first == again
    # What carries (each agent's last action, an input of this checkpoint's network) changes
    # what it does: over an episode, acting on from the last step and acting afresh at every
    # step part ways.
    policy.reset()
    fresh = avacraft.MarlPolicy(POLICY)
    env.reset(7)
    differ = 0
    while not env.done:
        carried = policy.act(env.obs(), env.avail())
        fresh.reset()
        differ += int((carried != fresh.act(env.obs(), env.avail())).any())
        env.step(carried)
    assert differ > 0


def test_bad_checkpoints_and_inputs_raise(tmp_path):
    with pytest.raises(avacraft.AvacraftError, match="missing does not exist"):
        avacraft.MarlPolicy(tmp_path / "missing")
    (tmp_path / "config.json").write_text("{ not json")
    with pytest.raises(avacraft.AvacraftError, match="cannot load the checkpoint"):
        avacraft.MarlPolicy(tmp_path)
    policy = avacraft.MarlPolicy(POLICY)
    with pytest.raises(avacraft.AvacraftError, match=r"obs: shape \[2, 30\] given, \[3, 30\] needed"):
        policy.act(np.zeros((2, 30)), np.ones((3, 9)))
    with pytest.raises(avacraft.AvacraftError, match=r"avail\[1\]: no action is available"):
        policy.act(np.zeros((3, 30)), np.array([[1] * 9, [0] * 9, [1] * 9]))
    with pytest.raises(avacraft.AvacraftError, match="trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`"):
        policy.play(avacraft.Env("2m_vs_1z_vlm"), 1)
    with pytest.raises(avacraft.AvacraftError, match="trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`"):
        policy.check_env(avacraft.Env("2m_vs_1z_vlm"))
    policy.check_env(avacraft.Env("3m_vlm"))
    with pytest.raises(avacraft.AvacraftError, match="SMAC features of 30 needed"):
        env = avacraft.parallel_env("3m_vlm", obs_mode="rgb")
        obs, _ = env.reset(seed=1)
        policy.act_parallel(obs)


def test_a_shipped_baseline_by_name_plays_as_its_checkpoint(tmp_path, monkeypatch):
    shipped = tmp_path / "3m_vlm" / "qmix"
    shipped.mkdir(parents=True)
    for f in ("agent.safetensors", "config.json"):
        (shipped / f).write_bytes((POLICY / f).read_bytes())
    monkeypatch.setenv("AVACRAFT_BASELINES", str(tmp_path))
    by_name = avacraft.MarlPolicy.baseline("3m_vlm", "qmix")
    assert (by_name.scenario, by_name.algo) == ("3m_vlm", avacraft.MarlPolicy(POLICY).algo)
    ref, _ = reference(avacraft.MarlPolicy(POLICY), 3)
    assert by_name.play(avacraft.Env("3m_vlm", reward="sparse", passive_allies=False), 3)["actions"] == ref["actions"]
    with pytest.raises(avacraft.AvacraftError, match=r"no shipped `mappo` baseline for scenario `3m_vlm`.*shipped there: qmix"):
        avacraft.MarlPolicy.baseline("3m_vlm", "mappo")
    with pytest.raises(avacraft.AvacraftError, match="only letters"):
        avacraft.MarlPolicy.baseline("3m_vlm", "../qmix")



STACKED = pathlib.Path(__file__).resolve().parents[2] / "baselines" / "3s_vs_5z" / "mappo-ff-ln-stack"


def test_a_frame_stacking_policy_carries_its_observations_from_step_to_step_as_in_rust():
    """A shipped MAPPO that reads each agent's last 4 observations (`stacked_frames`) acts from
    a SMAC loop as the Rust agent plays it, the observations kept in the policy between steps
    (and dropped by `reset`)."""
    policy = avacraft.MarlPolicy(STACKED)
    for seed in (1, 2):
        env = avacraft.StarCraft2Env("3s_vs_5z", seed=seed)
        env.reset()
        policy.reset()
        done, actions, forgetful = False, [], 0
        while not done:
            obs, avail = env.get_obs(), env.get_avail_actions()
            a = policy.act(obs, avail)
            actions.append(a.tolist())
            fresh = avacraft.MarlPolicy(STACKED)
            forgetful += int((fresh.act(obs, avail) != a).any())
            _, done, info = env.step(a)
        ref = policy.play(avacraft.Env("3s_vs_5z"), seed)
        assert actions == [[x if x >= 0 else 0 for x in step] for step in ref["actions"]], f"seed {seed}"
        assert info["battle_won"] == (ref["result"] == "win")
        assert forgetful > 0, f"seed {seed}: acting without the observations before chose the same at every step"


PVP = pathlib.Path(__file__).resolve().parents[2] / "baselines" / "terran_mirror" / "mappo"


def team_arrays(obs, team, n, obs_size, n_actions):
    """A team's features and masks from parallel_env observations, as act_parallel builds them."""
    f = np.zeros((n, obs_size), dtype=np.float32)
    m = np.zeros((n, n_actions), dtype=np.uint8)
    m[:, 0] = 1
    for name, o in obs.items():
        if name.startswith(f"team{team}_agent_"):
            i = int(name.rsplit("_", 1)[1])
            f[i], m[i] = o["observation"], o["action_mask"]
    return f, m


def test_team_2_plays_in_the_mirror_image_as_the_rust_agent():
    """A PvP checkpoint (trained as team 1) on both teams of a parallel_env: team 2's policy
    sees and acts in the mirror image, and the episodes are those `play` runs with the Rust
    agent on both teams (`episode --agent marl:DIR --agent2 marl:DIR`)."""
    env = avacraft.parallel_env("terran_mirror", obs_mode="features")
    differs = 0
    for seed in (1, 2):
        one, two, plain = avacraft.MarlPolicy(PVP), avacraft.MarlPolicy(PVP), avacraft.MarlPolicy(PVP)
        obs, _ = env.reset(seed=seed)
        while env.agents:
            a1, a2 = one.act_parallel(obs, team=1), two.act_parallel(obs, team=2)
            # The same network reading team 2's features as they are (no mirror).
            f, m = team_arrays(obs, 2, plain.n_agents, plain.obs_size, plain.n_actions)
            unmirrored = plain.act(f, m, team=1)
            differs += any(unmirrored[int(k.rsplit("_", 1)[1])] != v for k, v in a2.items())
            obs, _, _, _, infos = env.step({**a1, **a2})
            assert not any("invalid_action" in i for i in infos.values())
        ref_env = avacraft.Env("terran_mirror", reward="sparse", passive_allies=False)
        ref = avacraft.MarlPolicy(PVP).play(ref_env, seed)
        assert len(ref["actions2"]) == ref["steps"] == env.env.steps, f"seed {seed}"
        assert env.env.units() == ref_env.units(), f"seed {seed}: the same units, positions and health at the end"
    assert differs > 0, "the mirror changed no action"


RGB = pathlib.Path(__file__).resolve().parents[2] / "baselines" / "3m_vlm" / "mappo-rgb"


def test_an_image_checkpoint_plays_from_frames_rendered_from_the_game():
    policy = avacraft.MarlPolicy(RGB)
    assert (policy.obs, policy.scenario) == ("rgb", "3m_vlm")
    for seed in (1001, 1002):
        ref, ref_env = reference(policy, seed)
        actions, info, env = smac_episode(policy, seed, frames=True)
        # The Rust loop records a dead agent's no-op as -1, as the engine agent's no order.
        assert actions == [[a if a >= 0 else 0 for a in step] for step in ref["actions"]], f"seed {seed}"
        assert env.units() == ref_env.units()
        assert info["battle_won"] == (ref["result"] == "win")
    # The shipped policy won 100 of the paper table's 100 games on 3m_vlm.
    assert ref["result"] == "win"


def test_an_image_checkpoint_refuses_features_and_pvp():
    policy = avacraft.MarlPolicy(RGB)
    with pytest.raises(avacraft.AvacraftError, match=r"trained on `rgb` observations.*act_env\(env\)"):
        policy.act(np.zeros((3, policy.obs_size)), np.ones((3, 9)))
    with pytest.raises(avacraft.AvacraftError, match="trained on scenario `3m_vlm`, not `2s3z_vlm`"):
        policy.act_env(avacraft.Env("2s3z_vlm"))
    with pytest.raises(avacraft.AvacraftError, match="terran_mirror is PvP"):
        policy.play(avacraft.Env("terran_mirror"), 1)
    # A features checkpoint plays through act_env too: the actions `act` takes.
    features = avacraft.MarlPolicy(POLICY)
    env = avacraft.Env("3m_vlm", seed=1)
    env.reset(3)
    assert features.act_env(env).tolist() == features.act(env.obs(), env.avail()).tolist()
