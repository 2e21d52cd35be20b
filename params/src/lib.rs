//! What the components' parameter sets share: the error that names the
//! key whose value they refuse, and the checks that make it. Keys are the
//! parameters' field names, which are the keys of their configuration
//! table; the configuration puts the table's name in front.

use std::fmt;

/// A parameter the component cannot work with, named by its key.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamError {
    /// `key` = `value` lies outside `range` (as a user would write it).
    OutOfRange {
        key: String,
        value: String,
        range: &'static str,
    },
    /// `key` cannot be used, for the reason `why`.
    Invalid { key: String, why: String },
}

impl ParamError {
    /// The key refused.
    pub fn key(&self) -> &str {
        match self {
            ParamError::OutOfRange { key, .. } | ParamError::Invalid { key, .. } => key,
        }
    }

    /// The same error with its key inside `table` (`table.key`).
    pub fn within(self, table: &str) -> ParamError {
        match self {
            ParamError::OutOfRange { key, value, range } => ParamError::OutOfRange {
                key: format!("{table}.{key}"),
                value,
                range,
            },
            ParamError::Invalid { key, why } => ParamError::Invalid {
                key: format!("{table}.{key}"),
                why,
            },
        }
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::OutOfRange { key, value, range } => {
                write!(f, "`{key}` = {value} is out of range ({range})")
            }
            ParamError::Invalid { key, why } => write!(f, "`{key}`: {why}"),
        }
    }
}

impl std::error::Error for ParamError {}

/// `v` within `lo..=hi`, or the error naming `key` with `text` as the range.
pub fn range<T: PartialOrd + fmt::Display>(
    key: &str,
    v: T,
    lo: T,
    hi: T,
    text: &'static str,
) -> Result<(), ParamError> {
    // Written so that NaN fails: it compares false with both bounds.
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            key: key.into(),
            value: v.to_string(),
            range: text,
        })
    }
}

/// `v` a finite number over zero, or the error naming `key`.
pub fn positive(key: &str, v: f64) -> Result<(), ParamError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ParamError::Invalid {
            key: key.into(),
            why: format!("{v} is not a positive number"),
        })
    }
}

/// A length kept as `f32`, as the decimal it was written as (0.1, not
/// 0.10000000149): range checks then accept the bounds a user writes.
pub fn decimal(v: f32) -> f64 {
    (v as f64 * 1e6).round() / 1e6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_out_of_range_is_named_and_nan_is_refused() {
        let e = range("neighbors", 7, 1, 6, "1..=6").expect_err("7 > 6");
        assert_eq!(e.to_string(), "`neighbors` = 7 is out of range (1..=6)");
        assert_eq!(
            e.within("slam").to_string(),
            "`slam.neighbors` = 7 is out of range (1..=6)"
        );
        assert!(range("x", f64::NAN, 0.0, 1.0, "0..=1").is_err());
        assert!(range("x", 1.0, 0.0, 1.0, "0..=1").is_ok());
        let e = positive("voxel_m", 0.0).expect_err("zero");
        assert_eq!(e.key(), "voxel_m");
        assert!(positive("voxel_m", f64::INFINITY).is_err());
    }

    #[test]
    fn a_decimal_is_the_value_written() {
        assert_eq!(decimal(0.1), 0.1);
        assert_eq!(decimal(0.02), 0.02);
        assert_eq!(decimal(0.69), 0.69);
    }
}
