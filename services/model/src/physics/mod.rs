//! Platform physics (rigid body on the air bearing, wheels, CMGs, effects).

pub mod cmg_pyramid;

pub use cmg_pyramid::CmgPyramid;
