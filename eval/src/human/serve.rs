//! The rating server: the page (HTML, JS and CSS compiled into the program, so it works with
//! no internet), the replays' frames, and a small JSON API over the ratings database.
//!
//! What it sends is limited on purpose: the embedded page, and under `/replays/<id>/` only
//! `manifest.json` and frame files of the study's own ids, resolved inside the canonical
//! replays folder. The key (`key.json`) and the database are never reachable.
//!
//! API:
//! - `GET /api/study`: the metrics and the number of replays;
//! - `GET /api/rater/{name}`: the replays that rater has left, in the study's order (so a
//!   rater who stops and comes back goes on where they were);
//! - `POST /api/ratings` with a [`Rating`]: 201, or 400 (bad name, score or comment), 404
//!   (not a replay of the study) or 409 (rated already), each with `{"error": "..."}`.
//!
//! Every request must name this server by an IP address or `localhost` (or a name the
//! operator allows) in its `Host` header, else 421: a page on another site that a rater
//! opens could otherwise reach a loopback server through a DNS name resolving to 127.0.0.1
//! (DNS rebinding) and read or forge ratings.

use super::{DB_FILE, Db, HumanError, MANIFEST_FILE, METRICS, REPLAYS_DIR, Rating, check_rater, read_study, valid_id_shape};
use axum::Json;
use axum::extract::rejection::JsonRejection;
use axum::extract::{Path as UrlPath, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use std::collections::BTreeSet;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

const INDEX_HTML: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const APP_CSS: &str = include_str!("assets/app.css");
/// Everything the page loads comes from this server.
const CSP: &str = "default-src 'self'; img-src 'self'; style-src 'self'; script-src 'self'; connect-src 'self'; frame-ancestors 'none'";

struct App {
    /// The replays in the study's (blinded) order.
    order: Vec<String>,
    ids: BTreeSet<String>,
    /// The canonical replays folder: every file sent must resolve inside it.
    replays: PathBuf,
    db: Mutex<Db>,
    /// Host names answered besides IP literals and `localhost` (lower case, no port).
    hosts: Vec<String>,
}

/// A running rating server (on its own thread); stopped when dropped.
#[derive(Debug)]
pub struct Server {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<Result<(), HumanError>>>,
}

impl std::fmt::Debug for App {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("App").field("replays", &self.replays).field("ids", &self.ids.len()).finish()
    }
}

impl Server {
    /// Opens the study (and its database, creating it) and starts serving on `addr` (port 0:
    /// a free one; see [`Server::addr`]). Requests are answered when their `Host` is an IP
    /// address, `localhost` or one of `hosts` (for raters who reach a shared machine by name).
    pub fn start(study: &Path, addr: SocketAddr, hosts: &[String]) -> Result<Server, HumanError> {
        let (s, _) = read_study(study)?;
        let replays_dir = study.join(REPLAYS_DIR);
        let replays = replays_dir.canonicalize().map_err(super::io(&replays_dir))?;
        let db = Db::open(&study.join(DB_FILE))?;
        let hosts = hosts.iter().map(|h| h.trim_end_matches('.').to_ascii_lowercase()).collect();
        let app = Arc::new(App { ids: s.replays.iter().cloned().collect(), order: s.replays, replays, db: Mutex::new(db), hosts });
        let serve_err = |source| HumanError::Serve { addr: addr.to_string(), source };
        let listener = std::net::TcpListener::bind(addr).map_err(serve_err)?;
        listener.set_nonblocking(true).map_err(serve_err)?;
        let addr = listener.local_addr().map_err(serve_err)?;
        let serve_err = move |source| HumanError::Serve { addr: addr.to_string(), source };
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("human-eval-server".into())
            .spawn(move || {
                let rt = tokio::runtime::Builder::new_current_thread().enable_io().build().map_err(serve_err)?;
                rt.block_on(async move {
                    let listener = tokio::net::TcpListener::from_std(listener).map_err(serve_err)?;
                    axum::serve(listener, router(app))
                        .with_graceful_shutdown(async move {
                            let _ = stopped.await;
                        })
                        .await
                        .map_err(serve_err)
                })
            })
            .map_err(serve_err)?;
        Ok(Server { addr, stop: Some(stop), thread: Some(thread) })
    }

    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Serves until the process ends (or the server fails).
    pub fn wait(mut self) -> Result<(), HumanError> {
        // The stop sender stays alive in `self` while this waits, so the server runs on.
        self.join()
    }

    /// Stops serving (answers in progress finish) and waits for the server's thread.
    pub fn stop(mut self) -> Result<(), HumanError> {
        drop(self.stop.take());
        self.join()
    }

    fn join(&mut self) -> Result<(), HumanError> {
        match self.thread.take().map(std::thread::JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => {
                Err(HumanError::Serve { addr: self.addr.to_string(), source: std::io::Error::other("the server thread panicked") })
            }
            None => Ok(()),
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        drop(self.stop.take());
        let _ = self.join();
    }
}

fn router(app: Arc<App>) -> axum::Router {
    axum::Router::new()
        .route("/", get(|| async { asset("text/html; charset=utf-8", INDEX_HTML) }))
        .route("/app.js", get(|| async { asset("text/javascript; charset=utf-8", APP_JS) }))
        .route("/app.css", get(|| async { asset("text/css; charset=utf-8", APP_CSS) }))
        .route("/api/study", get(study))
        .route("/api/rater/{name}", get(rater))
        .route("/api/ratings", post(submit))
        .route("/replays/{id}/{file}", get(replay_file))
        .layer(axum::middleware::from_fn_with_state(Arc::clone(&app), check_host))
        .with_state(app)
}

async fn check_host(State(app): State<Arc<App>>, req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    let host = req.headers().get(header::HOST).and_then(|h| h.to_str().ok());
    if host.is_some_and(|h| host_allowed(h, &app.hosts)) {
        return next.run(req).await;
    }
    let shown: String = host.unwrap_or("(none)").chars().take(80).collect();
    error(
        StatusCode::MISDIRECTED_REQUEST,
        format!(
            "this server answers only to an IP address or localhost in the Host header, not {shown:?}: open it by its address, or start it with --allow-host NAME"
        ),
    )
}

/// Whether a `Host` header value (`name[:port]`, `[v6]:port`) names this server acceptably:
/// an IP literal (a rebinding attack needs a DNS name), `localhost`, or an allowed name.
pub(super) fn host_allowed(host: &str, allowed: &[String]) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        match rest.split_once(']') {
            Some((v6, port)) if port.is_empty() || port.strip_prefix(':').is_some_and(is_port) => {
                return v6.parse::<std::net::Ipv6Addr>().is_ok();
            }
            _ => return false,
        }
    } else {
        match host.rsplit_once(':') {
            Some((name, port)) if is_port(port) => name,
            Some(_) => return false,
            None => host,
        }
    };
    let name = name.trim_end_matches('.').to_ascii_lowercase();
    !name.is_empty() && (name.parse::<std::net::Ipv4Addr>().is_ok() || name == "localhost" || allowed.contains(&name))
}

fn is_port(s: &str) -> bool {
    !s.is_empty() && s.len() <= 5 && s.bytes().all(|b| b.is_ascii_digit())
}

fn asset(content_type: &'static str, body: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CONTENT_SECURITY_POLICY, CSP),
            (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

fn error(status: StatusCode, message: impl std::fmt::Display) -> Response {
    (status, Json(serde_json::json!({ "error": message.to_string() }))).into_response()
}

impl IntoResponse for HumanError {
    fn into_response(self) -> Response {
        let status = match &self {
            HumanError::BadRater(_) | HumanError::BadScore { .. } | HumanError::CommentTooLong { .. } => StatusCode::BAD_REQUEST,
            HumanError::UnknownReplay(_) => StatusCode::NOT_FOUND,
            HumanError::AlreadyRated { .. } => StatusCode::CONFLICT,
            _ => StatusCode::INTERNAL_SERVER_ERROR,
        };
        if status == StatusCode::INTERNAL_SERVER_ERROR {
            let mut msg = self.to_string();
            let mut src = std::error::Error::source(&self);
            while let Some(s) = src {
                msg.push_str(&format!(": {s}"));
                src = s.source();
            }
            tracing::error!("human-eval server: {msg}");
            return error(status, msg);
        }
        error(status, self)
    }
}

async fn study(State(app): State<Arc<App>>) -> Response {
    Json(serde_json::json!({ "replays": app.order.len(), "metrics": METRICS })).into_response()
}

async fn rater(State(app): State<Arc<App>>, UrlPath(name): UrlPath<String>) -> Result<Response, HumanError> {
    check_rater(&name)?;
    let done: BTreeSet<String> = app.db.lock().unwrap_or_else(|p| p.into_inner()).rated_by(&name)?.into_iter().collect();
    let left: Vec<&String> = app.order.iter().filter(|id| !done.contains(*id)).collect();
    Ok(Json(serde_json::json!({ "rater": name, "total": app.order.len(), "done": done.len(), "left": left })).into_response())
}

async fn submit(State(app): State<Arc<App>>, body: Result<Json<Rating>, JsonRejection>) -> Result<Response, HumanError> {
    let Json(r) = match body {
        Ok(b) => b,
        Err(e) => return Ok(error(StatusCode::BAD_REQUEST, format!("not a rating: {}", e.body_text()))),
    };
    r.check()?;
    if !app.ids.contains(&r.replay) {
        return Err(HumanError::UnknownReplay(r.replay.chars().take(40).collect()));
    }
    app.db.lock().unwrap_or_else(|p| p.into_inner()).insert(&r)?;
    tracing::info!("rating of {} by {}", r.replay, r.rater);
    Ok((StatusCode::CREATED, Json(serde_json::json!({ "ok": true }))).into_response())
}

/// `manifest.json` or a frame (`NNNNNN.png`) of one of the study's replays; anything else,
/// and anything that resolves outside the replays folder, is 404.
async fn replay_file(State(app): State<Arc<App>>, UrlPath((id, file)): UrlPath<(String, String)>) -> Response {
    let not_found = || error(StatusCode::NOT_FOUND, "no such file");
    let is_frame = file.len() == 10 && file.ends_with(".png") && file[..6].bytes().all(|b| b.is_ascii_digit());
    if !valid_id_shape(&id) || !app.ids.contains(&id) || !(is_frame || file == MANIFEST_FILE) {
        return not_found();
    }
    let Ok(path) = app.replays.join(&id).join(&file).canonicalize() else { return not_found() };
    if !path.starts_with(&app.replays) {
        return not_found();
    }
    match std::fs::read(&path) {
        Ok(bytes) => {
            let ct = if is_frame { "image/png" } else { "application/json" };
            // A study's frames never change, so the browser may keep them while scrubbing.
            ([(header::CONTENT_TYPE, ct), (header::CACHE_CONTROL, "private, max-age=3600")], bytes).into_response()
        }
        Err(_) => not_found(),
    }
}

#[cfg(test)]
mod tests {
    use super::host_allowed;

    #[test]
    fn only_ip_literals_localhost_and_allowed_names_pass() {
        let allowed = ["study.lab".to_owned()];
        for ok in ["127.0.0.1", "127.0.0.1:8737", "10.0.0.7:80", "[::1]:8737", "[::1]", "localhost", "LocalHost.:1", "study.lab:8737"] {
            assert!(host_allowed(ok, &allowed), "{ok}");
        }
        for bad in [
            "",
            ":80",
            "evil.com",
            "evil.com:8737",
            "127.0.0.1.evil.com",
            "localhost.evil.com",
            "[::1",
            "[::1]x",
            "[evil]:1",
            "127.0.0.1:99999x",
            "127.0.0.1:",
            "study.lab.evil:1",
        ] {
            assert!(!host_allowed(bad, &allowed), "{bad}");
        }
    }
}
