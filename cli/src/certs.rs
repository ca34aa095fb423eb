//! `avacraft certs`: a secured launch file's authority and one key pair per host.

use anyhow::{Context, Result};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct CertsArgs {
    /// The launch file whose `security.certs` directory and hosts to use.
    pub file: PathBuf,
}

pub fn certs(a: &CertsArgs, out: &mut dyn Write) -> Result<()> {
    // Certificates need the hosts, not the policies' weights.
    let plan = avacraft_launch::load_with(&a.file, avacraft_policy::Weights::Later)?;
    let files = avacraft_launch::write_certs(&plan).with_context(|| format!("certs: {}", plan.file))?;
    writeln!(out, "{}: an authority and a key pair for each of the hosts {:?}", plan.file, plan.hosts)?;
    for f in &files {
        writeln!(out, "  {}", f.display())?;
    }
    writeln!(
        out,
        "Copy ca.pem and each host's .pem and .key to that host. The authority's own key is not kept: run this again to re-issue every pair."
    )?;
    Ok(())
}
