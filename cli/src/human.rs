//! `avacraft human-eval`: the paper's human evaluation. `pack` makes a blinded study of
//! replays from an evaluation folder, `serve` runs the local rating page, `analyze` un-blinds
//! the ratings and compares the agent kinds.

use anyhow::{Context, Result};
use avacraft_eval::human::{self, PackOptions, Server};
use clap::{Args, Subcommand};
use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct HumanArgs {
    #[command(subcommand)]
    cmd: HumanCmd,
}

#[derive(Subcommand, Debug)]
enum HumanCmd {
    /// Choose finished episodes of two or more agent kinds from an evaluation folder, blind
    /// them (random order, anonymous ids; the key in STUDY/key.json) and draw their replays.
    Pack {
        /// The evaluation plan the folder was played from.
        #[arg(long)]
        plan: PathBuf,
        /// The evaluation folder (`avacraft eval PLAN --out DIR`).
        #[arg(long)]
        eval: PathBuf,
        /// The new study folder (must not exist or be empty).
        #[arg(long)]
        out: PathBuf,
        /// Episodes per agent kind.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
        per_kind: u32,
        /// Seeds the choice, the order and the ids.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Frame size WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360")]
        size: String,
    },
    /// Serve the rating page of a study (local; no internet needed). Ratings go into
    /// STUDY/ratings.db.
    Serve {
        #[arg(long)]
        study: PathBuf,
        /// Address to listen on (loopback by default: raters on this machine only).
        #[arg(long, default_value_t = IpAddr::V4(Ipv4Addr::LOCALHOST))]
        addr: IpAddr,
        /// Port (0: a free one; the URL is printed).
        #[arg(long, default_value_t = 8737)]
        port: u16,
        /// A host name raters reach this machine by (repeatable). IP addresses and
        /// `localhost` always work; other names in a request's Host header are refused, so a
        /// web page elsewhere cannot reach the server through DNS rebinding.
        #[arg(long = "allow-host", value_name = "NAME")]
        allow_hosts: Vec<String>,
    },
    /// Un-blind the ratings and compare the kinds per metric (Mann-Whitney U); writes
    /// STUDY/analysis.md and STUDY/analysis.png.
    Analyze {
        #[arg(long)]
        study: PathBuf,
    },
}

pub fn run(a: &HumanArgs, out: &mut dyn Write) -> Result<()> {
    match &a.cmd {
        HumanCmd::Pack { plan, eval, out: dir, per_kind, seed, size } => {
            let (width, height) = crate::render::parse_size(size)?;
            let plan = avacraft_eval::load(plan)?;
            let opts = PackOptions { eval: eval.clone(), out: dir.clone(), per_kind: *per_kind as usize, seed: *seed, width, height };
            let s = human::pack(&plan, &opts, &mut |i, n| {
                if i < n {
                    tracing::info!("drawing replay {} of {n}", i + 1);
                }
            })
            .with_context(|| format!("human-eval pack into {}", dir.display()))?;
            let kinds = s.per_kind.iter().map(|(k, n)| format!("{n} {}", k.name())).collect::<Vec<_>>().join(", ");
            writeln!(
                out,
                "{}: {} replays ({kinds}), {} frames, {:.1} MB; the key is {} (keep it from the raters)",
                dir.display(),
                s.replays,
                s.frames,
                s.bytes as f64 / 1e6,
                dir.join(human::KEY_FILE).display()
            )?;
            Ok(())
        }
        HumanCmd::Serve { study, addr, port, allow_hosts } => {
            let server = Server::start(study, SocketAddr::new(*addr, *port), allow_hosts)
                .with_context(|| format!("human-eval serve {}", study.display()))?;
            if !addr.is_loopback() {
                writeln!(out, "warning: listening on {addr}: anyone who can reach this machine can rate")?;
            }
            writeln!(out, "serving {} at {} (Ctrl-C stops; every submitted rating is on disk)", study.display(), server.url())?;
            out.flush()?;
            server.wait().context("human-eval serve")
        }
        HumanCmd::Analyze { study } => {
            let (analysis, files) = human::analyze(study).with_context(|| format!("human-eval analyze {}", study.display()))?;
            writeln!(out, "{}", analysis.markdown())?;
            if analysis.comparisons.is_empty() {
                writeln!(out, "note: fewer than two agent kinds have ratings yet, so nothing is compared")?;
            }
            for f in files {
                writeln!(out, "wrote {}", f.display())?;
            }
            Ok(())
        }
    }
}
