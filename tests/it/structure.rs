//! No import circle between the files of a crate, and no function outside tests over 120
//! lines (the last tests). A file that names another module's items (`crate::a::b`,
//! `super::x`, `use crate::{a, b}`) depends on that module's file; two files that depend on
//! each other, directly or through others, can only be read and changed
//! together, which the structure issue asked to end (world <-> sim <-> combat and six more
//! were found by review). This reads every crate's sources, so a new circle fails here,
//! naming its files, instead of waiting for the next review.
//!
//! It reads paths, not Rust's name resolution: re-exports through `lib.rs` (`crate::Config`)
//! count as depending on the crate root, which every module may do, and test modules
//! (`#[cfg(test)]` to the end of a file) and comments are left out.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module's path inside its crate: `["obs", "smac"]`; the root is empty.
type Module = Vec<String>;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The crates: folders with a `Cargo.toml` and a `src/`, outside build output.
fn crates() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for e in entries.filter_map(Result::ok) {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if !p.is_dir() || name.starts_with('.') || ["target", "node_modules", "runs", "baselines"].contains(&name.as_str()) {
                continue;
            }
            if p.join("Cargo.toml").is_file() && p.join("src").is_dir() {
                out.push(p.clone());
            }
            walk(&p, out);
        }
    }
    let mut out = Vec::new();
    walk(&repo(), &mut out);
    out.sort();
    out
}

fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).expect("a file under src/").with_extension("");
    let mut m: Module = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if m.last().is_some_and(|l| ["lib", "main", "mod"].contains(&l.as_str())) {
        m.pop();
    }
    m
}

/// The code of a file without its test module and comments.
fn code(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        if line.trim() == "#[cfg(test)]" {
            break;
        }
        out.push_str(line.split("//").next().unwrap_or_default());
        out.push('\n');
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The module paths a file's code names: `(base, segments)` for each `crate::`, `super::`
/// and `self::` path, and for each item of a braced `use crate::{..}` / `use super::{..}`.
fn named_paths(code: &str, here: &Module) -> Vec<Module> {
    let mut out = Vec::new();
    for (kw, base) in [("crate::", Vec::new()), ("super::", here[..here.len().saturating_sub(1)].to_vec()), ("self::", here.clone())] {
        let mut from = 0;
        while let Some(i) = code[from..].find(kw).map(|i| i + from) {
            from = i + kw.len();
            // Inside a longer path (`super::super::`, `a::self::`): read from its start.
            if code[..i].chars().next_back().is_some_and(is_ident) || code[..i].ends_with("::") {
                continue;
            }
            let rest = &code[from..];
            if let Some(inner) = rest.strip_prefix('{') {
                // One level of braces: `crate::{a, b::c}` names a and b.
                let end = inner.find('}').unwrap_or(inner.len());
                for item in inner[..end].split(',') {
                    let segs: Vec<String> =
                        item.trim().split(" as ").next().unwrap_or_default().split("::").map(|s| s.trim().to_owned()).collect();
                    if segs.first().is_some_and(|s| !s.is_empty() && s.chars().all(is_ident)) {
                        out.push(base.iter().cloned().chain(segs.into_iter().take_while(|s| s.chars().all(is_ident))).collect());
                    }
                }
                continue;
            }
            let path: String = rest.chars().take_while(|&c| is_ident(c) || c == ':').collect();
            let mut at = base.clone();
            let mut segs = path.split("::").filter(|s| !s.is_empty()).peekable();
            while segs.next_if_eq(&"super").is_some() {
                at.pop();
            }
            out.push(at.into_iter().chain(segs.map(str::to_owned)).collect());
        }
    }
    out
}

/// The crate's modules and, for each, the modules its file depends on.
fn graph(krate: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let src = krate.join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeMap<Module, PathBuf> = files.iter().map(|f| (module_of(&src, f), f.clone())).collect();
    let resolve =
        |path: &Module| -> Option<Module> { (1..=path.len()).rev().map(|n| path[..n].to_vec()).find(|p| modules.contains_key(p)) };
    let mut g = BTreeMap::new();
    for (m, file) in &modules {
        let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let deps: BTreeSet<Module> = named_paths(&code(&text), m).iter().filter_map(resolve).filter(|t| t != m).collect();
        g.insert(m.clone(), deps);
    }
    g
}

/// The strongly connected components of more than one module (Tarjan's algorithm).
fn circles(g: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'a> {
        g: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on: BTreeSet<&'a Module>,
        out: Vec<Vec<Module>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Module) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on.insert(v);
        for w in s.g.get(v).into_iter().flatten() {
            let Some((w, _)) = s.g.get_key_value(w) else { continue };
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                s.low.entry(v).and_modify(|l| *l = (*l).min(lw));
            } else if s.on.contains(w) {
                let iw = s.index[w];
                s.low.entry(v).and_modify(|l| *l = (*l).min(iw));
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.push(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State { g, index: BTreeMap::new(), low: BTreeMap::new(), stack: Vec::new(), on: BTreeSet::new(), out: Vec::new() };
    for v in g.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

fn name(m: &Module) -> String {
    if m.is_empty() { "lib".to_owned() } else { m.join("/") }
}

#[test]
fn no_crate_has_an_import_circle_between_its_files() {
    let crates = crates();
    assert!(crates.len() >= 15, "found only {} crates under {}", crates.len(), repo().display());
    let mut found = Vec::new();
    for krate in &crates {
        for c in circles(&graph(krate)) {
            let names: Vec<String> = c.iter().map(name).collect();
            found.push(format!("{}: {}", krate.strip_prefix(repo()).unwrap_or(krate).display(), names.join(" <-> ")));
        }
    }
    assert!(found.is_empty(), "import circles between files:\n{}", found.join("\n"));
}

/// The reader finds a circle where there is one: two files naming each other's items,
/// through a plain path and through a braced `use`.
#[test]
fn the_reader_finds_a_planted_circle() {
    let dir = std::env::temp_dir().join(format!("avacraft-circle-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("obs")).expect("temp dir");
    std::fs::write(src.join("lib.rs"), "mod world;\nmod obs;\n").expect("write");
    std::fs::write(src.join("world.rs"), "// crate::obs::smac in a comment does not count\nuse crate::{obs::smac::Feats, geom};\n")
        .expect("write");
    std::fs::write(src.join("obs/mod.rs"), "pub mod smac;\n").expect("write");
    std::fs::write(src.join("obs/smac.rs"), "fn f() -> super::super::world::World { todo!() }\n").expect("write");
    let g = graph(&dir);
    let c = circles(&g);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(c, vec![vec![vec!["obs".to_owned(), "smac".to_owned()], vec!["world".to_owned()]]], "graph: {g:?}");
}

/// Every crate's source files (under `src/`), named from the repository's root, with their text.
fn sources() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for krate in crates() {
        let mut files = Vec::new();
        rust_files(&krate.join("src"), &mut files);
        for f in files {
            let text = std::fs::read_to_string(&f).expect("a source file");
            out.push((f.strip_prefix(repo()).unwrap_or(&f).display().to_string(), text));
        }
    }
    out
}

/// Longest a function outside tests may be: past it, a function does several things that read
/// better as functions of their own (the structure issue's mark).
const MAX_FN_LINES: usize = 120;

/// `text` without its test module, comments, and string and char literals (so their braces do
/// not count), lines kept.
fn without_literals(text: &str) -> String {
    let text: String = text.lines().take_while(|l| l.trim() != "#[cfg(test)]").flat_map(|l| [l, "\n"]).collect();
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
            continue;
        }
        if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            let rest: String = c[i..].iter().collect();
            let end = rest.find("*/").map_or(c.len(), |k| i + rest[..k].chars().count() + 2);
            out.extend(c[i..end].iter().filter(|&&ch| ch == '\n'));
            i = end;
            continue;
        }
        // Raw strings: r"..", r#".."#, br#".."#.
        if c[i] == 'r' && (i == 0 || !is_ident(c[i - 1]) || c[i - 1] == 'b') {
            let mut j = i + 1;
            while j < c.len() && c[j] == '#' {
                j += 1;
            }
            if j < c.len() && c[j] == '"' {
                let hashes = j - i - 1;
                let close: String = std::iter::once('"').chain(std::iter::repeat_n('#', hashes)).collect();
                let rest: String = c[j + 1..].iter().collect();
                let end = rest.find(&close).map_or(c.len(), |k| j + 1 + rest[..k].chars().count() + close.len());
                out.extend(c[i..end].iter().filter(|&&ch| ch == '\n'));
                i = end;
                continue;
            }
        }
        if c[i] == '"' {
            let mut j = i + 1;
            while j < c.len() && c[j] != '"' {
                j += if c[j] == '\\' { 2 } else { 1 };
            }
            out.extend(c[i..(j + 1).min(c.len())].iter().filter(|&&ch| ch == '\n'));
            i = j + 1;
            continue;
        }
        // Char literals ('{', '\''), not lifetimes ('a).
        if c[i] == '\'' {
            let end = if c.get(i + 1) == Some(&'\\') {
                c[i + 2..].iter().position(|&ch| ch == '\'').map(|k| i + 3 + k)
            } else {
                (c.get(i + 2) == Some(&'\'')).then_some(i + 3)
            };
            if let Some(end) = end {
                i = end;
                continue;
            }
        }
        out.push(c[i]);
        i += 1;
    }
    out
}

/// Functions longer than `max` lines in `text`: (line, name, lines).
fn long_functions(text: &str, max: usize) -> Vec<(usize, String, usize)> {
    let code = without_literals(text);
    let lines: Vec<&str> = code.lines().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let words: Vec<&str> = lines[i].split(|ch: char| !is_ident(ch)).filter(|w| !w.is_empty()).collect();
        let Some(at) = words.iter().position(|w| *w == "fn") else {
            i += 1;
            continue;
        };
        let name = words.get(at + 1).map_or(String::new(), |w| (*w).to_owned());
        // The body: from the first `{` after the signature to its matching `}`; a `;` first
        // means a declaration without one.
        let (mut depth, mut opened, mut j) = (0i64, false, i);
        'scan: while j < lines.len() {
            for ch in lines[j].chars() {
                match ch {
                    ';' if !opened => break 'scan,
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
                if opened && depth == 0 {
                    break 'scan;
                }
            }
            j += 1;
        }
        let n = j.min(lines.len() - 1) - i + 1;
        if opened && n > max {
            found.push((i + 1, name, n));
        }
        i = if opened { j + 1 } else { i + 1 };
    }
    found
}

#[test]
fn no_function_outside_tests_is_over_120_lines() {
    let mut found = Vec::new();
    for (f, text) in sources() {
        for (line, name, n) in long_functions(&text, MAX_FN_LINES) {
            found.push(format!("{f}:{line} {name}: {n} lines"));
        }
    }
    assert!(found.is_empty(), "functions over {MAX_FN_LINES} lines:\n{}", found.join("\n"));
}

/// The length check counts a function's lines and is not fooled by braces in strings (a `//`
/// in one too), char literals, comments or a test module.
#[test]
fn the_length_check_finds_a_planted_long_function() {
    let body =
        |n: usize| (0..n).map(|k| format!("    let _x{k} = \"{{\"; let _u = \"http://{{}}\"; let _c = '{{'; // }}\n")).collect::<String>();
    let text = format!(
        "fn short() {{\n{}}}\nfn long<'a>(x: &'a str) {{\n{}}}\n#[cfg(test)]\nmod tests {{\nfn huge() {{\n{}}}\n}}\n",
        body(10),
        body(130),
        body(300)
    );
    assert_eq!(long_functions(&text, 120), vec![(13, "long".to_owned(), 132)]);
}

/// Topic names are built and parsed in one typed module (nodes/src/topics.rs); a name spelt
/// out elsewhere (`"/avacraft/..."` outside a test module) would drift from it unseen.
#[test]
fn no_raw_topic_string_outside_the_topic_module() {
    let mut found = Vec::new();
    for (f, text) in sources().into_iter().filter(|(f, _)| !f.ends_with("nodes/src/topics.rs")) {
        for (i, line) in code(&text).lines().enumerate() {
            if line.contains("\"/avacraft/") {
                found.push(format!("{f}:{}: {}", i + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "topic names spelt out of the topic module:\n{}", found.join("\n"));
}
