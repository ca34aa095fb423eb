//! Launch files (YAML): which scenario, clock, seeds and episodes, which agent nodes own
//! which units with which policy, the recorder, and the Zenoh router. Parsed with unknown
//! fields refused, then validated into a [`Plan`]; every error names the file, the field
//! and the value.
#![forbid(unsafe_code)]

mod command;
#[cfg(test)]
mod command_tests;
mod deploy;
mod error;
mod plan;
#[cfg(test)]
mod policy_tests;
mod validate;

#[cfg(test)]
/// The error and its sources, as the program prints them (`anyhow`'s `{:#}`).
pub(crate) fn chain(e: &LaunchError) -> String {
    format!("{:#}", anyhow::Error::new(e.clone()))
}

pub use deploy::{CertError, access_control, write_certs};
pub(crate) use error::Cx;
pub use error::LaunchError;
pub use plan::{
    AgentPlan, BridgePlan, BridgeTopic, ClockMode, CommanderPlan, EncoderPlan, FramePlan, NodeRuns, Plan, RawAgent, RawBridge, RawFrames,
    RawLaunch, RawSecurity, RecordBy, Security,
};

use avacraft_policy::{Resolve, Weights};
use std::path::Path;
use std::sync::Arc;

/// Reads and validates a launch file, reading every checkpoint it names.
pub fn load(path: &Path) -> Result<Plan, LaunchError> {
    load_with(path, Weights::Load)
}

/// [`load`], reading checkpoints now or only when a process makes their agents: the
/// simulator node and the bridge never act, and an agent node reads only its own.
pub fn load_with(path: &Path, weights: Weights) -> Result<Plan, LaunchError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| LaunchError::Io { file: file.clone(), source: Arc::new(e) })?;
    parse_with(&file, &text, path.parent(), weights)
}

/// Parses launch text; `base` resolves relative scenario paths.
pub fn parse(file: &str, text: &str, base: Option<&Path>) -> Result<Plan, LaunchError> {
    parse_with(file, text, base, Weights::Load)
}

/// [`parse`], with checkpoints read now or on first use (see [`load_with`]).
pub fn parse_with(file: &str, text: &str, base: Option<&Path>, weights: Weights) -> Result<Plan, LaunchError> {
    let raw: RawLaunch = serde_norway::from_str(text).map_err(|e| LaunchError::Syntax { file: file.to_owned(), source: Arc::new(e) })?;
    validate::validate(file, raw, Resolve { base, weights })
}

#[cfg(test)]
mod tests {
    use super::*;
    use avacraft_policy::PolicySpec;
    use std::path::PathBuf;

    #[test]
    fn a_good_file_becomes_a_plan() {
        let p = parse("t.yaml", "scenario: 3m_vlm\nepisodes: 2\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n", None)
            .expect("plan");
        assert_eq!(p.agents.len(), 3);
        assert_eq!(p.seeds, vec![1, 2]);
        assert_eq!(p.owners().len(), 3);
        assert_eq!(p.agents[0].id.as_str(), "unit_3".replace('3', &p.agents[0].units[0].get().to_string()));
    }

    #[test]
    fn errors_name_file_field_and_value() {
        let cases = [
            ("scenario: nope\nagents: []\n", "scenario"),
            ("scenario: 3m_vlm\nclock: fast\nagents:\n  - {per_unit: true, team: 1, policy: noop}\n", "clock"),
            ("scenario: 3m_vlm\nagents:\n  - {id: a, units: [9], policy: noop}\n", "agents[0].units"),
            ("scenario: 3m_vlm\nagents:\n  - {id: a, units: [1], policy: dance}\n", "agents[0].policy"),
            (
                "scenario: 3m_vlm\nagents:\n  - {id: a, units: [1], policy: noop}\n  - {id: b, units: [1], policy: noop}\n",
                "agents[1].units",
            ),
            ("scenario: 3m_vlm\nagents:\n  - {id: A, units: [1], policy: noop}\n", "agents[0].id"),
            ("scenario: 3m_vlm\ncolour: red\nagents: []\n", "colour"),
            ("scenario: 3m_vlm\nagents:\n  - {per_unit: true, team: 2, policy: noop}\n", "agents[0].units"),
            ("scenario: 3m_vlm\nagents:\n  - {id: a, team: 1, units: [1], policy: noop}\n", "agents[0].team"),
            ("scenario: 3m_vlm\nagents:\n  - {id: a, units: [1], policy: ava}\n", "agents[0].policy"),
            ("scenario: 3m_vlm\nagents:\n  - {id: a, units: [1], policy: noop, ava: {model: {kind: synthetic}}}\n", "agents[0].ava"),
            (
                "scenario: 3m_vlm\nava: {model: {kind: openai, url: ftp://x, model: m}}\nagents:\n  - {id: a, units: [1], policy: ava}\n",
                "ava",
            ),
            (
                "scenario: 3m_vlm\nava: {model: {kind: synthetic}, config: {decide_every: 0}}\nagents:\n  - {id: a, units: [1], policy: ava}\n",
                "ava",
            ),
            (
                "scenario: 3m_vlm\nava: {model: {kind: synthetic}, config: {planer: false}}\nagents:\n  - {id: a, units: [1], policy: ava}\n",
                "planer",
            ),
            ("scenario: 3m_vlm\nava: {model: {kind: gpt}}\nagents:\n  - {id: a, units: [1], policy: ava}\n", "gpt"),
            ("scenario: 3m_vlm\nenv: {step_mull: 4}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "step_mull"),
            ("scenario: 3m_vlm\nenv: {opponent: kite}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env"),
            ("scenario: 3m_vlm\nenv: {step_mul: 0}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env.step_mul"),
            ("scenario: 3m_vlm\nenv: [1]\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env"),
            // Not carried by SessionInfo: a recording could not replay it.
            ("scenario: 3m_vlm\nenv: {weapon_period: shot}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env.weapon_period"),
            ("scenario: 3m_vlm\nenv: {weapon_period: later}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "later"),
            ("scenario: 3m_vlm\nenv: {melee_surround: true}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env.melee_surround"),
            ("scenario: 3m_vlm\nenv: {state_agent: true}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env.state_agent"),
            (
                "scenario: 3m_vlm\nenv: {reward: dense, reward_only_positive: false}\nagents:\n  - {id: a, units: [1], policy: noop}\n",
                "env.reward_only_positive",
            ),
            // Under the deployment's sparse reward the settings are refused by name.
            ("scenario: 3m_vlm\nenv: {reward_win: 100}\nagents:\n  - {id: a, units: [1], policy: noop}\n", "env.reward_win"),
            (
                "scenario: 3m_vlm\nenv: {reward: dense, reward_scale_rate: -1}\nagents:\n  - {id: a, units: [1], policy: noop}\n",
                "env.reward_scale_rate",
            ),
        ];
        for (text, field) in cases {
            let e = chain(&parse("bad.yaml", text, None).expect_err(text));
            assert!(e.starts_with("bad.yaml") && e.contains(field), "{text}: {e}");
        }
    }

    #[test]
    fn the_env_section_sets_the_other_environment_options() {
        let text = "scenario: 3m_vlm\nopponent: focus\nenv: {step_mul: 4, full_vision: true, time_limit_loops: 500}\nagents:\n  - {id: a, units: [1], policy: noop}\n";
        let p = parse("env.yaml", text, None).expect("plan");
        let env = p.env_config();
        assert_eq!(env.step_mul.get(), 4);
        assert!(env.rules.full_vision);
        assert_eq!(env.time_limit_loops.map(|t| t.get()), Some(500));
        assert_eq!(env.reward, avacraft_engine::RewardMode::Sparse, "the deployment's defaults stay under the section");
        assert_eq!(env.opponent.map(|o| o.to_string()), Some("focus".into()));
        let plain = parse("env.yaml", "scenario: 3m_vlm\nagents:\n  - {id: a, units: [1], policy: noop}\n", None).expect("plan");
        assert_eq!(plain.env_config().step_mul.get(), 8);
    }

    /// Per-unit nodes of one image network on a team share an encoder node, unless the file
    /// says `share_encoder: false`; a network that reads no frames gets none.
    #[test]
    fn per_unit_image_networks_share_their_teams_encoder_node() {
        let body = "scenario: 3m_vlm\nagents:\n  - {per_unit: true, team: 1, policy: baseline:mappo-rgb}\n";
        let p = parse_with("rgb.yaml", body, None, Weights::Later).expect("plan");
        assert_eq!(p.encoders.len(), 1);
        assert_eq!((p.encoders[0].id.as_str(), p.encoders[0].team.get()), ("encoder_1", 1));
        assert!(p.agents.iter().all(|a| a.encoded), "every Marine's node is served");
        let own = parse_with("rgb.yaml", &format!("share_encoder: false\n{body}"), None, Weights::Later).expect("plan");
        assert!(own.encoders.is_empty() && own.agents.iter().all(|a| !a.encoded));
        let features = parse_with(
            "f.yaml",
            "scenario: 3m_vlm\nagents:\n  - {per_unit: true, team: 1, policy: baseline:mappo}\n",
            None,
            Weights::Later,
        )
        .expect("plan");
        assert!(features.encoders.is_empty(), "a features network reads no frames");
        let taken = "scenario: 3m_vlm\nagents:\n  - {id: encoder_1, units: [1], policy: baseline:mappo-rgb}\n  - {id: b, units: [2, 3], policy: baseline:mappo-rgb}\n";
        let p = parse_with("rgb.yaml", taken, None, Weights::Later).expect("plan");
        assert_eq!(p.encoders.iter().map(|e| e.id.as_str()).collect::<Vec<_>>(), ["encoder_1_1"], "an id the file uses is not taken");
    }

    #[test]
    fn ava_settings_come_from_the_file_or_the_entry() {
        let text = "scenario: 8m3mr1mv1st_mirror_pvp\nava: {model: {kind: synthetic}, record: calls}\nagents:\n  - {id: blue, units: [1, 2], policy: ava}\n  - {id: red, units: [14], policy: ava, ava: {model: {kind: replay, dir: old}, config: {roles: false}}}\n";
        let p = parse("pvp.yaml", text, Some(Path::new("/base"))).expect("plan");
        let spec = |i: usize| match &p.agents[i].policy {
            PolicySpec::Ava(s) => s.clone(),
            other => panic!("{other:?}"),
        };
        assert_eq!(spec(0).model, avacraft_ava::ModelSpec::Synthetic);
        assert_eq!(spec(0).record.as_deref(), Some(Path::new("/base/calls")), "paths are resolved against the launch file");
        assert_eq!(spec(1).model, avacraft_ava::ModelSpec::Replay { dir: PathBuf::from("/base/old") });
        assert!(!spec(1).config.roles && spec(0).config.roles);
        assert_eq!(p.agents[1].policy.to_string(), "ava");
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in "\\PC{0,200}") {
            let _ = parse("fuzz.yaml", &s, None);
        }
    }
}

#[cfg(test)]
mod deploy_tests {
    use super::*;
    use avacraft_nodes::TeamNo;

    fn pvp(extra: &str) -> String {
        format!(
            "scenario: MMM_vs_MMM\nrouter: tls/10.0.0.1:7447\nsecurity: {{certs: certs}}\nhosts: [server, blue, red]\nagents:\n  - {{id: blue_a, units: [1, 2], policy: hold, host: blue}}\n  - {{id: red_a, units: [13], policy: hold, host: red}}\n{extra}"
        )
    }

    #[test]
    fn the_shipped_launch_files_validate() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut n = 0;
        for entry in std::fs::read_dir(dir).expect("launch dir") {
            let p = entry.expect("entry").path();
            if p.extension().is_some_and(|e| e == "yaml") {
                load(&p).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 5, "{n} launch files");
    }

    #[test]
    fn hosts_security_and_bridge_are_validated_with_file_field_and_value() {
        let ok = parse("p.yaml", &pvp(""), None).expect("plan");
        assert_eq!((ok.server(), ok.agents[0].host.as_str(), ok.agents[1].team.get()), ("server", "blue", 2));
        let cases = [
            (pvp("").replace("tls/", "tcp/"), "router"),
            (pvp("").replace("security: {certs: certs}\n", ""), "hosts"),
            (pvp("").replace("hosts: [server, blue, red]", "hosts: [server, Blue]"), "hosts[1]"),
            (pvp("").replace("hosts: [server, blue, red]", "hosts: [server, blue, blue]"), "hosts[2]"),
            (pvp("").replace("host: red", "host: green"), "agents[1].host"),
            (pvp("").replace("units: [1, 2]", "units: [1, 13]"), "agents[0].units"),
            (pvp("bridge: {topics: [everything]}\n"), "bridge.topics[0]"),
            (pvp("bridge: {host: nowhere}\n"), "bridge.host"),
            (pvp("bridge: {frame_size: [0, 10]}\n"), "bridge.frame_size"),
            (pvp("bridge: {dds_networks: [localhost]}\n"), "bridge.dds_networks[0]"),
            (pvp("bridge: {dds_domain: 300}\n"), "bridge.dds_domain"),
            (pvp("").replace("policy: hold, host: blue", "policy: dds, host: blue"), "agents[0].policy"),
            (pvp("bridge: {host: server, teams: [1]}\n").replace("policy: hold, host: blue", "policy: dds, host: blue"), "bridge.host"),
            ("scenario: 3m_vlm\nhosts: [a, b]\nagents:\n  - {id: x, units: [1], policy: hold}\n".to_owned(), "hosts"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/127.0.0.1:7447"), "router"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/0.0.0.0:7447"), "router"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/10.0.0.1"), "router"),
            // A bridge on blue may carry only blue's team, once, and not both teams' roles.
            (pvp("bridge: {host: blue, teams: [2]}\n"), "bridge.teams[0]"),
            (pvp("bridge: {teams: [1, 1]}\n"), "bridge.teams[1]"),
            (pvp("bridge: {host: red, topics: [roles]}\n"), "bridge.topics"),
            // DDS agents: one team per bridge, bridged, with observations.
            (pvp("bridge: {}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.teams"),
            (pvp("bridge: {teams: [2]}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.teams"),
            (pvp("bridge: {teams: [1], topics: [status]}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.topics"),
        ];
        for (text, field) in cases {
            let e = parse("bad.yaml", &text, None).expect_err(&text).to_string();
            assert!(e.starts_with("bad.yaml: field `") && e.contains(&format!("`{field}`")), "{field}: {e}");
        }
    }

    fn rule<'a>(acl: &'a serde_json::Value, id: &str) -> &'a serde_json::Value {
        acl["rules"].as_array().and_then(|r| r.iter().find(|r| r["id"] == id)).unwrap_or_else(|| panic!("no rule {id}: {acl}"))
    }

    #[test]
    fn access_control_gives_each_host_its_own_actions_and_its_teams_topics() {
        let plan = parse("p.yaml", &pvp("bridge: {host: red, topics: [status, team_obs]}\n"), None).expect("plan");
        assert_eq!(
            plan.bridge.as_ref().map(|b| b.teams.clone()),
            Some(vec![TeamNo::new(2).expect("team")]),
            "a team host's bridge defaults to its team"
        );
        assert_eq!(
            plan.bridge.as_ref().map(|b| b.dds_networks.clone()),
            Some(vec!["127.0.0.1".parse().expect("ip")]),
            "DDS stays on the machine by default"
        );
        let acl = access_control(&plan, &avacraft_nodes::Topics::default(), 0);
        assert_eq!(acl["default_permission"], "deny");
        assert_eq!(rule(&acl, "server_all")["key_exprs"], serde_json::json!(["**", "@ros2_lv/0/**"]));
        assert_eq!(rule(&acl, "blue_send")["key_exprs"], serde_json::json!(["0/avacraft/agents/blue_a/actions/**"]));
        assert_eq!(rule(&acl, "blue_receive")["key_exprs"], serde_json::json!(["0/avacraft/team_1/**", "0/avacraft/status/**"]));
        assert_eq!(rule(&acl, "blue_receive")["flows"], serde_json::json!(["egress"]));
        // The bridge on red carries only team 2.
        assert_eq!(rule(&acl, "red_receive")["key_exprs"], serde_json::json!(["0/avacraft/team_2/**", "0/avacraft/status/**"]));
        // The graph: blue announces only its own nodes and learns only of the simulator.
        assert_eq!(
            rule(&acl, "blue_announce")["key_exprs"],
            serde_json::json!([
                "@ros2_lv/0/*/*/*/*/*/%avacraft/agent_blue_a",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/agent_blue_a/**",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/launch_blue",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/launch_blue/**"
            ])
        );
        assert_eq!(rule(&acl, "blue_sim_up")["key_exprs"], serde_json::json!(["@ros2_lv/0/*/*/*/*/*/%avacraft/sim"]));
        assert!(rule(&acl, "red_announce").to_string().contains("%avacraft/bridge"));
        let subjects = acl["subjects"].as_array().expect("subjects");
        assert_eq!(
            subjects.iter().map(|s| s["cert_common_names"][0].as_str().unwrap_or("")).collect::<Vec<_>>(),
            ["server", "blue", "red"]
        );
        // No rule of a team host names another team's prefix.
        let blue_rules: Vec<_> =
            acl["rules"].as_array().expect("rules").iter().filter(|r| r["id"].as_str().is_some_and(|i| i.starts_with("blue"))).collect();
        assert!(blue_rules.iter().all(|r| !r.to_string().contains("team_2")), "{blue_rules:?}");
        // And it is a configuration Zenoh accepts.
        let mut c = zenoh::Config::default();
        c.insert_json5("access_control", &acl.to_string()).expect("zenoh accepts the access control");
    }

    #[test]
    fn certificates_name_each_host_and_the_router_address() {
        let dir = std::env::temp_dir().join(format!("avacraft-certs-{}", std::process::id()));
        let plan = parse("p.yaml", &pvp("").replace("certs: certs", &format!("certs: {}", dir.display())), None).expect("plan");
        let files = write_certs(&plan).expect("certs");
        assert_eq!(files.len(), 1 + 2 * 3);
        let sec = plan.security.as_ref().expect("security");
        for h in ["server", "blue", "red"] {
            let pem = std::fs::read_to_string(sec.cert(h)).expect("cert");
            assert!(pem.starts_with("-----BEGIN CERTIFICATE-----"));
            assert!(std::fs::read_to_string(sec.key(h)).expect("key").contains("PRIVATE KEY"));
        }
        let without = parse("p.yaml", "scenario: 3m_vlm\nagents:\n  - {id: x, units: [1], policy: hold}\n", None).expect("plan");
        assert!(matches!(write_certs(&without), Err(CertError::NoSecurity)));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
