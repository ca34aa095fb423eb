//! Human evaluation without a browser: the statistics against SciPy, the ratings database's
//! rules, and what the rating server refuses (paths out of the study, bad input, second
//! ratings). The page itself is driven in headless Chromium by `cli/tests/it/human.rs`.
#![forbid(unsafe_code)]
#![allow(clippy::unwrap_used)]

use avacraft_eval::AgentKind;
use avacraft_eval::human::{self, Db, HumanError, Key, KeyEntry, Rating, Server};
use std::io::{Read, Write};
use std::path::Path;

const RATERS: [&str; 3] = ["alice", "bob", "carol"];

/// Replays per kind, and each rater's scores (exploitation, coherence, similarity) of each.
fn fixed() -> (Vec<(&'static str, AgentKind)>, Vec<Rating>) {
    let replays = vec![
        ("ra1", AgentKind::Scripted),
        ("ra2", AgentKind::Scripted),
        ("rb1", AgentKind::Marl),
        ("rb2", AgentKind::Marl),
        ("rc1", AgentKind::Vlm),
        ("rc2", AgentKind::Vlm),
    ];
    #[rustfmt::skip]
    let scores: [[(i64, i64, i64); 6]; 3] = [
        [(4, 2, 1), (5, 2, 2), (3, 3, 2), (4, 3, 3), (2, 4, 4), (1, 5, 4)],
        [(4, 1, 2), (3, 2, 1), (3, 3, 3), (2, 4, 2), (2, 4, 5), (2, 3, 3)],
        [(5, 3, 1), (4, 2, 2), (3, 2, 4), (3, 3, 3), (1, 5, 4), (2, 4, 5)],
    ];
    let mut ratings = Vec::new();
    for (ri, rater) in RATERS.iter().enumerate() {
        for (pi, (id, _)) in replays.iter().enumerate() {
            let (e, c, s) = scores[ri][pi];
            ratings.push(Rating {
                rater: (*rater).into(),
                replay: (*id).into(),
                exploitation: e,
                coherence: c,
                similarity: s,
                comment: String::new(),
            });
        }
    }
    (replays, ratings)
}

fn key_of(replays: &[(&str, AgentKind)]) -> Key {
    let replays = replays
        .iter()
        .map(|(id, kind)| {
            let e = KeyEntry {
                agent: format!("{}-agent", kind.name()),
                kind: *kind,
                scenario: "3m_vlm".into(),
                against: "opponent:default".into(),
                seed: 1,
                result: "win".into(),
                trajectory_hash: "0".into(),
            };
            ((*id).to_owned(), e)
        })
        .collect();
    Key { version: 1, eval: "eval".into(), replays }
}

/// A study folder with the fixed replays (one tiny frame each) and its key.
fn study(dir: &Path, replays: &[(&str, AgentKind)]) {
    for (id, _) in replays {
        let d = dir.join("replays").join(id);
        std::fs::create_dir_all(&d).unwrap();
        let m = human::Manifest { id: (*id).into(), frames: 1, width: 8, height: 8, step_seconds: 0.357 };
        std::fs::write(d.join("manifest.json"), serde_json::to_string(&m).unwrap()).unwrap();
        image::RgbImage::new(8, 8).save(d.join("000000.png")).unwrap();
    }
    let s = human::Study { version: 1, replays: replays.iter().map(|(id, _)| (*id).to_owned()).collect() };
    std::fs::write(dir.join("study.json"), serde_json::to_string(&s).unwrap()).unwrap();
    std::fs::write(dir.join("key.json"), serde_json::to_string(&key_of(replays)).unwrap()).unwrap();
}

/// p-values agree to 9 significant digits: statrs' and SciPy's normal tails differ in the
/// last few bits (about 1e-10 relative here).
fn close(p: f64, scipy: f64) -> bool {
    (p - scipy).abs() <= 1e-9 * scipy
}

#[test]
fn mann_whitney_matches_scipy() {
    // scipy.stats.mannwhitneyu(x, y, method="asymptotic") (SciPy 1.17.1): statistic, pvalue.
    let cases: [(&[f64], &[f64], f64, f64); 2] = [
        (&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0, 7.0], 0.0, 0.05182992721790968),
        (&[1.5, 2.5, 2.5, 9.0], &[2.5, 3.0, 3.0, 3.0, 10.0], 5.0, 0.253887299829074),
    ];
    for (x, y, u, p) in cases {
        let t = human::mann_whitney(x, y).unwrap();
        assert_eq!(t.u, u, "{x:?} {y:?}");
        assert!(close(t.p, p), "{x:?} {y:?}: p {} against SciPy's {p}", t.p);
    }
    let all_tied = human::mann_whitney(&[3.0, 3.0], &[3.0]).unwrap();
    assert_eq!((all_tied.p, all_tied.rank_biserial), (1.0, 0.0));
    assert!(human::mann_whitney(&[], &[1.0]).is_none());
}

#[test]
fn analyze_matches_scipy_on_fixed_ratings() {
    let dir = tempfile::tempdir().unwrap();
    let (replays, ratings) = fixed();
    study(dir.path(), &replays);
    let db = Db::open(&dir.path().join(human::DB_FILE)).unwrap();
    for r in &ratings {
        db.insert(r).unwrap();
    }
    drop(db);
    let (a, files) = human::analyze(dir.path()).unwrap();
    assert_eq!((a.ratings, a.raters, a.unrated), (18, 3, 0));
    // SciPy 1.17.1's `mannwhitneyu(x, y, alternative="two-sided", method="asymptotic")`, x
    // and y a metric's scores of the first and the second kind in `fixed()` (all raters'
    // ratings of the kind's two replays), e.g. scripted exploitation [4, 5, 4, 3, 5, 4]
    // against VLM [2, 1, 2, 2, 1, 2] gives U = 36.0, p = 0.003925625174650279.
    let scipy: [(&str, AgentKind, AgentKind, f64, f64); 9] = [
        ("exploitation", AgentKind::Scripted, AgentKind::Marl, 31.5, 0.027484253646120595),
        ("exploitation", AgentKind::Scripted, AgentKind::Vlm, 36.0, 0.003925625174650279),
        ("exploitation", AgentKind::Marl, AgentKind::Vlm, 34.0, 0.008575573280889573),
        ("coherence", AgentKind::Scripted, AgentKind::Marl, 5.0, 0.030911712175690952),
        ("coherence", AgentKind::Scripted, AgentKind::Vlm, 0.5, 0.005083806247010088),
        ("coherence", AgentKind::Marl, AgentKind::Vlm, 4.5, 0.027484253646120595),
        ("similarity", AgentKind::Scripted, AgentKind::Marl, 3.0, 0.014501048623879598),
        ("similarity", AgentKind::Scripted, AgentKind::Vlm, 0.0, 0.004128316645700645),
        ("similarity", AgentKind::Marl, AgentKind::Vlm, 4.0, 0.02444894531008939),
    ];
    assert_eq!(a.comparisons.len(), scipy.len());
    for (metric, ka, kb, u, p) in scipy {
        let c = a.comparisons.iter().find(|c| c.metric == metric && c.a == ka && c.b == kb).unwrap();
        assert_eq!(c.test.u, u, "{metric} {ka:?} vs {kb:?}");
        assert!(close(c.test.p, p), "{metric} {ka:?} vs {kb:?}: p {} against SciPy's {p}", c.test.p);
        assert!((c.test.rank_biserial - (2.0 * u / 36.0 - 1.0)).abs() < 1e-12);
    }
    let s = a.summaries.iter().find(|s| s.metric == "similarity" && s.kind == AgentKind::Vlm).unwrap();
    // VLM similarity ratings: 4 4 5 3 4 5.
    assert_eq!((s.ratings, s.replays, s.median), (6, 2, 4.0));
    assert!((s.mean - 25.0 / 6.0).abs() < 1e-12);
    let md = std::fs::read_to_string(&files[0]).unwrap();
    assert!(md.contains("| Game-bug exploitation | scripted vs vlm | 36.0 | 0.0039 | +1.000 |"), "{md}");
    assert!(md.contains("| Human similarity | vlm | 6 | 2 | 4.17 | 4.0 |"), "{md}");
    assert!(std::fs::metadata(&files[1]).unwrap().len() > 1000, "analysis.png");
}

#[test]
fn database_keeps_one_rating_per_rater_and_replay() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ratings.db");
    let (_, ratings) = fixed();
    let db = Db::open(&path).unwrap();
    db.insert(&ratings[0]).unwrap();
    let again = Rating { exploitation: 1, ..ratings[0].clone() };
    assert!(matches!(db.insert(&again), Err(HumanError::AlreadyRated { .. })));
    for bad in [0, 6, -1] {
        let r = Rating { coherence: bad, ..ratings[1].clone() };
        assert!(matches!(db.insert(&r), Err(HumanError::BadScore { metric: "coherence", .. })), "{bad}");
    }
    for name in ["", "a b", "x".repeat(33).as_str(), "ève", "../etc", "a;DROP"] {
        let r = Rating { rater: name.into(), ..ratings[1].clone() };
        assert!(matches!(db.insert(&r), Err(HumanError::BadRater(_))), "{name:?}");
    }
    let long = Rating { comment: "é".repeat(human::MAX_COMMENT_CHARS + 1), ..ratings[1].clone() };
    assert!(matches!(db.insert(&long), Err(HumanError::CommentTooLong { .. })));
    let ok = Rating { comment: "é".repeat(human::MAX_COMMENT_CHARS), ..ratings[1].clone() };
    db.insert(&ok).unwrap();
    drop(db);
    // Reopened (as after a restart of the server), nothing is lost and the rule holds.
    let db = Db::open(&path).unwrap();
    assert_eq!(db.all().unwrap(), vec![ratings[0].clone(), ok]);
    assert_eq!(db.rated_by("alice").unwrap(), vec!["ra1".to_owned(), "ra2".to_owned()]);
    assert!(matches!(db.insert(&again), Err(HumanError::AlreadyRated { .. })));
}

/// One raw HTTP/1.1 request (so paths reach the server exactly as written): status, headers
/// and body.
fn http(addr: std::net::SocketAddr, method: &str, path: &str, body: &str) -> (u16, String, String) {
    http_as(&addr.to_string(), addr, method, path, body)
}

/// [`http`] with the given `Host` header.
fn http_as(host: &str, addr: std::net::SocketAddr, method: &str, path: &str, body: &str) -> (u16, String, String) {
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(20))).unwrap();
    let req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    );
    s.write_all(req.as_bytes()).unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let text = String::from_utf8_lossy(&raw).into_owned();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head.split(' ').nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
    (status, head.to_owned(), body.to_owned())
}

#[test]
fn server_serves_only_the_study_and_checks_ratings() {
    let dir = tempfile::tempdir().unwrap();
    let (replays, _) = fixed();
    study(dir.path(), &replays[..2]);
    // A frame that is a link out of the replays folder must not be followed.
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("key.json"), dir.path().join("replays/ra1/000001.png")).unwrap();
    let server = Server::start(dir.path(), "127.0.0.1:0".parse().unwrap(), &["raters.lab".to_owned()]).unwrap();
    let addr = server.addr();
    assert!(addr.ip().is_loopback());

    // DNS rebinding: a foreign name in Host is refused on every route, before anything else.
    let port = addr.port();
    for host in ["evil.example", &format!("evil.example:{port}"), "127.0.0.1.evil.example", "localhost.evil", "[::1", ""] {
        for (method, path) in [("GET", "/"), ("GET", "/api/rater/alice"), ("POST", "/api/ratings")] {
            let (st, _, body) = http_as(host, addr, method, path, "");
            assert_eq!(st, 421, "Host {host:?}: {method} {path} answered {st}: {body}");
            assert!(body.contains("Host header"), "{body}");
        }
    }
    for host in [
        format!("localhost:{port}"),
        format!("LOCALHOST.:{port}"),
        format!("[::1]:{port}"),
        "raters.lab".into(),
        format!("Raters.Lab:{port}"),
    ] {
        assert_eq!(http_as(&host, addr, "GET", "/api/study", "").0, 200, "Host {host:?}");
    }

    let (st, head, body) = http(addr, "GET", "/", "");
    assert_eq!(st, 200);
    assert!(body.contains("AVACraft human evaluation") && head.to_lowercase().contains("content-security-policy"), "{head}");
    assert!(!body.contains("http://") && !body.contains("https://"), "the page loads nothing from elsewhere");
    assert_eq!(http(addr, "GET", "/app.js", "").0, 200);
    let (st, head, _) = http(addr, "GET", "/replays/ra1/000000.png", "");
    assert_eq!(st, 200);
    assert!(head.contains("image/png"), "{head}");
    let (st, _, body) = http(addr, "GET", "/replays/ra1/manifest.json", "");
    assert_eq!(st, 200);
    assert!(body.contains("\"frames\":1"), "{body}");
    for path in [
        "/key.json",
        "/ratings.db",
        "/study.json",
        "/replays/ra1/../../key.json",
        "/replays/ra1/%2e%2e%2f%2e%2e%2fkey.json",
        "/replays/..%2f..%2fkey.json/000000.png",
        "/replays/..%2F/key.json",
        "/replays/rb1/manifest.json",
        "/replays/ra1/000001.png",
        "/replays/ra1/000000.png.bak",
        "/replays/ra1/%2fetc%2fpasswd",
    ] {
        let (st, _, body) = http(addr, "GET", path, "");
        assert!(st == 404 || st == 400, "{path}: {st}");
        assert!(!body.contains("trajectory_hash"), "{path} leaked the key");
    }

    let (st, _, body) = http(addr, "GET", "/api/study", "");
    assert_eq!(st, 200);
    assert!(body.contains("Human similarity") && !body.contains("ra1"), "{body}");
    assert_eq!(http(addr, "GET", "/api/rater/bad%20name", "").0, 400);
    let (st, _, body) = http(addr, "GET", "/api/rater/alice", "");
    assert_eq!(st, 200);
    assert!(body.contains(r#""left":["ra1","ra2"]"#), "{body}");

    let rating = |replay: &str, e: i64, comment: &str| {
        serde_json::json!({"rater": "alice", "replay": replay, "exploitation": e, "coherence": 3, "similarity": 4, "comment": comment})
            .to_string()
    };
    assert_eq!(http(addr, "POST", "/api/ratings", &rating("ra1", 2, "kites well")).0, 201);
    let (st, _, body) = http(addr, "POST", "/api/ratings", &rating("ra1", 5, ""));
    assert_eq!(st, 409);
    assert!(body.contains("rated replay ra1 already"), "{body}");
    assert_eq!(http(addr, "POST", "/api/ratings", &rating("ra2", 6, "")).0, 400);
    assert_eq!(http(addr, "POST", "/api/ratings", &rating("rb1", 3, "")).0, 404);
    assert_eq!(http(addr, "POST", "/api/ratings", &rating("ra2", 3, &"x".repeat(2001))).0, 400);
    assert_eq!(http(addr, "POST", "/api/ratings", "{not json").0, 400);
    assert_eq!(http(addr, "POST", "/api/ratings", r#"{"rater":"alice","replay":"ra2"}"#).0, 400);
    let (_, _, body) = http(addr, "GET", "/api/rater/alice", "");
    assert!(body.contains(r#""left":["ra2"]"#), "{body}");
    server.stop().unwrap();

    let db = Db::open(&dir.path().join(human::DB_FILE)).unwrap();
    let all = db.all().unwrap();
    assert_eq!(all.len(), 1);
    assert_eq!((all[0].replay.as_str(), all[0].exploitation, all[0].comment.as_str()), ("ra1", 2, "kites well"));
}
