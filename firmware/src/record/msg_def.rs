//! Parses ROS 2 message definitions (`ros2msg`, with the `MSG:` blocks of
//! their dependencies) into field lists a CDR reader can walk.

use std::collections::BTreeMap;

/// A primitive field type and its size in bytes (its CDR alignment).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    Bool,
    /// `byte` and `uint8` (and `char`): one unsigned byte.
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl Primitive {
    fn parse(s: &str) -> Option<Primitive> {
        Some(match s {
            "bool" => Primitive::Bool,
            "byte" | "uint8" | "char" => Primitive::U8,
            "int8" => Primitive::I8,
            "uint16" => Primitive::U16,
            "int16" => Primitive::I16,
            "uint32" => Primitive::U32,
            "int32" => Primitive::I32,
            "uint64" => Primitive::U64,
            "int64" => Primitive::I64,
            "float32" => Primitive::F32,
            "float64" => Primitive::F64,
            _ => return None,
        })
    }

    pub fn size(self) -> usize {
        match self {
            Primitive::Bool | Primitive::U8 | Primitive::I8 => 1,
            Primitive::U16 | Primitive::I16 => 2,
            Primitive::U32 | Primitive::I32 | Primitive::F32 => 4,
            Primitive::U64 | Primitive::I64 | Primitive::F64 => 8,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FieldType {
    Primitive(Primitive),
    String,
    /// A message type, as `package/Name`.
    Message(String),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    One,
    Fixed(usize),
    /// A sequence (bounded or not: CDR writes its length either way).
    Sequence,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub ty: FieldType,
    pub arity: Arity,
}

/// Every message type of one schema, and the schema's own type.
#[derive(Clone, Debug)]
pub struct MessageDefs {
    pub root: String,
    pub types: BTreeMap<String, Vec<Field>>,
}

/// `pkg/msg/Name` or `pkg/Name` as `pkg/Name`.
pub fn normalise(name: &str) -> String {
    name.replacen("/msg/", "/", 1)
}

impl MessageDefs {
    /// Parse the schema `text` of the type named `schema_name`.
    pub fn parse(schema_name: &str, text: &str) -> Result<MessageDefs, String> {
        let root = normalise(schema_name);
        let mut types = BTreeMap::new();
        let mut current = root.clone();
        let mut fields = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            if line.len() >= 3 && line.bytes().all(|b| b == b'=') {
                types.insert(std::mem::take(&mut current), std::mem::take(&mut fields));
                continue;
            }
            if let Some(name) = line.strip_prefix("MSG:") {
                current = normalise(name.trim());
                continue;
            }
            let package = current.split('/').next().unwrap_or("");
            let field = parse_field(line, package).map_err(|e| format!("line {}: {e}", n + 1))?;
            fields.extend(field);
        }
        types.insert(current, fields);
        types.remove("");
        let defs = MessageDefs { root, types };
        defs.check()?;
        Ok(defs)
    }

    /// Every message type a field names is defined.
    fn check(&self) -> Result<(), String> {
        if !self.types.contains_key(&self.root) {
            return Err(format!("no definition of {}", self.root));
        }
        for (owner, fields) in &self.types {
            for f in fields {
                if let FieldType::Message(m) = &f.ty {
                    if !self.types.contains_key(m) {
                        return Err(format!("{owner}.{}: {m} is not defined", f.name));
                    }
                }
            }
        }
        Ok(())
    }
}

/// One line: a field, or `None` for a constant.
fn parse_field(line: &str, package: &str) -> Result<Option<Field>, String> {
    let mut words = line.split_whitespace();
    let (Some(ty), Some(name)) = (words.next(), words.next()) else {
        return Err(format!("'{line}' is not 'type name'"));
    };
    if name.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
        return Ok(None);
    }
    let (base, arity) = match ty.find('[') {
        Some(i) => {
            let inside = ty[i + 1..]
                .strip_suffix(']')
                .ok_or_else(|| format!("'{ty}' has an unclosed '['"))?;
            let arity = if inside.is_empty() || inside.starts_with("<=") {
                Arity::Sequence
            } else {
                Arity::Fixed(
                    inside
                        .parse()
                        .map_err(|_| format!("'{ty}' has a bad array size"))?,
                )
            };
            (&ty[..i], arity)
        }
        None => (ty, Arity::One),
    };
    // Bounded strings: `string<=N`.
    let base = base.split("<=").next().unwrap_or(base);
    let ty = match (Primitive::parse(base), base) {
        (Some(p), _) => FieldType::Primitive(p),
        (None, "string") => FieldType::String,
        (None, "wstring") => return Err("wstring is not supported".into()),
        (None, "Header") => FieldType::Message("std_msgs/Header".into()),
        (None, b) if b.contains('/') => FieldType::Message(normalise(b)),
        (None, b) => FieldType::Message(format!("{package}/{b}")),
    };
    Ok(Some(Field {
        name: name.to_string(),
        ty,
        arity,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_arrays_constants_and_dependencies_parse() {
        let d = MessageDefs::parse(
            "diagnostic_msgs/msg/DiagnosticArray",
            super::super::schemas::DIAGNOSTIC_ARRAY,
        )
        .expect("parses");
        assert_eq!(d.root, "diagnostic_msgs/DiagnosticArray");
        let status = &d.types["diagnostic_msgs/DiagnosticStatus"];
        // The four level constants are not fields.
        assert_eq!(status[0].name, "level");
        assert_eq!(status[0].ty, FieldType::Primitive(Primitive::U8));
        assert_eq!(
            status[4].ty,
            FieldType::Message("diagnostic_msgs/KeyValue".into())
        );
        assert_eq!(status[4].arity, Arity::Sequence);
        let odom = MessageDefs::parse("nav_msgs/msg/Odometry", super::super::schemas::ODOMETRY)
            .expect("parses");
        assert_eq!(
            odom.types["geometry_msgs/PoseWithCovariance"][1].arity,
            Arity::Fixed(36)
        );
    }

    #[test]
    fn an_undefined_type_or_a_bad_line_is_named() {
        let e = MessageDefs::parse("a/B", "Missing m\n").expect_err("undefined");
        assert!(e.contains("a/Missing"), "{e}");
        let e = MessageDefs::parse("a/B", "int32\n").expect_err("bad line");
        assert!(e.contains("line 1"), "{e}");
        let e = MessageDefs::parse("a/B", "int32[x] v\n").expect_err("bad size");
        assert!(e.contains("array size"), "{e}");
    }
}
