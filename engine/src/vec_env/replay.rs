//! Episodes of a vector environment played again from their seeds and team 1's actions, on
//! copies, without touching the environments themselves. The game and its opponent are
//! deterministic given an episode's seed and team 1's actions, so a replay gives back every
//! observation, state, mask and reward the episode had: a learner keeps an episode as its
//! actions (a few bytes a step) and rebuilds the rest when it needs it, as a resumed run's
//! replay buffer does.

use super::{OpponentFactory, VecEnv, VecEnvError, episode_seed, fill, step_lane};
use crate::agent::{AgentTeam, Grouping};
use crate::env::{Env, EnvConfig};
use crate::ids::Team;
use crate::learn::check_against_masks;
use crate::scenario::Scenario;
use std::sync::Arc;

/// What a [`VecEnv`]'s episodes are made from (its scenario, rules, seeds and opponent), to
/// replay them on any thread ([`VecEnv::replayer`]).
#[derive(Clone)]
pub struct Replayer {
    scenario: Arc<Scenario>,
    cfg: EnvConfig,
    seeds: Vec<u64>,
    opponent: Option<OpponentFactory>,
    n_agents: usize,
    obs_size: usize,
    state_size: usize,
    n_actions: usize,
}

impl std::fmt::Debug for Replayer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replayer").field("scenario", &self.scenario.name).field("envs", &self.seeds.len()).finish()
    }
}

/// One episode played again: per step, what the vector environment's buffers held for its
/// lane before the step (what team 1's actions were chosen on) and what the step gave.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Replayed {
    /// Steps replayed.
    pub steps: usize,
    /// `steps x A x obs_shape`, `steps x state_shape`, `steps x A x n_actions`.
    pub obs: Vec<f32>,
    pub state: Vec<f32>,
    pub avail: Vec<u8>,
    /// `steps`: team 1's reward, whether the step ended the episode in the game, at the time
    /// limit.
    pub reward: Vec<f32>,
    pub terminated: Vec<bool>,
    pub truncated: Vec<bool>,
    /// Where the last step ended the episode: what it ended on (the buffers' `final_*`).
    pub last: Option<(Vec<f32>, Vec<f32>, Vec<u8>)>,
}

impl VecEnv {
    /// What [`Replayer::replay`] plays this vector environment's episodes again from.
    pub fn replayer(&self) -> Replayer {
        Replayer {
            scenario: Arc::clone(&self.scenario),
            cfg: self.cfg.clone(),
            seeds: self.seeds.clone(),
            opponent: self.opponent_make.clone(),
            n_agents: self.n_agents,
            obs_size: self.obs_size,
            state_size: self.state_size,
            n_actions: self.n_actions,
        }
    }
}

impl Replayer {
    /// Environment `i`'s episode number `episode` (as [`VecEnv::episode_numbers`] counts
    /// them) played again with team 1's `actions` (SMAC indices, `A` a step). Actions the
    /// masks refuse, or that go on after the episode ended, are not that episode's: an error.
    /// The episode may still be under way after the last step (an episode a run was in the
    /// middle of).
    pub fn replay(&self, i: usize, episode: u64, actions: &[i64]) -> Result<Replayed, VecEnvError> {
        let (episode, seed) = episode_seed(&self.seeds, i, episode, (actions.len(), self.n_agents))?;
        let a = self.n_agents.max(1);
        // Made as the vector environment made its own, then reset to the episode's seed as
        // its lanes are.
        let mut env = Env::new(Arc::clone(&self.scenario), self.cfg.clone(), self.seeds[i]);
        env.reset(seed);
        let mut opponent = self.opponent.as_ref().map(|make| {
            let make = Arc::clone(make);
            let mut t = AgentTeam::new(Team::Two, Grouping::Team, move || make());
            t.reset(&env);
            t
        });
        let (oa, sa, aa) = (self.n_agents * self.obs_size, self.state_size, self.n_agents * self.n_actions);
        let steps = actions.len() / a;
        let mut r = Replayed {
            steps,
            obs: vec![0.0; steps * oa],
            state: vec![0.0; steps * sa],
            avail: vec![0; steps * aa],
            reward: Vec::with_capacity(steps),
            terminated: Vec::with_capacity(steps),
            truncated: Vec::with_capacity(steps),
            last: None,
        };
        for (t, acts) in actions.chunks(a).enumerate() {
            if r.last.is_some() {
                return Err(VecEnvError::Replay { env: i, episode, steps: t, given: steps });
            }
            let (obs, state, avail) =
                (&mut r.obs[t * oa..(t + 1) * oa], &mut r.state[t * sa..(t + 1) * sa], &mut r.avail[t * aa..(t + 1) * aa]);
            fill(&env, obs, state, avail);
            check_against_masks(acts, avail, self.n_agents, self.n_actions).map_err(|source| VecEnvError::Action { env: i, source })?;
            let out = step_lane(&mut env, opponent.as_mut(), episode, acts);
            r.reward.push(out.reward[0]);
            r.terminated.push(out.terminated);
            r.truncated.push(out.truncated);
            if out.done {
                let mut last = (vec![0.0; oa], vec![0.0; sa], vec![0; aa]);
                fill(&env, &mut last.0, &mut last.1, &mut last.2);
                r.last = Some(last);
            }
        }
        Ok(r)
    }

    /// Environments the vector environment steps.
    pub fn len(&self) -> usize {
        self.seeds.len()
    }
    pub fn is_empty(&self) -> bool {
        self.seeds.is_empty()
    }
    /// (agents, obs_shape, state_shape, n_actions) of team 1.
    pub fn shape(&self) -> (usize, usize, usize, usize) {
        (self.n_agents, self.obs_size, self.state_size, self.n_actions)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario;

    /// Plays `steps` vector steps with actions drawn from the masks, recording every lane's
    /// rows, outcomes and finished episodes' actions, and checks each finished episode's
    /// replay against what the lane went through.
    fn check(name: &str, steps: usize) {
        let s = Arc::new(scenario::builtin(name).expect("built in"));
        let mut v = VecEnv::new(s, EnvConfig::smac(), &[7, 11, 13], 1).expect("env");
        let (a, o, st, na) = v.shape();
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut draw = |n: usize| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % n as u64) as usize
        };
        let mut running: Vec<Replayed> = vec![Replayed::default(); v.len()];
        let mut acted: Vec<Vec<i64>> = vec![Vec::new(); v.len()];
        let mut finished = 0;
        for _ in 0..steps {
            let mut acts = Vec::new();
            for i in 0..v.len() {
                let b = &v.buffers;
                let r = &mut running[i];
                r.obs.extend_from_slice(&b.obs[i * a * o..(i + 1) * a * o]);
                r.state.extend_from_slice(&b.state[i * st..(i + 1) * st]);
                r.avail.extend_from_slice(&b.avail[i * a * na..(i + 1) * a * na]);
                r.steps += 1;
                for k in 0..a {
                    let m = &b.avail[(i * a + k) * na..(i * a + k + 1) * na];
                    let ok: Vec<usize> = (0..na).filter(|&x| m[x] == 1).collect();
                    acts.push(ok[draw(ok.len())] as i64);
                }
                acted[i].extend_from_slice(&acts[i * a..(i + 1) * a]);
            }
            let before = v.episode_numbers().to_vec();
            v.step(&acts).expect("step");
            let b = &v.buffers;
            for i in 0..v.len() {
                let r = &mut running[i];
                r.reward.push(b.reward[i]);
                r.terminated.push(b.terminated[i]);
                r.truncated.push(b.truncated[i]);
                if b.terminated[i] || b.truncated[i] {
                    r.last = Some((
                        b.final_obs[i * a * o..(i + 1) * a * o].to_vec(),
                        b.final_state[i * st..(i + 1) * st].to_vec(),
                        b.final_avail[i * a * na..(i + 1) * a * na].to_vec(),
                    ));
                    let played = std::mem::take(r);
                    let again = v.replayer().replay(i, before[i], &std::mem::take(&mut acted[i])).expect("replays");
                    assert_eq!(again, played, "{name}: environment {i}, episode {}", before[i]);
                    finished += 1;
                }
            }
        }
        assert!(finished >= 3, "{name}: only {finished} episodes ended");
        // An episode under way replays to where it is, without an end.
        for i in 0..v.len() {
            let again = v.replayer().replay(i, v.episode_numbers()[i], &acted[i]).expect("replays");
            assert_eq!(again, running[i], "{name}: environment {i} under way");
        }
    }

    #[test]
    fn a_replayed_episode_is_the_episode_its_lane_played() {
        check("3m", 200);
        check("2s_vs_1sc", 400);
        // Drawn per episode from its seed: a replay from the wrong seed would differ.
        check("protoss_5_vs_5", 300);
    }

    #[test]
    fn actions_past_the_end_or_off_the_masks_are_refused() {
        let s = Arc::new(scenario::builtin("3m").expect("built in"));
        let v = VecEnv::new(s, EnvConfig::smac(), &[1], 1).expect("env");
        let r = v.replayer();
        let (a, _, _, _) = r.shape();
        // No-op is refused to living units (SMAC's mask), so 0 everywhere is off the masks.
        assert!(matches!(r.replay(0, 1, &vec![0; a]), Err(VecEnvError::Action { env: 0, .. })));
        assert!(matches!(r.replay(3, 1, &[]), Err(VecEnvError::NoEnv { env: 3, envs: 1 })));
        assert!(matches!(r.replay(0, 1, &[1]), Err(VecEnvError::Count { .. })));
        // A whole episode (each agent's first allowed action), then one step more.
        let mut v = VecEnv::new(Arc::new(scenario::builtin("3m").expect("built in")), EnvConfig::smac(), &[1], 1).expect("env");
        let na = r.shape().3;
        let mut acted = Vec::new();
        loop {
            let acts: Vec<i64> = v.buffers.avail.chunks(na).map(|m| m.iter().position(|&x| x == 1).unwrap_or(0) as i64).collect();
            acted.extend_from_slice(&acts);
            v.step(&acts).expect("step");
            if v.buffers.terminated[0] || v.buffers.truncated[0] {
                break;
            }
        }
        assert!(r.replay(0, 1, &acted).expect("the episode").last.is_some());
        acted.extend(std::iter::repeat_n(0, a));
        assert!(matches!(r.replay(0, 1, &acted), Err(VecEnvError::Replay { env: 0, .. })));
    }
}
