//! The live view: a WebSocket client speaking the Foxglove protocol
//! connects to a running simulation, is greeted and told the channels,
//! subscribes and receives CDR messages; a viewer that never reads costs
//! counted drops; neither changes the mission's output.

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

type Viewer = WebSocket<MaybeTlsStream<TcpStream>>;

fn sim(args: &[&str], report: &std::path::Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args([
            "sim",
            "--world",
            "short-tube",
            "--duration",
            "60",
            "--no-progress",
        ])
        .args(args)
        .arg("--report")
        .arg(report)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("speleo runs")
}

/// The address the server logs when it starts listening.
fn address(child: &mut Child) -> String {
    let err = child.stderr.take().expect("stderr");
    let mut lines = BufReader::new(err).lines();
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(120) {
        let Some(Ok(line)) = lines.next() else { break };
        if let Some(at) = line.find("ws://") {
            let addr: String = line[at + 5..]
                .chars()
                .take_while(|c| !c.is_whitespace())
                .collect();
            // Keep draining stderr so the child never blocks on it.
            std::thread::spawn(move || lines.for_each(drop));
            return addr;
        }
    }
    panic!("the live view never said where it listens");
}

fn connect(addr: &str) -> Viewer {
    let mut req = format!("ws://{addr}")
        .into_client_request()
        .expect("request");
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().expect("header"),
    );
    let (ws, resp) = tungstenite::connect(req).expect("the viewer connects");
    assert_eq!(
        resp.headers()["Sec-WebSocket-Protocol"],
        "foxglove.websocket.v1"
    );
    ws
}

fn text(ws: &mut Viewer) -> serde_json::Value {
    match ws.read().expect("a message") {
        Message::Text(t) => serde_json::from_str(t.as_str()).expect("JSON"),
        other => panic!("expected text, got {other:?}"),
    }
}

/// Subscribe to `topics`, numbering the subscriptions from 1; returns the
/// (subscription, topic) pairs.
fn subscribe(
    ws: &mut Viewer,
    channels: &[serde_json::Value],
    topics: &[&str],
) -> Vec<(u32, String)> {
    let subs: Vec<(u32, u64, String)> = channels
        .iter()
        .filter(|c| topics.contains(&c["topic"].as_str().unwrap_or("")))
        .enumerate()
        .map(|(i, c)| {
            let id = c["id"].as_u64().expect("id");
            (
                i as u32 + 1,
                id,
                c["topic"].as_str().unwrap_or("").to_string(),
            )
        })
        .collect();
    let req: Vec<_> = subs
        .iter()
        .map(|(s, c, _)| serde_json::json!({"id": s, "channelId": c}))
        .collect();
    ws.send(Message::text(
        serde_json::json!({"op": "subscribe", "subscriptions": req}).to_string(),
    ))
    .expect("subscribe");
    subs.into_iter().map(|(s, _, t)| (s, t)).collect()
}

fn read_json(p: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).expect("report")).expect("json")
}

#[test]
fn a_foxglove_client_subscribes_and_receives_and_the_mission_is_unchanged() {
    let d = tempfile::tempdir().expect("tmp");
    let (with, without) = (d.path().join("live.json"), d.path().join("alone.json"));
    let mut child = sim(&["--live", "127.0.0.1:0"], &with);
    let addr = address(&mut child);

    let mut ws = connect(&addr);
    let info = text(&mut ws);
    assert_eq!(info["op"], "serverInfo");
    let adv = text(&mut ws);
    assert_eq!(adv["op"], "advertise");
    let channels = adv["channels"].as_array().expect("channels").clone();
    let odom = channels
        .iter()
        .find(|c| c["topic"] == "/odom")
        .expect("/odom advertised");
    assert_eq!(odom["schemaName"], "nav_msgs/msg/Odometry");
    assert_eq!(odom["encoding"], "cdr");
    let subs = subscribe(&mut ws, &channels, &["/odom", "/tf"]);
    assert_eq!(subs.len(), 2);

    // A second viewer subscribes to the LiDAR packets and never reads.
    let mut idle = connect(&addr);
    let _ = (text(&mut idle), text(&mut idle));
    subscribe(&mut idle, &channels, &["/raw/lidar", "/lidar/points"]);

    let mut received = std::collections::BTreeMap::<String, u64>::new();
    let mut last_time = 0u64;
    loop {
        match ws.read() {
            Ok(Message::Binary(b)) => {
                assert_eq!(b[0], 1, "message data opcode");
                let sub = u32::from_le_bytes(b[1..5].try_into().expect("4 bytes"));
                let time = u64::from_le_bytes(b[5..13].try_into().expect("8 bytes"));
                let topic = &subs
                    .iter()
                    .find(|(s, _)| *s == sub)
                    .expect("our subscription")
                    .1;
                // Plain little-endian CDR, as recorded.
                assert_eq!(&b[13..15], &[0, 1], "{topic}");
                assert!(
                    time >= last_time || topic == "/tf",
                    "{topic}: time went back"
                );
                last_time = last_time.max(time);
                *received.entry(topic.clone()).or_default() += 1;
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    let status = child.wait().expect("exit");
    assert!(status.success(), "{status:?}");
    eprintln!("received {received:?}");
    assert!(
        received.get("/odom").copied().unwrap_or(0) > 100,
        "{received:?}"
    );
    assert!(
        received.get("/tf").copied().unwrap_or(0) > 100,
        "{received:?}"
    );
    drop(idle);

    let r = read_json(&with);
    assert_eq!(r["live"]["viewers"], 2, "{}", r["live"]);
    assert!(
        r["live"]["sent"].as_u64().expect("sent") > 200,
        "{}",
        r["live"]
    );
    assert!(
        r["live"]["dropped"].as_u64().expect("dropped") > 0,
        "{}",
        r["live"]
    );
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);

    let status = sim(&[], &without).wait().expect("exit");
    assert!(status.success());
    let alone = read_json(&without);
    assert_eq!(r["output_hash"], alone["output_hash"]);
    assert_eq!(r["frames"], alone["frames"]);
}

#[test]
fn a_busy_or_bad_live_address_is_refused_before_the_mission() {
    let d = tempfile::tempdir().expect("tmp");
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = taken.local_addr().expect("addr").to_string();
    for bad in [addr.as_str(), "not-an-address"] {
        let out = Command::new(env!("CARGO_BIN_EXE_speleo"))
            .args(["sim", "--duration", "5", "--no-progress", "--live", bad])
            .arg("--report")
            .arg(d.path().join("r.json"))
            .output()
            .expect("speleo runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains("--live") && err.contains(bad), "{bad}: {err}");
        assert!(!d.path().join("r.json").exists(), "{bad}: the mission ran");
    }
}
