//! One validation's inputs as a file, to replay it away from the mission:
//! the rover's start, the plan, and the keyframe clouds exactly as the
//! simulator read them while it built its world. A validation that went
//! wrong 40 minutes into a mission is then a second's run of `speleo
//! validate`, its world written as a mesh and its track as a table.
//!
//! The file is little-endian binary: the magic `SPLVCASE`, a version,
//! the mission time it began, the start (x, y, z, yaw, pitch, roll; version
//! 1 had no pitch and roll), whether the way back was driven too (a byte;
//! from version 3), the plan's poses (x, y, ground z, heading),
//! the verdict the mission got (outcome code, driving time, goal error),
//! then each keyframe: whether it had a pose, its sensor origin and the
//! points read from it. Coordinates are the map frame's f64, so a replay
//! integrates the very same numbers.

use std::cell::RefCell;
use std::io::{self, Read, Write};

use crate::{CloudSource, Outcome, Stance, Verdict};

const MAGIC: &[u8; 8] = b"SPLVCASE";
const VERSION: u32 = 4;
/// The first version with the returns' intensities.
const INTENSITY_VERSION: u32 = 4;
/// Files of this version are still read (their start is level).
const LEVEL_START_VERSION: u32 = 1;
/// The first version with the start's pitch and roll.
const TILTED_START_VERSION: u32 = 2;
/// Bounds a corrupt file's counts before anything is allocated for them.
const MAX_PLAN_POSES: u32 = 1 << 16;
const MAX_KEYFRAMES: u32 = 1 << 16;
const MAX_POINTS: u32 = 1 << 24;

/// A keyframe as the simulator saw it: its sensor origin and the points
/// it read (none when it lay too far from the plan or under it).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordedKeyframe {
    pub origin: Option<[f64; 3]>,
    pub points: Vec<[f64; 3]>,
    /// Each point's return intensity; empty where none were measured.
    pub intensities: Vec<u8>,
}

/// One validation's inputs and the verdict the mission got from them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ValidationCase {
    /// Mission time of the start's pose, ns: when the query that planned
    /// from it began (the rover stands still then: a sample of the true
    /// track at that time places it in a simulated world).
    pub began_ns: u64,
    pub start: Stance,
    /// The way back was driven too ([`crate::InternalSim::check_way_back`]).
    pub way_back: bool,
    pub plan: Vec<[f64; 4]>,
    pub verdict: Option<Verdict>,
    pub keyframes: Vec<RecordedKeyframe>,
}

/// Why a case file could not be read.
#[derive(Debug)]
pub enum CaseError {
    Io(io::Error),
    NotACase,
    Version(u32),
    /// A count beyond what a validation can hold (a corrupt file).
    Count {
        what: &'static str,
        count: u32,
        max: u32,
    },
    Outcome(u8),
}

impl std::fmt::Display for CaseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CaseError::Io(e) if e.kind() == io::ErrorKind::UnexpectedEof => {
                write!(f, "the file ends inside the case (cut short?)")
            }
            CaseError::Io(e) => write!(f, "{e}"),
            CaseError::NotACase => write!(f, "not a validation case (no SPLVCASE magic)"),
            CaseError::Version(v) => write!(f, "case version {v}; this build reads {VERSION}"),
            CaseError::Count { what, count, max } => {
                write!(f, "{count} {what} (at most {max}): a corrupt case")
            }
            CaseError::Outcome(c) => write!(f, "unknown outcome code {c}"),
        }
    }
}

impl std::error::Error for CaseError {}

impl From<io::Error> for CaseError {
    fn from(e: io::Error) -> Self {
        CaseError::Io(e)
    }
}

fn outcome_code(o: Option<Outcome>) -> u8 {
    match o {
        None => 0,
        Some(Outcome::Reached) => 1,
        Some(Outcome::Timeout) => 2,
        Some(Outcome::TippedOver) => 3,
        Some(Outcome::Stuck) => 4,
        Some(Outcome::Missed) => 5,
        Some(Outcome::NoGround) => 6,
        Some(Outcome::NoWayBack) => 7,
        Some(Outcome::Overhang) => 8,
        Some(Outcome::Fell) => 9,
        Some(Outcome::TooSteepForGrip) => 10,
    }
}

fn outcome_from(c: u8) -> Result<Option<Outcome>, CaseError> {
    Ok(Some(match c {
        0 => return Ok(None),
        1 => Outcome::Reached,
        2 => Outcome::Timeout,
        3 => Outcome::TippedOver,
        4 => Outcome::Stuck,
        5 => Outcome::Missed,
        6 => Outcome::NoGround,
        7 => Outcome::NoWayBack,
        8 => Outcome::Overhang,
        9 => Outcome::Fell,
        10 => Outcome::TooSteepForGrip,
        _ => return Err(CaseError::Outcome(c)),
    }))
}

impl ValidationCase {
    /// A new recording for a validation of `plan` from `start`.
    pub fn begin(
        &mut self,
        began_ns: u64,
        start: Stance,
        way_back: bool,
        plan: impl IntoIterator<Item = [f64; 4]>,
    ) {
        self.began_ns = began_ns;
        self.start = start;
        self.way_back = way_back;
        self.plan.clear();
        self.plan.extend(plan);
        self.verdict = None;
        self.keyframes.clear();
    }

    /// Points read from all keyframes.
    pub fn points(&self) -> usize {
        self.keyframes.iter().map(|k| k.points.len()).sum()
    }

    pub fn write(&self, w: &mut impl Write) -> io::Result<()> {
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&self.began_ns.to_le_bytes())?;
        write_f64s(w, &self.start.xyz_yaw())?;
        write_f64s(w, &[self.start.pitch, self.start.roll])?;
        w.write_all(&[self.way_back as u8])?;
        w.write_all(&(self.plan.len() as u32).to_le_bytes())?;
        for q in &self.plan {
            write_f64s(w, q)?;
        }
        let v = self.verdict;
        w.write_all(&[outcome_code(v.map(|v| v.outcome))])?;
        write_f64s(
            w,
            &[
                v.map_or(0.0, |v| v.drive_s),
                v.map_or(0.0, |v| v.goal_error_m),
            ],
        )?;
        w.write_all(&(self.keyframes.len() as u32).to_le_bytes())?;
        for k in &self.keyframes {
            w.write_all(&[k.origin.is_some() as u8])?;
            write_f64s(w, &k.origin.unwrap_or([0.0; 3]))?;
            w.write_all(&(k.points.len() as u32).to_le_bytes())?;
            for p in &k.points {
                write_f64s(w, p)?;
            }
            let intensities = if k.intensities.len() == k.points.len() {
                &k.intensities[..]
            } else {
                &[]
            };
            w.write_all(&(intensities.len() as u32).to_le_bytes())?;
            w.write_all(intensities)?;
        }
        Ok(())
    }

    pub fn read(r: &mut impl Read) -> Result<ValidationCase, CaseError> {
        let mut magic = [0u8; 8];
        r.read_exact(&mut magic).map_err(|_| CaseError::NotACase)?;
        if &magic != MAGIC {
            return Err(CaseError::NotACase);
        }
        let version = read_u32(r)?;
        if !(LEVEL_START_VERSION..=VERSION).contains(&version) {
            return Err(CaseError::Version(version));
        }
        let mut t = [0u8; 8];
        r.read_exact(&mut t)?;
        let began_ns = u64::from_le_bytes(t);
        let [x, y, z, yaw] = read_f64s::<4>(r)?;
        let mut start = Stance::level(x, y, z, yaw);
        if version >= TILTED_START_VERSION {
            [start.pitch, start.roll] = read_f64s::<2>(r)?;
        }
        let mut way_back = [0u8];
        if version >= 3 {
            r.read_exact(&mut way_back)?;
        }
        let n = read_count(r, "plan poses", MAX_PLAN_POSES)?;
        let plan = (0..n)
            .map(|_| read_f64s::<4>(r))
            .collect::<Result<Vec<_>, _>>()?;
        let mut code = [0u8];
        r.read_exact(&mut code)?;
        let [drive_s, goal_error_m] = read_f64s::<2>(r)?;
        let verdict = outcome_from(code[0])?.map(|outcome| Verdict {
            outcome,
            drive_s,
            goal_error_m,
        });
        let n = read_count(r, "keyframes", MAX_KEYFRAMES)?;
        let mut keyframes = Vec::with_capacity(n as usize);
        for _ in 0..n {
            let mut has = [0u8];
            r.read_exact(&mut has)?;
            let origin = read_f64s::<3>(r)?;
            let m = read_count(r, "points in a keyframe", MAX_POINTS)?;
            let points = (0..m)
                .map(|_| read_f64s::<3>(r))
                .collect::<Result<Vec<_>, _>>()?;
            let mut intensities = Vec::new();
            if version >= INTENSITY_VERSION {
                let n = read_count(r, "intensities in a keyframe", m)?;
                if n != 0 && n != m {
                    return Err(CaseError::Count {
                        what: "intensities in a keyframe (none or one a point)",
                        count: n,
                        max: m,
                    });
                }
                intensities = vec![0; n as usize];
                r.read_exact(&mut intensities)?;
            }
            keyframes.push(RecordedKeyframe {
                origin: (has[0] != 0).then_some(origin),
                points,
                intensities,
            });
        }
        Ok(ValidationCase {
            began_ns,
            start,
            way_back: way_back[0] != 0,
            plan,
            verdict,
            keyframes,
        })
    }
}

fn write_f64s(w: &mut impl Write, v: &[f64]) -> io::Result<()> {
    for x in v {
        w.write_all(&x.to_le_bytes())?;
    }
    Ok(())
}

fn read_u32(r: &mut impl Read) -> Result<u32, CaseError> {
    let mut b = [0u8; 4];
    r.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

fn read_count(r: &mut impl Read, what: &'static str, max: u32) -> Result<u32, CaseError> {
    let count = read_u32(r)?;
    if count > max {
        return Err(CaseError::Count { what, count, max });
    }
    Ok(count)
}

fn read_f64s<const N: usize>(r: &mut impl Read) -> Result<[f64; N], CaseError> {
    let mut out = [0.0; N];
    for x in &mut out {
        let mut b = [0u8; 8];
        r.read_exact(&mut b)?;
        *x = f64::from_le_bytes(b);
    }
    Ok(out)
}

/// A replayed case serves the clouds as they were read.
impl CloudSource for ValidationCase {
    fn keyframes(&self) -> usize {
        self.keyframes.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.keyframes.get(k).and_then(|k| k.origin)
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let Some(kf) = self.keyframes.get(k) else {
            return false;
        };
        let to = from.saturating_add(n).min(kf.points.len());
        out.extend_from_slice(&kf.points[from.min(to)..to]);
        from.saturating_add(n) < kf.points.len()
    }
    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        out.clear();
        let Some(kf) = self.keyframes.get(k) else {
            return;
        };
        let to = from.saturating_add(n).min(kf.intensities.len());
        out.extend_from_slice(&kf.intensities[from.min(to)..to]);
    }
}

/// Another source's clouds, each answer also written into `case`: the
/// keyframe count, the origins and the points as the simulator read them,
/// but those `keep` does not read ([`crate::InternalSim::read_region`]),
/// which it drops unused (a case of the garage is then ~2 MB, not 35). The integration is point by point, so fewer points a slice
/// change nothing. (A keyframe whose pose SLAM replaced between two of
/// its slices keeps the last origin; the replay's verdict then says
/// whether that mattered.)
pub struct RecordingClouds<'a, C: CloudSource> {
    pub inner: &'a C,
    pub case: &'a RefCell<ValidationCase>,
    pub keep: crate::ReadRegion,
}

impl<C: CloudSource> CloudSource for RecordingClouds<'_, C> {
    fn keyframes(&self) -> usize {
        let n = self.inner.keyframes();
        let mut case = self.case.borrow_mut();
        if case.keyframes.len() < n {
            case.keyframes.resize_with(n, Default::default);
        }
        n
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        let o = self.inner.origin(k);
        if let Some(kf) = self.case.borrow_mut().keyframes.get_mut(k) {
            kf.origin = o;
        }
        o
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        let more = self.inner.points(k, from, n, out);
        let mut intensities = Vec::new();
        self.inner.intensities(k, from, n, &mut intensities);
        if let Some(kf) = self.case.borrow_mut().keyframes.get_mut(k) {
            if from == 0 {
                kf.points.clear();
                kf.intensities.clear();
            }
            let (keep, origin) = (self.keep, kf.origin);
            let with_intensity =
                intensities.len() == out.len() && kf.intensities.len() == kf.points.len();
            for (i, p) in out.iter().enumerate() {
                if keep.reads(origin, p) {
                    kf.points.push(*p);
                    if with_intensity {
                        kf.intensities.push(intensities[i]);
                    }
                }
            }
            if !with_intensity {
                kf.intensities.clear();
            }
        }
        more
    }
    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        self.inner.intensities(k, from, n, out);
    }
}
