//! The wiring table (`speleo_firmware::wiring`) against the code: every
//! task of the schedule has a row, every mailbox a writer, and each task's
//! code touches exactly the fields its row names, writing only those it
//! declares it writes.

use std::collections::BTreeSet;

use speleo_firmware::schedule_table::TASKS;
use speleo_firmware::wiring::WIRING;

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
fn touched(files: &[&str]) -> (BTreeSet<String>, BTreeSet<String>) {
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
fn every_scheduled_task_has_a_row_in_schedule_order_and_every_mailbox_a_writer() {
    let rows: Vec<&str> = WIRING.iter().map(|w| w.task).collect();
    assert_eq!(&rows[..TASKS.len()], &TASKS[..]);
    assert_eq!(rows[TASKS.len()..], ["executive"]);
    let fields = bus_fields();
    assert!(
        fields.contains("plan") && fields.contains("raw"),
        "{fields:?}"
    );
    for w in &WIRING {
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
            WIRING.iter().any(|w| w.writes.contains(&f.as_str())),
            "nothing writes bus.{f}"
        );
    }
}

#[test]
fn each_task_touches_the_fields_its_row_names_and_writes_only_those_it_declares() {
    for w in WIRING.iter().filter(|w| !w.files.is_empty()) {
        let (all, written) = touched(w.files);
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

#[test]
fn the_architecture_pages_task_table_is_the_schedule_and_the_wiring() {
    let cfg = speleo_firmware::config::Config::default();
    let specs = speleo_firmware::schedule_table::specs(&cfg).expect("default table");
    let frame_hz = 1_000_000 / cfg.executive.minor_frame_us;
    let page = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/architecture.md"
    ))
    .expect("docs/architecture.md");
    let rows: Vec<Vec<String>> = page
        .split("| task | rate | budget | policy | safe | writes | reads | does |")
        .nth(1)
        .expect("the page has the task table")
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.split('|').map(|c| c.trim().to_string()).collect())
        .collect();
    let names: Vec<&str> = rows.iter().map(|r| r[1].as_str()).collect();
    assert_eq!(names, TASKS, "the page's tasks, in order");
    for (row, spec) in rows.iter().zip(&specs) {
        let w = WIRING
            .iter()
            .find(|w| w.task == spec.name.as_str())
            .expect("a wiring row");
        let expected = [
            spec.name.to_string(),
            rate_text(spec, frame_hz),
            format!("{} us", spec.budget_us),
            spec.policy.as_str().to_string(),
            if spec.in_safe_mode { "yes" } else { "no" }.to_string(),
            w.writes.join(", "),
            w.reads.join(", "),
        ];
        assert_eq!(
            row[1..8],
            expected,
            "docs/architecture.md, task {}",
            spec.name
        );
    }
}
