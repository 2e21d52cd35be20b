//! The WebSocket server of the live view: an acceptor thread, one thread per
//! viewer, and `offer`, which the recorder's writer thread calls with every
//! message.

use std::io::ErrorKind;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tungstenite::{Message, WebSocket};

use super::protocol::{self, ClientOp, SUBPROTOCOL};
use crate::record::Topic;

/// Messages waiting for one viewer; beyond this they are dropped and counted.
const QUEUE: usize = 4096;
/// How long a viewer thread waits for the viewer's requests before sending
/// what is queued.
const POLL: Duration = Duration::from_millis(5);
/// Longest a viewer's socket may block a write; a viewer that takes its
/// data slower than it comes keeps what is buffered and loses the rest.
const WRITE_WAIT: Duration = Duration::from_millis(20);
/// Longest the handshake may take.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(2);
/// At the end, how long a viewer's buffered data may take to leave.
const LAST_FLUSH: Duration = Duration::from_secs(1);
/// Bytes buffered for one viewer beyond what its socket took.
const MAX_BUFFERED: usize = 8 << 20;
/// Longest wait of the acceptor between two looks at the listening socket.
const ACCEPT_NAP: Duration = Duration::from_millis(20);

/// What the live view did, for the run's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct LiveCounters {
    /// Viewers that connected.
    pub viewers: u64,
    /// Messages sent to viewers (one per viewer subscribed).
    pub sent: u64,
    /// Messages a viewer's full queue refused.
    pub dropped: u64,
    /// Connections refused (not a WebSocket, or without the Foxglove
    /// subprotocol).
    pub refused: u64,
}

#[derive(Default)]
struct Counters {
    viewers: AtomicU64,
    sent: AtomicU64,
    dropped: AtomicU64,
    refused: AtomicU64,
}

/// One connected viewer as the writer thread sees it.
struct Viewer {
    /// Subscription id per channel (index: `Topic as usize`).
    subscriptions: Mutex<[Option<u32>; Topic::ALL.len()]>,
    queue: SyncSender<Vec<u8>>,
    gone: AtomicBool,
}

#[derive(Default)]
struct Shared {
    viewers: Mutex<Vec<Arc<Viewer>>>,
    threads: Mutex<Vec<JoinHandle<()>>>,
    stop: AtomicBool,
    counters: Counters,
}

pub struct LiveServer {
    shared: Arc<Shared>,
    address: SocketAddr,
    acceptor: Option<JoinHandle<()>>,
}

impl LiveServer {
    /// Listen on `address` (`HOST:PORT`; port 0 picks a free one). A bad or
    /// busy address is an error here, before the mission starts.
    pub fn start(address: &str) -> Result<LiveServer, String> {
        let listener = TcpListener::bind(address)
            .map_err(|e| format!("--live {address}: cannot listen: {e}"))?;
        let address = listener
            .local_addr()
            .map_err(|e| format!("--live {address}: {e}"))?;
        listener
            .set_nonblocking(true)
            .map_err(|e| format!("--live {address}: {e}"))?;
        let shared = Arc::new(Shared::default());
        let s = Arc::clone(&shared);
        let acceptor = std::thread::Builder::new()
            .name("live-accept".into())
            .spawn(move || accept(listener, s))
            .map_err(|e| format!("cannot start the live view: {e}"))?;
        Ok(LiveServer {
            shared,
            address,
            acceptor: Some(acceptor),
        })
    }

    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// Hand one recorded message to every viewer subscribed to its channel.
    /// Never waits: a full queue drops the message and counts it.
    pub fn offer(&self, topic: Topic, log_time_ns: u64, data: &[u8]) {
        let Ok(viewers) = self.shared.viewers.lock() else {
            return;
        };
        for v in viewers.iter() {
            if v.gone.load(Ordering::Relaxed) {
                continue;
            }
            let sub = v
                .subscriptions
                .lock()
                .ok()
                .and_then(|s| s.get(topic as usize).copied().flatten());
            let Some(sub) = sub else {
                continue;
            };
            match v
                .queue
                .try_send(protocol::message_data(sub, log_time_ns, data))
            {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    self.shared.counters.dropped.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => v.gone.store(true, Ordering::Relaxed),
            }
        }
    }

    pub fn counters(&self) -> LiveCounters {
        let c = &self.shared.counters;
        LiveCounters {
            viewers: c.viewers.load(Ordering::Relaxed),
            sent: c.sent.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            refused: c.refused.load(Ordering::Relaxed),
        }
    }

    /// Send what is queued, close every connection and stop listening.
    pub fn stop(mut self) -> LiveCounters {
        self.shutdown();
        self.counters()
    }

    fn shutdown(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(a) = self.acceptor.take() {
            let _ = a.join();
        }
        let threads = self
            .shared
            .threads
            .lock()
            .map(|mut t| std::mem::take(&mut *t))
            .unwrap_or_default();
        for t in threads {
            let _ = t.join();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}

fn accept(listener: TcpListener, shared: Arc<Shared>) {
    while !shared.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                let s = Arc::clone(&shared);
                let spawned = std::thread::Builder::new()
                    .name("live-viewer".into())
                    .spawn(move || serve(stream, s));
                if let (Ok(t), Ok(mut threads)) = (spawned, shared.threads.lock()) {
                    threads.push(t);
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(ACCEPT_NAP),
            Err(e) => {
                tracing::warn!("live view: accept failed: {e}");
                std::thread::sleep(ACCEPT_NAP);
            }
        }
    }
}

/// The WebSocket handshake, with time limits so a stalled peer cannot hold
/// the thread.
fn handshake(stream: TcpStream) -> Option<WebSocket<TcpStream>> {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT));
    let _ = stream.set_write_timeout(Some(HANDSHAKE_TIMEOUT));
    let config =
        tungstenite::protocol::WebSocketConfig::default().max_write_buffer_size(MAX_BUFFERED);
    tungstenite::accept_hdr_with_config(stream, check_subprotocol, Some(config)).ok()
}

/// Accept a viewer that offers the Foxglove subprotocol, answering with it.
// The signature is tungstenite's handshake callback.
#[allow(clippy::result_large_err)]
fn check_subprotocol(req: &Request, mut resp: Response) -> Result<Response, ErrorResponse> {
    let offered = req
        .headers()
        .get_all("Sec-WebSocket-Protocol")
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|p| p.trim() == SUBPROTOCOL);
    if !offered {
        let mut refusal = ErrorResponse::new(Some(format!(
            "this server speaks the {SUBPROTOCOL} subprotocol only"
        )));
        *refusal.status_mut() = tungstenite::http::StatusCode::BAD_REQUEST;
        return Err(refusal);
    }
    resp.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        tungstenite::http::HeaderValue::from_static(SUBPROTOCOL),
    );
    Ok(resp)
}

/// One viewer: greet, advertise, then alternate between its requests and
/// its queue until it leaves or the server stops.
fn serve(stream: TcpStream, shared: Arc<Shared>) {
    let Some(mut ws) = handshake(stream) else {
        shared.counters.refused.fetch_add(1, Ordering::Relaxed);
        return;
    };
    shared.counters.viewers.fetch_add(1, Ordering::Relaxed);
    let (tx, rx) = sync_channel(QUEUE);
    let viewer = Arc::new(Viewer {
        subscriptions: Mutex::new([None; Topic::ALL.len()]),
        queue: tx,
        gone: AtomicBool::new(false),
    });
    let session = format!("speleo-{}", std::process::id());
    let greeted = ws
        .send(Message::text(protocol::server_info(&session)))
        .and_then(|()| ws.send(Message::text(protocol::advertise())));
    if greeted.is_err() {
        return;
    }
    if let Ok(mut v) = shared.viewers.lock() {
        v.push(Arc::clone(&viewer));
    }
    let _ = ws.get_ref().set_read_timeout(Some(POLL));
    let _ = ws.get_ref().set_write_timeout(Some(WRITE_WAIT));
    let ended = talk(&mut ws, &viewer, &rx, &shared);
    viewer.gone.store(true, Ordering::Relaxed);
    if let Ok(mut v) = shared.viewers.lock() {
        v.retain(|x| !Arc::ptr_eq(x, &viewer));
    }
    if !ended {
        let _ = ws.close(None);
        let _ = ws.flush();
    }
}

/// The socket took less than was written (a timeout, not a failure).
fn would_block(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(io) if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut))
}

/// Returns true when the viewer closed the connection.
fn talk(
    ws: &mut WebSocket<TcpStream>,
    viewer: &Viewer,
    rx: &Receiver<Vec<u8>>,
    shared: &Shared,
) -> bool {
    // Data written to the connection that its socket has not taken yet:
    // nothing more is written until it has.
    let mut backlog = false;
    loop {
        match ws.read() {
            Ok(Message::Text(t)) => handle(viewer, t.as_str()),
            Ok(Message::Close(_)) => return true,
            Ok(_) => {}
            Err(e) if would_block(&e) => {}
            Err(_) => return true,
        }
        if backlog {
            match ws.flush() {
                Ok(()) => backlog = false,
                Err(e) if would_block(&e) => {}
                Err(_) => return true,
            }
        }
        if !backlog {
            match send_queued(ws, rx, &shared.counters) {
                Ok(b) => backlog = b,
                Err(()) => return true,
            }
        }
        if shared.stop.load(Ordering::Relaxed) {
            let until = std::time::Instant::now() + LAST_FLUSH;
            while backlog && std::time::Instant::now() < until {
                backlog = matches!(ws.flush(), Err(ref e) if would_block(e));
            }
            return false;
        }
    }
}

/// Write what the viewer's queue holds. Ok(true) when the socket could not
/// take it all (the rest stays queued or counts as dropped).
fn send_queued(
    ws: &mut WebSocket<TcpStream>,
    rx: &Receiver<Vec<u8>>,
    counters: &Counters,
) -> Result<bool, ()> {
    let mut wrote = false;
    while let Ok(frame) = rx.try_recv() {
        match ws.write(Message::binary(frame)) {
            Ok(()) => {
                counters.sent.fetch_add(1, Ordering::Relaxed);
                wrote = true;
            }
            // Buffered, but the socket is full.
            Err(e) if would_block(&e) => {
                counters.sent.fetch_add(1, Ordering::Relaxed);
                return Ok(true);
            }
            Err(tungstenite::Error::WriteBufferFull(_)) => {
                counters.dropped.fetch_add(1, Ordering::Relaxed);
                return Ok(true);
            }
            Err(_) => return Err(()),
        }
    }
    if !wrote {
        return Ok(false);
    }
    match ws.flush() {
        Ok(()) => Ok(false),
        Err(e) if would_block(&e) => Ok(true),
        Err(_) => Err(()),
    }
}

fn handle(viewer: &Viewer, text: &str) {
    let Ok(mut subs) = viewer.subscriptions.lock() else {
        return;
    };
    match protocol::parse_client_op(text) {
        Ok(ClientOp::Subscribe(pairs)) => {
            for (id, channel) in pairs {
                if let Some(t) = Topic::from_channel_id(channel) {
                    subs[t as usize] = Some(id);
                }
            }
        }
        Ok(ClientOp::Unsubscribe(ids)) => {
            for s in subs.iter_mut() {
                if s.is_some_and(|x| ids.contains(&x)) {
                    *s = None;
                }
            }
        }
        Ok(ClientOp::Other(op)) => tracing::debug!("live view: {op} is not offered"),
        Err(e) => tracing::warn!("live view: a viewer sent {e}"),
    }
}
