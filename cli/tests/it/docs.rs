//! Every `avacraft` command the README and the docs show parses with the program's own
//! command line: a renamed flag or verb fails here, not in a reader's terminal. The cheap
//! ones are also run.

use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The pages with commands: the README, docs/ and the crates' READMEs.
fn pages() -> Vec<PathBuf> {
    let mut v =
        vec![repo().join("README.md"), repo().join("python/README.md"), repo().join("launch/README.md"), repo().join("marl/README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .expect("docs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    v.extend(docs);
    v
}

/// The `avacraft` commands of a page's code blocks, as argument lists (program name first):
/// continuation lines joined, comments and environment assignments dropped, `cargo run ...
/// --` read as the program. Lines with an ellipsis are sketches, not commands.
fn commands(text: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut in_block = false;
    let mut line = String::new();
    for raw in text.lines() {
        if raw.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        if !in_block {
            continue;
        }
        let l = raw.split(" #").next().unwrap_or_default().trim_end();
        if let Some(head) = l.strip_suffix('\\') {
            line.push_str(head);
            line.push(' ');
            continue;
        }
        line.push_str(l);
        let full = std::mem::take(&mut line);
        if full.contains("...") || full.trim_start().starts_with('#') {
            continue;
        }
        let words: Vec<&str> = full.split_whitespace().skip_while(|w| w.contains('=') && !w.starts_with('-')).collect();
        let args: Vec<&str> = match words.as_slice() {
            ["avacraft", rest @ ..] => rest.to_vec(),
            ["cargo", "run", rest @ ..] => match rest.iter().position(|w| *w == "--") {
                Some(i) => rest[i + 1..].to_vec(),
                None => continue,
            },
            _ => continue,
        };
        let mut argv = vec!["avacraft".to_owned()];
        argv.extend(args.iter().filter(|w| !w.starts_with('$')).map(|w| w.trim_matches('"').to_owned()));
        out.push(argv);
    }
    out
}

#[test]
fn every_command_in_the_docs_parses() {
    let mut seen = 0;
    let mut bad = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap_or_else(|e| panic!("{}: {e}", page.display()));
        for argv in commands(&text) {
            seen += 1;
            if let Err(e) = <avacraft_cli::Cli as clap::Parser>::try_parse_from(&argv) {
                bad.push(format!(
                    "{}: `{}`: {}",
                    page.display(),
                    argv[1..].join(" "),
                    e.render().to_string().lines().next().unwrap_or_default()
                ));
            }
        }
    }
    assert!(seen >= 20, "only {seen} commands found in the docs: is the extraction broken?");
    assert!(bad.is_empty(), "commands in the docs that the program refuses:\n{}", bad.join("\n"));
}

#[test]
fn the_extraction_reads_what_a_reader_would_type() {
    let page = "text `avacraft x`\n```bash\n# a comment\nFOO=1 cargo run --release -p avacraft-cli -- episode --scenario 3m_vlm \\\n    --episodes 2   # two\navacraft eval merge --out a b ...\navacraft scenarios\n```\n";
    assert_eq!(commands(page), vec![vec!["avacraft", "episode", "--scenario", "3m_vlm", "--episodes", "2"], vec!["avacraft", "scenarios"]]);
    // And a refused one is refused.
    assert!(<avacraft_cli::Cli as clap::Parser>::try_parse_from(["avacraft", "episode", "--no-such-flag"]).is_err());
}

/// The cheap commands are run as shown.
#[test]
fn the_cheap_commands_run() {
    for argv in [vec!["avacraft", "scenarios"], vec!["avacraft", "env-info", "--scenario", "3m_vlm"]] {
        let mut out = Vec::new();
        avacraft_cli::run_args(&argv, &mut out).unwrap_or_else(|e| panic!("{argv:?}: {e:#}"));
        assert!(!out.is_empty(), "{argv:?} printed nothing");
    }
}
