//! Deterministic JSON encoding of sample fields, their decoding and their JSON Schema.
//!
//! Encoding writes fields in declaration order with no whitespace. Finite `f64` values are
//! written in the shortest form that parses back to the same value; non-finite values
//! (which JSON numbers cannot hold) as `null`, read back as NaN.
//! Integers are written exactly (`u64` may exceed 2^53, where JavaScript tools lose precision).

use ipc_types::SampleHeader;
use serde_json::{Map, Value, json};

/// Why a message could not be decoded into a sample.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// The message is not valid JSON.
    #[error("invalid JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// A required field is absent.
    #[error("field `{field}` is missing")]
    Missing {
        /// Dotted path of the field.
        field: String,
    },
    /// A field has the wrong JSON type or an out-of-range value.
    #[error("field `{field}`: expected {expected}")]
    Type {
        /// Dotted path of the field.
        field: String,
        /// What the field must hold.
        expected: &'static str,
    },
    /// An array field has the wrong number of elements.
    #[error("field `{field}`: expected {expected} elements, found {found}")]
    Length {
        /// Dotted path of the field.
        field: String,
        /// Required element count.
        expected: usize,
        /// Element count in the message.
        found: usize,
    },
    /// The object holds a field the type does not have.
    #[error("unexpected field `{field}`")]
    Unknown {
        /// Dotted path of the field.
        field: String,
    },
}

fn path(parent: &str, field: &str) -> String {
    if parent.is_empty() {
        field.to_owned()
    } else {
        format!("{parent}.{field}")
    }
}

/// A field type with a JSON encoding, a decoding and a schema.
pub(crate) trait Field: Sized {
    /// Appends the JSON encoding of `self` to `out`.
    fn write(&self, out: &mut Vec<u8>);
    /// Decodes `value`; `field` is the dotted path used in errors.
    fn read(value: &Value, field: &str) -> Result<Self, DecodeError>;
    /// The JSON Schema of the field, with `description`.
    fn schema(description: &str) -> Value;
}

/// Writes `value` with serde_json (number formatting and string escaping).
fn write_serde<T: serde::Serialize + ?Sized>(value: &T, out: &mut Vec<u8>) {
    // Serialising numbers and strings into a Vec<u8> cannot fail.
    let _ = serde_json::to_writer(out, value);
}

/// What the schemas say of non-finite values.
const NON_FINITE: &str = "Non-finite values (NaN, ±infinity), which JSON numbers cannot hold, \
    are written as null and read back as NaN.";

impl Field for f64 {
    fn write(&self, out: &mut Vec<u8>) {
        if self.is_finite() {
            write_serde(self, out);
        } else {
            // JSON has no NaN or infinity; `null` is what JSON tools (Foxglove, serde_json,
            // JavaScript's JSON.stringify) make of them.
            out.extend_from_slice(b"null");
        }
    }

    fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
        let bad = || DecodeError::Type {
            field: field.to_owned(),
            expected: "a number or null",
        };
        match value {
            Value::Number(n) => n.as_f64().ok_or_else(bad),
            Value::Null => Ok(f64::NAN),
            _ => Err(bad()),
        }
    }

    fn schema(description: &str) -> Value {
        json!({
            "type": ["number", "null"],
            "description": format!("{description} {NON_FINITE}"),
        })
    }
}

/// The unsigned integer fields: written as serde writes them, read back only if in range.
macro_rules! unsigned_fields {
    ($($ty:ty: $expected:literal;)*) => {$(
        impl Field for $ty {
            fn write(&self, out: &mut Vec<u8>) {
                write_serde(self, out);
            }

            fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
                value
                    .as_u64()
                    .and_then(|v| <$ty>::try_from(v).ok())
                    .ok_or_else(|| DecodeError::Type {
                        field: field.to_owned(),
                        expected: $expected,
                    })
            }

            fn schema(description: &str) -> Value {
                json!({
                    "type": "integer",
                    "minimum": 0,
                    "maximum": <$ty>::MAX,
                    "description": description,
                })
            }
        }
    )*};
}

unsigned_fields! {
    u64: "an integer from 0 to 2^64 - 1";
    u32: "an integer from 0 to 2^32 - 1";
    u8: "an integer from 0 to 255";
}

/// Eight raw bytes (a CAN frame's payload), as an array of integers.
impl Field for [u8; 8] {
    fn write(&self, out: &mut Vec<u8>) {
        write_serde(&self[..], out);
    }

    fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
        let items = value.as_array().ok_or_else(|| DecodeError::Type {
            field: field.to_owned(),
            expected: "an array of 8 bytes",
        })?;
        if items.len() != 8 {
            return Err(DecodeError::Length {
                field: field.to_owned(),
                expected: 8,
                found: items.len(),
            });
        }
        let mut out = [0u8; 8];
        for (i, (slot, item)) in out.iter_mut().zip(items).enumerate() {
            *slot = u8::read(item, &format!("{field}[{i}]"))?;
        }
        Ok(out)
    }

    fn schema(description: &str) -> Value {
        json!({
            "type": "array",
            "items": {"type": "integer", "minimum": 0, "maximum": 255},
            "minItems": 8,
            "maxItems": 8,
            "description": description,
        })
    }
}

impl<const N: usize> Field for [f64; N] {
    fn write(&self, out: &mut Vec<u8>) {
        out.push(b'[');
        for (i, v) in self.iter().enumerate() {
            if i > 0 {
                out.push(b',');
            }
            v.write(out);
        }
        out.push(b']');
    }

    fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
        let items = value.as_array().ok_or_else(|| DecodeError::Type {
            field: field.to_owned(),
            expected: "an array of numbers",
        })?;
        if items.len() != N {
            return Err(DecodeError::Length {
                field: field.to_owned(),
                expected: N,
                found: items.len(),
            });
        }
        let mut out = [0.0; N];
        for (i, (slot, item)) in out.iter_mut().zip(items).enumerate() {
            *slot = f64::read(item, &format!("{field}[{i}]"))?;
        }
        Ok(out)
    }

    fn schema(description: &str) -> Value {
        json!({
            "type": "array",
            "items": {"type": ["number", "null"]},
            "minItems": N,
            "maxItems": N,
            "description": format!("{description} {NON_FINITE}"),
        })
    }
}

macro_rules! name_field {
    ($n:literal) => {
/// NUL-padded UTF-8 name ([`ipc_types::Heartbeat::name`]).
///
/// Written as a JSON string when the bytes are canonical (valid UTF-8 up to the first NUL, only
/// NULs after it), otherwise as an array of the 32 raw bytes, so decoding is always exact.
impl Field for [u8; $n] {
    fn write(&self, out: &mut Vec<u8>) {
        let len = self.iter().position(|&b| b == 0).unwrap_or(self.len());
        let (text, rest) = self.split_at(len);
        match core::str::from_utf8(text) {
            Ok(s) if rest.iter().all(|&b| b == 0) => write_serde(s, out),
            _ => write_serde(&self[..], out),
        }
    }

    fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
        let mut out = [0u8; $n];
        match value {
            Value::String(s) => {
                let bytes = s.as_bytes();
                if bytes.len() > out.len() || bytes.contains(&0) {
                    return Err(DecodeError::Type {
                        field: field.to_owned(),
                        expected: concat!("a string of at most ", $n, " UTF-8 bytes without NUL"),
                    });
                }
                out[..bytes.len()].copy_from_slice(bytes);
                Ok(out)
            }
            Value::Array(items) => {
                if items.len() != out.len() {
                    return Err(DecodeError::Length {
                        field: field.to_owned(),
                        expected: out.len(),
                        found: items.len(),
                    });
                }
                for (i, (slot, item)) in out.iter_mut().zip(items).enumerate() {
                    *slot = item
                        .as_u64()
                        .and_then(|v| u8::try_from(v).ok())
                        .ok_or_else(|| DecodeError::Type {
                            field: format!("{field}[{i}]"),
                            expected: "an integer from 0 to 255",
                        })?;
                }
                Ok(out)
            }
            _ => Err(DecodeError::Type {
                field: field.to_owned(),
                expected: concat!("a string or an array of ", $n, " bytes"),
            }),
        }
    }

    fn schema(description: &str) -> Value {
        json!({
            "oneOf": [
                {"type": "string"},
                {
                    "type": "array",
                    "items": {"type": "integer", "minimum": 0, "maximum": 255},
                    "minItems": $n,
                    "maxItems": $n,
                },
            ],
            "description": format!(
                "{description} A string when the {} bytes are UTF-8 padded with NULs, otherwise \
                 the raw bytes.", $n
            ),
        })
    }
}

    };
}

name_field!(32);
// The reason of a ground command's acknowledgement.
name_field!(256);

/// The flag bits of [`SampleHeader::flags`], for the schema description.
const FLAGS_DESCRIPTION: &str = "Bit set of validity flags: bit 0 VALID (data may be used), \
    bits 1-4 SATURATED channel 0-3 (x, y, z, 4th gimbal), bit 5 OUT_OF_RANGE, bit 8 STALE \
    (repeat of an older measurement), bit 9 SIMULATED, bit 10 REPLAYED.";

impl Field for SampleHeader {
    fn write(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(b"{\"time_ns\":");
        self.time_ns.write(out);
        out.extend_from_slice(b",\"sequence\":");
        self.sequence.write(out);
        out.extend_from_slice(b",\"flags\":");
        self.flags.write(out);
        out.extend_from_slice(b",\"source_id\":");
        self.source_id.write(out);
        out.push(b'}');
    }

    fn read(value: &Value, field: &str) -> Result<Self, DecodeError> {
        let obj = as_object(value, field)?;
        let header = SampleHeader {
            time_ns: member(obj, field, "time_ns")?,
            sequence: member(obj, field, "sequence")?,
            flags: member(obj, field, "flags")?,
            source_id: member(obj, field, "source_id")?,
        };
        check_no_extra(obj, field, &["time_ns", "sequence", "flags", "source_id"])?;
        Ok(header)
    }

    fn schema(description: &str) -> Value {
        object_schema(
            "testbed::SampleHeader.v1",
            description,
            &[
                (
                    "time_ns",
                    u64::schema(
                        "Time of validity: the instant the sample describes, ns on the run's \
                         clock (device or simulation time, never the wall clock).",
                    ),
                ),
                (
                    "sequence",
                    u64::schema("Per-publisher sequence number, +1 for every published sample."),
                ),
                ("flags", u32::schema(FLAGS_DESCRIPTION)),
                (
                    "source_id",
                    u32::schema("Identifier of the producing instance, 0 if there is one."),
                ),
            ],
        )
    }
}

/// `value` as an object, or a type error naming `field` (empty for the message itself).
pub(crate) fn as_object<'a>(
    value: &'a Value,
    field: &str,
) -> Result<&'a Map<String, Value>, DecodeError> {
    value.as_object().ok_or_else(|| DecodeError::Type {
        field: if field.is_empty() {
            "(message)".to_owned()
        } else {
            field.to_owned()
        },
        expected: "an object",
    })
}

/// Decodes member `name` of `obj`, which sits at path `parent`.
pub(crate) fn member<T: Field>(
    obj: &Map<String, Value>,
    parent: &str,
    name: &str,
) -> Result<T, DecodeError> {
    let field = path(parent, name);
    match obj.get(name) {
        Some(value) => T::read(value, &field),
        None => Err(DecodeError::Missing { field }),
    }
}

/// Fails if `obj` has a member not in `known`.
pub(crate) fn check_no_extra(
    obj: &Map<String, Value>,
    parent: &str,
    known: &[&str],
) -> Result<(), DecodeError> {
    match obj.keys().find(|k| !known.contains(&k.as_str())) {
        Some(extra) => Err(DecodeError::Unknown {
            field: path(parent, extra),
        }),
        None => Ok(()),
    }
}

/// JSON Schema of an object with exactly the given properties, all required.
pub(crate) fn object_schema(title: &str, description: &str, properties: &[(&str, Value)]) -> Value {
    let props: Map<String, Value> = properties
        .iter()
        .map(|(name, schema)| ((*name).to_owned(), schema.clone()))
        .collect();
    let required: Vec<&str> = properties.iter().map(|(name, _)| *name).collect();
    json!({
        "title": title,
        "description": description,
        "type": "object",
        "properties": props,
        "required": required,
        "additionalProperties": false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round<T: Field>(v: &T) -> T {
        let mut out = Vec::new();
        v.write(&mut out);
        let value: Value = serde_json::from_slice(&out).expect("valid JSON");
        T::read(&value, "x").expect("decodes")
    }

    #[test]
    fn floats_round_trip_exactly() {
        for v in [
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-300,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            -1.2345e17,
        ] {
            assert_eq!(round(&v).to_bits(), v.to_bits(), "{v:e}");
        }
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut out = Vec::new();
            v.write(&mut out);
            assert_eq!(out, b"null", "{v}");
            assert!(round(&v).is_nan(), "{v}");
        }
        let string: Value = serde_json::from_str("\"NaN\"").expect("json");
        assert!(f64::read(&string, "x").is_err(), "a string is not a number");
    }

    #[test]
    fn integers_round_trip_at_their_limits() {
        assert_eq!(round(&u64::MAX), u64::MAX);
        assert_eq!(round(&u32::MAX), u32::MAX);
        let too_big: Value = serde_json::from_str("4294967296").expect("json");
        assert!(u32::read(&too_big, "x").is_err());
        let negative: Value = serde_json::from_str("-1").expect("json");
        assert!(u64::read(&negative, "x").is_err());
    }

    #[test]
    fn names_are_strings_when_canonical_and_exact_otherwise() {
        let mut name = [0u8; 32];
        name[..3].copy_from_slice(b"gnc");
        let mut out = Vec::new();
        name.write(&mut out);
        assert_eq!(out, b"\"gnc\"");
        assert_eq!(round(&name), name);

        name[10] = 0xff; // garbage after the NUL: kept byte for byte
        let mut out = Vec::new();
        name.write(&mut out);
        assert_eq!(out[0], b'[');
        assert_eq!(round(&name), name);

        let full = [b'a'; 32];
        assert_eq!(round(&full), full);
    }

    #[test]
    fn array_length_is_checked() {
        let v: Value = serde_json::from_str("[1, 2]").expect("json");
        assert!(matches!(
            <[f64; 3]>::read(&v, "rate"),
            Err(DecodeError::Length {
                expected: 3,
                found: 2,
                ..
            })
        ));
    }
}
