//! Sessions: repeated runs of the same, unchanged bench.
//!
//! A rig file's `[sim] session = N` (default 0) says which session of the bench a run is. Two
//! sessions of one bench film and measure the same unit: the sensor build (its residual
//! birefringence, LED ring, surface), the bench's surface and the F/T transducer's power-up bias at
//! power cycle 0 stay. What differs between sessions on a real bench differs here too: the
//! camera's noise and the phase of its gain and offset drift (the renderer), the F/T noise and its
//! random-walk drift, camera drops, timing jitter and latch delays, DAQ arrival jitter and the
//! stage controllers' update jitter.
//!
//! Each of those draws its seed through [`salted`]: session 0 leaves the seed as it is, so a rig
//! file without `session` gives exactly the bytes and numbers it gave before sessions existed.

use fringe_rig::seeded::mix;

/// Stream number that keeps session-salted seeds apart from the other streams of a seed.
const SESSION_STREAM: u64 = 0x5E55_1015;

/// `seed` for session `session`: `seed` itself for session 0, else an independent seed.
pub(crate) fn salted(seed: u64, session: u64) -> u64 {
    if session == 0 {
        seed
    } else {
        mix(mix(seed, SESSION_STREAM), session)
    }
}

/// Frames by which session `session` shifts the renderer's slow gain and offset drift: 0 for
/// session 0, else up to a million frames (the drift's periods are 300-6000 frames, so another
/// session sees the drift at an unrelated phase).
pub(crate) fn drift_frames(session: u64) -> u64 {
    if session == 0 {
        0
    } else {
        mix(session, SESSION_STREAM ^ 0xD71F) % 1_000_000
    }
}

#[cfg(test)]
mod tests;
