//! Replay's judge: every output the replay produces must equal, byte for
//! byte, the output recorded on the same topic in the same frame.

use super::cdr_json::decode;
use super::msg_def::MessageDefs;
use super::topics::Topic;
use super::writer::MESSAGE_CAPACITY;

/// One recorded output.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExpectedMessage {
    pub frame: u64,
    pub data: Vec<u8>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DivergenceKind {
    /// Both have the message; the content differs.
    Differs { expected: usize },
    /// The replay produced a message the recording does not have.
    Extra,
    /// The recording has a message the replay did not produce.
    Missing { expected: usize },
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Divergence {
    pub topic: Topic,
    pub frame: u64,
    pub kind: DivergenceKind,
}

pub struct Comparer {
    expected: Vec<Vec<ExpectedMessage>>,
    cursor: Vec<usize>,
    /// Frames after this are not compared (the open chunk of a killed run).
    last_frame: u64,
    divergence: Option<Divergence>,
    /// The replayed content at the divergence (capacity fixed at start-up).
    actual: Vec<u8>,
    pub compared: u64,
}

impl Comparer {
    /// `expected[i]` holds the outputs of topic `Topic::ALL[i]` in order;
    /// `largest` is the size of the largest message (kept at a divergence).
    pub fn new(expected: Vec<Vec<ExpectedMessage>>, last_frame: u64, largest: usize) -> Self {
        let n = expected.len();
        Comparer {
            expected,
            cursor: vec![0; n],
            last_frame,
            divergence: None,
            actual: Vec::with_capacity(largest.max(MESSAGE_CAPACITY)),
            compared: 0,
        }
    }

    pub fn last_frame(&self) -> u64 {
        self.last_frame
    }

    pub fn divergence(&self) -> Option<&Divergence> {
        self.divergence.as_ref()
    }

    fn diverge(&mut self, topic: Topic, frame: u64, kind: DivergenceKind, actual: &[u8]) {
        // Within one frame, keep the most upstream topic, so the report
        // names the cause, not a consequence.
        if let Some(d) = &self.divergence {
            let key = |t: Topic| (t.flow_rank(), t as usize);
            if d.frame < frame || (d.frame == frame && key(d.topic) <= key(topic)) {
                return;
            }
        }
        self.actual.clear();
        let n = actual.len().min(self.actual.capacity());
        self.actual.extend_from_slice(&actual[..n]);
        self.divergence = Some(Divergence { topic, frame, kind });
    }

    /// Is the run already known to differ before `frame`?
    fn settled_before(&self, frame: u64) -> bool {
        self.divergence.as_ref().is_some_and(|d| d.frame < frame)
    }

    pub fn check(&mut self, topic: Topic, frame: u64, data: &[u8]) {
        if self.settled_before(frame) || frame > self.last_frame {
            return;
        }
        let t = topic as usize;
        let Some(queue) = self.expected.get(t) else {
            return;
        };
        let i = self.cursor[t];
        match queue.get(i) {
            Some(e) if e.frame == frame && e.data == data => {
                self.cursor[t] += 1;
                self.compared += 1;
            }
            Some(e) if e.frame == frame => {
                self.diverge(topic, frame, DivergenceKind::Differs { expected: i }, data)
            }
            Some(e) if e.frame < frame => {
                let f = e.frame;
                self.diverge(topic, f, DivergenceKind::Missing { expected: i }, &[])
            }
            _ => self.diverge(topic, frame, DivergenceKind::Extra, data),
        }
    }

    /// At the end of each frame: recorded outputs of this frame (or earlier)
    /// that the replay did not produce.
    pub fn end_frame(&mut self, frame: u64) {
        if self.settled_before(frame) || frame > self.last_frame {
            return;
        }
        for t in 0..self.expected.len() {
            let i = self.cursor[t];
            if let Some(e) = self.expected[t].get(i) {
                if e.frame <= frame {
                    let f = e.frame;
                    self.diverge(
                        Topic::ALL[t],
                        f,
                        DivergenceKind::Missing { expected: i },
                        &[],
                    );
                }
            }
        }
    }

    /// After the last frame: recorded outputs the replay never produced.
    pub fn finish(&mut self) {
        if self.divergence.is_some() {
            return;
        }
        let mut first: Option<(u64, usize, usize)> = None;
        for (t, q) in self.expected.iter().enumerate() {
            if let Some(e) = q.get(self.cursor[t]) {
                if e.frame <= self.last_frame && first.is_none_or(|(f, _, _)| e.frame < f) {
                    first = Some((e.frame, t, self.cursor[t]));
                }
            }
        }
        if let Some((frame, t, i)) = first {
            self.diverge(
                Topic::ALL[t],
                frame,
                DivergenceKind::Missing { expected: i },
                &[],
            );
        }
    }

    /// A sentence for the user: topic, frame, and the first differing field.
    pub fn describe(&self) -> Option<String> {
        let d = self.divergence.as_ref()?;
        let name = d.topic.info().name;
        let queue = &self.expected[d.topic as usize];
        Some(match &d.kind {
            DivergenceKind::Differs { expected } => {
                let rec = &queue[*expected].data;
                let (field, a, b) = first_difference(d.topic, rec, &self.actual);
                format!(
                    "divergence: topic {name}, frame {}, field {field}: recorded {a}, replayed {b}",
                    d.frame
                )
            }
            DivergenceKind::Extra => format!(
                "divergence: topic {name}, frame {}: the replay produced a message the recording does not have",
                d.frame
            ),
            DivergenceKind::Missing { .. } => format!(
                "divergence: topic {name}, frame {}: the recording has a message the replay did not produce",
                d.frame
            ),
        })
    }
}

/// The path of the first field whose value differs, with both values, read
/// through the topic's schema.
pub fn first_difference(
    topic: Topic,
    recorded: &[u8],
    replayed: &[u8],
) -> (String, String, String) {
    let info = topic.info();
    let defs = MessageDefs::parse(info.schema, info.schema_data);
    let parse = |b: &[u8]| match &defs {
        Ok(d) => decode(d, b).map_err(|e| e.to_string()),
        Err(e) => Err(e.clone()),
    };
    match (parse(recorded), parse(replayed)) {
        (Ok(a), Ok(b)) => {
            let mut path = String::new();
            match walk(&a, &b, &mut path) {
                Some((x, y)) => (
                    if path.is_empty() {
                        "(whole message)".into()
                    } else {
                        path
                    },
                    x,
                    y,
                ),
                None => ("(formatting)".into(), "-".into(), "-".into()),
            }
        }
        _ => {
            let at = recorded
                .iter()
                .zip(replayed)
                .position(|(a, b)| a != b)
                .unwrap_or(recorded.len().min(replayed.len()));
            (
                format!("byte {at}"),
                format!("{} bytes", recorded.len()),
                format!("{} bytes", replayed.len()),
            )
        }
    }
}

fn walk(
    a: &serde_json::Value,
    b: &serde_json::Value,
    path: &mut String,
) -> Option<(String, String)> {
    use serde_json::Value;
    if a == b {
        return None;
    }
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                let len = path.len();
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(k);
                match y.get(k) {
                    Some(vb) => {
                        if let Some(d) = walk(va, vb, path) {
                            return Some(d);
                        }
                    }
                    None => return Some((va.to_string(), "(absent)".into())),
                }
                path.truncate(len);
            }
            let extra = y.keys().find(|k| !x.contains_key(*k))?;
            if !path.is_empty() {
                path.push('.');
            }
            path.push_str(extra);
            Some(("(absent)".into(), y[extra].to_string()))
        }
        (Value::Array(x), Value::Array(y)) => {
            for (i, (va, vb)) in x.iter().zip(y).enumerate() {
                let len = path.len();
                path.push_str(&format!("[{i}]"));
                if let Some(d) = walk(va, vb, path) {
                    return Some(d);
                }
                path.truncate(len);
            }
            Some((format!("{} items", x.len()), format!("{} items", y.len())))
        }
        _ => Some((a.to_string(), b.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(frame: u64, s: &str) -> ExpectedMessage {
        ExpectedMessage {
            frame,
            data: s.as_bytes().to_vec(),
        }
    }

    fn comparer(odom: Vec<ExpectedMessage>) -> Comparer {
        let mut e = vec![Vec::new(); Topic::ALL.len()];
        e[Topic::Odom as usize] = odom;
        Comparer::new(e, 10, 0)
    }

    #[test]
    fn identical_streams_pass() {
        let mut c = comparer(vec![msg(1, "{\"a\":1}"), msg(2, "{\"a\":2}")]);
        c.check(Topic::Odom, 1, b"{\"a\":1}");
        c.check(Topic::Odom, 2, b"{\"a\":2}");
        c.finish();
        assert!(c.divergence().is_none());
        assert_eq!(c.compared, 2);
    }

    #[test]
    fn a_changed_field_is_named() {
        use crate::record::encode::Time;
        let pose = |y: f64| {
            let mut v = Vec::new();
            let t = Time { sec: 1, nsec: 0 };
            crate::record::ros2::pose_stamped(
                &mut v,
                t,
                "map",
                [1.0, y, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            )
            .expect("write");
            v
        };
        let mut e = vec![Vec::new(); Topic::ALL.len()];
        e[Topic::SlamPose as usize] = vec![ExpectedMessage {
            frame: 1,
            data: pose(2.0),
        }];
        let mut c = Comparer::new(e, 10, 0);
        c.check(Topic::SlamPose, 1, &pose(2.5));
        let d = c.describe().expect("diverged");
        assert!(d.contains("/slam/pose"), "{d}");
        assert!(d.contains("frame 1"), "{d}");
        assert!(d.contains("pose.position.y"), "{d}");
        assert!(d.contains("2.5"), "{d}");
    }

    #[test]
    fn missing_and_extra_messages() {
        let mut c = comparer(vec![msg(1, "{}"), msg(2, "{}")]);
        c.check(Topic::Odom, 1, b"{}");
        c.finish();
        assert!(matches!(
            c.divergence(),
            Some(Divergence {
                frame: 2,
                kind: DivergenceKind::Missing { .. },
                ..
            })
        ));
        let mut c = comparer(vec![msg(3, "{}")]);
        c.check(Topic::Odom, 1, b"{}");
        assert!(matches!(
            c.divergence(),
            Some(Divergence {
                frame: 1,
                kind: DivergenceKind::Extra,
                ..
            })
        ));
    }

    #[test]
    fn the_most_upstream_topic_of_a_frame_is_reported() {
        let mut e = vec![Vec::new(); Topic::ALL.len()];
        e[Topic::Imu as usize] = vec![msg(5, "{}"), msg(6, "{}")];
        e[Topic::Odom as usize] = vec![msg(5, "{\"x\":1}")];
        let mut c = Comparer::new(e, 10, 0);
        // The IMU sample of frame 5 is missing; odometry differs as a result.
        c.check(Topic::Odom, 5, b"{\"x\":2}");
        c.end_frame(5);
        assert_eq!(
            c.divergence().map(|d| (d.topic, d.frame)),
            Some((Topic::Imu, 5))
        );
    }

    #[test]
    fn frames_past_the_last_complete_one_are_not_judged() {
        let mut c = comparer(vec![msg(11, "{}")]);
        c.check(Topic::Odom, 11, b"{\"x\":1}");
        c.finish();
        assert!(c.divergence().is_none());
    }
}
