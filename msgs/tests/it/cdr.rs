//! The encode/decode choke point: reference bytes, round trips, hostile input.

use crate::common::*;
use avacraft_msgs::{
    AbilityState, ActionBatch, AreaEffect, DecodeError, EpisodeStatus, Header, Image, RoleAssignment, RoleGroup, RosMessage, SessionInfo,
    StdString, TeamObservation, Time, UnitAction, UnitObservation, UnitState, decode, encode,
};
use proptest::prelude::*;

fn hex(s: &str) -> Vec<u8> {
    let digits: Vec<u8> = s.bytes().filter(|b| b.is_ascii_hexdigit()).collect();
    digits.chunks(2).map(|p| u8::from_str_radix(std::str::from_utf8(p).expect("ascii"), 16).expect("hex")).collect()
}

fn rgb_2x2() -> Image {
    Image {
        header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "cam".into() },
        height: 2,
        width: 2,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: 6,
        data: (1..=12).collect(),
    }
}

/// Reference bytes from /work/shared/reference/ros2_interop.md.
#[test]
fn image_matches_reference_bytes() {
    let mut expected = hex("00010000 01000000 02000000 04000000 63616d00 02000000 02000000 05000000 72676238 00 000000 06000000 0c000000");
    expected.extend(1..=12u8);
    assert_eq!(encode(&rgb_2x2()), expected);
    assert_eq!(decode::<Image>(&expected).expect("reference bytes decode"), rgb_2x2());
}

#[test]
fn std_string_is_length_prefixed_and_nul_terminated() {
    let bytes = encode(&StdString { data: "hi".into() });
    assert_eq!(bytes, [0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0]);
}

#[test]
fn up_to_three_padding_bytes_are_accepted_but_not_more() {
    let mut bytes = encode(&StdString { data: "hi".into() });
    bytes.push(0);
    assert_eq!(decode::<StdString>(&bytes).expect("1 byte of padding").data, "hi");
    bytes.extend([0, 0, 0]);
    assert!(matches!(decode::<StdString>(&bytes), Err(DecodeError::TrailingBytes { count: 4 })));
}

#[test]
fn big_endian_payloads_decode() {
    let bytes = [0, 0, 0, 0, 0, 0, 0, 7, 0, 0, 0, 9];
    assert_eq!(decode::<Time>(&bytes).expect("CDR_BE"), Time { sec: 7, nanosec: 9 });
}

#[test]
fn errors_name_the_problem() {
    assert!(matches!(decode::<Time>(&[0, 1]), Err(DecodeError::TooShort { len: 2 })));
    assert!(matches!(decode::<Time>(&[0, 7, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]), Err(DecodeError::UnsupportedEncapsulation { id: [0, 7] })));
    assert!(matches!(decode::<Time>(&[0, 1, 0, 0, 1, 0, 0, 0, 2]), Err(DecodeError::Truncated)));
    assert!(matches!(decode::<StdString>(&[0, 1, 0, 0, 2, 0, 0, 0, 0xff, 0]), Err(DecodeError::InvalidUtf8(_))));
    let mut bad_bool = encode(&AbilityState::default());
    bad_bool[4 + 1] = 2; // after the `ability` byte
    assert!(matches!(decode::<AbilityState>(&bad_bool), Err(DecodeError::InvalidBool(2))));
    let e = decode::<Time>(&[0, 1]).expect_err("too short");
    assert!(e.to_string().contains("2 bytes"), "{e}");
}

/// A length prefix of 4 billion must fail on the missing bytes, not try to allocate them.
#[test]
fn huge_length_prefixes_fail_without_allocating() {
    let mut payload = encode(&RoleGroup::default());
    // Layout: header, role (1), pad 3, agent_id (4+1), pad 3, unit_tags count.
    payload.truncate(payload.len() - 4);
    payload.extend(u32::MAX.to_le_bytes());
    assert!(matches!(decode::<RoleGroup>(&payload), Err(DecodeError::Truncated)));
    // TeamObservation body: stamp 0..8, frame_id 8..13 + pad, episode 16..24, step, game_loop,
    // team 32, pad, `units` count at 36..40 (plus the 4-byte header).
    let mut team = encode(&TeamObservation { team: 5, units: vec![UnitState::default()], ..TeamObservation::default() });
    assert_eq!((team[36], &team[40..44]), (5, &[1u8, 0, 0, 0][..]), "layout assumption");
    team[40..44].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(decode::<TeamObservation>(&team), Err(DecodeError::Truncated)));
    let mut image = encode(&Image::default());
    let n = image.len();
    image[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(decode::<Image>(&image), Err(DecodeError::Truncated)));
}

fn round_trip<T: RosMessage + PartialEq + std::fmt::Debug>(value: &T) -> Result<(), TestCaseError> {
    let bytes = encode(value);
    prop_assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
    let back: T = decode(&bytes).map_err(|e| TestCaseError::fail(format!("{}: {e}", T::TYPE_NAME)))?;
    prop_assert_eq!(&back, value);
    Ok(())
}

proptest! {
    #[test]
    fn time_round_trips(v in time()) { round_trip(&v)?; }
    #[test]
    fn header_round_trips(v in header()) { round_trip(&v)?; }
    #[test]
    fn std_string_round_trips(v in std_string()) { round_trip(&v)?; }
    #[test]
    fn image_round_trips(v in image(0)) { round_trip(&v)?; }
    #[test]
    fn unit_state_round_trips(v in unit_state(0)) { round_trip(&v)?; }
    #[test]
    fn ability_state_round_trips(v in ability_state()) { round_trip(&v)?; }
    #[test]
    fn area_effect_round_trips(v in area_effect()) { round_trip(&v)?; }
    #[test]
    fn unit_observation_round_trips(v in unit_observation(0)) { round_trip(&v)?; }
    #[test]
    fn team_observation_round_trips(v in team_observation(0)) { round_trip(&v)?; }
    #[test]
    fn unit_action_round_trips(v in unit_action()) { round_trip(&v)?; }
    #[test]
    fn action_batch_round_trips(v in action_batch(0)) { round_trip(&v)?; }
    #[test]
    fn episode_status_round_trips(v in episode_status()) { round_trip(&v)?; }
    #[test]
    fn role_group_round_trips(v in role_group(0)) { round_trip(&v)?; }
    #[test]
    fn role_assignment_round_trips(v in role_assignment(0)) { round_trip(&v)?; }
    #[test]
    fn session_info_round_trips(v in session_info(0)) { round_trip(&v)?; }
    #[test]
    fn model_call_round_trips(v in model_call(0)) { round_trip(&v)?; }
    #[test]
    fn team_features_round_trip(v in team_features(0)) { round_trip(&v)?; }

    /// Any bytes, with or without a valid header, give a value or an error, never a panic.
    #[test]
    fn decoding_arbitrary_bytes_never_panics(mut bytes in proptest::collection::vec(any::<u8>(), 0..256), valid_header in any::<bool>()) {
        if valid_header && bytes.len() >= 4 {
            bytes[..4].copy_from_slice(&[0, 1, 0, 0]);
        }
        let _ = decode::<UnitObservation>(&bytes);
        let _ = decode::<TeamObservation>(&bytes);
        let _ = decode::<ActionBatch>(&bytes);
        let _ = decode::<EpisodeStatus>(&bytes);
        let _ = decode::<RoleAssignment>(&bytes);
        let _ = decode::<SessionInfo>(&bytes);
        let _ = decode::<avacraft_msgs::ModelCall>(&bytes);
        let _ = decode::<avacraft_msgs::TeamFeatures>(&bytes);
        let _ = decode::<Image>(&bytes);
        let _ = decode::<AreaEffect>(&bytes);
        let _ = decode::<UnitState>(&bytes);
        let _ = decode::<UnitAction>(&bytes);
        prop_assert!(decode::<Time>(&bytes[..bytes.len().min(3)]).is_err());
    }

    /// Corrupting one byte of a valid payload never panics either.
    #[test]
    fn corrupted_payloads_never_panic(v in unit_observation(0), index in any::<prop::sample::Index>(), byte in any::<u8>()) {
        let mut bytes = encode(&v);
        let i = index.index(bytes.len());
        bytes[i] = byte;
        let _ = decode::<UnitObservation>(&bytes);
        // Every proper prefix lacks part of the last field (`text`), so it must be rejected.
        prop_assert!(decode::<UnitObservation>(&bytes[..i]).is_err());
    }
}
