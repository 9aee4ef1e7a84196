//! Friction identification (to be written).
