//! Replaying a recording made by a real deployment (`deploy.rs` records one and calls
//! [`check_recording`]): with no flag, every recorded state matches; in tampered copies
//! (one applied action, an episode's seed, the recorded configuration) the replay names the
//! first diverging step; recordings without a session description, cut short or not MCAP
//! at all get clear answers.

use avacraft_cli::{Mismatch, ReplayError, read_recording, replay_recording};
use avacraft_msgs::{ActionBatch, EpisodeStatus, RosMessage, SessionInfo, UnitAction, decode, encode};
use std::borrow::Cow;
use std::path::Path;
use std::process::Command;

use crate::common::{exe, tmp};

/// A copy of an MCAP file with each message passed through `edit` (schema name, payload);
/// messages for which it returns false are left out.
fn rewrite(bytes: &[u8], mut edit: impl FnMut(&str, &mut Vec<u8>) -> bool) -> Vec<u8> {
    let mut w = mcap::Writer::new(std::io::Cursor::new(Vec::new())).expect("writer");
    for m in mcap::MessageStream::new(bytes).expect("an MCAP file") {
        let m = m.expect("a message");
        let mut data = m.data.to_vec();
        let ty = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        if edit(ty, &mut data) {
            w.write(&mcap::Message { data: Cow::Owned(data), ..m }).expect("write");
        }
    }
    w.finish().expect("finish");
    w.into_inner().into_inner()
}

/// Edits every message of type `T` in place.
fn edit_each<T: RosMessage>(bytes: &[u8], mut f: impl FnMut(&mut T)) -> Vec<u8> {
    rewrite(bytes, |ty, data| {
        if ty == T::TYPE_NAME {
            let mut msg: T = decode(data).expect("decodes");
            f(&mut msg);
            *data = encode(&msg);
        }
        true
    })
}

/// The first mismatch of each episode of a recording's replay.
fn mismatches(bytes: &[u8]) -> Vec<Option<Mismatch>> {
    let rec = read_recording(bytes).expect("readable");
    replay_recording(&rec, None).expect("replays").into_iter().map(|r| r.mismatch).collect()
}

fn replay_cli(file: &Path, extra: &[&str]) -> (bool, String) {
    let out = Command::new(exe()).arg("replay").arg(file).args(extra).output().expect("run avacraft replay");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

/// `mcap` holds two episodes of a lockstep deployment.
pub fn check_recording(mcap: &Path) {
    let bytes = std::fs::read(mcap).expect("the recording");
    // Nothing but the file: every recorded state matches, and the video renders.
    let gif = tmp("replay.gif");
    let (ok, text) = replay_cli(mcap, &["--video", gif.to_str().expect("utf8")]);
    assert!(ok, "{text}");
    assert_eq!(text.matches("every recorded state matches").count(), 2, "{text}");
    assert!(std::fs::metadata(&gif).is_ok_and(|m| m.len() > 1000));
    let rec = read_recording(&bytes).expect("readable");
    assert_eq!(rec.episodes.len(), 2);
    let results = replay_recording(&rec, None).expect("replays");
    for r in &results {
        assert!(r.mismatch.is_none() && r.complete && r.compared_steps as u32 == r.steps + 1, "{r:?}");
    }

    // One applied action changed (to Hold) at step k: the state after step k, that of
    // step k + 1, is the first to differ, in that episode only.
    let ep0 = &rec.episodes[&0];
    let (k, i) = ep0
        .applied
        .iter()
        .filter(|(s, _)| **s >= 2)
        .find_map(|(&s, b)| b.actions.iter().position(|a| a.kind != UnitAction::HOLD && a.kind != UnitAction::NOOP).map(|i| (s, i)))
        .expect("an order to change");
    let tampered = edit_each::<ActionBatch>(&bytes, |b| {
        if b.episode == 0 && b.step == k {
            b.actions[i].kind = UnitAction::HOLD;
        }
    });
    let found = mismatches(&tampered);
    let want = ep0.statuses[&(k + 1)].state_hash;
    assert!(
        matches!(&found[0], Some(Mismatch::State { step, expected, got, .. }) if *step == k + 1 && *expected == want && *got != want),
        "{found:?}"
    );
    assert_eq!(found[1], None, "the other episode still matches");
    let copy = tmp("tampered_action.mcap");
    std::fs::write(&copy, &tampered).expect("write");
    let (ok, text) = replay_cli(&copy, &[]);
    assert!(!ok && text.contains(&format!("episode 0 (seed {}, 3m_vlm): MISMATCH: diverges at step {}", ep0.seed, k + 1)), "{text}");
    assert!(text.contains(&format!("recorded state hash {want:016x}")), "{text}");

    // Another seed for episode 1: its very first state differs.
    let tampered = edit_each::<EpisodeStatus>(&bytes, |s| {
        if s.episode == 1 {
            s.seed += 100;
        }
    });
    let found = mismatches(&tampered);
    assert!(found[0].is_none() && matches!(found[1], Some(Mismatch::State { step: 0, .. })), "{found:?}");

    // A different recorded configuration (opponent, game loops per step) is seen at step 0.
    for change in
        [(|s: &mut SessionInfo| s.opponent = SessionInfo::OPPONENT_FOCUS) as fn(&mut SessionInfo), |s: &mut SessionInfo| s.step_mul = 4]
    {
        let found = mismatches(&edit_each::<SessionInfo>(&bytes, change));
        assert!(found.iter().all(|m| matches!(m, Some(Mismatch::State { step: 0, .. }))), "{found:?}");
    }

    // A recording from before sessions were recorded is refused, naming what it lacks.
    let old = rewrite(&bytes, |ty, _| ty != SessionInfo::TYPE_NAME);
    assert!(matches!(read_recording(&old), Err(ReplayError::NoSession)));
    let copy = tmp("no_session.mcap");
    std::fs::write(&copy, &old).expect("write");
    let (ok, text) = replay_cli(&copy, &[]);
    assert!(!ok && text.contains("no session description") && text.contains("avacraft_msgs/msg/SessionInfo"), "{text}");

    // A recorder that joined during episode 0: that episode is skipped, episode 1 replays.
    let late = rewrite(&bytes, |ty, data| match ty {
        t if t == EpisodeStatus::TYPE_NAME => decode::<EpisodeStatus>(data).is_ok_and(|s| s.episode > 0 || s.step >= 3),
        t if t == ActionBatch::TYPE_NAME => decode::<ActionBatch>(data).is_ok_and(|b| b.episode > 0 || b.step >= 3),
        t if t == SessionInfo::TYPE_NAME => decode::<SessionInfo>(data).is_ok_and(|s| s.episode > 0),
        _ => true,
    });
    let rec = read_recording(&late).expect("readable");
    assert_eq!(rec.skipped, vec![(0, "the recording starts at its step 3".to_owned())]);
    assert_eq!(mismatches(&late), vec![None]);
    let copy = tmp("late.mcap");
    std::fs::write(&copy, &late).expect("write");
    let (ok, text) = replay_cli(&copy, &[]);
    assert!(ok && text.contains("episode 0: skipped") && text.contains("every recorded state matches"), "{text}");

    // Cut short: what is left replays, with a warning; no episode is called a mismatch.
    let copy = tmp("cut.mcap");
    std::fs::write(&copy, &bytes[..bytes.len() * 2 / 3]).expect("write");
    let (ok, text) = replay_cli(&copy, &[]);
    assert!(ok && text.contains("is cut short"), "{text}");

    // Not MCAP at all.
    assert!(matches!(read_recording(b"scenario: 3m_vlm\n"), Err(ReplayError::NotMcap(_))));
    let copy = tmp("not.mcap");
    std::fs::write(&copy, b"scenario: 3m_vlm\n").expect("write");
    let (ok, text) = replay_cli(&copy, &[]);
    assert!(!ok && text.contains("not an MCAP file"), "{text}");
}

/// The live view's channels a launch adds to its recording: each a ROS 2 topic (ros2msg
/// schema, CDR, its type hash), one screen, scene and status per re-simulated step, at the log
/// time of that step's recorded status, and decodable as its ROS 2 type.
pub fn check_live_channels(bytes: &[u8]) {
    use avacraft_live::LiveChannel;
    use avacraft_msgs::foxglove_msgs::SceneUpdate;
    use avacraft_msgs::{Image, StdString, decode};
    let summary = mcap::Summary::read(bytes).expect("summary").expect("summary present");
    for c in LiveChannel::ALL {
        let ch =
            summary.channels.values().find(|ch| ch.topic == c.topic().as_str()).unwrap_or_else(|| panic!("{} not recorded", c.topic()));
        let (name, schema, hash) = avacraft_live::ros2_type(c);
        let s = ch.schema.as_ref().expect("a schema");
        assert_eq!((s.name.as_str(), s.encoding.as_str(), ch.message_encoding.as_str()), (name, "ros2msg", "cdr"), "{}", c.topic());
        assert_eq!(s.data.as_ref(), schema.as_bytes());
        assert_eq!(ch.metadata.get("topic_type_hash").map(String::as_str), Some(hash));
    }
    let rec = read_recording(bytes).expect("readable");
    let steps: usize = replay_recording(&rec, None).expect("replays").iter().map(|r| r.steps as usize).sum();
    let status_times: std::collections::BTreeSet<u64> = rec.episodes.values().flat_map(|e| e.status_times.values().copied()).collect();
    let msgs: Vec<_> = mcap::MessageStream::new(bytes).expect("stream").filter_map(Result::ok).collect();
    let on = |c: LiveChannel| msgs.iter().filter(move |m| m.channel.topic == c.topic().as_str());
    for c in [LiveChannel::Screen, LiveChannel::Scene, LiveChannel::Status] {
        assert_eq!(on(c).count(), steps, "{}: one message per re-simulated step", c.topic());
        assert!(on(c).all(|m| status_times.contains(&m.log_time)), "{}: at the recorded steps' times", c.topic());
    }
    let img: Image = decode(&on(LiveChannel::Screen).next().expect("a screen").data).expect("an Image");
    let (w, h) = avacraft_cli::RECORDED_VIEW.screen;
    assert_eq!((img.width, img.height, img.encoding.as_str(), img.data.len() as u32), (w, h, "rgb8", w * h * 3));
    let scene: SceneUpdate = decode(&on(LiveChannel::Scene).next().expect("a scene").data).expect("a SceneUpdate");
    assert!(!scene.entities.is_empty() && scene.entities.iter().all(|e| !e.cylinders.is_empty()));
    let status: StdString = decode(&on(LiveChannel::Status).next().expect("a status").data).expect("a String");
    let json: serde_json::Value = serde_json::from_str(&status.data).expect("the status's JSON");
    assert!(json["scenario"].is_string(), "{json}");
    // Adding them again is refused, and the file stays as it was.
    let copy = tmp("live_twice.mcap");
    std::fs::write(&copy, bytes).expect("copy");
    let again = avacraft_cli::add_live_channels(&copy).expect_err("refused");
    assert!(format!("{again:#}").contains("already has the live view's channels"), "{again:#}");
    assert_eq!(std::fs::read(&copy).expect("still there"), bytes);
    // So is a file that is not a session, unchanged too.
    let not = tmp("not_a_session.mcap");
    std::fs::write(&not, b"not an mcap file").expect("write");
    assert!(avacraft_cli::add_live_channels(&not).is_err());
    assert_eq!(std::fs::read(&not).expect("still there"), b"not an mcap file");
}
