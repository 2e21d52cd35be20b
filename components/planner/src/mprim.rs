//! SBPL's motion-primitive files (`.mprim`): a header (`resolution_m`,
//! `numberofangles`, `totalnumberofprimitives`) and, per primitive, its
//! `primID`, `startangle_c`, `endpose_c` (cells and angle bin, relative to
//! the start cell), `additionalactioncostmult` and `intermediateposes`
//! (metres and radians, from the start cell's corner-relative origin).
//! Every malformed file gives an error that names the line.

use thiserror::Error;

/// One primitive as written in the file.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionPrimitive {
    pub id: i32,
    /// Heading bin it starts from.
    pub start_angle: u32,
    /// End cell offset and end heading bin (not normalised).
    pub end: [i32; 3],
    pub cost_mult: u32,
    /// Intermediate poses `x, y, theta`, the first at the start.
    pub poses: Vec<[f64; 3]>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct MprimFile {
    pub resolution_m: f64,
    pub angles: u32,
    pub primitives: Vec<MotionPrimitive>,
}

#[derive(Debug, Error, PartialEq)]
#[error("line {line}: {what}")]
pub struct MprimError {
    pub line: usize,
    pub what: String,
}

/// Limits that keep a hostile file from asking for absurd memory.
const MAX_ANGLES: u32 = 1024;
const MAX_PRIMITIVES: usize = 100_000;
const MAX_POSES: usize = 10_000;

/// Whitespace-separated tokens with their line numbers.
pub(crate) struct Tokens<'a> {
    it: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        let it: Box<dyn Iterator<Item = (usize, &'a str)> + 'a> = Box::new(
            text.lines()
                .enumerate()
                .flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t))),
        );
        Tokens {
            it: it.peekable(),
            last_line: 1,
        }
    }

    pub(crate) fn err(&self, what: impl Into<String>) -> MprimError {
        MprimError {
            line: self.last_line,
            what: what.into(),
        }
    }

    pub(crate) fn next(&mut self, what: &str) -> Result<&'a str, MprimError> {
        match self.it.next() {
            Some((line, t)) => {
                self.last_line = line;
                Ok(t)
            }
            None => Err(self.err(format!("the file ends where {what} was expected"))),
        }
    }

    /// The next token, which must be `key` (case-insensitive).
    pub(crate) fn key(&mut self, key: &str) -> Result<(), MprimError> {
        let t = self.next(key)?;
        if t.eq_ignore_ascii_case(key) {
            Ok(())
        } else {
            Err(self.err(format!("expected `{key}`, found `{t}`")))
        }
    }

    /// Whether the next token is `key`, consumed if so.
    pub(crate) fn optional_key(&mut self, key: &str) -> bool {
        if self
            .it
            .peek()
            .is_some_and(|(_, t)| t.eq_ignore_ascii_case(key))
        {
            if let Some((line, _)) = self.it.next() {
                self.last_line = line;
            }
            true
        } else {
            false
        }
    }

    pub(crate) fn int(&mut self, what: &str) -> Result<i64, MprimError> {
        let t = self.next(what)?;
        t.parse::<i64>()
            .map_err(|_| self.err(format!("{what}: `{t}` is not an integer")))
    }

    pub(crate) fn float(&mut self, what: &str) -> Result<f64, MprimError> {
        let t = self.next(what)?;
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(format!("{what}: `{t}` is not a finite number"))),
        }
    }

    pub(crate) fn ranged(&mut self, what: &str, lo: i64, hi: i64) -> Result<i64, MprimError> {
        let v = self.int(what)?;
        if v < lo || v > hi {
            return Err(self.err(format!("{what}: {v} is outside {lo}..={hi}")));
        }
        Ok(v)
    }

    pub(crate) fn at_end(&mut self) -> bool {
        self.it.peek().is_none()
    }
}

/// Parse a `.mprim` file.
pub fn parse(text: &str) -> Result<MprimFile, MprimError> {
    let mut t = Tokens::new(text);
    t.key("resolution_m:")?;
    let resolution_m = t.float("resolution_m")?;
    if resolution_m <= 0.0 {
        return Err(t.err("resolution_m must be positive"));
    }
    t.key("numberofangles:")?;
    let angles = t.ranged("numberofangles", 1, MAX_ANGLES as i64)? as u32;
    t.key("totalnumberofprimitives:")?;
    let total = t.ranged("totalnumberofprimitives", 0, MAX_PRIMITIVES as i64)? as usize;
    let mut primitives = Vec::with_capacity(total);
    for _ in 0..total {
        t.key("primID:")?;
        let id = t.ranged("primID", i32::MIN as i64, i32::MAX as i64)? as i32;
        t.key("startangle_c:")?;
        let start_angle = t.ranged("startangle_c", 0, angles as i64 - 1)? as u32;
        t.key("endpose_c:")?;
        let mut end = [0i32; 3];
        for (k, e) in end.iter_mut().enumerate() {
            *e = t.ranged(
                ["endpose_c x", "endpose_c y", "endpose_c theta"][k],
                -1_000_000,
                1_000_000,
            )? as i32;
        }
        t.key("additionalactioncostmult:")?;
        let cost_mult = t.ranged("additionalactioncostmult", 1, 1_000)? as u32;
        t.key("intermediateposes:")?;
        let n = t.ranged("intermediateposes", 1, MAX_POSES as i64)? as usize;
        let mut poses = Vec::with_capacity(n);
        for _ in 0..n {
            let x = t.float("intermediate pose x")?;
            let y = t.float("intermediate pose y")?;
            let th = t.float("intermediate pose theta")?;
            poses.push([x, y, th]);
        }
        primitives.push(MotionPrimitive {
            id,
            start_angle,
            end,
            cost_mult,
            poses,
        });
    }
    if !t.at_end() {
        let extra = t.next("")?;
        return Err(t.err(format!(
            "`{extra}` after the {total} primitives the header announced"
        )));
    }
    Ok(MprimFile {
        resolution_m,
        angles,
        primitives,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE: &str = "resolution_m: 0.025000\nnumberofangles: 16\ntotalnumberofprimitives: 1\n\
        primID: 0\nstartangle_c: 0\nendpose_c: 1 0 0\nadditionalactioncostmult: 1\n\
        intermediateposes: 2\n0.0000 0.0000 0.0000\n0.0250 0.0000 0.0000\n";

    #[test]
    fn a_primitive_is_read() {
        let f = parse(ONE).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(f.angles, 16);
        assert_eq!(f.primitives.len(), 1);
        assert_eq!(f.primitives[0].end, [1, 0, 0]);
        assert_eq!(f.primitives[0].poses[1], [0.025, 0.0, 0.0]);
    }

    #[test]
    fn malformed_files_name_the_line() {
        for (bad, line, why) in [
            (ONE.replace("0.025000", "-1"), 1, "positive"),
            (
                ONE.replace("numberofangles: 16", "numberofangles: x"),
                2,
                "not an integer",
            ),
            (
                ONE.replace("startangle_c: 0", "startangle_c: 16"),
                5,
                "outside",
            ),
            (
                ONE.replace("endpose_c: 1 0 0", "endpose: 1 0 0"),
                6,
                "expected `endpose_c:`",
            ),
            (
                ONE.replace("0.0250 0.0000 0.0000\n", "0.0250 nan 0\n"),
                10,
                "finite",
            ),
            (ONE.replace("0.0250 0.0000 0.0000\n", ""), 9, "ends"),
            (
                ONE.to_string() + "primID: 1\n",
                11,
                "after the 1 primitives",
            ),
            (
                ONE.replace("totalnumberofprimitives: 1", "totalnumberofprimitives: 2"),
                10,
                "ends",
            ),
        ] {
            match parse(&bad) {
                Err(e) => {
                    assert_eq!(e.line, line, "{bad}: {e}");
                    assert!(e.what.contains(why), "{bad}: {e}");
                }
                Ok(_) => panic!("accepted: {bad}"),
            }
        }
    }
}
