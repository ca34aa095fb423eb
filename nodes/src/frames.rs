//! Zero-copy image-frame transport between local processes over iceoryx2 0.10.
//!
//! A frame service named `service` (for example `avacraft/team_1/screen`) consists of
//!
//! * a publish-subscribe service of `[u8]` slices; every sample is a 32-byte little-endian
//!   [`FrameHeader`] followed by the pixel rows, and
//! * an event service `<service>/notify`; the publisher notifies it after every sample so that
//!   subscribers can sleep in [`FrameSubscriber::recv_timeout`] instead of polling.
//!
//! Wire layout of the header (all little endian, 32 bytes):
//!
//! | offset | size | field                                   |
//! |--------|------|-----------------------------------------|
//! | 0      | 8    | `sequence` (u64)                        |
//! | 8      | 8    | `source_timestamp_ns` (i64)             |
//! | 16     | 4    | `width` (u32)                           |
//! | 20     | 4    | `height` (u32)                          |
//! | 24     | 4    | `step` (u32, bytes per row)             |
//! | 28     | 1    | encoding (0 = rgb8, 1 = rgba8)          |
//! | 29     | 3    | reserved, must be zero                  |
//!
//! The pixel block that follows must be exactly `step * height` bytes, with
//! `step >= width * bytes_per_pixel`.
//!
//! The ports use `ipc_threadsafe` services, so [`FramePublisher`], [`FrameSubscriber`] and
//! [`Frame`] are `Send` and can be moved to worker threads.
//!
//! Every user has an iceoryx2 instance of its own: its folder is `/tmp/iceoryx2-<uid>/` (mode
//! 0700, see [`iceoryx2_folder`]) and its shared-memory objects are named `iox2_<uid>_*`, a
//! function of the user alone, so all of a user's processes meet there whatever their
//! environment. (iceoryx2's default, `/tmp/iceoryx2/`, belongs to the first user who made it,
//! mode 0750, and refuses every other user.)

use core::fmt;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::{Path as StdPath, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use iceoryx2::node::{NodeCleanupFailure, NodeView};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;

/// The iceoryx2 service flavour used for all ports (inter-process, ports are `Send + Sync`).
type Ipc = ipc_threadsafe::Service;

/// History of the publish-subscribe service: none, a late subscriber waits for the next frame.
const HISTORY_SIZE: usize = 0;
/// Per-subscriber queue depth; with safe overflow the oldest queued frame is overwritten.
const SUBSCRIBER_BUFFER_SIZE: usize = 2;
/// Samples a subscriber may hold at once: one while draining to the newest sample plus
/// [`MAX_HELD_FRAMES`] frames held by the user.
const SUBSCRIBER_MAX_BORROWED_SAMPLES: usize = MAX_HELD_FRAMES + 2;
/// Number of [`Frame`]s a user may keep alive at the same time per subscriber.
pub const MAX_HELD_FRAMES: usize = 2;
/// Publishers allowed per frame service.
const MAX_PUBLISHERS: usize = 2;
/// Notifiers allowed per notify service (one per publisher).
const MAX_NOTIFIERS: usize = MAX_PUBLISHERS;

/// Pixel encoding of a frame, as in ROS `sensor_msgs/Image`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// 3 bytes per pixel, code 0.
    Rgb8,
    /// 4 bytes per pixel, code 1.
    Rgba8,
}

impl Encoding {
    /// Wire code of the encoding.
    pub const fn code(self) -> u8 {
        match self {
            Encoding::Rgb8 => 0,
            Encoding::Rgba8 => 1,
        }
    }

    /// Parses a wire code.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Encoding::Rgb8),
            1 => Some(Encoding::Rgba8),
            _ => None,
        }
    }

    /// Bytes per pixel.
    pub const fn bytes_per_pixel(self) -> u32 {
        match self {
            Encoding::Rgb8 => 3,
            Encoding::Rgba8 => 4,
        }
    }

    /// ROS encoding name (`rgb8`, `rgba8`).
    pub const fn as_str(self) -> &'static str {
        match self {
            Encoding::Rgb8 => "rgb8",
            Encoding::Rgba8 => "rgba8",
        }
    }
}

impl fmt::Display for Encoding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Metadata sent in front of every frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FrameHeader {
    /// Publisher-defined sequence number.
    pub sequence: u64,
    /// Source timestamp in nanoseconds (clock chosen by the application).
    pub source_timestamp_ns: i64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels (rows).
    pub height: u32,
    /// Bytes per row, at least `width * bytes_per_pixel`.
    pub step: u32,
    /// Pixel encoding.
    pub encoding: Encoding,
}

/// Why a byte slice is not a valid frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MalformedFrame {
    /// Shorter than the fixed header.
    #[error("sample of {len} bytes is shorter than the {}-byte frame header", FrameHeader::SIZE)]
    TooShort {
        /// Length of the sample.
        len: usize,
    },
    /// Unknown encoding code.
    #[error("unknown encoding code {code} (0 = rgb8, 1 = rgba8)")]
    BadEncoding {
        /// The code found.
        code: u8,
    },
    /// Reserved header bytes are not zero.
    #[error("reserved header bytes 29..32 are not zero: {reserved:?}")]
    ReservedNotZero {
        /// The reserved bytes found.
        reserved: [u8; 3],
    },
    /// Row stride smaller than one row of pixels.
    #[error("step {step} is smaller than width {width} x {bytes_per_pixel} bytes per pixel")]
    StepTooSmall {
        /// Declared step.
        step: u32,
        /// Declared width.
        width: u32,
        /// Bytes per pixel of the declared encoding.
        bytes_per_pixel: u32,
    },
    /// Pixel block does not match `step * height`.
    #[error("pixel block is {actual} bytes but step x height = {expected} bytes")]
    SizeMismatch {
        /// `step * height`.
        expected: u64,
        /// Bytes present after the header.
        actual: u64,
    },
}

impl FrameHeader {
    /// Size of the encoded header in bytes.
    pub const SIZE: usize = 32;

    /// Header for tightly packed rows (`step = width * bytes_per_pixel`).
    pub const fn packed(sequence: u64, source_timestamp_ns: i64, width: u32, height: u32, encoding: Encoding) -> Self {
        Self { sequence, source_timestamp_ns, width, height, step: width.saturating_mul(encoding.bytes_per_pixel()), encoding }
    }

    /// Number of pixel bytes the header announces (`step * height`).
    pub const fn pixel_bytes(&self) -> u64 {
        self.step as u64 * self.height as u64
    }

    /// Checks the header against a pixel block of `pixel_len` bytes.
    pub fn validate(&self, pixel_len: usize) -> Result<(), MalformedFrame> {
        let bytes_per_pixel = self.encoding.bytes_per_pixel();
        if u64::from(self.step) < u64::from(self.width) * u64::from(bytes_per_pixel) {
            return Err(MalformedFrame::StepTooSmall { step: self.step, width: self.width, bytes_per_pixel });
        }
        let expected = self.pixel_bytes();
        let actual = pixel_len as u64;
        if expected != actual {
            return Err(MalformedFrame::SizeMismatch { expected, actual });
        }
        Ok(())
    }

    /// Encodes the header into its 32-byte wire form.
    pub fn encode(&self) -> [u8; Self::SIZE] {
        let mut out = [0u8; Self::SIZE];
        out[0..8].copy_from_slice(&self.sequence.to_le_bytes());
        out[8..16].copy_from_slice(&self.source_timestamp_ns.to_le_bytes());
        out[16..20].copy_from_slice(&self.width.to_le_bytes());
        out[20..24].copy_from_slice(&self.height.to_le_bytes());
        out[24..28].copy_from_slice(&self.step.to_le_bytes());
        out[28] = self.encoding.code();
        out
    }

    /// Parses a complete sample (header + pixels) and returns the header and the pixel block.
    /// Never panics; every inconsistency is a [`MalformedFrame`].
    pub fn parse(sample: &[u8]) -> Result<(Self, &[u8]), MalformedFrame> {
        let Some((head, pixels)) = sample.split_first_chunk::<{ Self::SIZE }>() else {
            return Err(MalformedFrame::TooShort { len: sample.len() });
        };
        let u64_at = |at: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&head[at..at + 8]);
            b
        };
        let u32_at = |at: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&head[at..at + 4]);
            u32::from_le_bytes(b)
        };
        let code = head[28];
        let encoding = Encoding::from_code(code).ok_or(MalformedFrame::BadEncoding { code })?;
        let reserved = [head[29], head[30], head[31]];
        if reserved != [0; 3] {
            return Err(MalformedFrame::ReservedNotZero { reserved });
        }
        let header = Self {
            sequence: u64::from_le_bytes(u64_at(0)),
            source_timestamp_ns: i64::from_le_bytes(u64_at(8)),
            width: u32_at(16),
            height: u32_at(20),
            step: u32_at(24),
            encoding,
        };
        header.validate(pixels.len())?;
        Ok((header, pixels))
    }
}

/// Errors of the frame transport. Every variant names the service it concerns.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// The service name is not a valid iceoryx2 service name.
    #[error("frame service \"{service}\": invalid service name: {source}")]
    InvalidServiceName {
        /// Service name as given.
        service: String,
        /// iceoryx2 reason.
        #[source]
        source: iceoryx2::service::service_name::ServiceNameError,
    },
    /// This user's iceoryx2 folder (see [`iceoryx2_folder`]) cannot be used.
    #[error("frame service \"{service}\": cannot use the iceoryx2 folder {}: {reason}", folder.display())]
    Folder {
        /// Service name.
        service: String,
        /// The folder.
        folder: PathBuf,
        /// Why, and what to do about it.
        reason: String,
    },
    /// Creating an iceoryx2 node, service or port failed.
    #[error(
        "frame service \"{service}\": cannot {what} (iceoryx2 folder {}{}): {source}",
        folder.display(),
        diagnosis.as_deref().map(|d| format!("; {d}")).unwrap_or_default()
    )]
    Setup {
        /// Service name.
        service: String,
        /// The step that failed, e.g. "open publish-subscribe service".
        what: &'static str,
        /// This user's iceoryx2 folder.
        folder: PathBuf,
        /// What is wrong with the folder, if anything is found.
        diagnosis: Option<String>,
        /// iceoryx2 reason.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The frame does not fit the publisher's fixed sample size.
    #[error(
        "frame service \"{service}\": frame of {frame_bytes} bytes ({} header + {pixel_bytes} pixel bytes) exceeds the maximum of {max_bytes} bytes",
        FrameHeader::SIZE
    )]
    FrameTooLarge {
        /// Service name.
        service: String,
        /// Header + pixels.
        frame_bytes: usize,
        /// Pixel bytes alone.
        pixel_bytes: usize,
        /// Configured maximum sample size.
        max_bytes: usize,
    },
    /// `publish` was called with a header that does not describe the pixel block.
    #[error("frame service \"{service}\": refusing to publish an inconsistent frame: {source}")]
    InvalidFrame {
        /// Service name.
        service: String,
        /// What is inconsistent.
        #[source]
        source: MalformedFrame,
    },
    /// A received sample is not a valid frame.
    #[error("frame service \"{service}\": received a malformed frame: {source}")]
    Malformed {
        /// Service name.
        service: String,
        /// What is wrong.
        #[source]
        source: MalformedFrame,
    },
    /// Loaning, sending, notifying, receiving or waiting failed at runtime.
    #[error("frame service \"{service}\": {what} failed: {source}")]
    Transport {
        /// Service name.
        service: String,
        /// The operation that failed, e.g. "loan sample".
        what: &'static str,
        /// iceoryx2 reason.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

fn setup_err<E: std::error::Error + Send + Sync + 'static>(service: &str, what: &'static str) -> impl FnOnce(E) -> FrameError {
    move |e| {
        let folder = user_instance().map(|u| u.folder.clone()).unwrap_or_default();
        let diagnosis = diagnose(&folder);
        FrameError::Setup { service: service.to_owned(), what, folder, diagnosis, source: Box::new(e) }
    }
}

fn transport_err<E: std::error::Error + Send + Sync + 'static>(service: &str, what: &'static str) -> impl FnOnce(E) -> FrameError {
    move |e| FrameError::Transport { service: service.to_owned(), what, source: Box::new(e) }
}

/// This user's iceoryx2 instance: its folder and its configuration.
struct UserInstance {
    uid: u32,
    folder: PathBuf,
    config: Config,
}

/// This user's iceoryx2 instance, worked out once per process.
fn user_instance() -> Result<&'static UserInstance, String> {
    static INSTANCE: OnceLock<Result<UserInstance, String>> = OnceLock::new();
    INSTANCE
        .get_or_init(|| {
            let uid = effective_uid()?;
            let folder = PathBuf::from(format!("/tmp/iceoryx2-{uid}"));
            let mut config = Config::default();
            let root = Path::new(format!("{}/", folder.display()).as_bytes()).map_err(|e| format!("not an iceoryx2 path: {e}"))?;
            config.global.set_root_path(&root);
            config.global.prefix =
                FileName::new(format!("iox2_{uid}_").as_bytes()).map_err(|e| format!("not an iceoryx2 file name: {e}"))?;
            Ok(UserInstance { uid, folder, config })
        })
        .as_ref()
        .map_err(Clone::clone)
}

/// The effective user id of this process: the user the iceoryx2 files are made for.
fn effective_uid() -> Result<u32, String> {
    // Linux: the second field of `Uid:` in /proc/self/status.
    if let Ok(status) = std::fs::read_to_string("/proc/self/status")
        && let Some(uid) = status.lines().find_map(|l| l.strip_prefix("Uid:")).and_then(|v| v.split_whitespace().nth(1)?.parse().ok())
    {
        return Ok(uid);
    }
    // Elsewhere: the owner of a file this process makes.
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or_default();
    let probe = std::env::temp_dir().join(format!(".avacraft-uid-{}-{nanos}", std::process::id()));
    let made = std::fs::File::create(&probe).and_then(|_| std::fs::metadata(&probe));
    let _ = std::fs::remove_file(&probe);
    made.map(|m| m.uid())
        .map_err(|e| format!("cannot tell which user this process runs as: no /proc/self/status, and {}: {e}", probe.display()))
}

/// The folder where this user's iceoryx2 instance keeps its files: `/tmp/iceoryx2-<uid>`, a
/// function of the user alone, so the publishers and subscribers of one user meet there.
pub fn iceoryx2_folder() -> Option<PathBuf> {
    user_instance().ok().map(|u| u.folder.clone())
}

/// This user's iceoryx2 configuration (folder and shared-memory prefix), with the folder made
/// and checked: for iceoryx2 nodes made outside this module that must meet its services
/// (`NodeBuilder::new().config(frames::iceoryx2_config()?)`).
pub fn iceoryx2_config() -> Result<&'static Config, FrameError> {
    prepare("*")
}

/// Makes this user's iceoryx2 folder (mode 0700) unless it is there, and checks that it is a
/// folder of this user's; returns the instance's configuration.
fn prepare(service: &str) -> Result<&'static Config, FrameError> {
    let instance = user_instance().map_err(|reason| FrameError::Folder {
        service: service.to_owned(),
        folder: PathBuf::from("/tmp/iceoryx2-<uid>"),
        reason,
    })?;
    let folder = &instance.folder;
    let refuse = |reason: String| FrameError::Folder { service: service.to_owned(), folder: folder.clone(), reason };
    match std::fs::DirBuilder::new().mode(0o700).create(folder) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(refuse(format!("cannot make it: {e}"))),
    }
    let meta = std::fs::symlink_metadata(folder).map_err(|e| refuse(format!("cannot read it: {e}")))?;
    if meta.file_type().is_symlink() || !meta.is_dir() {
        return Err(refuse("it is not a folder (a symbolic link or a file): remove it".to_owned()));
    }
    if meta.uid() != instance.uid {
        return Err(refuse(format!(
            "it belongs to uid {}, not to this user (uid {}): whoever made it can read this user's frames; remove it (as its owner or root)",
            meta.uid(),
            instance.uid
        )));
    }
    if meta.permissions().mode() & 0o077 != 0 {
        std::fs::set_permissions(folder, std::fs::Permissions::from_mode(0o700))
            .map_err(|e| refuse(format!("cannot make it private (chmod 700): {e}")))?;
    }
    Ok(&instance.config)
}

/// What is wrong with an iceoryx2 folder or its `nodes` and `services` folders, if anything
/// that would make iceoryx2 fail is found.
fn diagnose(folder: &StdPath) -> Option<String> {
    let uid = user_instance().ok()?.uid;
    for dir in [folder.to_path_buf(), folder.join("nodes"), folder.join("services")] {
        let meta = match std::fs::symlink_metadata(&dir) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Some(format!("{} cannot be read: {e}", dir.display())),
        };
        if !meta.is_dir() {
            return Some(format!("{} is not a folder", dir.display()));
        }
        if meta.uid() != uid {
            return Some(format!("{} belongs to uid {}, not to this user (uid {uid})", dir.display(), meta.uid()));
        }
        if meta.permissions().mode() & 0o700 != 0o700 {
            return Some(format!("{} has mode {:o}: its owner cannot use it", dir.display(), meta.permissions().mode() & 0o7777));
        }
    }
    None
}

/// Removes the resources of nodes whose processes died without cleaning up (best effort).
/// Returns the number of dead nodes that were cleaned.
pub fn cleanup_stale_resources() -> usize {
    let config = match prepare("(stale-resource cleanup)") {
        Ok(c) => c,
        Err(e) => {
            eprintln!("avacraft frames: {e}");
            return 0;
        }
    };
    cleanup_in(config)
}

fn cleanup_in(config: &Config) -> usize {
    let mut cleaned = 0;
    let listed = Node::<Ipc>::list(config, |state| {
        if let NodeState::Dead(view) = state {
            let id = *view.id();
            match view.try_remove_stale_resources() {
                Ok(()) => cleaned += 1,
                // another process or thread is removing it right now: nothing for us to do
                Err(NodeCleanupFailure::AnotherInstanceIsCleaningUpTheNode) => {}
                Err(e) => eprintln!("avacraft frames: could not remove stale resources of dead node {id:?}: {e}"),
            }
        }
        CallbackProgression::Continue
    });
    if let Err(e) = listed {
        eprintln!("avacraft frames: could not list iceoryx2 nodes for stale-resource cleanup: {e}");
    }
    cleaned
}

fn open_node(service: &str, role: &str) -> Result<Node<Ipc>, FrameError> {
    let config = prepare(service)?;
    cleanup_in(config);
    let mut builder = NodeBuilder::new().config(config).signal_handling_mode(SignalHandlingMode::Disabled);
    // A node name is informational only; skip it if the service name makes it invalid.
    if let Ok(name) = NodeName::new(&format!("avacraft-frames-{role}")) {
        builder = builder.name(&name);
    }
    builder.create::<Ipc>().map_err(setup_err(service, "create iceoryx2 node"))
}

fn service_names(service: &str) -> Result<(ServiceName, ServiceName), FrameError> {
    let invalid = |source| FrameError::InvalidServiceName { service: service.to_owned(), source };
    let data = ServiceName::new(service).map_err(invalid)?;
    let notify = ServiceName::new(&format!("{service}/notify")).map_err(invalid)?;
    Ok((data, notify))
}

type PubSubFactory = iceoryx2::service::port_factory::publish_subscribe::PortFactory<Ipc, [u8], ()>;
type EventFactory = iceoryx2::service::port_factory::event::PortFactory<Ipc>;

fn open_services(node: &Node<Ipc>, service: &str, max_subscribers: usize) -> Result<(PubSubFactory, EventFactory), FrameError> {
    let (data_name, notify_name) = service_names(service)?;
    let max_subscribers = max_subscribers.max(1);
    let pubsub = node
        .service_builder(&data_name)
        .publish_subscribe::<[u8]>()
        .history_size(HISTORY_SIZE)
        .subscriber_max_buffer_size(SUBSCRIBER_BUFFER_SIZE)
        .subscriber_max_borrowed_samples(SUBSCRIBER_MAX_BORROWED_SAMPLES)
        .enable_safe_overflow(true)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(max_subscribers)
        .open_or_create()
        .map_err(setup_err(service, "open publish-subscribe service"))?;
    let event = node
        .service_builder(&notify_name)
        .event()
        .max_notifiers(MAX_NOTIFIERS)
        .max_listeners(max_subscribers)
        .open_or_create()
        .map_err(setup_err(service, "open notify event service"))?;
    Ok((pubsub, event))
}

/// Publishes frames on a service; owns its iceoryx2 node.
pub struct FramePublisher {
    service: String,
    max_bytes: usize,
    // Field order = drop order: ports before their services and node.
    publisher: Publisher<Ipc, [u8], ()>,
    notifier: Notifier<Ipc>,
    _pubsub: PubSubFactory,
    _event: EventFactory,
    _node: Node<Ipc>,
}

impl fmt::Debug for FramePublisher {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FramePublisher").field("service", &self.service).field("max_bytes", &self.max_bytes).finish_non_exhaustive()
    }
}

impl FramePublisher {
    /// Opens (or creates) the frame service `service` and its `<service>/notify` event service.
    ///
    /// `max_bytes` is the largest sample (header + pixels) this publisher can send; the shared
    /// memory is sized statically for it, so samples are never lost to reallocation.
    /// `max_subscribers` is the subscriber limit of the service (all participants should use the
    /// same value; opening an existing service with a larger value fails).
    pub fn open(service: &str, max_bytes: usize, max_subscribers: usize) -> Result<Self, FrameError> {
        let node = open_node(service, "pub")?;
        let (pubsub, event) = open_services(&node, service, max_subscribers)?;
        let publisher = pubsub
            .publisher_builder()
            .initial_max_slice_len(max_bytes.max(FrameHeader::SIZE))
            .allocation_strategy(AllocationStrategy::Static)
            .create()
            .map_err(setup_err(service, "create publisher"))?;
        let notifier = event.notifier_builder().create().map_err(setup_err(service, "create notifier"))?;
        Ok(Self { service: service.to_owned(), max_bytes, publisher, notifier, _pubsub: pubsub, _event: event, _node: node })
    }

    /// Service name.
    pub fn service(&self) -> &str {
        &self.service
    }

    /// Largest sample (header + pixels) in bytes.
    pub fn max_bytes(&self) -> usize {
        self.max_bytes
    }

    /// Copies `header` and `pixels` into one shared-memory sample, sends it and wakes the
    /// subscribers. Returns an error (and sends nothing) if the frame is inconsistent with its
    /// header or larger than `max_bytes`.
    pub fn publish(&mut self, header: FrameHeader, pixels: &[u8]) -> Result<(), FrameError> {
        let service = self.service.as_str();
        header.validate(pixels.len()).map_err(|source| FrameError::InvalidFrame { service: service.to_owned(), source })?;
        let frame_bytes = FrameHeader::SIZE + pixels.len();
        if frame_bytes > self.max_bytes {
            return Err(FrameError::FrameTooLarge {
                service: service.to_owned(),
                frame_bytes,
                pixel_bytes: pixels.len(),
                max_bytes: self.max_bytes,
            });
        }
        let sample = self.publisher.loan_slice_uninit(frame_bytes).map_err(transport_err(service, "loan sample"))?;
        // `unsafe_code` is forbidden here, so the uninitialised slice is initialised through
        // iceoryx2's safe `write_from_fn` (a vectorised zero fill) before the real bytes are
        // copied in.
        let mut sample = sample.write_from_fn(|_| 0u8);
        let (head, body) = sample.payload_mut().split_at_mut(FrameHeader::SIZE);
        head.copy_from_slice(&header.encode());
        body.copy_from_slice(pixels);
        sample.send().map_err(transport_err(service, "send sample"))?;
        self.notifier.notify().map_err(transport_err(service, "notify subscribers"))?;
        Ok(())
    }
}

/// A received frame. The pixels are borrowed zero-copy from shared memory; the sample is
/// returned to the publisher when the `Frame` is dropped. At most [`MAX_HELD_FRAMES`] frames per
/// subscriber may be alive at once.
pub struct Frame {
    header: FrameHeader,
    sample: Sample<Ipc, [u8], ()>,
}

impl fmt::Debug for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Frame").field("header", &self.header).field("pixel_bytes", &self.pixels().len()).finish()
    }
}

impl Frame {
    /// Parsed header.
    pub fn header(&self) -> &FrameHeader {
        &self.header
    }

    /// Pixel rows (`step * height` bytes), borrowed from shared memory.
    pub fn pixels(&self) -> &[u8] {
        self.sample.payload().get(FrameHeader::SIZE..).unwrap_or_default()
    }

    /// Copies the pixels out and releases the shared-memory sample.
    pub fn into_pixels(self) -> Vec<u8> {
        self.pixels().to_vec()
    }
}

/// Receives frames from a service; owns its iceoryx2 node.
pub struct FrameSubscriber {
    service: String,
    subscriber: Subscriber<Ipc, [u8], ()>,
    listener: Listener<Ipc>,
    _pubsub: PubSubFactory,
    _event: EventFactory,
    _node: Node<Ipc>,
}

impl fmt::Debug for FrameSubscriber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FrameSubscriber").field("service", &self.service).finish_non_exhaustive()
    }
}

impl FrameSubscriber {
    /// Opens (or creates) the frame service `service` and its `<service>/notify` event service.
    /// `max_subscribers` must match the value the publisher uses (see [`FramePublisher::open`]).
    pub fn open(service: &str, max_subscribers: usize) -> Result<Self, FrameError> {
        let node = open_node(service, "sub")?;
        let (pubsub, event) = open_services(&node, service, max_subscribers)?;
        let subscriber =
            pubsub.subscriber_builder().buffer_size(SUBSCRIBER_BUFFER_SIZE).create().map_err(setup_err(service, "create subscriber"))?;
        let listener = event.listener_builder().create().map_err(setup_err(service, "create listener"))?;
        Ok(Self { service: service.to_owned(), subscriber, listener, _pubsub: pubsub, _event: event, _node: node })
    }

    /// Service name.
    pub fn service(&self) -> &str {
        &self.service
    }

    /// Waits up to `timeout` for a frame and returns the newest one; older queued frames are
    /// discarded. Sleeps on the notify event (no busy polling). `Ok(None)` on timeout.
    pub fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<Frame>, FrameError> {
        let deadline = Instant::now() + timeout;
        loop {
            // Drain the notification count first so that a notification arriving after the
            // drain below wakes the next wait.
            self.listener.try_wait(|_| {}).map_err(transport_err(&self.service, "wait for notification"))?;
            if let Some(frame) = self.try_recv()? {
                return Ok(Some(frame));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            self.listener.timed_wait(|_| {}, deadline - now).map_err(transport_err(&self.service, "wait for notification"))?;
        }
    }

    /// Returns the newest queued frame without waiting.
    pub fn try_recv(&mut self) -> Result<Option<Frame>, FrameError> {
        let mut newest = None;
        while let Some(sample) = self.subscriber.receive().map_err(transport_err(&self.service, "receive sample"))? {
            newest = Some(sample); // drops (releases) the previous, older sample
        }
        let Some(sample) = newest else {
            return Ok(None);
        };
        let (header, _) =
            FrameHeader::parse(sample.payload()).map_err(|source| FrameError::Malformed { service: self.service.clone(), source })?;
        Ok(Some(Frame { header, sample }))
    }
}
