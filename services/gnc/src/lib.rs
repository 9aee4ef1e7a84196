//! GNC (to be written).
pub mod control;
pub mod cmg_steering;
pub mod mekf;
