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

/// The code of a file without its test module and comments. A test module in a file of its
/// own (`#[cfg(test)]` over `mod tests;`) leaves the lines after it in (see [`test_files`]).
fn code(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]" {
            if lines.peek().and_then(|l| test_file_decl(l)).is_some() {
                lines.next();
                continue;
            }
            break;
        }
        out.push_str(line.split("//").next().unwrap_or_default());
        out.push('\n');
    }
    out
}

/// `tests` from `mod tests;`: a module declared in a file of its own.
fn test_file_decl(line: &str) -> Option<&str> {
    let name = line.trim().strip_prefix("mod ")?.strip_suffix(';')?;
    name.chars().all(is_ident).then_some(name)
}

/// The modules of a crate that are test modules in files of their own.
fn test_files(src: &Path, files: &[PathBuf]) -> BTreeSet<Module> {
    let mut out = BTreeSet::new();
    for f in files {
        let m = module_of(src, f);
        let text = std::fs::read_to_string(f).unwrap_or_default();
        let mut lines = text.lines().peekable();
        while let Some(line) = lines.next() {
            if line.trim() == "#[cfg(test)]"
                && let Some(name) = lines.peek().and_then(|l| test_file_decl(l))
            {
                out.insert(m.iter().cloned().chain([name.to_owned()]).collect());
            }
        }
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
    let tests = test_files(&src, &files);
    let modules: BTreeMap<Module, PathBuf> =
        files.iter().map(|f| (module_of(&src, f), f.clone())).filter(|(m, _)| !tests.contains(m)).collect();
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

/// The layers a crate's `lib.rs` doc names, bottom first: lines such as
/// ``//! 3. rules: `action`, `rules`, `combat` ``.
fn layers(krate: &Path) -> Vec<(String, Vec<String>)> {
    let lib = std::fs::read_to_string(krate.join("src/lib.rs")).expect("lib.rs");
    lib.lines()
        .filter_map(|l| {
            let (num, rest) = l.strip_prefix("//! ")?.split_once(". ")?;
            num.parse::<usize>().ok()?;
            let (name, mods) = rest.split_once(": ")?;
            let mods: Vec<String> = mods.split('`').skip(1).step_by(2).map(str::to_owned).collect();
            (!mods.is_empty() && mods.iter().all(|m| m.chars().all(is_ident))).then(|| (name.to_owned(), mods))
        })
        .collect()
}

/// What `lib.rs` re-exports at the crate root, by name: `pub use m::{A, b::C as D};` maps A, C
/// and D to `m`.
fn root_exports(lib_code: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut rest = lib_code;
    while let Some(i) = rest.find("pub use ") {
        rest = &rest[i + "pub use ".len()..];
        let end = rest.find(';').unwrap_or(rest.len());
        let (stmt, after) = rest.split_at(end);
        rest = after;
        let Some((m, items)) = stmt.split_once("::") else { continue };
        for item in items.split([',', '{', '}']) {
            for name in item.split(" as ") {
                let name = name.trim().rsplit("::").next().unwrap_or_default();
                if !name.is_empty() && name.chars().all(is_ident) {
                    out.insert(name.to_owned(), m.trim().to_owned());
                }
            }
        }
    }
    out
}

/// Each file's uses of the crate's top-level modules: (the file's module, the top-level module
/// a path of it names). A root re-export (`crate::Env`) counts as the module it comes from; an
/// item `lib.rs` defines itself counts as `lib`, above every layer.
fn top_uses(krate: &Path) -> Vec<(Module, String)> {
    let src = krate.join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let tops: BTreeSet<String> = files.iter().filter_map(|f| module_of(&src, f).first().cloned()).collect();
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap_or_default();
    let exports = root_exports(&code(&lib));
    let tests = test_files(&src, &files);
    let mut out = Vec::new();
    for f in &files {
        let m = module_of(&src, f);
        let Some(own) = m.first().filter(|_| !tests.contains(&m)) else { continue };
        let text = std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        for p in named_paths(&code(&text), &m) {
            let Some(first) = p.first() else { continue };
            let top = if tops.contains(first) { first.clone() } else { exports.get(first).cloned().unwrap_or_else(|| "lib".to_owned()) };
            if &top != own {
                out.push((m.clone(), top));
            }
        }
    }
    out
}

/// Where a crate's files break its layers: a use of a higher layer, of an item `lib.rs`
/// defines, or a module no layer names.
fn layer_breaks(krate: &Path) -> Vec<String> {
    let layers = layers(krate);
    let level: BTreeMap<&str, usize> = layers.iter().enumerate().flat_map(|(i, (_, ms))| ms.iter().map(move |m| (m.as_str(), i))).collect();
    let name_of = |i: usize| format!("{}. {}", i + 1, layers[i].0);
    let mut out = BTreeSet::new();
    if layers.is_empty() {
        out.insert("lib.rs names no layers".to_owned());
    }
    for (m, top) in top_uses(krate) {
        let Some(&own) = level.get(m[0].as_str()) else {
            out.insert(format!("module `{}` is in no layer", m[0]));
            continue;
        };
        match level.get(top.as_str()) {
            _ if top == "lib" => out.insert(format!("{} names an item lib.rs defines", name(&m))),
            None => out.insert(format!("module `{top}` (used by {}) is in no layer", name(&m))),
            Some(&l) if l > own => out.insert(format!("{} (layer {}) uses `{top}` (layer {})", name(&m), name_of(own), name_of(l))),
            Some(_) => false,
        };
    }
    out.into_iter().collect()
}

/// A crate's top-level modules and the ones each uses, with one file per use (the evidence).
fn module_graph(krate: &Path) -> BTreeMap<Module, BTreeMap<Module, Module>> {
    let mut g: BTreeMap<Module, BTreeMap<Module, Module>> = BTreeMap::new();
    for (m, top) in top_uses(krate) {
        g.entry(vec![top.clone()]).or_default();
        g.entry(vec![m[0].clone()]).or_default().entry(vec![top]).or_insert(m);
    }
    g
}

/// A path around a circle of modules, naming the file behind each step:
/// `env (env/step) -> agent (agent/runner) -> env`.
fn circle_path(g: &BTreeMap<Module, BTreeMap<Module, Module>>, members: &[Module]) -> String {
    let start = &members[0];
    // Breadth-first inside the circle's modules, back to the start.
    let mut came: BTreeMap<&Module, &Module> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start]);
    'search: while let Some(v) = queue.pop_front() {
        for w in g[v].keys().filter(|w| members.contains(w)) {
            if w == start {
                came.insert(start, v);
                break 'search;
            }
            if !came.contains_key(w) {
                came.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    let mut path = vec![start];
    let mut at = came[start];
    while at != start {
        path.push(at);
        at = came[at];
    }
    path.push(start);
    path.reverse();
    let steps: Vec<String> = path.windows(2).map(|s| format!("{} ({})", name(s[0]), name(&g[s[0]][s[1]]))).collect();
    format!("{} -> {}", steps.join(" -> "), name(start))
}

fn module_circles(krate: &Path) -> Vec<String> {
    let g = module_graph(krate);
    let plain: BTreeMap<Module, BTreeSet<Module>> = g.iter().map(|(k, v)| (k.clone(), v.keys().cloned().collect())).collect();
    circles(&plain).iter().map(|c| circle_path(&g, c)).collect()
}

/// Inside the engine and marl, every file uses only modules of its own layer or lower, as
/// their lib.rs docs name the layers.
#[test]
fn engine_and_marl_files_use_only_their_own_layer_or_lower() {
    for krate in ["engine", "marl"] {
        let breaks = layer_breaks(&repo().join(krate));
        assert!(breaks.is_empty(), "{krate}/src breaks its layers:\n{}", breaks.join("\n"));
    }
}

/// No two top-level modules of any crate use each other, directly or around a circle.
#[test]
fn no_crate_has_an_import_circle_between_its_modules() {
    let mut found = Vec::new();
    for krate in crates() {
        for c in module_circles(&krate) {
            found.push(format!("{}: {c}", krate.strip_prefix(repo()).unwrap_or(&krate).display()));
        }
    }
    assert!(found.is_empty(), "import circles between modules:\n{}", found.join("\n"));
}

/// The module checks find what they look for: a circle between two modules whose files do
/// not form one (named with its files), an upward use, a use of an item lib.rs defines, and
/// a module in no layer.
#[test]
fn the_module_checks_find_planted_breaks() {
    let dir = std::env::temp_dir().join(format!("avacraft-layers-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("obs")).expect("temp dir");
    let lib = "//! 1. state: `world`\n//! 2. observations: `obs`\nmod world;\nmod obs;\nmod extra;\npub use obs::units::Info;\npub struct Error;\n";
    std::fs::write(src.join("lib.rs"), lib).expect("write");
    std::fs::write(src.join("world.rs"), "use crate::Info;\nfn f() -> crate::Error { todo!() }\n").expect("write");
    std::fs::write(src.join("obs/mod.rs"), "pub mod smac;\npub mod units;\n").expect("write");
    std::fs::write(src.join("obs/smac.rs"), "fn f() -> crate::world::World { todo!() }\n").expect("write");
    std::fs::write(src.join("obs/units.rs"), "pub struct Info;\n").expect("write");
    std::fs::write(src.join("extra.rs"), "use crate::world;\n").expect("write");
    let (files, modules, breaks) = (circles(&graph(&dir)), module_circles(&dir), layer_breaks(&dir));
    std::fs::remove_dir_all(&dir).ok();
    assert!(files.is_empty(), "no file circle: {files:?}");
    assert_eq!(modules, vec!["obs (obs/smac) -> world (world) -> obs".to_owned()]);
    assert_eq!(
        breaks,
        vec![
            "module `extra` is in no layer".to_owned(),
            "world (layer 1. state) uses `obs` (layer 2. observations)".to_owned(),
            "world names an item lib.rs defines".to_owned(),
        ]
    );
}
