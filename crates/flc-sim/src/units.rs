//! Unit conversions at the interface. Everything inside is SI; km/h appears only in keys and
//! arguments whose name says so (`speed_kmh`).

/// km/h -> m/s. Only used where the user interface speaks km/h (keys ending in `_kmh`).
pub const KMH: f64 = 1.0 / 3.6;
