//! The platform as Foxglove's 3D panel draws it (the run log's and the ground link's
//! `testbed/scene`), from the run's model configuration.
//!
//! The paper's platform is "a cylinder with two plates". Its size is the uniform cylinder of
//! the configured mass and inertia (**derived**: `I_zz = m r²/2`, `I_xx ≈ I_yy = m (3r² + h²)/12`).
//! The wheels sit on the upper plate along body X, Y and Z; the four CMGs on the lower plate at
//! the pyramid's azimuths, along their gimbal axes (the configured skew); the thrusters at
//! their configured positions, pointing along their thrust. Where on a plate a device sits
//! is a drawing choice, not a parameter of any model; the air bearing is the sphere at the
//! body origin.

use nalgebra::{Unit, UnitQuaternion, Vector3};
use testbed_log::foxglove::scene::{Pose, Primitive, Rgba, Scene};
use testbed_model::config::ModelConfig;
use testbed_model::physics::cmg_pyramid::CmgPyramid;

const PLATE_THICKNESS_M: f64 = 0.03;
/// The shortest platform drawn, m (an inertia that gives a flatter cylinder is drawn this tall).
const MIN_HEIGHT_M: f64 = 0.1;
const STRUCTURE: Rgba = [0.62, 0.64, 0.68, 0.35];
const PLATE: Rgba = [0.55, 0.57, 0.6, 1.0];
const BEARING: Rgba = [0.9, 0.55, 0.15, 1.0];
const WHEEL: Rgba = [0.2, 0.45, 0.85, 1.0];
const CMG: Rgba = [0.25, 0.7, 0.35, 1.0];
const THRUSTER: Rgba = [0.85, 0.25, 0.2, 1.0];

/// Radius and height of the uniform cylinder with `model`'s mass and inertia, m.
pub fn cylinder_size_m(model: &ModelConfig) -> (f64, f64) {
    let m = model.platform.mass_kg;
    let inertia = model.platform.inertia_kgm2;
    let radius = (2.0 * inertia[2][2] / m).sqrt();
    let transverse = 0.5 * (inertia[0][0] + inertia[1][1]);
    let height_sq = 12.0 * transverse / m - 3.0 * radius * radius;
    (radius, height_sq.max(MIN_HEIGHT_M * MIN_HEIGHT_M).sqrt())
}

/// The rotation taking the primitive's own `from` axis onto `to`, as `[x, y, z, w]`.
fn along(from: &Vector3<f64>, to: &Vector3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::rotation_between(from, to).unwrap_or_else(|| {
        // Opposite vectors: half a turn about an axis normal to them.
        let normal = from
            .cross(&Vector3::x())
            .try_normalize(1e-9)
            .unwrap_or_else(|| from.cross(&Vector3::y()).normalize());
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(normal), std::f64::consts::PI)
    });
    [q.i, q.j, q.k, q.w]
}

/// The platform's scene in frame `frame_id` (e.g. `body`, the estimated attitude).
pub fn platform_scene(model: &ModelConfig, frame_id: &str) -> Scene {
    let (radius, height) = cylinder_size_m(model);
    let top = 0.5 * height;
    let mut parts = vec![
        Primitive::Cylinder {
            pose: Pose::at([0.0, 0.0, 0.0]),
            diameter_m: 2.0 * radius,
            length_m: height,
            color: STRUCTURE,
        },
        Primitive::Sphere {
            pose: Pose::at([0.0, 0.0, 0.0]),
            diameter_m: 0.15 * radius,
            color: BEARING,
        },
    ];
    for z in [top, -top] {
        parts.push(Primitive::Cylinder {
            pose: Pose::at([0.0, 0.0, z]),
            diameter_m: 2.2 * radius,
            length_m: PLATE_THICKNESS_M,
            color: PLATE,
        });
    }
    let wheel_size = 0.3 * radius;
    let on_top = top + PLATE_THICKNESS_M + 0.5 * wheel_size;
    for (axis, spot) in [
        (Vector3::x(), [0.5, 0.0]),
        (Vector3::y(), [0.0, 0.5]),
        (Vector3::z(), [-0.45, -0.45]),
    ] {
        parts.push(Primitive::Cylinder {
            pose: Pose {
                position_m: [spot[0] * radius, spot[1] * radius, on_top],
                orientation: along(&Vector3::z(), &axis),
            },
            diameter_m: wheel_size,
            length_m: 0.3 * wheel_size,
            color: WHEEL,
        });
    }
    let pyramid = CmgPyramid::from_config(&model.cmg);
    let cmg_size = 0.2 * radius;
    for i in 0..4 {
        let axis = pyramid.gimbal_axis(i);
        let horizontal = Vector3::new(axis.x, axis.y, 0.0)
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::x);
        let spot = 0.6 * radius * horizontal;
        parts.push(Primitive::Cube {
            pose: Pose {
                position_m: [spot.x, spot.y, -top - PLATE_THICKNESS_M - 0.5 * cmg_size],
                orientation: along(&Vector3::z(), &axis),
            },
            size_m: [cmg_size; 3],
            color: CMG,
        });
    }
    if let Some(thrusters) = &model.thrusters {
        for (position, direction) in thrusters.position_m.iter().zip(&thrusters.direction) {
            parts.push(Primitive::Arrow {
                pose: Pose {
                    position_m: *position,
                    orientation: along(&Vector3::x(), &Vector3::from(*direction)),
                },
                length_m: 0.25 * radius,
                color: THRUSTER,
            });
        }
    }
    Scene {
        frame_id: frame_id.to_owned(),
        id: "platform".into(),
        parts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cylinder_has_the_configured_mass_and_inertia() {
        let model = ModelConfig::default();
        let (r, h) = cylinder_size_m(&model);
        let m = model.platform.mass_kg;
        let i = model.platform.inertia_kgm2;
        assert!((m * r * r / 2.0 - i[2][2]).abs() < 1e-9);
        let transverse = m * (3.0 * r * r + h * h) / 12.0;
        assert!((transverse - 0.5 * (i[0][0] + i[1][1])).abs() < 1e-9);
        // The digest's platform: about 1.2 m across and 0.7 m tall.
        assert!(
            (1.1..1.3).contains(&(2.0 * r)) && (0.6..0.8).contains(&h),
            "{r} {h}"
        );
    }

    #[test]
    fn each_part_points_along_its_axis() {
        for (from, to) in [
            (Vector3::z(), Vector3::x()),
            (Vector3::z(), Vector3::new(0.3, -0.5, 0.8).normalize()),
            (Vector3::x(), -Vector3::x()),
            (Vector3::z(), Vector3::z()),
        ] {
            let [x, y, z, w] = along(&from, &to);
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            assert!((q * from - to).norm() < 1e-12, "{from:?} → {to:?}");
        }
    }

    #[test]
    fn the_scene_has_the_structure_and_every_device() {
        let mut model = ModelConfig::default();
        let scene = platform_scene(&model, "body");
        let count = |f: fn(&Primitive) -> bool| scene.parts.iter().filter(|p| f(p)).count();
        // Structure and two plates, three wheels.
        assert_eq!(count(|p| matches!(p, Primitive::Cylinder { .. })), 6);
        assert_eq!(count(|p| matches!(p, Primitive::Cube { .. })), 4);
        assert_eq!(count(|p| matches!(p, Primitive::Arrow { .. })), 0);
        model.thrusters = Some(Default::default());
        let scene = platform_scene(&model, "body");
        assert_eq!(
            scene
                .parts
                .iter()
                .filter(|p| matches!(p, Primitive::Arrow { .. }))
                .count(),
            6
        );
    }
}
