//! Foxglove's well-known schemas for what viewers draw natively: the platform's attitude as
//! `foxglove.FrameTransform` (JSON encoding), in the run log and on the ground link.
//!
//! Frames: `level` is the estimator's local-level frame L, `body` the platform body frame as
//! estimated,
//! `body_truth` the simulated true body frame. A transform gives the child frame's pose in the
//! parent frame; the air bearing is the origin of both, so the translation is zero.

use crate::record::{LogRecord, TopicKind};
use serde_json::json;

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
pub fn frame_transform_json(time_ns: u64, child: &str, q: &[f64; 4]) -> String {
    json!({
        "timestamp": {"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000},
        "parent_frame_id": "level",
        "child_frame_id": child,
        "translation": {"x": 0.0, "y": 0.0, "z": 0.0},
        "rotation": {"x": -q[0], "y": -q[1], "z": -q[2], "w": q[3]},
    })
    .to_string()
}

/// The derived transform of a record, if it has one: `(topic, child frame, quaternion)`.
/// Invalid estimates (not converged or reset) have none.
pub fn transform_of(record: &LogRecord) -> Option<(&'static str, &'static str, [f64; 4])> {
    match record {
        LogRecord::AttitudeEstimate(e) if e.header.is_valid() => {
            Some((TF_ESTIMATE_TOPIC, "body", e.quaternion))
        }
        LogRecord::SimTruth(s) => Some((TF_TRUTH_TOPIC, "body_truth", s.quaternion)),
        _ => None,
    }
}

/// Whether records of `kind` can have a derived transform.
pub(crate) fn has_transform(kind: TopicKind) -> bool {
    matches!(kind, TopicKind::AttitudeEstimate | TopicKind::SimTruth)
}

#[cfg(test)]
mod tests {
    use super::*;

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
