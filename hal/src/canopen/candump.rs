//! `candump` logs: the `-L` log format (`(1699584944.440580) can0 701#00`)
//! and the default screen format (`  can0  080   [0] `).

use crate::can::CanFrame;

/// One logged frame.
#[derive(Clone, Debug, PartialEq)]
pub struct LoggedFrame {
    /// Seconds, when the line carries a time stamp.
    pub time_s: Option<f64>,
    pub interface: String,
    pub frame: CanFrame,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LineError {
    /// Nothing recognisable (the line number and the reason).
    Unreadable(usize, &'static str),
    /// CAN FD (`##`) frames are not used on the drives' bus.
    CanFd(usize),
}

fn hex_bytes(s: &str) -> Option<heapless::Vec<u8, 8>> {
    let s = s.trim();
    if !s.len().is_multiple_of(2) || s.len() > 16 {
        return None;
    }
    let mut out = heapless::Vec::new();
    for i in (0..s.len()).step_by(2) {
        out.push(u8::from_str_radix(s.get(i..i + 2)?, 16).ok()?)
            .ok()?;
    }
    Some(out)
}

fn frame(id_text: &str, data: &[u8], rtr: bool) -> Option<CanFrame> {
    let id = u32::from_str_radix(id_text, 16).ok()?;
    let extended = id_text.len() > 3;
    if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
        return None;
    }
    let mut f = CanFrame::new(0, data);
    f.id = id;
    f.extended = extended;
    f.rtr = rtr;
    Some(f)
}

/// Parse one line; blank lines and `#` comments give `Ok(None)`.
pub fn parse_line(n: usize, line: &str) -> Result<Option<LoggedFrame>, LineError> {
    let t = line.trim();
    if t.is_empty() || t.starts_with('#') {
        return Ok(None);
    }
    let bad = |why| LineError::Unreadable(n, why);
    if let Some(rest) = t.strip_prefix('(') {
        // -L format.
        let (ts, rest) = rest.split_once(')').ok_or(bad("no closing parenthesis"))?;
        let time_s = ts
            .trim()
            .parse::<f64>()
            .map_err(|_| bad("bad time stamp"))?;
        let mut parts = rest.split_whitespace();
        let iface = parts.next().ok_or(bad("no interface"))?;
        let body = parts.next().ok_or(bad("no frame"))?;
        if body.contains("##") {
            return Err(LineError::CanFd(n));
        }
        let (id, data) = body.split_once('#').ok_or(bad("no '#' in the frame"))?;
        let (data, rtr) = match data.strip_prefix('R') {
            Some(_) => (heapless::Vec::new(), true),
            None => (hex_bytes(data).ok_or(bad("bad data bytes"))?, false),
        };
        let frame = frame(id, &data, rtr).ok_or(bad("bad identifier"))?;
        return Ok(Some(LoggedFrame {
            time_s: Some(time_s),
            interface: iface.to_string(),
            frame,
        }));
    }
    // Screen format: iface id [len] bytes...
    let mut parts = t.split_whitespace();
    let iface = parts.next().ok_or(bad("no interface"))?;
    let id = parts.next().ok_or(bad("no identifier"))?;
    let len = parts.next().ok_or(bad("no length"))?;
    let len: usize = len
        .strip_prefix('[')
        .and_then(|l| l.strip_suffix(']'))
        .and_then(|l| l.parse().ok())
        .filter(|l| *l <= 8)
        .ok_or(bad("bad length"))?;
    let mut data: heapless::Vec<u8, 8> = heapless::Vec::new();
    for b in parts.take(len) {
        let v = u8::from_str_radix(b, 16).map_err(|_| bad("bad data byte"))?;
        let _ = data.push(v);
    }
    if data.len() != len {
        return Err(bad("fewer data bytes than the length says"));
    }
    let frame = frame(id, &data, false).ok_or(bad("bad identifier"))?;
    Ok(Some(LoggedFrame {
        time_s: None,
        interface: iface.to_string(),
        frame,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_formats_parse() {
        let f = parse_line(1, "(1699584944.442629) can0 582#4300100092010200")
            .expect("ok")
            .expect("frame");
        assert_eq!(f.frame.id, 0x582);
        assert_eq!(f.frame.payload(), &[0x43, 0, 0x10, 0, 0x92, 1, 2, 0]);
        assert_eq!(f.time_s, Some(1699584944.442629));
        let s = parse_line(2, "  can0  602   [8]  2B 40 60 00 00 01 00 00")
            .expect("ok")
            .expect("frame");
        assert_eq!(s.frame.id, 0x602);
        assert_eq!(s.frame.len, 8);
        let sync = parse_line(3, "(1.0) can0 080#")
            .expect("ok")
            .expect("frame");
        assert_eq!(sync.frame.len, 0);
        assert_eq!(parse_line(4, "# comment"), Ok(None));
        assert!(parse_line(5, "(1.0) can0 123##0112").is_err());
        assert!(parse_line(6, "(1.0) can0 1234#0011223344556677889900").is_err());
        assert!(parse_line(7, "garbage").is_err());
    }
}
