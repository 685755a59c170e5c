//! A unit's health as its no-contact frames show it: the optical fit (centre, radius, crop
//! radius), the brightness of the disc, the light around its rim (where the LED ring's hot spots
//! lie), the light of each side of the disc, and a coarse image of the disc for changes of its
//! surface ([`signature`]); and what changed between two such signatures ([`change`]), the one
//! taken when the unit was accepted and the one of a check.
//!
//! Pure measurement: no thresholds and no verdicts (the health check that uses these figures sets
//! them from measured noise).

pub(crate) mod change;
pub(crate) mod signature;

pub use change::{Change, ChangeError, RIM_SECTOR_DEG};
pub use signature::{Signature, SignatureError, CELLS, INNER, RIM_BINS, SIDES};
