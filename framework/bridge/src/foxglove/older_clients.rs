//! Clients that offer only the Foxglove WebSocket protocol's older name.
//!
//! The Foxglove SDK's server negotiates the protocol as `foxglove.sdk.v1` and answers a client
//! that offers only `foxglove.websocket.v1` with HTTP 400. Foxglove calls the two names one
//! protocol (the SDK's messages are those of `foxglove.websocket.v1`), but Lichtblick before its
//! `foxglove.sdk.v1` support, PlotJuggler's Foxglove client and older Foxglove apps offer only
//! the old name, so they could not connect.
//!
//! The relay owns the bridge's public port and accepts every name the SDK accepts and the older
//! one. For each client it opens a WebSocket to the SDK's server on a loopback port, offering
//! the name the client chose (`foxglove.sdk.v1` for a client of the older name), and carries
//! every text, binary and close message both ways unchanged. It reads no Foxglove message: the
//! protocol stays the SDK's, and the WebSocket framing is tungstenite's (the crate the SDK's
//! server is built on).
//!
//! A slow client loses messages where the SDK decides: the relay writes each message to the
//! client before it reads the next from the SDK, so the SDK's queue for that client fills and
//! the SDK drops. The loopback connection's socket buffers are a queue of their own before that
//! (a client that cannot keep up gets older messages than it would directly).
//!
//! Latency: the SDK's server leaves Nagle's algorithm on (0.30 sets no `TCP_NODELAY`), so after
//! one small message it holds the next until the client acknowledges, and a Linux client
//! acknowledges late (delayed ACK, up to 40 ms): at 1 kHz a client received each joint state
//! 0.1-42 ms after its cycle, 17.4 ms at the median. The relay asks its kernel to acknowledge the
//! SDK at once (`TCP_QUICKACK`, re-armed after every message, as Linux requires) and sends to its
//! own client with Nagle off, so its clients get the messages about 1 ms after their cycle.

use std::net::{SocketAddr, TcpListener as StdListener};
use std::os::fd::{AsFd, OwnedFd};
use std::thread::JoinHandle;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::oneshot;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tokio_tungstenite::tungstenite::http::{HeaderValue, StatusCode, header::SEC_WEBSOCKET_PROTOCOL};
use tokio_tungstenite::tungstenite::{Error as WsError, Message};

/// The protocol's name in the Foxglove SDK, the one the relay offers the SDK's server for a
/// client of the older name.
pub const SDK_NAME: &str = "foxglove.sdk.v1";
/// The SDK's newer name (schemas by reference), which the SDK prefers when offered.
pub const SDK_NAME_V1_1: &str = "foxglove.sdk.v1.1";
/// The protocol's older name (the `foxglove/ws-protocol` specification, Lichtblick).
pub const OLDER_NAME: &str = "foxglove.websocket.v1";

/// Why the relay could not start.
#[derive(Debug, thiserror::Error)]
pub enum RelayError {
    /// The public address could not be bound (port taken, address not on this machine).
    #[error("cannot listen on {host}:{port}")]
    Bind {
        /// Address.
        host: String,
        /// Port.
        port: u16,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The relay's thread or its event loop could not be made.
    #[error("cannot start the relay for clients of `foxglove.websocket.v1`")]
    Start(#[source] std::io::Error),
}

/// The subprotocol to answer a client with: the newest the SDK speaks that it offers, else the
/// older name, else none (the client speaks something else).
///
/// ```
/// use jointctl_bridge::foxglove::older_clients::negotiate;
/// assert_eq!(negotiate(["foxglove.websocket.v1"]), Some("foxglove.websocket.v1"));
/// assert_eq!(negotiate(["foxglove.websocket.v1, foxglove.sdk.v1"]), Some("foxglove.sdk.v1"));
/// assert_eq!(negotiate(["foxglove.sdk.v1", "foxglove.sdk.v1.1"]), Some("foxglove.sdk.v1.1"));
/// assert_eq!(negotiate(["graphql-ws"]), None);
/// ```
pub fn negotiate<'a>(headers: impl IntoIterator<Item = &'a str>) -> Option<&'static str> {
    let offered: Vec<&str> = headers.into_iter().flat_map(|h| h.split(',')).map(str::trim).collect();
    [SDK_NAME_V1_1, SDK_NAME, OLDER_NAME].into_iter().find(|name| offered.contains(name))
}

/// The name to offer the SDK's server for a client that chose `name`.
fn upstream_name(name: &'static str) -> &'static str {
    if name == OLDER_NAME { SDK_NAME } else { name }
}

/// How long a client may take to finish its handshake, and how long the relay waits at stop
/// for its connections to pass on the SDK's close (assumptions: a loopback or LAN handshake
/// takes milliseconds; a close needs one write).
const HANDSHAKE_S: u64 = 10;
const CLOSE_GRACE_MS: u64 = 500;

/// The running relay: its thread serves until [`Relay::stop`] or drop.
pub struct Relay {
    port: u16,
    shutdown: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl Relay {
    /// Listens on `host:port` (0: a free port) and relays every client to the SDK's server at
    /// `127.0.0.1:sdk_port`. The address is bound before this returns, so a taken port is an
    /// error here, not in the relay's thread.
    ///
    /// ```no_run
    /// use jointctl_bridge::foxglove::older_clients::Relay;
    /// let relay = Relay::start("127.0.0.1", 8765, 40123)?;
    /// println!("ws://127.0.0.1:{}", relay.port());
    /// relay.stop();
    /// # Ok::<(), jointctl_bridge::foxglove::older_clients::RelayError>(())
    /// ```
    pub fn start(host: &str, port: u16, sdk_port: u16) -> Result<Relay, RelayError> {
        let bind_error = |source| RelayError::Bind { host: host.to_string(), port, source };
        let listener = StdListener::bind((host, port)).map_err(bind_error)?;
        let port = listener.local_addr().map_err(bind_error)?.port();
        listener.set_nonblocking(true).map_err(RelayError::Start)?;
        let runtime = tokio::runtime::Builder::new_current_thread().enable_io().enable_time().build().map_err(RelayError::Start)?;
        let listener = {
            let _in_runtime = runtime.enter();
            TcpListener::from_std(listener).map_err(RelayError::Start)?
        };
        let (shutdown, stopped) = oneshot::channel();
        let upstream = SocketAddr::from(([127, 0, 0, 1], sdk_port));
        let thread = std::thread::Builder::new()
            .name("foxglove-relay".into())
            .spawn(move || runtime.block_on(accept_until(listener, upstream, stopped)))
            .map_err(RelayError::Start)?;
        Ok(Relay { port, shutdown: Some(shutdown), thread: Some(thread) })
    }

    /// The public port (the one asked for, or the one picked for 0).
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Stops accepting, gives the relayed connections half a second to pass on a close (stop the
    /// SDK's server first, and its close to each client goes through), closes what is left and
    /// waits for the thread.
    pub fn stop(mut self) {
        self.stop_now();
    }

    fn stop_now(&mut self) {
        if let Some(shutdown) = self.shutdown.take() {
            let _ = shutdown.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop_now();
    }
}

/// Accepts clients until told to stop; each is relayed in a task of its own. At stop the
/// connections get a moment to pass on the SDK's close (the bridge stops the SDK's server
/// first); leaving drops the runtime with what is left, which closes those connections.
async fn accept_until(listener: TcpListener, upstream: SocketAddr, mut stop: oneshot::Receiver<()>) {
    let mut connections = tokio::task::JoinSet::new();
    loop {
        tokio::select! {
            _ = &mut stop => break,
            // Reap finished connections as they end, so the set holds the live ones only.
            Some(_) = connections.join_next(), if !connections.is_empty() => {}
            accepted = listener.accept() => match accepted {
                Ok((stream, peer)) => {
                    connections.spawn(async move {
                        if let Err(e) = relay_one(stream, upstream).await {
                            tracing::debug!(%peer, "Foxglove relay: connection ended: {e}");
                        }
                    });
                }
                Err(e) => {
                    // Out of file descriptors and the like: wait rather than spin.
                    tracing::warn!("Foxglove relay: cannot accept a client: {e}");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
            },
        }
    }
    let _ = tokio::time::timeout(Duration::from_millis(CLOSE_GRACE_MS), async { while connections.join_next().await.is_some() {} }).await;
}

/// One client: a connection to the SDK's server, the client's handshake (HTTP 502 when the SDK
/// cannot be reached, 400 for another protocol), the SDK's handshake with the client's choice,
/// then every message carried both ways until either side closes.
async fn relay_one(stream: TcpStream, upstream: SocketAddr) -> Result<(), WsError> {
    let peer = stream.peer_addr().ok();
    let _ = stream.set_nodelay(true);
    let sdk = TcpStream::connect(upstream).await.inspect_err(|e| tracing::warn!(?peer, "Foxglove relay: cannot reach the SDK's server on {upstream}: {e}"));
    let mut chosen: Option<&'static str> = None;
    // The callback's type is tungstenite's (as the SDK's handshake has it).
    #[allow(clippy::result_large_err)]
    let answer = |request: &Request, mut response: Response| -> Result<Response, ErrorResponse> {
        let refuse = |status: StatusCode, why: String| {
            let mut refusal = ErrorResponse::new(Some(why));
            *refusal.status_mut() = status;
            Err(refusal)
        };
        if sdk.is_err() {
            return refuse(StatusCode::BAD_GATEWAY, "The Foxglove SDK's server behind this relay cannot be reached".into());
        }
        let offered = request.headers().get_all(SEC_WEBSOCKET_PROTOCOL);
        match negotiate(offered.iter().filter_map(|h| h.to_str().ok())) {
            Some(name) => {
                chosen = Some(name);
                response.headers_mut().insert(SEC_WEBSOCKET_PROTOCOL, HeaderValue::from_static(name));
                Ok(response)
            }
            None => {
                tracing::info!(?peer, "Foxglove client refused: it offers none of {SDK_NAME_V1_1}, {SDK_NAME}, {OLDER_NAME}");
                refuse(StatusCode::BAD_REQUEST, format!("Offer the subprotocol {SDK_NAME_V1_1}, {SDK_NAME} or {OLDER_NAME}"))
            }
        }
    };
    let handshake = tokio::time::timeout(Duration::from_secs(HANDSHAKE_S), tokio_tungstenite::accept_hdr_async(stream, answer));
    let client = handshake.await.map_err(|_| WsError::Io(std::io::ErrorKind::TimedOut.into()))??;
    let (Ok(sdk), Some(name)) = (sdk, chosen) else { return Ok(()) };
    sdk.set_nodelay(true)?;
    // The same socket under a second descriptor, to re-arm quick ACKs while the WebSocket owns it.
    let acks: OwnedFd = sdk.as_fd().try_clone_to_owned()?;
    acknowledge_at_once(&acks);
    let mut request = format!("ws://{upstream}/").into_client_request()?;
    request.headers_mut().insert(SEC_WEBSOCKET_PROTOCOL, HeaderValue::from_static(upstream_name(name)));
    let (server, _) = tokio_tungstenite::client_async(request, sdk).await.inspect_err(|e| tracing::warn!(?peer, "Foxglove relay: the SDK's server refused the handshake: {e}"))?;
    tracing::info!(?peer, subprotocol = name, "Foxglove client connected");
    let (mut to_client, mut from_client) = client.split();
    let (mut to_server, mut from_server) = server.split();
    let down = async {
        while let Some(message) = from_server.next().await {
            acknowledge_at_once(&acks);
            if carry(&mut to_client, message?).await? {
                break;
            }
        }
        Ok::<_, WsError>(())
    };
    let up = async {
        while let Some(message) = from_client.next().await {
            if carry(&mut to_server, message?).await? {
                break;
            }
        }
        Ok::<_, WsError>(())
    };
    // Either side closing ends both; each side's close (or the reply to one) is flushed.
    let ended = tokio::select! {
        ended = down => ended,
        ended = up => ended,
    };
    let grace = Duration::from_millis(CLOSE_GRACE_MS);
    let _ = tokio::time::timeout(grace, to_client.close()).await;
    let _ = tokio::time::timeout(grace, to_server.close()).await;
    ended
}

/// Asks the kernel to acknowledge what the SDK sends at once, not after the delayed-ACK timer:
/// with Nagle's algorithm on at the SDK's end, each late acknowledgement holds back the next
/// message. Linux drops out of quick-ACK mode by itself, so this is re-armed after every read.
/// A failure only costs latency.
fn acknowledge_at_once(socket: &OwnedFd) {
    let _ = socket2::SockRef::from(socket).set_tcp_quickack(true);
}

/// Sends a data or close message on; pings and pongs stay on their own connection (tungstenite
/// answers a ping itself). True when the message was a close.
async fn carry<S>(to: &mut S, message: Message) -> Result<bool, WsError>
where
    S: futures_util::Sink<Message, Error = WsError> + Unpin,
{
    match message {
        Message::Text(_) | Message::Binary(_) => {
            to.send(message).await?;
            Ok(false)
        }
        Message::Close(frame) => {
            let _ = to.send(Message::Close(frame)).await;
            Ok(true)
        }
        Message::Ping(_) | Message::Pong(_) | Message::Frame(_) => Ok(false),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn either_name_is_answered_and_the_sdks_is_preferred() {
        assert_eq!(negotiate(["foxglove.sdk.v1.1"]), Some(SDK_NAME_V1_1));
        assert_eq!(negotiate(["foxglove.sdk.v1.1, foxglove.websocket.v1"]), Some(SDK_NAME_V1_1));
        assert_eq!((upstream_name(OLDER_NAME), upstream_name(SDK_NAME), upstream_name(SDK_NAME_V1_1)), (SDK_NAME, SDK_NAME, SDK_NAME_V1_1));
        assert_eq!(negotiate(["foxglove.websocket.v1"]), Some(OLDER_NAME));
        assert_eq!(negotiate(["foxglove.sdk.v1"]), Some(SDK_NAME));
        assert_eq!(negotiate(["foxglove.websocket.v1,foxglove.sdk.v1"]), Some(SDK_NAME));
        assert_eq!(negotiate(["foxglove.websocket.v1", " foxglove.sdk.v1 "]), Some(SDK_NAME));
        assert_eq!(negotiate(["foxglove.websocket.v2", "foxglove"]), None);
        assert_eq!(negotiate(std::iter::empty()), None);
    }

    #[test]
    fn a_taken_port_is_an_error_that_names_it() {
        let taken = StdListener::bind("127.0.0.1:0").unwrap();
        let port = taken.local_addr().unwrap().port();
        let err = Relay::start("127.0.0.1", port, 1).err().expect("the port is taken");
        assert!(err.to_string().contains(&format!("127.0.0.1:{port}")), "{err}");
    }
}
