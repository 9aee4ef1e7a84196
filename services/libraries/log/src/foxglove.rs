//! Foxglove's well-known schemas for what viewers draw natively, in the run log and on the
//! ground link (JSON encoding, Foxglove's own JSON Schemas): the platform's attitude as
//! `foxglove.FrameTransform` and `foxglove.PoseInFrame`, its shape as `foxglove.SceneUpdate`
//! ([`scene`]), the run's events as `foxglove.Log` ([`events`]).
//!
//! Frames: `level` is the estimator's local-level frame L, `body` the platform body frame as
//! estimated,
//! `body_truth` the simulated true body frame. A transform gives the child frame's pose in the
//! parent frame; the air bearing is the origin of both, so the translation is zero.

use crate::record::LogRecord;
use std::io::Write as _;

pub mod events;
pub mod scene;

/// Schema name of a pose in a frame.
pub const POSE_IN_FRAME: &str = "foxglove.PoseInFrame";

/// Foxglove's JSON Schema of `foxglove.PoseInFrame` (foxglove/schemas, MIT).
pub fn pose_in_frame_schema() -> &'static str {
    include_str!("foxglove/schemas/PoseInFrame.json")
}

/// The body's pose in the `level` frame at `time_ns` as `foxglove.PoseInFrame`, for the
/// attitude quaternion `q` = `[x, y, z, w]` (level-frame components to body components, the
/// estimator's convention; the pose is its conjugate, as in [`frame_transform_json`]).
pub fn pose_in_frame_json(time_ns: u64, q: &[f64; 4]) -> String {
    let mut out = Vec::with_capacity(192);
    out.extend_from_slice(b"{\"frame_id\":\"level\",\"pose\":{\"orientation\":");
    conjugate(&mut out, q);
    out.extend_from_slice(b",\"position\":{\"x\":0.0,\"y\":0.0,\"z\":0.0}},\"timestamp\":");
    timestamp(&mut out, time_ns);
    out.push(b'}');
    // Only ASCII and serde_json's valid UTF-8 were written.
    String::from_utf8(out).unwrap_or_default()
}

/// Schema name of a frame transform.
pub const FRAME_TRANSFORM: &str = "foxglove.FrameTransform";
/// Topic of the estimated attitude as a frame transform (`level` → `body`).
pub const TF_ESTIMATE_TOPIC: &str = "testbed/tf/estimate";
/// Topic of the simulated true attitude as a frame transform (`level` → `body_truth`).
pub const TF_TRUTH_TOPIC: &str = "testbed/tf/truth";
/// Topic of the estimated attitude as the body's pose in the level frame.
pub const POSE_ESTIMATE_TOPIC: &str = "testbed/pose/estimate";
/// Topics the log derives from the samples (not ipc-types topics; readers of samples skip
/// them), in channel order ([`derived_channel_id`](crate::derived_channel_id)).
pub const DERIVED_TOPICS: &[&str] = &[
    TF_ESTIMATE_TOPIC,
    TF_TRUTH_TOPIC,
    POSE_ESTIMATE_TOPIC,
    events::EVENTS_TOPIC,
    scene::SCENE_TOPIC,
];

/// The schema name and JSON Schema of each of [`DERIVED_TOPICS`], in its order.
pub fn derived_schemas() -> [(&'static str, &'static str); 5] {
    [
        (FRAME_TRANSFORM, frame_transform_schema()),
        (FRAME_TRANSFORM, frame_transform_schema()),
        (POSE_IN_FRAME, pose_in_frame_schema()),
        (events::LOG, events::log_schema()),
        (scene::SCENE_UPDATE, scene::scene_update_schema()),
    ]
}

/// What a record gives Foxglove's panels besides its own message, taken when it is encoded
/// (never decoded back from its text).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Derived {
    #[default]
    Nothing,
    /// An attitude: its frame transform (and, for the estimate, its pose).
    Transform(Transform),
    /// An event for the Log panel.
    Event(events::Event),
    /// The controller's mode: an event when it changes ([`events::ModeChanges`]).
    Mode(u32),
}

/// What `record` derives ([`Derived`]).
pub fn derived_of(record: &LogRecord) -> Derived {
    if let Some(t) = transform_of(record) {
        return Derived::Transform(t);
    }
    match record {
        LogRecord::ControllerStatus(s) => Derived::Mode(s.mode),
        _ => events::event_of(record).map_or(Derived::Nothing, Derived::Event),
    }
}

/// Foxglove's JSON Schema of `foxglove.FrameTransform` (foxglove/schemas, MIT).
pub fn frame_transform_schema() -> &'static str {
    include_str!("foxglove/schemas/FrameTransform.json")
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
    out.extend_from_slice(b",\"parent_frame_id\":\"level\",\"rotation\":");
    conjugate(&mut out, q);
    out.extend_from_slice(b",\"timestamp\":");
    timestamp(&mut out, time_ns);
    out.extend_from_slice(b",\"translation\":{\"x\":0.0,\"y\":0.0,\"z\":0.0}}");
    // Only ASCII and serde_json's valid UTF-8 were written.
    String::from_utf8(out).unwrap_or_default()
}

/// The conjugate of `q` = `[x, y, z, w]` as a JSON object, keys sorted.
fn conjugate(out: &mut Vec<u8>, q: &[f64; 4]) {
    out.extend_from_slice(b"{\"w\":");
    number(out, q[3]);
    for (key, component) in [
        (&b",\"x\":"[..], q[0]),
        (b",\"y\":", q[1]),
        (b",\"z\":", q[2]),
    ] {
        out.extend_from_slice(key);
        number(out, -component);
    }
    out.push(b'}');
}

/// `time_ns` as a Foxglove time object, keys sorted.
fn timestamp(out: &mut Vec<u8>, time_ns: u64) {
    // Writing into a Vec<u8> cannot fail.
    let _ = write!(
        out,
        "{{\"nsec\":{},\"sec\":{}}}",
        time_ns % 1_000_000_000,
        time_ns / 1_000_000_000
    );
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
    use serde_json::json;

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

    proptest::proptest! {
        #[test]
        fn any_pose_text_is_that_of_the_json_object(
            time_ns in proptest::prelude::any::<u64>(),
            q in proptest::prelude::any::<[f64; 4]>(),
        ) {
            let reference = json!({
                "timestamp": {"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000},
                "frame_id": "level",
                "pose": {
                    "position": {"x": 0.0, "y": 0.0, "z": 0.0},
                    "orientation": {"x": -q[0], "y": -q[1], "z": -q[2], "w": q[3]},
                },
            })
            .to_string();
            proptest::prop_assert_eq!(pose_in_frame_json(time_ns, &q), reference);
        }
    }

    #[test]
    fn the_pose_has_the_fields_of_foxgloves_schema() {
        let pose: serde_json::Value =
            serde_json::from_str(&pose_in_frame_json(3, &[0.0, 0.0, 0.0, 1.0])).unwrap();
        let schema: serde_json::Value = serde_json::from_str(pose_in_frame_schema()).unwrap();
        let keys = |v: &serde_json::Value| {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        assert_eq!(keys(&pose), keys(&schema["properties"]));
        assert_eq!(
            keys(&pose["pose"]),
            keys(&schema["properties"]["pose"]["properties"])
        );
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
