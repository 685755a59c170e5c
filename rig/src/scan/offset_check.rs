//! The zero-load check a scan makes when it measures the F/T offset at the safe height: the
//! sensor's calibration profile knows the offset it had, and one that moved beyond tolerance
//! since (a power cycle, a knock, a loose mount) is reported. The check itself belongs to the
//! profile (`fringe-calibration`); the engine only calls it.

/// Checks a no-contact offset.
pub trait OffsetCheck: Send + Sync + std::fmt::Debug {
    /// Warnings for the no-contact offset `mean` (Fx Fy Fz in N, Tx Ty Tz in N m) with its
    /// standard errors; empty when it agrees.
    fn check(&self, mean: [f64; 6], standard_error: [f64; 6]) -> Vec<String>;
}
