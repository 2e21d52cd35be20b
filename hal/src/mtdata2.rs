//! Every MTData2 data item Speleo knows, in all four precisions and three
//! coordinate systems. Items are read straight from the payload; unknown
//! identifiers are skipped by their size field and reported as such.
//!
//! A data identifier's low nibble holds the format: bits 0-1 the precision
//! (Float32, fixed point 12.20, fixed point 16.32, Float64), bits 2-3 the
//! coordinate system (ENU, NED, NWU). All values are big-endian. Fixed point
//! 16.32 is sent as the 4-byte fraction followed by the 2-byte signed integer.

/// Numeric format of a vector item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    Float32,
    Fp1220,
    Fp1632,
    Float64,
}

impl Precision {
    pub fn from_id(id: u16) -> Precision {
        match id & 0x3 {
            0 => Precision::Float32,
            1 => Precision::Fp1220,
            2 => Precision::Fp1632,
            _ => Precision::Float64,
        }
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        match self {
            Precision::Float32 | Precision::Fp1220 => 4,
            Precision::Fp1632 => 6,
            Precision::Float64 => 8,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Precision::Float32 => "Float32",
            Precision::Fp1220 => "FP1220",
            Precision::Fp1632 => "FP1632",
            Precision::Float64 => "Float64",
        }
    }

    /// Read one value (the slice holds exactly `size()` bytes).
    pub fn read(self, b: &[u8]) -> f64 {
        match self {
            Precision::Float32 => f32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Precision::Fp1220 => i32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64 / 1_048_576.0,
            Precision::Fp1632 => {
                let frac = u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as i64;
                let int = i16::from_be_bytes([b[4], b[5]]) as i64;
                ((int << 32) | frac) as f64 / 4_294_967_296.0
            }
            Precision::Float64 => {
                f64::from_be_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
            }
        }
    }

    /// Write one value; fixed-point values are rounded to the nearest step.
    pub fn write(self, v: f64, out: &mut [u8]) {
        match self {
            Precision::Float32 => out[..4].copy_from_slice(&(v as f32).to_be_bytes()),
            Precision::Fp1220 => {
                out[..4].copy_from_slice(&((v * 1_048_576.0).round() as i32).to_be_bytes())
            }
            Precision::Fp1632 => {
                let raw = (v * 4_294_967_296.0).round() as i64;
                out[..4].copy_from_slice(&((raw & 0xFFFF_FFFF) as u32).to_be_bytes());
                out[4..6].copy_from_slice(&((raw >> 32) as i16).to_be_bytes());
            }
            Precision::Float64 => out[..8].copy_from_slice(&v.to_be_bytes()),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoordinateSystem {
    EastNorthUp,
    NorthEastDown,
    NorthWestUp,
}

impl CoordinateSystem {
    pub fn from_id(id: u16) -> Option<CoordinateSystem> {
        match id & 0xC {
            0x0 => Some(CoordinateSystem::EastNorthUp),
            0x4 => Some(CoordinateSystem::NorthEastDown),
            0x8 => Some(CoordinateSystem::NorthWestUp),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CoordinateSystem::EastNorthUp => "EastNorthUp",
            CoordinateSystem::NorthEastDown => "NorthEastDown",
            CoordinateSystem::NorthWestUp => "NorthWestUp",
        }
    }
}

/// UTC time as the MTi sends it (0x1010).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UtcTime {
    pub nanos: u32,
    pub year: u16,
    pub month: u8,
    pub day: u8,
    pub hour: u8,
    pub minute: u8,
    pub second: u8,
    pub flags: u8,
}

/// The u-blox NAV-PVT record the MTi forwards (0x7010), 94 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct GnssPvt {
    pub itow: u32,
    pub year: u16,
    pub month: u8,
    pub day: u8,
    pub hour: u8,
    pub min: u8,
    pub sec: u8,
    pub valid: u8,
    pub t_acc: u32,
    pub nano: i32,
    pub fix_type: u8,
    pub flags: u8,
    pub num_sv: u8,
    pub reserved1: u8,
    pub lon: i32,
    pub lat: i32,
    pub height: i32,
    pub hmsl: i32,
    pub h_acc: u32,
    pub v_acc: u32,
    pub vel_n: i32,
    pub vel_e: i32,
    pub vel_d: i32,
    pub g_speed: i32,
    pub head_mot: i32,
    pub s_acc: u32,
    pub head_acc: u32,
    pub head_veh: i32,
    pub gdop: u16,
    pub pdop: u16,
    pub tdop: u16,
    pub vdop: u16,
    pub hdop: u16,
    pub ndop: u16,
    pub edop: u16,
}

pub const GNSS_PVT_LEN: usize = 94;

/// The satellites the MTi's receiver tracks (0x7020): the time of week,
/// then 4 bytes a satellite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GnssSatInfo<'a> {
    /// GNSS time of week, ms.
    pub itow: u32,
    records: &'a [u8],
}

/// One satellite of a [`GnssSatInfo`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SatInfo {
    /// The constellation (u-blox numbering: 0 GPS, 1 SBAS, 2 Galileo,
    /// 3 BeiDou, 5 QZSS, 6 GLONASS).
    pub gnss_id: u8,
    pub sv_id: u8,
    /// Carrier to noise ratio, dBHz.
    pub cno: u8,
    pub flags: u8,
}

impl SatInfo {
    /// Signal quality, 0 (no signal) to 7 (code and carrier locked).
    pub fn quality(&self) -> u8 {
        self.flags & 0x07
    }

    /// Used for navigation.
    pub fn used(&self) -> bool {
        self.flags & 0x08 != 0
    }

    /// Health: 0 unknown, 1 healthy, 2 unhealthy.
    pub fn health(&self) -> u8 {
        (self.flags >> 4) & 0x03
    }

    /// Differential corrections are available for it.
    pub fn corrected(&self) -> bool {
        self.flags & 0x40 != 0
    }
}

impl<'a> GnssSatInfo<'a> {
    /// Number of satellites reported.
    pub fn len(&self) -> usize {
        self.records.len() / 4
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    pub fn satellites(&self) -> impl Iterator<Item = SatInfo> + 'a {
        self.records.chunks_exact(4).map(|r| SatInfo {
            gnss_id: r[0],
            sv_id: r[1],
            cno: r[2],
            flags: r[3],
        })
    }
}

/// What an item holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Item<'a> {
    PacketCounter(u16),
    SampleTimeFine(u32),
    SampleTimeCoarse(u32),
    UtcTime(UtcTime),
    StatusByte(u8),
    StatusWord(u32),
    BaroPressure(u32),
    /// Values of a numeric item (1 to 9 of them), with their format.
    Numbers {
        kind: Kind,
        precision: Precision,
        coords: Option<CoordinateSystem>,
        values: [f64; 9],
        len: usize,
    },
    GnssPvt(GnssPvt),
    GnssSatInfo(GnssSatInfo<'a>),
    /// Unknown identifier, skipped by size.
    Unknown {
        id: u16,
        size: usize,
    },
}

/// The numeric items.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Temperature,
    Quaternion,
    RotationMatrix,
    EulerAngles,
    DeltaV,
    Acceleration,
    FreeAcceleration,
    RateOfTurn,
    DeltaQ,
    MagneticField,
    LatLon,
    AltitudeEllipsoid,
    PositionEcef,
    VelocityXyz,
}

impl Kind {
    /// The group (identifier without format bits) and number of values.
    fn of_group(group: u16) -> Option<(Kind, usize)> {
        Some(match group {
            0x0810 => (Kind::Temperature, 1),
            0x2010 => (Kind::Quaternion, 4),
            0x2020 => (Kind::RotationMatrix, 9),
            0x2030 => (Kind::EulerAngles, 3),
            0x4010 => (Kind::DeltaV, 3),
            0x4020 => (Kind::Acceleration, 3),
            0x4030 => (Kind::FreeAcceleration, 3),
            0x8020 => (Kind::RateOfTurn, 3),
            0x8030 => (Kind::DeltaQ, 4),
            0xC020 => (Kind::MagneticField, 3),
            0x5040 => (Kind::LatLon, 2),
            0x5020 => (Kind::AltitudeEllipsoid, 1),
            0x5030 => (Kind::PositionEcef, 3),
            0xD010 => (Kind::VelocityXyz, 3),
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Kind::Temperature => "Temperature",
            Kind::Quaternion => "Quaternion",
            Kind::RotationMatrix => "RotationMatrix",
            Kind::EulerAngles => "EulerAngles",
            Kind::DeltaV => "DeltaV",
            Kind::Acceleration => "Acceleration",
            Kind::FreeAcceleration => "FreeAcceleration",
            Kind::RateOfTurn => "RateOfTurn",
            Kind::DeltaQ => "DeltaQ",
            Kind::MagneticField => "MagneticField",
            Kind::LatLon => "LatLon",
            Kind::AltitudeEllipsoid => "AltitudeEllipsoid",
            Kind::PositionEcef => "PositionEcef",
            Kind::VelocityXyz => "VelocityXYZ",
        }
    }

    /// Items whose values depend on the chosen coordinate system.
    pub fn has_coordinate_system(self) -> bool {
        matches!(
            self,
            Kind::Quaternion | Kind::RotationMatrix | Kind::EulerAngles | Kind::VelocityXyz
        )
    }

    /// Names of the values, for display.
    pub fn fields(self) -> &'static [&'static str] {
        match self {
            Kind::Quaternion | Kind::DeltaQ => &["Q0", "Q1", "Q2", "Q3"],
            Kind::LatLon => &["Lat", "Lon"],
            Kind::Temperature | Kind::AltitudeEllipsoid => &[""],
            Kind::RotationMatrix => &["A", "B", "C", "D", "E", "F", "G", "H", "I"],
            _ => &["X", "Y", "Z"],
        }
    }
}

/// An item ended before its size field said.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Truncated {
    pub offset: usize,
}

fn be16(b: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([b[i], b[i + 1]])
}
fn be32(b: &[u8], i: usize) -> u32 {
    u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

fn gnss_pvt(d: &[u8]) -> GnssPvt {
    let i32at = |i| be32(d, i) as i32;
    GnssPvt {
        itow: be32(d, 0),
        year: be16(d, 4),
        month: d[6],
        day: d[7],
        hour: d[8],
        min: d[9],
        sec: d[10],
        valid: d[11],
        t_acc: be32(d, 12),
        nano: i32at(16),
        fix_type: d[20],
        flags: d[21],
        num_sv: d[22],
        reserved1: d[23],
        lon: i32at(24),
        lat: i32at(28),
        height: i32at(32),
        hmsl: i32at(36),
        h_acc: be32(d, 40),
        v_acc: be32(d, 44),
        vel_n: i32at(48),
        vel_e: i32at(52),
        vel_d: i32at(56),
        g_speed: i32at(60),
        head_mot: i32at(64),
        s_acc: be32(d, 68),
        head_acc: be32(d, 72),
        head_veh: i32at(76),
        gdop: be16(d, 80),
        pdop: be16(d, 82),
        tdop: be16(d, 84),
        vdop: be16(d, 86),
        hdop: be16(d, 88),
        ndop: be16(d, 90),
        edop: be16(d, 92),
    }
}

/// Decode one item's content. Known identifiers with an unexpected size are
/// reported as unknown (skipped), never misread.
pub fn item(id: u16, d: &[u8]) -> Item<'_> {
    let unknown = Item::Unknown { id, size: d.len() };
    match id {
        0x1020 if d.len() == 2 => return Item::PacketCounter(be16(d, 0)),
        0x1060 if d.len() == 4 => return Item::SampleTimeFine(be32(d, 0)),
        0x1070 if d.len() == 4 => return Item::SampleTimeCoarse(be32(d, 0)),
        0x1010 if d.len() == 12 => {
            return Item::UtcTime(UtcTime {
                nanos: be32(d, 0),
                year: be16(d, 4),
                month: d[6],
                day: d[7],
                hour: d[8],
                minute: d[9],
                second: d[10],
                flags: d[11],
            })
        }
        0xE010 if d.len() == 1 => return Item::StatusByte(d[0]),
        0xE020 if d.len() == 4 => return Item::StatusWord(be32(d, 0)),
        0x3010 if d.len() == 4 => return Item::BaroPressure(be32(d, 0)),
        0x7010 if d.len() == GNSS_PVT_LEN => return Item::GnssPvt(gnss_pvt(d)),
        // Its size is its count's: 8 bytes, then 4 a satellite.
        0x7020 if d.len() >= 8 && d.len() == 8 + 4 * usize::from(d[4]) => {
            return Item::GnssSatInfo(GnssSatInfo {
                itow: be32(d, 0),
                records: &d[8..],
            })
        }
        _ => {}
    }
    let Some((kind, n)) = Kind::of_group(id & 0xFFF0) else {
        return unknown;
    };
    let precision = Precision::from_id(id);
    if d.len() != n * precision.size() {
        return unknown;
    }
    let coords = if kind.has_coordinate_system() {
        match CoordinateSystem::from_id(id) {
            Some(c) => Some(c),
            None => return unknown,
        }
    } else {
        None
    };
    let mut values = [0.0; 9];
    for (k, v) in values.iter_mut().take(n).enumerate() {
        *v = precision.read(&d[k * precision.size()..(k + 1) * precision.size()]);
    }
    Item::Numbers {
        kind,
        precision,
        coords,
        values,
        len: n,
    }
}

/// Iterate over the items of an MTData2 payload: `(data id, item)`, or the
/// offset of an item that runs past the end (then iteration stops).
pub fn items(payload: &[u8]) -> impl Iterator<Item = Result<(u16, Item<'_>), Truncated>> {
    let mut at = 0usize;
    let mut done = false;
    core::iter::from_fn(move || {
        if done || at >= payload.len() {
            return None;
        }
        if at + 3 > payload.len() {
            done = true;
            return Some(Err(Truncated { offset: at }));
        }
        let id = be16(payload, at);
        let size = payload[at + 2] as usize;
        let Some(d) = payload.get(at + 3..at + 3 + size) else {
            done = true;
            return Some(Err(Truncated { offset: at }));
        };
        at += 3 + size;
        Some(Ok((id, item(id, d))))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_round_trips() {
        for v in [0.0, 1.5, -7.25, 57.679442145396024, -0.0000123] {
            for p in [Precision::Fp1220, Precision::Fp1632, Precision::Float64] {
                let mut b = [0u8; 8];
                p.write(v, &mut b);
                let step = match p {
                    Precision::Fp1220 => 1.0 / 1_048_576.0,
                    Precision::Fp1632 => 1.0 / 4_294_967_296.0,
                    _ => 0.0,
                };
                assert!(
                    (p.read(&b[..p.size()]) - v).abs() <= step / 2.0,
                    "{p:?} {v}"
                );
            }
        }
        // -1.5 in 16.32: integer part -2, fraction 0x80000000.
        assert_eq!(Precision::Fp1632.read(&[0x80, 0, 0, 0, 0xFF, 0xFE]), -1.5);
    }

    #[test]
    fn format_bits_decode() {
        let Item::Numbers {
            kind,
            precision,
            coords,
            values,
            len,
        } = item(0x2035, &[0; 12])
        else {
            panic!("numbers");
        };
        assert_eq!(
            (kind, precision, coords, len),
            (
                Kind::EulerAngles,
                Precision::Fp1220,
                Some(CoordinateSystem::NorthEastDown),
                3
            )
        );
        assert_eq!(values[0], 0.0);
        assert!(matches!(
            item(0x4020, &[0; 5]),
            Item::Unknown { size: 5, .. }
        ));
        assert!(matches!(
            item(0x9999, &[1, 2]),
            Item::Unknown {
                id: 0x9999,
                size: 2
            }
        ));
    }

    #[test]
    fn truncation_stops_iteration() {
        let v: Vec<_> = items(&[0x10, 0x20, 0x02, 0x00, 0x05, 0x40, 0x20, 0x0C, 1]).collect();
        assert_eq!(v.len(), 2);
        assert_eq!(v[0], Ok((0x1020, Item::PacketCounter(5))));
        assert_eq!(v[1], Err(Truncated { offset: 5 }));
    }

    #[test]
    fn satellite_info_is_read_by_its_count_and_refused_at_another_size() {
        // iTOW 123456 ms, 2 satellites: GPS 7 at 42 dBHz, code and carrier
        // locked, used, healthy; GLONASS 3 at 18 dBHz, searching.
        let mut d = vec![0x00, 0x01, 0xE2, 0x40, 2, 0, 0, 0];
        d.extend_from_slice(&[0, 7, 42, 0x1F]);
        d.extend_from_slice(&[6, 3, 18, 0x01]);
        let Item::GnssSatInfo(s) = item(0x7020, &d) else {
            panic!("{:?}", item(0x7020, &d));
        };
        assert_eq!(s.itow, 123_456);
        let v: Vec<SatInfo> = s.satellites().collect();
        assert_eq!(v.len(), 2);
        assert_eq!((v[0].gnss_id, v[0].sv_id, v[0].cno), (0, 7, 42));
        assert!(v[0].used() && v[0].quality() == 7 && v[0].health() == 1);
        assert!(!v[1].used() && v[1].quality() == 1 && v[1].health() == 0);
        // One satellite short of its count: skipped, never misread.
        d.truncate(12);
        assert_eq!(
            item(0x7020, &d),
            Item::Unknown {
                id: 0x7020,
                size: 12
            }
        );
        assert_eq!(
            item(0x7020, &d[..3]),
            Item::Unknown {
                id: 0x7020,
                size: 3
            }
        );
    }
}
