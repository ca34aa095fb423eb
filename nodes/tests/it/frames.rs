//! Integration tests of the iceoryx2 frame transport.

use std::error::Error;
use std::io::{BufRead, BufReader, Write};
use std::process::Stdio;
use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use crate::common::{child_arg, child_process};
use avacraft_nodes::frames::{Encoding, FrameError, FrameHeader, FramePublisher, FrameSubscriber, MalformedFrame};

type TestResult = Result<(), Box<dyn Error + Send + Sync>>;

const FULL_HD_BYTES: usize = FrameHeader::SIZE + 1920 * 1080 * 3;
const RECV_TIMEOUT: Duration = Duration::from_secs(10);

fn service_name(test: &str) -> String {
    format!("avacraft/test_{}/{test}", std::process::id())
}

/// Deterministic pixel pattern that differs per frame and is not periodic at small strides.
fn pattern(sequence: u64, len: usize) -> Vec<u8> {
    (0..len).map(|i| ((i ^ (i >> 8) ^ (i >> 16)) as u64).wrapping_mul(31).wrapping_add(sequence.wrapping_mul(101)) as u8).collect()
}

fn check_frame(frame: &avacraft_nodes::frames::Frame, expected: &FrameHeader) -> TestResult {
    assert_eq!(frame.header(), expected);
    let want = pattern(expected.sequence, frame.pixels().len());
    assert_eq!(frame.pixels().len() as u64, expected.pixel_bytes());
    if let Some(pos) = frame.pixels().iter().zip(&want).position(|(a, b)| a != b) {
        return Err(format!("frame {} differs at byte {pos}", expected.sequence).into());
    }
    Ok(())
}

fn assert_send<T: Send>() {}

#[test]
fn ports_and_frames_are_send() {
    assert_send::<FramePublisher>();
    assert_send::<FrameSubscriber>();
    assert_send::<avacraft_nodes::frames::Frame>();
}

#[test]
fn round_trip_two_threads() -> TestResult {
    let service = service_name("roundtrip");
    let headers = [
        FrameHeader::packed(0, 1_000, 160, 120, Encoding::Rgb8),
        FrameHeader::packed(1, 2_000, 1920, 1080, Encoding::Rgb8),
        // padded rows: 10 px rgba8 = 40 bytes per row, step 48
        FrameHeader { sequence: 2, source_timestamp_ns: -5, width: 10, height: 3, step: 48, encoding: Encoding::Rgba8 },
    ];
    let (ready_tx, ready_rx) = mpsc::channel::<()>();
    let (ack_tx, ack_rx) = mpsc::channel::<()>();

    let sub_service = service.clone();
    let sub_headers = headers;
    let subscriber = thread::spawn(move || -> TestResult {
        let mut sub = FrameSubscriber::open(&sub_service, 4)?;
        ready_tx.send(())?;
        for expected in &sub_headers {
            let frame = sub.recv_timeout(RECV_TIMEOUT)?.ok_or("timed out waiting for a frame")?;
            check_frame(&frame, expected)?;
            ack_tx.send(())?;
        }
        Ok(())
    });

    let pub_service = service.clone();
    let publisher = thread::spawn(move || -> TestResult {
        ready_rx.recv_timeout(RECV_TIMEOUT)?;
        let mut publisher = FramePublisher::open(&pub_service, FULL_HD_BYTES, 4)?;
        for header in headers {
            publisher.publish(header, &pattern(header.sequence, header.pixel_bytes() as usize))?;
            ack_rx.recv_timeout(RECV_TIMEOUT)?;
        }
        Ok(())
    });

    publisher.join().map_err(|_| "publisher thread panicked")??;
    subscriber.join().map_err(|_| "subscriber thread panicked")??;
    Ok(())
}

#[test]
fn recv_returns_newest_frame_and_drops_older_ones() -> TestResult {
    let service = service_name("newest");
    let mut sub = FrameSubscriber::open(&service, 4)?;
    let mut publisher = FramePublisher::open(&service, 1024, 4)?;
    for seq in 0..5 {
        let header = FrameHeader::packed(seq, 0, 4, 2, Encoding::Rgba8);
        publisher.publish(header, &pattern(seq, 32))?;
    }
    let frame = sub.recv_timeout(RECV_TIMEOUT)?.ok_or("no frame")?;
    check_frame(&frame, &FrameHeader::packed(4, 0, 4, 2, Encoding::Rgba8))?;
    // a held frame stays valid while more frames arrive
    publisher.publish(FrameHeader::packed(5, 0, 4, 2, Encoding::Rgba8), &pattern(5, 32))?;
    let next = sub.recv_timeout(RECV_TIMEOUT)?.ok_or("no frame")?;
    assert_eq!(next.header().sequence, 5);
    check_frame(&frame, &FrameHeader::packed(4, 0, 4, 2, Encoding::Rgba8))?;
    assert!(sub.recv_timeout(Duration::from_millis(50))?.is_none());
    Ok(())
}

#[test]
fn each_user_has_a_private_iceoryx2_folder() -> TestResult {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let _sub = FrameSubscriber::open(&service_name("folder"), 4)?;
    let folder = avacraft_nodes::frames::iceoryx2_folder().ok_or("no iceoryx2 folder")?;
    let meta = std::fs::symlink_metadata(&folder)?;
    // The owner of a file this process makes is this user.
    let probe = folder.join(format!("probe-{}", std::process::id()));
    std::fs::write(&probe, b"")?;
    let uid = std::fs::metadata(&probe)?.uid();
    std::fs::remove_file(&probe)?;
    assert_eq!(folder, std::path::PathBuf::from(format!("/tmp/iceoryx2-{uid}")));
    assert!(meta.is_dir() && meta.uid() == uid, "{} is not this user's folder", folder.display());
    assert_eq!(meta.permissions().mode() & 0o777, 0o700, "{} is not private", folder.display());
    assert!(folder.join("nodes").is_dir(), "iceoryx2 keeps its nodes elsewhere than {}", folder.display());
    Ok(())
}

#[test]
fn recv_times_out_without_publisher() -> TestResult {
    let mut sub = FrameSubscriber::open(&service_name("timeout"), 4)?;
    let start = std::time::Instant::now();
    assert!(sub.recv_timeout(Duration::from_millis(100))?.is_none());
    assert!(start.elapsed() >= Duration::from_millis(100));
    Ok(())
}

#[test]
fn oversized_and_inconsistent_frames_are_refused() -> TestResult {
    let service = service_name("limits");
    let mut publisher = FramePublisher::open(&service, FrameHeader::SIZE + 100, 4)?;
    let header = FrameHeader::packed(0, 0, 10, 10, Encoding::Rgb8);
    match publisher.publish(header, &[0u8; 300]) {
        Err(err @ FrameError::FrameTooLarge { frame_bytes: 332, pixel_bytes: 300, max_bytes: 132, .. }) => {
            let msg = err.to_string();
            assert!(msg.contains(&service) && msg.contains("332") && msg.contains("132"), "{msg}");
        }
        other => return Err(format!("expected FrameTooLarge, got {other:?}").into()),
    }
    match publisher.publish(FrameHeader::packed(0, 0, 4, 4, Encoding::Rgb8), &[0u8; 47]) {
        Err(FrameError::InvalidFrame { source: MalformedFrame::SizeMismatch { expected: 48, actual: 47 }, .. }) => {}
        other => return Err(format!("expected InvalidFrame, got {other:?}").into()),
    }
    // a frame that fits is still accepted afterwards
    publisher.publish(FrameHeader::packed(1, 0, 4, 4, Encoding::Rgb8), &[7u8; 48])?;
    Ok(())
}

#[test]
fn header_round_trip_and_targeted_rejections() {
    let header = FrameHeader { sequence: u64::MAX - 3, source_timestamp_ns: -42, width: 3, height: 2, step: 12, encoding: Encoding::Rgba8 };
    let mut bytes = header.encode().to_vec();
    bytes.extend_from_slice(&[9u8; 24]);
    assert_eq!(FrameHeader::parse(&bytes), Ok((header, &[9u8; 24][..])));

    assert_eq!(FrameHeader::parse(&bytes[..31]), Err(MalformedFrame::TooShort { len: 31 }));
    assert_eq!(FrameHeader::parse(&bytes[..40]), Err(MalformedFrame::SizeMismatch { expected: 24, actual: 8 }));
    let mut bad = bytes.clone();
    bad[28] = 2;
    assert_eq!(FrameHeader::parse(&bad), Err(MalformedFrame::BadEncoding { code: 2 }));
    let mut bad = bytes.clone();
    bad[30] = 1;
    assert_eq!(FrameHeader::parse(&bad), Err(MalformedFrame::ReservedNotZero { reserved: [0, 1, 0] }));
    let mut bad = bytes.clone();
    bad[24..28].copy_from_slice(&11u32.to_le_bytes());
    assert_eq!(FrameHeader::parse(&bad), Err(MalformedFrame::StepTooSmall { step: 11, width: 3, bytes_per_pixel: 4 }));
    // huge declared sizes must not overflow
    let mut bad = bytes;
    bad[16..28].copy_from_slice(&[0xff; 12]);
    assert!(matches!(FrameHeader::parse(&bad), Err(MalformedFrame::StepTooSmall { .. })));
}

#[test]
fn header_parsing_rejects_random_garbage() {
    let mut rng = fastrand::Rng::with_seed(0x0A7A_C4AF);
    let mut accepted = 0;
    for _ in 0..20_000 {
        let len = rng.usize(0..256);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.u8(..)).collect();
        if rng.bool() && len >= FrameHeader::SIZE {
            // make the encoding and padding plausible so the size checks get exercised too
            bytes[28] = rng.u8(0..2);
            bytes[29..32].fill(0);
        }
        // must never panic; whatever is accepted must be self-consistent
        if let Ok((header, pixels)) = FrameHeader::parse(&bytes) {
            accepted += 1;
            assert_eq!(header.pixel_bytes(), pixels.len() as u64);
            assert_eq!(&header.encode()[..], &bytes[..FrameHeader::SIZE]);
        }
    }
    // random widths/heights practically never match the length
    assert!(accepted < 20, "accepted {accepted} random slices");
}

#[test]
fn malformed_sample_is_a_typed_error() -> TestResult {
    use iceoryx2::prelude::*;
    let service = service_name("garbage");
    let mut sub = FrameSubscriber::open(&service, 4)?;
    // a foreign publisher on the same service sending a 10-byte sample
    let node = NodeBuilder::new().config(avacraft_nodes::frames::iceoryx2_config()?).create::<ipc_threadsafe::Service>()?;
    let pubsub = node.service_builder(&ServiceName::new(&service)?).publish_subscribe::<[u8]>().open()?;
    let raw = pubsub.publisher_builder().initial_max_slice_len(64).create()?;
    raw.loan_slice_uninit(10)?.write_from_fn(|i| i as u8).send()?;
    match sub.try_recv() {
        Err(err @ FrameError::Malformed { source: MalformedFrame::TooShort { len: 10 }, .. }) => {
            assert!(err.to_string().contains(&service));
        }
        other => return Err(format!("expected Malformed, got {other:?}").into()),
    }
    Ok(())
}

const CHILD_FRAMES: u64 = 50;

/// The child of `cross_process_50_frames`: publishes the frames one by one, each after the
/// parent has acknowledged the one before.
fn publish_for_parent(service: &str) -> TestResult {
    let mut publisher = FramePublisher::open(service, FrameHeader::SIZE + 160 * 120 * 3, 4)?;
    let mut acks = BufReader::new(std::io::stdin());
    for seq in 0..CHILD_FRAMES {
        let header = FrameHeader::packed(seq, seq as i64 * 1_000_000, 160, 120, Encoding::Rgb8);
        publisher.publish(header, &pattern(seq, header.pixel_bytes() as usize))?;
        // wait for the parent to confirm reception, so no frame is overwritten
        let mut line = String::new();
        if acks.read_line(&mut line)? == 0 {
            return Err("parent closed the ack pipe".into());
        }
    }
    Ok(())
}

#[test]
fn cross_process_50_frames() -> TestResult {
    if let Some(service) = child_arg() {
        return publish_for_parent(&service);
    }
    let service = service_name("cross_process");
    let mut sub = FrameSubscriber::open(&service, 4)?;
    let mut child = child_process("frames::cross_process_50_frames", &service)?.stdin(Stdio::piped()).stdout(Stdio::null()).spawn()?;
    let mut ack = child.stdin.take().ok_or("no child stdin")?;
    let mut result: TestResult = Ok(());
    for seq in 0..CHILD_FRAMES {
        let step = sub.recv_timeout(RECV_TIMEOUT).map_err(Into::into).and_then(|frame| {
            let frame = frame.ok_or_else(|| format!("timed out waiting for frame {seq}"))?;
            check_frame(&frame, &FrameHeader::packed(seq, seq as i64 * 1_000_000, 160, 120, Encoding::Rgb8))
        });
        if let Err(e) = step {
            result = Err(e);
            break;
        }
        writeln!(ack, "ok")?;
    }
    drop(ack);
    let status = child.wait()?;
    result?;
    assert!(status.success(), "child exited with {status}");
    Ok(())
}

/// The child of `stale_resources_of_killed_process_are_removed`: opens a publisher, says
/// so, and blocks until it is killed.
fn be_killed_holding_a_publisher(service: &str) -> TestResult {
    let _publisher = FramePublisher::open(service, 1024, 4)?;
    println!("IPC_CHILD_READY");
    std::io::stdout().flush()?;
    let mut line = String::new();
    std::io::stdin().read_line(&mut line)?; // never answered; the parent kills us
    Ok(())
}

fn dead_nodes() -> Result<usize, Box<dyn Error + Send + Sync>> {
    use iceoryx2::prelude::*;
    let mut dead = 0;
    Node::<ipc_threadsafe::Service>::list(avacraft_nodes::frames::iceoryx2_config()?, |state| {
        if matches!(state, NodeState::Dead(_)) {
            dead += 1;
        }
        CallbackProgression::Continue
    })
    .map_err(|e| format!("cannot list iceoryx2 nodes: {e:?}"))?;
    Ok(dead)
}

#[test]
fn stale_resources_of_killed_process_are_removed() -> TestResult {
    if let Some(service) = child_arg() {
        return be_killed_holding_a_publisher(&service);
    }
    let service = service_name("crash");
    let mut child = child_process("frames::stale_resources_of_killed_process_are_removed", &service)?
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()?;
    let stdout = child.stdout.take().ok_or("no child stdout")?;
    let ready = BufReader::new(stdout).lines().map_while(Result::ok).any(|line| line.contains("IPC_CHILD_READY"));
    child.kill()?; // SIGKILL: no destructors run in the child
    child.wait()?;
    assert!(ready, "child never opened its publisher");
    let dead_before = dead_nodes()?;
    // Other tests of this process open nodes concurrently, and opening a node also cleans dead
    // nodes; a cleanup that finds another one under way skips that node. So call it again until
    // nothing dead is left, and assert on the final state rather than on who cleaned.
    let mut cleaned = 0;
    let mut left = dead_before;
    for _ in 0..200 {
        cleaned += avacraft_nodes::frames::cleanup_stale_resources();
        left = dead_nodes()?;
        if left == 0 {
            break;
        }
        thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(left, 0, "dead nodes left (before: {dead_before}, cleaned here: {cleaned})");
    eprintln!("stale cleanup: {dead_before} dead node(s) found, {cleaned} removed by cleanup_stale_resources");
    // the service is usable again by new participants
    let mut sub = FrameSubscriber::open(&service, 4)?;
    let mut publisher = FramePublisher::open(&service, 1024, 4)?;
    publisher.publish(FrameHeader::packed(7, 0, 2, 2, Encoding::Rgb8), &[1u8; 12])?;
    let frame = sub.recv_timeout(RECV_TIMEOUT)?.ok_or("no frame after cleanup")?;
    assert_eq!(frame.header().sequence, 7);
    Ok(())
}
