//! The arm from another machine: `inspect echo --zenoh` and `cmd --zenoh` through a
//! `jointctl bridge zenoh` (see `jointctl_bridge::zenoh`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;
use jointctl_bridge::zenoh::{Credentials, ZenohClientError, connect, key, send_command};

/// The environment variable a password may come from (instead of a file).
const PASSWORD_ENV: &str = "JOINTCTL_ZENOH_PASSWORD";

/// How to authenticate to a bridge (Zenoh's user/password scheme). The password never goes on
/// the command line, where other users see it in the process list.
#[derive(Args, Clone, Debug, Default)]
pub struct CredentialArgs {
    /// User name to authenticate with (the bridge's `network.zenoh.commands.users_file`).
    #[arg(long, requires = "zenoh")]
    user: Option<String>,
    /// File holding the password (first line); without it, the environment variable
    /// JOINTCTL_ZENOH_PASSWORD.
    #[arg(long, value_name = "FILE", requires = "user")]
    password_file: Option<PathBuf>,
}

impl CredentialArgs {
    /// The credentials, when a user is given.
    fn credentials(&self) -> Result<Option<Credentials>, String> {
        let Some(user) = &self.user else { return Ok(None) };
        let password = match &self.password_file {
            Some(file) => jointctl_files::read_to_string(file, jointctl_files::FileKind::Credentials).map_err(|e| e.to_string())?.lines().next().unwrap_or("").to_string(),
            None => std::env::var(PASSWORD_ENV).map_err(|_| format!("--user {user} needs a password: --password-file FILE or {PASSWORD_ENV}"))?,
        };
        if password.is_empty() {
            return Err(format!("the password for --user {user} is empty"));
        }
        Ok(Some(Credentials { user: user.clone(), password }))
    }
}

fn session(endpoint: &str, credentials: &CredentialArgs, timeout_s: f64) -> Result<zenoh::Session, String> {
    let credentials = credentials.credentials()?;
    connect(endpoint, credentials.as_ref(), timeout_s).map_err(|e| e.to_string())
}

/// `jointctl cmd --zenoh ENDPOINT ...`: exit 0 when the runtime accepted the command, 1 with the
/// reason when it, or the bridge, refused it.
pub fn command(endpoint: &str, arm: &str, credentials: &CredentialArgs, request: &jointctl_ipc::CommandRequest, timeout_s: f64) -> ExitCode {
    let session = match session(endpoint, credentials, timeout_s) {
        Ok(s) => s,
        Err(e) => return crate::fail(e),
    };
    match send_command(&session, endpoint, arm, request, timeout_s) {
        Ok((true, message)) => {
            crate::print_out(&format!("{message}\n"));
            ExitCode::SUCCESS
        }
        Ok((false, message)) => crate::fail(message),
        Err(e) => crate::fail(e),
    }
}

/// `jointctl inspect echo --zenoh ENDPOINT`: the arm's joint states from its bridge.
pub fn echo(endpoint: &str, arm: &str, credentials: &CredentialArgs, timeout_s: f64, opts: &crate::arm_view::EchoOptions) -> ExitCode {
    let session = match session(endpoint, credentials, timeout_s) {
        Ok(s) => s,
        Err(e) => return crate::fail(e),
    };
    let topic = key(arm, "joint_state");
    let subscriber = match zenoh::Wait::wait(session.declare_subscriber(topic.clone())) {
        Ok(s) => s,
        Err(e) => return crate::fail(format!("cannot subscribe to `{topic}`: {e}")),
    };
    let mut last = Instant::now();
    crate::arm_view::echo(opts, || match subscriber.try_recv() {
        Ok(Some(sample)) => {
            last = Instant::now();
            let text = sample.payload().try_to_string().map_err(|e| format!("`{topic}`: not UTF-8: {e}"))?.into_owned();
            let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("`{topic}`: not JSON: {e}"))?;
            let state = jointctl_record::messages::parse_joint_state(&v).map_err(|e| format!("`{topic}`: {e}"))?;
            Ok(Some((state, v["wall_ns"].as_u64())))
        }
        Ok(None) if last.elapsed() > Duration::from_secs_f64(timeout_s) => {
            Err(ZenohClientError::Silent { what: "joint state", arm: arm.to_string(), endpoint: endpoint.to_string(), timeout_s }.to_string())
        }
        Ok(None) => Ok(None),
        Err(e) => Err(format!("`{topic}`: {e}")),
    })
}
