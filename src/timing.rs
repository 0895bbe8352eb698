//! Wall-clock laps for the `timings_s` of `stage.json` (where a stage's time goes).

use std::time::Instant;

/// Seconds since `clock`, which is set to now.
pub fn lap(clock: &mut Instant) -> f64 {
    let now = Instant::now();
    let seconds = (now - *clock).as_secs_f64();
    *clock = now;
    seconds
}
