//! The measured-data CSV files (`docs/measured-data.md`): their names, their columns, and one
//! plain record type per file, read and written through the `csv` crate with serde.
//!
//! This module knows nothing of [`crate::Dataset`]: `data.rs` converts between the records and
//! the dataset ([`Records`] ⇄ `Dataset`), so [`read_dir`] and [`write_dir`] work with any type
//! that converts from and to [`Records`].
//!
//! SI units, body axes, one header row, comma-separated, `t_s` seconds from any origin, rows in
//! time order; files may be missing where a device was absent. Columns may come in any order
//! but must be exactly the contract's (an unknown, duplicate or missing column is refused,
//! naming it). Empty lines are skipped, spaces around fields ignored. Numbers must be complete
//! decimal numbers (`-1.5`, `2e-3`, `.5`): a truncated or malformed one (`1e`, `1.`, `-`,
//! `1.2.3`) is refused, as is a non-finite one (`NaN`, `inf`). Every error names the file and,
//! for content, the data row, its line in the file and the column.

use crate::error::DataError;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::path::{Path, PathBuf};

/// File names of the CSV contract.
pub mod files {
    pub const GYRO: &str = "gyro.csv";
    pub const INCLINOMETER: &str = "inclinometer.csv";
    pub const MAGNETOMETER: &str = "magnetometer.csv";
    pub const WHEELS: &str = "wheels.csv";
    pub const CMG: &str = "cmg.csv";
    pub const THRUSTERS: &str = "thrusters.csv";
}

/// One row of a contract file: its columns (in the contract's order, time first) are the
/// record's fields.
pub trait Record: DeserializeOwned + Serialize {
    /// Column names in the contract's order; the first is the time `t_s`.
    const COLUMNS: &'static [&'static str];
    /// The row's time, s.
    fn t_s(&self) -> f64;
}

/// A record type whose fields are the file's columns, each a number read strictly
/// ([`parse_number`]) and written in the shortest form that reads back to the same value.
macro_rules! record {
    ($(#[$meta:meta])* $name:ident { $($(#[$fmeta:meta])* $field:ident),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
        pub struct $name {
            $(
                $(#[$fmeta])*
                #[serde(deserialize_with = "number", serialize_with = "shortest")]
                pub $field: f64,
            )+
        }

        impl Record for $name {
            const COLUMNS: &'static [&'static str] = &[$(stringify!($field)),+];
            fn t_s(&self) -> f64 {
                self.t_s
            }
        }
    };
}

record! {
    /// A `gyro.csv` row: body rate, rad/s.
    GyroRecord { t_s, wx, wy, wz }
}
record! {
    /// An `inclinometer.csv` row: tilt of body X and body Y against the level plane, rad.
    TiltRecord { t_s, tilt_x, tilt_y }
}
record! {
    /// A `magnetometer.csv` row: flux density, body axes, T.
    FieldRecord { t_s, bx, by, bz }
}
record! {
    /// A `wheels.csv` row: wheel speeds rad/s, motor-torque commands Nm.
    WheelRecord { t_s, speed_x, speed_y, speed_z, torque_x, torque_y, torque_z }
}
record! {
    /// A `cmg.csv` row: gimbal angles rad, gimbal-rate commands rad/s.
    CmgRecord {
        t_s, gimbal_1, gimbal_2, gimbal_3, gimbal_4,
        rate_cmd_1, rate_cmd_2, rate_cmd_3, rate_cmd_4,
    }
}

record! {
    /// A `thrusters.csv` row: the valve on-time applied to each of the six thrusters for the
    /// command period starting at `t_s`, s (0: shut).
    ThrusterRecord {
        t_s, on_time_0_s, on_time_1_s, on_time_2_s, on_time_3_s, on_time_4_s, on_time_5_s,
    }
}

/// Columns of each file, in the contract's order.
pub mod columns {
    use super::Record;
    pub const GYRO: &[&str] = super::GyroRecord::COLUMNS;
    pub const INCLINOMETER: &[&str] = super::TiltRecord::COLUMNS;
    pub const MAGNETOMETER: &[&str] = super::FieldRecord::COLUMNS;
    pub const WHEELS: &[&str] = super::WheelRecord::COLUMNS;
    pub const CMG: &[&str] = super::CmgRecord::COLUMNS;
    pub const THRUSTERS: &[&str] = super::ThrusterRecord::COLUMNS;
}

/// The contents of a measured-data directory as plain records; an empty series is an absent
/// file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Records {
    /// The directory (for messages).
    pub dir: PathBuf,
    pub gyro: Vec<GyroRecord>,
    pub inclinometer: Vec<TiltRecord>,
    pub magnetometer: Vec<FieldRecord>,
    pub wheels: Vec<WheelRecord>,
    pub cmg: Vec<CmgRecord>,
    pub thrusters: Vec<ThrusterRecord>,
}

/// Read a measured-data directory (into a [`crate::Dataset`], or anything built from
/// [`Records`]). Missing files are absent devices; `Dataset::check` then says whether what is
/// there is enough.
pub fn read_dir<D: From<Records>>(dir: &Path) -> Result<D, DataError> {
    if !dir.is_dir() {
        return Err(DataError::NotData {
            path: dir.to_path_buf(),
        });
    }
    Ok(D::from(Records {
        dir: dir.to_path_buf(),
        gyro: read_file(&dir.join(files::GYRO))?,
        inclinometer: read_file(&dir.join(files::INCLINOMETER))?,
        magnetometer: read_file(&dir.join(files::MAGNETOMETER))?,
        wheels: read_file(&dir.join(files::WHEELS))?,
        cmg: read_file(&dir.join(files::CMG))?,
        thrusters: read_file(&dir.join(files::THRUSTERS))?,
    }))
}

/// Write `data` as a measured-data directory (creating it); devices without rows get no file.
/// Returns the files written.
pub fn write_dir<D>(dir: &Path, data: &D) -> Result<Vec<PathBuf>, DataError>
where
    for<'a> Records: From<&'a D>,
{
    let records = Records::from(data);
    std::fs::create_dir_all(dir).map_err(|source| DataError::Write {
        file: dir.to_path_buf(),
        source,
    })?;
    let mut written = Vec::new();
    for (name, done) in [
        (
            files::GYRO,
            write_file(&dir.join(files::GYRO), &records.gyro),
        ),
        (
            files::INCLINOMETER,
            write_file(&dir.join(files::INCLINOMETER), &records.inclinometer),
        ),
        (
            files::MAGNETOMETER,
            write_file(&dir.join(files::MAGNETOMETER), &records.magnetometer),
        ),
        (
            files::WHEELS,
            write_file(&dir.join(files::WHEELS), &records.wheels),
        ),
        (files::CMG, write_file(&dir.join(files::CMG), &records.cmg)),
        (
            files::THRUSTERS,
            write_file(&dir.join(files::THRUSTERS), &records.thrusters),
        ),
    ] {
        if done? {
            written.push(dir.join(name));
        }
    }
    Ok(written)
}

/// Read one contract file; an absent file gives no rows.
pub fn read_file<R: Record>(path: &Path) -> Result<Vec<R>, DataError> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let file = std::fs::File::open(path).map_err(|source| DataError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    read_records(path, std::io::BufReader::new(file))
}

/// Read CSV text of a contract file (`file` names it in errors). Checks the header, every
/// number, and the time order.
pub fn read_records<R: Record>(
    file: &Path,
    mut input: impl std::io::Read,
) -> Result<Vec<R>, DataError> {
    let mut text = String::new();
    input
        .read_to_string(&mut text)
        .map_err(|source| DataError::Read {
            file: file.to_path_buf(),
            source,
        })?;
    let mut lines = LineCounter::new(&text);
    let contract = R::COLUMNS;
    let expected = contract.join(",");
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(::csv::Trim::All)
        .from_reader(text.as_bytes());
    let io_error = |e: ::csv::Error| match e.kind() {
        ::csv::ErrorKind::Io(_) => DataError::Read {
            file: file.to_path_buf(),
            source: match e.into_kind() {
                ::csv::ErrorKind::Io(source) => source,
                _ => unreachable!(),
            },
        },
        _ => DataError::Content {
            file: file.to_path_buf(),
            message: e.to_string(),
        },
    };
    let headers = reader.headers().map_err(io_error)?.clone();
    if headers.is_empty() || headers.iter().all(str::is_empty) {
        return Err(DataError::Empty {
            file: file.to_path_buf(),
            expected,
        });
    }
    let header_error = |message: String| DataError::Header {
        file: file.to_path_buf(),
        message,
        expected: expected.clone(),
    };
    let header_text = headers.iter().collect::<Vec<_>>().join(",");
    for want in contract {
        if !headers.iter().any(|n| n == *want) {
            return Err(header_error(format!(
                "column `{want}` is missing (header `{header_text}`)"
            )));
        }
    }
    if let Some(extra) = headers.iter().find(|n| !contract.contains(n)) {
        return Err(header_error(format!("unknown column `{extra}`")));
    }
    if headers.len() != contract.len() {
        return Err(header_error(format!(
            "{} columns, expected {} (a column appears twice)",
            headers.len(),
            contract.len()
        )));
    }
    let mut rows: Vec<R> = Vec::new();
    let mut record = ::csv::StringRecord::new();
    loop {
        let more = reader.read_record(&mut record).map_err(|e| {
            let line = e.position().map(|p| lines.line_of(p.byte() as usize));
            match line {
                Some(line) => DataError::Row {
                    file: file.to_path_buf(),
                    row: rows.len() + 1,
                    line: Some(line),
                    message: e.to_string(),
                },
                None => io_error(e),
            }
        })?;
        if !more {
            break;
        }
        let row = rows.len() + 1;
        let line = record
            .position()
            .map_or(row + 1, |p| lines.line_of(p.byte() as usize));
        let at = |message: String| DataError::Row {
            file: file.to_path_buf(),
            row,
            line: Some(line),
            message,
        };
        if record.len() != headers.len() {
            let column = if record.len() < headers.len() {
                format!("column `{}` is missing", &headers[record.len()])
            } else {
                format!("field {} has no column", headers.len() + 1)
            };
            return Err(at(format!(
                "{} fields, the header has {} ({column}; truncated line?)",
                record.len(),
                headers.len()
            )));
        }
        let value: R = record.deserialize(Some(&headers)).map_err(|e| {
            // The offending column: the one the error names, else the first field that is not
            // a number.
            let field = match e.kind() {
                ::csv::ErrorKind::Deserialize { err, .. } => err.field(),
                _ => None,
            };
            let column = field
                .map(|i| i as usize)
                .or_else(|| record.iter().position(|f| parse_number(f).is_err()));
            match column {
                Some(i) => {
                    let text = record.get(i).unwrap_or("");
                    let why = parse_number(text).err().unwrap_or_else(|| e.to_string());
                    at(format!("column `{}`: {why}", &headers[i]))
                }
                None => at(e.to_string()),
            }
        })?;
        if let Some(p) = rows.last().map(R::t_s).filter(|p| value.t_s() <= *p) {
            return Err(at(format!(
                "column `t_s`: time {} s is not after the previous row's {p} s (rows must be in \
                 time order)",
                value.t_s()
            )));
        }
        rows.push(value);
    }
    // A writer killed mid-row leaves a last line without its newline, and a number cut there
    // (`0.12` of `0.1234`) still parses: an unended last row is refused, naming its last field.
    if !rows.is_empty() && !text.ends_with('\n') {
        let last = text.rsplit('\n').next().unwrap_or_default();
        let fields = last.split(',').count();
        let column = headers.get(fields.saturating_sub(1)).unwrap_or("?");
        let value = last.rsplit(',').next().unwrap_or_default().trim();
        return Err(DataError::Row {
            file: file.to_path_buf(),
            row: rows.len(),
            line: Some(text.split('\n').count()),
            message: format!(
                "column `{column}`: `{value}` ends the file without a newline: the file looks \
                 cut while being written (a cut number still parses); if the row is complete, \
                 end the file with a newline"
            ),
        });
    }
    Ok(rows)
}

/// Line numbers (from 1) of records by their byte offset, counted incrementally; a record
/// starting at an empty line is on the next line that is not empty (the reader skips empty
/// lines).
struct LineCounter<'t> {
    text: &'t str,
    at: usize,
    line: usize,
}

impl<'t> LineCounter<'t> {
    fn new(text: &'t str) -> Self {
        Self {
            text,
            at: 0,
            line: 1,
        }
    }

    fn line_of(&mut self, byte: usize) -> usize {
        let byte = byte.min(self.text.len());
        if byte > self.at {
            self.line += self.text.as_bytes()[self.at..byte]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.at = byte;
        }
        let (mut pos, mut line) = (self.at, self.line);
        while let Some(end) = self.text.as_bytes()[pos..].iter().position(|&b| b == b'\n') {
            if !matches!(&self.text.as_bytes()[pos..pos + end], b"" | b"\r") {
                break;
            }
            pos += end + 1;
            line += 1;
        }
        line
    }
}

/// Write one contract file (header in the contract's order); no file without rows. Whether a
/// file was written.
pub fn write_file<R: Record>(path: &Path, rows: &[R]) -> Result<bool, DataError> {
    if rows.is_empty() {
        return Ok(false);
    }
    let write_error = |e: ::csv::Error| DataError::Write {
        file: path.to_path_buf(),
        source: match e.into_kind() {
            ::csv::ErrorKind::Io(source) => source,
            other => std::io::Error::other(format!("{other:?}")),
        },
    };
    let mut writer = ::csv::Writer::from_path(path).map_err(write_error)?;
    for row in rows {
        writer.serialize(row).map_err(write_error)?;
    }
    writer.flush().map_err(|source| DataError::Write {
        file: path.to_path_buf(),
        source,
    })?;
    Ok(true)
}

/// A number of the contract: `[+-]digits[.digits][(e|E)[+-]digits]` or `[+-].digits[…]`,
/// finite. A truncated or malformed number (`1e`, `2.`, `-`, `1.2.3`, empty) is refused; the
/// error says why.
pub fn parse_number(text: &str) -> Result<f64, String> {
    let b = text.as_bytes();
    let digits = |mut i: usize| {
        let start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        (i, i - start)
    };
    let mut i = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let (after_int, int_digits) = digits(i);
    i = after_int;
    let mut complete = int_digits > 0;
    if b.get(i) == Some(&b'.') {
        let (after_frac, frac_digits) = digits(i + 1);
        i = after_frac;
        complete = frac_digits > 0;
    }
    if complete && matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let (after_exp, exp_digits) = digits(i);
        i = after_exp;
        complete = exp_digits > 0;
    }
    let lower = text.to_ascii_lowercase();
    let word = lower.trim_start_matches(['+', '-']);
    if matches!(word, "nan" | "inf" | "infinity") {
        return Err(format!("`{text}` is not a finite number"));
    }
    if text.is_empty() {
        return Err("empty field, expected a number".into());
    }
    if !complete || i != b.len() {
        return Err(format!("`{text}` is not a number (truncated or malformed)"));
    }
    let x: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("`{text}` is not a finite number (out of range)"))
    }
}

fn number<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let text = <&str>::deserialize(d)?;
    parse_number(text).map_err(serde::de::Error::custom)
}

/// The shortest decimal form that reads back to the same value (Rust's `Display` for `f64`).
fn shortest<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_gyro(text: &str) -> Result<Vec<GyroRecord>, String> {
        read_records(Path::new("d/gyro.csv"), text.as_bytes()).map_err(|e| e.to_string())
    }

    fn gyro(t_s: f64, wx: f64, wy: f64, wz: f64) -> GyroRecord {
        GyroRecord { t_s, wx, wy, wz }
    }

    #[test]
    fn reads_columns_in_any_order() {
        let rows = parse_gyro("wz,t_s,wx,wy\n3,0.0,1,2\n6,0.1,4,5\n").unwrap();
        assert_eq!(
            rows,
            vec![gyro(0.0, 1.0, 2.0, 3.0), gyro(0.1, 4.0, 5.0, 6.0)]
        );
    }

    #[test]
    fn numbers_are_strict() {
        for ok in ["0", "-1.5", "+2", ".5", "1e-3", "2.5E+7", "-0.0"] {
            assert!(parse_number(ok).is_ok(), "{ok}");
        }
        for bad in [
            "", "1e", "1e-", "2.", "-", ".", "1.2.3", "0x10", "1,5", "NaN", "-inf", "1e999",
        ] {
            assert!(parse_number(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn errors_name_file_row_and_column() {
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.1,1,x,3\n").unwrap_err();
        assert!(
            e.contains("gyro.csv")
                && e.contains("row 2")
                && e.contains("line 3")
                && e.contains("`wy`"),
            "{e}"
        );
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.1,1,NaN,3\n").unwrap_err();
        assert!(
            e.contains("row 2") && e.contains("`wy`") && e.contains("not a finite number"),
            "{e}"
        );
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.2,1,2,3\n0.1,1,2,3\n").unwrap_err();
        assert!(e.contains("row 3") && e.contains("time order"), "{e}");
        let e = parse_gyro("t_s,wx,wy\n0,1,2\n").unwrap_err();
        assert!(e.contains("header") && e.contains("`wz` is missing"), "{e}");
        let e = parse_gyro("t_s,wx,wy,wz,temp\n0,1,2,3,4\n").unwrap_err();
        assert!(e.contains("unknown column `temp`"), "{e}");
        let e = parse_gyro("t_s,wx,wy,wz,wx\n0,1,2,3,4\n").unwrap_err();
        assert!(e.contains("twice"), "{e}");
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2\n").unwrap_err();
        assert!(e.contains("row 1") && e.contains("3 fields"), "{e}");
        let e = parse_gyro("").unwrap_err();
        assert!(e.contains("empty"), "{e}");
        // Blank lines are skipped; the line number still counts them.
        let e = parse_gyro("t_s,wx,wy,wz\n\n0,1,2,3\n\n0.1,1,2,3e\n").unwrap_err();
        assert!(
            e.contains("row 2") && e.contains("line 5") && e.contains("`wz`"),
            "{e}"
        );
    }

    #[test]
    fn a_truncated_last_line_is_refused() {
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.12,3.4,5,1e").unwrap_err();
        assert!(
            e.contains("gyro.csv")
                && e.contains("row 2")
                && e.contains("line 3")
                && e.contains("`wz`")
                && e.contains("`1e`"),
            "{e}"
        );
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.12,3.4,1e").unwrap_err();
        assert!(
            e.contains("row 2") && e.contains("3 fields") && e.contains("`wz`"),
            "{e}"
        );
        // Cut inside a number that still parses (0.1234 → 0.12): refused all the same.
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.12,3.4,5,0.12").unwrap_err();
        assert!(
            e.contains("gyro.csv")
                && e.contains("row 2")
                && e.contains("line 3")
                && e.contains("`wz`")
                && e.contains("`0.12`")
                && e.contains("newline"),
            "{e}"
        );
        assert!(parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.12,3.4,5,0.12\n").is_ok());
    }
}
