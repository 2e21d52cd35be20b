//! A validation recorded as a case file replays to the same verdict and
//! prediction, and a damaged case file is refused with a reason.

use std::cell::RefCell;

use speleo_simulator::{
    CaseError, CloudSource, InternalSim, Outcome, RecordingClouds, SimulatorParams, Stance,
    ValidationCase,
};

/// Ground at 0 with a 0.45 m ledge at x = 2 (refused) seen from sensors
/// 1 m over it, with the ledge's face.
struct Ledge {
    origins: Vec<[f64; 3]>,
    points: Vec<[f64; 3]>,
}

fn z(x: f64) -> f64 {
    if x > 2.0 {
        0.45
    } else {
        0.0
    }
}

impl Ledge {
    fn new() -> Ledge {
        let mut points = Vec::new();
        for i in 0..160 {
            let x = -2.0 + 0.05 * i as f64;
            for j in 0..60 {
                let y = -1.5 + 0.05 * j as f64;
                points.push([x, y, z(x)]);
                let mut h = 0.05;
                while (x - 2.0).abs() < 0.03 && h < 0.45 {
                    points.push([2.0, y, h]);
                    h += 0.05;
                }
            }
        }
        Ledge {
            origins: vec![[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [40.0, 0.0, 1.0]],
            points,
        }
    }
}

impl CloudSource for Ledge {
    fn keyframes(&self) -> usize {
        self.origins.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.origins.get(k).copied()
    }
    fn points(&self, _k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let to = (from + n).min(self.points.len());
        out.extend_from_slice(&self.points[from.min(to)..to]);
        to < self.points.len()
    }
    fn intensities(&self, _k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        out.clear();
        let to = (from + n).min(self.points.len());
        out.extend((from.min(to)..to).map(|i| (i % 200) as u8 + 1));
    }
}

fn plan() -> Vec<[f64; 4]> {
    (0..=30)
        .map(|i| [0.1 * i as f64, 0.0, z(0.1 * i as f64), 0.0])
        .collect()
}

/// Standing a little pitched and rolled: the attitude is part of a case.
fn start() -> Stance {
    Stance {
        pitch: 0.01,
        roll: -0.02,
        ..Stance::level(0.0, 0.0, SimulatorParams::default().base_height_m, 0.0)
    }
}

/// A validation's outcome, predicted track and driving time.
type Run = (Outcome, Vec<[f64; 3]>, f64);

fn validate(sim: &mut InternalSim, clouds: &impl CloudSource) -> Run {
    sim.begin(start(), plan());
    drive(sim, clouds)
}

/// The validation begun in `sim` to its verdict.
fn drive(sim: &mut InternalSim, clouds: &impl CloudSource) -> Run {
    let mut steps = 0;
    let v = loop {
        if let Some(v) = sim.step(clouds, 13) {
            break v;
        }
        steps += 1;
        assert!(steps < 2_000_000, "no verdict");
    };
    (v.outcome, sim.prediction().to_vec(), v.drive_s)
}

/// The ledge validated through the recorder, and the case it wrote.
fn recorded() -> (Run, Vec<u8>) {
    let scans = Ledge::new();
    let case = RefCell::new(ValidationCase::default());
    case.borrow_mut().begin(42, start(), false, plan());
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    sim.begin(start(), plan());
    let got = {
        let rec = RecordingClouds {
            inner: &scans,
            case: &case,
            keep: sim.read_region(),
        };
        drive(&mut sim, &rec)
    };
    let mut case = case.into_inner();
    case.verdict = sim.verdict();
    let mut bytes = Vec::new();
    case.write(&mut bytes).expect("write");
    (got, bytes)
}

#[test]
fn a_recorded_validation_replays_to_the_same_verdict_and_prediction() {
    let (live, bytes) = recorded();
    assert_ne!(live.0, Outcome::Reached, "the ledge is refused");
    let case = ValidationCase::read(&mut bytes.as_slice()).expect("read");
    assert_eq!(case.plan, plan());
    assert_eq!(case.start, start());
    assert_eq!(case.began_ns, 42);
    assert_eq!(case.verdict.map(|v| v.outcome), Some(live.0));
    assert_eq!(case.keyframes.len(), 3);
    assert!(
        case.keyframes[2].points.is_empty(),
        "the keyframe 40 m off is not read, only its origin"
    );
    for k in &case.keyframes {
        assert_eq!(
            k.intensities.len(),
            k.points.len(),
            "an intensity a point kept"
        );
    }
    assert!(case.keyframes[0].intensities.iter().any(|&i| i > 1));
    let read = 2 * Ledge::new().points.len();
    assert!(
        case.points() > read / 2 && case.points() < read,
        "only the points in the box are kept: {} of {read}",
        case.points()
    );
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    let replayed = validate(&mut sim, &case);
    assert_eq!(replayed.0, live.0);
    assert_eq!(replayed.1, live.1, "the same predicted track");
    assert_eq!(replayed.2.to_bits(), live.2.to_bits());
    let world = sim.world_mesh().expect("a world");
    assert!(world.triangle_count() > 100, "{}", world.triangle_count());
    assert!(sim.rover_state().is_some());
}

#[test]
fn a_damaged_case_is_refused_with_its_reason() {
    let (_, bytes) = recorded();
    let cut = ValidationCase::read(&mut &bytes[..bytes.len() - 5]).expect_err("refused");
    assert!(matches!(cut, CaseError::Io(_)), "{cut}");
    assert!(cut.to_string().contains("cut short"), "{cut}");
    let not = ValidationCase::read(&mut &b"PLY\nformat"[..]).expect_err("refused");
    assert!(matches!(not, CaseError::NotACase), "{not}");
    let mut newer = bytes.clone();
    newer[8] = 9;
    let v = ValidationCase::read(&mut newer.as_slice()).expect_err("refused");
    assert!(matches!(v, CaseError::Version(9)), "{v}");
    // The plan's pose count, just after the magic, version, time, start
    // and the way-back byte.
    let mut huge = bytes.clone();
    huge[69..73].copy_from_slice(&u32::MAX.to_le_bytes());
    let h = ValidationCase::read(&mut huge.as_slice()).expect_err("refused");
    assert!(matches!(h, CaseError::Count { .. }), "{h}");
    let mut outcome = bytes;
    let at = 73 + plan().len() * 32;
    outcome[at] = 77;
    let o = ValidationCase::read(&mut outcome.as_slice()).expect_err("refused");
    assert!(matches!(o, CaseError::Outcome(77)), "{o}");
}

/// The case's bytes with no keyframes: the same in every version.
fn without_keyframes(bytes: &[u8]) -> Vec<u8> {
    let at = 73 + plan().len() * 32 + 1 + 16;
    let mut out = bytes[..at].to_vec();
    out.extend_from_slice(&0u32.to_le_bytes());
    out
}

#[test]
fn a_case_of_the_first_version_is_read_with_a_level_start() {
    // Version 1 had no pitch and roll after x, y, z, yaw.
    let bytes = without_keyframes(&recorded().1);
    let mut old = bytes[..52].to_vec();
    old[8..12].copy_from_slice(&1u32.to_le_bytes());
    old.extend_from_slice(&bytes[69..]);
    let case = ValidationCase::read(&mut old.as_slice()).expect("a version 1 case");
    let s = start();
    assert_eq!(case.start, Stance::level(0.0, 0.0, s.position[2], s.yaw));
    assert_eq!(case.plan, plan());
    assert!(!case.way_back);
}

#[test]
fn a_case_keeps_whether_the_way_back_was_driven_and_one_of_the_second_version_had_none() {
    let (_, bytes) = recorded();
    let mut case = ValidationCase::read(&mut bytes.as_slice()).expect("read");
    assert!(!case.way_back);
    case.way_back = true;
    let mut again = Vec::new();
    case.write(&mut again).expect("write");
    assert_eq!(
        ValidationCase::read(&mut again.as_slice()).expect("read"),
        case
    );
    // Version 2: no way-back byte after the start.
    let again = without_keyframes(&again);
    let mut v2 = again[..68].to_vec();
    v2[8..12].copy_from_slice(&2u32.to_le_bytes());
    v2.extend_from_slice(&again[69..]);
    let old = ValidationCase::read(&mut v2.as_slice()).expect("a version 2 case");
    assert_eq!(old.start, case.start);
    assert!(!old.way_back);
    assert_eq!(old.plan, case.plan);
}

#[test]
fn a_case_of_the_third_version_is_read_without_intensities() {
    let (_, bytes) = recorded();
    let mut case = ValidationCase::read(&mut bytes.as_slice()).expect("read");
    case.keyframes.truncate(1);
    case.keyframes[0].points.truncate(2);
    case.keyframes[0].intensities.clear();
    let mut v3 = Vec::new();
    case.write(&mut v3).expect("write");
    // Version 3 had no intensity count after a keyframe's points.
    v3.truncate(v3.len() - 4);
    v3[8..12].copy_from_slice(&3u32.to_le_bytes());
    assert_eq!(
        ValidationCase::read(&mut v3.as_slice()).expect("a version 3 case"),
        case
    );
    // Intensities neither none nor one a point are refused.
    case.keyframes[0].intensities = vec![7, 7];
    let mut odd = Vec::new();
    case.write(&mut odd).expect("write");
    let count = odd.len() - 2 - 4;
    odd[count..count + 4].copy_from_slice(&1u32.to_le_bytes());
    let e = ValidationCase::read(&mut odd.as_slice()).expect_err("refused");
    assert!(matches!(e, CaseError::Count { .. }), "{e}");
}
