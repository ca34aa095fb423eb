//! Publish-to-receive latency of the frame transport across two threads.
//!
//! `cargo run --release -p avacraft-nodes --example frame_latency`
//!
//! The publisher stamps each frame with the time just before `publish()` (which includes copying
//! the pixels into shared memory); the subscriber thread computes the latency when
//! `recv_timeout()` returns. Frames are sent lock-step (the publisher waits for the subscriber's
//! acknowledgement), so the numbers are unloaded latencies. The first `WARMUP` frames, which
//! page in the shared memory, are not counted.

use std::error::Error;
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use avacraft_nodes::frames::{Encoding, FrameHeader, FramePublisher, FrameSubscriber};

type AnyResult<T> = Result<T, Box<dyn Error + Send + Sync>>;

const WARMUP: usize = 20;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let idx = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[idx.min(sorted.len() - 1)]
}

fn summary(name: &str, mut samples_us: Vec<f64>) {
    samples_us.sort_by(f64::total_cmp);
    println!(
        "  {name:<26} p50 {:>8.1} us   p99 {:>8.1} us   max {:>8.1} us",
        percentile(&samples_us, 0.50),
        percentile(&samples_us, 0.99),
        samples_us.last().copied().unwrap_or(f64::NAN)
    );
}

fn run(width: u32, height: u32, frames: usize) -> AnyResult<()> {
    // A namespace of its own per run and size, so concurrent runs do not share a service.
    let topics = avacraft_nodes::Topics::new(&format!("/latency_{}_{width}x{height}", std::process::id()))?;
    let service = topics.frame_service(avacraft_nodes::TeamNo::new(1)?, avacraft_nodes::FrameKind::Screen);
    let pixel_bytes = width as usize * height as usize * 3;
    let base = Instant::now();
    let now_ns = move || base.elapsed().as_nanos() as i64;

    let (ready_tx, ready_rx) = mpsc::channel::<()>();
    let (ack_tx, ack_rx) = mpsc::channel::<()>();
    let total = frames + WARMUP;

    let sub_service = service.clone();
    let subscriber = thread::spawn(move || -> AnyResult<Vec<f64>> {
        let mut sub = FrameSubscriber::open(&sub_service, 2)?;
        ready_tx.send(())?;
        let mut latencies = Vec::with_capacity(total);
        for i in 0..total {
            let frame = sub.recv_timeout(Duration::from_secs(5))?.ok_or_else(|| format!("timeout at frame {i}"))?;
            let latency_ns = now_ns() - frame.header().source_timestamp_ns;
            if frame.header().sequence != i as u64 || frame.pixels().len() != pixel_bytes {
                return Err(format!("unexpected frame {:?}", frame.header()).into());
            }
            drop(frame);
            if i >= WARMUP {
                latencies.push(latency_ns as f64 / 1_000.0);
            }
            ack_tx.send(())?;
        }
        Ok(latencies)
    });

    ready_rx.recv_timeout(Duration::from_secs(5))?;
    let mut publisher = FramePublisher::open(&service, FrameHeader::SIZE + pixel_bytes, 2)?;
    let pixels: Vec<u8> = (0..pixel_bytes).map(|i| i as u8).collect();
    let mut publish_us = Vec::with_capacity(frames);
    for i in 0..total {
        let start = now_ns();
        publisher.publish(FrameHeader::packed(i as u64, start, width, height, Encoding::Rgb8), &pixels)?;
        if i >= WARMUP {
            publish_us.push((now_ns() - start) as f64 / 1_000.0);
        }
        ack_rx.recv_timeout(Duration::from_secs(5))?;
    }
    let latencies = subscriber.join().map_err(|_| "subscriber thread panicked")??;

    println!("{width}x{height} rgb8 ({} bytes), {frames} frames after {WARMUP} warm-up:", pixel_bytes + FrameHeader::SIZE);
    summary("publish() call", publish_us);
    summary("publish-to-receive", latencies);
    Ok(())
}

fn main() -> AnyResult<()> {
    run(160, 120, 500)?;
    run(1920, 1080, 50)?;
    Ok(())
}
