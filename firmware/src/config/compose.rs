//! Sections that hold components' parameters beside keys of their own
//! (`[slam] enabled`). serde's `flatten` cannot refuse unknown keys, so
//! such a section is read as a table: its own keys are taken out, each
//! component reads the keys it writes over its defaults, and a key left
//! over is refused by name.

use serde::de::DeserializeOwned;
use serde::Serialize;
use toml::{Table, Value};

/// A section's table while its keys are handed out.
pub(super) struct Section {
    name: &'static str,
    table: Table,
    known: Vec<String>,
}

impl Section {
    /// The section `name` from its table.
    pub(super) fn new(name: &'static str, table: Table) -> Self {
        Section {
            name,
            table,
            known: Vec::new(),
        }
    }

    /// The section's own `key`, if written.
    pub(super) fn own<T: DeserializeOwned>(&mut self, key: &str) -> Result<Option<T>, String> {
        self.known.push(key.into());
        match self.table.remove(key) {
            Some(v) => v.try_into().map(Some).map_err(|e| self.named(key, e)),
            None => Ok(None),
        }
    }

    /// A component's parameters: `base` with the keys written that are
    /// its own (the keys `base` serializes to).
    pub(super) fn part<T: Serialize + DeserializeOwned>(&mut self, base: &T) -> Result<T, String> {
        let mut merged = Table::try_from(base).map_err(|e| e.to_string())?;
        let keys: Vec<String> = merged.keys().cloned().collect();
        for key in keys {
            if let Some(v) = self.table.remove(&key) {
                // Read alone first, so that a wrong type names its key.
                let mut one = Table::new();
                one.insert(key.clone(), v.clone());
                Value::Table(one)
                    .try_into::<T>()
                    .map_err(|e| self.named(&key, e))?;
                merged.insert(key.clone(), v);
            }
            self.known.push(key);
        }
        Value::Table(merged)
            .try_into()
            .map_err(|e| format!("[{}]: {}", self.name, e.message()))
    }

    /// Refuses a key no part and no own key took.
    pub(super) fn finish(self) -> Result<(), String> {
        match self.table.keys().next() {
            None => Ok(()),
            Some(key) => {
                let expected: Vec<String> = self.known.iter().map(|k| format!("`{k}`")).collect();
                Err(format!(
                    "unknown field `{key}` in [{}], expected one of {}",
                    self.name,
                    expected.join(", ")
                ))
            }
        }
    }

    /// A value's error, naming its key.
    fn named(&self, key: &str, e: toml::de::Error) -> String {
        format!("`{}.{key}`: {}", self.name, e.message())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Part {
        a: f64,
        b: u32,
    }

    impl Default for Part {
        fn default() -> Self {
            Part { a: 1.0, b: 2 }
        }
    }

    fn section(text: &str) -> Section {
        Section::new("s", toml::from_str(text).expect("a table"))
    }

    #[test]
    fn keys_go_to_their_part_over_its_base_and_others_are_refused_by_name() {
        let mut s = section("on = false\nb = 7\n");
        assert_eq!(s.own::<bool>("on").expect("a bool"), Some(false));
        let base = Part { a: 3.0, b: 4 };
        assert_eq!(s.part(&base).expect("read"), Part { a: 3.0, b: 7 });
        s.finish().expect("nothing left");
        let mut s = section("b = 7\ncolour = 2\n");
        s.part(&Part::default()).expect("read");
        let e = s.finish().expect_err("an unknown key");
        assert!(e.contains("unknown field `colour` in [s]"), "{e}");
        assert!(e.contains("`a`, `b`"), "{e}");
        let mut s = section("b = \"seven\"\n");
        let e = s.part(&Part::default()).expect_err("a wrong type");
        assert!(e.contains("`s.b`"), "{e}");
    }
}
