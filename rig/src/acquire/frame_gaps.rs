//! Frames lost by a camera, counted from the gaps in its frame ids. A frame that arrives late
//! (after a newer one) fills the gap it was counted in: frames out of order are not drops.

/// Counts the frames missing from a stream of frame ids.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameGaps {
    newest: Option<u64>,
    dropped: u64,
    late: u64,
}

impl FrameGaps {
    /// Takes the id of the frame that just arrived.
    pub fn observe(&mut self, id: u64) {
        match self.newest {
            None => self.newest = Some(id),
            Some(newest) if id > newest => {
                self.dropped += id - newest - 1;
                self.newest = Some(id);
            }
            Some(newest) if id < newest => {
                // Counted as dropped when the newer frame overtook it.
                self.dropped = self.dropped.saturating_sub(1);
                self.late += 1;
            }
            Some(_) => {}
        }
    }

    /// Frames missing so far (ids skipped and not delivered late).
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Frames that arrived after a newer one.
    pub fn late(&self) -> u64 {
        self.late
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(ids: &[u64]) -> FrameGaps {
        let mut g = FrameGaps::default();
        for &id in ids {
            g.observe(id);
        }
        g
    }

    #[test]
    fn gaps_are_drops_and_late_frames_fill_them() {
        assert_eq!(count(&[0, 1, 2, 3]).dropped(), 0);
        assert_eq!(count(&[5, 6, 9, 10]).dropped(), 2);
        let swapped = count(&[0, 2, 1, 4, 3, 5]);
        assert_eq!((swapped.dropped(), swapped.late()), (0, 2));
        let lost_then_late = count(&[0, 3, 1, 4]);
        assert_eq!((lost_then_late.dropped(), lost_then_late.late()), (1, 1));
        assert_eq!(count(&[7, 7, 8]).dropped(), 0);
    }
}
