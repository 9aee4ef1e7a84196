//! Device models (to be written).
