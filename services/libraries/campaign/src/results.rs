//! A campaign's machine-readable results: one row per run and variant (index, variant, seed,
//! each dispersed value, each metric, the error of a failed run) as CSV and JSON, the runs'
//! series as CSV, and the manifest that ties a directory of results to its campaign.
//!
//! The CSV files are what shards hand to a merge: numbers are written in Rust's shortest form
//! that reads back to the same `f64` (`inf` and `NaN` included), so merged results are the bits
//! a single host computes. Text in, text out: the files are written by the caller.

use crate::error::CampaignError;
use crate::metrics::{Metric, RunMetrics, RunSeries};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One run of one variant, reduced.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    pub index: u64,
    pub variant: String,
    pub seed: u64,
    /// The dispersed keys' values, in the campaign's key order.
    pub values: Vec<f64>,
    pub metrics: RunMetrics,
    /// Why the closed loop stopped, for a run it could not carry out.
    pub error: Option<String>,
    pub series: RunSeries,
}

/// The file names of a results directory.
pub mod files {
    pub const RUNS_CSV: &str = "runs.csv";
    pub const RUNS_JSON: &str = "runs.json";
    pub const SERIES_CSV: &str = "series.csv";
    pub const SUMMARY_JSON: &str = "summary.json";
    pub const MANIFEST_JSON: &str = "manifest.json";
    /// The campaign file's text, as run (a merge reads its options from it).
    pub const CAMPAIGN_TOML: &str = "campaign.toml";
    pub const REPORT_MD: &str = "report.md";
}

/// What a results directory holds: which campaign (its fingerprint: the campaign file and its
/// base run configuration), which runs.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The campaign file as named when it ran.
    pub campaign: String,
    /// Hex FNV-1a of the campaign's text and its base run configuration: shards of one
    /// campaign have the same.
    pub fingerprint: String,
    pub runs: u64,
    /// `i/N` for a shard, `None` for every run.
    pub shard: Option<String>,
    /// How many runs this directory holds (of each variant).
    pub runs_here: u64,
}

const HEAD: [&str; 3] = ["index", "variant", "seed"];

fn cell(x: Option<f64>) -> String {
    x.map_or_else(String::new, |x| x.to_string())
}

/// `runs.csv`: a header, then one line per row.
pub fn runs_csv(keys: &[String], rows: &[RunRow]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<&str> = HEAD
        .into_iter()
        .chain(keys.iter().map(String::as_str))
        .chain(Metric::ALL.iter().map(|m| m.name()))
        .chain(["error"])
        .collect();
    // Writing to memory cannot fail.
    w.write_record(&header).expect("in memory");
    for r in rows {
        let mut record = vec![r.index.to_string(), r.variant.clone(), r.seed.to_string()];
        record.extend(r.values.iter().map(|x| x.to_string()));
        record.extend(r.metrics.0.iter().map(|x| cell(*x)));
        record.push(r.error.clone().unwrap_or_default());
        w.write_record(&record).expect("in memory");
    }
    String::from_utf8(w.into_inner().expect("in memory")).expect("UTF-8 written")
}

/// `series.csv`: per row its quantity (`pointing_error_deg`, `nees`) and its samples, the
/// header naming their times.
pub fn series_csv(rows: &[RunRow], step_s: f64) -> String {
    let length = rows
        .iter()
        .map(|r| r.series.nees.len().max(r.series.pointing_error_deg.len()))
        .max()
        .unwrap_or(0);
    let mut w = csv::WriterBuilder::new()
        .flexible(true)
        .from_writer(Vec::new());
    let mut header = vec!["index".to_string(), "variant".into(), "quantity".into()];
    header.extend((0..length).map(|j| format!("t{}", j as f64 * step_s)));
    w.write_record(&header).expect("in memory");
    for r in rows {
        for (quantity, values) in [
            ("pointing_error_deg", &r.series.pointing_error_deg),
            ("nees", &r.series.nees),
        ] {
            let mut record = vec![r.index.to_string(), r.variant.clone(), quantity.to_string()];
            record.extend(values.iter().map(|x| x.to_string()));
            w.write_record(&record).expect("in memory");
        }
    }
    String::from_utf8(w.into_inner().expect("in memory")).expect("UTF-8 written")
}

/// `runs.json`: the rows as objects, values and metrics by name (`null` where undefined).
pub fn runs_json(keys: &[String], rows: &[RunRow]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let values: serde_json::Map<String, serde_json::Value> = keys
                    .iter()
                    .cloned()
                    .zip(r.values.iter().map(|x| serde_json::json!(x)))
                    .collect();
                let metrics: serde_json::Map<String, serde_json::Value> = Metric::ALL
                    .iter()
                    .map(|m| (m.name().to_string(), serde_json::json!(r.metrics.get(*m))))
                    .collect();
                serde_json::json!({
                    "index": r.index,
                    "variant": r.variant,
                    "seed": r.seed,
                    "values": values,
                    "metrics": metrics,
                    "error": r.error,
                })
            })
            .collect(),
    )
}

/// The rows of `runs.csv` text and `series.csv` text (`path` names the directory in messages),
/// checked against the campaign's `keys`.
pub fn read_rows(
    path: &str,
    keys: &[String],
    runs_text: &str,
    series_text: &str,
) -> Result<Vec<RunRow>, CampaignError> {
    let bad = |reason: String| CampaignError::Results {
        path: path.to_string(),
        reason,
    };
    let mut reader = csv::Reader::from_reader(runs_text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| bad(format!("runs.csv: {e}")))?
        .iter()
        .map(str::to_string)
        .collect();
    let expected: Vec<String> = HEAD
        .iter()
        .map(|s| s.to_string())
        .chain(keys.iter().cloned())
        .chain(Metric::ALL.iter().map(|m| m.name().to_string()))
        .chain(["error".to_string()])
        .collect();
    if header != expected {
        return Err(bad(format!(
            "runs.csv has the columns {}, not this campaign's {}",
            header.join(","),
            expected.join(",")
        )));
    }
    let number = |line: usize, column: &str, text: &str| -> Result<f64, CampaignError> {
        text.parse::<f64>().map_err(|_| {
            bad(format!(
                "runs.csv line {line}: {column} = {text:?} is not a number"
            ))
        })
    };
    let mut rows = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let line = i + 2;
        let record = record.map_err(|e| bad(format!("runs.csv line {line}: {e}")))?;
        let whole = |column: usize| -> Result<u64, CampaignError> {
            record[column].parse().map_err(|_| {
                bad(format!(
                    "runs.csv line {line}: {} = {:?} is not a whole number",
                    expected[column], &record[column]
                ))
            })
        };
        let mut values = Vec::with_capacity(keys.len());
        for (j, key) in keys.iter().enumerate() {
            values.push(number(line, key, &record[3 + j])?);
        }
        let mut metrics = RunMetrics::default();
        for (j, metric) in Metric::ALL.iter().enumerate() {
            let text = &record[3 + keys.len() + j];
            metrics.0[j] = if text.is_empty() {
                None
            } else {
                Some(number(line, metric.name(), text)?)
            };
        }
        let error = &record[3 + keys.len() + Metric::ALL.len()];
        rows.push(RunRow {
            index: whole(0)?,
            variant: record[1].to_string(),
            seed: whole(2)?,
            values,
            metrics,
            error: (!error.is_empty()).then(|| error.to_string()),
            series: RunSeries::default(),
        });
    }

    let mut series: BTreeMap<(u64, String), RunSeries> = BTreeMap::new();
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(series_text.as_bytes());
    for (i, record) in reader.records().enumerate() {
        let line = i + 2;
        let record = record.map_err(|e| bad(format!("series.csv line {line}: {e}")))?;
        if record.len() < 3 {
            return Err(bad(format!("series.csv line {line}: fewer than 3 columns")));
        }
        let index: u64 = record[0]
            .parse()
            .map_err(|_| bad(format!("series.csv line {line}: index {:?}", &record[0])))?;
        let samples = record
            .iter()
            .skip(3)
            .map(|x| {
                x.parse::<f64>()
                    .map_err(|_| bad(format!("series.csv line {line}: {x:?} is not a number")))
            })
            .collect::<Result<Vec<f64>, _>>()?;
        let entry = series.entry((index, record[1].to_string())).or_default();
        match &record[2] {
            "pointing_error_deg" => entry.pointing_error_deg = samples,
            "nees" => entry.nees = samples,
            other => {
                return Err(bad(format!(
                    "series.csv line {line}: unknown quantity {other:?}"
                )));
            }
        }
    }
    for row in &mut rows {
        row.series = series
            .remove(&(row.index, row.variant.clone()))
            .ok_or_else(|| {
                bad(format!(
                    "series.csv has no series of run {} ({})",
                    row.index, row.variant
                ))
            })?;
    }
    Ok(rows)
}

/// Joins the rows of several results directories (`(manifest, rows)` each) of one campaign:
/// same fingerprint, no run twice, every run of every variant present. The rows come back in
/// (index, variant) order, as one host writes them.
pub fn merge(
    parts: Vec<(Manifest, Vec<RunRow>)>,
    variants: &[String],
) -> Result<Vec<RunRow>, CampaignError> {
    let merge_error = CampaignError::Merge;
    let Some(first) = parts.first().map(|p| p.0.clone()) else {
        return Err(merge_error("no results directories given".into()));
    };
    let mut rows: BTreeMap<(u64, usize), RunRow> = BTreeMap::new();
    for (manifest, part) in parts {
        if manifest.fingerprint != first.fingerprint || manifest.runs != first.runs {
            return Err(merge_error(format!(
                "the results of {} (fingerprint {}, {} runs) are not of the same campaign as {} (fingerprint {}, {} runs): same campaign file and base configuration needed",
                manifest.campaign,
                manifest.fingerprint,
                manifest.runs,
                first.campaign,
                first.fingerprint,
                first.runs
            )));
        }
        for row in part {
            let variant = variants
                .iter()
                .position(|v| *v == row.variant)
                .ok_or_else(|| {
                    merge_error(format!(
                        "run {} has the unknown variant {:?}",
                        row.index, row.variant
                    ))
                })?;
            let (index, shard) = (row.index, manifest.shard.clone());
            if rows.insert((index, variant), row).is_some() {
                return Err(merge_error(format!(
                    "run {index} ({}) is in two results directories (the second: shard {})",
                    variants[variant],
                    shard.as_deref().unwrap_or("all")
                )));
            }
        }
    }
    let missing: Vec<String> = (0..first.runs)
        .flat_map(|k| (0..variants.len()).map(move |v| (k, v)))
        .filter(|key| !rows.contains_key(key))
        .take(10)
        .map(|(k, v)| format!("{k} ({})", variants[v]))
        .collect();
    if !missing.is_empty() {
        return Err(merge_error(format!(
            "runs missing (a shard not given or not finished): {}{}",
            missing.join(", "),
            if missing.len() == 10 { ", …" } else { "" }
        )));
    }
    Ok(rows.into_values().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(index: u64, variant: &str) -> RunRow {
        let mut metrics = RunMetrics::default();
        metrics.0[0] = Some(0.1 + index as f64 / 3.0);
        metrics.0[1] = Some(f64::INFINITY);
        metrics.0[2] = Some(1e-300);
        RunRow {
            index,
            variant: variant.into(),
            seed: u64::MAX >> 1,
            values: vec![std::f64::consts::PI * index as f64, -1.0 / 7.0],
            metrics,
            error: (index == 2).then(|| "estimator: \"diverged\", badly".to_string()),
            series: RunSeries {
                pointing_error_deg: vec![5.0 / 3.0, 0.1],
                nees: vec![f64::NAN, 6.000000000000001],
            },
        }
    }

    fn manifest(shard: &str) -> Manifest {
        Manifest {
            campaign: "c.toml".into(),
            fingerprint: "ab".into(),
            runs: 3,
            shard: Some(shard.into()),
            runs_here: 1,
        }
    }

    fn same_bits(a: &RunRow, b: &RunRow) -> bool {
        let bits = |xs: &[f64]| xs.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let metric_bits =
            |m: &RunMetrics| m.0.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
        a.index == b.index
            && a.variant == b.variant
            && a.seed == b.seed
            && a.error == b.error
            && bits(&a.values) == bits(&b.values)
            && metric_bits(&a.metrics) == metric_bits(&b.metrics)
            && bits(&a.series.nees) == bits(&b.series.nees)
            && bits(&a.series.pointing_error_deg) == bits(&b.series.pointing_error_deg)
    }

    #[test]
    fn rows_read_back_bit_for_bit() {
        let keys = vec!["a.b[0]".to_string(), "c".to_string()];
        let rows: Vec<RunRow> = (0..3).map(|k| row(k, "base")).collect();
        let back = read_rows(
            "dir",
            &keys,
            &runs_csv(&keys, &rows),
            &series_csv(&rows, 1.0),
        )
        .unwrap();
        assert_eq!(back.len(), 3);
        assert!(rows.iter().zip(&back).all(|(a, b)| same_bits(a, b)));
        let err = read_rows("dir", &keys[..1], &runs_csv(&keys, &rows), "")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("dir") && err.contains("not this campaign's"),
            "{err}"
        );
        let json = runs_json(&keys, &rows);
        assert_eq!(json[2]["values"]["c"], serde_json::json!(-1.0 / 7.0));
        assert_eq!(json[0]["metrics"]["settle_s"], serde_json::json!(0.1));
    }

    #[test]
    fn merge_joins_shards_in_order_and_refuses_gaps_doubles_and_strangers() {
        let variants = vec!["a".to_string(), "b".to_string()];
        let part = |shard: &str, ks: &[u64]| {
            (
                manifest(shard),
                ks.iter()
                    .flat_map(|k| [row(*k, "b"), row(*k, "a")])
                    .collect::<Vec<_>>(),
            )
        };
        let merged = merge(vec![part("1/2", &[1]), part("0/2", &[0, 2])], &variants).unwrap();
        let order: Vec<(u64, &str)> = merged
            .iter()
            .map(|r| (r.index, r.variant.as_str()))
            .collect();
        assert_eq!(
            order,
            [(0, "a"), (0, "b"), (1, "a"), (1, "b"), (2, "a"), (2, "b")]
        );
        let err = merge(vec![part("0/2", &[0, 2])], &variants)
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing") && err.contains("1 (a)"), "{err}");
        let err = merge(vec![part("0/2", &[0, 2]), part("1/2", &[1, 2])], &variants)
            .unwrap_err()
            .to_string();
        assert!(err.contains("run 2 (b) is in two"), "{err}");
        let mut stranger = part("1/2", &[1]);
        stranger.0.fingerprint = "cd".into();
        let err = merge(vec![part("0/2", &[0, 2]), stranger], &variants)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not of the same campaign"), "{err}");
    }
}
