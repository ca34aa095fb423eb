//! An image-mode network's frames in a deployment: the simulator draws its team's screen and
//! minimap at the network's sizes every step and sends them reliably on the team's frame
//! topics (`sensor_msgs/Image`, stamped with the step's game time, as the observations are).
//! An agent node acts on a step only once it holds both frames with its observations' stamp,
//! so the network reads the pixels an in-process run of the same step shows it.

use crate::AgentStats;
use avacraft_engine::agent::{FrameNeed, TeamFrames};
use avacraft_msgs::{Image, Time};
use avacraft_nodes::{FrameKind, Node, NodeError, Qos, Subscriber, TeamNo, TopicKind, Topics};

/// The team's newest screen and minimap, with their stamps.
pub(crate) struct FrameFeed {
    need: FrameNeed,
    team: TeamNo,
    subs: [(FrameKind, Subscriber<Image>); 2],
    latest: [Option<(Time, Vec<u8>)>; 2],
}

impl FrameFeed {
    /// Subscribes to `team`'s frames when the agent reads some.
    pub(crate) fn open(node: &Node, topics: &Topics, team: TeamNo, need: Option<FrameNeed>) -> Result<Option<FrameFeed>, NodeError> {
        let Some(need) = need else { return Ok(None) };
        let qos = Qos::Reliable { depth: 10 };
        let sub = |k: FrameKind| node.subscriber::<Image>(&topics.frames(team, k), qos).map(|s| (k, s));
        Ok(Some(FrameFeed { need, team, subs: [sub(FrameKind::Screen)?, sub(FrameKind::Minimap)?], latest: [None, None] }))
    }

    /// Takes what arrived; frames of another size or encoding, or off their topic, count as
    /// malformed. Whether anything arrived.
    pub(crate) fn poll(&mut self, topics: &Topics, stats: &mut AgentStats) -> Result<bool, NodeError> {
        let mut got = false;
        for (i, (kind, sub)) in self.subs.iter().enumerate() {
            let (w, h) = if *kind == FrameKind::Screen { self.need.screen } else { self.need.minimap };
            while let Some(r) = sub.try_recv()? {
                got = true;
                let on_topic = matches!(topics.classify(&r.topic), Some(TopicKind::Frames(t, k)) if t == self.team && k == *kind);
                match r.msg {
                    Ok(img) if on_topic && fits(&img, w, h) => self.latest[i] = Some((img.header.stamp, img.data)),
                    Ok(img) => {
                        stats.malformed += 1;
                        tracing::warn!(kind = kind.name(), width = img.width, height = img.height, encoding = %img.encoding,
                            "a frame of another size or encoding than the network reads ({w}x{h} rgb8) was ignored");
                    }
                    Err(e) => {
                        stats.malformed += 1;
                        tracing::warn!(kind = kind.name(), error = %e, "malformed frame ignored");
                    }
                }
            }
        }
        Ok(got)
    }

    /// Whether both frames of the step stamped `stamp` are here.
    pub(crate) fn has(&self, stamp: Time) -> bool {
        self.latest.iter().all(|l| l.as_ref().is_some_and(|(s, _)| *s == stamp))
    }

    /// The stamp of the newest step both frames are here for.
    pub(crate) fn newest(&self) -> Option<Time> {
        match &self.latest {
            [Some((s1, _)), Some((s2, _))] if s1 == s2 => Some(*s1),
            _ => None,
        }
    }

    /// Both frames of the step stamped `stamp`, once they are here.
    pub(crate) fn at(&self, stamp: Time) -> Option<TeamFrames> {
        match &self.latest {
            [Some((s1, screen)), Some((s2, minimap))] if *s1 == stamp && *s2 == stamp => {
                Some(TeamFrames { screen: screen.clone(), minimap: minimap.clone() })
            }
            _ => None,
        }
    }
}

fn fits(img: &Image, w: u32, h: u32) -> bool {
    img.width == w && img.height == h && img.encoding == "rgb8" && img.step == w * 3 && img.data.len() == (w * h * 3) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_rgb8_frames_of_the_networks_size_fit() {
        let good = Image { width: 4, height: 2, encoding: "rgb8".into(), step: 12, data: vec![0; 24], ..Image::default() };
        assert!(fits(&good, 4, 2));
        assert!(!fits(&good, 2, 4), "transposed");
        let bad = [
            Image { encoding: "bgr8".into(), ..good.clone() },
            Image { data: vec![0; 23], ..good.clone() },
            Image { step: 16, ..good.clone() },
            Image { width: 5, ..good.clone() },
        ];
        assert!(bad.iter().all(|b| !fits(b, 4, 2)));
    }
}
