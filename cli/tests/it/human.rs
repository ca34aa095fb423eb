//! `avacraft human-eval`, end to end in a real browser: an evaluation of three agent kinds is
//! packed into a blinded study, the rating server runs, and headless Chromium (Debian's
//! `chromium`, driven over the DevTools protocol) signs in two raters, plays, pauses and
//! scrubs a replay, rates every replay (one rater stops half-way and comes back), and the
//! ratings are then found in the SQLite database and analyzed.

use crate::common::tmp;
use avacraft_eval::human::Server;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

/// Headless Chromium with its DevTools endpoint; killed when dropped.
struct Browser {
    child: Child,
    ws: WebSocket<MaybeTlsStream<TcpStream>>,
    next_id: u64,
    session: String,
}

fn chromium() -> PathBuf {
    let candidates = ["/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"];
    std::env::var_os("AVACRAFT_CHROMIUM")
        .map(PathBuf::from)
        .or_else(|| candidates.iter().map(PathBuf::from).find(|p| p.is_file()))
        .filter(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "this test drives the rating page in headless Chromium, which is not installed: \
                 install Debian's `chromium` (`sudo apt-get install chromium`; .ci/run does) or name \
                 the browser in AVACRAFT_CHROMIUM"
            )
        })
}

impl Browser {
    fn launch(profile: &Path) -> Browser {
        let mut child = Command::new(chromium())
            .args([
                "--headless",
                // Root (as in CI containers) cannot run Chromium's sandbox; the browser only
                // visits this test's own loopback server.
                "--no-sandbox",
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--no-first-run",
                "--no-default-browser-check",
                "--remote-debugging-port=0",
                "--window-size=1280,1000",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg("about:blank")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start chromium");
        // Chromium prints its DevTools address on stderr.
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(url) = line.strip_prefix("DevTools listening on ") {
                    let _ = tx.send(url.trim().to_owned());
                }
            }
        });
        let url = match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(u) => u,
            Err(_) => {
                let _ = child.kill();
                panic!("chromium did not open its DevTools endpoint within 60 s");
            }
        };
        let (ws, _) = tungstenite::connect(url.as_str()).expect("connect to DevTools");
        if let MaybeTlsStream::Plain(s) = ws.get_ref() {
            s.set_read_timeout(Some(Duration::from_secs(60))).expect("timeout");
        }
        let mut b = Browser { child, ws, next_id: 0, session: String::new() };
        let target = b.call("Target.createTarget", json!({ "url": "about:blank" }));
        let target = target["targetId"].as_str().expect("targetId").to_owned();
        let attached = b.call("Target.attachToTarget", json!({ "targetId": target, "flatten": true }));
        b.session = attached["sessionId"].as_str().expect("sessionId").to_owned();
        b
    }

    /// One DevTools command (on the page's session once attached); its result.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        self.ws.send(Message::text(msg.to_string())).expect("send to DevTools");
        loop {
            let m = self.ws.read().expect("read from DevTools");
            let Message::Text(t) = m else { continue };
            let v: Value = serde_json::from_str(t.as_str()).expect("DevTools JSON");
            if v["id"] == json!(id) {
                assert!(v.get("error").is_none(), "{method}: {}", v["error"]);
                return v["result"].clone();
            }
        }
    }

    /// Evaluates JavaScript in the page (awaiting a promise); its value.
    fn eval(&mut self, js: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({ "expression": js, "awaitPromise": true, "returnByValue": true }));
        assert!(r.get("exceptionDetails").is_none(), "{js}: {}", r["exceptionDetails"]);
        r["result"]["value"].clone()
    }

    /// Waits (at most 30 s) until `js` is true in the page.
    fn wait(&mut self, what: &str, js: &str) {
        let start = Instant::now();
        while self.eval(&format!("!!({js})")) != json!(true) {
            assert!(start.elapsed() < Duration::from_secs(30), "timed out waiting for {what} ({js})");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn open(&mut self, url: &str) {
        self.call("Page.navigate", json!({ "url": url }));
        self.wait("the page to load", "document.readyState === 'complete' && document.body.dataset.state === 'login'");
    }

    fn state(&mut self) -> String {
        self.eval("document.body.dataset.state").as_str().unwrap_or_default().to_owned()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A rater's scores of a replay of a kind: different per kind, so the analysis has
/// something to find.
fn scores(kind: &str, rater: &str) -> [u8; 3] {
    let bump = u8::from(rater == "bob");
    match kind {
        "scripted" => [4 + bump, 2, 1 + bump],
        "marl" => [3, 3 - bump, 2],
        _ => [1 + bump, 4 + bump, 4],
    }
}

/// Signs `rater` in and rates replays until `stop_after` are rated in this sitting (or all).
fn rate(b: &mut Browser, url: &str, rater: &str, key: &BTreeMap<String, String>, stop_after: usize, seen: &mut Vec<String>) {
    b.open(url);
    b.eval(&format!("document.getElementById('rater').value = '{rater}'; document.getElementById('start').click(); true"));
    b.wait("the first replay left", "['rate', 'done'].includes(document.body.dataset.state)");
    let mut rated = 0;
    while b.state() == "rate" && rated < stop_after {
        b.wait("the frame", "document.getElementById('frame').complete && document.getElementById('frame').naturalWidth === 320");
        let replay = b.eval("document.body.dataset.replay").as_str().expect("replay id").to_owned();
        assert!(key.contains_key(&replay), "{replay} is not in the key");
        seen.push(replay.clone());
        // Submitting before rating every metric is stopped in the page.
        b.eval("document.getElementById('submit').click(); true");
        let kind = &key[&replay];
        for (metric, v) in ["exploitation", "coherence", "similarity"].iter().zip(scores(kind, rater)) {
            b.eval(&format!("document.querySelector('input[name={metric}][value=\"{v}\"]').click(); true"));
        }
        b.eval(&format!("document.getElementById('comment').value = '{rater} on {replay}'; true"));
        b.eval("document.getElementById('submit').click(); true");
        b.wait("the next replay", &format!("document.body.dataset.state === 'done' || document.body.dataset.replay !== '{replay}'"));
        rated += 1;
    }
}

// Long on purpose: one scenario a rater goes through, end to end, read top to bottom.
#[test]
fn human_eval_in_headless_chromium() {
    let t0 = Instant::now();
    let dir = tmp("human");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let plan = dir.join("plan.toml");
    std::fs::write(
        &plan,
        r#"name = "human"
scenarios = ["3m_vlm"]
seeds = [1, 2]

[[agents]]
name = "focus"
policy = "focus-fire"

# A scripted agent standing in for a trained policy (its kind is what a study compares).
[[agents]]
name = "mover"
policy = "attack-move"
kind = "marl"

# AVA on its instant stand-in model, which re-plays without a recording.
[[agents]]
name = "ava-standin"
policy = "ava"
ava = { model = { kind = "synthetic" }, record = "calls", config = { image = false, decide_every = 4 } }
"#,
    )
    .expect("plan");
    let (eval, study) = (dir.join("eval"), dir.join("study"));
    let run = |args: &[&str]| {
        let mut out = Vec::new();
        let res = avacraft_cli::run_args(std::iter::once("avacraft").chain(args.iter().copied()), &mut out);
        let text = String::from_utf8_lossy(&out).into_owned();
        if let Err(e) = res {
            panic!("avacraft {}: {e:#}\n{text}", args.join(" "));
        }
        text
    };
    let s = |p: &Path| p.display().to_string();
    run(&["eval", &s(&plan), "--out", &s(&eval), "--threads", "1"]);
    let text = run(&[
        "human-eval",
        "pack",
        "--plan",
        &s(&plan),
        "--eval",
        &s(&eval),
        "--out",
        &s(&study),
        "--per-kind",
        "2",
        "--seed",
        "5",
        "--size",
        "320x180",
    ]);
    assert!(text.contains("6 replays (2 scripted, 2 marl, 2 vlm)"), "{text}");
    eprintln!("evaluated and packed in {:.1?}", t0.elapsed());

    // Blinding: what the server can send names no agent; the key maps the ids back.
    let key: Value = serde_json::from_str(&std::fs::read_to_string(study.join("key.json")).expect("key")).expect("key json");
    let kinds: BTreeMap<String, String> = key["replays"]
        .as_object()
        .expect("replays")
        .iter()
        .map(|(id, e)| (id.clone(), e["kind"].as_str().unwrap_or("").to_owned()))
        .collect();
    assert_eq!(kinds.len(), 6);
    for entry in std::fs::read_dir(study.join("replays")).expect("replays") {
        let manifest = std::fs::read_to_string(entry.expect("entry").path().join("manifest.json")).expect("manifest");
        for word in ["focus", "mover", "ava", "scripted", "marl", "vlm"] {
            assert!(!manifest.contains(word), "a manifest names {word}: {manifest}");
        }
    }

    let server = Server::start(&study, "127.0.0.1:0".parse().expect("addr"), &[]).expect("serve");
    let url = server.url();
    let profile = dir.join("chromium-profile");
    let mut b = Browser::launch(&profile);

    // The player: play at 4x, pause, scrub.
    b.open(&url);
    b.eval("document.getElementById('rater').value = 'alice'; document.getElementById('start').click(); true");
    b.wait("the first replay", "document.body.dataset.state === 'rate'");
    b.wait("the first frame", "document.getElementById('frame').complete && document.getElementById('frame').naturalWidth === 320");
    let frames = b.eval("Number(document.getElementById('scrub').max) + 1").as_f64().expect("frames");
    assert!(frames > 5.0, "{frames} frames");
    b.eval("const s = document.getElementById('speed'); s.value = '4'; s.dispatchEvent(new Event('change')); true");
    b.eval("document.getElementById('play').click(); true");
    b.wait("playback", "Number(document.body.dataset.frame) >= 3");
    assert_eq!(b.eval("document.getElementById('play').textContent"), json!("Pause"));
    b.eval("document.getElementById('play').click(); true");
    let paused = b.eval("document.body.dataset.frame");
    std::thread::sleep(Duration::from_millis(600));
    assert_eq!(b.eval("document.body.dataset.frame"), paused, "paused playback moved on");
    b.eval("const r = document.getElementById('scrub'); r.value = '1'; r.dispatchEvent(new Event('input')); true");
    b.wait(
        "the scrubbed frame",
        "document.getElementById('frame').src.endsWith('/000001.png') && document.getElementById('frame').complete",
    );
    assert_eq!(b.eval("document.getElementById('pos').textContent"), json!(format!("2 / {frames}")));
    let shot = b.call("Page.captureScreenshot", json!({ "format": "png" }));
    let png = shot["data"].as_str().and_then(|d| base64::Engine::decode(&base64::engine::general_purpose::STANDARD, d).ok());
    assert!(png.as_ref().is_some_and(|p| p.starts_with(b"\x89PNG")), "a screenshot of the page");
    // To look at the page as a rater sees it: AVACRAFT_HUMAN_SCREENSHOT=page.png.
    if let (Some(path), Some(png)) = (std::env::var_os("AVACRAFT_HUMAN_SCREENSHOT"), png) {
        std::fs::write(path, png).expect("write the screenshot");
    }
    b.eval("document.getElementById('submit').click(); true");
    assert!(b.eval("document.getElementById('message').textContent").as_str().is_some_and(|m| m.starts_with("Rate ")));

    // alice rates 2, leaves, and comes back for the other 4; bob rates all 6 at once.
    let mut alice = Vec::new();
    rate(&mut b, &url, "alice", &kinds, 2, &mut alice);
    assert_eq!(b.state(), "rate");
    rate(&mut b, &url, "alice", &kinds, usize::MAX, &mut alice);
    assert_eq!(b.state(), "done");
    assert_eq!(b.eval("document.getElementById('progress').textContent"), json!("6 of 6 rated"));
    let mut bob = Vec::new();
    rate(&mut b, &url, "bob", &kinds, usize::MAX, &mut bob);
    assert_eq!(b.state(), "done");
    for seen in [&alice, &bob] {
        let mut ids = seen.clone();
        ids.sort();
        assert_eq!(ids, kinds.keys().cloned().collect::<Vec<_>>(), "each replay once");
    }
    // A second rating of a replay is refused, with a message saying why.
    let again = b.eval(&format!(
        "fetch('/api/ratings', {{ method: 'POST', headers: {{ 'Content-Type': 'application/json' }}, body: JSON.stringify({{ \
         rater: 'bob', replay: '{}', exploitation: 1, coherence: 1, similarity: 1, comment: '' }}) }}) \
         .then(async r => [r.status, (await r.json()).error])",
        bob[0]
    ));
    assert_eq!(again[0], json!(409), "{again}");
    assert!(again[1].as_str().is_some_and(|m| m.contains("already")), "{again}");
    drop(b);
    server.stop().expect("stop");

    // The ratings, read back with SQLite itself.
    let db = rusqlite::Connection::open(study.join("ratings.db")).expect("db");
    let mut st = db.prepare("SELECT rater, replay, exploitation, coherence, similarity, comment FROM ratings").expect("query");
    let rows: Vec<(String, String, u8, u8, u8, String)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?)))
        .expect("rows")
        .collect::<Result<_, _>>()
        .expect("rows");
    assert_eq!(rows.len(), 12);
    for (rater, replay, e, c, s, comment) in &rows {
        assert_eq!([*e, *c, *s], scores(&kinds[replay], rater), "{rater} on {replay}");
        assert_eq!(comment, &format!("{rater} on {replay}"));
    }

    let text = run(&["human-eval", "analyze", "--study", &s(&study)]);
    assert!(text.contains("12 ratings by 2 raters"), "{text}");
    assert!(text.contains("| Game-bug exploitation | scripted vs vlm |"), "{text}");
    assert!(study.join("analysis.png").is_file());
    eprintln!("whole test in {:.1?}", t0.elapsed());
}
