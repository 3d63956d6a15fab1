//! The arm on the network over Zenoh: what it publishes, for other machines, and commands from
//! them.
//!
//! Key expressions (`<arm>` is the YAML's `arm:`):
//! - `jointctl/<arm>/raw`, `.../joint_state`, `.../diagnostics`, `.../commands`: the recording's
//!   JSON of each sample, with `wall_ns` added (the cycle's stamp on the bridge machine's wall
//!   clock [UNIX ns]; the monotonic `stamp_ns` means nothing on another machine).
//! - `jointctl/<arm>/command`: a queryable. The query's payload is a command as JSON
//!   ([`jointctl_record::messages::request`]); the reply is `{"accepted": bool, "message": str}`.
//!
//! Two Zenoh sessions keep reading and commanding apart. The one on `--listen` admits every peer
//! and answers every command with a refusal that says why. Only when the arm's YAML has
//! `network.zenoh.commands` does a second session listen on its endpoint, admitting only peers
//! that pass Zenoh's user/password authentication against the YAML's `users_file`; commands that
//! arrive there go to the runtime, which validates them as it validates local ones. Both
//! sessions have multicast scouting off, so they are reached at their endpoints only; they never
//! connect to each other, and the command session admits no peer without credentials, so no
//! path leads from the open session to the command queryable.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use jointctl_ipc::{CommandClient, IpcScope};
use jointctl_record::feed::{ArmFeed, FeedError, wall_clock_ns};

use crate::BridgeSummary;
use jointctl_record::messages;
use zenoh::Wait;


/// The key expression of one of the arm's topics (`joint_state`, `raw`, ...).
///
/// ```
/// assert_eq!(jointctl_bridge::zenoh::key("sherpa", "joint_state"), "jointctl/sherpa/joint_state");
/// ```
pub fn key(arm: &str, topic: &str) -> String {
    format!("jointctl/{arm}/{topic}")
}

/// The key expression of the arm's command queryable.
///
/// ```
/// assert_eq!(jointctl_bridge::zenoh::command_key("sherpa"), "jointctl/sherpa/command");
/// ```
pub fn command_key(arm: &str) -> String {
    key(arm, "command")
}

/// What to serve.
#[derive(Clone, Debug)]
pub struct ZenohOptions {
    /// The arm (its YAML `arm:` name).
    pub arm: String,
    /// Its shared memory.
    pub scope: IpcScope,
    /// Zenoh endpoints of the read-only session, e.g. `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// The arm's YAML, for its `network.zenoh` section; `None`: the file the runtime runs.
    pub config: Option<PathBuf>,
    /// How long to wait for the arm's services, and how long the arm may be silent [s].
    pub timeout_s: f64,
    /// How long a command may wait for the runtime's answer [s].
    pub command_timeout_s: f64,
}

/// Why the bridge cannot serve.
#[derive(Debug, thiserror::Error)]
pub enum ZenohBridgeError {
    /// The arm could not be read.
    #[error(transparent)]
    Feed(#[from] FeedError),
    /// The arm's YAML could not be read for its `network` section.
    #[error("{}: {reason}", .file.display())]
    Config {
        /// The file.
        file: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The users file is missing, empty or readable by others.
    #[error("{} (network.zenoh.commands.users_file): {reason}", .file.display())]
    UsersFile {
        /// The file.
        file: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A Zenoh session could not be configured or opened.
    #[error("cannot open a Zenoh session on {endpoints}: {reason}")]
    Session {
        /// Its endpoints.
        endpoints: String,
        /// Zenoh's reason.
        reason: String,
    },
    /// The runtime's command service could not be reached (commands are allowed, but no
    /// runtime serves the arm, or its client slots are taken).
    #[error("cannot forward commands to the runtime")]
    Runtime(#[source] jointctl_ipc::CommandError),
    /// A publisher or queryable could not be declared.
    #[error("cannot declare `{key}` on Zenoh: {reason}")]
    Declare {
        /// The key expression.
        key: String,
        /// Zenoh's reason.
        reason: String,
    },
}

/// Where the bridge listens, once it does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Listening {
    /// The read-only session's endpoints.
    pub listen: Vec<String>,
    /// The command session's endpoint, when the YAML allows commands.
    pub commands: Option<String>,
}

/// A configuration with multicast scouting off: the session is reached at its endpoints only.
fn base_config(mode: &str) -> Result<zenoh::Config, String> {
    let mut config = zenoh::Config::default();
    for (key, value) in [("mode", format!("\"{mode}\"")), ("scouting/multicast/enabled", "false".into())] {
        config.insert_json5(key, &value).map_err(|e| format!("{key}: {e}"))?;
    }
    Ok(config)
}

/// Zenoh's access control on the bridge's sessions: no peer may put or delete in the arm's key
/// space (`jointctl/**`); only the bridge's own session publishes there. Without it, a peer
/// with no credentials published well-formed joint states on the open endpoint, and 49 of 60
/// samples `inspect echo --zenoh` showed carried its forged q1 (issue 40, finding 12).
const READ_ONLY_FOR_PEERS: &str = r#"{
    enabled: true,
    default_permission: "allow",
    rules: [{ id: "the arm's key space is the bridge's", permission: "deny", flows: ["ingress"], messages: ["put", "delete"], key_exprs: ["jointctl/**"] }],
    subjects: [{ id: "every peer" }],
    policies: [{ rules: ["the arm's key space is the bridge's"], subjects: ["every peer"] }],
}"#;

fn listening_session(endpoints: &[String], users_file: Option<&Path>) -> Result<zenoh::Session, ZenohBridgeError> {
    let session_error = |reason: String| ZenohBridgeError::Session { endpoints: endpoints.join(", "), reason };
    let mut config = base_config("peer").map_err(session_error)?;
    let list = serde_json::to_string(endpoints).unwrap_or_default();
    config.insert_json5("listen/endpoints", &list).map_err(|e| session_error(format!("listen/endpoints: {e}")))?;
    if let Some(file) = users_file {
        let path = serde_json::to_string(&file.to_string_lossy()).unwrap_or_default();
        config.insert_json5("transport/auth/usrpwd/dictionary_file", &path).map_err(|e| session_error(e.to_string()))?;
    }
    config.insert_json5("access_control", READ_ONLY_FOR_PEERS).map_err(|e| session_error(format!("access_control: {e}")))?;
    zenoh::open(config).wait().map_err(|e| session_error(e.to_string()))
}

/// The fewest characters a password of the users file may have. Zenoh's user/password handshake
/// has no hook where failed logins could be slowed down or counted (Zenoh 1.x), so a peer may
/// guess as fast as it can open links; the password must be too long to guess instead. Sixteen
/// characters of base64 (`head -c 12 /dev/urandom | base64`) are 96 bits: at a million guesses
/// a second, 10^15 years on average (an assumption on the guessing rate, far above the tens a
/// second a `cmd` per guess reaches).
pub const MIN_PASSWORD_CHARS: usize = 16;

/// Checks the users file as Zenoh will read it, that only its owner may read it, and that no
/// password is shorter than [`MIN_PASSWORD_CHARS`].
fn check_users_file(file: &Path) -> Result<(), ZenohBridgeError> {
    use std::os::unix::fs::PermissionsExt;
    let bad = |reason: String| ZenohBridgeError::UsersFile { file: file.to_path_buf(), reason };
    let meta = std::fs::metadata(file).map_err(|e| bad(e.to_string()))?;
    let mode = meta.permissions().mode();
    if mode & 0o077 != 0 {
        return Err(bad(format!("others may read or change it (mode {:o}): `chmod 600` it", mode & 0o777)));
    }
    let text = jointctl_files::read_to_string(file, jointctl_files::FileKind::Credentials).map_err(|e| bad(e.to_string()))?;
    let mut users = 0;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match line.split_once(':') {
            Some((user, password)) if !user.is_empty() && !password.is_empty() => {
                // Its length, never the password itself: the error goes to logs and terminals.
                let chars = password.chars().count();
                if chars < MIN_PASSWORD_CHARS {
                    return Err(bad(format!(
                        "line {}: the password of `{user}` has {chars} characters, at least {MIN_PASSWORD_CHARS} are needed: Zenoh cannot slow down failed logins, so a password must be too long to guess (`head -c 12 /dev/urandom | base64` makes one)",
                        i + 1
                    )));
                }
                users += 1;
            }
            _ => return Err(bad(format!("line {}: not `user:password`", i + 1))),
        }
    }
    if users == 0 {
        return Err(bad("names no user: one `user:password` per line".into()));
    }
    Ok(())
}

/// The YAML's `network.zenoh.commands`, with its users file resolved, or why commands are off.
fn commands_config(config: Option<&Path>) -> Result<Result<jointctl_config::ZenohCommandsConfig, String>, ZenohBridgeError> {
    let Some(file) = config else {
        return Ok(Err("the runtime did not say which YAML it runs, so none allows commands over the network".into()));
    };
    let loaded = jointctl_config::load(file).map_err(|e| ZenohBridgeError::Config { file: file.to_path_buf(), reason: e.to_string() })?;
    match loaded.config.network.zenoh.commands.clone() {
        None => Ok(Err(format!("the arm's YAML ({}) does not allow commands over the network (it has no `network.zenoh.commands`)", file.display()))),
        Some(mut c) => {
            c.users_file = loaded.source.resolve(&c.users_file);
            Ok(Ok(c))
        }
    }
}

/// One sample's JSON with `wall_ns` added, into `out`.
fn with_wall_clock(out: &mut String, json: &str, stamp_ns: u64) {
    out.clear();
    match json.strip_suffix('}') {
        Some(body) => {
            out.push_str(body);
            out.push_str(",\"wall_ns\":");
            match wall_clock_ns(stamp_ns) {
                Some(ns) => out.push_str(&ns.to_string()),
                None => out.push_str("null"),
            }
            out.push('}');
        }
        None => out.push_str(json),
    }
}

/// The reply to a command: `{"accepted": bool, "message": str}`.
fn answer(accepted: bool, message: &str) -> String {
    serde_json::json!({"accepted": accepted, "message": message}).to_string()
}

/// Serves the arm until `stop` is set, the arm stops or falls silent. `ready` learns where it
/// listens once peers may connect.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use jointctl_bridge::zenoh::{ZenohOptions, serve};
/// let opts = ZenohOptions {
///     arm: "sherpa".into(), scope: Default::default(), listen: vec!["tcp/0.0.0.0:7447".into()],
///     config: None, timeout_s: 5.0, command_timeout_s: 2.0,
/// };
/// serve(&opts, &std::sync::atomic::AtomicBool::new(false), |at| eprintln!("listening on {:?}", at.listen))?;
/// # Ok(()) }
/// ```
pub fn serve(opts: &ZenohOptions, stop: &AtomicBool, ready: impl FnOnce(&Listening)) -> Result<BridgeSummary, ZenohBridgeError> {
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let mut feed = ArmFeed::open(&opts.arm, &opts.scope, timeout, &format!("jointctl-bridge-zenoh-{}", std::process::id()))?;
    let config_file = opts.config.clone().or_else(|| feed.descriptor().config_path());
    let commands = commands_config(config_file.as_deref())?;
    let declare_error = |key: &str| {
        let key = key.to_string();
        move |e: zenoh::Error| ZenohBridgeError::Declare { key: key.clone(), reason: e.to_string() }
    };

    let open = listening_session(&opts.listen, None)?;
    let mut publishers = BTreeMap::new();
    for (topic, _) in messages::CHANNELS {
        let k = key(&opts.arm, topic);
        publishers.insert(topic, open.declare_publisher(k.clone()).wait().map_err(declare_error(&k))?);
    }
    let command_key = command_key(&opts.arm);
    let refusals = open.declare_queryable(command_key.clone()).wait().map_err(declare_error(&command_key))?;
    let refusal = match &commands {
        Ok(c) => format!("this endpoint only publishes: commands are served to authenticated peers at {} (network.zenoh.commands)", c.listen),
        Err(why) => why.clone(),
    };

    // The command session and its client of the runtime, when the YAML allows commands.
    let mut serving = None;
    if let Ok(c) = &commands {
        check_users_file(&c.users_file)?;
        let session = listening_session(std::slice::from_ref(&c.listen), Some(&c.users_file))?;
        let queryable = session.declare_queryable(command_key.clone()).wait().map_err(declare_error(&command_key))?;
        let client = CommandClient::open(&opts.scope, &opts.arm, &format!("jointctl-bridge-zenoh-cmd-{}", std::process::id()))
            .map_err(ZenohBridgeError::Runtime)?;
        tracing::info!(arm = %opts.arm, endpoint = %c.listen, "serving commands to authenticated peers");
        serving = Some((session, queryable, client, crate::RateLimit::new(c.max_commands_per_s)));
    }
    ready(&Listening { listen: opts.listen.clone(), commands: commands.as_ref().ok().map(|c| c.listen.clone()) });

    let mut text = String::with_capacity(16 * 1024);
    let result = crate::pump(
        &mut feed,
        stop,
        timeout,
        "Zenoh",
        |m| {
            if let Some(publisher) = publishers.get(m.topic) {
                with_wall_clock(&mut text, m.json, m.stamp_ns);
                if let Err(e) = publisher.put(text.as_bytes()).wait() {
                    tracing::warn!(topic = m.topic, error = %e, "a sample could not be published");
                }
            }
        },
        || {
            while let Ok(Some(query)) = refusals.try_recv() {
                tracing::info!(arm = %opts.arm, reason = %refusal, "refused a command from the network");
                let _ = query.reply(query.key_expr().clone(), answer(false, &format!("refused: {refusal}"))).wait();
            }
            if let Some((_, queryable, client, limit)) = &mut serving {
                while let Ok(Some(query)) = queryable.try_recv() {
                    let reply = if limit.take(Instant::now()) {
                        forward(&opts.arm, query.payload(), client, opts.command_timeout_s)
                    } else {
                        let why = format!("more than {} commands a second from the network (network.zenoh.commands.max_commands_per_s); this one was not forwarded", jointctl_config::short_number(limit.per_s));
                        tracing::info!(arm = %opts.arm, reason = %why, "refused a command from the network");
                        answer(false, &format!("refused: {why}"))
                    };
                    let _ = query.reply(query.key_expr().clone(), reply).wait();
                }
            }
        },
    );
    if let Some((session, queryable, client, _)) = serving {
        drop((queryable, client));
        let _ = session.close().wait();
    }
    drop((refusals, publishers));
    let _ = open.close().wait();
    Ok(result?)
}

/// A command from an authenticated peer, to the runtime; the reply says what it answered.
fn forward(arm: &str, payload: Option<&zenoh::bytes::ZBytes>, client: &CommandClient, timeout_s: f64) -> String {
    let parsed = payload
        .ok_or_else(|| "the query carries no command (send it as the query's payload)".to_string())
        .and_then(|p| p.try_to_string().map_err(|e| format!("the command is not UTF-8 text: {e}")).map(|s| s.into_owned()))
        .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).map_err(|e| format!("the command is not JSON: {e}")))
        .and_then(|v| messages::parse_request(&v).map_err(|e| e.to_string()));
    let request = match parsed {
        Ok(r) => r,
        Err(why) => {
            tracing::info!(arm, reason = %why, "refused a malformed command from the network");
            return answer(false, &format!("refused: {why}"));
        }
    };
    let what = messages::request(&request).to_string();
    match client.send(request, timeout_s) {
        Ok(response) => {
            let accepted = response.accepted != 0;
            if accepted {
                tracing::info!(arm, command = %what, message = response.text(), "accepted a command from the network");
            } else {
                tracing::info!(arm, command = %what, reason = response.text(), "the runtime refused a command from the network");
            }
            answer(accepted, &format!("{}: {}", if accepted { "accepted" } else { "refused" }, response.text()))
        }
        Err(e) => {
            tracing::warn!(arm, command = %what, error = %e, "a command from the network got no answer");
            answer(false, &format!("no answer: {e}"))
        }
    }
}

/// How a network client authenticates: Zenoh's user/password scheme.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Credentials {
    /// User name.
    pub user: String,
    /// Password.
    pub password: String,
}

/// Why a network client failed.
#[derive(Debug, thiserror::Error)]
pub enum ZenohClientError {
    /// No session: nothing listens there, or the bridge refused this peer.
    #[error("cannot reach the bridge at {endpoint}: {reason}")]
    Connect {
        /// The endpoint.
        endpoint: String,
        /// What went wrong, as far as it can be told.
        reason: String,
    },
    /// Zenoh failed after connecting.
    #[error("Zenoh: {0}")]
    Zenoh(String),
    /// Nothing arrived in time.
    #[error("no {what} from arm `{arm}` at {endpoint} within {timeout_s} s: is `jointctl bridge zenoh` running for this arm?")]
    Silent {
        /// What was waited for.
        what: &'static str,
        /// The arm.
        arm: String,
        /// The endpoint.
        endpoint: String,
        /// How long [s].
        timeout_s: f64,
    },
}

/// A client session to a bridge at `endpoint`, authenticating when `credentials` are given.
/// When the session cannot open, says whether anything listens there (TCP endpoints) and so
/// whether the bridge refused this peer.
pub fn connect(endpoint: &str, credentials: Option<&Credentials>, timeout_s: f64) -> Result<zenoh::Session, ZenohClientError> {
    let connect_error = |reason: String| ZenohClientError::Connect { endpoint: endpoint.to_string(), reason };
    let config = client_config(endpoint, credentials, timeout_s).map_err(connect_error)?;
    zenoh::open(config).wait().map_err(|e| connect_error(diagnose(endpoint, credentials.is_some(), timeout_s, &e.to_string())))
}

/// A client's Zenoh configuration for `endpoint`, authenticating when `credentials` are given.
fn client_config(endpoint: &str, credentials: Option<&Credentials>, timeout_s: f64) -> Result<zenoh::Config, String> {
    let mut config = base_config("client")?;
    let endpoints = serde_json::to_string(&[endpoint]).unwrap_or_default();
    let timeout_ms = ((timeout_s * 1e3) as i64).max(1).to_string();
    let mut settings = vec![("connect/endpoints", endpoints), ("connect/timeout_ms", timeout_ms)];
    if let Some(c) = credentials {
        settings.push(("transport/auth/usrpwd/user", serde_json::to_string(&c.user).unwrap_or_default()));
        settings.push(("transport/auth/usrpwd/password", serde_json::to_string(&c.password).unwrap_or_default()));
    }
    for (key, value) in settings {
        config.insert_json5(key, &value).map_err(|e| format!("{key}: {e}"))?;
    }
    Ok(config)
}

/// Why a session could not open, as far as a TCP probe tells, and, for refused credentials,
/// whether the same peer without them is admitted.
fn diagnose(endpoint: &str, authenticated: bool, timeout_s: f64, zenoh_says: &str) -> String {
    let Some(address) = endpoint.strip_prefix("tcp/") else { return zenoh_says.to_string() };
    let reachable = std::net::ToSocketAddrs::to_socket_addrs(address)
        .ok()
        .and_then(|mut a| a.next())
        .is_some_and(|a| std::net::TcpStream::connect_timeout(&a, Duration::from_secs(1)).is_ok());
    match (reachable, authenticated) {
        (false, _) => format!("nothing listens there ({zenoh_says})"),
        (true, false) => "the bridge refused this peer: that endpoint admits only authenticated peers (give --user and a password)".into(),
        (true, true) => {
            // Admitted without credentials: the endpoint takes none (the bridge's open one), and
            // the credentials were never judged. Said as "wrong user or password" before, with
            // the right ones (issue 40, finding 14).
            let open = client_config(endpoint, None, timeout_s.min(2.0)).ok().and_then(|c| zenoh::open(c).wait().ok());
            match open {
                Some(session) => {
                    let _ = session.close().wait();
                    "that endpoint takes no credentials: it is the bridge's open endpoint, which only publishes; commands go to the bridge's command endpoint (the arm's `network.zenoh.commands.listen`)".into()
                }
                None => "the bridge refused this peer's credentials (wrong user or password?)".into(),
            }
        }
    }
}

/// Sends a command (its JSON, [`messages::request`]) and returns the bridge's reply:
/// `(accepted, message)`.
pub fn send_command(session: &zenoh::Session, endpoint: &str, arm: &str, request: &jointctl_ipc::CommandRequest, timeout_s: f64) -> Result<(bool, String), ZenohClientError> {
    let replies = session
        .get(command_key(arm))
        .payload(messages::request(request).to_string())
        .timeout(Duration::from_secs_f64(timeout_s))
        .wait()
        .map_err(|e| ZenohClientError::Zenoh(e.to_string()))?;
    let silent = || ZenohClientError::Silent { what: "answer", arm: arm.to_string(), endpoint: endpoint.to_string(), timeout_s };
    let reply = replies.recv().map_err(|_| silent())?;
    let sample = reply.into_result().map_err(|e| ZenohClientError::Zenoh(e.payload().try_to_string().map(|s| s.into_owned()).unwrap_or_default()))?;
    let text = sample.payload().try_to_string().map_err(|e| ZenohClientError::Zenoh(e.to_string()))?.into_owned();
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| ZenohClientError::Zenoh(format!("the bridge's answer is not JSON: {e}")))?;
    Ok((v["accepted"].as_bool().unwrap_or(false), v["message"].as_str().unwrap_or("").to_string()))
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt;

    /// The users file with `line`, owner-only, checked.
    fn check(name: &str, line: &str) -> Result<(), super::ZenohBridgeError> {
        let file = std::env::temp_dir().join(format!("jointctl-users-{}-{name}.txt", std::process::id()));
        std::fs::write(&file, format!("{line}\n")).unwrap();
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o600)).unwrap();
        let checked = super::check_users_file(&file);
        std::fs::remove_file(&file).unwrap();
        checked
    }

    #[test]
    fn a_password_counts_characters_not_bytes_from_16() {
        let fifteen = "a".repeat(15);
        let e = check("fifteen", &format!("operator:{fifteen}")).unwrap_err().to_string();
        assert!(e.contains("has 15 characters, at least 16") && !e.contains(&fifteen), "{e}");
        assert!(check("sixteen", &format!("operator:{}", "a".repeat(16))).is_ok());
        // Fifteen characters of two bytes each: 30 bytes, still too short.
        assert!(check("multibyte", &format!("operator:{}", "é".repeat(15))).is_err());
        assert!(check("multibyte16", &format!("operator:{}", "é".repeat(16))).is_ok());
    }
}
