//! rmw_zenoh's wire conventions (Jazzy, rmw_zenoh >= 0.2.4), so ROS 2 tools attached to the
//! same Zenoh router list, echo and record AVACraft's topics: data key expressions with the
//! type name and REP-2016 hash, liveliness tokens for nodes and endpoints, and the 33-byte
//! attachment every sample must carry (subscribers drop samples without it).

use crate::topics::{Topic, TopicPattern};

/// Reliability and depth of an endpoint, as rmw_zenoh encodes them in liveliness tokens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Qos {
    /// RELIABLE, KEEP_ALL, VOLATILE (congestion control BLOCK, as rmw_zenoh maps it):
    /// observations, actions, status: nothing may be dropped. `depth` only sizes queues.
    Reliable { depth: u32 },
    /// BEST_EFFORT, KEEP_LAST `depth`, VOLATILE: image frames (a late frame is worthless).
    BestEffort { depth: u32 },
}

impl Qos {
    /// `rel:dur:hist,depth:dl_s,dl_ns:ls_s,ls_ns:liv,lease_s,lease_ns`, each field empty when
    /// it is rmw_zenoh's default (RELIABLE, VOLATILE, KEEP_LAST, depth 42, infinite, AUTOMATIC).
    pub fn token_text(self) -> String {
        match self {
            Qos::Reliable { .. } => "::2,:,:,:,,".to_owned(),
            Qos::BestEffort { depth } => {
                let depth = if depth == 42 { String::new() } else { depth.to_string() };
                format!("2::,{depth}:,:,:,,")
            }
        }
    }
    /// The YAML that MCAP's ros2 profile stores per channel (`offered_qos_profiles`).
    pub fn mcap_yaml(self) -> String {
        let (rel, hist, depth) = match self {
            Qos::Reliable { depth } => (1, 2, depth),
            Qos::BestEffort { depth } => (2, 1, depth),
        };
        format!(
            "- history: {hist}\n  depth: {depth}\n  reliability: {rel}\n  durability: 2\n  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false\n"
        )
    }
}

/// Replaces every `/` with `%`; an empty name becomes `%` (rmw_zenoh's mangling).
pub fn mangle(name: &str) -> String {
    if name.is_empty() { "%".to_owned() } else { name.replace('/', "%") }
}

/// The data key of a topic: `<domain>/<topic>/<dds type>/<type hash>`.
pub fn data_key(domain: u32, topic: &Topic, dds_type: &str, type_hash: &str) -> String {
    format!("{domain}/{}/{dds_type}/{type_hash}", topic.as_str().trim_matches('/'))
}

/// Every key under a pattern of topics (any type), as [`key_space`] for one topic.
pub fn pattern_space(domain: u32, topics: &TopicPattern) -> String {
    format!("{domain}/{}/**", topics.as_str().trim_matches('/'))
}

/// [`data_key`] for a pattern of topics (`*` segments match any one segment).
pub fn pattern_key(domain: u32, topics: &TopicPattern, dds_type: &str, type_hash: &str) -> String {
    format!("{domain}/{}/{dds_type}/{type_hash}", topics.as_str().trim_matches('/'))
}

/// Every data key of a topic, whatever its type (a key expression for access control).
pub fn key_space(domain: u32, topic: &Topic) -> String {
    format!("{domain}/{}/**", topic.as_str().trim_matches('/'))
}

/// Every liveliness token of a domain (the ROS graph).
pub fn liveliness_space(domain: u32) -> String {
    format!("@ros2_lv/{domain}/**")
}

/// The liveliness tokens of one node: its node token and its endpoints' tokens.
pub fn node_token_space(domain: u32, namespace: &str, name: &crate::NodeName) -> [String; 2] {
    let node = format!("@ros2_lv/{domain}/*/*/*/*/*/{}/{name}", mangle(namespace));
    [node.clone(), format!("{node}/**")]
}

/// Who a liveliness token describes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeIdentity {
    pub domain: u32,
    /// The Zenoh session id, hex.
    pub zid: String,
    pub node_id: u32,
    /// ROS namespace, e.g. `/avacraft` (empty for the root).
    pub namespace: String,
    pub name: String,
}

/// Kind of endpoint in a liveliness token.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EntityKind {
    Publisher,
    Subscription,
}

impl NodeIdentity {
    /// `@ros2_lv/<domain>/<zid>/<node_id>/<node_id>/NN/<enclave>/<namespace>/<name>`.
    pub fn node_token(&self) -> String {
        format!("@ros2_lv/{}/{}/{}/{}/NN/%/{}/{}", self.domain, self.zid, self.node_id, self.node_id, mangle(&self.namespace), self.name)
    }

    /// The endpoint token: the node's fields, then topic, type, hash and QoS.
    pub fn endpoint_token(&self, entity_id: u32, kind: EntityKind, topic: &Topic, dds_type: &str, type_hash: &str, qos: Qos) -> String {
        let k = match kind {
            EntityKind::Publisher => "MP",
            EntityKind::Subscription => "MS",
        };
        format!(
            "@ros2_lv/{}/{}/{}/{entity_id}/{k}/%/{}/{}/{}/{dds_type}/{type_hash}/{}",
            self.domain,
            self.zid,
            self.node_id,
            mangle(&self.namespace),
            self.name,
            mangle(topic.as_str()),
            qos.token_text()
        )
    }
}

/// A data key taken apart: `<domain>/<topic>/<dds type>/<type hash>`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataKey {
    pub domain: u32,
    pub topic: Topic,
    pub dds_type: String,
    pub type_hash: String,
}

/// The inverse of [`data_key`]; `None` for a key that is not one (a foreign publisher's).
pub fn parse_data_key(key: &str) -> Option<DataKey> {
    let (domain, rest) = key.split_once('/')?;
    let (rest, type_hash) = rest.rsplit_once('/')?;
    let (topic, dds_type) = rest.rsplit_once('/')?;
    Some(DataKey {
        domain: domain.parse().ok()?,
        topic: Topic::parse(&format!("/{topic}")).ok()?,
        dds_type: dds_type.to_owned(),
        type_hash: type_hash.to_owned(),
    })
}

/// What a liveliness token announces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum TokenKind {
    Node,
    Publisher,
    Subscription,
}

/// A liveliness token taken apart:
/// `@ros2_lv/<domain>/<zid>/<node>/<entity>/<NN|MP|MS>/<enclave>/<ns>/<name>[/<topic>/<type>/<hash>/<qos>]`
/// (names mangled, `%` for '/').
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Token {
    pub kind: TokenKind,
    /// The node's namespace, mangled as in the token (`%avacraft`).
    pub namespace: String,
    pub node: String,
    /// The endpoint's topic, for publishers and subscriptions.
    pub topic: Option<Topic>,
}

/// The inverse of [`NodeIdentity::node_token`] and [`NodeIdentity::endpoint_token`].
pub fn parse_token(key: &str) -> Option<Token> {
    let p: Vec<&str> = key.split('/').collect();
    if p.first() != Some(&"@ros2_lv") {
        return None;
    }
    let kind = match *p.get(5)? {
        "NN" => TokenKind::Node,
        "MP" => TokenKind::Publisher,
        "MS" => TokenKind::Subscription,
        _ => return None,
    };
    let topic = match kind {
        TokenKind::Node => None,
        _ => Some(Topic::parse(&p.get(9)?.replace('%', "/")).ok()?),
    };
    Some(Token { kind, namespace: (*p.get(7)?).to_owned(), node: (*p.get(8)?).to_owned(), topic })
}

/// An entity's GID: XXH3-128 of its liveliness key, low 64 bits then high 64 bits, little endian.
pub fn gid(liveliness_key: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(liveliness_key.as_bytes());
    let mut out = [0u8; 16];
    out[..8].copy_from_slice(&(h as u64).to_le_bytes());
    out[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    out
}

/// The attachment of a sample: `seq (i64 LE) | source timestamp ns (i64 LE) | 0x10 | gid`.
pub fn attachment(seq: i64, source_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&seq.to_le_bytes());
    a[8..16].copy_from_slice(&source_ns.to_le_bytes());
    a[16] = 0x10;
    a[17..].copy_from_slice(gid);
    a
}

/// A parsed attachment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attachment {
    pub seq: i64,
    pub source_ns: i64,
    pub gid: [u8; 16],
}

/// Reads an attachment; `None` when it is not rmw_zenoh's 33-byte layout.
pub fn parse_attachment(bytes: &[u8]) -> Option<Attachment> {
    let bytes: &[u8; 33] = bytes.try_into().ok()?;
    if bytes[16] != 0x10 {
        return None;
    }
    let (seq, rest) = bytes.split_first_chunk::<8>()?;
    let (ts, rest) = rest.split_first_chunk::<8>()?;
    let gid: [u8; 16] = rest[1..].try_into().ok()?;
    Some(Attachment { seq: i64::from_le_bytes(*seq), source_ns: i64::from_le_bytes(*ts), gid })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_tokens_parse_back() {
        let t = Topic::parse("/avacraft/team_1/unit_3/obs").expect("topic");
        let key = data_key(7, &t, "avacraft_msgs::msg::dds_::UnitObservation_", "RIHS01_ab");
        let k = parse_data_key(&key).expect("parses");
        assert_eq!(
            (k.domain, &k.topic, k.dds_type.as_str(), k.type_hash.as_str()),
            (7, &t, "avacraft_msgs::msg::dds_::UnitObservation_", "RIHS01_ab")
        );
        for bad in ["", "0", "x/a/T/H", "0/T/H", "0/a b/T/H"] {
            assert_eq!(parse_data_key(bad), None, "{bad:?}");
        }
        let n = NodeIdentity { domain: 0, zid: "abc".into(), node_id: 1, namespace: "/avacraft".into(), name: "sim".into() };
        let node = parse_token(&n.node_token()).expect("node token");
        assert_eq!((node.kind, node.namespace.as_str(), node.node.as_str(), node.topic), (TokenKind::Node, "%avacraft", "sim", None));
        let sub = parse_token(&n.endpoint_token(4, EntityKind::Subscription, &t, "T", "H", Qos::Reliable { depth: 10 })).expect("endpoint");
        assert_eq!((sub.kind, sub.topic.as_ref()), (TokenKind::Subscription, Some(&t)));
        assert_eq!(parse_token("@ros2_lv/0/abc/1/1/XX/%/%/n"), None);
        assert_eq!(parse_token("0/avacraft/status"), None);
    }

    #[test]
    fn keys_tokens_and_qos_follow_rmw_zenoh() {
        let t = Topic::parse("/robot1/chatter").expect("topic");
        assert_eq!(
            data_key(0, &t, "std_msgs::msg::dds_::String_", "RIHS01_df66"),
            "0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df66"
        );
        assert_eq!(Qos::Reliable { depth: 10 }.token_text(), "::2,:,:,:,,", "RELIABLE, KEEP_ALL");
        assert_eq!(Qos::BestEffort { depth: 1 }.token_text(), "2::,1:,:,:,,");
        assert_eq!(Qos::BestEffort { depth: 42 }.token_text(), "2::,:,:,:,,", "the default depth is left out");
        let n = NodeIdentity { domain: 0, zid: "abc".into(), node_id: 0, namespace: String::new(), name: "talker".into() };
        assert_eq!(n.node_token(), "@ros2_lv/0/abc/0/0/NN/%/%/talker");
        let unit0 = Topic::parse("/unit0/screen").expect("topic");
        assert_eq!(mangle(unit0.as_str()), "%unit0%screen");
        let e = n.endpoint_token(
            3,
            EntityKind::Publisher,
            &unit0,
            "sensor_msgs::msg::dds_::Image_",
            "RIHS01_d31d",
            Qos::BestEffort { depth: 1 },
        );
        assert_eq!(e, "@ros2_lv/0/abc/0/3/MP/%/%/talker/%unit0%screen/sensor_msgs::msg::dds_::Image_/RIHS01_d31d/2::,1:,:,:,,");
    }

    #[test]
    fn attachment_round_trips_and_rejects_other_layouts() {
        let g = gid("@ros2_lv/0/abc/0/3/MP");
        let a = attachment(7, 1_700_000_000_000_000_000, &g);
        assert_eq!(a.len(), 33);
        assert_eq!(a[16], 0x10);
        assert_eq!(parse_attachment(&a), Some(Attachment { seq: 7, source_ns: 1_700_000_000_000_000_000, gid: g }));
        assert_eq!(parse_attachment(&a[..32]), None);
        let mut bad = a;
        bad[16] = 0x11;
        assert_eq!(parse_attachment(&bad), None);
        assert_ne!(gid("a"), gid("b"));
    }
}
