//! The topology (`speleo_firmware::tasks::TOPOLOGY`) against the code:
//! every mailbox has a writer, each task's code touches exactly the fields
//! its row names, writing only those it declares it writes, and
//! docs/architecture.md's task table is the topology's (run with
//! `SPELEO_BLESS_DOCS=1` to rewrite it from the topology).

use std::collections::BTreeSet;

use speleo_firmware::tasks::{EXECUTIVE_READS, EXECUTIVE_WRITES, TOPOLOGY};

/// A row of the wiring: the tasks', then the mission loop's.
struct Row {
    task: &'static str,
    /// Its file under `src/tasks/` (none for the mission loop).
    file: Option<String>,
    writes: &'static [&'static str],
    reads: &'static [&'static str],
}

fn rows() -> Vec<Row> {
    let mut rows: Vec<Row> = TOPOLOGY
        .iter()
        .map(|n| Row {
            task: n.task,
            file: Some(format!("{}.rs", n.task)),
            writes: n.writes,
            reads: n.reads,
        })
        .collect();
    rows.push(Row {
        task: "executive",
        file: None,
        writes: EXECUTIVE_WRITES,
        reads: EXECUTIVE_READS,
    });
    rows
}

const SRC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src");

/// The fields of `pub struct Bus` in bus.rs.
fn bus_fields() -> BTreeSet<String> {
    let text = std::fs::read_to_string(format!("{SRC}/bus.rs")).expect("bus.rs");
    let body = text
        .split("pub struct Bus {")
        .nth(1)
        .and_then(|r| r.split("\n}").next())
        .expect("bus.rs defines Bus");
    body.lines()
        .filter_map(|l| l.trim().strip_prefix("pub "))
        .filter_map(|l| l.split(':').next())
        .map(str::to_string)
        .collect()
}

/// Calls after `bus.FIELD` that change the mailbox.
const WRITING_CALLS: [&str; 11] = [
    "publish(",
    "retract(",
    "push(",
    "push_back(",
    "clear(",
    "swap(",
    "map_mut(",
    "begin(",
    "commit(",
    "pop_newest(",
    "input(",
];

/// The fields a task's code (tests aside) touches, and those it changes.
fn touched(files: &[String]) -> (BTreeSet<String>, BTreeSet<String>) {
    let (mut all, mut written) = (BTreeSet::new(), BTreeSet::new());
    for f in files {
        let text = std::fs::read_to_string(format!("{SRC}/tasks/{f}")).expect("task file");
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        let mut rest = code;
        while let Some(at) = rest.find("bus") {
            let before = &rest[..at];
            rest = &rest[at + 3..];
            // `bus.` as a whole word only (not `self.bus.` or `rebus.`), the
            // dot maybe on the next line.
            let Some(after) = rest.trim_start().strip_prefix('.') else {
                continue;
            };
            if before
                .chars()
                .last()
                .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.')
            {
                continue;
            }
            let field: String = after
                .chars()
                .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                .collect();
            if field.is_empty() {
                continue;
            }
            let tail = after[field.len()..].trim_start();
            // A sub-field (`bus.counters.can_errors += 1`) counts as the field.
            let tail = tail
                .strip_prefix('.')
                .map(|t| {
                    let sub = t
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .count();
                    if t[sub..].starts_with('(') {
                        t
                    } else {
                        t[sub..].trim_start()
                    }
                })
                .unwrap_or(tail);
            let assigns = (tail.starts_with('=') && !tail.starts_with("=="))
                || tail.starts_with("+=")
                || tail.starts_with("-=");
            let calls_writer = WRITING_CALLS.iter().any(|c| tail.starts_with(c));
            let lent_mut = before.trim_end().ends_with("&mut");
            if assigns || calls_writer || lent_mut {
                written.insert(field.clone());
            }
            all.insert(field);
        }
    }
    (all, written)
}

#[test]
fn every_mailbox_has_a_writer_and_each_row_names_real_fields_once() {
    let rows = rows();
    let fields = bus_fields();
    assert!(
        fields.contains("plan") && fields.contains("raw"),
        "{fields:?}"
    );
    for w in &rows {
        for f in w.writes.iter().chain(w.reads) {
            assert!(fields.contains(*f), "{}: the bus has no field {f}", w.task);
        }
        for f in w.reads {
            assert!(
                !w.writes.contains(f),
                "{}: {f} both read and written: name it once, as written",
                w.task
            );
        }
    }
    for f in &fields {
        assert!(
            rows.iter().any(|w| w.writes.contains(&f.as_str())),
            "nothing writes bus.{f}"
        );
    }
}

#[test]
fn each_task_touches_the_fields_its_row_names_and_writes_only_those_it_declares() {
    for w in rows() {
        let Some(file) = &w.file else { continue };
        let (all, written) = touched(std::slice::from_ref(file));
        let declared: BTreeSet<String> = w
            .writes
            .iter()
            .chain(w.reads)
            .map(|f| f.to_string())
            .collect();
        assert_eq!(
            all, declared,
            "{}: fields touched in its code vs its row",
            w.task
        );
        for f in &written {
            assert!(
                w.writes.contains(&f.as_str()),
                "{} writes bus.{f} but its row says it only reads it",
                w.task
            );
        }
    }
}

/// How docs/architecture.md writes a task's rate.
fn rate_text(spec: &speleo_scheduler::TaskSpec, frame_hz: u32) -> String {
    let d = spec.rate.divisor;
    let mut t = if d == 1 {
        format!("{frame_hz} Hz")
    } else {
        let o = spec.rate.offset;
        format!("{} Hz (frames {o}, {}, ...)", frame_hz / d, o + d)
    };
    if spec.anytime.is_some() {
        t.push_str(", anytime");
    }
    t
}

const TABLE_HEAD: &str = "| task | rate | budget | policy | safe | writes | reads | does |";

/// docs/architecture.md's task table as the topology and the default
/// configuration's schedule give it.
fn task_table() -> String {
    let cfg = speleo_firmware::config::Config::default();
    let specs = speleo_firmware::schedule_table::specs(&cfg).expect("default table");
    let frame_hz = 1_000_000 / cfg.executive.minor_frame_us;
    let mut t = format!("{TABLE_HEAD}\n|---|---|---|---|---|---|---|---|\n");
    for (n, spec) in TOPOLOGY.iter().zip(&specs) {
        t.push_str(&format!(
            "| {} | {} | {} us | {} | {} | {} | {} | {} |\n",
            spec.name,
            rate_text(spec, frame_hz),
            spec.budget_us,
            spec.policy.as_str(),
            if spec.in_safe_mode { "yes" } else { "no" },
            n.writes.join(", "),
            n.reads.join(", "),
            n.does
        ));
    }
    t
}

#[test]
fn the_architecture_pages_task_table_is_the_topologys() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/architecture.md");
    let page = std::fs::read_to_string(path).expect("docs/architecture.md");
    let start = page.find(TABLE_HEAD).expect("the page has the task table");
    let len = page[start..]
        .split_inclusive('\n')
        .take_while(|l| l.starts_with('|'))
        .map(str::len)
        .sum::<usize>();
    let (current, wanted) = (&page[start..start + len], task_table());
    if std::env::var_os("SPELEO_BLESS_DOCS").is_some() {
        let page = format!("{}{wanted}{}", &page[..start], &page[start + len..]);
        std::fs::write(path, page).expect("docs/architecture.md written");
        return;
    }
    assert_eq!(
        current, wanted,
        "docs/architecture.md's task table differs from the topology: \
         run `SPELEO_BLESS_DOCS=1 cargo test -p speleo-firmware --test wiring` to rewrite it"
    );
}
