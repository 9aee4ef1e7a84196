//! Platform physics (to be written).
