//! The agent contract: a team's observation built directly equals the fold of its units'
//! observations, scripted agents act only for the units they control, and how a team is
//! split among agents does not change what scripted focus fire does.

use crate::helpers::{arena_units, load};
use avacraft_engine::agent::{AGENTS, AgentCtx, AgentTeam, GroupObs, Grouping, agent_seed, by_name, factory};
use avacraft_engine::{Buffs, Controllers, Env, EnvConfig, Scenario, Team, UnitId, builtin};
use std::sync::Arc;

/// The position of each tag in its team's agent order.
fn index_of(env: &Env, team: Team) -> impl Fn(UnitId) -> usize {
    let order: Vec<UnitId> = env.agents(team).to_vec();
    move |id| order.iter().position(|&t| t == id).unwrap_or(usize::MAX)
}

#[test]
fn team_observation_is_the_fold_of_its_units_observations() {
    let (mut abilities, mut buffs, mut effects, mut checked) = (false, false, false, 0);
    // Storms and a Guardian Shield on the ground: a High Templar and a Sentry with energy
    // against a clump of ranged units.
    let fx = arena_units(
        "pvp",
        &[
            ("HighTemplar", 1, 10.0, 16.0, "energy = 200"),
            ("Sentry", 1, 9.0, 15.0, "energy = 200"),
            ("Zealot", 1, 9.0, 17.0, ""),
            ("Stalker", 1, 9.0, 14.0, ""),
            ("Marine", 2, 17.0, 16.0, ""),
            ("Marine", 2, 17.5, 16.5, ""),
            ("Marine", 2, 17.5, 15.5, ""),
            ("Marine", 2, 18.0, 16.0, ""),
        ],
        "upgrades = [{ team = 1, name = \"PsiStormTech\" }]",
    );
    let mut cases: Vec<(Arc<Scenario>, u64)> = vec![(load(&fx), 1)];
    for (name, seed) in [("pvz_ht", 2), ("8m3mr1mv1st_mirror_pvp", 3), ("MMM_vs_MMM", 1), ("mixed_units_pvp", 5)] {
        cases.push((Arc::new(builtin(name).expect("scenario")), seed));
    }
    for (s, seed) in cases {
        let name = s.name.clone();
        let mut env = Env::new(Arc::clone(&s), EnvConfig::default(), seed);
        let mut c = Controllers::named(&s, "kite", Some("focus")).expect("policy");
        c.reset(&env);
        while !env.done() {
            if env.steps().is_multiple_of(2) {
                for team in Team::BOTH {
                    let direct = GroupObs::team(&env, team, 7, avacraft_engine::Reads::ALL);
                    let folded = GroupObs::fold(&env.agent_observations(team, 7), index_of(&env, team)).expect("a team has agents");
                    assert_eq!(direct, folded, "{name} step {} {team:?}", env.steps());
                    abilities |= direct.units.iter().any(|u| u.abilities.iter().any(|a| a.available));
                    buffs |= direct.units.iter().any(|u| !u.buffs.is_empty() && !u.buffs.contains(Buffs::DETECTED));
                    effects |= !direct.effects.is_empty();
                    checked += 1;
                }
            }
            c.act(&mut env);
            env.step();
        }
    }
    assert!(abilities && buffs && effects && checked > 100, "abilities {abilities}, buffs {buffs}, effects {effects}, {checked} checks");
}

#[test]
fn every_policy_acts_only_for_the_units_it_controls() {
    for (name, seed) in [("MMM_vs_MMM", 4), ("pvz_ht", 1), ("8m3mr1mv1st_mirror_pvp", 2), ("2c_vs_64zg_vlm", 3)] {
        let s: Arc<Scenario> = Arc::new(builtin(name).expect("scenario"));
        for &(policy, _) in &AGENTS {
            let mut env = Env::new(Arc::clone(&s), EnvConfig::default(), seed);
            // The game is played by focus fire; the policy under test sees every second unit's
            // observations and controls those units only.
            let mut c = Controllers::named(&s, "focus-fire", Some("focus-fire")).expect("policy");
            c.reset(&env);
            let team = Team::One;
            let mine: Vec<u32> = env.agents(team).iter().step_by(2).map(|id| id.tag()).collect();
            let mut agent = by_name(policy).expect("policy");
            let ids: Vec<UnitId> = env.agents(team).iter().step_by(2).copied().collect();
            let ctx = AgentCtx { scenario: Arc::clone(&s), team, units: ids, seed: agent_seed(seed, team, mine[0]) };
            agent.reset(&ctx);
            let mut given = 0;
            while !env.done() && env.steps() < 120 {
                let obs: Vec<_> = env.agent_observations(team, 0).into_iter().filter(|o| mine.contains(&o.unit.tag())).collect();
                let g = GroupObs::fold(&obs, index_of(&env, team)).expect("observations");
                for a in agent.act(&g) {
                    assert!(mine.contains(&a.unit.tag()), "{name}: {policy} gave {a:?} for a unit it does not control");
                    given += 1;
                }
                c.act(&mut env);
                env.step();
            }
            assert!(given > 0 || policy == "noop", "{name}: {policy} never acted");
        }
    }
}

fn focus_fire_hash(s: &Arc<Scenario>, seed: u64, grouping: Grouping) -> (u64, u32) {
    let mut env = Env::new(Arc::clone(s), EnvConfig::default(), seed);
    let mut t = AgentTeam::new(Team::One, grouping, factory("focus-fire").expect("policy"));
    t.reset(&env);
    while !env.done() {
        t.step(&mut env, 0);
        env.step();
    }
    (env.trajectory_hash(), env.steps())
}

#[test]
fn focus_fire_plays_the_same_game_per_unit_and_per_team() {
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    for seed in [1, 2, 3] {
        let team = focus_fire_hash(&s, seed, Grouping::Team);
        assert_eq!(focus_fire_hash(&s, seed, Grouping::PerUnit), team, "seed {seed}");
        let groups = Grouping::Groups(vec![vec![UnitId::new(0)], vec![UnitId::new(1), UnitId::new(2)]]);
        assert_eq!(focus_fire_hash(&s, seed, groups), team, "seed {seed}");
    }
}

#[test]
fn scripted_sides_never_have_an_action_refused() {
    // The scripted agents check casts from observations alone; the engine must agree.
    for name in ["8m3mr1mv1st_mirror_pvp", "8s_vs_8m3mr1mv1st_pvp", "MMM_vs_MMM", "terran_mirror", "mixed_units_pvp", "7s_vs_11m1mv1st"] {
        let s = Arc::new(builtin(name).expect("scenario"));
        for (p1, p2) in [("focus-fire", "kite"), ("defensive", "focus"), ("aggressive", "attack-move")] {
            for seed in [1, 2] {
                let mut env = Env::new(Arc::clone(&s), EnvConfig::default(), seed);
                let mut c = Controllers::named(&s, p1, Some(p2)).expect("policy");
                c.reset(&env);
                while !env.done() {
                    c.act(&mut env);
                    env.step();
                }
                assert_eq!(env.refused(), [0, 0], "{name} seed {seed}: {p1} vs {p2}");
            }
        }
    }
}
