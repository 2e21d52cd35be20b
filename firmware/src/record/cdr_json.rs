//! Reads any CDR message through its `ros2msg` definitions into a JSON
//! value: replay names the field where a run diverged, and tests check that
//! every recorded message is exactly what its schema says.

use serde_json::{Map, Value};

use super::msg_def::{Arity, Field, FieldType, MessageDefs, Primitive};

/// Why a message does not match its schema.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("not little-endian plain CDR")]
    Encapsulation,
    #[error("{field}: the message ends at byte {at}")]
    Truncated { field: String, at: usize },
    #[error("{field}: a string is not NUL-terminated UTF-8")]
    BadString { field: String },
    #[error("{left} bytes left over after the last field")]
    LeftOver { left: usize },
}

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, align: usize, field: &str) -> Result<&'a [u8], DecodeError> {
        let start = self.pos + (align - self.pos % align) % align;
        let s = start
            .checked_add(n)
            .and_then(|end| self.b.get(start..end))
            .ok_or_else(|| DecodeError::Truncated {
                field: field.to_string(),
                at: self.b.len() + 4,
            })?;
        self.pos = start + n;
        Ok(s)
    }

    fn primitive(&mut self, p: Primitive, field: &str) -> Result<Value, DecodeError> {
        let s = self.take(p.size(), p.size(), field)?;
        let a = |n: usize| -> [u8; 8] {
            let mut a = [0; 8];
            a[..n].copy_from_slice(&s[..n]);
            a
        };
        Ok(match p {
            Primitive::Bool => Value::Bool(s[0] != 0),
            Primitive::U8 => s[0].into(),
            Primitive::I8 => (s[0] as i8).into(),
            Primitive::U16 => u16::from_le_bytes([s[0], s[1]]).into(),
            Primitive::I16 => i16::from_le_bytes([s[0], s[1]]).into(),
            Primitive::U32 => (u64::from_le_bytes(a(4)) as u32).into(),
            Primitive::I32 => (u64::from_le_bytes(a(4)) as u32 as i32).into(),
            Primitive::U64 => u64::from_le_bytes(a(8)).into(),
            Primitive::I64 => i64::from_le_bytes(a(8)).into(),
            Primitive::F32 => f32::from_le_bytes([s[0], s[1], s[2], s[3]]).into(),
            Primitive::F64 => f64::from_le_bytes(a(8)).into(),
        })
    }

    fn string(&mut self, field: &str) -> Result<Value, DecodeError> {
        let n = u32::from_le_bytes(self.take(4, 4, field)?.try_into().unwrap_or_default());
        let s = self.take(n as usize, 1, field)?;
        match s.split_last() {
            Some((0, text)) => std::str::from_utf8(text)
                .map(|t| Value::String(t.to_string()))
                .map_err(|_| DecodeError::BadString {
                    field: field.to_string(),
                }),
            _ => Err(DecodeError::BadString {
                field: field.to_string(),
            }),
        }
    }

    fn one(&mut self, defs: &MessageDefs, f: &Field) -> Result<Value, DecodeError> {
        match &f.ty {
            FieldType::Primitive(p) => self.primitive(*p, &f.name),
            FieldType::String => self.string(&f.name),
            FieldType::Message(m) => self.message(defs, m),
        }
    }

    fn field(&mut self, defs: &MessageDefs, f: &Field) -> Result<Value, DecodeError> {
        let n = match f.arity {
            Arity::One => return self.one(defs, f),
            Arity::Fixed(n) => n,
            Arity::Sequence => {
                let s = self.take(4, 4, &f.name)?;
                u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize
            }
        };
        // A length can claim more than the message holds: every element
        // takes at least a byte, so check before reserving.
        if n > self.b.len().saturating_sub(self.pos) && !matches!(f.arity, Arity::Fixed(_)) {
            return Err(DecodeError::Truncated {
                field: f.name.clone(),
                at: self.b.len() + 4,
            });
        }
        let mut items = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            items.push(self.one(defs, f)?);
        }
        Ok(Value::Array(items))
    }

    fn message(&mut self, defs: &MessageDefs, name: &str) -> Result<Value, DecodeError> {
        let mut out = Map::new();
        for f in defs.types.get(name).map(Vec::as_slice).unwrap_or(&[]) {
            let v = self.field(defs, f)?;
            out.insert(f.name.clone(), v);
        }
        Ok(Value::Object(out))
    }
}

/// Decode `bytes` (encapsulation header included) as `defs`' root type.
/// Up to three zero bytes of padding may follow the last field; anything
/// else left over is an error, so a message cannot hide extra fields.
pub fn decode(defs: &MessageDefs, bytes: &[u8]) -> Result<Value, DecodeError> {
    let body = match bytes {
        [0x00, 0x01, _, _, body @ ..] => body,
        _ => return Err(DecodeError::Encapsulation),
    };
    let mut r = Reader { b: body, pos: 0 };
    let v = r.message(defs, &defs.root)?;
    let rest = &body[r.pos..];
    if rest.len() > 3 || rest.iter().any(|&b| b != 0) {
        return Err(DecodeError::LeftOver { left: rest.len() });
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::cdr::{write_raw_input, CdrWriter};
    use crate::record::schemas;

    #[test]
    fn a_raw_input_decodes_field_by_field() {
        let defs =
            MessageDefs::parse("speleo_msgs/msg/RawInput", schemas::RAW_INPUT).expect("defs");
        let mut v = Vec::new();
        write_raw_input(&mut v, 7, 9, "imu", &[1, 2]).expect("write");
        let j = decode(&defs, &v).expect("decodes");
        assert_eq!(j["receive_time"]["sec"], 7);
        assert_eq!(j["receive_time"]["nanosec"], 9);
        assert_eq!(j["device"], "imu");
        assert_eq!(j["data"], serde_json::json!([1, 2]));
        for cut in 0..v.len() {
            assert!(decode(&defs, &v[..cut]).is_err(), "{cut}");
        }
        v.extend_from_slice(&[0, 0, 0, 0]);
        assert_eq!(decode(&defs, &v), Err(DecodeError::LeftOver { left: 4 }));
    }

    #[test]
    fn alignment_is_from_the_end_of_the_encapsulation_header() {
        let defs = MessageDefs::parse("a/B", "uint8 a\nfloat64 b\nuint16[2] c\n").expect("defs");
        let mut v = Vec::new();
        let mut c = CdrWriter::new(&mut v).expect("header");
        c.u8(3).expect("u8");
        c.f64(2.5).expect("f64");
        c.u16(4).expect("u16");
        c.u16(5).expect("u16");
        // 1 byte, 7 of padding, 8, then 2 and 2.
        assert_eq!(v.len(), 4 + 1 + 7 + 8 + 4);
        let j = decode(&defs, &v).expect("decodes");
        assert_eq!(j, serde_json::json!({"a": 3, "b": 2.5, "c": [4, 5]}));
    }
}
