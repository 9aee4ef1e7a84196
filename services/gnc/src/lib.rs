//! GNC (to be written).
