//! The platform's shape as a `foxglove.SceneUpdate`, so Foxglove's 3D panel draws the test bed
//! moving with its attitude: one entity, locked to a frame (`body`), made of cylinders, cubes,
//! spheres and arrows.
//!
//! The shape is plain data ([`Scene`]); what it is made of (the platform's size, where the
//! actuators sit) is decided by the caller from the run's configuration.

use serde_json::{Value, json};

/// Topic of the platform's scene.
pub const SCENE_TOPIC: &str = "testbed/scene";
/// Schema name of a scene update.
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// Run time between two scene messages, ns: a viewer that seeks finds the scene within it.
pub const SCENE_PERIOD_NS: u64 = 1_000_000_000;

/// Foxglove's JSON Schema of `foxglove.SceneUpdate` (foxglove/schemas, MIT).
pub fn scene_update_schema() -> &'static str {
    include_str!("schemas/SceneUpdate.json")
}

/// An RGBA colour, each component 0 to 1.
pub type Rgba = [f64; 4];

/// A pose in the entity's frame: position, m, and orientation quaternion `[x, y, z, w]`
/// (rotating the primitive's own axes onto the frame's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub position_m: [f64; 3],
    pub orientation: [f64; 4],
}

impl Pose {
    /// At `position_m`, not rotated.
    pub fn at(position_m: [f64; 3]) -> Self {
        Self {
            position_m,
            orientation: [0.0, 0.0, 0.0, 1.0],
        }
    }
}

/// One drawn part.
#[derive(Debug, Clone, PartialEq)]
pub enum Primitive {
    /// A cylinder along its own z axis: diameter and length, m.
    Cylinder {
        pose: Pose,
        diameter_m: f64,
        length_m: f64,
        color: Rgba,
    },
    /// A box of the given edge lengths along its own axes, m.
    Cube {
        pose: Pose,
        size_m: [f64; 3],
        color: Rgba,
    },
    /// A sphere of the given diameter, m.
    Sphere {
        pose: Pose,
        diameter_m: f64,
        color: Rgba,
    },
    /// An arrow along its own x axis, of total length `length_m`, m.
    Arrow {
        pose: Pose,
        length_m: f64,
        color: Rgba,
    },
}

/// The platform's shape: the parts of one entity locked to `frame_id`.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The frame the parts are drawn in (e.g. `body`: they move with the estimated attitude).
    pub frame_id: String,
    /// The entity's id (a later message with the same id replaces it).
    pub id: String,
    pub parts: Vec<Primitive>,
}

impl Scene {
    /// The `foxglove.SceneUpdate` that draws the scene at `time_ns` (ns since the Unix epoch),
    /// until replaced (zero lifetime).
    pub fn update_json(&self, time_ns: u64) -> String {
        let timestamp = json!({"sec": time_ns / 1_000_000_000, "nsec": time_ns % 1_000_000_000});
        let mut cylinders = Vec::new();
        let mut cubes = Vec::new();
        let mut spheres = Vec::new();
        let mut arrows = Vec::new();
        for part in &self.parts {
            match part {
                Primitive::Cylinder {
                    pose,
                    diameter_m,
                    length_m,
                    color,
                } => cylinders.push(json!({
                    "pose": pose_json(pose),
                    "size": vector(&[*diameter_m, *diameter_m, *length_m]),
                    "bottom_scale": 1.0,
                    "top_scale": 1.0,
                    "color": color_json(color),
                })),
                Primitive::Cube {
                    pose,
                    size_m,
                    color,
                } => cubes.push(json!({
                    "pose": pose_json(pose),
                    "size": vector(size_m),
                    "color": color_json(color),
                })),
                Primitive::Sphere {
                    pose,
                    diameter_m,
                    color,
                } => spheres.push(json!({
                    "pose": pose_json(pose),
                    "size": vector(&[*diameter_m; 3]),
                    "color": color_json(color),
                })),
                Primitive::Arrow {
                    pose,
                    length_m,
                    color,
                } => arrows.push(json!({
                    "pose": pose_json(pose),
                    "shaft_length": 0.7 * length_m,
                    "shaft_diameter": 0.1 * length_m,
                    "head_length": 0.3 * length_m,
                    "head_diameter": 0.25 * length_m,
                    "color": color_json(color),
                })),
            }
        }
        json!({
            "deletions": [],
            "entities": [{
                "timestamp": timestamp,
                "frame_id": self.frame_id,
                "id": self.id,
                "lifetime": {"sec": 0, "nsec": 0},
                "frame_locked": true,
                "metadata": [],
                "arrows": arrows,
                "cubes": cubes,
                "spheres": spheres,
                "cylinders": cylinders,
                "lines": [],
                "triangles": [],
                "texts": [],
                "models": [],
            }],
        })
        .to_string()
    }
}

fn vector(v: &[f64; 3]) -> Value {
    json!({"x": v[0], "y": v[1], "z": v[2]})
}

fn pose_json(pose: &Pose) -> Value {
    let q = pose.orientation;
    json!({
        "position": vector(&pose.position_m),
        "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
    })
}

fn color_json(c: &Rgba) -> Value {
    json!({"r": c[0], "g": c[1], "b": c[2], "a": c[3]})
}

#[cfg(test)]
mod tests {
    use super::*;

    fn schema_properties(schema: &Value, path: &[&str]) -> Vec<String> {
        let mut node = schema;
        for key in path {
            node = &node["properties"][key];
            if node["type"] == "array" {
                node = &node["items"];
            }
        }
        let mut keys: Vec<String> = node["properties"]
            .as_object()
            .map(|o| o.keys().cloned().collect())
            .unwrap_or_default();
        keys.sort();
        keys
    }

    fn keys(v: &Value) -> Vec<String> {
        let mut keys: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        keys.sort();
        keys
    }

    /// Every field Foxglove's schema defines is written, and nothing else, for the entity
    /// and each kind of primitive.
    #[test]
    fn the_update_has_every_field_of_foxgloves_schema() {
        let pose = Pose::at([0.1, -0.2, 0.3]);
        let color = [0.5, 0.5, 0.5, 1.0];
        let scene = Scene {
            frame_id: "body".into(),
            id: "platform".into(),
            parts: vec![
                Primitive::Cylinder {
                    pose,
                    diameter_m: 1.2,
                    length_m: 0.03,
                    color,
                },
                Primitive::Cube {
                    pose,
                    size_m: [0.1, 0.2, 0.3],
                    color,
                },
                Primitive::Sphere {
                    pose,
                    diameter_m: 0.1,
                    color,
                },
                Primitive::Arrow {
                    pose,
                    length_m: 0.2,
                    color,
                },
            ],
        };
        let update: Value = serde_json::from_str(&scene.update_json(1_500_000_000)).unwrap();
        let schema: Value = serde_json::from_str(scene_update_schema()).unwrap();
        assert_eq!(keys(&update), schema_properties(&schema, &[]));
        let entity = &update["entities"][0];
        assert_eq!(keys(entity), schema_properties(&schema, &["entities"]));
        assert_eq!(entity["timestamp"], json!({"sec": 1, "nsec": 500_000_000}));
        assert_eq!(entity["frame_locked"], true);
        for kind in ["cylinders", "cubes", "spheres", "arrows"] {
            let parts = entity[kind].as_array().unwrap();
            assert_eq!(parts.len(), 1, "{kind}");
            assert_eq!(
                keys(&parts[0]),
                schema_properties(&schema, &["entities", kind]),
                "{kind}"
            );
            assert_eq!(parts[0]["pose"]["position"]["y"], -0.2, "{kind}");
        }
        assert_eq!(
            entity["cylinders"][0]["size"],
            json!({"x": 1.2, "y": 1.2, "z": 0.03})
        );
    }
}
