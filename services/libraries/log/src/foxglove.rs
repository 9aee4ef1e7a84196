//! Foxglove's well-known schemas for what viewers draw natively: the platform's attitude as
//! `foxglove.FrameTransform` (JSON encoding), in the run log and on the ground link.
//!
//! Frames: `level` is the estimator's local-level frame L, `body` the platform body frame as
//! estimated,
//! `body_truth` the simulated true body frame. A transform gives the child frame's pose in the
//! parent frame; the air bearing is the origin of both, so the translation is zero.

use crate::record::LogRecord;
use serde_json::json;
use std::io::Write as _;

/// Schema name of a frame transform.
pub const FRAME_TRANSFORM: &str = "foxglove.FrameTransform";
/// Topic of the estimated attitude as a frame transform (`level` → `body`).
pub const TF_ESTIMATE_TOPIC: &str = "testbed/tf/estimate";
/// Topic of the simulated true attitude as a frame transform (`level` → `body_truth`).
pub const TF_TRUTH_TOPIC: &str = "testbed/tf/truth";
/// Topics the log derives from the samples (not ipc-types topics; readers of samples skip them).
pub const DERIVED_TOPICS: &[&str] = &[TF_ESTIMATE_TOPIC, TF_TRUTH_TOPIC];

/// JSON Schema of `foxglove.FrameTransform` (the fields filled here).
pub fn frame_transform_schema() -> String {
    let vector = |names: &[&str]| {
        let props: serde_json::Map<String, serde_json::Value> = names
            .iter()
            .map(|n| ((*n).to_owned(), json!({"type": "number"})))
            .collect();
        json!({"type": "object", "properties": props})
    };
    json!({
        "title": FRAME_TRANSFORM,
        "type": "object",
        "properties": {
            "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
            "parent_frame_id": {"type": "string"},
            "child_frame_id": {"type": "string"},
            "translation": vector(&["x", "y", "z"]),
            "rotation": vector(&["x", "y", "z", "w"]),
        }
    })
    .to_string()
}

/// The frame transform `level` → `child` at `time_ns` (ns, on whatever clock the caller
/// uses) for the attitude quaternion `q` = `[x, y, z, w]` that maps level-frame components to
/// body components (the estimator's convention); the body's pose in the level frame is its
/// conjugate.
///
/// Written field by field, keys in sorted order, numbers as serde_json writes them (shortest
/// round-trip; a non-finite component as `null`): the text a `serde_json::json!` object of the
/// same fields gives, without building one (building and printing it was most of the cost of
/// logging a truth sample or an estimate).
pub fn frame_transform_json(time_ns: u64, child: &str, q: &[f64; 4]) -> String {
    let mut out = Vec::with_capacity(256);
    out.extend_from_slice(b"{\"child_frame_id\":");
    // Serialising a string into a Vec<u8> cannot fail.
    let _ = serde_json::to_writer(&mut out, child);
    out.extend_from_slice(b",\"parent_frame_id\":\"level\",\"rotation\":{\"w\":");
    number(&mut out, q[3]);
    for (key, component) in [
        (&b",\"x\":"[..], q[0]),
        (b",\"y\":", q[1]),
        (b",\"z\":", q[2]),
    ] {
        out.extend_from_slice(key);
        number(&mut out, -component);
    }
    // Writing into a Vec<u8> cannot fail.
    let _ = write!(
        out,
        "}},\"timestamp\":{{\"nsec\":{},\"sec\":{}}},\"translation\":{{\"x\":0.0,\"y\":0.0,\"z\":0.0}}}}",
        time_ns % 1_000_000_000,
        time_ns / 1_000_000_000
    );
    // Only ASCII and serde_json's valid UTF-8 were written.
    String::from_utf8(out).unwrap_or_default()
}

/// `x` as a JSON number the way serde_json writes an `f64` value (`null` if not finite).
fn number(out: &mut Vec<u8>, x: f64) {
    if x.is_finite() {
        // Serialising a number into a Vec<u8> cannot fail.
        let _ = serde_json::to_writer(&mut *out, &x);
    } else {
        out.extend_from_slice(b"null");
    }
}

/// A record's derived transform: `(topic, child frame, quaternion [x, y, z, w])`.
pub type Transform = (&'static str, &'static str, [f64; 4]);

/// The derived transform of a record, if it has one. Invalid estimates (not converged or
/// reset) have none.
pub fn transform_of(record: &LogRecord) -> Option<Transform> {
    match record {
        LogRecord::AttitudeEstimate(e) if e.header.is_valid() => {
            Some((TF_ESTIMATE_TOPIC, "body", e.quaternion))
        }
        LogRecord::SimTruth(s) => Some((TF_TRUTH_TOPIC, "body_truth", s.quaternion)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `frame_transform_json` wrote before it was written field by field: the reference
    /// its text must equal.
    fn reference(time_ns: u64, child: &str, q: &[f64; 4]) -> String {
        json!({
            "timestamp": {"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000},
            "parent_frame_id": "level",
            "child_frame_id": child,
            "translation": {"x": 0.0, "y": 0.0, "z": 0.0},
            "rotation": {"x": -q[0], "y": -q[1], "z": -q[2], "w": q[3]},
        })
        .to_string()
    }

    #[test]
    fn the_transform_text_is_that_of_the_json_object_byte_for_byte() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let cases: [(u64, &str, [f64; 4]); 6] = [
            (0, "body", [0.0, 0.0, 0.0, 1.0]),
            (1_500_000_000, "body_truth", [0.0, 0.0, s, s]),
            (
                u64::MAX,
                "body",
                [-0.0, 1e-300, -1.2345678901234567e-5, 0.9999999999999999],
            ),
            (999_999_999, "a \"quoted\" frame", [0.1, 0.2, 0.3, 0.927]),
            (7, "body", [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1.0]),
            (
                1_795_824_824_447_349_051,
                "body",
                [0.035363, 0.050483, 0.171071, 0.983329],
            ),
        ];
        for (time_ns, child, q) in cases {
            assert_eq!(
                frame_transform_json(time_ns, child, &q),
                reference(time_ns, child, &q),
                "{time_ns} {child} {q:?}"
            );
        }
    }

    proptest::proptest! {
        #[test]
        fn any_transform_text_is_that_of_the_json_object(
            time_ns in proptest::prelude::any::<u64>(),
            q in proptest::prelude::any::<[f64; 4]>(),
        ) {
            proptest::prop_assert_eq!(
                frame_transform_json(time_ns, "body", &q),
                reference(time_ns, "body", &q)
            );
        }
    }

    #[test]
    fn the_transform_is_the_bodys_pose_in_the_level_frame() {
        // 90° about z: q (level → body components) = [0, 0, sin 45°, cos 45°]; the body's pose
        // in the level frame is the opposite rotation.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let text = frame_transform_json(1_500_000_000, "body", &[0.0, 0.0, s, s]);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["timestamp"]["sec"], 1);
        assert_eq!(v["timestamp"]["nsec"], 500_000_000);
        assert_eq!(v["parent_frame_id"], "level");
        assert_eq!(v["child_frame_id"], "body");
        assert_eq!(v["rotation"]["z"].as_f64(), Some(-s));
        assert_eq!(v["rotation"]["w"].as_f64(), Some(s));
    }
}
