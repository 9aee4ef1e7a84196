//! The measured-data CSV directory (`shared/DESIGN.md`): read it into a [`Dataset`], write one.
//!
//! SI units, body axes, one header row, comma-separated, `t_s` seconds from any origin, rows in
//! time order; files may be missing where a device was absent. Columns may come in any order
//! but must be exactly the contract's (an unknown or missing column is refused, naming it).
//! Blank lines are skipped. Every error names the file and, for content, the row.

use crate::data::{CmgRow, Dataset, FieldRow, GyroRow, TiltRow, WheelRow, files};
use crate::error::DataError;
use nalgebra::{Vector3, Vector4};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Columns of each file, in the contract's order.
pub mod columns {
    pub const GYRO: &[&str] = &["t_s", "wx", "wy", "wz"];
    pub const INCLINOMETER: &[&str] = &["t_s", "tilt_x", "tilt_y"];
    pub const MAGNETOMETER: &[&str] = &["t_s", "bx", "by", "bz"];
    pub const WHEELS: &[&str] = &[
        "t_s", "speed_x", "speed_y", "speed_z", "torque_x", "torque_y", "torque_z",
    ];
    pub const CMG: &[&str] = &[
        "t_s",
        "gimbal_1",
        "gimbal_2",
        "gimbal_3",
        "gimbal_4",
        "rate_cmd_1",
        "rate_cmd_2",
        "rate_cmd_3",
        "rate_cmd_4",
    ];
}

/// Read a measured-data directory. Missing files are absent devices; [`Dataset::check`] then
/// says whether what is there is enough.
pub fn read_dir(dir: &Path) -> Result<Dataset, DataError> {
    if !dir.is_dir() {
        return Err(DataError::NotData {
            path: dir.to_path_buf(),
        });
    }
    let gyro = read_file(dir, files::GYRO, columns::GYRO)?
        .into_iter()
        .map(|v| GyroRow {
            t_s: v[0],
            rate_rad_s: Vector3::new(v[1], v[2], v[3]),
        })
        .collect();
    let inclinometer = read_file(dir, files::INCLINOMETER, columns::INCLINOMETER)?
        .into_iter()
        .map(|v| TiltRow {
            t_s: v[0],
            tilt_rad: [v[1], v[2]],
        })
        .collect();
    let magnetometer = read_file(dir, files::MAGNETOMETER, columns::MAGNETOMETER)?
        .into_iter()
        .map(|v| FieldRow {
            t_s: v[0],
            field_t: Vector3::new(v[1], v[2], v[3]),
        })
        .collect();
    let wheels = read_file(dir, files::WHEELS, columns::WHEELS)?
        .into_iter()
        .map(|v| WheelRow {
            t_s: v[0],
            speed_rad_s: Vector3::new(v[1], v[2], v[3]),
            torque_nm: Vector3::new(v[4], v[5], v[6]),
        })
        .collect();
    let cmg = read_file(dir, files::CMG, columns::CMG)?
        .into_iter()
        .map(|v| CmgRow {
            t_s: v[0],
            gimbal_rad: Vector4::new(v[1], v[2], v[3], v[4]),
            rate_cmd_rad_s: Vector4::new(v[5], v[6], v[7], v[8]),
        })
        .collect();
    Ok(Dataset {
        source: dir.to_path_buf(),
        gyro,
        inclinometer,
        magnetometer,
        wheels,
        cmg,
    })
}

/// Read one file of the directory into rows of values in the contract's column order; an
/// absent file gives no rows.
fn read_file(dir: &Path, name: &str, contract: &[&str]) -> Result<Vec<Vec<f64>>, DataError> {
    let path = dir.join(name);
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text = std::fs::read_to_string(&path).map_err(|source| DataError::Read {
        file: path.clone(),
        source,
    })?;
    parse(&path, &text, contract)
}

/// Parse CSV text against the contract's columns (see the module documentation). Checks
/// finiteness and time order as it goes.
pub fn parse(file: &Path, text: &str, contract: &[&str]) -> Result<Vec<Vec<f64>>, DataError> {
    let expected = contract.join(",");
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(DataError::Empty {
            file: file.to_path_buf(),
            expected,
        });
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let header_error = |message: String| DataError::Header {
        file: file.to_path_buf(),
        message,
        expected: expected.clone(),
    };
    let mut position = Vec::with_capacity(contract.len());
    for want in contract {
        match names.iter().position(|n| n == want) {
            Some(p) => position.push(p),
            None => {
                return Err(header_error(format!(
                    "column `{want}` is missing (header `{}`)",
                    header.trim()
                )));
            }
        }
    }
    if let Some(extra) = names.iter().find(|n| !contract.contains(n)) {
        return Err(header_error(format!("unknown column `{extra}`")));
    }
    if names.len() != contract.len() {
        return Err(header_error(format!(
            "{} columns, expected {}",
            names.len(),
            contract.len()
        )));
    }
    let mut rows = Vec::new();
    let mut previous_t: Option<f64> = None;
    for (index, line) in lines {
        let row = rows.len() + 1;
        let at = |message: String| DataError::Row {
            file: file.to_path_buf(),
            row,
            line: index + 1,
            message,
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != contract.len() {
            return Err(at(format!(
                "{} fields, the header has {}",
                fields.len(),
                contract.len()
            )));
        }
        let mut values = Vec::with_capacity(contract.len());
        for (name, &p) in contract.iter().zip(&position) {
            let text = fields[p];
            let x: f64 = text
                .parse()
                .map_err(|_| at(format!("column `{name}`: `{text}` is not a number")))?;
            if !x.is_finite() {
                return Err(at(format!(
                    "column `{name}`: `{text}` is not a finite number"
                )));
            }
            values.push(x);
        }
        if let Some(p) = previous_t.filter(|p| values[0] <= *p) {
            return Err(at(format!(
                "time {} s is not after the previous row's {p} s (rows must be in time order)",
                values[0]
            )));
        }
        previous_t = Some(values[0]);
        rows.push(values);
    }
    Ok(rows)
}

/// Write `data` as a measured-data directory (creating it); devices without rows get no file.
/// Numbers are written in the shortest form that reads back to the same value.
pub fn write_dir(dir: &Path, data: &Dataset) -> Result<Vec<PathBuf>, DataError> {
    std::fs::create_dir_all(dir).map_err(|source| DataError::Write {
        file: dir.to_path_buf(),
        source,
    })?;
    let mut written = Vec::new();
    let mut put = |name: &str, contract: &[&str], rows: Vec<Vec<f64>>| -> Result<(), DataError> {
        if rows.is_empty() {
            return Ok(());
        }
        let mut text = contract.join(",");
        text.push('\n');
        for row in rows {
            for (i, x) in row.iter().enumerate() {
                if i > 0 {
                    text.push(',');
                }
                let _ = write!(text, "{x}");
            }
            text.push('\n');
        }
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|source| DataError::Write {
            file: path.clone(),
            source,
        })?;
        written.push(path);
        Ok(())
    };
    put(
        files::GYRO,
        columns::GYRO,
        data.gyro
            .iter()
            .map(|r| [&[r.t_s][..], r.rate_rad_s.as_slice()].concat())
            .collect(),
    )?;
    put(
        files::INCLINOMETER,
        columns::INCLINOMETER,
        data.inclinometer
            .iter()
            .map(|r| vec![r.t_s, r.tilt_rad[0], r.tilt_rad[1]])
            .collect(),
    )?;
    put(
        files::MAGNETOMETER,
        columns::MAGNETOMETER,
        data.magnetometer
            .iter()
            .map(|r| [&[r.t_s][..], r.field_t.as_slice()].concat())
            .collect(),
    )?;
    put(
        files::WHEELS,
        columns::WHEELS,
        data.wheels
            .iter()
            .map(|r| {
                [
                    &[r.t_s][..],
                    r.speed_rad_s.as_slice(),
                    r.torque_nm.as_slice(),
                ]
                .concat()
            })
            .collect(),
    )?;
    put(
        files::CMG,
        columns::CMG,
        data.cmg
            .iter()
            .map(|r| {
                [
                    &[r.t_s][..],
                    r.gimbal_rad.as_slice(),
                    r.rate_cmd_rad_s.as_slice(),
                ]
                .concat()
            })
            .collect(),
    )?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_gyro(text: &str) -> Result<Vec<Vec<f64>>, String> {
        parse(Path::new("d/gyro.csv"), text, columns::GYRO).map_err(|e| e.to_string())
    }

    #[test]
    fn reads_columns_in_any_order() {
        let rows = parse_gyro("wz,t_s,wx,wy\n3,0.0,1,2\n6,0.1,4,5\n").unwrap();
        assert_eq!(
            rows,
            vec![vec![0.0, 1.0, 2.0, 3.0], vec![0.1, 4.0, 5.0, 6.0]]
        );
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
            e.contains("row 2") && e.contains("not a finite number"),
            "{e}"
        );
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2,3\n0.2,1,2,3\n0.1,1,2,3\n").unwrap_err();
        assert!(e.contains("row 3") && e.contains("time order"), "{e}");
        let e = parse_gyro("t_s,wx,wy\n0,1,2\n").unwrap_err();
        assert!(e.contains("header") && e.contains("`wz` is missing"), "{e}");
        let e = parse_gyro("t_s,wx,wy,wz,temp\n0,1,2,3,4\n").unwrap_err();
        assert!(e.contains("unknown column `temp`"), "{e}");
        let e = parse_gyro("t_s,wx,wy,wz\n0,1,2\n").unwrap_err();
        assert!(e.contains("row 1") && e.contains("3 fields"), "{e}");
        let e = parse_gyro("").unwrap_err();
        assert!(e.contains("empty"), "{e}");
    }
}
