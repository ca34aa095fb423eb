//! The multi-host part of a launch file: which host runs what, the deployment's TLS
//! identities, the Zenoh access control that follows from who owns which units, and the
//! DDS bridge.
//!
//! One file describes the whole deployment and every host runs `avacraft launch <file>
//! --host <name>`. The first host runs the router, the simulator and the recorder. The
//! router admits only hosts holding a certificate of the deployment's authority (mutual
//! TLS), and its access control knows each host by its certificate's common name: a host
//! may publish only on the action topics of the agent nodes it runs and receive only the
//! topics of the teams those nodes play for. A host named nowhere has no rule, and the
//! default is deny.

use crate::error::LaunchError;
use crate::plan::{BridgePlan, BridgeTopic, Plan, RawBridge, RawSecurity, Security};
use avacraft_nodes::{NodeName, TeamNo, Topics};
use serde_json::json;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// A host or bridge name: lowercase letters, digits and '_' (it is a certificate's common
/// name and a file name).
pub(crate) fn valid_host(name: &str) -> bool {
    (1..=32).contains(&name.len())
        && name.starts_with(|c: char| c.is_ascii_lowercase())
        && name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

pub(crate) fn bridge_plan(
    cx: &crate::Cx<'_>,
    raw: &RawBridge,
    hosts: &[String],
    agents: &[crate::AgentPlan],
) -> Result<BridgePlan, LaunchError> {
    let host = raw.host.clone().unwrap_or_else(|| hosts[0].clone());
    if !hosts.contains(&host) {
        return Err(cx.err("bridge.host", format!("{host:?}"), format!("not one of the hosts {hosts:?}")));
    }
    let teams_of = |f: &dyn Fn(&crate::AgentPlan) -> bool| -> Vec<TeamNo> {
        let set: BTreeSet<TeamNo> = agents.iter().filter(|a| f(a)).map(|a| a.team).collect();
        set.into_iter().collect()
    };
    let agent_teams = teams_of(&|_| true);
    // On a team's host the bridge carries no more than that host may read.
    let on_server = host == hosts[0];
    let allowed = if on_server { agent_teams.clone() } else { teams_of(&|a| a.host == host) };
    let mut topics = BTreeSet::new();
    for (i, t) in raw.topics.iter().enumerate() {
        topics.insert(match t.as_str() {
            "status" => BridgeTopic::Status,
            "team_obs" => BridgeTopic::TeamObs,
            "unit_obs" => BridgeTopic::UnitObs,
            "frames" => BridgeTopic::Frames,
            "roles" => BridgeTopic::Roles,
            other => {
                return Err(cx.err(
                    format!("bridge.topics[{i}]"),
                    format!("{other:?}"),
                    "must be status, team_obs, unit_obs, frames or roles",
                ));
            }
        });
    }
    let mut teams = Vec::new();
    for (i, &t) in raw.teams.iter().enumerate() {
        let field = format!("bridge.teams[{i}]");
        let no = TeamNo::new(t).map_err(|e| cx.err(field.clone(), t, e.to_string()))?;
        if !agent_teams.contains(&no) {
            return Err(cx.err(field, t, "no agent node plays for this team"));
        }
        if !allowed.contains(&no) {
            return Err(cx.err(field, t, format!("the bridge runs on `{host}`, which runs no agent node of this team")));
        }
        if teams.contains(&no) {
            return Err(cx.err(field, t, "named twice"));
        }
        teams.push(no);
    }
    if teams.is_empty() {
        teams = allowed.clone();
    }
    if teams.is_empty() {
        return Err(cx.err("bridge.host", format!("{host:?}"), "runs no agent node, so there is no team the bridge may carry"));
    }
    if !on_server && agent_teams.len() > 1 && topics.contains(&BridgeTopic::Roles) {
        return Err(cx.err("bridge.topics", "roles", format!("the roles name both teams' agents; `{host}` may see only its own team")));
    }
    // DDS has no access control here: a DDS agent sees everything the bridge carries.
    let dds_teams = teams_of(&|a| a.is_dds());
    if !dds_teams.is_empty() && teams.len() > 1 {
        return Err(cx.err(
            "bridge.teams",
            format!("{:?}", teams.iter().map(|t| t.get()).collect::<Vec<_>>()),
            "with agents on DDS, the bridge may carry one team only (DDS agents would read the other team's observations)",
        ));
    }
    for t in &dds_teams {
        if !teams.contains(t) {
            return Err(cx.err(
                "bridge.teams",
                format!("{:?}", teams.iter().map(|t| t.get()).collect::<Vec<_>>()),
                format!("team {} has agents on DDS but is not bridged", t.get()),
            ));
        }
    }
    if !dds_teams.is_empty() && !topics.contains(&BridgeTopic::TeamObs) && !topics.contains(&BridgeTopic::UnitObs) {
        return Err(cx.err("bridge.topics", format!("{:?}", raw.topics), "agents on DDS need team_obs or unit_obs"));
    }
    let [w, h] = raw.frame_size;
    if !(1..=4096).contains(&w) || !(1..=4096).contains(&h) {
        return Err(cx.err("bridge.frame_size", format!("[{w}, {h}]"), "width and height must be 1 to 4096"));
    }
    if raw.frame_every == 0 {
        return Err(cx.err("bridge.frame_every", 0, "must be at least 1"));
    }
    if raw.dds_domain > 232 {
        return Err(cx.err("bridge.dds_domain", raw.dds_domain, "DDS domain ids are 0 to 232"));
    }
    let mut dds_networks = Vec::new();
    let nets = raw.dds_networks.clone().unwrap_or_else(|| vec!["127.0.0.1".to_owned()]);
    for (i, n) in nets.iter().enumerate() {
        dds_networks
            .push(n.parse().map_err(|e| cx.err(format!("bridge.dds_networks[{i}]"), format!("{n:?}"), format!("not an IP address: {e}")))?);
    }
    Ok(BridgePlan { host, dds_domain: raw.dds_domain, topics, teams, frame_size: (w, h), frame_every: raw.frame_every, dds_networks })
}

/// Why certificates could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CertError {
    #[error("the launch file has no `security:` section, so there is nothing to make certificates for")]
    NoSecurity,
    #[error("making the certificate of `{host}`: {message}")]
    Make { host: String, message: String },
    #[error("writing {path}: {message}")]
    Write { path: String, message: String },
}

/// The host part of a `tls/<host>:<port>` endpoint.
fn endpoint_host(endpoint: &str) -> Option<&str> {
    let rest = endpoint.split_once('/')?.1;
    let (host, _port) = rest.rsplit_once(':')?;
    Some(host.trim_start_matches('[').trim_end_matches(']'))
}

/// Writes a fresh authority and one key pair per host into the plan's certificate
/// directory; returns the files written. The first host's certificate also names the
/// router's address, which connecting hosts check.
pub fn write_certs(plan: &Plan) -> Result<Vec<PathBuf>, CertError> {
    use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose, SanType};
    let Some(sec) = &plan.security else { return Err(CertError::NoSecurity) };
    fn make(host: &str) -> impl Fn(rcgen::Error) -> CertError + '_ {
        move |e| CertError::Make { host: host.to_owned(), message: e.to_string() }
    }
    let ca_key = KeyPair::generate().map_err(make("ca"))?;
    let mut ca = CertificateParams::new(Vec::<String>::new()).map_err(make("ca"))?;
    ca.distinguished_name.push(DnType::CommonName, format!("avacraft deployment authority ({})", plan.scenario.name));
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    let ca_cert = ca.self_signed(&ca_key).map_err(make("ca"))?;
    let issuer = Issuer::new(ca, ca_key);
    {
        use std::os::unix::fs::DirBuilderExt;
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(&sec.certs)
            .map_err(|e| CertError::Write { path: sec.certs.display().to_string(), message: e.to_string() })?;
    }
    let mut files = Vec::new();
    // Owner-only files: the directory holds private keys.
    let mut write = |path: PathBuf, text: String| -> Result<(), CertError> {
        use std::io::Write;
        use std::os::unix::fs::OpenOptionsExt;
        let err = |e: std::io::Error| CertError::Write { path: path.display().to_string(), message: e.to_string() };
        let mut f = std::fs::OpenOptions::new().write(true).create(true).truncate(true).mode(0o600).open(&path).map_err(err)?;
        f.write_all(text.as_bytes()).map_err(err)?;
        files.push(path);
        Ok(())
    };
    write(sec.ca(), ca_cert.pem())?;
    for (i, host) in plan.hosts.iter().enumerate() {
        let key = KeyPair::generate().map_err(make(host))?;
        let mut names = vec![host.clone()];
        if i == 0 {
            names.push("localhost".to_owned());
        }
        let mut p = CertificateParams::new(names).map_err(make(host))?;
        if i == 0 {
            p.subject_alt_names.push(SanType::IpAddress(std::net::Ipv4Addr::LOCALHOST.into()));
            if let Some(addr) = endpoint_host(&plan.router) {
                match addr.parse::<std::net::IpAddr>() {
                    Ok(ip) => p.subject_alt_names.push(SanType::IpAddress(ip)),
                    Err(_) => p.subject_alt_names.push(SanType::DnsName(addr.try_into().map_err(make(host))?)),
                }
            }
        }
        p.distinguished_name.push(DnType::CommonName, host.as_str());
        p.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth, ExtendedKeyUsagePurpose::ClientAuth];
        p.key_usages = vec![KeyUsagePurpose::DigitalSignature, KeyUsagePurpose::KeyEncipherment];
        let cert = p.signed_by(&key, &issuer).map_err(make(host))?;
        write(sec.cert(host), cert.pem())?;
        write(sec.key(host), key.serialize_pem())?;
    }
    Ok(files)
}

/// Every message kind a rule can name.
const ALL_MESSAGES: [&str; 9] = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "reply",
    "declare_queryable",
    "liveliness_token",
    "liveliness_query",
    "declare_liveliness_subscriber",
];

/// The router's `access_control` object (JSON, which JSON5 reads): the first host may do
/// anything; every other host may publish on its own agent nodes' action topics, subscribe
/// to its teams' topics and the episode status, and take part in the ROS graph (liveliness).
pub fn access_control(plan: &Plan, topics: &Topics, domain: u32) -> serde_json::Value {
    let key = |t: &avacraft_nodes::Topic| avacraft_nodes::ros::key_space(domain, t);
    let graph = avacraft_nodes::ros::liveliness_space(domain);
    let ns = topics.namespace();
    // `**` does not match chunks that start with '@' (the liveliness space): name it too.
    // Ids carry the host names (unique by validation), so no two can clash.
    let first = &plan.hosts[0];
    let mut rules = vec![json!({
        "id": format!("{first}_all"), "messages": ALL_MESSAGES, "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": ["**", graph],
    })];
    let mut subjects = vec![json!({ "id": format!("host_{first}"), "cert_common_names": [first] })];
    let mut policies = vec![json!({ "rules": [format!("{first}_all")], "subjects": [format!("host_{first}")] })];
    for host in plan.hosts.iter().skip(1) {
        let agents: Vec<_> = plan.agents.iter().filter(|a| &a.host == host).collect();
        let bridged = plan.bridge.as_ref().filter(|b| &b.host == host);
        let commanders: Vec<_> = plan.commanders.iter().filter(|c| &c.host == host).collect();
        let mut teams: BTreeSet<TeamNo> = agents.iter().map(|a| a.team).collect();
        teams.extend(bridged.iter().flat_map(|b| b.teams.iter().copied()));
        teams.extend(commanders.iter().map(|c| c.team));
        let mut sends: Vec<String> = agents.iter().map(|a| key(&topics.actions(&a.id))).collect();
        // AVA nodes publish their model calls for the recording.
        sends.extend(
            agents.iter().filter(|a| matches!(a.policy, avacraft_policy::PolicySpec::Ava(_))).map(|a| key(&topics.model_calls(&a.id))),
        );
        sends.extend(
            commanders
                .iter()
                .filter(|c| matches!(c.policy, avacraft_policy::CommanderPolicy::Ava(_)))
                .map(|c| key(&topics.model_calls(&c.id))),
        );
        // A commander sends its team's orders (the simulator checks them); an encoder node
        // its team's encodings.
        sends.extend(commanders.iter().map(|c| key(&topics.orders(c.team))));
        let encoders: Vec<_> = plan.encoders.iter().filter(|e| &e.host == host).collect();
        sends.extend(encoders.iter().map(|e| key(&topics.features(e.team))));
        let mut reads: Vec<String> = teams.iter().map(|t| key(&topics.team_prefix(*t))).collect();
        reads.push(key(&topics.status()));
        if bridged.is_some_and(|b| b.topics.contains(&BridgeTopic::Roles)) {
            reads.push(key(&topics.roles()));
        }
        let mut names = Vec::new();
        let mut rule = |id: String, messages: &[&str], flows: &[&str], keys: &[String]| {
            if !keys.is_empty() {
                rules.push(json!({ "id": id, "messages": messages, "flows": flows, "permission": "allow", "key_exprs": keys }));
                names.push(id);
            }
        };
        rule(format!("{host}_send"), &["put"], &["ingress"], &sends);
        // A publisher sends only where it knows of a subscriber: the host must learn of the
        // simulator's subscription to every agent's actions (its existence, nothing more).
        if !sends.is_empty() {
            let mut matching = vec![avacraft_nodes::ros::pattern_space(domain, &topics.any_actions())];
            matching.extend(commanders.iter().map(|c| key(&topics.orders(c.team))));
            matching.extend(encoders.iter().map(|e| key(&topics.features(e.team))));
            rule(format!("{host}_matching"), &["declare_subscriber"], &["egress"], &matching);
        }
        rule(format!("{host}_subscribe"), &["declare_subscriber"], &["ingress"], &reads);
        rule(format!("{host}_receive"), &["put"], &["egress"], &reads);
        // The ROS graph: a host announces only its own nodes (so it cannot forge another's
        // agent or the simulator), may ask, and learns only whether the simulator is up.
        let mut own: Vec<String> = Vec::new();
        let mut names_on_host: Vec<NodeName> = agents.iter().map(|a| NodeName::agent(&a.id)).collect();
        names_on_host.extend(commanders.iter().map(|c| NodeName::agent(&c.id)));
        names_on_host.extend(encoders.iter().map(|e| NodeName::agent(&e.id)));
        names_on_host.push(NodeName::launch_on(host));
        if bridged.is_some() {
            names_on_host.push(NodeName::bridge());
        }
        for n in &names_on_host {
            own.extend(avacraft_nodes::ros::node_token_space(domain, ns, n));
        }
        rule(format!("{host}_announce"), &["liveliness_token"], &["ingress"], &own);
        rule(format!("{host}_ask"), &["liveliness_query"], &["ingress"], std::slice::from_ref(&graph));
        let [sim, _] = avacraft_nodes::ros::node_token_space(domain, ns, &NodeName::sim());
        rule(format!("{host}_sim_up"), &["liveliness_token"], &["egress"], &[sim]);
        subjects.push(json!({ "id": format!("host_{host}"), "cert_common_names": [host] }));
        policies.push(json!({ "rules": names, "subjects": [format!("host_{host}")] }));
    }
    json!({ "enabled": true, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies })
}

/// The certificate directory, relative to the launch file.
pub(crate) fn security(raw: &RawSecurity, base: Option<&Path>) -> Security {
    let certs = match base {
        Some(b) if raw.certs.is_relative() => b.join(&raw.certs),
        _ => raw.certs.clone(),
    };
    Security { certs }
}
