//! A live view in Foxglove: the arm's recorded topics on the Foxglove SDK's WebSocket server,
//! behind a relay that also lets in clients of the protocol's older name ([`older_clients`]).

pub mod older_clients;

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use foxglove::{Context, PartialMetadata, RawChannel, Schema, WebSocketServer};
use jointctl_ipc::IpcScope;
use jointctl_record::feed::{ArmFeed, FeedError, wall_clock_ns};

use crate::BridgeSummary;
use jointctl_record::messages;

/// What to serve.
#[derive(Clone, Debug)]
pub struct FoxgloveOptions {
    /// The arm (its YAML `arm:` name).
    pub arm: String,
    /// Its shared memory.
    pub scope: IpcScope,
    /// Address to listen on (`127.0.0.1`: this machine only; `0.0.0.0`: every interface).
    pub host: String,
    /// TCP port; 0 picks a free one (the `ready` callback learns which).
    pub port: u16,
    /// How long to wait for the arm's services, and how long the arm may be silent [s].
    pub timeout_s: f64,
    /// Let in clients that offer only `foxglove.websocket.v1` (Lichtblick, PlotJuggler): the
    /// public port is then [`older_clients::Relay`]'s, and the SDK's server listens on a loopback
    /// port behind it. False: the SDK's server on the public port, `foxglove.sdk.v1` only.
    pub older_clients: bool,
}

/// Why the bridge stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum FoxgloveBridgeError {
    /// The arm could not be read.
    #[error(transparent)]
    Feed(#[from] FeedError),
    /// A channel could not be created.
    #[error("cannot create the Foxglove channel `{topic}`")]
    Channel {
        /// The topic.
        topic: String,
        /// The SDK's reason.
        source: foxglove::FoxgloveError,
    },
    /// The relay for clients of the older name could not start.
    #[error(transparent)]
    Relay(#[from] older_clients::RelayError),
    /// The WebSocket server could not start (port taken, address not local).
    #[error("cannot start the Foxglove WebSocket server on {host}:{port}")]
    Server {
        /// Address.
        host: String,
        /// Port.
        port: u16,
        /// The SDK's reason.
        source: foxglove::FoxgloveError,
    },
}


/// The SDK's channels, one per recorded topic, with the recording's JSON schemas.
fn channels(ctx: &Arc<Context>) -> Result<BTreeMap<&'static str, Arc<RawChannel>>, FoxgloveBridgeError> {
    let mut out = BTreeMap::new();
    for (topic, schema_name) in messages::CHANNELS {
        let schema = messages::schema(topic).map(|s| s.to_string()).unwrap_or_default();
        let channel = ctx
            .channel_builder(topic)
            .message_encoding("json")
            .schema(Schema::new(schema_name, "jsonschema", schema.into_bytes()))
            .build_raw()
            .map_err(|source| FoxgloveBridgeError::Channel { topic: topic.to_string(), source })?;
        out.insert(topic, channel);
    }
    Ok(out)
}

/// Serves the arm until `stop` is set or the arm stops or falls silent; `ready` learns the public
/// port once clients may connect. Message times are the cycles' stamps on the wall clock.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use jointctl_bridge::foxglove::{FoxgloveOptions, serve};
/// let opts = FoxgloveOptions { arm: "sherpa".into(), scope: Default::default(), host: "127.0.0.1".into(), port: 8765, timeout_s: 5.0, older_clients: true };
/// let summary = serve(&opts, &std::sync::atomic::AtomicBool::new(false), |port| eprintln!("ws://127.0.0.1:{port}"))?;
/// println!("{:?}", summary.messages);
/// # Ok(()) }
/// ```
pub fn serve(opts: &FoxgloveOptions, stop: &AtomicBool, ready: impl FnOnce(u16)) -> Result<BridgeSummary, FoxgloveBridgeError> {
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let mut feed = ArmFeed::open(&opts.arm, &opts.scope, timeout, &format!("jointctl-bridge-foxglove-{}", std::process::id()))?;
    let ctx = Context::new();
    let channels = channels(&ctx)?;
    // Behind the relay, the SDK's server is reachable from this machine only.
    let (sdk_host, sdk_port) = if opts.older_clients { ("127.0.0.1".to_string(), 0) } else { (opts.host.clone(), opts.port) };
    let server = WebSocketServer::new()
        .name(format!("jointctl {}", opts.arm))
        .bind(sdk_host.clone(), sdk_port)
        .context(&ctx)
        .start_blocking()
        .map_err(|source| FoxgloveBridgeError::Server { host: sdk_host, port: sdk_port, source })?;
    let relay = match opts.older_clients {
        true => match older_clients::Relay::start(&opts.host, opts.port, server.port()) {
            Ok(relay) => Some(relay),
            Err(e) => {
                server.stop().wait_blocking();
                return Err(e.into());
            }
        },
        false => None,
    };
    ready(relay.as_ref().map_or(server.port(), older_clients::Relay::port));
    let result = crate::pump(
        &mut feed,
        stop,
        timeout,
        "Foxglove",
        |m| {
            // No client subscribed: nothing to encode for.
            if let Some(channel) = channels.get(m.topic).filter(|c| c.has_sinks()) {
                channel.log_with_meta(m.json.as_bytes(), PartialMetadata { log_time: wall_clock_ns(m.stamp_ns) });
            }
        },
        || {},
    );
    // The SDK's server first: its close to each client passes through the relay.
    server.stop().wait_blocking();
    if let Some(relay) = relay {
        relay.stop();
    }
    Ok(result?)
}
